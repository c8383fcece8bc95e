#include "durer/render/Kernels.h"

namespace durer {

#if defined(DURER_KERNELS_X86)
DURER_DECLARE_KERNEL_SET(x86_64_v2)
DURER_DECLARE_KERNEL_SET(x86_64_v3)
DURER_DECLARE_KERNEL_SET(x86_64_v4)

const KernelSet& kernels() {
  static const KernelSet v2{"x86-64-v2", DURER_KERNEL_SET_ENTRIES(x86_64_v2)};
  static const KernelSet v3{"x86-64-v3", DURER_KERNEL_SET_ENTRIES(x86_64_v3)};
  static const KernelSet v4{"x86-64-v4", DURER_KERNEL_SET_ENTRIES(x86_64_v4)};
  // The kernels are compiled without contraction (-ffp-contract=off), so every set computes
  // bit-identical images.
  static const KernelSet& best = []() -> const KernelSet& {
    __builtin_cpu_init();
    if (__builtin_cpu_supports("x86-64-v4")) return v4;
    return __builtin_cpu_supports("x86-64-v3") ? v3 : v2;
  }();
  return best;
}
#else
DURER_DECLARE_KERNEL_SET(DURER_KERNEL_SET)

const KernelSet& kernels() {
  static const KernelSet set{DURER_KERNEL_SET_NAME, DURER_KERNEL_SET_ENTRIES(DURER_KERNEL_SET)};
  return set;
}
#endif

}  // namespace durer
