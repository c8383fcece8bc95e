// The lecture's sphere methods (algebraic, geometric) for both precisions, compiled once for the
// baseline instruction set: they are there to compare accuracy, not to be fast.
#include "durer/render/CastKernel.h"
#include "durer/render/RenderKernel.h"

namespace durer {

template <typename Real>
RenderStats renderLecture(const RenderJob& job, SphereMethod method) {
  return method == SphereMethod::Algebraic ? renderWith<Real, SphereMethod::Algebraic>(job)
                                           : renderWith<Real, SphereMethod::Geometric>(job);
}

template <typename Real>
CastStats castLecture(const CastJob<Real>& job, SphereMethod method) {
  return method == SphereMethod::Algebraic ? castWith<Real, SphereMethod::Algebraic>(job)
                                           : castWith<Real, SphereMethod::Geometric>(job);
}

template RenderStats renderLecture<float>(const RenderJob&, SphereMethod);
template RenderStats renderLecture<double>(const RenderJob&, SphereMethod);
template CastStats castLecture<float>(const CastJob<float>&, SphereMethod);
template CastStats castLecture<double>(const CastJob<double>&, SphereMethod);

}  // namespace durer
