#include "EmbreeTracer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "durer/geometry/RayPacket.h"
#include "durer/render/Camera.h"

namespace bench {

namespace {

// Dürer's split of the image (Renderer.cpp): 8x8-pixel tiles, work items of 8 tiles along a row
// taken in order by whichever thread is free. A tile row of 8 pixels is one rtcIntersect8 packet.
constexpr int kTileSize = 8;
constexpr int kStripTiles = 8;
constexpr int kLanes = 8;
static_assert(kTileSize == kLanes, "a tile row is one Embree packet");
static_assert(kTileSize * kTileSize <= durer::kPacketSize, "a tile fits one Dürer ray packet");

constexpr float kGroundHalfSize = 1000;  // far beyond what any workload's camera sees
// Shadow rays start this far off the surface (scene units): Embree has no error-bounded offset like
// Dürer's, and a fixed one this small changes no pixel's verdict here (the spheres' radius is 0.02).
constexpr float kShadowOffset = 1e-4f;
constexpr float kInfinity = std::numeric_limits<float>::infinity();

// One thread's tracer: it generates a tile's rays with Dürer's camera and traces them row by row.
class TileTracer {
 public:
  TileTracer(const Workload& w, const durer::CameraSpec& camera, RTCScene scene, unsigned groundId, Image& image)
      : m_workload(w), m_scene(scene), m_groundId(groundId), m_camera(camera, w.width, w.height), m_image(image) {
    rtcInitIntersectContext(&m_context);
    if (w.sunDirection) m_towardSun = -durer::toReal<float>(*w.sunDirection);
  }

  // Tiles are numbered row by row; strip s is tiles 8s .. 8s + 7 (a strip may wrap to the next row).
  void traceStrip(int64_t strip) {
    const int64_t tilesX = (m_workload.width + kTileSize - 1) / kTileSize;
    const int64_t tileCount = tilesX * ((m_workload.height + kTileSize - 1) / kTileSize);
    for (int64_t tile = strip * kStripTiles; tile < std::min(tileCount, (strip + 1) * kStripTiles); ++tile) {
      traceTile(static_cast<int>(tile % tilesX) * kTileSize, static_cast<int>(tile / tilesX) * kTileSize);
    }
  }

  int64_t shadowRays() const { return m_shadowRays; }

 private:
  void traceTile(int x0, int y0) {
    const int w = std::min(kTileSize, m_workload.width - x0), h = std::min(kTileSize, m_workload.height - y0);
    float sampleX[durer::kPacketSize], sampleY[durer::kPacketSize];
    for (int k = 0; k < w * h; ++k) {
      sampleX[k] = static_cast<float>(x0 + k % w) + 0.5f;  // pixel centres, as Dürer's 1-spp sampler
      sampleY[k] = static_cast<float>(y0 + k / w) + 0.5f;
    }
    m_camera.generate(m_packet, sampleX, sampleY, w * h);
    for (int row = 0; row < h; ++row) {
      traceRow(row * w, w, static_cast<size_t>(y0 + row) * m_workload.width + x0);
    }
  }

