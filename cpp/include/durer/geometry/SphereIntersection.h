#pragma once
// The three ray/sphere formulas, written on scalars so that the loops over a packet vectorise.
// Inputs: the ray origin o and direction d (any non-zero length), the centre c and radius r, and
// the per-ray terms of d (sphereRayTerms); f = o - c.
// Output: both roots in units of d, near <= far; NaN roots mean a miss (a NaN never compares as a hit).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "durer/Inline.h"
#include "durer/geometry/RayPacket.h"
#include "durer/Options.h"
#include "durer/math/Float.h"

namespace durer {

template <typename Real>
struct SphereRoots {
  Real near;
  Real far;
};

// The first root at or past tMin, else NaN/inf that fails any range test.
template <typename Real>
DURER_INLINE Real firstRootFrom(SphereRoots<Real> roots, Real tMin) {
  return roots.near >= tMin ? roots.near : roots.far;
}

// Per-ray quantities shared by every sphere, computed once per packet.
template <typename Real>
struct SphereRayTerms {
  Real invLength;  // geometric: 1/|d|
  Real lengthSq;   // algebraic: d·d, the lecture's a
  Real sx, sy, sz; // robust: s = d·scale, exactly (scale is a power of two), with |s| in [1, 2·sqrt(3))
  Real a, invA;    // robust: s·s and 1/(s·s)
  Real scale;      // robust: t along d = t along s · scale; NaN if d's largest component is 0, subnormal,
                   // inf or NaN: the ray then misses
};

template <SphereMethod M, typename Real>
DURER_INLINE SphereRayTerms<Real> sphereRayTerms(Real dx, Real dy, Real dz) {
  SphereRayTerms<Real> terms{};
  if constexpr (M == SphereMethod::Robust) {
    const Real ax = std::fabs(dx), ay = std::fabs(dy), az = std::fabs(dz);
    const Real largest = ax > ay ? (ax > az ? ax : az) : (ay > az ? ay : az);
    // A power-of-two scale changes exponents only: s is d exactly, and no square over- or underflows.
    const Real scale = inversePowerOfTwo(largest);
    terms.sx = dx * scale;
    terms.sy = dy * scale;
    terms.sz = dz * scale;
    terms.a = terms.sx * terms.sx + terms.sy * terms.sy + terms.sz * terms.sz;
    terms.invA = Real(1) / terms.a;
    terms.scale = scale;
  } else {
    terms.lengthSq = dx * dx + dy * dy + dz * dz;
    terms.invLength = Real(1) / std::sqrt(terms.lengthSq);
  }
  return terms;
}

// Squared distance from the centre to the ray's line, |f × s|² / (s·s): each component of the cross
// product nearly exact, so it keeps its digits when |f| is many orders above the radius.
template <typename Real>
DURER_INLINE Real lineDistanceSq(Real fx, Real fy, Real fz, const SphereRayTerms<Real>& t) {
  const Real cx = differenceOfProducts(fy, t.sz, fz, t.sy);
  const Real cy = differenceOfProducts(fz, t.sx, fx, t.sz);
  const Real cz = differenceOfProducts(fx, t.sy, fy, t.sx);
  return (cx * cx + cy * cy + cz * cz) * t.invA;
}

// The robust method reports a hit only where the discriminant r² - p² exceeds a bound on its
// rounding error, kGrazingBound·epsilon·(r² + p²) (about twice the error the cross products,
// squares and division can make: docs/numerics.md). Rays that graze within it miss: never a false hit.
constexpr int kGrazingBound = 8;

template <typename Real>
DURER_INLINE bool robustMeets(Real r2, Real lineDistance2) {
  return r2 - lineDistance2 > kGrazingBound * std::numeric_limits<Real>::epsilon() * (r2 + lineDistance2);
}

// The per-packet prefilter: implied by robustMeets on the exact f = fh + fe, from fh alone. The line
// moves by at most |fe| <= u·|fh|₁ when the error of fh is added back, so r is widened by epsilon·|fh|₁.
template <typename Real>
DURER_INLINE bool robustMayMeet(Real r, Real lineDistance2, Real fhL1) {
  const Real wide = r + std::numeric_limits<Real>::epsilon() * fhL1;
  return robustMeets(wide * wide, lineDistance2);
}

template <typename Real>
DURER_INLINE SphereRoots<Real> sphereAlgebraic(Real fx, Real fy, Real fz, Real dx, Real dy, Real dz,
                                         SphereRayTerms<Real> terms, Real r) {
  const Real a = terms.lengthSq;
  const Real b = 2 * (fx * dx + fy * dy + fz * dz);
  const Real c = fx * fx + fy * fy + fz * fz - r * r;
  const Real s = std::sqrt(b * b - 4 * a * c);
  return {(-b - s) / (2 * a), (-b + s) / (2 * a)};
}

// tMin >= 0 enables the lecture's early rejection (origin outside, centre behind the origin).
template <typename Real>
DURER_INLINE SphereRoots<Real> sphereGeometric(Real fx, Real fy, Real fz, Real dx, Real dy, Real dz,
                                         SphereRayTerms<Real> terms, Real r, Real tMin) {
  const Real invLength = terms.invLength;
  const Real ux = dx * invLength, uy = dy * invLength, uz = dz * invLength;
  const Real tp = -(fx * ux + fy * uy + fz * uz);  // closest approach along the unit direction
  const Real l2 = fx * fx + fy * fy + fz * fz;
  const Real r2 = r * r;
  const Real d2 = l2 - tp * tp;                   // squared distance from the centre to the ray
  const bool behind = tMin >= 0 && l2 > r2 && tp < 0;
  const Real nan = std::numeric_limits<Real>::quiet_NaN();
  const bool miss = behind || d2 > r2;
  const Real squareRoot = std::sqrt(std::max(r2 - d2, Real(0)));  // unconditional: see robustRoots
  const Real tq = miss ? nan : squareRoot;
  return {(tp - tq) * invLength, (tp + tq) * invLength};
}

// The ray origin's part of the robust test, shared by every ray from that origin (a perspective
// camera's packet): f = o - centre as fh + fe, and c = |f|² - r².
template <typename Real>
struct RobustOrigin {
  Real fx, fy, fz;  // fh = fl(o - centre)
  Real ex, ey, ez;  // fe: o - centre - fh, exactly
  Real c;           // |f|² - r²
};

template <typename Real>
DURER_INLINE RobustOrigin<Real> robustOrigin(Real ox, Real oy, Real oz, const Vec3<Real>& center, Real r) {
  RobustOrigin<Real> o;
  o.fx = ox - center.x, o.fy = oy - center.y, o.fz = oz - center.z;
  o.ex = twoDiffError(ox, center.x, o.fx), o.ey = twoDiffError(oy, center.y, o.fy);
  o.ez = twoDiffError(oz, center.z, o.fz);
  o.c = sumOfSquaresMinus(o.fx, o.fy, o.fz, r) +
        (2 * (o.fx * o.ex + o.fy * o.ey + o.fz * o.ez) + (o.ex * o.ex + o.ey * o.ey + o.ez * o.ez));
  return o;
}

// b = f·s, the exact f's projection on the scaled direction (fh's part and fe's): robustRoots' b.
template <typename Real>
DURER_INLINE Real robustB(const RobustOrigin<Real>& f, const SphereRayTerms<Real>& t) {
  return (f.fx * t.sx + f.fy * t.sy + f.fz * t.sz) + (f.ex * t.sx + f.ey * t.sy + f.ez * t.sz);
}

// Whether robustRoots' roots are both below any tMin > 0 because the ray starts outside the sphere
// (c > 0) and moves away from it (b > 0): then q = -(b + root) < 0, so q / a and c / q are negative
// (or NaN, or -0 where a product underflows: still below tMin). A reflection or shadow ray leaving
// the sphere it starts on is the common case.
template <typename Real>
DURER_INLINE bool robustLeaves(const RobustOrigin<Real>& f, const SphereRayTerms<Real>& t) {
  return f.c > 0 && robustB(f, t) > 0;
}

// The robust test. f = o - c is carried exactly as fh + fe (fh rounded, fe its rounding error), so
// nothing below depends on how far the sphere is from the origin. With s the exactly scaled
// direction: the discriminant a·(r² - p²), p² = |f × s|²/a the squared line distance (no b² - ac
// cancellation: Ray Tracing Gems ch. 7), each cross component by difference of products; the roots
// q/a and c/q with q of the sign of -b (no -b ± sqrt cancellation); c = |f|² - r² by a compensated
// sum, accurate when the origin is near the surface (a ground sphere seen from just above it).
template <typename Real>
DURER_INLINE SphereRoots<Real> robustRoots(const RobustOrigin<Real>& f, const SphereRayTerms<Real>& t, Real r) {
  const Real cx = differenceOfProducts(f.fy, t.sz, f.fz, t.sy) + (f.ey * t.sz - f.ez * t.sy);
  const Real cy = differenceOfProducts(f.fz, t.sx, f.fx, t.sz) + (f.ez * t.sx - f.ex * t.sz);
  const Real cz = differenceOfProducts(f.fx, t.sy, f.fy, t.sx) + (f.ex * t.sy - f.ey * t.sx);
  const Real lineDistance2 = (cx * cx + cy * cy + cz * cz) * t.invA;
  const Real r2 = r * r;
  // Every operation done whatever the outcome, the miss chosen after: no operation that may raise a
  // floating-point exception depends on a condition, so the loops over a packet vectorise without
  // masked instructions (AVX2 as well as AVX-512).
  const bool meets = robustMeets(r2, lineDistance2);
  const Real discriminant = t.a * (r2 - lineDistance2);
  const Real squareRoot = std::sqrt(std::max(discriminant, Real(0)));  // discriminant > 0 where it meets
  const Real root = meets ? squareRoot : std::numeric_limits<Real>::quiet_NaN();
  const Real b = robustB(f, t);
  const Real q = -(b + std::copysign(root, b));
  const Real t0 = q * t.invA * t.scale;
  const Real t1 = f.c / q * t.scale;
  const bool ordered = t0 <= t1;
  return {ordered ? t0 : t1, ordered ? t1 : t0};
}

template <typename Real>
DURER_INLINE SphereRoots<Real> sphereRobust(Real ox, Real oy, Real oz, const Vec3<Real>& center,
                                      const SphereRayTerms<Real>& t, Real r) {
  return robustRoots(robustOrigin(ox, oy, oz, center, r), t, r);
}

// The per-ray terms of a whole packet, structure-of-arrays (an array of SphereRayTerms structs
// costs store-forwarding stalls in the vectorised loops).
template <typename Real>
struct PacketRayTerms {
  alignas(64) Real invLength[kPacketSize];
  alignas(64) Real lengthSq[kPacketSize];
  alignas(64) Real sx[kPacketSize];
  alignas(64) Real sy[kPacketSize];
  alignas(64) Real sz[kPacketSize];
  alignas(64) Real a[kPacketSize];
  alignas(64) Real invA[kPacketSize];
  alignas(64) Real scale[kPacketSize];

