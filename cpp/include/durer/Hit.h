#pragma once
#include <cstdint>
#include <limits>

#include "durer/Vec.h"

namespace durer {

// The full record of a ray's closest hit, built once after the t-only search.
template <typename Real>
struct Hit {
  Real t = std::numeric_limits<Real>::infinity();  // ray parameter, in units of the ray direction; inf on a miss
  Vec3<Real> normal{0};                            // unit, world space; sphere: outward; plane: as given; 0 on a miss
  Vec3<Real> point{0};                             // world space, projected back onto the surface
  Vec3<Real> pointError{0};                        // per-component bound on |point - exact hit point| (RayOffset.h)
  int32_t objectId = -1;                           // id returned when the object was added; -1 on a miss
  int32_t materialId = -1;                         // -1 on a miss
  bool isHit() const { return objectId >= 0; }
};

}  // namespace durer