  // Rays first .. first + count of the packet, written to pixels pixel .. pixel + count.
  void traceRow(int first, int count, size_t pixel) {
    alignas(32) int valid[kLanes];
    RTCRayHit8 rays{};
    for (int k = 0; k < kLanes; ++k) {
      valid[k] = k < count ? -1 : 0;
      if (k >= count) continue;
      const int i = first + k;
      rays.ray.org_x[k] = m_packet.ox[i], rays.ray.org_y[k] = m_packet.oy[i], rays.ray.org_z[k] = m_packet.oz[i];
      rays.ray.dir_x[k] = m_packet.dx[i], rays.ray.dir_y[k] = m_packet.dy[i], rays.ray.dir_z[k] = m_packet.dz[i];
      rays.ray.tnear[k] = m_packet.tMin;
      rays.ray.tfar[k] = m_packet.tMax;
      rays.ray.mask[k] = ~0u;
      rays.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      rays.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect8(valid, m_scene, &m_context, &rays);
    for (int k = 0; k < count; ++k) {
      m_image.depth[pixel + k] = rays.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID ? kInfinity : rays.ray.tfar[k];
    }
    if (m_workload.sunDirection) traceShadows(rays, count, pixel);
  }

  // Occlusion rays toward the sun from the hits that face it (Dürer casts none for the others).
  void traceShadows(const RTCRayHit8& hits, int count, size_t pixel) {
    alignas(32) int valid[kLanes] = {};
    RTCRay8 rays{};
    for (int k = 0; k < count; ++k) {
      if (hits.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) continue;
      const durer::Vec3<float> sphereNormal(hits.hit.Ng_x[k], hits.hit.Ng_y[k], hits.hit.Ng_z[k]);
      const durer::Vec3<float> normal =
          hits.hit.geomID[k] == m_groundId ? durer::Vec3<float>(0, 1, 0) : glm::normalize(sphereNormal);
      if (glm::dot(normal, m_towardSun) <= 0) continue;
      const float t = hits.ray.tfar[k];
      const durer::Vec3<float> origin =
          durer::Vec3<float>(hits.ray.org_x[k], hits.ray.org_y[k], hits.ray.org_z[k]) +
          t * durer::Vec3<float>(hits.ray.dir_x[k], hits.ray.dir_y[k], hits.ray.dir_z[k]) + kShadowOffset * normal;
      valid[k] = -1;
      rays.org_x[k] = origin.x, rays.org_y[k] = origin.y, rays.org_z[k] = origin.z;
      rays.dir_x[k] = m_towardSun.x, rays.dir_y[k] = m_towardSun.y, rays.dir_z[k] = m_towardSun.z;
      rays.tfar[k] = kInfinity;
      rays.mask[k] = ~0u;
      ++m_shadowRays;
    }
    rtcOccluded8(valid, m_scene, &m_context, &rays);
    // rtcOccluded8 sets tfar to -inf where something blocks the ray.
    for (int k = 0; k < count; ++k) m_image.lit[pixel + k] = valid[k] && rays.tfar[k] >= 0;
  }

  const Workload& m_workload;
  RTCScene m_scene;
  unsigned m_groundId;
  durer::Camera<float> m_camera;
  Image& m_image;
  RTCIntersectContext m_context;
  durer::Vec3<float> m_towardSun{0};
  durer::RayPacket<float> m_packet;
  int64_t m_shadowRays = 0;
};

}  // namespace

EmbreeDevice::EmbreeDevice(int threads) : m_device(rtcNewDevice(("threads=" + std::to_string(threads)).c_str())) {
  if (!m_device) throw std::runtime_error("rtcNewDevice failed: error " + std::to_string(rtcGetDeviceError(nullptr)));
}

EmbreeDevice::~EmbreeDevice() { rtcReleaseDevice(m_device); }

void EmbreeDevice::check(const char* what) const {
  const RTCError error = rtcGetDeviceError(m_device);
  if (error != RTC_ERROR_NONE) {
    throw std::runtime_error(std::string(what) + " failed: Embree error " + std::to_string(error));
  }
}

EmbreeScene::EmbreeScene(const EmbreeDevice& device, const Workload& workload, bool animated)
    : m_device(device), m_workload(workload), m_scene(rtcNewScene(device.handle())) {
  if (animated) rtcSetSceneFlags(m_scene, RTC_SCENE_FLAG_DYNAMIC);
  addSpheres(animated);
  if (workload.groundPlane) addGround();
  device.check("building the Embree geometry");
}

EmbreeScene::~EmbreeScene() {
  rtcReleaseGeometry(m_spheres);
  rtcReleaseScene(m_scene);
}

void EmbreeScene::addSpheres(bool animated) {
  const RTCGeometry geometry = rtcNewGeometry(m_device.handle(), RTC_GEOMETRY_TYPE_SPHERE_POINT);
  if (animated) rtcSetGeometryBuildQuality(geometry, RTC_BUILD_QUALITY_REFIT);
  const size_t n = m_workload.sphereCount();
  auto* spheres = static_cast<float*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), n));
  for (size_t i = 0; i < n; ++i) {
    for (size_t axis = 0; axis < 3; ++axis) {
      spheres[4 * i + axis] = static_cast<float>(m_workload.centers[3 * i + axis]);
    }
    spheres[4 * i + 3] = static_cast<float>(m_workload.radii[i]);
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(m_scene, geometry);
  m_spheres = geometry;  // kept (released with the scene) for moveSpheres
}

void EmbreeScene::moveSpheres(const std::vector<double>& centers) {
  auto* spheres = static_cast<float*>(rtcGetGeometryBufferData(m_spheres, RTC_BUFFER_TYPE_VERTEX, 0));
  for (size_t i = 0; i < m_workload.sphereCount(); ++i) {
    for (size_t axis = 0; axis < 3; ++axis) spheres[4 * i + axis] = static_cast<float>(centers[3 * i + axis]);
  }
  rtcUpdateGeometryBuffer(m_spheres, RTC_BUFFER_TYPE_VERTEX, 0);
  rtcCommitGeometry(m_spheres);
  m_device.check("moving the Embree spheres");
}

