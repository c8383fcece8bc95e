#pragma once
// Triangles, one contiguous set per group (single triangles and the faces of meshes alike), with the
// watertight ray-triangle test of Woop, Benthin & Wald (JCGT 2013): each ray is sheared and scaled so
// that it runs along +z from the origin, and the triangle's 2D edge functions U, V, W decide the hit.
// An edge shared by two triangles gets exactly opposite edge functions in both (a·b − c·d rounds to
// the negation of c·d − a·b), and 0 counts as inside, so a ray through a shared edge or vertex hits
// at least one of them: no cracks. Degenerate triangles (U + V + W = 0) miss; nothing yields NaN.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <utility>
#include <limits>
#include <vector>

#include "durer/Inline.h"
#include "durer/accel/Bvh.h"
#include "durer/geometry/Hit.h"
#include "durer/accel/PrimitiveSet.h"
#include "durer/geometry/RayPacket.h"
#include "durer/math/Float.h"
#include "durer/math/Vec.h"

namespace durer {

template <typename Real>
struct Triangle {
  Vec3<Real> v0, v1, v2;  // object space (world space outside a transformed group)
  Vec3<Real> normal;      // unit normalize((v1 − v0) × (v2 − v0)): the winding gives the side; 0 if degenerate
};

// A ray's shear into the test's frame: z is its largest direction component, x and y follow
// (swapped when d_z < 0, so that the winding, and so U, V, W's signs, are kept).
template <typename Real>
struct RayShear {
  int kx, ky, kz;
  Real sx, sy, sz;  // d_kx / d_kz, d_ky / d_kz, 1 / d_kz
  RayShear() = default;
  RayShear(Real dx, Real dy, Real dz) {
    const Real ax = std::fabs(dx), ay = std::fabs(dy), az = std::fabs(dz);
    kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
    kx = kz == 2 ? 0 : kz + 1;
    ky = kx == 2 ? 0 : kx + 1;
    const Real d[3] = {dx, dy, dz};
    if (d[kz] < 0) std::swap(kx, ky);
    sx = d[kx] / d[kz];
    sy = d[ky] / d[kz];
    sz = 1 / d[kz];
  }
};

// The outcome of one ray-triangle test: t = T / det and barycentrics u/det, v/det, w/det of
// v0, v1, v2 when `hit`.
template <typename Real>
struct TriangleHit {
  bool hit = false;
  Real t = 0;
  Real u = 0, v = 0, w = 0, det = 0;
};

// The 2D edge function a.x·b.y − a.y·b.x of two sheared vertices. In single precision a result of
// exactly 0 is recomputed in double from the same float coordinates (the paper's fallback): their
// products are exact in double, so its sign is exact; a nonzero float result already has the exact
// sign (rounding is monotonic). The two triangles at an edge thus agree on its sign.
template <typename Real>
DURER_INLINE Real edgeFunction(Real ax, Real ay, Real bx, Real by) {
  const Real e = ax * by - ay * bx;
  if constexpr (std::is_same_v<Real, float>) {
    if (e == 0) {
      const double exact = double(ax) * double(by) - double(ay) * double(bx);
      const float rounded = static_cast<float>(exact);
      // A nonzero value below the float range keeps its sign: the sign is what decides.
      if (rounded == 0 && exact != 0) return exact > 0 ? std::numeric_limits<float>::denorm_min()
                                                       : -std::numeric_limits<float>::denorm_min();
      return rounded;
    }
  }
  return e;
}

template <typename Real>
class TriangleSet : public PrimitiveSet<Triangle<Real>, Real, 3> {
  using Base = PrimitiveSet<Triangle<Real>, Real, 3>;

 public:
  TriangleSet() = default;
  template <typename Other>
  explicit TriangleSet(const TriangleSet<Other>& other) {
    this->convertFrom(other, [](const Triangle<Other>& t) {
      return Triangle<Real>{toReal<Real>(t.v0), toReal<Real>(t.v1), toReal<Real>(t.v2), toReal<Real>(t.normal)};
    });
  }

