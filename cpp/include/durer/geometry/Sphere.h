#pragma once
#include "durer/math/Vec.h"

namespace durer {

// A sphere as the sets store it (SphereSet, and SphereGrid's records).
template <typename Real>
struct Sphere {
  Vec3<Real> center;  // object space (world space outside a transformed group)
  Real radius;        // > 0
};

}  // namespace durer
