#pragma once
#include <atomic>
#include <cstdint>

#include "durer/PlaneSet.h"
#include "durer/SphereSet.h"

namespace durer {

// A group of objects, one contiguous set per primitive kind (no virtual call per primitive per ray).
// A scene's geometry is a group. Packed primitive index: [0, spheres) spheres, then planes.
template <typename Real>
class Group {
 public:
  Group() = default;
  template <typename Other>
  explicit Group(const Group<Other>& other) : m_spheres(other.spheres()), m_planes(other.planes()) {}

  SphereSet<Real>& spheres() { return m_spheres; }
  const SphereSet<Real>& spheres() const { return m_spheres; }
  PlaneSet<Real>& planes() { return m_planes; }
  const PlaneSet<Real>& planes() const { return m_planes; }

  // The cheap t-only search for each ray's closest primitive; returns the ray-primitive tests made.
  template <SphereMethod M>
  int64_t intersect(RayPacket<Real>& packet, const std::atomic<bool>* cancel) const {
    packet.resetHits();
    return m_spheres.template intersect<M>(packet, 0, cancel) +
           m_planes.intersect(packet, static_cast<int32_t>(m_spheres.size()));
  }

  // The full hit record of ray k, once its search is over (a miss gives the default record).
  Hit<Real> hit(const RayPacket<Real>& packet, int k) const {
    const int32_t prim = packet.prim[k];
    if (prim == kNoPrimitive) return Hit<Real>{};
    const size_t index = static_cast<size_t>(prim);
    if (index < m_spheres.size()) return m_spheres.hit(packet, k, index);
    return m_planes.hit(packet, k, index - m_spheres.size());
  }

 private:
  SphereSet<Real> m_spheres;
  PlaneSet<Real> m_planes;
};

}  // namespace durer
