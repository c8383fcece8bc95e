#pragma once
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "durer/Inline.h"
#include "durer/geometry/Hit.h"
#include "durer/accel/PrimitiveSet.h"
#include "durer/geometry/RayPacket.h"
#include "durer/math/Float.h"
#include "durer/math/Vec.h"
#include "durer/scene/Limits.h"

namespace durer {

// Points p with normal·(p - point) = 0; optionally bounded to the parallelogram point + a·edge1 +
// b·edge2, a, b in [0, 1] (point is then its corner). The bounded test uses the dual basis:
// a = (p - point)·dual1, b = (p - point)·dual2. Rays meet it at t = normal·(point - o) / normal·d:
// measuring from a point of the plane rather than subtracting normal·o from its offset from 0 keeps
// the digits when o and the plane are both far from 0.
// An unbounded plane ends where coordinates leave the precision's limits (|x| <= coordinateLimit, in
// the frame it is tested in): a ray nearly parallel to it would otherwise meet it at a t, and a
// point, that no later step (depth pass, hit point, secondary rays) can represent.
template <typename Real>
struct Plane {
  Vec3<Real> normal;  // unit, world space; the shading normal as given (not flipped toward the ray)
  Vec3<Real> point;   // a point of the plane: the parallelogram's corner if bounded, else offset·normal
  bool bounded;
  Vec3<Real> dual1;   // bounded only: in the plane, dual1·edge1 = 1, dual1·edge2 = 0
  Vec3<Real> dual2;   // bounded only: in the plane, dual2·edge1 = 0, dual2·edge2 = 1
};

template <typename Real>
class PlaneSet : public PrimitiveSet<Plane<Real>, Real> {
 public:
  PlaneSet() = default;
  template <typename Other>
  explicit PlaneSet(const PlaneSet<Other>& other) {
    this->convertFrom(other, [](const Plane<Other>& p) {
      return Plane<Real>{toReal<Real>(p.normal), toReal<Real>(p.point), p.bounded, toReal<Real>(p.dual1),
                         toReal<Real>(p.dual2)};
    });
  }

  // Lowers each ray's tHit to its closest plane hit in [tMin, tHit). A ray parallel to a plane gets
  // t = ±inf or NaN (lying in it: 0/0), neither of which passes the range test.
  // Returns the ray-plane tests made.
  int64_t intersect(RayPacket<Real>& packet, int32_t primBase, const std::atomic<bool>* cancel) const {
    return this->searchAll(packet, cancel, [&](int32_t first, int32_t count) {
      for (int32_t i = first; i < first + count; ++i) {
        const Plane<Real>& plane = this->m_primitives[static_cast<size_t>(i)];
        if (plane.bounded) {
          intersectOne<true>(packet, plane, primBase + i);
        } else {
          intersectOne<false>(packet, plane, primBase + i);
        }
      }
    });
  }

  // Where ray k meets plane `pl` (at packet.tHit[k]); pointError: that point's error bound.
  DURER_INLINE static Vec3<Real> pointOn(const Plane<Real>& pl, const RayPacket<Real>& packet, int k) {
    const Real t = packet.tHit[k];
    const Vec3<Real> p(packet.ox[k] + t * packet.dx[k], packet.oy[k] + t * packet.dy[k],
                       packet.oz[k] + t * packet.dz[k]);
    // One projection step back onto the plane, measured from its point: the error is then a few
    // roundings of the coordinates' magnitude, whatever t's error was.
    return p - glm::dot(pl.normal, p - pl.point) * pl.normal;
  }
  DURER_INLINE static Vec3<Real> pointError(const Plane<Real>& pl, const Vec3<Real>& point) {
    return errorGamma<Real>(8) * (absolute(point) + absolute(pl.point));
  }

  // Full record of ray k's hit on plane `index` (from values in registers, as SphereSet::hit's).
  Hit<Real> hit(const RayPacket<Real>& packet, int k, size_t index) const {
    const Plane<Real>& pl = this->m_primitives[index];
    const Vec3<Real> point = pointOn(pl, packet, k);
    Hit<Real> h;
    h.t = packet.tHit[k];
    h.normal = pl.normal, h.geometricNormal = pl.normal;
    h.point = point;
    h.pointError = pointError(pl, point);
    this->recordIds(h, index);
    return h;
  }

  // hit(packet, k, index) for every ray k of the packet, all of which met plane `index`, as
  // SphereSet::hitsOn makes a sphere's.
  template <typename Make>
  void hitsOn(const RayPacket<Real>& packet, size_t index, const Make& make) const {
    const Plane<Real> pl = this->m_primitives[index];
    alignas(64) Real v[9][kPacketSize];
    for (int k = 0; k < packet.count; ++k) {
      const Vec3<Real> point = pointOn(pl, packet, k), error = pointError(pl, point);
      for (int i = 0; i < 3; ++i) v[i][k] = pl.normal[i], v[3 + i][k] = point[i], v[6 + i][k] = error[i];
    }
    this->recordsFrom(packet, index, v, make);
  }

 private:
  template <bool Bounded>
  DURER_INLINE static void intersectOne(RayPacket<Real>& packet, const Plane<Real>& pl, int32_t id) {
    const int n = packet.count;
    const Real* __restrict ox = packet.ox;
    const Real* __restrict oy = packet.oy;
    const Real* __restrict oz = packet.oz;
    const Real* __restrict dx = packet.dx;
    const Real* __restrict dy = packet.dy;
    const Real* __restrict dz = packet.dz;
    const Vec3<Real> nrm = pl.normal;
    for (int k = 0; k < n; ++k) {
      const Real denominator = nrm.x * dx[k] + nrm.y * dy[k] + nrm.z * dz[k];
      const Real t = (nrm.x * (pl.point.x - ox[k]) + nrm.y * (pl.point.y - oy[k]) + nrm.z * (pl.point.z - oz[k])) /
                     denominator;
      // A finite n·d (an infinite direction would give t = ±0); a parallel ray's ±inf or NaN fails
      // the epilog's range test.
      bool valid = std::fabs(denominator) < std::numeric_limits<Real>::infinity();
      if constexpr (Bounded) {
        const Real qx = ox[k] + t * dx[k] - pl.point.x;
        const Real qy = oy[k] + t * dy[k] - pl.point.y;
        const Real qz = oz[k] + t * dz[k] - pl.point.z;
        const Real a = qx * pl.dual1.x + qy * pl.dual1.y + qz * pl.dual1.z;
        const Real b = qx * pl.dual2.x + qy * pl.dual2.y + qz * pl.dual2.z;
        valid = valid & (a >= 0) & (a <= 1) & (b >= 0) & (b <= 1);
      } else {
        constexpr Real kReach = static_cast<Real>(coordinateLimit<Real>());
        const Real px = ox[k] + t * dx[k], py = oy[k] + t * dy[k], pz = oz[k] + t * dz[k];
        valid = valid & (std::fabs(px) <= kReach) & (std::fabs(py) <= kReach) & (std::fabs(pz) <= kReach);
      }
      recordHit(packet, k, t, id, valid);
    }
  }

};

}  // namespace durer
