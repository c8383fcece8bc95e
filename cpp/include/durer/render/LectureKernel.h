#pragma once
// The lecture's sphere methods (algebraic, geometric) for a precision, compiled once for the
// baseline instruction set: they are there to compare accuracy, not to be fast. Instantiated by
// src/kernels/LectureFloat.cpp and LectureDouble.cpp, one translation unit a precision, which a
// build compiles side by side (together, the longest compilation of a clean build).
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

}  // namespace durer
