// The lecture's sphere methods in single precision (LectureKernel.h).
#include "durer/render/LectureKernel.h"

namespace durer {
template RenderStats renderLecture<float>(const RenderJob&, SphereMethod);
template CastStats castLecture<float>(const CastJob<float>&, SphereMethod);
}  // namespace durer
