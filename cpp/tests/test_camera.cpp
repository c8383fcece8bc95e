// Camera::footprint against the rays Camera::generate makes: every sample whose ray meets a sphere
// lies in the sphere's box and disk, no nearer than its lower bound on t, every ray through the
// disk's core meets the sphere's line, and a sphere wholly in front gets a box no more than a pixel
// wider than its hit samples on each side and a disk and core within a pixel of them.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>

#include "durer/render/Camera.h"

using namespace durer;

namespace {

// The ray's nearest t >= 0 on the sphere, in double from the ray as rounded; inf if it misses.
double meetAt(const RayPacket<double>& ray, int k, const Vec3d& c, double r) {
  const Vec3d o(ray.ox[k], ray.oy[k], ray.oz[k]), d(ray.dx[k], ray.dy[k], ray.dz[k]);
  const Vec3d f = o - c;
  const double b = glm::dot(f, d), a = glm::dot(d, d);
  const Vec3d across = f - (b / a) * d;  // the line's nearest point to the centre, less rounding than b² - ac
  const double h = a * (r * r - glm::dot(across, across));
  if (h < 0) return std::numeric_limits<double>::infinity();
  const double root = std::sqrt(h);
  const double near = (-b - root) / a, far = (-b + root) / a;
  return near >= 0 ? near : far >= 0 ? far : std::numeric_limits<double>::infinity();
}

// Whether the ray's line meets the sphere (at any t: an orthographic image along a sun has rays on
// both sides of its plane).
bool lineMeets(const RayPacket<double>& ray, int k, const Vec3d& c, double r) {
  const Vec3d o(ray.ox[k], ray.oy[k], ray.oz[k]), d(ray.dx[k], ray.dy[k], ray.dz[k]);
  const Vec3d f = o - c;
  const Vec3d across = f - (glm::dot(f, d) / glm::dot(d, d)) * d;
  return glm::dot(across, across) < r * r;
}

// How many spheres the checks guarded by their footprint ran on: probed just outside a bounded box,
// compared with the hit samples of a projection inside the image.
struct Checked {
  int probed = 0, compared = 0;
  void add(const Checked& other) { probed += other.probed, compared += other.compared; }
};

template <typename Real>
Checked checkCamera(const CameraSpec& spec, std::mt19937_64& random) {
  constexpr int kWidth = 48, kHeight = 32, kPerPixel = 4;
  Checked checked;
  const Camera<Real> camera(spec, kWidth, kHeight);
  std::uniform_real_distribution<double> unit(-1, 1), radius(0.01, 2.5), distance(0, 12);
  for (int sphere = 0; sphere < 60; ++sphere) {
    const Vec3d c = spec.center + distance(random) * glm::normalize(Vec3d(unit(random), unit(random), unit(random)));
    const double r = radius(random);
    SampleBox box{};
    SampleDisk disk{};
    double tLow = 0;
    const bool seen = camera.footprint(c, r, box, tLow, &disk);
    SampleBox alone{};
    double alsoLow = 0;
    REQUIRE(camera.footprint(c, r, alone, alsoLow) == seen);  // the disk changes nothing else
    if (seen) REQUIRE((alone.x0 == box.x0 && alone.x1 == box.x1 && alone.y0 == box.y0 && alone.y1 == box.y1));
    // The farthest hit sample from the disk's centre, the nearest missed one.
    double farthestHit = 0, nearestMiss = std::numeric_limits<double>::infinity();
    double hitX0 = std::numeric_limits<double>::infinity(), hitX1 = -hitX0, hitY0 = hitX0, hitY1 = -hitX0;
    for (int row = 0; row < kHeight * kPerPixel; ++row) {
      Real sampleX[kWidth * kPerPixel], sampleY[kWidth * kPerPixel];
      for (int col = 0; col < kWidth * kPerPixel; ++col) {
        sampleX[col] = Real((col + 0.5) / kPerPixel), sampleY[col] = Real((row + 0.5) / kPerPixel);
      }
      RayPacket<double> rays;
      for (int start = 0; start < kWidth * kPerPixel; start += kPacketSize) {
        RayPacket<Real> packet;
        const int count = std::min(kPacketSize, kWidth * kPerPixel - start);
        camera.generate(packet, sampleX + start, sampleY + start, count);
        for (int k = 0; k < count; ++k) {
          rays.ox[k] = double(packet.ox[k]), rays.oy[k] = double(packet.oy[k]), rays.oz[k] = double(packet.oz[k]);
          rays.dx[k] = double(packet.dx[k]), rays.dy[k] = double(packet.dy[k]), rays.dz[k] = double(packet.dz[k]);
          const double t = meetAt(rays, k, c, r);
          const double x = double(sampleX[start + k]), y = double(sampleY[start + k]);
          const double fromCentre = std::hypot(x - disk.x, y - disk.y);
          if (!(t < std::numeric_limits<double>::infinity())) {
            if (!lineMeets(rays, k, c, r)) nearestMiss = std::min(nearestMiss, fromCentre);
            continue;
          }
          CAPTURE(sphere);
          REQUIRE(seen);
          REQUIRE(!(fromCentre > disk.radius));
          farthestHit = std::max(farthestHit, fromCentre);
          REQUIRE(box.x0 <= x);
          REQUIRE(x <= box.x1);
          REQUIRE(box.y0 <= y);
          REQUIRE(y <= box.y1);
          REQUIRE(tLow <= t * (1 + 1e-9));
          hitX0 = std::min(hitX0, x), hitX1 = std::max(hitX1, x), hitY0 = std::min(hitY0, y), hitY1 = std::max(hitY1, y);
        }
      }
    }
    // Rays just outside the box's sides miss (a grid's samples rarely come that close to a silhouette).
    const bool bounded = std::isfinite(box.x0) && std::isfinite(box.x1) && std::isfinite(box.y0) && std::isfinite(box.y1);
    if (seen && bounded) {
      ++checked.probed;
      constexpr int kProbes = 512;
      const double outside = 1e-3;  // pixels: float sample positions round by at most 4e-6 here
      for (int side = 0; side < 4; ++side) {
        Real sampleX[kPacketSize], sampleY[kPacketSize];
        RayPacket<double> rays;
        for (int start = 0; start < kProbes; start += kPacketSize) {
          for (int k = 0; k < kPacketSize; ++k) {
            const double along = (start + k + 0.5) / kProbes;
            const double x = side == 0 ? box.x0 - outside : side == 1 ? box.x1 + outside : box.x0 + along * (box.x1 - box.x0);
            const double y = side == 2 ? box.y0 - outside : side == 3 ? box.y1 + outside : box.y0 + along * (box.y1 - box.y0);
            sampleX[k] = Real(x), sampleY[k] = Real(y);
          }
          RayPacket<Real> packet;
          camera.generate(packet, sampleX, sampleY, kPacketSize);
          for (int k = 0; k < kPacketSize; ++k) {
            rays.ox[k] = double(packet.ox[k]), rays.oy[k] = double(packet.oy[k]), rays.oz[k] = double(packet.oz[k]);
            rays.dx[k] = double(packet.dx[k]), rays.dy[k] = double(packet.dy[k]), rays.dz[k] = double(packet.dz[k]);
            CAPTURE(sphere);
            CAPTURE(side);
            REQUIRE(!(meetAt(rays, k, c, r) < std::numeric_limits<double>::infinity()));
          }
        }
      }
    }
    // Every ray line through the core meets the sphere (probed just inside the core's rim);
    // orthographic, the core is the sphere's own disk but for the rounding bounds.
    if (seen) {
      const double core = disk.core, pixel = double(std::max(camera.projection().pixelWidth,
                                                             camera.projection().pixelHeight));
      CAPTURE(sphere);
      if (spec.projection == Projection::Orthographic) CHECK(core > r / pixel - 0.05);
      REQUIRE(!(core > nearestMiss));
      for (int start = 0; core > 0 && start < 512; start += kPacketSize) {
        Real sampleX[kPacketSize], sampleY[kPacketSize];
        for (int k = 0; k < kPacketSize; ++k) {
          const double angle = 2 * M_PI * (start + k + 0.5) / 512, reach = core * (1 - 1e-9);
          sampleX[k] = Real(disk.x + reach * std::cos(angle)), sampleY[k] = Real(disk.y + reach * std::sin(angle));
        }
        RayPacket<Real> packet;
        camera.generate(packet, sampleX, sampleY, kPacketSize);
        RayPacket<double> rays;
        for (int k = 0; k < kPacketSize; ++k) {
          rays.ox[k] = double(packet.ox[k]), rays.oy[k] = double(packet.oy[k]), rays.oz[k] = double(packet.oz[k]);
          rays.dx[k] = double(packet.dx[k]), rays.dy[k] = double(packet.dy[k]), rays.dz[k] = double(packet.dz[k]);
          REQUIRE(lineMeets(rays, k, c, r));
        }
      }
    }
    // Wholly in front, its projection inside the image: the box is the projection's, within a pixel.
    const ParallelProjection frame = camera.projection();
    const Vec3d q = frame.inFrame(c);
    const bool inside = q.z > 2 * r && box.x0 > 1 && box.x1 < kWidth - 1 && box.y0 > 1 && box.y1 < kHeight - 1;
    if (seen && inside && hitX0 <= hitX1) {
      ++checked.compared;
      CAPTURE(sphere);
      CHECK(box.x0 >= hitX0 - 1);
      CHECK(box.x1 <= hitX1 + 1);
      CHECK(box.y0 >= hitY0 - 1);
      CHECK(box.y1 <= hitY1 + 1);
      CHECK(disk.radius <= farthestHit + 1);
      // Seen under a small angle (the core's sine and the silhouette's tangent agree), the core
      // reaches the nearest missed sample but for their spacing.
      if (nearestMiss > 2 && r < 0.05 * glm::length(c - spec.center)) CHECK(disk.core >= nearestMiss - 1);
    }
  }
  return checked;
}

// A perspective camera of field of view `fov` at a random place, looking a random way.
CameraSpec randomPerspective(double fov, std::mt19937_64& random) {
  std::uniform_real_distribution<double> unit(-1, 1);
  CameraSpec spec;
  spec.projection = Projection::Perspective;
  spec.center = Vec3d(unit(random), unit(random), unit(random)) * 5.0;
  spec.direction = Vec3d(unit(random), unit(random), unit(random));
  spec.up = Vec3d(0, 1, 0);
  spec.size = fov;
  spec.tMin = 0;
  spec.tMax = std::numeric_limits<double>::infinity();
  return spec;
}

}  // namespace

