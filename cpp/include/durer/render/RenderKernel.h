#pragma once
// A render's kernel for one precision and sphere method: the tiles of TileRenderer.h, or the rounds
// of AdaptiveSampler.h, on the render's threads. Instantiated by the kernel translation units
// (src/kernels: the robust kernels once per instruction set, the lecture's once).
#include <algorithm>
#include <memory>
#include <optional>
#include <vector>

#include "durer/render/AdaptiveSampler.h"
#include "durer/render/TileRenderer.h"

namespace durer {

template <typename Real, typename Methods>
RenderStats renderWith(const RenderJob& job) {
  const Scene& scene = job.scene;
  const CameraSpec& spec = job.camera;
  const RenderSettings& settings = job.settings;
  const RenderTargets& targets = job.targets;
  JobControl& control = job.control;
  const EffectSet& effects = job.effects;
  // Camera rays search the scene's own spheres through the camera's view, and a light's shadow rays
  // through the light's (for a few lights), never their hierarchy: a render with no other rays
  // (bounces, occlusion, shadow rays all over a light, mirrors' rays toward area lights) is prepared
  // without it (at 10M spheres most of a first render's time), unless a view is refused.
  const bool viewsOnly = !effects.bounces() && !effects.occlusion && !effects.sampledShadows &&
                         !effects.mirroredLights &&
                         tiles::TileRenderer<Real, Methods>::viewsLights(effects);
  std::shared_ptr<const Group<Real>> prepared = scene.prepared<Real>(settings.threads, !viewsOnly);
  std::optional<tiles::TileRenderer<Real, Methods>> made;
  made.emplace(scene, *prepared, spec, settings, targets, effects, control.cancel);
  if (viewsOnly && !made->viewsSpheres()) {
    made.reset();
    prepared = scene.prepared<Real>(settings.threads, true);
    made.emplace(scene, *prepared, spec, settings, targets, effects, control.cancel);
  }
  const tiles::TileRenderer<Real, Methods>& tiles = *made;
  RenderStats stats;
  stats.effects = effects;
  // A work item is a tile (of the pixels sampled): more threads than tiles would have nothing to do
  // (not started).
  const int asked = settings.threads > 0 ? settings.threads : defaultThreadCount();
  if (settings.sampler == SamplerKind::Adaptive) {
    tiles::AdaptiveSampler<Real, Methods> adaptive(tiles, settings, targets);
    stats.threads = workersFor(asked, adaptive.tileCount());
    stats.counters = adaptive.render(stats.threads, control, job.poll, stats.adaptive);
    stats.cancelled = control.cancel.load();
    return stats;
  }
  const int64_t tileCount = tiles.tileCount();
  stats.threads = workersFor(asked, tileCount);
  // The workers' shares are bands of the image (runPhases), so threads rarely write to the same
  // cache line of the outputs, and only where the bands meet does one worker take another's tiles,
  // a tile at a time.
  std::vector<WorkerCounters> traced(static_cast<size_t>(stats.threads));
  std::vector<uint8_t> done(static_cast<size_t>(tileCount), 0);  // a byte a tile: each written by one worker
  runParallel(
      tileCount, stats.threads, control,
      [&](int64_t tile, int worker) {
        const RayCounters counters = tiles.render(tile);  // nothing if cancelled before it was written
        traced[static_cast<size_t>(worker)].counters += counters;
        done[static_cast<size_t>(tile)] = counters.camera > 0;
      },
      job.poll);
  for (const WorkerCounters& w : traced) stats.counters += w.counters;
  stats.cancelled = control.cancel.load();
  if (stats.cancelled) {
    for (int64_t tile = 0; tile < tileCount; ++tile) {
      if (done[static_cast<size_t>(tile)]) continue;
      const auto [x0, y0, w, h] = tiles.tileRect(tile);
      tiles.markUnreached(x0, y0, w, h);
    }
  }
  return stats;
}

}  // namespace durer