  // A triangle, with its own normal at its corners if the set is smooth().
  void add(const Triangle<Real>& tri, int32_t material, int32_t objectId) {
    Base::add(tri, material, objectId);
    if (this->smooth()) this->m_normals.push_back(flatNormals(tri));
  }
  void add(const Triangle<Real>& tri, int32_t material, int32_t objectId, const typename Base::Colors& colors) {
    Base::add(tri, material, objectId, colors);
    if (this->smooth()) this->m_normals.push_back(flatNormals(tri));
  }
  // The last triangle added is smooth: `normals` (unit) at v0, v1, v2. The first makes the set
  // smooth(), every triangle before it flat.
  void smoothLast(const typename Base::Normals& normals) {
    if (!this->smooth()) {
      this->m_normals.reserve(this->m_primitives.capacity());
      for (const Triangle<Real>& tri : this->m_primitives) this->m_normals.push_back(flatNormals(tri));
    }
    this->m_normals.back() = normals;
  }

  // The hierarchy over the triangles' boxes, each grown by γ₁₆ of its largest extent and rounded
  // outward. A ray from a point of the box (a ray leaving a mesh) meets a triangle at a t whose
  // rounding error is a few γ of the triangle's coordinates relative to the origin (tErrorBound),
  // which the slab test's own widening, relative to t, does not cover near t = 0: a ray leaving
  // a mesh's shared edge meets both triangles at t rounded below 0 each its own way, and with
  // t_min = -inf the hierarchy dropped the one at the lower t, its box entered at exactly 0 (found by
  // the traversal fuzz: a mesh at 1e6 in float). Origins farther off are covered by that widening.
  void buildBvh(int threads) {
    Base::buildBvh(
        [](const Triangle<Real>& t, Vec3<Real>& lo, Vec3<Real>& hi) {
          lo = glm::min(t.v0, glm::min(t.v1, t.v2)), hi = glm::max(t.v0, glm::max(t.v1, t.v2));
          const Vec3<Real> extent = hi - lo;
          const Real pad = errorGamma<Real>(16) * max3(extent.x, extent.y, extent.z);
          lo -= pad, hi += pad;
          roundOutward(lo, hi);
        },
        threads);
  }

  // Grows [lo, hi] to hold every triangle.
  void bounds(Vec3<Real>& lo, Vec3<Real>& hi) const {
    for (const Triangle<Real>& t : this->m_primitives) {
      lo = glm::min(lo, glm::min(t.v0, glm::min(t.v1, t.v2)));
      hi = glm::max(hi, glm::max(t.v0, glm::max(t.v1, t.v2)));
    }
  }

  // Lowers each ray's tHit to its closest triangle hit in [tMin, tHit); triangle i is recorded as
  // primBase + i. Returns the ray-triangle tests made.
  template <bool AnyHit = false>
  int64_t intersect(RayPacket<Real>& packet, int32_t primBase, const std::atomic<bool>* cancel) const {
    if (this->m_primitives.empty()) return 0;
    RayShear<Real> shears[kPacketSize];
    // Rays that count t > 0 (secondary rays, perspective cameras) must not meet the triangle they
    // leave: such hits need t conservatively above 0. A camera with t_min = -inf keeps every root.
    const bool countsFromZero = packet.tMin >= 0;
    for (int k = 0; k < packet.count; ++k) shears[k] = RayShear<Real>(packet.dx[k], packet.dy[k], packet.dz[k]);
    const auto testRay = [&](int32_t first, int32_t count, int k) {
      for (int32_t i = first; i < first + count; ++i) {
        const Triangle<Real>& tri = this->m_primitives[static_cast<size_t>(i)];
        const TriangleHit<Real> h = test(tri, packet.ox[k], packet.oy[k], packet.oz[k], shears[k], countsFromZero);
        recordHit(packet, k, h.t, primBase + i, h.hit);
      }
    };
    const auto testRange = [&](int32_t first, int32_t count) {
      for (int32_t i = first; i < first + count; ++i) {
        for (int k = 0; k < packet.count; ++k) testRay(i, 1, k);
      }
    };
    return this->template search<AnyHit>(packet, cancel, testRange, testRay);
  }

