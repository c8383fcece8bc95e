#pragma once
// The colour of a packet's hits: emission, ambient light (scaled by its unoccluded fraction when
// ambient occlusion is asked for), the lights' diffuse and Phong terms (with shadow rays toward
// lights that cast them), and the mirror and refracted rays, traced as packets of their own,
// bounce after bounce (6.837 assignments 2-4). What a scene does not call for is never run: the
// EffectSet says which parts apply, decided once per render (Renderer.cpp), so an absent effect costs
// at most a test per packet, never per ray.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "durer/accel/Group.h"
#include "durer/render/RayCounters.h"
#include "durer/geometry/RayOffset.h"
#include "durer/geometry/RayPacket.h"
#include "durer/math/Float.h"
#include "durer/render/PixelSampler.h"
#include "durer/render/Shading.h"

namespace durer {

struct EffectSet {
  bool lit = false;         // lights (or scene shading "lit"): else flat colours
  bool specular = false;    // lit, and some material has a Phong highlight
  bool shadows = false;     // lit, and some light casts shadows
  int viewedLights = 0;     // lit: how many lights cast shadows whose rays views could serve (hard ones)
  bool sampledShadows = false;  // lit: an area light or a light of some size casts shadows (rays all over it)
  bool mirroredLights = false;  // lit: an area light, and some material reflective (a ray toward it: addMirrored)
  bool reflection = false;  // some material is reflective and maxBounces > 0
  bool refraction = false;  // some material is transparent and maxBounces > 0
  bool occlusion = false;   // lit, ambient occlusion asked for, and some ambient · kd to scale
  bool colors = false;      // some primitive has its own colours: flat colours too come from hit records
  bool bounces() const { return reflection || refraction; }
};

struct BounceLimits {
  int maxBounces;    // the deepest secondary ray (a camera ray's children are at depth 1)
  double minWeight;  // rays whose weight would fall below this are not spawned
  bool shadeBack;    // shade back faces with the flipped normal (6.837 -shade_back)
};

struct OcclusionSettings {
  int samples = 0;       // rays per shaded hit
  double distance = 0;   // how far an occluder counts (inf: any)
  uint64_t seed = 0;     // the render's seed
};

template <typename Real, typename Methods>
class PacketShader {
 public:
  PacketShader(const Group<Real>& group, SphereMethod method, const Shading<Real>& shading, const EffectSet& effects,
               const BounceLimits& limits, const OcclusionSettings& occlusion, const Vec3<Real>& background,
               const std::atomic<bool>& cancel)
      : m_group(group), m_method(method), m_shading(shading), m_effects(effects), m_limits(limits), m_occlusion(occlusion),
        m_background(background), m_cancel(cancel), m_minWeight(static_cast<Real>(limits.minWeight)) {}

  // The views of the scene's own spheres from its lights (SphereView), in the order of the shading's
  // lights: null where none was made (the light casts no shadows, more than
  // SphereSet::kMostLightViews lights cast shadows, fewer than SphereView::kMinLightSpheres spheres,
  // or a view that would not pay or could not be made).
  void useLightViews(std::vector<const SphereView<Real>*> views) { m_lightViews = std::move(views); }

  // The shading normal of a hit (Hit.h decides the side).
  Vec3<Real> shadingNormal(const Hit<Real>& hit, const Vec3<Real>& direction) const {
    return durer::shadingNormal(hit, direction, m_limits.shadeBack);
  }

  // rgb[k] = the colour ray k of `packet` sees (its search done, hits[k] its hit records); depth:
  // 0 for camera rays; weights: each ray's weight in the pixel (secondary rays below minWeight are
  // never spawned).
  void shade(const RayPacket<Real>& packet, const Hit<Real>* hits, const Real* weights, int depth, Vec3<Real>* rgb,
             RayCounters& counters) const {
    if (m_effects.occlusion) {
      alignas(64) Real open[kPacketSize];
      ambientOcclusion(packet, hits, open, counters);
      baseColors<true>(packet, hits, open, rgb);
    } else {
      baseColors<false>(packet, hits, nullptr, rgb);
    }
    if (m_effects.lit) {  // one instantiation per combination: no per-ray test of what is absent
      if (m_effects.specular) {
        m_effects.shadows ? addLights<true, true>(packet, hits, rgb, counters)
                          : addLights<true, false>(packet, hits, rgb, counters);
      } else {
        m_effects.shadows ? addLights<false, true>(packet, hits, rgb, counters)
                          : addLights<false, false>(packet, hits, rgb, counters);
      }
    }
    if (m_effects.bounces()) addBounces(packet, hits, weights, depth, rgb, counters);
    // Sums of non-negative finite terms can overflow, but never to NaN: saturated here, a brighter
    // colour stays finite through every factor that multiplies it on the way to the pixel.
    const Real brightest = std::numeric_limits<Real>::max();
    for (int k = 0; k < packet.count; ++k) rgb[k] = glm::min(rgb[k], Vec3<Real>(brightest));
  }

