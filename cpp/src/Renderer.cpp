#include "durer/render/Renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "durer/render/Kernels.h"
#include "durer/scene/Limits.h"
#include "durer/scene/Validate.h"

namespace durer {

void validate(const RenderSettings& s) {
  const auto requireCount = [](int value, const char* field) {
    if (value < 1 || value > kRenderLimits.side) {
      fail(std::string(field) + " must be in [1, " + std::to_string(kRenderLimits.side) + "], got " + std::to_string(value));
    }
  };
  requireCount(s.width, "width");
  requireCount(s.height, "height");
  requireCount(s.samplesPerPixel, "spp");
  if (s.threads < 0) fail("threads must be >= 0 (0: all cores), got " + std::to_string(s.threads));
  unsigned known = 0;
  std::string names;
  for (const OptionName<PassFlags>& pass : kPassNames) {
    known |= pass.value;
    names += (names.empty() ? "" : ", ") + std::string(pass.name);
  }
  if (s.passes == 0 || (s.passes & ~known) != 0) fail("passes must name at least one of " + names);
  requireCount(s.minSamples, "min_spp");
  if (!(std::isfinite(s.timeLimit) && s.timeLimit >= 0)) fail("time_limit must be finite and >= 0 (0: none), got " + show(s.timeLimit));
  if (!(std::isfinite(s.targetError) && s.targetError > 0)) fail("target_error must be finite and > 0, got " + show(s.targetError));
  if (s.maxBounces < 0 || s.maxBounces > kRenderLimits.maxBounces) {
    fail("max_bounces must be in [0, " + std::to_string(kRenderLimits.maxBounces) + "], got " + std::to_string(s.maxBounces));
  }
  if (!(std::isfinite(s.minWeight) && s.minWeight >= 0)) fail("min_weight must be finite and >= 0, got " + show(s.minWeight));
  const RenderSettings::AmbientOcclusion& ao = s.ambientOcclusion;
  if (ao.on && (ao.samples < 1 || ao.samples > kRenderLimits.raysPerHit)) {
    fail("ambient_occlusion samples must be in [1, " + std::to_string(kRenderLimits.raysPerHit) + "], got " +
         std::to_string(ao.samples));
  }
  if (ao.on && !(ao.distance > 0)) fail("ambient_occlusion distance must be > 0 (inf: unlimited), got " + show(ao.distance));
  const RenderSettings::Region& r = s.region;
  if (r.width != 0 && !(r.x >= 0 && r.y >= 0 && r.width >= 1 && r.height >= 1 && r.x <= s.width - r.width &&
                        r.y <= s.height - r.height)) {
    fail("region must lie inside the " + std::to_string(s.width) + "x" + std::to_string(s.height) + " image");
  }
}


namespace {

// What the scene calls for, given what is asked: decided once, before rendering.
EffectSet effectsFor(const Scene& scene, const RenderSettings& settings, const RenderTargets& targets) {
  EffectSet e;
  if (!targets.color) return e;  // depth and normals need no shading at all
  const auto any = [&](auto field) {
    return std::any_of(scene.materials().begin(), scene.materials().end(), [&](const Material& m) {
      const Vec3d v = m.*field;
      return v.x > 0 || v.y > 0 || v.z > 0;
    });
  };
  // Lights casting shadows whose rays views could serve (all through the light's point, or along its
  // direction), and whether some light's rays go all over it instead (an area light, a light of some size).
  const auto hard = [](const auto& lights) {
    return int(std::count_if(lights.begin(), lights.end(),
                             [](const auto& l) { return l.shadows && !l.soft.on(); }));
  };
  const auto sampled = [](const auto& lights) {
    return std::any_of(lights.begin(), lights.end(),
                       [](const auto& l) { return l.shadows && l.soft.on(); });
  };
  e.lit = scene.lit();
  e.specular = e.lit && any(&Material::specular);
  if (e.lit) {
    e.viewedLights = hard(scene.directionalLights()) + hard(scene.pointLights()) + hard(scene.spotLights());
    const auto& areas = scene.areaLights();
    e.sampledShadows = sampled(scene.directionalLights()) || sampled(scene.pointLights()) ||
                       sampled(scene.spotLights()) ||
                       std::any_of(areas.begin(), areas.end(), [](const AreaLight& l) { return l.shadows; });
    e.mirroredLights = !areas.empty() && any(&Material::reflective);
  }
  e.shadows = e.viewedLights > 0 || e.sampledShadows;
  e.reflection = settings.maxBounces > 0 && any(&Material::reflective);
  e.refraction = settings.maxBounces > 0 && any(&Material::transparent);
  const Vec3d& ambient = scene.ambient();
  e.colors = scene.colored();
  e.occlusion = e.lit && settings.ambientOcclusion.on && (ambient.x > 0 || ambient.y > 0 || ambient.z > 0) &&
                (any(&Material::diffuse) || e.colors);
  return e;
}

// The most rays one camera ray's tree of reflections and refractions may hold, and the most
// allowed: a render past it would not end in any time a user waits (a material that reflects and
// refracts at full strength doubles the rays at each of max_bounces levels). Level k holds at most
// 2^k rays where a material spawns both, and, as a ray's children's weights add up to at most c
// times its own (c the largest reflective + transparent of one material, largest components), at
// most c^k / min_weight rays of weight min_weight or more, the only ones spawned. 2^17 admits the
// deepest max_bounces (kRenderLimits.maxBounces, 1000) at the default min_weight (0.01) for materials that do not add light
// (c <= 1: at most 100 rays a level).
constexpr double kMostRaysPerCameraRay = 1 << 17;

void requireBoundedBounces(const Scene& scene, const RenderSettings& settings, const EffectSet& effects) {
  double c = 0;
  bool branching = false;
  for (const Material& m : scene.materials()) {  // colours are >= 0: their largest component is maxAbs
    const double reflective = effects.reflection ? maxAbs(m.reflective) : 0;
    const double transparent = effects.refraction ? maxAbs(m.transparent) : 0;
    branching = branching || (reflective > 0 && transparent > 0);
    c = std::max(c, reflective + transparent);
  }
  if (!branching) return;  // a chain: max_bounces + 1 rays at most
  double rays = 0, level = 1, weight = 1;  // the bound at level k: 2^k, and c^k
  for (int k = 0; k <= settings.maxBounces && rays <= kMostRaysPerCameraRay; ++k) {
    rays += settings.minWeight > 0 ? std::min(level, weight / settings.minWeight) : level;
    level *= 2, weight *= c;
  }
  if (rays <= kMostRaysPerCameraRay) return;
  std::ostringstream message;
  message << "max_bounces=" << settings.maxBounces << " with min_weight=" << settings.minWeight
          << " lets one camera ray spawn more than " << kMostRaysPerCameraRay
          << " reflected and refracted rays (a material both reflects and refracts, reflective + transparent up to "
          << c << "): lower max_bounces or raise min_weight";
  fail(message.str());
}

}  // namespace

RenderStats render(const Scene& scene, const CameraSpec& camera, const RenderSettings& settings,
                   const RenderTargets& targets, JobControl& control, const std::function<void()>& poll) {
  validate(camera);
  validate(settings);
  const NumericLimits& limits = limitsFor(settings.precision);
  scene.requireFits(limits, requireRaysWithin(camera, settings.width, settings.height, limits));
  const auto start = std::chrono::steady_clock::now();
  const EffectSet effects = effectsFor(scene, settings, targets);
  requireBoundedBounces(scene, settings, effects);
  const RenderJob job{scene, camera, settings, targets, effects, control, poll};
  const bool single = settings.precision == Precision::Float;
  RenderStats stats;
  const KernelSet& set = kernelsFor(settings.sphereMethod);
  stats = single ? set.renderFloat(job) : set.renderDouble(job);
  stats.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

}  // namespace durer