  // Full record of ray k's hit on triangle `index` at packet.tHit[k]: the point from the
  // barycentrics (pbrt-v4), so its error does not depend on t's, and so is the colour of a coloured
  // triangle from its corners' (each weight in [0, 1]: the colour stays within theirs).
  Hit<Real> hit(const RayPacket<Real>& packet, int k, size_t index) const {
    const Triangle<Real>& tri = this->m_primitives[index];
    const TriangleHit<Real> h =
        test(tri, packet.ox[k], packet.oy[k], packet.oz[k], RayShear<Real>(packet.dx[k], packet.dy[k], packet.dz[k]));
    const Real invDet = 1 / h.det;
    const Real b0 = h.u * invDet, b1 = h.v * invDet, b2 = h.w * invDet;
    const Vec3<Real> p0 = b0 * tri.v0, p1 = b1 * tri.v1, p2 = b2 * tri.v2;
    Hit<Real> out;
    out.t = packet.tHit[k];
    out.geometricNormal = tri.normal;
    out.normal = tri.normal;
    if (this->smooth()) {
      const typename Base::Normals& n = this->normals()[index];
      out.normal = smoothNormal(n, b0, b1, b2, tri.normal);
      const Real toward = packet.dx[k] * tri.normal.x + packet.dy[k] * tri.normal.y + packet.dz[k] * tri.normal.z;
      out.lift = static_cast<float>(terminatorLift(tri, n, b0, b1, b2, toward < 0 ? tri.normal : -tri.normal));
    }
    out.point = p0 + p1 + p2;
    out.pointError = errorGamma<Real>(7) * (absolute(p0) + absolute(p1) + absolute(p2));
    this->recordIds(out, index);
    if (this->colored()) {
      const typename Base::Colors& c = this->colors()[index];
      out.colored = true;
      out.color = b0 * c[0] + b1 * c[1] + b2 * c[2];
    }
    return out;
  }

  // One ray against one triangle (Woop, Benthin & Wald, section 3). With positiveT, a hit must have
  // t above its own rounding-error bound (pbrt-v4, 4th ed. §6.8.7): a ray leaving a triangle's
  // surface (its origin a few ulps off it) does not meet it again, however the ray is sheared.
  DURER_INLINE static TriangleHit<Real> test(const Triangle<Real>& tri, Real ox, Real oy, Real oz, const RayShear<Real>& s,
                                bool positiveT = false) {
    const Real a[3] = {tri.v0.x - ox, tri.v0.y - oy, tri.v0.z - oz};
    const Real b[3] = {tri.v1.x - ox, tri.v1.y - oy, tri.v1.z - oz};
    const Real c[3] = {tri.v2.x - ox, tri.v2.y - oy, tri.v2.z - oz};
    const Real ax = a[s.kx] - s.sx * a[s.kz], ay = a[s.ky] - s.sy * a[s.kz];
    const Real bx = b[s.kx] - s.sx * b[s.kz], by = b[s.ky] - s.sy * b[s.kz];
    const Real cx = c[s.kx] - s.sx * c[s.kz], cy = c[s.ky] - s.sy * c[s.kz];
    TriangleHit<Real> h;
    h.u = edgeFunction(cx, cy, bx, by);  // edge v1 -> v2: the weight of v0
    h.v = edgeFunction(ax, ay, cx, cy);  // edge v2 -> v0: the weight of v1
    h.w = edgeFunction(bx, by, ax, ay);  // edge v0 -> v1: the weight of v2
    const bool outside = (h.u < 0 || h.v < 0 || h.w < 0) && (h.u > 0 || h.v > 0 || h.w > 0);
    h.det = h.u + h.v + h.w;
    if (outside || h.det == 0 || h.det != h.det) return h;  // h.hit stays false
    const Real rawZ = max3(a[s.kz], b[s.kz], c[s.kz]);
    if (!rayInShearedBox(ax, bx, cx, rawZ) || !rayInShearedBox(ay, by, cy, rawZ)) return h;
    const Real az = s.sz * a[s.kz], bz = s.sz * b[s.kz], cz = s.sz * c[s.kz];
    // U, V, W and det are products of two coordinates: scaled by a power of two (exact, so t keeps
    // its bits) before they meet a third, t's numerator cannot overflow where coordinates fit Limits.h.
    const Real power = inversePowerOfTwo(std::fabs(h.det));
    const Real scale = power == power ? power : Real(1);
    h.t = (h.u * scale * az + h.v * scale * bz + h.w * scale * cz) / (h.det * scale);
    h.hit = h.t == h.t;
    if (positiveT && h.hit) {
      h.hit = h.t > tErrorBound(h, scale, max3(ax, bx, cx), max3(ay, by, cy), rawZ, max3(az, bz, cz));
    }
    return h;
  }