TEST_CASE_TEMPLATE("a footprint holds every sample whose camera ray meets the sphere, and little more", Real, float,
                   double) {
  std::mt19937_64 random(7);
  Checked perspective;
  for (const double fov : {20.0, 60.0, 110.0, 170.0}) {
    for (int camera = 0; camera < 4; ++camera) {
      const CameraSpec spec = randomPerspective(fov, random);
      CAPTURE(fov);
      perspective.add(checkCamera<Real>(spec, random));
    }
  }
  CameraSpec ortho;
  ortho.center = Vec3d(0.5, -1, 2);
  ortho.direction = Vec3d(0.2, -0.3, -1);
  ortho.size = 6;
  ortho.tMin = -std::numeric_limits<double>::infinity();
  ortho.tMax = std::numeric_limits<double>::infinity();
  Checked orthographic = checkCamera<Real>(ortho, random);
  ortho.size = 24;  // wider: some spheres lie wholly inside the image (at size 6 none of the 60 did)
  orthographic.add(checkCamera<Real>(ortho, random));
  // The guarded checks ran (counted here: 308 and 89 perspective spheres, 120 and 13 orthographic).
  CHECK(perspective.probed > 200);
  CHECK(perspective.compared > 50);
  CHECK(orthographic.probed > 80);
  CHECK(orthographic.compared > 5);
}

