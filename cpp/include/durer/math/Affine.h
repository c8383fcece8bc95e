#pragma once
// An affine map p -> A·p + b (column vectors), the frame change of a transformed group: rays go
// into object space by objectFromWorld, normals come back by the inverse transpose, points by
// worldFromObject (pbrt-v4's naming: the map's name says which frame it maps from and to).
#include <cmath>

#include "durer/math/Float.h"

namespace durer {

template <typename Real>
struct Affine {
  Vec3<Real> row[3];  // rows of A
  Vec3<Real> offset;  // b

  template <typename Other>
  static Affine from(const Affine<Other>& o) {
    return {{toReal<Real>(o.row[0]), toReal<Real>(o.row[1]), toReal<Real>(o.row[2])}, toReal<Real>(o.offset)};
  }

  // Component arithmetic written out (no FMA: -ffp-contract=off), so that the vectorised search and
  // the scalar hit record map a ray to the same bits.
  Real pointX(Real x, Real y, Real z) const { return row[0].x * x + row[0].y * y + row[0].z * z + offset.x; }
  Real pointY(Real x, Real y, Real z) const { return row[1].x * x + row[1].y * y + row[1].z * z + offset.y; }
  Real pointZ(Real x, Real y, Real z) const { return row[2].x * x + row[2].y * y + row[2].z * z + offset.z; }
  Real vectorX(Real x, Real y, Real z) const { return row[0].x * x + row[0].y * y + row[0].z * z; }
  Real vectorY(Real x, Real y, Real z) const { return row[1].x * x + row[1].y * y + row[1].z * z; }
  Real vectorZ(Real x, Real y, Real z) const { return row[2].x * x + row[2].y * y + row[2].z * z; }

  Vec3<Real> point(const Vec3<Real>& p) const { return {pointX(p.x, p.y, p.z), pointY(p.x, p.y, p.z), pointZ(p.x, p.y, p.z)}; }
  Vec3<Real> vector(const Vec3<Real>& v) const {
    return {vectorX(v.x, v.y, v.z), vectorY(v.x, v.y, v.z), vectorZ(v.x, v.y, v.z)};
  }
  // Aᵀ·v: a normal maps back to world space by the transpose of objectFromWorld's A (the inverse
  // transpose of worldFromObject's).
  Vec3<Real> transposed(const Vec3<Real>& v) const { return v.x * row[0] + v.y * row[1] + v.z * row[2]; }

  // A bound on the rounding error of point(p) given p's own error bound (pbrt-v4, Transform of a
  // Point3fi): γ₃ of the products' magnitudes plus the input error carried through |A|.
  Vec3<Real> pointError(const Vec3<Real>& p, const Vec3<Real>& error) const {
    Vec3<Real> e;
    for (int i = 0; i < 3; ++i) {
      const Vec3<Real> a = absolute(row[i]);
      e[i] = errorGamma<Real>(3) * (glm::dot(a, absolute(p)) + std::fabs(offset[i])) +
             (1 + errorGamma<Real>(3)) * glm::dot(a, error);
    }
    return e;
  }

  double determinant() const { return glm::dot(row[0], glm::cross(row[1], row[2])); }
  bool isIdentity() const {
    return row[0] == Vec3<Real>(1, 0, 0) && row[1] == Vec3<Real>(0, 1, 0) && row[2] == Vec3<Real>(0, 0, 1) &&
           offset == Vec3<Real>(0);
  }
  bool operator==(const Affine& o) const {
    return row[0] == o.row[0] && row[1] == o.row[1] && row[2] == o.row[2] && offset == o.offset;
  }
};

using Affined = Affine<double>;

// The inverse map (A⁻¹, -A⁻¹·b), by the adjugate. The caller has checked that A is invertible.
inline Affined inverse(const Affined& m) {
  const Vec3d c0 = glm::cross(m.row[1], m.row[2]), c1 = glm::cross(m.row[2], m.row[0]), c2 = glm::cross(m.row[0], m.row[1]);
  const double invDet = 1 / glm::dot(m.row[0], c0);
  // A⁻¹'s columns are the cross products over the determinant; its rows are their components.
  Affined inv{{Vec3d(c0.x, c1.x, c2.x) * invDet, Vec3d(c0.y, c1.y, c2.y) * invDet, Vec3d(c0.z, c1.z, c2.z) * invDet},
              Vec3d(0)};
  inv.offset = -inv.vector(m.offset);
  return inv;
}

// The one rule for whether a transform can be used (Scene, and through durer._core.is_invertible
// the Python package): finite, with A invertible judged scale-free (|det A| against its Hadamard
// bound, the product of the row lengths: 1 for any rotation or axis scale, 0 for a singular map)
// and a finite inverse.
inline bool isInvertible(const Affined& m) {
  constexpr double kMinRelativeDeterminant = 1e-12;
  for (int i = 0; i < 3; ++i) {
    const Vec3d& row = m.row[i];
    if (!(std::isfinite(row.x) && std::isfinite(row.y) && std::isfinite(row.z) && std::isfinite(m.offset[i]))) {
      return false;
    }
  }
  const double bound = glm::length(m.row[0]) * glm::length(m.row[1]) * glm::length(m.row[2]);
  if (!(std::fabs(m.determinant()) > kMinRelativeDeterminant * bound)) return false;
  const Affined inv = inverse(m);
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(glm::dot(inv.row[i], Vec3d(1)) + inv.offset[i])) return false;
  }
  return true;
}

}  // namespace durer