  // pbrt-v4's bound on the rounding error of t, from the largest sheared x and y (maxX, maxY), the
  // largest z before (rawZ, world units from the origin) and after (maxZ) its scaling by 1/d_z, and
  // the edge functions (scaled by `scale` as in the test, so that no product of three coordinates
  // is formed). x and y are sheared with the unscaled z (x − (d_x/d_z)·z, |d_x/d_z| <= 1), so their
  // errors are bounded with rawZ; pbrt's maxZ there only holds for directions of about unit length
  // (|d| = 1e-4 made the bound 1e4 times too large, and rays from inside a mesh missed it). As
  // written, scaling the direction by a power of two scales the bound exactly as it scales t.
  static Real tErrorBound(const TriangleHit<Real>& h, Real scale, Real maxX, Real maxY, Real rawZ, Real maxZ) {
    const Real deltaZ = errorGamma<Real>(3) * maxZ;
    const Real deltaX = errorGamma<Real>(5) * (maxX + rawZ), deltaY = errorGamma<Real>(5) * (maxY + rawZ);
    const Real deltaE = 2 * (errorGamma<Real>(2) * maxX * maxY + deltaY * maxX + deltaX * maxY) * scale;
    const Real maxE = max3(h.u, h.v, h.w) * scale;
    return 3 * (errorGamma<Real>(3) * maxE * maxZ + deltaE * maxZ + deltaZ * maxE) / std::fabs(h.det * scale);
  }

  // Whether the ray, at 0 in the sheared plane, lies within the sheared vertices' range p, q, r on
  // one axis, widened by their rounding (tErrorBound's deltaX, twice). Every true hit does. Where a
  // triangle is many orders of magnitude smaller than its distance from the ray in that plane, all
  // three edge functions are rounding noise and may share a sign by chance, which would make a hit
  // millions of sizes away from the triangle (a 1e-9 sliver 2e6 from the ray).
  DURER_INLINE static bool rayInShearedBox(Real p, Real q, Real r, Real rawZ) {
    const Real slack = 2 * errorGamma<Real>(5) * (max3(p, q, r) + rawZ);
    return std::min(p, std::min(q, r)) <= slack && std::max(p, std::max(q, r)) >= -slack;
  }

  // The corners' normals interpolated by barycentrics b0, b1, b2, unit; the face's normal where
  // they cancel (opposite normals at the corners).
  static Vec3<Real> smoothNormal(const typename Base::Normals& n, Real b0, Real b1, Real b2, const Vec3<Real>& face) {
    const Vec3<Real> sum = b0 * n[0] + b1 * n[1] + b2 * n[2];
    const Real length = glm::length(sum);
    return length > 0 && length < std::numeric_limits<Real>::infinity() ? sum / length : face;
  }

  static typename Base::Normals flatNormals(const Triangle<Real>& tri) { return {tri.normal, tri.normal, tri.normal}; }

  // Cycles' shadow terminator offset (shadow_ray_smooth_surface_offset): the smooth surface that a
  // flat triangle and its corner normals n describe, a parabola in the barycentrics (u, v, w) held
  // within each corner's tangent plane, lies this far from the face at (u, v, w) along the unit
  // interpolated normal (signed; `front`: the face's normal on the side the ray comes from). In the
  // triangle's space.
  static Real terminatorLift(const Triangle<Real>& tri, const typename Base::Normals& n, Real u, Real v, Real w,
                             const Vec3<Real>& front) {
    const Vec3<Real> corner[3] = {tri.v0, tri.v1, tri.v2};
    const Vec3<Real> p = u * corner[0] + v * corner[1] + w * corner[2];
    const Vec3<Real> normal = u * n[0] + v * n[1] + w * n[2];
    const Real a = glm::dot(n[2] - n[0], corner[0] - corner[2]);
    const Real b = glm::dot(n[2] - n[1], corner[1] - corner[2]);
    const Real c = glm::dot(n[1] - n[0], corner[1] - corner[0]);
    const Real parabola = a * u * (u - 1) + (a + b + c) * u * v + b * v * (v - 1);
    const Real side = glm::dot(normal, front) > 0 ? Real(1) : Real(-1);
    Real envelope = std::numeric_limits<Real>::infinity();
    for (int i = 0; i < 3; ++i) {
      const Vec3<Real>& vi = corner[i];
      const Real reach = std::max(std::max(side * glm::dot(corner[(i + 1) % 3] - vi, n[i]),
                                           side * glm::dot(corner[(i + 2) % 3] - vi, n[i])), Real(0));
      envelope = std::min(envelope, std::max(side * glm::dot(vi - p, n[i]) + reach, Real(0)));
    }
    const Real h = side > 0 ? std::max(envelope, parabola / 2) : std::min(-envelope, parabola / 2);
    return h * glm::length(normal);
  }

  DURER_INLINE static Real max3(Real p, Real q, Real r) {
    return std::max(std::fabs(p), std::max(std::fabs(q), std::fabs(r)));
  }
};

}  // namespace durer
