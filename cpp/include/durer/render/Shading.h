#pragma once
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "durer/geometry/SphericalRectangle.h"
#include "durer/math/Float.h"
#include "durer/math/Vec.h"
#include "durer/scene/Scene.h"

namespace durer {

// A uniform point (x, y) of the unit disc for (u, v) in [0, 1)^2: Shirley and Chiu's concentric
// map, which keeps the strata of Sobol points compact. Its angle stays within ±π/4 of an axis, where
// short Taylor series give sine and cosine to 2e-9 (libm's sincos took a fifth of an AO render) in
// plain arithmetic, the same on every instruction set.
inline void concentricDisc(double u, double v, double& x, double& y) {
  const double a = 2 * u - 1, b = 2 * v - 1;
  const bool wide = std::fabs(a) > std::fabs(b);
  const double r = wide ? a : b;
  const double t = r == 0 ? 0 : kPi / 4 * (wide ? b / a : a / b);
  const double t2 = t * t;
  const double sine = t * (1 - t2 / 6 * (1 - t2 / 20 * (1 - t2 / 42 * (1 - t2 / 72))));
  const double cosine = 1 - t2 / 2 * (1 - t2 / 12 * (1 - t2 / 30 * (1 - t2 / 56 * (1 - t2 / 90))));
  x = r * (wide ? cosine : sine);
  y = r * (wide ? sine : cosine);
}

// A light in the render's precision: directional, point, spot and area alike. An area light is met
// through points on its surface, `samples` of them per shaded hit (surfacePoint), each seen as a
// point light of colour color · cosθ / samples (θ: off the light's normal) with inverse-square
// falloff: their mean estimates the surface's integral. A light of some size (`size`) spreads its
// highlights over it; one with soft shadows (`softShadows`, `spread`) casting shadows sends `samples` shadow rays
// per hit toward points all over it (PacketShader::addSoftLight).
template <typename Real>
struct ShadingLight {
  enum class Kind { Directional, Point, Spot, Area };
  Kind kind = Kind::Point;
  Vec3<Real> vector{0};          // directional: unit direction toward the light; point, spot: position; area: centre
  Vec3<Real> color{0};           // linear RGB
  Vec3<Real> attenuation{0, 0, 1};  // point, spot: c0, c1, c2 of color / (c0 + c1·d + c2·d²)
  Vec3<Real> axis{0};            // spot: unit direction it shines; area: unit normal, u × v
  Real cosHalfAngle = 0;         // spot
  Real blend = 0;                // spot, in [0, 1]
  bool shadows = false;          // whether shadow rays are cast toward it
  Vec3<Real> u{0}, v{0};         // area: edge vectors
  bool ellipse = false;          // area: the ellipse inscribed in the parallelogram
  bool perpendicular = false;    // area: u ⟂ v to 1e-6 (a rectangle, or an ellipse with them for axes)
  Real nearSquared = 0;          // area, an ellipse: 0.36 · the product of its semi-axes, where by area gets noisier
  Real area = 0;                 // area: of the surface
  int samples = 1;               // area: points per shaded hit; a light of some size: shadow rays per hit
  bool softShadows = false;      // point, spot, directional: its shadows sampled over its size (SoftShadows::on)
  Real spread = 0;               // soft shadows: point, spot: its sphere's radius; directional: 1 − cos of its half angle
  Real size = 0;                 // point, spot: its sphere's radius; directional: its half angle (highlights)

  // Whether its shadow rays all pass through one point (or run along one direction), so that a view
  // of the spheres from there can serve them: not an area light's, nor a soft-shadowed one's.
  bool viewable() const { return kind != Kind::Area && !softShadows; }

  // Area: the point of the surface for (a, b) in [0, 1)^2, uniform over it (an affine map of the
  // unit square, or of the unit disc for an ellipse).
  Vec3<Real> surfacePoint(double a, double b) const {
    if (ellipse) {
      concentricDisc(a, b, a, b);
      return vector + static_cast<Real>(a / 2) * u + static_cast<Real>(b / 2) * v;
    }
    return vector + static_cast<Real>(a - 0.5) * u + static_cast<Real>(b - 0.5) * v;
  }

  // Area: whether `point`, on the light's plane, lies on its surface (inside the ellipse, or the
  // parallelogram).
  bool inside(const Vec3<Real>& point) const {
    // Its coordinates along u and v from the centre (u, v need not be perpendicular): w = a·u + b·v.
    const Vec3<Real> w = point - vector, n = glm::cross(u, v);
    const Real nn = glm::dot(n, n);
    const Real a = glm::dot(glm::cross(w, v), n) / nn, b = glm::dot(glm::cross(u, w), n) / nn;
    return ellipse ? a * a + b * b <= Real(0.25) : std::fabs(a) <= Real(0.5) && std::fabs(b) <= Real(0.5);
  }

  // Area: whether the ray from `origin` along unit r meets the surface from its front, and then
  // `toward`, the vector from origin to where it does (a shadow ray's, t in (0, 1)).
  bool mirroredFrom(const Vec3<Real>& origin, const Vec3<Real>& r, Vec3<Real>& toward) const {
    const Real facing = glm::dot(r, axis);
    if (!(facing < 0)) return false;  // along the surface or at its back: it shines one way
    const Real t = glm::dot(vector - origin, axis) / facing;
    if (!(t > 0 && t < std::numeric_limits<Real>::infinity())) return false;
    toward = t * r;
    return inside(origin + toward);
  }

