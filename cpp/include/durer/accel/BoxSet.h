#pragma once
// Axis-aligned boxes, one contiguous set per group. The slab test gives the entry and exit t; a ray
// starting inside a box (or, with t_min = -inf, any ray) meets it at the first of the two in range.
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "durer/Inline.h"
#include "durer/accel/Bvh.h"
#include "durer/geometry/Slab.h"
#include "durer/math/Float.h"
#include "durer/geometry/Hit.h"
#include "durer/accel/PrimitiveSet.h"
#include "durer/geometry/RayPacket.h"
#include "durer/math/Vec.h"

namespace durer {

template <typename Real>
struct Box {
  Vec3<Real> lo, hi;  // object space (world space outside a transformed group); lo < hi in each axis
};

template <typename Real>
class BoxSet : public PrimitiveSet<Box<Real>, Real> {
 public:
  BoxSet() = default;
  template <typename Other>
  explicit BoxSet(const BoxSet<Other>& other) {
    // Rounded outward, so that the box in float still holds the box as given.
    this->convertFrom(other, [](const Box<Other>& b) {
      Box<Real> out;
      for (int a = 0; a < 3; ++a) out.lo[a] = toRealDown<Real>(b.lo[a]), out.hi[a] = toRealUp<Real>(b.hi[a]);
      return out;
    });
  }

  void buildBvh(int threads) {
    Base::buildBvh([](const Box<Real>& b, Vec3<Real>& lo, Vec3<Real>& hi) { lo = b.lo, hi = b.hi; }, threads);
  }

  // Grows [lo, hi] to hold every box.
  void bounds(Vec3<Real>& lo, Vec3<Real>& hi) const {
    for (const Box<Real>& b : this->m_primitives) lo = glm::min(lo, b.lo), hi = glm::max(hi, b.hi);
  }

  // Lowers each ray's tHit to its closest box hit in [tMin, tHit); box i is recorded as
  // primBase + i. Returns the ray-box tests made.
  template <bool AnyHit = false>
  int64_t intersect(RayPacket<Real>& packet, int32_t primBase, const std::atomic<bool>* cancel) const {
    if (this->m_primitives.empty()) return 0;
    const PacketInverse<Real> inv(packet);
    const auto testRange = [&](int32_t first, int32_t count) {
      for (int32_t i = first; i < first + count; ++i) {
        for (int k = 0; k < packet.count; ++k) intersectRay(packet, inv, k, this->m_primitives[static_cast<size_t>(i)], primBase + i);
      }
    };
    const auto testRay = [&](int32_t first, int32_t count, int k) {
      for (int32_t i = first; i < first + count; ++i) intersectRay(packet, inv, k, this->m_primitives[static_cast<size_t>(i)], primBase + i);
    };
    return this->template search<AnyHit>(packet, cancel, testRange, testRay);
  }

  // Full record of ray k's hit on box `index`: the face is the axis along which the hit point is
  // farthest out (relative to the half extent), and the point is put exactly on that face's plane.
  Hit<Real> hit(const RayPacket<Real>& packet, int k, size_t index) const {
    const Box<Real>& b = this->m_primitives[index];
    const Real t = packet.tHit[k];
    Vec3<Real> p(packet.ox[k] + t * packet.dx[k], packet.oy[k] + t * packet.dy[k], packet.oz[k] + t * packet.dz[k]);
    const Vec3<Real> center = (b.lo + b.hi) * Real(0.5), half = (b.hi - b.lo) * Real(0.5);
    const Vec3<Real> q = (p - center) / half;
    const int axis = std::fabs(q.x) >= std::fabs(q.y) && std::fabs(q.x) >= std::fabs(q.z) ? 0
                     : std::fabs(q.y) >= std::fabs(q.z)                                    ? 1
                                                                                           : 2;
    Hit<Real> h;
    h.t = t;
    h.normal = Vec3<Real>(0);
    h.normal[axis] = q[axis] < 0 ? Real(-1) : Real(1);
    h.geometricNormal = h.normal;
    p[axis] = q[axis] < 0 ? b.lo[axis] : b.hi[axis];
    h.point = p;
    // The other two coordinates carry t's error: a few roundings of |o| + |t·d| each.
    const Vec3<Real> o(packet.ox[k], packet.oy[k], packet.oz[k]), d(packet.dx[k], packet.dy[k], packet.dz[k]);
    h.pointError = errorGamma<Real>(8) * (absolute(o) + absolute(t * d) + absolute(p));
    h.pointError[axis] = 0;
    this->recordIds(h, index);
    return h;
  }

 private:
  DURER_INLINE static void intersectRay(RayPacket<Real>& packet, const PacketInverse<Real>& inv, int k, const Box<Real>& b, int32_t id) {
    constexpr Real inf = std::numeric_limits<Real>::infinity();
    Real nearT = -inf, farT = inf;
    slab(b.lo.x, b.hi.x, packet.ox[k], inv.x[k], nearT, farT);
    slab(b.lo.y, b.hi.y, packet.oy[k], inv.y[k], nearT, farT);
    slab(b.lo.z, b.hi.z, packet.oz[k], inv.z[k], nearT, farT);
    // Entry if it is in range, else the exit (the ray starts inside).
    const Real t = nearT >= packet.tMin ? nearT : farT;
    recordHit(packet, k, t, id, (nearT <= farT) & (t < inf));
  }

  using Base = PrimitiveSet<Box<Real>, Real>;
};

}  // namespace durer