namespace {

// The ray's nearest t >= tMin on the sphere (tMin may be -inf: an orthographic camera's rays run
// both ways), in double from the ray as rounded; inf if it misses.
double meetFrom(const RayPacket<double>& ray, int k, const Vec3d& c, double r, double tMin) {
  const Vec3d o(ray.ox[k], ray.oy[k], ray.oz[k]), d(ray.dx[k], ray.dy[k], ray.dz[k]);
  const Vec3d f = o - c;
  const double b = glm::dot(f, d), a = glm::dot(d, d);
  const Vec3d across = f - (b / a) * d;
  const double h = a * (r * r - glm::dot(across, across));
  if (h < 0) return std::numeric_limits<double>::infinity();
  const double root = std::sqrt(h);
  const double near = (-b - root) / a, far = (-b + root) / a;
  return near >= tMin ? near : far >= tMin ? far : std::numeric_limits<double>::infinity();
}

// Through a lens: every sample whose ray, from any point of the aperture, meets the sphere at t >=
// the camera's tMin lies in its box, no nearer than its lower bound on t; a sphere wholly beyond the
// lens's plane gets a bounded box. Returns how many spheres some ray met.
template <typename Real>
int checkLens(const CameraSpec& spec, std::mt19937_64& random) {
  constexpr int kWidth = 24, kHeight = 16, kPerPixel = 2;
  const Camera<Real> camera(spec, kWidth, kHeight);
  REQUIRE(camera.hasLens());
  // The lens's corners and rim (its points farthest out) and its centre.
  const double lens[] = {0.0, 0.125, 0.5, 0.875, 1 - 1e-12};
  std::uniform_real_distribution<double> unit(-1, 1), radius(0.01, 1.5), distance(0, 12);
  int met = 0;
  for (int sphere = 0; sphere < 40; ++sphere) {
    const Vec3d c = spec.center + distance(random) * glm::normalize(Vec3d(unit(random), unit(random), unit(random)));
    const double r = radius(random);
    SampleBox box{};
    double tLow = 0;
    const bool seen = camera.footprint(c, r, box, tLow);
    const double nearest = camera.projection().inFrame(c).z - r;
    if (seen && (spec.projection == Projection::Orthographic || nearest > 1e-3)) {
      CAPTURE(sphere);
      REQUIRE((std::isfinite(box.x0) && std::isfinite(box.x1) && std::isfinite(box.y0) && std::isfinite(box.y1)));
    }
    bool hit = false;
    for (const double u : lens) {
      for (const double v : lens) {
        for (int row = 0; row < kHeight * kPerPixel; ++row) {
          Real sampleX[kWidth * kPerPixel], sampleY[kWidth * kPerPixel];
          double lensU[kWidth * kPerPixel], lensV[kWidth * kPerPixel];
          for (int col = 0; col < kWidth * kPerPixel; ++col) {
            sampleX[col] = Real((col + 0.5) / kPerPixel), sampleY[col] = Real((row + 0.5) / kPerPixel);
            lensU[col] = u, lensV[col] = v;
          }
          for (int start = 0; start < kWidth * kPerPixel; start += kPacketSize) {
            RayPacket<Real> packet;
            const int count = std::min(kPacketSize, kWidth * kPerPixel - start);
            camera.generate(packet, sampleX + start, sampleY + start, count, lensU + start, lensV + start);
            RayPacket<double> rays;
            for (int k = 0; k < count; ++k) {
              rays.ox[k] = double(packet.ox[k]), rays.oy[k] = double(packet.oy[k]), rays.oz[k] = double(packet.oz[k]);
              rays.dx[k] = double(packet.dx[k]), rays.dy[k] = double(packet.dy[k]), rays.dz[k] = double(packet.dz[k]);
              const double t = meetFrom(rays, k, c, r, spec.tMin);
              if (!(t < std::numeric_limits<double>::infinity())) continue;
              const double x = double(sampleX[start + k]), y = double(sampleY[start + k]);
              CAPTURE(sphere);
              CAPTURE(u);
              CAPTURE(v);
              REQUIRE(seen);
              REQUIRE(box.x0 <= x);
              REQUIRE(x <= box.x1);
              REQUIRE(box.y0 <= y);
              REQUIRE(y <= box.y1);
              REQUIRE(tLow <= t + 1e-9 * std::fabs(t));
              hit = true;
            }
          }
        }
      }
    }
    met += hit ? 1 : 0;
  }
  return met;
}

}  // namespace

