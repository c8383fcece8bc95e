// The robust cast kernels, compiled once per instruction set (DURER_ISA).
#include "durer/render/CastKernel.h"

namespace durer {
DURER_DECLARE_KERNEL_SET(DURER_ISA)
CastStats DURER_ISA::castFloat(const CastJob<float>& job) { return castWith<float, SphereMethod::Robust>(job); }
CastStats DURER_ISA::castDouble(const CastJob<double>& job) { return castWith<double, SphereMethod::Robust>(job); }
}  // namespace durer