 private:
  static Vec3<Real> direction(const RayPacket<Real>& p, int k) { return Vec3<Real>(p.dx[k], p.dy[k], p.dz[k]); }

  // A hit's kd: its primitive's own colour if it has one, else its material's.
  static const Vec3<Real>& diffuse(const Hit<Real>& hit, const MaterialIn<Real>& m) {
    return hit.colored ? hit.color : m.diffuse;
  }

  // max(N·H, 0) for the half vector H = normalize(L + V). L + V is zero when the light lies exactly
  // behind the point as the viewer sees it (a back face lit from behind, the light on the camera ray):
  // H is undefined and normalising it gave NaN; no highlight faces both ways, so 0.
  static Real highlight(const Vec3<Real>& normal, const Vec3<Real>& half) {
    return glm::dot(half, half) > 0 ? std::max(glm::dot(normal, glm::normalize(half)), Real(0)) : Real(0);
  }

  // Σ over lights of max(N·L, 0)·light·kd (+ ks·light·max(N·H, 0)^exponent where N·L > 0), a light's
  // term dropped where the shadow ray toward it is blocked (a light of some size: scaled by the
  // cosine-weighted share of its shadow rays that nothing blocks); an area light is the mean of its samples'
  // terms, and a mirror sees it along its mirror direction (addMirrored), not in its glint.
  // One light (one sample) at a time, so that the shadow rays toward it go as one packet.
  template <bool Specular, bool Shadows>
  void addLights(const RayPacket<Real>& packet, const Hit<Real>* hits, Vec3<Real>* rgb, RayCounters& counters) const {
    Lit lit;
    for (int k = 0; k < packet.count; ++k) {
      if (!hits[k].isHit()) continue;
      ++counters.shadingEvaluations;
      const Vec3<Real> d = direction(packet, k);
      lit.normal[k] = shadingNormal(hits[k], d);
      lit.toViewer[k] = -glm::normalize(d);
    }
    bool keyed = false;
    for (size_t l = 0; l < m_shading.lights().size(); ++l) {
      const ShadingLight<Real>& light = m_shading.lights()[l];
      const SphereView<Real>* view = l < m_lightViews.size() ? m_lightViews[l] : nullptr;
      const bool area = light.kind == ShadingLight<Real>::Kind::Area;
      const bool soft = Shadows && light.shadows && !area && !light.viewable();
      if (!area && !soft) {
        addLight<Specular, Shadows, false>(packet, hits, lit, light, view, 0, 0, rgb, counters);
        continue;
      }
      if (!keyed) {
        for (int k = 0; k < packet.count; ++k) lit.key[k] = hits[k].isHit() ? rayKey(packet, k) : 0;
        keyed = true;
      }
      // Each light's samples scrambled apart from the others' and the AO's, which share the ray's key.
      const auto salt = static_cast<uint32_t>(mixBits(kLightSampleSalt + l));
      if (soft) {
        addSoftLight<Specular>(packet, hits, lit, light, salt, rgb, counters);
        continue;
      }
      // A rectangle large in a hit's sight is sampled by the solid angle it fills there (far off, by
      // area: the two agree, and the construction loses digits on a tiny solid angle). An ellipse
      // whose plane passes nearer a hit than 0.6 · √(a·b) (a, b its semi-axes) is sampled by its
      // rectangle's, points outside the ellipse carrying nothing: uniform over its area, the few
      // points near the hit would weigh far above the rest; farther off, area sampling's weights
      // vary less than that all-or-nothing. Where the two cross (16 samples, relative RMSE by the
      // rectangle / by area): under a disc of radius 0.5 9.9 % / 10.2 % at height 0.29, 9.1 % /
      // 9.1 % at 0.31 (the switch at 0.3); under an ellipse of semi-axes 1 and 0.2, 9.5 % / 10.9 % at
      // 0.25, 9.5 % / 8.5 % at 0.3 (the switch at 0.27).
      SphericalRectangle seen[kPacketSize];
      const bool bySolidAngle = light.perpendicular;
      if (bySolidAngle) {
        for (int k = 0; k < packet.count; ++k) {
          if (!hits[k].isHit()) continue;
          const Real height = glm::dot(hits[k].point - light.vector, light.axis);
          if (light.ellipse && !(height * height < light.nearSquared)) continue;
          seen[k] = light.seenFrom(hits[k].point);
          if (seen[k].solidAngle() < kLeastSampledSolidAngle) seen[k] = SphericalRectangle();
        }
      }
      for (int s = 0; s < light.samples; ++s) {
        addLight<Specular, Shadows, true>(packet, hits, lit, light, nullptr, static_cast<uint32_t>(s), salt, rgb,
                                          counters, bySolidAngle ? seen : nullptr);
      }
      addMirrored(packet, hits, light, rgb, counters);
    }
  }