  template <SphereMethod M>
  DURER_INLINE void compute(const Real* dx, const Real* dy, const Real* dz, int count) {
    for (int k = 0; k < count; ++k) {
      const SphereRayTerms<Real> t = sphereRayTerms<M>(dx[k], dy[k], dz[k]);
      invLength[k] = t.invLength, lengthSq[k] = t.lengthSq;
      sx[k] = t.sx, sy[k] = t.sy, sz[k] = t.sz, a[k] = t.a, invA[k] = t.invA, scale[k] = t.scale;
    }
  }
  DURER_INLINE SphereRayTerms<Real> operator[](int k) const {
    return {invLength[k], lengthSq[k], sx[k], sy[k], sz[k], a[k], invA[k], scale[k]};
  }
};

template <SphereMethod M, typename Real>
DURER_INLINE SphereRoots<Real> sphereRoots(Real ox, Real oy, Real oz, const Vec3<Real>& center, Real dx, Real dy, Real dz,
                                     const SphereRayTerms<Real>& terms, Real r, Real tMin) {
  if constexpr (M == SphereMethod::Algebraic) {
    return sphereAlgebraic(ox - center.x, oy - center.y, oz - center.z, dx, dy, dz, terms, r);
  } else if constexpr (M == SphereMethod::Geometric) {
    return sphereGeometric(ox - center.x, oy - center.y, oz - center.z, dx, dy, dz, terms, r, tMin);
  } else {
    return sphereRobust(ox, oy, oz, center, terms, r);
  }
}

}  // namespace durer
