// The kernels in double precision, compiled once per instruction set (DURER_ISA), the render
// and the cast in one translation unit (KernelsFloat.cpp says why).
#include "durer/render/CastKernel.h"
#include "durer/render/RenderKernel.h"

namespace durer {
DURER_DECLARE_KERNEL_SET(DURER_ISA)
RenderStats DURER_ISA::renderDouble(const RenderJob& job) { return renderWith<double, KernelMethods>(job); }
CastStats DURER_ISA::castDouble(const CastJob<double>& job) { return castWith<double, KernelMethods>(job); }
}  // namespace durer