void EmbreeScene::addGround() {
  const RTCGeometry geometry = rtcNewGeometry(m_device.handle(), RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4));
  const float s = kGroundHalfSize;
  const float corners[4][3] = {{-s, 0, -s}, {s, 0, -s}, {s, 0, s}, {-s, 0, s}};
  std::copy(&corners[0][0], &corners[0][0] + 12, vertices);
  auto* triangles = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 2));
  const unsigned indices[6] = {0, 1, 2, 0, 2, 3};
  std::copy(indices, indices + 6, triangles);
  rtcCommitGeometry(geometry);
  m_groundId = rtcAttachGeometry(m_scene, geometry);
  rtcReleaseGeometry(geometry);
}

void EmbreeScene::commit() {
  rtcCommitScene(m_scene);
  m_device.check("rtcCommitScene");
}

void EmbreeScene::trace(int threads, Image& image, const durer::CameraSpec& camera) const {
  if (m_workload.givenRays()) {
    traceGivenRays(threads, image);
    return;
  }
  const int64_t tiles = static_cast<int64_t>((m_workload.width + kTileSize - 1) / kTileSize) *
                        ((m_workload.height + kTileSize - 1) / kTileSize);
  const int64_t strips = (tiles + kStripTiles - 1) / kStripTiles;
  std::atomic<int64_t> nextStrip{0};
  std::atomic<int64_t> shadowRays{0};
  std::vector<std::thread> pool;
  for (int i = 0; i < threads; ++i) {
    pool.emplace_back([&] {
      TileTracer tracer(m_workload, camera, m_scene, m_groundId, image);
      for (int64_t strip; (strip = nextStrip++) < strips;) tracer.traceStrip(strip);
      shadowRays += tracer.shadowRays();
    });
  }
  for (std::thread& thread : pool) thread.join();
  image.rays = static_cast<int64_t>(m_workload.width) * m_workload.height + shadowRays.load();
}

}  // namespace bench

namespace bench {

void EmbreeScene::traceGivenRays(int threads, Image& image) const {
  constexpr int64_t kChunk = 1024;  // rays a thread takes at a time
  const int64_t count = static_cast<int64_t>(image.depth.size());
  const int64_t firstOcclusion = count - static_cast<int64_t>(m_workload.occlusionRays);
  std::atomic<int64_t> next{0};
  std::vector<std::thread> pool;
  for (int i = 0; i < threads; ++i) {
    pool.emplace_back([&] {
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      for (int64_t first; (first = next.fetch_add(kChunk)) < count;) {
        for (int64_t r = first; r < std::min(count, first + kChunk); ++r) {
          const double* o = &m_workload.rayOrigins[static_cast<size_t>(3 * r)];
          const double* d = &m_workload.rayDirections[static_cast<size_t>(3 * r)];
          RTCRayHit ray{};
          ray.ray.org_x = static_cast<float>(o[0]), ray.ray.org_y = static_cast<float>(o[1]);
          ray.ray.org_z = static_cast<float>(o[2]);
          ray.ray.dir_x = static_cast<float>(d[0]), ray.ray.dir_y = static_cast<float>(d[1]);
          ray.ray.dir_z = static_cast<float>(d[2]);
          const bool occlusion = r >= firstOcclusion;
          ray.ray.tfar = occlusion ? static_cast<float>(m_workload.occlusionTMax) : kInfinity;
          ray.ray.mask = ~0u;
          ray.hit.geomID = RTC_INVALID_GEOMETRY_ID;
          ray.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
          if (occlusion) {  // any hit: Embree sets tfar to -inf
            rtcOccluded1(m_scene, &context, &ray.ray);
            image.depth[static_cast<size_t>(r)] = ray.ray.tfar < 0 ? Workload::kOccluded : kInfinity;
            continue;
          }
          rtcIntersect1(m_scene, &context, &ray);
          image.depth[static_cast<size_t>(r)] = ray.hit.geomID == RTC_INVALID_GEOMETRY_ID ? kInfinity : ray.ray.tfar;
        }
      }
    });
  }
  for (std::thread& thread : pool) thread.join();
  image.rays = count;
}

}  // namespace bench