// Camera::footprints makes a pinhole's footprints (perspective or orthographic) eight at once with
// footprint()'s operations: the same boxes, bounds and verdicts bit for bit, for spheres in front
// of, around and behind the eye (or the orthographic t_min), on its plane, huge and tiny, eight at
// a time and fewer (through a lens, and with disks, it calls footprint() itself).
TEST_CASE_TEMPLATE("footprints gives footprint's boxes bit for bit", Real, float, double) {
  constexpr int kLanes = Camera<Real>::kFootprints;
  std::mt19937_64 random(20261204);
  std::uniform_real_distribution<double> unit(-1, 1), scale(-6, 6);
  int seen = 0, unseen = 0;
  for (const double fov : {20.0, 60.0, 110.0, 170.0, 0.0}) {  // 0: orthographic, 6 wide, from t = -1
    CameraSpec spec = randomPerspective(fov, random);
    if (fov == 0) spec.projection = Projection::Orthographic, spec.size = 6, spec.tMin = -1;
    const Camera<Real> camera(spec, 640, 360);
    for (int block = 0; block < 500; ++block) {
      Vec3d centers[kLanes];
      double radii[kLanes];
      for (int j = 0; j < kLanes; ++j) {
        const double reach = std::pow(10.0, scale(random) / 2);  // 0.001 to 1000 from the eye
        centers[j] = spec.center + reach * Vec3d(unit(random), unit(random), unit(random));
        radii[j] = std::pow(10.0, scale(random) / 2) * (j == 3 ? 1e-9 : 1);
      }
      if (block % 7 == 0) centers[1] = spec.center;  // the eye at the centre
      const int n = block % 5 == 0 ? 1 + block % kLanes : kLanes;
      SampleBox boxes[kLanes];
      double tLows[kLanes];
      bool in[kLanes];
      camera.footprints(n, centers, radii, boxes, tLows, nullptr, in);
      for (int j = 0; j < n; ++j) {
        SampleBox box{};
        double tLow = 0;
        const bool alone = camera.footprint(centers[j], radii[j], box, tLow);
        CAPTURE(fov);
        CAPTURE(block);
        CAPTURE(j);
        REQUIRE(in[j] == alone);
        (alone ? seen : unseen) += 1;
        if (!alone) continue;
        const auto bits = [](double x) {
          uint64_t b;
          std::memcpy(&b, &x, sizeof b);
          return b;
        };
        CHECK(bits(boxes[j].x0) == bits(box.x0));
        CHECK(bits(boxes[j].x1) == bits(box.x1));
        CHECK(bits(boxes[j].y0) == bits(box.y0));
        CHECK(bits(boxes[j].y1) == bits(box.y1));
        CHECK(bits(tLows[j]) == bits(tLow));
      }
    }
  }
  CHECK(seen > 1000);
  CHECK(unseen > 1000);
}

