#pragma once
// Where secondary rays start: the epsilon policy (docs/numerics.md). A hit point carries a bound on
// its rounding error; a secondary ray starts just outside that error box, on the side of the surface
// it leaves toward, so it can neither re-hit its own surface (acne) nor skip past a nearby one (leaks).
// No fixed t_min: the offset is a few ulps of the hit point's own magnitude, in the render's precision.

#include "durer/math/Float.h"

namespace durer {

// The origin of a ray leaving a surface point in direction w (any length): the point pushed along
// the normal by the error box's extent in that direction, then one more ulp away in every component
// the normal has, so that it is strictly off the surface even where the error bound is 0.
// point: on the surface (reprojected); normal: unit; error: per-component bound on |point - exact|.
template <typename Real>
Vec3<Real> offsetRayOrigin(const Vec3<Real>& point, const Vec3<Real>& normal, const Vec3<Real>& error,
                           const Vec3<Real>& w) {
  // The side w leaves toward, and each step below, selected without branches: coin tosses for the
  // branch predictor over a render's shadow and bounce rays.
  const Real side = Real(1) - Real(2) * Real(glm::dot(w, normal) < 0);
  const Vec3<Real> away = side * normal;
  const Vec3<Real> origin = point + glm::dot(absolute(normal), error) * away;
  return Vec3<Real>(nextToward(origin.x, away.x), nextToward(origin.y, away.y), nextToward(origin.z, away.z));
}

}  // namespace durer
