#pragma once
#include <algorithm>
#include <vector>

#include "durer/Scene.h"
#include "durer/Vec.h"

namespace durer {

// The 6.837 assignment-2 shading, in the render's precision:
//   no lights: the material's diffuse colour (flat);
//   lights:    ambient·kd + Σ max(N·L, 0)·light·kd over directional and point lights.
template <typename Real>
class Shading {
 public:
  explicit Shading(const Scene& scene) : m_ambient(toReal<Real>(scene.ambient())), m_lit(scene.hasLights()) {
    for (const Material& m : scene.materials()) m_diffuse.push_back(toReal<Real>(m.diffuse));
    for (const DirectionalLight& l : scene.directionalLights()) {
      m_toDirectional.push_back(toReal<Real>(-l.direction));
      m_directionalColor.push_back(toReal<Real>(l.color));
    }
    for (const PointLight& l : scene.pointLights()) {
      m_pointPosition.push_back(toReal<Real>(l.position));
      m_pointColor.push_back(toReal<Real>(l.color));
    }
  }

  bool lit() const { return m_lit; }  // whether shading needs the normal

  const Vec3<Real>& diffuse(int32_t material) const { return m_diffuse[static_cast<size_t>(material)]; }

  Vec3<Real> shade(int32_t material, const Vec3<Real>& point, const Vec3<Real>& normal) const {
    const Vec3<Real>& kd = diffuse(material);
    if (!m_lit) return kd;
    Vec3<Real> irradiance = m_ambient;
    for (size_t i = 0; i < m_toDirectional.size(); ++i) {
      irradiance += std::max(glm::dot(normal, m_toDirectional[i]), Real(0)) * m_directionalColor[i];
    }
    for (size_t i = 0; i < m_pointPosition.size(); ++i) {
      const Vec3<Real> toLight = glm::normalize(m_pointPosition[i] - point);
      irradiance += std::max(glm::dot(normal, toLight), Real(0)) * m_pointColor[i];
    }
    return irradiance * kd;
  }

 private:
  std::vector<Vec3<Real>> m_diffuse;  // by material id
  Vec3<Real> m_ambient;
  bool m_lit;
  std::vector<Vec3<Real>> m_toDirectional, m_directionalColor;
  std::vector<Vec3<Real>> m_pointPosition, m_pointColor;
};

}  // namespace durer
