// The robust render kernel in single precision, compiled once per instruction set (DURER_ISA).
#include "durer/render/RenderKernel.h"

namespace durer {
DURER_DECLARE_KERNEL_SET(DURER_ISA)
RenderStats DURER_ISA::renderFloat(const RenderJob& job) { return renderWith<float, SphereMethod::Robust>(job); }
}  // namespace durer