  // What addLights knows of a packet's hits before the lights: shading normals, unit directions to
  // the viewer, and (for area lights and soft shadows) the scramble of each hit's light samples.
  struct Lit {
    alignas(64) Vec3<Real> normal[kPacketSize];
    alignas(64) Vec3<Real> toViewer[kPacketSize];
    alignas(64) uint32_t key[kPacketSize];
  };

  // A light's term at hit k for unit toLight (cosine = N·toLight > 0) and its falloff there: kd's and
  // the highlight's (none of an area light in a mirror's glint: kMirrorGlintExponent). Colours first:
  // their products are finite (Limits.h), so a huge falloff gives at most inf, never 0·inf, and
  // shade() saturates it.
  template <bool Specular>
  Vec3<Real> lightTerm(const Hit<Real>& h, const Lit& lit, int k, const ShadingLight<Real>& light,
                       const Vec3<Real>& toLight, Real cosine, Real falloff) const {
    const MaterialIn<Real>& m = m_shading.material(h.materialId);
    Vec3<Real> term = (cosine * falloff) * (light.color * diffuse(h, m));
    if constexpr (Specular) {
      if (light.kind == ShadingLight<Real>::Kind::Area && glints(m)) return term;
      Real exponent = m.exponent, scale = 1;
      if (light.size > 0) spreadOver(light.angularRadius2(h.point), exponent, scale);
      term += (std::pow(highlight(lit.normal[k], toLight + lit.toViewer[k]), exponent) * (falloff * scale)) *
              (light.color * m.specular);
    }
    return term;
  }

  // A highlight of a light of some size (angular radius α, α2 = α²) spreads over it: the lobe's
  // half-vector spread (Blinn-Phong's variance ~1/n an axis) grows by the light's disc as a Gaussian
  // of its half-maximum width would (the half vector moves by α / 2: α² / (8 ln 2)), and its peak
  // drops as the normalised lobe's (n + 8) / 8, keeping its light: a 0.5 m Point light 6 m off
  // glints as Cycles' (its sphere's image) instead of 11x brighter at the peak.
  static void spreadOver(Real alpha2, Real& exponent, Real& scale) {
    const Real widened = exponent / (1 + exponent * alpha2 / Real(8 * kLn2));
    scale = (widened + 8) / (exponent + 8);
    exponent = widened;
  }

  // Where a shadow ray toward unit toLight leaves hit k.
  Vec3<Real> shadowOrigin(const Hit<Real>& h, const Lit& lit, int k, const Vec3<Real>& toLight, Real cosine) const {
    return offsetRayOrigin(h.point, h.geometricNormal, h.pointError, toLight) +
           terminatorOffset(h, lit.normal[k], cosine, toLight);
  }

  // One light's terms (Area: its sample s, a point of its surface for each hit, scrambled by the
  // hit's key ^ salt; by solid angle where seen[k] has one) added to rgb, through a packet of shadow
  // rays where it casts shadows.
  template <bool Specular, bool Shadows, bool Area>
  void addLight(const RayPacket<Real>& packet, const Hit<Real>* hits, const Lit& lit, const ShadingLight<Real>& light,
                const SphereView<Real>* view, uint32_t s, uint32_t salt, Vec3<Real>* rgb, RayCounters& counters,
                const SphericalRectangle* seen = nullptr) const {
    RayPacket<Real> shadow;
    alignas(64) int pixelOf[kPacketSize];
    alignas(64) Vec3<Real> term[kPacketSize];
    shadow.count = 0;
    for (int k = 0; k < packet.count; ++k) {
      if (!hits[k].isHit()) continue;
      const Hit<Real>& h = hits[k];
      Vec3<Real> at, toLight;
      Real falloff;
      if constexpr (Area) {
        double a, b;
        PixelSampler::hitSample(s, lit.key[k] ^ salt, a, b);
        const double solidAngle = seen ? seen[k].solidAngle() : 0;
        at = solidAngle > 0 ? toReal<Real>(seen[k].point(a, b)) : light.surfacePoint(a, b);
        if (solidAngle > 0 && light.ellipse && !light.inside(at)) continue;
        const Vec3<Real> w = at - h.point;
        const Real d2 = glm::dot(w, w);
        const Real d = std::sqrt(d2);
        if (!(d > 0)) continue;  // the hit is that point (or too near it for a direction)
        toLight = w / d;
        falloff = solidAngle > 0 ? light.solidAngleFalloff(solidAngle) : light.areaFalloff(toLight, d2);
        if (!(falloff > 0)) continue;  // behind the surface
      } else {
        toLight = light.toLight(h.point);
      }
      const Real cosine = glm::dot(lit.normal[k], toLight);
      if (!(cosine > 0)) continue;
      if constexpr (!Area) falloff = light.falloff(h.point, toLight);
      const Vec3<Real> contribution = lightTerm<Specular>(h, lit, k, light, toLight, cosine, falloff);
      if (!(Shadows && light.shadows)) {
        rgb[k] += contribution;
        continue;
      }
      const int j = shadow.count++;
      shadow.from[j] = packet.prim[k];
      const Vec3<Real> origin = shadowOrigin(h, lit, k, toLight, cosine);
      Vec3<Real> toward;
      if constexpr (Area) {
        toward = at - origin;
      } else {
        toward = light.shadowDirection(origin);
      }
      shadow.ox[j] = origin.x, shadow.oy[j] = origin.y, shadow.oz[j] = origin.z;
      shadow.dx[j] = toward.x, shadow.dy[j] = toward.y, shadow.dz[j] = toward.z;
      pixelOf[j] = k;
      term[j] = contribution;
    }
    shadow.leaving = true;
    addUnblocked(shadow, light, view, pixelOf, term, rgb, counters);
  }

