#pragma once
#include "durer/Vec.h"

namespace durer {

// P(t) = origin + t * direction. The direction need not be unit length; t is in units of it.
template <typename Real>
struct Ray {
  Vec3<Real> origin;     // world space
  Vec3<Real> direction;  // world space, non-zero
  Vec3<Real> at(Real t) const { return origin + t * direction; }
};

}  // namespace durer
