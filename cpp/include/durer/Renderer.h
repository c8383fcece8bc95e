#pragma once
#include <cstdint>
#include <functional>

#include "durer/Camera.h"
#include "durer/Scene.h"
#include "durer/SphereMethod.h"
#include "durer/WorkQueue.h"

namespace durer {

enum PassFlags : unsigned {
  kPassColor = 1u << 0,   // RGBA, linear
  kPassDepth = 1u << 1,   // t of the hit along the unit camera ray; the pixel's nearest sample; inf on a miss
  kPassNormal = 1u << 2,  // unit world-space normal, the normalised mean over the pixel's hit samples; 0 on a miss
};

struct RenderSettings {
  int width = 0;                     // pixels, >= 1
  int height = 0;                    // pixels, >= 1
  int samplesPerPixel = 1;           // >= 1; 1 samples the pixel centre
  uint64_t seed = 0;                 // jitter seed
  Precision precision = Precision::Double;
  SphereMethod sphereMethod = SphereMethod::Robust;
  unsigned passes = kPassColor | kPassDepth | kPassNormal;
  int threads = 0;                   // 0: all hardware threads
};

// Output buffers, row-major, top row first, float32; null for a pass not requested.
struct RenderTargets {
  float* color = nullptr;   // height x width x 4
  float* depth = nullptr;   // height x width
  float* normal = nullptr;  // height x width x 3
};

struct RenderStats {
  int64_t cameraRays = 0;         // rays traced (fewer than width·height·spp when cancelled)
  int64_t shadowRays = 0;         // toward lights that cast shadows, from lit points facing them
  int64_t intersectionTests = 0;  // ray-primitive tests
  double milliseconds = 0;        // wall time of the render
  int threads = 0;
  bool cancelled = false;
};

void validate(const RenderSettings& settings);  // throws std::invalid_argument naming the field

// Renders in 8x8-pixel tiles on settings.threads workers; poll() is called from this thread while
// they work (see runParallel). On cancel the targets hold the finished tiles; the rest is untouched.
RenderStats render(const Scene& scene, const CameraSpec& camera, const RenderSettings& settings,
                   const RenderTargets& targets, JobControl& control, const std::function<void()>& poll);

}  // namespace durer