  // Whether a material's Phong lobe is its mirror's glint (kMirrorGlintExponent).
  static bool glints(const MaterialIn<Real>& m) {
    return maxComponent(m.reflective) > 0 && m.exponent >= static_cast<Real>(kMirrorGlintExponent);
  }

  // An area light as a mirror shows it: where hit k's mirror direction (its mirror ray's, bounces or
  // not: it is direct light, as a highlight is) meets the light's front, reflective · its radiance,
  // π·color / area (the radiance whose cosine-weighted integral gives the samples' terms: a white
  // floor under a light filling its sky and a white mirror show the same), unless something stands
  // in the way — whether or not the light casts shadows: the mirror sees what it faces. Exact where
  // a glint of its samples would be speckled: a mirror's lobe is a direction, which a handful of
  // points on the light almost never meet.
  void addMirrored(const RayPacket<Real>& packet, const Hit<Real>* hits, const ShadingLight<Real>& light,
                   Vec3<Real>* rgb, RayCounters& counters) const {
    RayPacket<Real> shadow;
    alignas(64) int pixelOf[kPacketSize];
    alignas(64) Vec3<Real> term[kPacketSize];
    shadow.count = 0;
    // Finite (a light of a tiny area: the largest number), so that a product with a black channel is 0.
    const Real perArea = std::min(static_cast<Real>(kPi) / light.area, std::numeric_limits<Real>::max());
    for (int k = 0; k < packet.count; ++k) {
      if (!hits[k].isHit()) continue;
      const Hit<Real>& h = hits[k];
      const MaterialIn<Real>& m = m_shading.material(h.materialId);
      if (!(maxComponent(m.reflective) > 0)) continue;
      Vec3<Real> origin, r;
      mirrorRay(h, glm::normalize(direction(packet, k)), origin, r);
      Vec3<Real> toward;
      if (!light.mirroredFrom(origin, r, toward)) continue;
      const int j = shadow.count++;
      shadow.ox[j] = origin.x, shadow.oy[j] = origin.y, shadow.oz[j] = origin.z;
      shadow.dx[j] = toward.x, shadow.dy[j] = toward.y, shadow.dz[j] = toward.z;
      pixelOf[j] = k;
      term[j] = perArea * (m.reflective * light.color);
    }
    addUnblocked(shadow, light, nullptr, pixelOf, term, rgb, counters);
  }

