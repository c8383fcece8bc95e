#include "Workload.h"

#include <cmath>
#include <cstdint>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>

#include "durer/render/Camera.h"
#include "durer/render/Cast.h"
#include "durer/scene/Light.h"

namespace bench {

namespace {

constexpr uint64_t kSeed = 20261123;
constexpr double kCubeHalf = 1;         // the cube is [-1, 1]^3
constexpr double kSlabHalfWidth = 10;   // the slab is 20 x 20 (x, z) ...
constexpr double kSlabHeight = 4;       // ... x 4 (y), standing on the ground plane y = 0
constexpr double kSlabRadius = 0.02;    // ~3.5 pixels across: 1920 pixels span the view's 22 units
constexpr double kSqrtHalf = 0.70710678118654752440;

// A quarter of the mean spacing of n spheres in the cube: they fill the same share of its volume
// (π/192, 1.6 %) at every n, ever finer.
double cubeRadius(size_t n) { return 0.5 * kCubeHalf / std::cbrt(static_cast<double>(n)); }

void addUniformSpheres(Workload& w, size_t n, const durer::Vec3d& lo, const durer::Vec3d& hi, double radius) {
  std::mt19937_64 random(kSeed);
  std::uniform_real_distribution<double> x(lo.x, hi.x), y(lo.y, hi.y), z(lo.z, hi.z);
  w.centers.reserve(3 * n);
  for (size_t i = 0; i < n; ++i) {
    w.centers.insert(w.centers.end(), {x(random), y(random), z(random)});
  }
  w.radii.assign(n, radius);
}

// Spheres fill the cube, seen along -z by an orthographic camera whose image width spans the cube.
void makeCube(Workload& w, size_t n) {
  addUniformSpheres(w, n, durer::Vec3d(-kCubeHalf), durer::Vec3d(kCubeHalf), cubeRadius(n));
  w.camera.projection = durer::Projection::Orthographic;
  w.camera.center = {0, 0, 4 * kCubeHalf};
  w.camera.size = 2 * kCubeHalf;
}

// The cube's spheres seen from its centre through a 60° perspective camera.
void makeInside(Workload& w, size_t n) {
  makeCube(w, n);
  w.camera.projection = durer::Projection::Perspective;
  w.camera.center = {0, 0, 0};
  w.camera.size = 60;
}

// Small spheres in a 20 x 20 x 4 slab on a ground plane, seen from 45° above by an orthographic camera.
void makeSlab(Workload& w, size_t n) {
  const double r = kSlabRadius;
  addUniformSpheres(w, n, {-kSlabHalfWidth, r, -kSlabHalfWidth}, {kSlabHalfWidth, kSlabHeight - r, kSlabHalfWidth}, r);
  w.groundPlane = true;
  w.camera.projection = durer::Projection::Orthographic;
  w.camera.direction = {0, -kSqrtHalf, -kSqrtHalf};
  w.camera.center = durer::Vec3d(0, kSlabHeight / 2, 0) - 40.0 * w.camera.direction;
  w.camera.size = 2.2 * kSlabHalfWidth;
}

void makeSlabWithSun(Workload& w, size_t n) {
  makeSlab(w, n);
  w.sunDirection = glm::normalize(durer::Vec3d(1, -2, -1));
}

// Radius-0.05 spheres uniform in a 20-unit cube (bench/secondary_rays.py's), and a ray per pixel
// leaving a random sphere's surface in a random direction: reflection and shadow rays, incoherent.
void makeBounce(Workload& w, size_t n) {
  constexpr double kHalf = 10, kRadius = 0.05, kOffset = 1.001;  // origins just outside their sphere
  addUniformSpheres(w, n, durer::Vec3d(-kHalf), durer::Vec3d(kHalf), kRadius);
  // Centres in float, so that both tracers in both precisions meet the same spheres: many hits are a
  // few radii from the ray's origin, where rounding a centre to float (up to 5e-7) would move a hit by
  // more than the agreement's 1e-4 relative.
  for (double& c : w.centers) c = static_cast<float>(c);
  w.camera.projection = durer::Projection::Orthographic;  // not traced; a valid camera all the same
  std::mt19937_64 random(kSeed + 1);
  std::uniform_int_distribution<size_t> sphere(0, n - 1);
  std::normal_distribution<double> normal;
  const size_t count = static_cast<size_t>(w.width) * static_cast<size_t>(w.height);
  w.rayOrigins.reserve(3 * count), w.rayDirections.reserve(3 * count);
  for (size_t i = 0; i < count; ++i) {
    durer::Vec3d d(0);
    while (!(glm::length(d) > 1e-3)) d = durer::Vec3d(normal(random), normal(random), normal(random));
    const durer::Vec3<float> direction = glm::normalize(durer::Vec3<float>(d));
    const size_t s = sphere(random);
    const durer::Vec3d center(w.centers[3 * s], w.centers[3 * s + 1], w.centers[3 * s + 2]);
    const durer::Vec3<float> origin(center + kOffset * kRadius * durer::Vec3d(direction));
    for (int a = 0; a < 3; ++a) w.rayOrigins.push_back(origin[a]), w.rayDirections.push_back(direction[a]);
  }
}

// The rays of one generation (origins, directions: count x 3 each), and what durer::cast finds for them.
struct Generation {
  std::vector<double> origins, directions;
  std::vector<double> t, normals;
  size_t size() const { return origins.size() / 3; }
  void add(const durer::Vec3d& origin, const durer::Vec3d& direction) {
    for (int a = 0; a < 3; ++a) origins.push_back(origin[a]), directions.push_back(direction[a]);
  }
  void append(const Generation& other) {
    origins.insert(origins.end(), other.origins.begin(), other.origins.end());
    directions.insert(directions.end(), other.directions.begin(), other.directions.end());
  }
};

void castGeneration(const durer::Scene& scene, Generation& g) {
  g.t.assign(g.size(), 0), g.normals.assign(3 * g.size(), 0);
  std::vector<int32_t> ids(g.size());
  durer::CastInput input;
  input.origins = g.origins.data(), input.directions = g.directions.data(), input.count = g.size();
  input.tMax = INFINITY;
  durer::CastOutput<double> output;
  output.t = g.t.data(), output.normal = g.normals.data(), output.objectId = ids.data(), output.materialId = ids.data();
  durer::JobControl control;
  durer::cast<double>(scene, input, output, control, [] {});
}

// The camera's ray through the centre of every pixel, row by row (Dürer's Camera<double>).
Generation cameraRays(const Workload& w) {
  Generation rays;
  const durer::Camera<double> camera(w.camera, w.width, w.height);
  for (int y = 0; y < w.height; ++y) {
    for (int x0 = 0; x0 < w.width; x0 += durer::kPacketSize) {
      durer::RayPacket<double> packet;
      double sx[durer::kPacketSize], sy[durer::kPacketSize];
      const int count = std::min(durer::kPacketSize, w.width - x0);
      for (int k = 0; k < count; ++k) sx[k] = x0 + k + 0.5, sy[k] = y + 0.5;
      camera.generate(packet, sx, sy, count);
      for (int k = 0; k < count; ++k) {
        rays.add(durer::Vec3d(packet.ox[k], packet.oy[k], packet.oz[k]), durer::Vec3d(packet.dx[k], packet.dy[k], packet.dz[k]));
      }
    }
  }
  return rays;
}

// Where a surface point's shadow ray goes: toward a sun, along its unit direction without end, or to
// a point light, reached at t = 1.
struct ShadowTarget {
  std::optional<durer::Vec3d> towardSun;
  durer::Vec3d light{0};

