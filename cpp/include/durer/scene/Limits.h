#pragma once
// The numbers Dürer accepts, per precision: the one table every range check reads (the scene's adds,
// the camera, render and cast; durer._core.LIMITS for the package and docs/numerics.md, which derives
// each bound). Inside them every render and cast computes finite colour, depth and normal.
#include <type_traits>

#include "durer/Options.h"

namespace durer {

struct NumericLimits {
  const char* precision;
  // |x| of every coordinate: sphere centres ± radii, vertices, box corners, plane offsets and corners,
  // light positions, camera centres and image windows, rays' origins, and the reach of a transform's
  // object space. The sphere test squares differences of two such numbers (≤ 193·(2x)² must fit) and
  // the triangle test multiplies two (96·(4x)²); in double the bound is the float32 depth pass's
  // (2√3·x must fit) and the hierarchy's single-precision binning (2x must fit).
  double coordinate;
  // Every colour component (material fields, light colours, attenuation, ambient, background): a
  // product of two fits in float, the precision of the colour pass.
  double color;
};

inline constexpr NumericLimits kLimits[] = {
    {"float", 1e18, 1e18},
    {"double", 1e36, 1e18},
};

// What one render accepts besides numbers (durer._core.RENDER_LIMITS for the package and Blender's
// settings): an image side, samples per pixel and min_spp up to `side` (keeps width·height·spp well
// inside int64), ray trees up to `maxBounces` deep, and up to `raysPerHit` ambient-occlusion rays,
// area light samples or soft shadow rays per shaded hit.
struct RenderLimits {
  int side;
  int maxBounces;
  int raysPerHit;
};
inline constexpr RenderLimits kRenderLimits{1 << 20, 1000, 1 << 16};

template <typename Real>
constexpr double coordinateLimit() {
  return kLimits[std::is_same_v<Real, float> ? 0 : 1].coordinate;
}

inline const NumericLimits& limitsFor(Precision p) { return kLimits[p == Precision::Float ? 0 : 1]; }
// What every add is checked against: the widest precision's limits (float renders check again).
inline const NumericLimits& widestLimits() { return limitsFor(Precision::Double); }

}  // namespace durer
