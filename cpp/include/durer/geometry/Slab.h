#pragma once
// The slab test of a ray against an axis-aligned box, one axis at a time: used by the box primitive
// (BoxSet), by the packet-against-box test (anyRayEnters: an instance's bounds, a hierarchy
// node's children in a packet's walk) and by the sphere grid's entry (SphereGrid::start).
#include <algorithm>
#include <limits>

#include "durer/Inline.h"
#include "durer/geometry/RayPacket.h"
#include "durer/math/Float.h"

namespace durer {

// Narrows [nearT, farT] to the slab [lo, hi] of one axis, for a ray with origin o and reciprocal
// direction inv on it. A NaN from 0·inf (a ray parallel to the slab with its origin on a face, so
// inside it) leaves the range as it was; a parallel ray off the face gives ±inf and empties or keeps
// it. Kept this small on purpose: GCC (with its default -ftrapping-math) left the BVH's packet loop
// scalar on ISAs without mask registers (x86-64-v2, AVX2) while each slab also widened its ends
// under an inf guard: 3x slower on 1,000 spheres.
template <typename Real>
DURER_INLINE void slab(Real lo, Real hi, Real o, Real inv, Real& nearT, Real& farT) {
  constexpr Real inf = std::numeric_limits<Real>::infinity();
  const Real t0 = (lo - o) * inv, t1 = (hi - o) * inv;
  const bool defined = (t0 == t0) & (t1 == t1);
  const Real tNear = defined ? (t0 < t1 ? t0 : t1) : -inf;
  const Real tFar = defined ? (t0 < t1 ? t1 : t0) : inf;
  nearT = tNear > nearT ? tNear : nearT;
  farT = tFar < farT ? tFar : farT;
}

// Each ray's reciprocal direction, for slab tests (computed once per packet).
template <typename Real>
struct PacketInverse {
  alignas(64) Real x[kPacketSize], y[kPacketSize], z[kPacketSize];
  explicit PacketInverse(const RayPacket<Real>& p) {
    for (int k = 0; k < p.count; ++k) x[k] = 1 / p.dx[k], y[k] = 1 / p.dy[k], z[k] = 1 / p.dz[k];
  }
};

// How much a slab range's ends are widened (widenDown, widenUp) to keep every ray that truly meets
// the box. The slab's t are each within γ₃ of the exact ones (two roundings and the reciprocal's),
// so 2γ₃ would do; the factor is 2γ₅ because the product and the rounded factor add two roundings of
// their own. Widening commutes with the max and min over the slabs (it is monotonic), so it is done
// once on the range's ends.
template <typename Real>
inline constexpr Real kSlabWiden = 2 * errorGamma<Real>(5);

// Whether any ray of the packet may meet the box [lo, hi] (rounded outward) at some t in
// [tMin, its tHit], the slab's t widened by kSlabWiden for their own rounding. Rays are
// tested 16 at a time (a vectorised loop each), stopping at the first chunk with a ray that enters.
template <typename Real>
DURER_INLINE bool anyRayEnters(const RayPacket<Real>& p, const PacketInverse<Real>& inv, const Vec3<Real>& lo, const Vec3<Real>& hi) {
  constexpr Real inf = std::numeric_limits<Real>::infinity();
  constexpr int kChunk = 16;
  for (int first = 0; first < p.count; first += kChunk) {
    int entering = 0;  // an integer count, not a bool: the reduction then vectorises
    for (int k = first; k < std::min(first + kChunk, p.count); ++k) {
      Real nearT = -inf, farT = inf;
      slab(lo.x, hi.x, p.ox[k], inv.x[k], nearT, farT);
      slab(lo.y, hi.y, p.oy[k], inv.y[k], nearT, farT);
      slab(lo.z, hi.z, p.oz[k], inv.z[k], nearT, farT);
      nearT = widenDown(nearT, kSlabWiden<Real>);
      farT = widenUp(farT, kSlabWiden<Real>);
      nearT = p.tMin > nearT ? p.tMin : nearT;
      farT = p.tHit[k] < farT ? p.tHit[k] : farT;
      entering += nearT <= farT ? 1 : 0;
    }
    if (entering > 0) return true;
  }
  return false;
}

}  // namespace durer
