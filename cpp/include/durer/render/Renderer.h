#pragma once
#include <cstdint>
#include <functional>
#include <limits>

#include "durer/render/Camera.h"
#include "durer/render/PacketShader.h"
#include "durer/render/PixelSampler.h"
#include "durer/render/RayCounters.h"
#include "durer/scene/Scene.h"
#include "durer/Options.h"
#include "durer/render/WorkQueue.h"

namespace durer {

struct RenderSettings {
  int width = 0;                     // pixels, >= 1
  int height = 0;                    // pixels, >= 1
  int samplesPerPixel = 1;           // >= 1; center/stratified sampler at 1: the pixel centre (PixelSampler::centred)
  uint64_t seed = 0;                 // sampler seed
  SamplerKind sampler = SamplerKind::Stratified;
  double targetError = 0.01;         // adaptive: a pixel stops once its colour's estimated RMS error is below this
  int minSamples = 4;                // adaptive: samples every pixel takes first (at most samplesPerPixel)
  double timeLimit = 0;              // adaptive: seconds after which refining stops (0: none)
  Precision precision = Precision::Double;
  SphereMethod sphereMethod = SphereMethod::Robust;
  unsigned passes = kDefaultPasses;  // PassFlags
  DepthKind depth = DepthKind::Ray;  // what the depth pass measures
  int threads = 0;                   // 0: all hardware threads
  bool shadeBack = false;            // shade back faces with the flipped normal (6.837 -shade_back)
  int maxBounces = 4;                // deepest secondary ray (reflection, refraction); 0: none
  double minWeight = 0.01;           // secondary rays that would weigh less are not spawned
  // Ambient occlusion (durer.render's ambient_occlusion=(samples, distance)): the ambient term scaled
  // by the unoccluded fraction of the cosine-weighted hemisphere within `distance`, from `samples`
  // any-hit rays per shaded hit. Off: none traced.
  struct AmbientOcclusion {
    bool on = false;
    int samples = 16;                                           // [1, 65536]
    double distance = std::numeric_limits<double>::infinity();  // > 0; inf: any occluder
  } ambientOcclusion;
  // The part of the image rendered: pixels [x, x + width) x [y, y + height), sampled and seeded as in
  // the whole image, written to targets of region.width x region.height. Width 0: the whole image.
  struct Region {
    int x = 0, y = 0, width = 0, height = 0;
  } region;
};

// Output buffers, row-major, top row first; null for a pass not requested.
struct RenderTargets {
  float* color = nullptr;   // height x width x 4
  float* depth = nullptr;   // height x width
  float* normal = nullptr;  // height x width x 3
  int32_t* objectId = nullptr;    // height x width
  int32_t* materialId = nullptr;  // height x width
  int32_t* samples = nullptr;  // height x width: samples taken per pixel
  float* error = nullptr;      // height x width: adaptive: the estimated RMS error of the pixel's colour
};

// What adaptive sampling reached (AdaptiveSampler.h).
struct AdaptiveStats {
  double estimatedRmse = 0;    // root mean square over the pixels of their estimated colour errors
  double estimatedWorst = 0;   // the largest of them
  int rounds = 0;              // sampling rounds run (the first pass included)
  int64_t probes = 0;          // camera rays that probed a stratum's outside (not samples: AdaptiveSampler.h)
  bool timeLimitReached = false;
};

struct RenderStats {
  RayCounters counters;  // rays by kind and what was cut (fewer than width·height·spp camera rays when cancelled)
  EffectSet effects;     // what the scene called for
  double milliseconds = 0;  // wall time of the render
  int threads = 0;
  bool cancelled = false;
  AdaptiveStats adaptive;  // with SamplerKind::Adaptive
};

void validate(const RenderSettings& settings);  // throws std::invalid_argument naming the field

// Renders in 8x8-pixel tiles on settings.threads workers; poll() is called from this thread while
// they work (see runParallel). On cancel the targets hold the finished tiles; the rest is untouched.
RenderStats render(const Scene& scene, const CameraSpec& camera, const RenderSettings& settings,
                   const RenderTargets& targets, JobControl& control, const std::function<void()>& poll);

}  // namespace durer
