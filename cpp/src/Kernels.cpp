#include "durer/render/Kernels.h"

namespace durer {

#if defined(DURER_KERNELS_X86)
DURER_DECLARE_KERNEL_SET(x86_64_v2)
DURER_DECLARE_KERNEL_SET(x86_64_v3)
DURER_DECLARE_KERNEL_SET(x86_64_v4)

namespace {
const KernelSet kV2{"x86-64-v2", DURER_KERNEL_SET_ENTRIES(x86_64_v2)};
const KernelSet kV3{"x86-64-v3", DURER_KERNEL_SET_ENTRIES(x86_64_v3)};
const KernelSet kV4{"x86-64-v4", DURER_KERNEL_SET_ENTRIES(x86_64_v4)};
}  // namespace

const KernelSet& kernels() {
  // The kernels are compiled without contraction (-ffp-contract=off), so every set computes
  // bit-identical images.
  static const KernelSet& best = []() -> const KernelSet& {
    __builtin_cpu_init();
    if (__builtin_cpu_supports("x86-64-v4")) return kV4;
    return __builtin_cpu_supports("x86-64-v3") ? kV3 : kV2;
  }();
  return best;
}

const KernelSet& kernelsFor(SphereMethod method) { return method == SphereMethod::Robust ? kernels() : kV2; }
#else
DURER_DECLARE_KERNEL_SET(DURER_KERNEL_SET)

const KernelSet& kernels() {
  static const KernelSet set{DURER_KERNEL_SET_NAME, DURER_KERNEL_SET_ENTRIES(DURER_KERNEL_SET)};
  return set;
}

const KernelSet& kernelsFor(SphereMethod) { return kernels(); }
#endif

}  // namespace durer
