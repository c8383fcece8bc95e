#include "durer/render/Kernels.h"

namespace durer {

#if defined(DURER_KERNELS_X86)
DURER_DECLARE_KERNEL_SET(x86_64_v2)
DURER_DECLARE_KERNEL_SET(x86_64_v3)
DURER_DECLARE_KERNEL_SET(x86_64_v4)

const KernelSet& kernels() {
  static const KernelSet v2{"x86-64-v2", x86_64_v2::renderFloat, x86_64_v2::renderDouble, x86_64_v2::castFloat,
                            x86_64_v2::castDouble};
  static const KernelSet v3{"x86-64-v3", x86_64_v3::renderFloat, x86_64_v3::renderDouble, x86_64_v3::castFloat,
                            x86_64_v3::castDouble};
  static const KernelSet v4{"x86-64-v4", x86_64_v4::renderFloat, x86_64_v4::renderDouble, x86_64_v4::castFloat,
                            x86_64_v4::castDouble};
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
  static const KernelSet set{DURER_KERNEL_SET_NAME, DURER_KERNEL_SET::renderFloat, DURER_KERNEL_SET::renderDouble,
                             DURER_KERNEL_SET::castFloat, DURER_KERNEL_SET::castDouble};
  return set;
}
#endif

}  // namespace durer
