// The lecture's sphere methods in double precision (LectureKernel.h).
#include "durer/render/LectureKernel.h"

namespace durer {
template RenderStats renderLecture<double>(const RenderJob&, SphereMethod);
template CastStats castLecture<double>(const CastJob<double>&, SphereMethod);
}  // namespace durer