  // A light of some size casting shadows (a point or spot light's sphere, a sun's disc): its term as
  // addLight's, times the share of its light that reaches the hit — of light.samples shadow rays per
  // hit, spread uniformly over the cone of directions it fills seen from the ray's origin (each
  // carrying the same radiance), those nothing blocks, each weighted by its cosine with the shading
  // normal. Where none is blocked the share is 1 exactly: the hard light's image, without noise. No
  // view: the rays do not all pass through the light's centre (or along its direction) as a view's must.
  template <bool Specular>
  void addSoftLight(const RayPacket<Real>& packet, const Hit<Real>* hits, const Lit& lit,
                    const ShadingLight<Real>& light, uint32_t salt, Vec3<Real>* rgb, RayCounters& counters) const {
    alignas(64) int pixelOf[kPacketSize];
    alignas(64) Real open[kPacketSize], all[kPacketSize];  // the cosines of the unblocked rays, of all
    alignas(64) Vec3<Real> term[kPacketSize], origin[kPacketSize];
    ShadowCone cone[kPacketSize];
    const bool sun = light.kind == ShadingLight<Real>::Kind::Directional;
    int count = 0;
    for (int k = 0; k < packet.count; ++k) {
      if (!hits[k].isHit()) continue;
      const Hit<Real>& h = hits[k];
      const Vec3<Real> toLight = light.toLight(h.point);
      const Real cosine = glm::dot(lit.normal[k], toLight);
      if (!(cosine > 0)) continue;
      const Vec3<Real> t = lightTerm<Specular>(h, lit, k, light, toLight, cosine, light.falloff(h.point, toLight));
      if (!(maxComponent(t) > 0)) continue;  // outside a spot's cone, or a black surface: nothing to shadow
      const int j = count++;
      pixelOf[j] = k;
      term[j] = t;
      open[j] = all[j] = 0;
      origin[j] = shadowOrigin(h, lit, k, toLight, cosine);
      cone[j] = sun ? ShadowCone::sunward(light.vector, light.spread)
                    : ShadowCone::sphere(light.vector - origin[j], light.spread);
    }
    RayPacket<Real> shadow;
    alignas(64) Real weight[kPacketSize];
    for (int s = 0; s < light.samples && count > 0; ++s) {
      shadow.count = count;
      for (int j = 0; j < count; ++j) {
        double a, b;
        PixelSampler::hitSample(static_cast<uint32_t>(s), lit.key[pixelOf[j]] ^ salt, a, b);
        Vec3<Real> unit;
        const Vec3<Real> toward = cone[j].ray(a, b, unit);
        weight[j] = std::max(glm::dot(lit.normal[pixelOf[j]], unit), Real(0));
        all[j] += weight[j];
        shadow.ox[j] = origin[j].x, shadow.oy[j] = origin[j].y, shadow.oz[j] = origin[j].z;
        shadow.dx[j] = toward.x, shadow.dy[j] = toward.y, shadow.dz[j] = toward.z;
      }
      traceShadows(shadow, light, nullptr, counters);
      for (int j = 0; j < count; ++j) open[j] += shadow.prim[j] == kNoPrimitive ? weight[j] : Real(0);
    }
    // A hit whose samples all fell below its horizon (the cone crossing it: every weight 0) learnt
    // nothing of its light: the hard light's ray toward the centre decides.
    int hard = 0;
    for (int j = 0; j < count; ++j) {
      if (all[j] > 0) {
        if (open[j] > 0) rgb[pixelOf[j]] += (open[j] / all[j]) * term[j];
        continue;
      }
      const Vec3<Real> toward = light.shadowDirection(origin[j]);
      shadow.ox[hard] = origin[j].x, shadow.oy[hard] = origin[j].y, shadow.oz[hard] = origin[j].z;
      shadow.dx[hard] = toward.x, shadow.dy[hard] = toward.y, shadow.dz[hard] = toward.z;
      pixelOf[hard] = pixelOf[j], term[hard] = term[j];
      ++hard;
    }
    shadow.count = hard;
    addUnblocked(shadow, light, nullptr, pixelOf, term, rgb, counters);
  }

  // The cone of directions a light of some size fills seen from a shadow ray's origin, and the rays
  // toward it: a sphere's (radius r at distance d: sin α = r / d) or a sun's (its half angle α).
  struct ShadowCone {
    Vec3<Real> axis, tangent, bitangent;  // unit: toward the light's centre (along the sun), and across
    double oneMinusCos = 0;               // 1 − cos α (0: the one ray along the axis)
    Real distance = 0, radius = 0;        // a sphere's: its centre's distance and its radius
    bool sun = false;

    // A sphere of radius r whose centre lies at `toCentre` (nonzero: the origin is offset from the hit,
    // never at the light) from the origin; from inside it, the one ray to the centre (nothing between
    // can block its light).
    static ShadowCone sphere(const Vec3<Real>& toCentre, Real r) {
      ShadowCone c;
      c.distance = glm::length(toCentre);
      c.axis = toCentre / c.distance;
      const double sine = static_cast<double>(r) / static_cast<double>(c.distance);
      if (sine < 1) c.oneMinusCos = sine * sine / (1 + std::sqrt(1 - sine * sine)), c.radius = r;
      orthonormalFrame(c.axis, c.tangent, c.bitangent);
      return c;
    }
    static ShadowCone sunward(const Vec3<Real>& direction, double oneMinusCos) {
      ShadowCone c;
      c.axis = direction, c.oneMinusCos = oneMinusCos, c.sun = true;
      orthonormalFrame(c.axis, c.tangent, c.bitangent);
      return c;
    }

    // The shadow ray for (a, b) in [0, 1)^2, uniform over the cone's solid angle (the unit disc's
    // concentric map lifted onto the cap: cos θ = 1 − ρ²·(1 − cos α)), and its unit direction `w`:
    // a sun's is w (t up to inf), a sphere's ends on the sphere's near side at t = 1.
    Vec3<Real> ray(double a, double b, Vec3<Real>& w) const {
      double x, y;
      concentricDisc(a, b, x, y);
      const double rho2 = x * x + y * y;
      const double h = rho2 * oneMinusCos;                 // 1 − cos θ
      const double sine = std::sqrt(h * (2 - h));          // sin θ
      const double scale = rho2 > 0 ? sine / std::sqrt(rho2) : 0;
      w = static_cast<Real>(x * scale) * tangent + static_cast<Real>(y * scale) * bitangent +
          static_cast<Real>(1 - h) * axis;
      if (sun) return w;
      const Real across = distance * static_cast<Real>(sine);
      const Real beyond = std::sqrt(std::max(radius * radius - across * across, Real(0)));
      return (distance * static_cast<Real>(1 - h) - beyond) * w;  // d·cos θ − √(r² − d²·sin² θ)
    }
  };

