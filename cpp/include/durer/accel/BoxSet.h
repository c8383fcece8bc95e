#pragma once
// Axis-aligned boxes, one contiguous set per group. The slab test gives the entry and exit t; a ray
// starting inside a box (or, with t_min = -inf, any ray) meets it at the first of the two in range.
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "durer/accel/Bvh.h"
#include "durer/geometry/Slab.h"
#include "durer/math/Float.h"
#include "durer/geometry/Hit.h"
#include "durer/accel/PrimitiveIds.h"
#include "durer/geometry/RayOffset.h"
#include "durer/geometry/RayPacket.h"
#include "durer/math/Vec.h"

namespace durer {

template <typename Real>
struct Box {
  Vec3<Real> lo, hi;  // object space (world space outside a transformed group); lo < hi in each axis
};

template <typename Real>
class BoxSet {
 public:
  BoxSet() = default;
  template <typename Other>
  explicit BoxSet(const BoxSet<Other>& other) {
    m_boxes.reserve(other.size());
    for (size_t i = 0; i < other.size(); ++i) {
      // Rounded outward, so that the box in float still holds the box as given.
      Vec3<Real> lo, hi;
      for (int a = 0; a < 3; ++a) {
        lo[a] = toRealDown<Real>(other.box(i).lo[a]);
        hi[a] = toRealUp<Real>(other.box(i).hi[a]);
      }
      m_boxes.push_back({lo, hi});
    }
    m_ids = other.ids();
  }

  void add(const Box<Real>& box, int32_t material, int32_t objectId) {
    m_boxes.push_back(box);
    m_ids.add(material, objectId);
  }

  size_t size() const { return m_boxes.size(); }
  const Box<Real>& box(size_t i) const { return m_boxes[i]; }
  const PrimitiveIds& ids() const { return m_ids; }

  void buildBvh() {
    std::vector<Vec3<Real>> lo(m_boxes.size()), hi(m_boxes.size());
    for (size_t i = 0; i < m_boxes.size(); ++i) lo[i] = m_boxes[i].lo, hi[i] = m_boxes[i].hi;
    const std::vector<uint32_t> order = m_bvh.build(std::move(lo), std::move(hi));
    std::vector<Box<Real>> sorted(m_boxes.size());
    for (size_t i = 0; i < order.size(); ++i) sorted[i] = m_boxes[order[i]];
    m_boxes.swap(sorted);
    m_ids.permute(order);
  }

  // Grows [lo, hi] to hold every box.
  void bounds(Vec3<Real>& lo, Vec3<Real>& hi) const {
    for (const Box<Real>& b : m_boxes) lo = glm::min(lo, b.lo), hi = glm::max(hi, b.hi);
  }

  // Lowers each ray's tHit to its closest box hit in [tMin, tHit); box i is recorded as
  // primBase + i. Returns the ray-box tests made.
  int64_t intersect(RayPacket<Real>& packet, int32_t primBase, const std::atomic<bool>* cancel) const {
    if (m_boxes.empty()) return 0;
    const PacketInverse<Real> inv(packet);
    const auto testRange = [&](int32_t first, int32_t count) {
      for (int32_t i = first; i < first + count; ++i) intersectOne(packet, inv, m_boxes[static_cast<size_t>(i)], primBase + i);
    };
    if (!m_bvh.empty()) return m_bvh.traverse(packet, cancel, testRange) * packet.count;
    testRange(0, static_cast<int32_t>(m_boxes.size()));
    return static_cast<int64_t>(m_boxes.size()) * packet.count;
  }

  // Full record of ray k's hit on box `index`: the face is the axis along which the hit point is
  // farthest out (relative to the half extent), and the point is put exactly on that face's plane.
  Hit<Real> hit(const RayPacket<Real>& packet, int k, size_t index) const {
    const Box<Real>& b = m_boxes[index];
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
    p[axis] = q[axis] < 0 ? b.lo[axis] : b.hi[axis];
    h.point = p;
    // The other two coordinates carry t's error: a few roundings of |o| + |t·d| each.
    const Vec3<Real> o(packet.ox[k], packet.oy[k], packet.oz[k]), d(packet.dx[k], packet.dy[k], packet.dz[k]);
    h.pointError = errorGamma<Real>(8) * (glm::abs(o) + glm::abs(t * d) + glm::abs(p));
    h.pointError[axis] = 0;
    h.objectId = m_ids.objectIds()[index];
    h.materialId = m_ids.materials()[index];
    return h;
  }

 private:
  static void intersectOne(RayPacket<Real>& packet, const PacketInverse<Real>& inv, const Box<Real>& b, int32_t id) {
    constexpr Real inf = std::numeric_limits<Real>::infinity();
    for (int k = 0; k < packet.count; ++k) {
      Real nearT = -inf, farT = inf;
      slab(b.lo.x, b.hi.x, packet.ox[k], inv.x[k], nearT, farT);
      slab(b.lo.y, b.hi.y, packet.oy[k], inv.y[k], nearT, farT);
      slab(b.lo.z, b.hi.z, packet.oz[k], inv.z[k], nearT, farT);
      // Entry if it is in range, else the exit (the ray starts inside).
      const Real t = nearT >= packet.tMin ? nearT : farT;
      const bool closer = (nearT <= farT) & (t >= packet.tMin) & (t < packet.tHit[k]) & (t > -inf) & (t < inf);
      packet.tHit[k] = closer ? t : packet.tHit[k];
      packet.prim[k] = closer ? id : packet.prim[k];
    }
  }

  std::vector<Box<Real>> m_boxes;
  PrimitiveIds m_ids;
  Bvh<Real> m_bvh;  // empty: brute force
};

}  // namespace durer
