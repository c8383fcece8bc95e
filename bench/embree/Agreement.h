#pragma once
#include <cstdint>

#include "Image.h"

namespace bench {

// How far Dürer's image of a workload is from Embree's: the check that makes the timings mean anything.
struct Agreement {
  static constexpr double kDepthTolerance = 1e-4;  // relative: |Δt| <= 1e-4 t
  static constexpr double kMaxDisagreeing = 1e-3;  // of the pixels: >= 99.9 % must agree on hit and depth
  // Shadow verdicts: each small sphere casts a shadow edge, and where a shadow ray grazes a sphere the
  // two tracers' roundings decide (about 0.1 % of the slab's pixels, split evenly both ways).
  static constexpr double kMaxLitDisagreeing = 5e-3;

  int64_t pixels = 0;
  int64_t hitMismatches = 0;    // one hits, the other misses
  int64_t bothHit = 0;
  int64_t depthMismatches = 0;  // both hit, depths further apart than kDepthTolerance
  double depthDifference999 = 0;  // 99.9th percentile of |Δt| / t where both hit
  double maxDepthDifference = 0;  // its maximum (a pixel where each hits a different sphere)
  int64_t litMismatches = 0;    // with a sun: lit by one, in shadow or unlit by the other
  int64_t litByEmbreeOnly = 0;  // of those, the pixels Embree lights

  bool passed() const;
};

Agreement compare(const Image& embree, const Image& durer);

}  // namespace bench