  // Traces the shadow rays of `shadow` toward `light`, t in (0, shadowTMax()): then prim[j] is
  // kNoPrimitive where nothing blocks ray j. Point, spot and area samples sit at t = 1, which needs
  // no epsilon.
  void traceShadows(RayPacket<Real>& shadow, const ShadingLight<Real>& light, const SphereView<Real>* view,
                    RayCounters& counters) const {
    // t > 0: an offset of a few ulps of a number near 0 can underflow to t = -0 in the plane test.
    shadow.tMin = std::numeric_limits<Real>::denorm_min();
    shadow.tMax = light.shadowTMax();
    shadow.view = view;
    counters.intersectionTests += m_group.template occluded<Methods>(m_method, shadow, &m_cancel);
    counters.shadow += shadow.count;
  }

  // The shadow rays of `shadow` traced (none: nothing to do), term[j] added to rgb[pixelOf[j]] for
  // each that nothing blocks.
  void addUnblocked(RayPacket<Real>& shadow, const ShadingLight<Real>& light, const SphereView<Real>* view,
                    const int* pixelOf, const Vec3<Real>* term, Vec3<Real>* rgb, RayCounters& counters) const {
    if (shadow.count == 0) return;
    traceShadows(shadow, light, view, counters);
    for (int j = 0; j < shadow.count; ++j) {
      if (shadow.prim[j] == kNoPrimitive) rgb[pixelOf[j]] += term[j];
    }
  }

  static constexpr uint64_t kLightSampleSalt = 0x9e3779b97f4a7c15ull;
  static constexpr double kLn2 = 0.69314718055994530942;
  // Below this many steradians a rectangle is sampled by area (pbrt-v4's threshold).
  static constexpr double kLeastSampledSolidAngle = 1e-3;

  // Emission plus ambient · kd (lit; with Occlusion, the ambient light scaled by open[k]) or kd
  // (flat) of each hit, the background for misses.
  template <bool Occlusion>
  void baseColors(const RayPacket<Real>& packet, const Hit<Real>* hits, const Real* open, Vec3<Real>* rgb) const {
    for (int k = 0; k < packet.count; ++k) {
      if (!hits[k].isHit()) {
        rgb[k] = m_background;
        continue;
      }
      const MaterialIn<Real>& m = m_shading.material(hits[k].materialId);
      const Vec3<Real>& kd = diffuse(hits[k], m);
      if constexpr (Occlusion) {
        rgb[k] = m.emission + (open[k] * m_shading.ambient()) * kd;  // occlusion implies lit
      } else {
        rgb[k] = m.emission + (m_effects.lit ? m_shading.ambient() * kd : kd);
      }
    }
  }

  // open[k] = the unoccluded fraction of the cosine-weighted hemisphere about hit k's shading normal
  // within the AO distance (1 for misses and black diffuse), from m_occlusion.samples any-hit rays
  // per hit: sample s of every hit goes in one packet.
  void ambientOcclusion(const RayPacket<Real>& packet, const Hit<Real>* hits, Real* open, RayCounters& counters) const {
    alignas(64) Vec3<Real> normal[kPacketSize], tangent[kPacketSize], bitangent[kPacketSize];
    alignas(64) uint32_t key[kPacketSize];
    alignas(64) int hitOf[kPacketSize];
    int count = 0;
    for (int k = 0; k < packet.count; ++k) {
      open[k] = 1;
      if (!hits[k].isHit() || maxComponent(diffuse(hits[k], m_shading.material(hits[k].materialId))) <= 0) continue;
      const int j = count++;
      hitOf[j] = k;
      normal[j] = shadingNormal(hits[k], direction(packet, k));
      orthonormalFrame(normal[j], tangent[j], bitangent[j]);
      key[j] = rayKey(packet, k);
      open[k] = 0;
    }
    if (count == 0) return;
    RayPacket<Real> rays;
    rays.count = count;
    rays.tMin = std::numeric_limits<Real>::denorm_min();  // t > 0, as for shadow rays
    rays.tMax = static_cast<Real>(m_occlusion.distance);
    for (int s = 0; s < m_occlusion.samples; ++s) {
      for (int j = 0; j < count; ++j) {
        const Hit<Real>& h = hits[hitOf[j]];
        double u, v;
        PixelSampler::hitSample(static_cast<uint32_t>(s), key[j], u, v);
        double x, y, z;
        cosineHemisphere(u, v, x, y, z);
        const Vec3<Real> w = static_cast<Real>(x) * tangent[j] + static_cast<Real>(y) * bitangent[j] +
                             static_cast<Real>(z) * normal[j];
        const Vec3<Real> origin = offsetRayOrigin(h.point, h.geometricNormal, h.pointError, w);
        rays.ox[j] = origin.x, rays.oy[j] = origin.y, rays.oz[j] = origin.z;
        rays.dx[j] = w.x, rays.dy[j] = w.y, rays.dz[j] = w.z;
      }
      counters.intersectionTests += m_group.template occluded<Methods>(m_method, rays, &m_cancel);
      counters.ambientOcclusion += count;
      for (int j = 0; j < count; ++j) open[hitOf[j]] += rays.prim[j] == kNoPrimitive ? Real(1) : Real(0);
    }
    const Real perSample = Real(1) / static_cast<Real>(m_occlusion.samples);
    for (int j = 0; j < count; ++j) open[hitOf[j]] *= perSample;
  }

