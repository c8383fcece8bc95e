#pragma once
#include <cstdint>

namespace durer {

// What a render did, by kind; summed per tile, then into the render's totals.
struct RayCounters {
  int64_t camera = 0;                    // camera rays traced
  int64_t shadow = 0;                    // shadow rays (lights with shadows, lit points facing them)
  int64_t reflection = 0;                // mirror rays
  int64_t refraction = 0;                // refracted rays, total internal reflections included
  int64_t ambientOcclusion = 0;          // ambient occlusion rays
  int64_t shadingEvaluations = 0;        // hits shaded with lights (camera and secondary)
  int64_t cutByDepth = 0;                // secondary rays not spawned: deeper than maxBounces
  int64_t cutByWeight = 0;               // secondary rays not spawned: weight below minWeight
  int64_t totalInternalReflections = 0;  // refractions turned into reflections
  int64_t intersectionTests = 0;         // ray-primitive tests performed

  RayCounters& operator+=(const RayCounters& o) {
    camera += o.camera, shadow += o.shadow, reflection += o.reflection, refraction += o.refraction;
    ambientOcclusion += o.ambientOcclusion;
    shadingEvaluations += o.shadingEvaluations, cutByDepth += o.cutByDepth, cutByWeight += o.cutByWeight;
    totalInternalReflections += o.totalInternalReflections, intersectionTests += o.intersectionTests;
    return *this;
  }
};

// One worker's counters, alone on their cache lines: each worker of a job (runPhases' worker
// number) adds to its own without a lock; the render sums them at the end.
struct alignas(64) WorkerCounters {
  RayCounters counters;
};

}  // namespace durer
