#pragma once
#include <algorithm>
#include <atomic>
#include <limits>
#include <memory>
#include <mutex>
#include <cstdint>
#include <vector>

#include "durer/Inline.h"
#include "durer/geometry/Hit.h"
#include "durer/accel/PrimitiveSet.h"
#include "durer/geometry/RayOffset.h"
#include "durer/geometry/RayPacket.h"
#include "durer/accel/Bvh.h"
#include "durer/accel/SphereView.h"
#include "durer/geometry/SphereIntersection.h"
#include "durer/math/Float.h"
#include "durer/math/Vec.h"

namespace durer {

template <typename Real>
struct Sphere {
  Vec3<Real> center;  // object space (world space outside a transformed group)
  Real radius;        // > 0
};

// All spheres of a group, contiguous. The search is t-only; the hit record is built once per ray.
template <typename Real>
class SphereSet : public PrimitiveSet<Sphere<Real>, Real> {
 public:
  SphereSet() = default;
  template <typename Other>
  explicit SphereSet(const SphereSet<Other>& other) {
    this->convertFrom(other, convert<Other>);
  }

  // Builds the bounding-volume hierarchy (and reorders the spheres and their ids to its order);
  // worth it above a few dozen spheres, after which intersect() traverses it.
  void buildBvh(int threads) { Base::buildBvh(kBoxOf, threads); }

  // The spheres of `source`, the set this one was made from, after they moved (Base::refitFrom).
  template <typename Other>
  bool refitFrom(const SphereSet<Other>& source, int threads) {
    m_views.clear();
    return Base::refitFrom(source, convert<Other>, kBoxOf, threads);
  }

  // The view of these spheres made for `key` (SphereView): the one kept for this key (see ViewCache),
  // else make()'s (null where a view would not pay).
  template <typename Make>
  std::shared_ptr<const SphereView<Real>> view(const ViewKey& key, const Make& make) const {
    return m_views.find(key, make);
  }

  void setSphere(size_t i, const Sphere<Real>& sphere) { this->m_primitives[i] = sphere; }

  // Grows [lo, hi] to hold every sphere (the bounds of a transformed group).
  void bounds(Vec3<Real>& lo, Vec3<Real>& hi) const {
    for (const Sphere<Real>& s : this->m_primitives) {
      lo = glm::min(lo, s.center - s.radius);
      hi = glm::max(hi, s.center + s.radius);
    }
  }

  // Lowers each ray's tHit to its closest sphere hit in [tMin, tHit) (with AnyHit: to some hit, for
  // rays without one yet); sphere i is recorded as primBase + i. Gives up if *cancel is set (checked
  // every ray or every few thousand spheres; the packet is then garbage).
  // Returns the ray-sphere tests made.
  template <SphereMethod M, bool AnyHit = false>
  int64_t intersect(RayPacket<Real>& packet, int32_t primBase, const std::atomic<bool>* cancel) const {
    if (this->m_primitives.empty()) return 0;
    PacketRayTerms<Real> terms;
    terms.template compute<M>(packet.dx, packet.dy, packet.dz, packet.count);
    if (packet.view) {
      if constexpr (AnyHit) {  // shadow rays toward a directional light, through its view
        int64_t tests = 0;
        packet.view->prefetchOccluders(packet);
        for (int k = 0; k < packet.count; ++k) {
          if (packet.prim[k] != kNoPrimitive) continue;
          const SphereRayTerms<Real> rayTerms = terms[k];
          tests += packet.view->occluders(packet, k, [&](uint32_t i) {
            intersectRay<M>(packet, rayTerms, k, static_cast<size_t>(i), primBase);
            return packet.prim[k] != kNoPrimitive;
          });
        }
        return tests;
      } else {  // camera rays, through the camera's view
        const int64_t tests = packet.view->search(packet, [&](uint32_t i, int kBegin, int kEnd, bool all) {
          if (all) {
            intersectOne<M>(packet, terms, static_cast<size_t>(i), primBase, kBegin, kEnd);
          } else {  // the rays under the sphere's rows: the prefilter would rarely spare the test
            intersectOne<M, false>(packet, terms, static_cast<size_t>(i), primBase, kBegin, kEnd);
          }
        });
        if (tests >= 0) return tests;
      }
    }
    return this->template search<AnyHit>(
        packet, cancel,
        [&](int32_t first, int32_t count) {
          for (int32_t i = first; i < first + count; ++i) intersectOne<M>(packet, terms, static_cast<size_t>(i), primBase);
        },
        [&](int32_t first, int32_t count, int k) {
          const SphereRayTerms<Real> rayTerms = terms[k];
          for (int32_t i = first; i < first + count; ++i) intersectRay<M>(packet, rayTerms, k, static_cast<size_t>(i), primBase);
        });
  }