  // A cosine-distributed unit direction (x, y, z), z up, for (u, v) in [0, 1)^2 (Malley's method: a
  // uniform point of the unit disc lifted onto the hemisphere).
  static void cosineHemisphere(double u, double v, double& x, double& y, double& z) {
    concentricDisc(u, v, x, y);
    z = std::sqrt(std::max(1 - x * x - y * y, 0.0));
  }

  // t, b such that (t, b, n) is a right-handed orthonormal frame, for unit n (Duff et al. 2017: no
  // branch on which axis n is closest to; it jumps only where n.z changes sign).
  static void orthonormalFrame(const Vec3<Real>& n, Vec3<Real>& t, Vec3<Real>& b) {
    const Real sign = std::copysign(Real(1), n.z);
    const Real a = -1 / (sign + n.z), c = n.x * n.y * a;
    t = Vec3<Real>(1 + sign * n.x * n.x * a, sign * c, -sign * n.x);
    b = Vec3<Real>(c, sign + n.y * n.y * a, -n.y);
  }

  // The Owen scramble of a hit's AO samples: a hash of the render's seed and the ray that found the
  // hit. That ray is a pure function of (seed, pixel, sample) and the bounces before it, so the
  // samples, like the pixel sampler's, depend on neither threads nor tiling.
  uint32_t rayKey(const RayPacket<Real>& p, int k) const {
    uint64_t key = m_occlusion.seed;
    for (const Real c : {p.ox[k], p.oy[k], p.oz[k], p.dx[k], p.dy[k], p.dz[k]}) {
      typename FloatBits<Real>::Bits bits;
      std::memcpy(&bits, &c, sizeof bits);
      key = mixBits(key ^ bits);
    }
    return static_cast<uint32_t>(key);
  }

  // The mirror ray of hit h for the unit direction d that found it: its origin and direction (the
  // same for the shading normal and its opposite), as a bounce traces it and addMirrored tests it.
  static void mirrorRay(const Hit<Real>& h, const Vec3<Real>& d, Vec3<Real>& origin, Vec3<Real>& r) {
    r = glm::reflect(d, h.normal);
    origin = offsetRayOrigin(h.point, h.geometricNormal, h.pointError, r);
  }

  // A secondary ray waiting to be traced: where it starts and goes, whose colour it adds to, how much.
  struct Child {
    Vec3<Real> origin, direction;
    int parent;
    int32_t from;  // the packed primitive it leaves (RayPacket::from)
    Vec3<Real> factor;  // the reflective or transparent colour it is seen through
    Real weight;
  };

  void addBounces(const RayPacket<Real>& packet, const Hit<Real>* hits, const Real* weights, int depth,
                  Vec3<Real>* rgb, RayCounters& counters) const {
    Child children[2 * kPacketSize];
    int count = 0;
    for (int k = 0; k < packet.count; ++k) {
      if (!hits[k].isHit()) continue;
      const MaterialIn<Real>& m = m_shading.material(hits[k].materialId);
      const Vec3<Real> d = glm::normalize(direction(packet, k));
      const bool reflective = m_effects.reflection && maxComponent(m.reflective) > 0;
      const bool transparent = m_effects.refraction && maxComponent(m.transparent) > 0;
      if (reflective && spawnable(weights[k] * maxComponent(m.reflective), depth, counters)) {
        Vec3<Real> origin, r;
        mirrorRay(hits[k], d, origin, r);
        children[count++] = {origin, r, k, packet.prim[k], m.reflective, weights[k] * maxComponent(m.reflective)};
        ++counters.reflection;
      }
      if (transparent && spawnable(weights[k] * maxComponent(m.transparent), depth, counters)) {
        Vec3<Real> t, about;
        if (!refract(d, hits[k], m.ior, t, about)) {
          t = glm::reflect(d, about);
          ++counters.totalInternalReflections;
        }
        children[count++] = {offsetRayOrigin(hits[k].point, hits[k].geometricNormal, hits[k].pointError, t), t, k,
                             packet.prim[k], m.transparent, weights[k] * maxComponent(m.transparent)};
        ++counters.refraction;
      }
    }
    for (int first = 0; first < count; first += kPacketSize) {
      traceChildren(children + first, std::min(kPacketSize, count - first), depth + 1, rgb, counters);
    }
  }

