#pragma once
// A render's kernel for one precision and sphere method: the tiles of TileRenderer.h, or the rounds
// of AdaptiveSampler.h, on the render's threads. Instantiated by the kernel translation units
// (src/kernels), each compiled once per instruction set.
#include <algorithm>
#include <memory>
#include <mutex>

#include "durer/render/AdaptiveSampler.h"
#include "durer/render/TileRenderer.h"

namespace durer {

template <typename Real, SphereMethod M>
RenderStats renderWith(const RenderJob& job) {
  const Scene& scene = job.scene;
  const CameraSpec& spec = job.camera;
  const RenderSettings& settings = job.settings;
  const RenderTargets& targets = job.targets;
  JobControl& control = job.control;
  const std::shared_ptr<const Group<Real>> prepared = scene.prepared<Real>(settings.threads);
  const Group<Real>& group = *prepared;
  const EffectSet& effects = job.effects;
  const tiles::TileRenderer<Real, M> tiles(scene, group, spec, settings, targets, effects, control.cancel);
  RenderStats stats;
  stats.effects = effects;
  stats.threads = settings.threads > 0 ? settings.threads : defaultThreadCount();
  if (settings.sampler == SamplerKind::Adaptive) {
    tiles::AdaptiveSampler<Real, M> adaptive(tiles, settings, targets);
    stats.counters = adaptive.render(stats.threads, control, job.poll, stats.adaptive);
    stats.cancelled = control.cancel.load();
    return stats;
  }
  // A work item is a strip of kStripTiles tiles along a row: threads then rarely write to the same
  // cache line of the outputs, and the shared totals see one update per strip, not per tile.
  constexpr int64_t kStripTiles = 8;
  const int64_t tileCount = tiles.tileCount();
  std::mutex totalsMutex;
  runParallel(
      (tileCount + kStripTiles - 1) / kStripTiles, stats.threads, control,
      [&](int64_t strip) {
        RayCounters counters;
        for (int64_t tile = strip * kStripTiles; tile < std::min(tileCount, (strip + 1) * kStripTiles); ++tile) {
          counters += tiles.render(tile);
        }
        const std::lock_guard<std::mutex> lock(totalsMutex);
        stats.counters += counters;
      },
      job.poll);
  stats.cancelled = control.cancel.load();
  return stats;
}

}  // namespace durer