  // One sphere against ray k: the same arithmetic as intersectOne's loop, so the same t.
  template <SphereMethod M>
  DURER_INLINE void intersectRay(RayPacket<Real>& packet, const SphereRayTerms<Real>& terms, int k, size_t i, int32_t primBase) const {
    const Vec3<Real> c = this->m_primitives[i].center;
    const Real r = this->m_primitives[i].radius;
    const Real ox = packet.ox[k], oy = packet.oy[k], oz = packet.oz[k];
    if constexpr (M == SphereMethod::Robust) {
      const Real fx = ox - c.x, fy = oy - c.y, fz = oz - c.z;
      if (!robustMayMeet(r, lineDistanceSq(fx, fy, fz, terms), std::fabs(fx) + std::fabs(fy) + std::fabs(fz))) return;
    }
    const SphereRoots<Real> roots =
        sphereRoots<M>(ox, oy, oz, c, packet.dx[k], packet.dy[k], packet.dz[k], terms, r, packet.tMin);
    recordHit(packet, k, firstRootFrom(roots, packet.tMin), primBase + static_cast<int32_t>(i));
  }

  // One sphere against the packet's rays [kBegin, kEnd) (all by default): the vectorised inner loop.
  // Prefilter: first whether any ray may meet it (worth it where most spheres tested meet no ray, as
  // in a hierarchy's leaves, not for a view's sphere against the rays under it).
  template <SphereMethod M, bool Prefilter = true>
  DURER_INLINE void intersectOne(RayPacket<Real>& packet, const PacketRayTerms<Real>& terms, size_t i, int32_t primBase,
                                 int kBegin = 0, int kEnd = -1) const {
    const Vec3<Real> c = this->m_primitives[i].center;
    const Real r = this->m_primitives[i].radius;
    const int n = kEnd < 0 ? packet.count : kEnd;
    if constexpr (M == SphereMethod::Robust && Prefilter) {
      if (!anyRayMayMeet(packet, terms, c, r, kBegin, n)) return;
    }
    const Real tMin = packet.tMin;
    const int32_t id = primBase + static_cast<int32_t>(i);
    const Real* __restrict ox = packet.ox;
    const Real* __restrict oy = packet.oy;
    const Real* __restrict oz = packet.oz;
    const Real* __restrict dx = packet.dx;
    const Real* __restrict dy = packet.dy;
    const Real* __restrict dz = packet.dz;
    if constexpr (M == SphereMethod::Robust) {
      if (packet.commonOrigin) {  // the origin's part once per sphere, not once per ray
        const RobustOrigin<Real> origin = robustOrigin(ox[0], oy[0], oz[0], c, r);
        for (int k = kBegin; k < n; ++k) recordHit(packet, k, firstRootFrom(robustRoots(origin, terms[k], r), tMin), id);
        return;
      }
    }
    for (int k = kBegin; k < n; ++k) {
      const SphereRoots<Real> roots = sphereRoots<M>(ox[k], oy[k], oz[k], c, dx[k], dy[k], dz[k], terms[k], r, tMin);
      recordHit(packet, k, firstRootFrom(roots, tMin), id);
    }
  }