  void traceChildren(const Child* children, int count, int depth, Vec3<Real>* rgb, RayCounters& counters) const {
    RayPacket<Real> packet;
    packet.count = count;
    packet.tMin = std::numeric_limits<Real>::denorm_min();  // t > 0, as for shadow rays
    packet.tMax = std::numeric_limits<Real>::infinity();
    alignas(64) Real weights[kPacketSize];
    for (int j = 0; j < count; ++j) {
      const Child& c = children[j];
      packet.ox[j] = c.origin.x, packet.oy[j] = c.origin.y, packet.oz[j] = c.origin.z;
      packet.dx[j] = c.direction.x, packet.dy[j] = c.direction.y, packet.dz[j] = c.direction.z;
      packet.from[j] = c.from;
      weights[j] = c.weight;
    }
    packet.leaving = true;
    counters.intersectionTests += m_group.template intersect<Methods>(m_method, packet, &m_cancel);
    if (m_cancel.load(std::memory_order_relaxed)) return;
    HitRecords<Real, kPacketSize> hits;
    const auto make = [&](int j, const auto& f) { hits.make(j, f); };
    if (!m_group.makeUniformHits(packet, make)) {
      m_group.forEachHitRecord(packet, count, [&](int j) { make(j, [&] { return m_group.hit(packet, j); }); });
    }
    alignas(64) Vec3<Real> seen[kPacketSize];
    shade(packet, hits.data(), weights, depth, seen, counters);
    for (int j = 0; j < count; ++j) rgb[children[j].parent] += children[j].factor * seen[j];
  }

  // Whether a child of this weight at depth + 1 is traced; counts why not.
  bool spawnable(Real weight, int depth, RayCounters& counters) const {
    if (depth + 1 > m_limits.maxBounces) {
      ++counters.cutByDepth;
      return false;
    }
    if (!(weight >= m_minWeight)) {
      ++counters.cutByWeight;
      return false;
    }
    return true;
  }

  // Where a smooth triangle's shadow ray toward unit toLight starts beyond the face (Cycles'
  // shadow_ray_offset with its default Geometry Offset, 0.1): near the terminator, where the
  // shading normal (`shaded`, cosine = shaded·toLight) or the face turns from the light, on the
  // smooth surface the corners' normals describe (Hit::lift) instead of the flat face, whose
  // neighbours would shadow it (toward a light below the face too: from there the ray may meet the
  // face itself, as in Cycles, which then skips no primitive). Zero elsewhere.
  static Vec3<Real> terminatorOffset(const Hit<Real>& hit, const Vec3<Real>& shaded, Real cosine,
                                     const Vec3<Real>& toLight) {
    constexpr Real kCutoff = Real(0.1);
    if (hit.lift == 0) return Vec3<Real>(0);
    const Real side = glm::dot(shaded, hit.normal) < 0 ? Real(-1) : Real(1);  // the normal as shaded
    const Real faceCosine = side * glm::dot(hit.geometricNormal, toLight);
    const Real amount = cosine < kCutoff ? std::clamp(2 - (faceCosine + cosine) / kCutoff, Real(0), Real(1))
                                         : std::clamp(1 - faceCosine / kCutoff, Real(0), Real(1));
    return (amount * static_cast<Real>(hit.lift)) * hit.normal;
  }

  // Snell's law through the surface of `hit` for unit d: entering where d meets its face from the
  // front (η = 1/ior), leaving otherwise (η = ior; facingSign: the face decides, not a smooth normal),
  // about `facing`, its normal turned to the side d comes from, or the face's own where a smooth
  // one leans past the ray (total internal reflection reflects about it too). False on total
  // internal reflection.
  static bool refract(const Vec3<Real>& d, const Hit<Real>& hit, Real ior, Vec3<Real>& t, Vec3<Real>& facing) {
    const Real side = facingSign(glm::dot(d, hit.geometricNormal), true);
    const bool entering = side > 0;
    const Vec3<Real> shaded = side * hit.normal;
    facing = glm::dot(d, shaded) < 0 ? shaded : side * hit.geometricNormal;
    const Real eta = entering ? 1 / ior : ior;
    const Real cosIn = -glm::dot(d, facing);
    const Real k = 1 - eta * eta * (1 - cosIn * cosIn);
    if (k < 0) return false;
    t = eta * d + (eta * cosIn - std::sqrt(k)) * facing;
    return true;
  }

  static Real maxComponent(const Vec3<Real>& v) { return std::max(v.x, std::max(v.y, v.z)); }

  const Group<Real>& m_group;
  SphereMethod m_method;  // one of Methods
  const Shading<Real>& m_shading;
  EffectSet m_effects;
  BounceLimits m_limits;
  OcclusionSettings m_occlusion;
  Vec3<Real> m_background;  // what a secondary ray that misses sees (RGB)
  const std::atomic<bool>& m_cancel;
  std::vector<const SphereView<Real>*> m_lightViews;
  Real m_minWeight;
};

}  // namespace durer