TEST_CASE_TEMPLATE("through a lens, a footprint holds every sample whose ray from any of its points meets the sphere",
                   Real, float, double) {
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  int met = 0;
  for (const int blades : {0, 5}) {
    for (const double ratio : {1.0, 0.5, 2.0}) {
      for (const double aperture : {0.05, 0.6}) {
        CameraSpec spec;
        spec.projection = Projection::Perspective;
        spec.center = Vec3d(unit(random), unit(random), unit(random)) * 5.0;
        spec.direction = Vec3d(unit(random), unit(random), unit(random));
        spec.size = 70;
        spec.tMin = 0;
        spec.tMax = std::numeric_limits<double>::infinity();
        spec.apertureRadius = aperture, spec.focusDistance = 4, spec.apertureBlades = blades;
        spec.apertureRotation = 0.4, spec.apertureRatio = ratio;
        met += checkLens<Real>(spec, random);
        spec.projection = Projection::Orthographic;
        spec.size = 8;
        met += checkLens<Real>(spec, random);
        spec.tMin = -std::numeric_limits<double>::infinity();  // rays both ways: spheres behind it too
        met += checkLens<Real>(spec, random);
      }
    }
  }
  CHECK(met > 250);  // of 1,440 spheres, scattered all around the cameras
}

TEST_CASE_TEMPLATE("placeSamples gives the positions and exactly their box", Real, float, double) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> offset(0, 1);
  std::uniform_int_distribution<int> pixel(0, (1 << 20) - 1);  // the validated widths' range
  for (int round = 0; round < 2000; ++round) {
    const int count = 1 + round % kPacketSize;
    int x[kPacketSize], y[kPacketSize];
    double u[kPacketSize], v[kPacketSize];
    for (int k = 0; k < count; ++k) {
      x[k] = pixel(rng), y[k] = pixel(rng);
      // Offsets near 1 round a float position onto the next pixel's edge: the box must hold it.
      u[k] = round % 3 == 0 ? std::nextafter(1.0, 0.0) : offset(rng), v[k] = offset(rng);
    }
    Real sx[kPacketSize], sy[kPacketSize], box[4];
    placeSamples(x, y, u, v, count, sx, sy, box);
    Real lo[2] = {sx[0], sy[0]}, hi[2] = {sx[0], sy[0]};
    for (int k = 0; k < count; ++k) {
      CHECK(sx[k] == static_cast<Real>(x[k] + u[k]));
      CHECK(sy[k] == static_cast<Real>(y[k] + v[k]));
      lo[0] = std::min(lo[0], sx[k]), hi[0] = std::max(hi[0], sx[k]);
      lo[1] = std::min(lo[1], sy[k]), hi[1] = std::max(hi[1], sy[k]);
    }
    CHECK(box[0] == lo[0]);
    CHECK(box[1] == hi[0]);
    CHECK(box[2] == lo[1]);
    CHECK(box[3] == hi[1]);
  }
}