  // Whether the robust test may find a hit for any ray (robustMayMeet, implied by the full test).
  // Most spheres miss most packets; this skips their square roots and divisions.
  DURER_INLINE static bool anyRayMayMeet(const RayPacket<Real>& packet, const PacketRayTerms<Real>& terms, const Vec3<Real>& c,
                                         Real r, int kBegin, int kEnd) {
    int meeting = 0;  // an integer count, not a bool: the reduction then vectorises
    for (int k = kBegin; k < kEnd; ++k) {
      const Real fx = packet.ox[k] - c.x, fy = packet.oy[k] - c.y, fz = packet.oz[k] - c.z;
      const Real fL1 = std::fabs(fx) + std::fabs(fy) + std::fabs(fz);
      meeting += robustMayMeet(r, lineDistanceSq(fx, fy, fz, terms[k]), fL1) ? 1 : 0;
    }
    return meeting > 0;
  }

  Vec3<Real> normal(const RayPacket<Real>& packet, int k, size_t index) const {
    const Real t = packet.tHit[k];
    const Vec3<Real> p(packet.ox[k] + t * packet.dx[k], packet.oy[k] + t * packet.dy[k],
                       packet.oz[k] + t * packet.dz[k]);
    // A sphere smaller than the spacing of numbers at its hit point can be met exactly at its centre
    // (p - c = 0): the normal then faces the ray.
    return glm::normalize(wellScaled(p - this->m_primitives[index].center,
                                     -Vec3<Real>(packet.dx[k], packet.dy[k], packet.dz[k])));
  }

  // Full record of ray k's hit on sphere `index` at packet.tHit[k].
  Hit<Real> hit(const RayPacket<Real>& packet, int k, size_t index) const {
    const Vec3<Real> c = this->m_primitives[index].center;
    Hit<Real> h;
    h.t = packet.tHit[k];
    h.normal = normal(packet, k, index);
    // Reprojection onto the sphere (pbrt-v4): the point's error no longer depends on t's error.
    h.point = c + this->m_primitives[index].radius * h.normal;
    h.pointError = errorGamma<Real>(6) * (absolute(h.point - c) + absolute(c));
    this->recordIds(h, index);
    return h;
  }

 private:
  using Base = PrimitiveSet<Sphere<Real>, Real>;

  // The views last made: the last camera's (an animation's moving camera leaves no trail of stale
  // views) and the last few lights'. The next render of the same camera and lights reuses them. A copy
  // of the set starts without any.
  struct ViewCache {
    static constexpr size_t kLightViews = 3;
    std::mutex mutex;
    std::vector<std::pair<ViewKey, std::shared_ptr<const SphereView<Real>>>> views;  // oldest first
    ViewCache() = default;
    ViewCache(const ViewCache&) {}
    ViewCache& operator=(const ViewCache&) {
      clear();
      return *this;
    }
    void clear() {
      const std::lock_guard<std::mutex> lock(mutex);
      views.clear();
    }
    template <typename Make>
    std::shared_ptr<const SphereView<Real>> find(const ViewKey& key, const Make& make) {
      const std::lock_guard<std::mutex> lock(mutex);
      for (const auto& [made, view] : views) {
        if (made == key) return view;
      }
      const size_t kept = key.light ? kLightViews - 1 : 0;  // of the same kind, besides the new one
      size_t same = 0;
      for (auto it = views.end(); it != views.begin();) {
        --it;
        if (it->first.light != key.light) continue;
        if (same < kept) {
          ++same;
        } else {
          it = views.erase(it);
        }
      }
      views.emplace_back(key, make());
      return views.back().second;
    }
  };
  mutable ViewCache m_views;

  template <typename Other>
  static Sphere<Real> convert(const Sphere<Other>& s) {
    return Sphere<Real>{toReal<Real>(s.center), static_cast<Real>(s.radius)};
  }
  // A sphere's box, rounded outward, for the hierarchy's builds and refits: a lambda, so that it
  // inlines into their loops (a function reference was called per sphere).
  static constexpr auto kBoxOf = [](const Sphere<Real>& s, Vec3<Real>& lo, Vec3<Real>& hi) {
    lo = s.center - s.radius, hi = s.center + s.radius;
    roundOutward(lo, hi);
  };
};

}  // namespace durer
