#pragma once
#include <cstddef>
#include <cstdint>
#include <functional>

#include "durer/scene/Scene.h"
#include "durer/Options.h"
#include "durer/render/WorkQueue.h"

namespace durer {

// A batch of arbitrary rays, structure-of-arrays at the boundary.
struct CastInput {
  const double* origins = nullptr;     // count x 3, world space; rounded to the precision used
  const double* directions = nullptr;  // count x 3, world space; any length (zero or non-finite: a miss)
  size_t count = 0;
  double tMin = 0;                     // hits with t in [tMin, tMax) count, t in units of each direction
  double tMax = 0;
  SphereMethod sphereMethod = SphereMethod::Robust;
  int threads = 0;                     // 0: all hardware threads
  bool anyHit = false;                 // occlusion: each search stops at the first hit it finds in
                                       // [tMin, tMax), not necessarily the closest; only t is written
};

template <typename Real>
struct CastOutput {
  Real* t = nullptr;              // count: closest hit (anyHit: the hit found), inf on a miss
  Real* normal = nullptr;         // count x 3: unit world-space normal, 0 on a miss (not with anyHit)
  int32_t* objectId = nullptr;    // count: -1 on a miss (not with anyHit)
  int32_t* materialId = nullptr;  // count: -1 on a miss (not with anyHit)
};

struct CastStats {
  int64_t intersectionTests = 0;
  double milliseconds = 0;
};

// Closest hits of many rays. Rays with NaN anywhere miss (they never produce a hit).
template <typename Real>
CastStats cast(const Scene& scene, const CastInput& input, const CastOutput<Real>& output, JobControl& control,
               const std::function<void()>& poll);

}  // namespace durer
