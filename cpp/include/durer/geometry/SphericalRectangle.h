#pragma once
// The solid angle a rectangle fills seen from a point, and points of the rectangle uniform in that
// solid angle (Ureña, Fajardo and King 2013, "An Area-Preserving Parametrization for Spherical
// Rectangles", as pbrt-v4's SampleSphericalRectangle): near a large area light, points uniform over
// its area crowd where it looks small and leave the nearby part to a few heavy samples; these carry
// equal weights. In double whatever the render's precision: the construction subtracts angles.
#include <algorithm>
#include <cmath>

#include "durer/math/Float.h"
#include "durer/math/Vec.h"

namespace durer {

class SphericalRectangle {
 public:
  SphericalRectangle() = default;  // no solid angle
  // The rectangle corner + a·ex + b·ey (a, b in [0, 1], ex ⟂ ey) seen from p, which lies on the side
  // ex × ey points to (an area light's lit side; else the solid angle is 0).
  SphericalRectangle(const Vec3d& p, const Vec3d& corner, const Vec3d& ex, const Vec3d& ey) : m_p(p) {
    const double lx = glm::length(ex), ly = glm::length(ey);
    m_ex = ex / lx, m_ey = ey / ly, m_ez = glm::cross(m_ex, m_ey);
    const Vec3d d = corner - p;
    m_x0 = glm::dot(d, m_ex), m_y0 = glm::dot(d, m_ey), m_z0 = glm::dot(d, m_ez);
    m_x1 = m_x0 + lx, m_y1 = m_y0 + ly;
    if (!(m_z0 < 0)) return;  // behind the rectangle, or in its plane
    const Vec3d v00(m_x0, m_y0, m_z0), v01(m_x0, m_y1, m_z0), v10(m_x1, m_y0, m_z0), v11(m_x1, m_y1, m_z0);
    const Vec3d n0 = glm::normalize(glm::cross(v00, v10)), n1 = glm::normalize(glm::cross(v10, v11));
    const Vec3d n2 = glm::normalize(glm::cross(v11, v01)), n3 = glm::normalize(glm::cross(v01, v00));
    const double g0 = angleBetween(-n0, n1), g1 = angleBetween(-n1, n2);
    const double g2 = angleBetween(-n2, n3), g3 = angleBetween(-n3, n0);
    m_solidAngle = g0 + g1 + g2 + g3 - 2 * kPi;
    m_b0 = n0.z, m_b1 = n2.z, m_k = g2 + g3;
  }

  // Steradians; 0 from behind (and, by rounding, for a rectangle too small or far to resolve).
  double solidAngle() const { return std::isfinite(m_solidAngle) && m_solidAngle > 0 ? m_solidAngle : 0; }

  // The rectangle's point for (u, v) in [0, 1)^2, uniform over the solid angle (solidAngle() > 0).
  Vec3d point(double u, double v) const {
    const double au = u * m_solidAngle - m_k;
    const double fu = (std::cos(au) * m_b0 - m_b1) / std::sin(au);
    const double cu = std::clamp(std::copysign(1 / std::sqrt(fu * fu + m_b0 * m_b0), fu), -kBelowOne, kBelowOne);
    const double xu = std::clamp(-(cu * m_z0) / std::sqrt(1 - cu * cu), m_x0, m_x1);
    const double dd = std::sqrt(xu * xu + m_z0 * m_z0);
    const double h0 = m_y0 / std::sqrt(dd * dd + m_y0 * m_y0), h1 = m_y1 / std::sqrt(dd * dd + m_y1 * m_y1);
    const double hv = h0 + v * (h1 - h0);
    const double yv = hv * hv < 1 - 1e-12 ? std::clamp(hv * dd / std::sqrt(1 - hv * hv), m_y0, m_y1) : m_y1;
    return m_p + xu * m_ex + yv * m_ey + m_z0 * m_ez;
  }

 private:
  static constexpr double kBelowOne = 1 - 0x1p-53;

  // The angle between unit vectors, accurate near 0 and π (acos of their dot product is not).
  static double angleBetween(const Vec3d& a, const Vec3d& b) {
    return glm::dot(a, b) < 0 ? kPi - 2 * std::asin(std::min(glm::length(a + b) / 2, 1.0))
                              : 2 * std::asin(std::min(glm::length(a - b) / 2, 1.0));
  }

  Vec3d m_p, m_ex, m_ey, m_ez;
  double m_x0 = 0, m_x1 = 0, m_y0 = 0, m_y1 = 0, m_z0 = 0;
  double m_solidAngle = 0, m_b0 = 0, m_b1 = 0, m_k = 0;  // m_k: the angles g2 + g3
};

}  // namespace durer
