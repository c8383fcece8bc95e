// The robust render kernel in double precision, compiled once per instruction set (DURER_ISA).
#include "durer/render/RenderKernel.h"

namespace durer {
DURER_DECLARE_KERNEL_SET(DURER_ISA)
RenderStats DURER_ISA::renderDouble(const RenderJob& job) { return renderWith<double, SphereMethod::Robust>(job); }
}  // namespace durer
