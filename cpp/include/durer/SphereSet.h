#pragma once
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <vector>

#include "durer/Hit.h"
#include "durer/PrimitiveIds.h"
#include "durer/RayOffset.h"
#include "durer/RayPacket.h"
#include "durer/SphereIntersection.h"
#include "durer/Vec.h"

namespace durer {

template <typename Real>
struct Sphere {
  Vec3<Real> center;  // world space
  Real radius;        // > 0
};

// All spheres of a group, contiguous. The search is t-only; the hit record is built once per ray.
template <typename Real>
class SphereSet {
 public:
  SphereSet() = default;
  template <typename Other>
  explicit SphereSet(const SphereSet<Other>& other) {
    m_spheres.reserve(other.size());
    for (size_t i = 0; i < other.size(); ++i) {
      const auto& s = other.sphere(i);
      m_spheres.push_back({toReal<Real>(s.center), static_cast<Real>(s.radius)});
    }
    m_ids = other.ids();
  }

  void add(const Sphere<Real>& sphere, int32_t material, int32_t objectId) {
    m_spheres.push_back(sphere);
    m_ids.add(material, objectId);
  }
  void reserve(size_t n) {
    m_spheres.reserve(n);
    m_ids.reserve(n);
  }

  size_t size() const { return m_spheres.size(); }
  const Sphere<Real>& sphere(size_t i) const { return m_spheres[i]; }
  const PrimitiveIds& ids() const { return m_ids; }

  // Lowers each ray's tHit to its closest sphere hit in [tMin, tHit); sphere i is recorded as
  // primBase + i. Between chunks of spheres it gives up if *cancel is set (the packet is then garbage).
  template <SphereMethod M>
  void intersect(RayPacket<Real>& packet, int32_t primBase, const std::atomic<bool>* cancel) const {
    const int n = packet.count;
    const Real tMin = packet.tMin;
    alignas(64) SphereRayTerms<Real> terms[kPacketSize];
    for (int k = 0; k < n; ++k) terms[k] = sphereRayTerms<M>(packet.dx[k], packet.dy[k], packet.dz[k]);
    const Real* __restrict ox = packet.ox;
    const Real* __restrict oy = packet.oy;
    const Real* __restrict oz = packet.oz;
    const Real* __restrict dx = packet.dx;
    const Real* __restrict dy = packet.dy;
    const Real* __restrict dz = packet.dz;
    Real* __restrict tHit = packet.tHit;
    int32_t* __restrict prim = packet.prim;
    // 4096 spheres x 64 rays is well under a millisecond: cancel stays prompt even without acceleration.
    constexpr size_t kChunk = 4096;
    for (size_t begin = 0; begin < m_spheres.size(); begin += kChunk) {
      if (cancel && cancel->load(std::memory_order_relaxed)) return;
      const size_t end = std::min(m_spheres.size(), begin + kChunk);
      for (size_t i = begin; i < end; ++i) {
        const Vec3<Real> c = m_spheres[i].center;
        const Real r = m_spheres[i].radius;
        const int32_t id = primBase + static_cast<int32_t>(i);
        if constexpr (M == SphereMethod::Robust) {
          if (!anyRayMeets(packet, terms, c, r)) continue;  // the robust test's own discriminant: nothing skipped wrongly
        }
        for (int k = 0; k < n; ++k) {
          const SphereRoots<Real> roots =
              sphereRoots<M>(ox[k] - c.x, oy[k] - c.y, oz[k] - c.z, dx[k], dy[k], dz[k], terms[k], r, tMin);
          const Real t = firstRootFrom(roots, tMin);
          const bool closer = (t >= tMin) & (t < tHit[k]);  // false for NaN: NaN never hits
          tHit[k] = closer ? t : tHit[k];
          prim[k] = closer ? id : prim[k];
        }
      }
    }
  }

  // Whether the robust test may find a hit for any ray (robustMayMeet, implied by robustMeets).
  // Most spheres miss most packets; this skips their square roots and divisions.
  static bool anyRayMeets(const RayPacket<Real>& packet, const SphereRayTerms<Real>* terms, const Vec3<Real>& c,
                          Real r) {
    int meeting = 0;  // an integer count, not a bool: the reduction then vectorises
    const Real r2 = r * r;
    for (int k = 0; k < packet.count; ++k) {
      const Real fx = packet.ox[k] - c.x, fy = packet.oy[k] - c.y, fz = packet.oz[k] - c.z;
      meeting += robustMayMeet(r2, lineDistanceSq(fx, fy, fz, terms[k])) ? 1 : 0;
    }
    return meeting > 0;
  }

  // Full record of ray k's hit on sphere `index` at packet.tHit[k].
  Hit<Real> hit(const RayPacket<Real>& packet, int k, size_t index) const {
    const Real t = packet.tHit[k];
    const Vec3<Real> p(packet.ox[k] + t * packet.dx[k], packet.oy[k] + t * packet.dy[k],
                       packet.oz[k] + t * packet.dz[k]);
    const Vec3<Real> c = m_spheres[index].center;
    Hit<Real> h;
    h.t = t;
    h.normal = glm::normalize(p - c);
    // Reprojection onto the sphere (pbrt-v4): the point's error no longer depends on t's error.
    h.point = c + m_spheres[index].radius * h.normal;
    h.pointError = errorGamma<Real>(6) * (glm::abs(h.point - c) + glm::abs(c));
    h.objectId = m_ids.objectIds()[index];
    h.materialId = m_ids.materials()[index];
    return h;
  }

 private:
  std::vector<Sphere<Real>> m_spheres;
  PrimitiveIds m_ids;
};

}  // namespace durer
