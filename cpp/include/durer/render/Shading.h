#pragma once
#include <algorithm>
#include <limits>
#include <vector>

#include "durer/scene/Scene.h"
#include "durer/math/Vec.h"

namespace durer {

// A light in the render's precision: directional, point and spot alike.
template <typename Real>
struct ShadingLight {
  enum class Kind { Directional, Point, Spot };
  Kind kind;
  Vec3<Real> vector;       // directional: unit direction toward the light; point, spot: position
  Vec3<Real> color;        // linear RGB
  Vec3<Real> attenuation;  // point, spot: c0, c1, c2 of color / (c0 + c1·d + c2·d²)
  Vec3<Real> axis;         // spot: unit direction it shines
  Real cosHalfAngle;       // spot
  Real blend;              // spot, in [0, 1]
  bool shadows;            // whether shadow rays are cast toward it

  Vec3<Real> toLight(const Vec3<Real>& point) const {  // unit
    return kind == Kind::Directional ? vector : glm::normalize(vector - point);
  }

  // The fraction of the light's colour arriving at `point` (toLight: its unit direction toward the
  // light). Finite, so that colour · falloff is never 0·inf: where the falloff's denominator
  // underflows (a point at the light with c0 = 0) it is the precision's largest number.
  Real falloff(const Vec3<Real>& point, const Vec3<Real>& toLight) const {
    if (kind == Kind::Directional) return 1;
    const Real d = glm::length(vector - point);
    Real factor = std::min(1 / (attenuation.x + d * (attenuation.y + d * attenuation.z)),
                           std::numeric_limits<Real>::max());
    if (kind == Kind::Spot) factor *= spotFactor(-glm::dot(toLight, axis));
    return factor;
  }

  Real spotFactor(Real cosine) const {
    if (blend <= 0) return cosine > cosHalfAngle ? Real(1) : Real(0);
    const Real x = std::clamp((cosine - cosHalfAngle) / ((1 - cosHalfAngle) * blend), Real(0), Real(1));
    return x * x * (3 - 2 * x);  // smoothstep
  }

  // A shadow ray from `origin` toward the light covers t in (0, shadowTMax()): for point and spot
  // lights the direction is not normalised, so the light sits exactly at t = 1 and needs no epsilon.
  Vec3<Real> shadowDirection(const Vec3<Real>& origin) const {
    return kind == Kind::Directional ? vector : vector - origin;
  }
  Real shadowTMax() const { return kind == Kind::Directional ? std::numeric_limits<Real>::infinity() : Real(1); }
};

// What shading reads, in the render's precision: materials by id, lights, ambient. Whether a scene
// is lit, and which effects apply, is the render's EffectSet; PacketShader.h does the shading.
template <typename Real>
class Shading {
 public:
  explicit Shading(const Scene& scene) : m_ambient(toReal<Real>(scene.ambient())) {
    using Kind = typename ShadingLight<Real>::Kind;
    for (const Material& m : scene.materials()) m_materials.push_back(MaterialIn<Real>::from(m));
    const Vec3<Real> none(0);
    for (const DirectionalLight& l : scene.directionalLights()) {
      m_lights.push_back({Kind::Directional, toReal<Real>(-l.direction), toReal<Real>(l.color), none, none, 0, 0,
                          l.shadows});
    }
    for (const PointLight& l : scene.pointLights()) {
      m_lights.push_back({Kind::Point, toReal<Real>(l.position), toReal<Real>(l.color), toReal<Real>(l.attenuation),
                          none, 0, 0, l.shadows});
    }
    for (const SpotLight& l : scene.spotLights()) {
      m_lights.push_back({Kind::Spot, toReal<Real>(l.position), toReal<Real>(l.color), toReal<Real>(l.attenuation),
                          toReal<Real>(l.direction), static_cast<Real>(l.cosHalfAngle), static_cast<Real>(l.blend),
                          l.shadows});
    }
  }

  const MaterialIn<Real>& material(int32_t id) const { return m_materials[static_cast<size_t>(id)]; }
  const Vec3<Real>& ambient() const { return m_ambient; }
  const std::vector<ShadingLight<Real>>& lights() const { return m_lights; }

 private:
  std::vector<MaterialIn<Real>> m_materials;  // by material id
  Vec3<Real> m_ambient;
  std::vector<ShadingLight<Real>> m_lights;
};

}  // namespace durer
