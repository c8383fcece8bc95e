#pragma once
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "durer/render/Camera.h"
#include "durer/scene/Scene.h"

namespace bench {

// What both ray tracers are given: the same spheres (kept in double, as Dürer's scene keeps them;
// Embree gets them rounded to float), an optional ground plane y = 0 facing up, an optional sun, and
// the camera whose rays both trace, or rays given one per pixel instead.
struct Workload {
  std::string kind;
  std::vector<double> centers;  // count x 3
  std::vector<double> radii;    // count
  bool groundPlane = false;
  std::optional<durer::Vec3d> sunDirection;  // unit, the way the light travels; casts shadows
  durer::CameraSpec camera;
  int width = 0;
  int height = 0;
  // Rays given instead of the camera's, one per pixel (width x height, row by row): origins and
  // directions (unit but for shadow rays toward a point light), count x 3 each, float values
  // (Embree's rays exactly; Dürer casts them with durer::cast).
  std::vector<double> rayOrigins, rayDirections;
  // The last occlusionRays given rays are shadow rays: they ask only whether anything lies ahead
  // (Embree: rtcOccluded1), and each tracer's image holds kOccluded where something does.
  size_t occlusionRays = 0;
  // How far, in units of its direction, a shadow ray looks: without end toward a sun (its direction
  // unit); 1 toward a point light (its direction runs from its origin to the light).
  double occlusionTMax = INFINITY;
  static constexpr float kOccluded = 1;

  size_t sphereCount() const { return radii.size(); }
  // The centres of an animation's frame `frame`: odd frames move every sphere by a quarter of its
  // radius in a direction of its own (seeded), even frames put them back.
  std::vector<double> frameCenters(int frame) const;
  // Another pose of the camera (a synthetic data set's next view): turned 2 degrees about its up
  // vector, its centre kept.
  durer::CameraSpec posedCamera() const;
  bool givenRays() const { return !rayOrigins.empty(); }
};

// The workload kinds, one sentence each, for --help and the error on an unknown name.
const std::vector<std::pair<std::string, std::string>>& workloadKinds();

// Builds workload `kind` with `spheres` random spheres (seeded: the same call gives the same
// spheres) for a width x height image; std::invalid_argument on an unknown kind.
Workload makeWorkload(const std::string& kind, size_t spheres, int width, int height);

// Dürer's scene of the workload: its spheres with the default material, the plane, the sun.
// Returns the spheres' object ids (for moveSpheres).
std::vector<int32_t> addToScene(const Workload& workload, durer::Scene& scene);

}  // namespace bench
