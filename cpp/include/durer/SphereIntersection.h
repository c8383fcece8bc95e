#pragma once
// The three ray/sphere formulas, written on scalars so that the loops over a packet vectorise.
// Inputs: f = origin - centre, d = ray direction (any non-zero length), r = radius.
// Output: both roots in units of d, near <= far; NaN roots mean a miss (a NaN never compares as a hit).
#include <cmath>
#include <limits>

#include "durer/SphereMethod.h"

namespace durer {

template <typename Real>
struct SphereRoots {
  Real near;
  Real far;
};

// The first root at or past tMin, else NaN/inf that fails any range test.
template <typename Real>
inline Real firstRootFrom(SphereRoots<Real> roots, Real tMin) {
  return roots.near >= tMin ? roots.near : roots.far;
}

// Per-ray quantities shared by every sphere, computed once per packet.
template <typename Real>
struct SphereRayTerms {
  Real invLength;    // 1/|d| (geometric)
  Real invLengthSq;  // 1/(d·d) (algebraic, robust)
};

template <typename Real>
inline SphereRoots<Real> sphereAlgebraic(Real fx, Real fy, Real fz, Real dx, Real dy, Real dz,
                                         SphereRayTerms<Real> terms, Real r) {
  const Real b = 2 * (fx * dx + fy * dy + fz * dz);
  const Real c = fx * fx + fy * fy + fz * fz - r * r;
  const Real discriminant = b * b - 4 * c / terms.invLengthSq;
  const Real s = std::sqrt(discriminant);
  const Real halfInvA = Real(0.5) * terms.invLengthSq;
  return {(-b - s) * halfInvA, (-b + s) * halfInvA};
}

// tMin >= 0 enables the lecture's early rejection (origin outside, centre behind the origin).
template <typename Real>
inline SphereRoots<Real> sphereGeometric(Real fx, Real fy, Real fz, Real dx, Real dy, Real dz,
                                         SphereRayTerms<Real> terms, Real r, Real tMin) {
  const Real invLength = terms.invLength;
  const Real ux = dx * invLength, uy = dy * invLength, uz = dz * invLength;
  const Real tp = -(fx * ux + fy * uy + fz * uz);  // closest approach along the unit direction
  const Real l2 = fx * fx + fy * fy + fz * fz;
  const Real r2 = r * r;
  const Real d2 = l2 - tp * tp;                   // squared distance from the centre to the ray
  const bool behind = tMin >= 0 && l2 > r2 && tp < 0;
  const Real nan = std::numeric_limits<Real>::quiet_NaN();
  const Real tq = (behind || d2 > r2) ? nan : std::sqrt(r2 - d2);
  return {(tp - tq) * invLength, (tp + tq) * invLength};
}

template <typename Real>
inline SphereRoots<Real> sphereRobust(Real fx, Real fy, Real fz, Real dx, Real dy, Real dz,
                                      SphereRayTerms<Real> terms, Real r) {
  const Real invA = terms.invLengthSq;
  const Real b = fx * dx + fy * dy + fz * dz;  // half the lecture's b
  // l: from the centre to the ray's closest point; r² - |l|² avoids the cancellation in b² - ac.
  const Real along = b * invA;
  const Real lx = fx - along * dx, ly = fy - along * dy, lz = fz - along * dz;
  const Real discriminant = (r * r - (lx * lx + ly * ly + lz * lz)) / invA;
  const Real c = fx * fx + fy * fy + fz * fz - r * r;
  // q has the sign of -b, so -b and the square root never cancel; the other root is c/q (Vieta).
  const Real q = -(b + std::copysign(std::sqrt(discriminant), b));
  const Real t0 = q * invA;
  const Real t1 = c / q;
  const bool ordered = t0 <= t1;
  return {ordered ? t0 : t1, ordered ? t1 : t0};
}

template <SphereMethod M, typename Real>
inline SphereRoots<Real> sphereRoots(Real fx, Real fy, Real fz, Real dx, Real dy, Real dz,
                                     SphereRayTerms<Real> terms, Real r, Real tMin) {
  if constexpr (M == SphereMethod::Algebraic) {
    return sphereAlgebraic(fx, fy, fz, dx, dy, dz, terms, r);
  } else if constexpr (M == SphereMethod::Geometric) {
    return sphereGeometric(fx, fy, fz, dx, dy, dz, terms, r, tMin);
  } else {
    return sphereRobust(fx, fy, fz, dx, dy, dz, terms, r);
  }
}

}  // namespace durer