  durer::Vec3d direction(const durer::Vec3d& point) const { return towardSun ? *towardSun : light - point; }
  double tMax() const { return towardSun ? INFINITY : 1.0; }
};

// The ray tree a colour render at one sample a pixel traces from `rays` (the camera's) when every
// surface is a mirror: from every hit of a camera or reflection ray, a shadow ray toward `target` where
// the surface faces it, and the mirror reflection up to 4 bounces. Each starts 1e-4 off its surface.
void traceTree(const durer::Scene& scene, Generation rays, const ShadowTarget& target, Generation& reflections,
               Generation& shadows) {
  constexpr double kOffset = 1e-4;
  constexpr int kBounces = 4;
  for (int depth = 0; rays.size() > 0; ++depth) {
    castGeneration(scene, rays);
    Generation next;
    for (size_t i = 0; i < rays.size(); ++i) {
      if (!std::isfinite(rays.t[i])) continue;
      const durer::Vec3d o(rays.origins[3 * i], rays.origins[3 * i + 1], rays.origins[3 * i + 2]);
      const durer::Vec3d d(rays.directions[3 * i], rays.directions[3 * i + 1], rays.directions[3 * i + 2]);
      const durer::Vec3d normal(rays.normals[3 * i], rays.normals[3 * i + 1], rays.normals[3 * i + 2]);
      const durer::Vec3d facing = glm::dot(normal, d) < 0 ? normal : -normal;
      const durer::Vec3d point = o + rays.t[i] * d + kOffset * facing;
      const durer::Vec3d toLight = target.direction(point);
      if (glm::dot(facing, toLight) > 0) shadows.add(point, toLight);
      if (depth < kBounces) next.add(point, glm::reflect(d, facing));
    }
    if (depth > 0) reflections.append(rays);
    rays = std::move(next);
  }
}

constexpr double kSecondaryLift = 10.5;  // bench/secondary_rays.py's ground is y = -10.5

// bench/secondary_rays.py's scene -- radius-0.05 spheres uniform in a 20-unit cube over a ground plane
// 0.5 below it, a 60-degree perspective camera 15 units in front of the cube -- lifted by 10.5 so that
// the ground is y = 0 (its spheres drawn by this file's generator, not numpy's), lit by `target`. The
// given rays are the shadow and reflection rays its colour render traces (every surface reflects half:
// the weight cut never stops a bounce), the reflection rays first, then the shadow rays (occlusion
// rays), found with durer::cast in double.
void makeSecondaryLit(Workload& w, size_t n, const ShadowTarget& target) {
  constexpr double kHalf = 10, kRadius = 0.05, kLift = kSecondaryLift;
  addUniformSpheres(w, n, durer::Vec3d(-kHalf, kLift - kHalf, -kHalf), durer::Vec3d(kHalf, kLift + kHalf, kHalf), kRadius);
  for (double& c : w.centers) c = static_cast<float>(c);  // as in makeBounce: both tracers meet the same spheres
  w.groundPlane = true;
  w.camera.projection = durer::Projection::Perspective;
  w.camera.center = {0, kLift, 25};
  w.camera.size = 60;
  durer::Scene scene;
  addToScene(w, scene);
  Generation rays, shadows;
  traceTree(scene, cameraRays(w), target, rays, shadows);
  if (rays.size() + shadows.size() == 0) {
    throw std::invalid_argument("the secondary workload's camera rays at " + std::to_string(w.width) + "x" +
                                std::to_string(w.height) + " meet nothing: no shadow or reflection rays to trace");
  }
  rays.append(shadows);
  for (double& v : rays.origins) v = static_cast<float>(v);  // as float values: Embree's rays exactly
  for (double& v : rays.directions) v = static_cast<float>(v);
  w.rayOrigins = std::move(rays.origins), w.rayDirections = std::move(rays.directions);
  w.occlusionRays = shadows.size();
  w.occlusionTMax = target.tMax();
  w.width = static_cast<int>(w.rayOrigins.size() / 3), w.height = 1;  // a ray per pixel of one row
}

// The sun along (-1, -2, -1).
void makeSecondary(Workload& w, size_t n) {
  makeSecondaryLit(w, n, ShadowTarget{-glm::normalize(durer::Vec3d(-1, -2, -1))});
}

// bench/secondary_rays.py's point light (15, 30, 15), above a corner of the cube.
void makeSecondaryPoint(Workload& w, size_t n) {
  makeSecondaryLit(w, n, ShadowTarget{std::nullopt, durer::Vec3d(15, 30 + kSecondaryLift, 15)});
}

using Maker = void (*)(Workload&, size_t);

struct Kind {
  const char* name;
  const char* description;
  Maker make;
};

const Kind kKinds[] = {
    {"cube", "random spheres in a cube, radius a quarter of their mean spacing, orthographic view", makeCube},
    {"slab", "radius-0.02 spheres in a 20x20x4 slab on a ground plane, orthographic view from 45 degrees", makeSlab},
    {"slab-sun", "the slab lit by a sun casting shadows (colour render; Embree adds occlusion rays)", makeSlabWithSun},
    {"inside", "the cube's spheres seen from its centre, 60-degree perspective view", makeInside},
    {"bounce", "radius-0.05 spheres in a 20-unit cube, a ray per pixel leaving a random sphere in a random direction",
     makeBounce},
    {"secondary", "bench/secondary_rays.py's scene; its colour render's shadow and reflection rays, up to 4 bounces",
     makeSecondary},
    {"secondary-point", "the secondary scene under bench/secondary_rays.py's point light instead of the sun",
     makeSecondaryPoint},
};

}  // namespace

const std::vector<std::pair<std::string, std::string>>& workloadKinds() {
  static const std::vector<std::pair<std::string, std::string>> kinds = [] {
    std::vector<std::pair<std::string, std::string>> list;
    for (const Kind& kind : kKinds) list.emplace_back(kind.name, kind.description);
    return list;
  }();
  return kinds;
}

Workload makeWorkload(const std::string& kind, size_t spheres, int width, int height) {
  for (const Kind& k : kKinds) {
    if (kind != k.name) continue;
    Workload w;
    w.kind = kind;
    w.width = width;
    w.height = height;
    w.camera.tMax = INFINITY;
    k.make(w, spheres);
    durer::validate(w.camera);
    return w;
  }
  throw std::invalid_argument("unknown workload '" + kind + "'");
}

std::vector<double> Workload::frameCenters(int frame) const {
  std::vector<double> moved = centers;
  if (frame % 2 == 0) return moved;
  std::mt19937_64 random(kSeed + 1);
  std::normal_distribution<double> normal;
  for (size_t i = 0; i < sphereCount(); ++i) {
    durer::Vec3d d(0);
    while (!(glm::length(d) > 1e-3)) d = durer::Vec3d(normal(random), normal(random), normal(random));
    const durer::Vec3d direction = glm::normalize(d);
    for (int axis = 0; axis < 3; ++axis) moved[3 * i + axis] += 0.25 * radii[i] * direction[axis];
  }
  return moved;
}

durer::CameraSpec Workload::posedCamera() const {
  constexpr double kTurn = 2 * 3.14159265358979323846 / 180;
  durer::CameraSpec posed = camera;
  const durer::Vec3d u = glm::normalize(camera.up), d = camera.direction;
  // Rodrigues' rotation of the direction about the unit up vector.
  posed.direction = d * std::cos(kTurn) + glm::cross(u, d) * std::sin(kTurn) + u * glm::dot(u, d) * (1 - std::cos(kTurn));
  durer::validate(posed);
  return posed;
}

std::vector<int32_t> addToScene(const Workload& w, durer::Scene& scene) {
  const int32_t defaultMaterial = 0;
  const int32_t first = scene.addSpheres(w.centers.data(), w.radii.data(), &defaultMaterial, w.sphereCount(), false);
  if (w.groundPlane) scene.addPlane({0, 1, 0}, 0, defaultMaterial, nullptr);
  if (w.sunDirection) scene.addDirectionalLight(durer::DirectionalLight{*w.sunDirection, {1, 1, 1}, true});
  std::vector<int32_t> ids(w.sphereCount());
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = first + static_cast<int32_t>(i);
  return ids;
}

}  // namespace bench
