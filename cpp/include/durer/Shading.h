#pragma once
#include <algorithm>
#include <limits>
#include <vector>

#include "durer/Scene.h"
#include "durer/Vec.h"

namespace durer {

// A light in the render's precision, directional and point alike.
template <typename Real>
struct ShadingLight {
  bool directional;
  Vec3<Real> vector;  // directional: unit direction toward the light; point: its position
  Vec3<Real> color;   // linear RGB
  bool shadows;       // whether shadow rays are cast toward it

  Vec3<Real> toLight(const Vec3<Real>& point) const {  // unit
    return directional ? vector : glm::normalize(vector - point);
  }
  // A shadow ray from `origin` toward the light covers t in [0, shadowTMax()): for a point light the
  // direction is not normalised, so the light sits exactly at t = 1 and needs no epsilon either.
  Vec3<Real> shadowDirection(const Vec3<Real>& origin) const { return directional ? vector : vector - origin; }
  Real shadowTMax() const { return directional ? std::numeric_limits<Real>::infinity() : Real(1); }
};

// The 6.837 assignment-2 shading, in the render's precision:
//   no lights: the material's diffuse colour (flat);
//   lights:    ambient·kd + Σ max(N·L, 0)·light·kd over directional and point lights,
//              a light's term dropped where a shadow ray toward it is blocked (lights with shadows).
template <typename Real>
class Shading {
 public:
  explicit Shading(const Scene& scene) : m_ambient(toReal<Real>(scene.ambient())) {
    for (const Material& m : scene.materials()) m_diffuse.push_back(toReal<Real>(m.diffuse));
    for (const DirectionalLight& l : scene.directionalLights()) {
      m_lights.push_back({true, toReal<Real>(-l.direction), toReal<Real>(l.color), l.shadows});
    }
    for (const PointLight& l : scene.pointLights()) {
      m_lights.push_back({false, toReal<Real>(l.position), toReal<Real>(l.color), l.shadows});
    }
  }

  bool lit() const { return !m_lights.empty(); }  // whether shading needs hit records
  const Vec3<Real>& diffuse(int32_t material) const { return m_diffuse[static_cast<size_t>(material)]; }
  const Vec3<Real>& ambient() const { return m_ambient; }
  const std::vector<ShadingLight<Real>>& lights() const { return m_lights; }

 private:
  std::vector<Vec3<Real>> m_diffuse;  // by material id
  Vec3<Real> m_ambient;
  std::vector<ShadingLight<Real>> m_lights;
};

}  // namespace durer
