#pragma once
#include <cstdint>

#include "Image.h"

namespace bench {

// How far Dürer's image of a workload is from Embree's: the check that makes the timings mean anything.
struct Agreement {
  static constexpr double kDepthTolerance = 1e-4;  // relative: |Δt| <= 1e-4 t
  static constexpr double kMaxDisagreeing = 1e-3;  // of the pixels: >= 99.9 % must agree

  int64_t pixels = 0;
  int64_t hitMismatches = 0;    // one hits, the other misses
  int64_t bothHit = 0;
  int64_t depthMismatches = 0;  // both hit, depths further apart than kDepthTolerance
  double depthDifference999 = 0;  // 99.9th percentile of |Δt| / t where both hit
  double maxDepthDifference = 0;  // its maximum (a pixel where each hits a different sphere)
  int64_t litMismatches = 0;    // with a sun: lit by one, in shadow or unlit by the other

  bool passed() const;
};

Agreement compare(const Image& embree, const Image& durer);

}  // namespace bench