  // Area, u ⟂ v: the rectangle (an ellipse's: the one around it) seen from `point`, to sample by
  // solid angle; v made exactly perpendicular to u (a shear of the nearly perpendicular parallelogram:
  // the same area, a sliver of cos·|v| / (4|u|) of it moved, cos <= 1e-6).
  SphericalRectangle seenFrom(const Vec3<Real>& point) const {
    const Vec3d a(u), b = Vec3d(v) - (glm::dot(Vec3d(v), a) / glm::dot(a, a)) * a;
    const Vec3d corner = Vec3d(vector) - (a + b) / 2.0;
    return SphericalRectangle(Vec3d(point), corner, a, b);
  }

  // Area, u ⟂ v: the falloff of a point sampled by solid angle where its rectangle fills
  // `solidAngle`: Ω / (area · samples), so that the term is the radiance color / area times
  // Ω cosθ / samples (an ellipse's points outside it carry nothing: inside()).
  Real solidAngleFalloff(double solidAngle) const {
    return static_cast<Real>(solidAngle / (static_cast<double>(area) * samples));
  }

  // Area: the falloff of the surface point toward which a hit sees unit toLight at squared distance
  // d2: cosθ / d² / samples, 0 behind the surface, finite (as falloff()).
  Real areaFalloff(const Vec3<Real>& toLight, Real d2) const {
    const Real cosine = -glm::dot(toLight, axis);
    if (!(cosine > 0)) return 0;
    return std::min(cosine / d2, std::numeric_limits<Real>::max()) / static_cast<Real>(samples);
  }

  // Point, spot, directional of some size: the square of the angle its sphere's or disc's radius
  // spans seen from `point` (a sphere's at most 1: from inside it, a radian; a disc's half angle
  // below π/2).
  Real angularRadius2(const Vec3<Real>& point) const {
    if (kind == Kind::Directional) return size * size;
    const Vec3<Real> w = vector - point;
    const Real d2 = glm::dot(w, w);
    return size * size < d2 ? size * size / d2 : Real(1);
  }

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
    for (const DirectionalLight& l : scene.directionalLights()) {
      ShadingLight<Real>& light = add(Kind::Directional, -l.direction, l.color, l.shadows);
      takeSize(light, l.soft);
      const double half = l.soft.size;
      if (light.softShadows) light.spread = static_cast<Real>(2 * std::sin(half / 2) * std::sin(half / 2));  // 1 − cos, no cancellation
    }
    for (const PointLight& l : scene.pointLights()) {
      ShadingLight<Real>& light = add(Kind::Point, l.position, l.color, l.shadows);
      light.attenuation = toReal<Real>(l.attenuation);
      takeSize(light, l.soft);
      if (light.softShadows) light.spread = light.size;
    }
    for (const SpotLight& l : scene.spotLights()) {
      ShadingLight<Real>& light = add(Kind::Spot, l.position, l.color, l.shadows);
      light.attenuation = toReal<Real>(l.attenuation);
      light.axis = toReal<Real>(l.direction);
      light.cosHalfAngle = static_cast<Real>(l.cosHalfAngle), light.blend = static_cast<Real>(l.blend);
      takeSize(light, l.soft);
      if (light.softShadows) light.spread = light.size;
    }
    for (const AreaLight& l : scene.areaLights()) {
      ShadingLight<Real>& light = add(Kind::Area, l.position, l.color, l.shadows);
      light.axis = toReal<Real>(glm::normalize(glm::cross(l.u, l.v)));
      light.u = toReal<Real>(l.u), light.v = toReal<Real>(l.v);
      light.ellipse = l.ellipse, light.samples = l.samples;
      const double parallelogram = glm::length(glm::cross(l.u, l.v));
      light.area = static_cast<Real>(l.ellipse ? kPi / 4 * parallelogram : parallelogram);
      // To 1e-6: edges from a float32 matrix (Blender's) are perpendicular to ~1e-8 at best.
      light.perpendicular = std::fabs(glm::dot(l.u, l.v)) <= 1e-6 * glm::length(l.u) * glm::length(l.v);
      light.nearSquared = static_cast<Real>(0.36 * glm::length(l.u) * glm::length(l.v) / 4);
    }
  }

  const MaterialIn<Real>& material(int32_t id) const { return m_materials[static_cast<size_t>(id)]; }
  const std::vector<MaterialIn<Real>>& materials() const { return m_materials; }
  const Vec3<Real>& ambient() const { return m_ambient; }
  const std::vector<ShadingLight<Real>>& lights() const { return m_lights; }

 private:
  std::vector<MaterialIn<Real>> m_materials;  // by material id
  Vec3<Real> m_ambient;
  std::vector<ShadingLight<Real>> m_lights;

  // A point, spot or directional light's size, which spreads its highlights, and its soft shadows.
  static void takeSize(ShadingLight<Real>& light, const SoftShadows& soft) {
    light.size = static_cast<Real>(soft.size), light.samples = soft.samples, light.softShadows = soft.on();
  }

  ShadingLight<Real>& add(typename ShadingLight<Real>::Kind kind, const Vec3d& vector, const Vec3d& color, bool shadows) {
    ShadingLight<Real>& light = m_lights.emplace_back();
    light.kind = kind, light.vector = toReal<Real>(vector), light.color = toReal<Real>(color), light.shadows = shadows;
    return light;
  }
};

}  // namespace durer
