#pragma once
#include <cstdint>
#include <limits>
#include <new>
#include <type_traits>

#include "durer/math/Vec.h"

namespace durer {

// The full record of a ray's closest hit, built once after the t-only search.
template <typename Real>
struct Hit {
  Real t = std::numeric_limits<Real>::infinity();  // ray parameter, in units of the ray direction; inf on a miss
  Vec3<Real> normal{0};                            // unit, world space; sphere: outward; plane: as given; 0 on a miss
  // Unit, world space: the surface's own normal, along which rays leaving it are offset and which
  // decides the side a ray meets. `normal` but on a smooth triangle, whose `normal` (the one shaded
  // and written to the Normal pass) interpolates its corners' normals.
  Vec3<Real> geometricNormal{0};
  Vec3<Real> point{0};                             // world space, projected back onto the surface
  Vec3<Real> pointError{0};                        // per-component bound on |point - exact hit point| (RayOffset.h)
  int32_t objectId = -1;                           // id returned when the object was added; -1 on a miss
  int32_t materialId = -1;                         // -1 on a miss
  // A smooth triangle's terminator lift (Cycles' shadow terminator offset): how far the smooth
  // surface its corner normals describe lies from the face at the point, along `normal`, signed,
  // world units; 0 elsewhere. A float, in the record's padding: a heuristic's distance.
  float lift = 0;
  bool colored = false;                            // whether the primitive has its own colour:
  Vec3<Real> color;                                // then its kd at the hit, in place of the material's (else unset)
  bool isHit() const { return objectId >= 0; }
};

// Room for a packet's hit records, record k made in place by make(k, f) from the record f() returns:
// no default record first and no copy after (copying a returned record read it back in wider
// pieces than it had just been written in, a store-forwarding stall per piece).
template <typename Real, int N>
class HitRecords {
  static_assert(std::is_trivially_destructible_v<Hit<Real>>, "records are never destroyed");

 public:
  template <typename F>
  void make(int k, const F& f) {
    ::new (static_cast<void*>(m_bytes + static_cast<size_t>(k) * sizeof(Hit<Real>))) Hit<Real>(f());
  }
  Hit<Real>* data() { return std::launder(reinterpret_cast<Hit<Real>*>(m_bytes)); }
  Hit<Real>& operator[](int k) { return data()[k]; }

 private:
  alignas(64) unsigned char m_bytes[N * sizeof(Hit<Real>)];
};

// Which side of a surface is shaded, decided here for every pass and every bounce: -1 flips the
// normal toward the ray where shadeBack asks for it and the ray arrives from behind the surface
// (direction·normal > 0, normal of any length), else +1 keeps the normal as stored.
template <typename Real>
Real facingSign(Real directionDotNormal, bool shadeBack) {
  return shadeBack && directionDotNormal > 0 ? Real(-1) : Real(1);
}

// The normal a hit is shaded with, by facingSign's rule. Branch-free (the product by ±1 is exact), so
// that loops over a packet's normals vectorise.
template <typename Real>
Vec3<Real> shadingNormal(const Vec3<Real>& normal, const Vec3<Real>& direction, bool shadeBack) {
  return facingSign(glm::dot(direction, normal), shadeBack) * normal;
}

// A hit's normal on the side facingSign gives, the side decided by the surface's own normal.
template <typename Real>
Vec3<Real> shadingNormal(const Hit<Real>& hit, const Vec3<Real>& direction, bool shadeBack) {
  return facingSign(glm::dot(direction, hit.geometricNormal), shadeBack) * hit.normal;
}

}  // namespace durer
