#pragma once
#include <embree3/rtcore.h>

#include "Image.h"
#include "Workload.h"

namespace bench {

// An Embree device; its build threads are Embree's own (TBB), capped by "threads=N".
class EmbreeDevice {
 public:
  explicit EmbreeDevice(int threads);
  ~EmbreeDevice();
  EmbreeDevice(const EmbreeDevice&) = delete;
  EmbreeDevice& operator=(const EmbreeDevice&) = delete;

  RTCDevice handle() const { return m_device; }
  void check(const char* what) const;  // throws std::runtime_error if Embree reported an error

 private:
  RTCDevice m_device;
};

// A workload's geometry in Embree: its spheres as RTC_GEOMETRY_TYPE_SPHERE_POINT (float x, y, z, r)
// and its ground plane as a quad far larger than anything the camera sees.
class EmbreeScene {
 public:
  // Fills the buffers; no build. `animated`: Embree's set-up for geometry that moves between
  // frames (RTC_SCENE_FLAG_DYNAMIC, the spheres refitted: RTC_BUILD_QUALITY_REFIT).
  EmbreeScene(const EmbreeDevice& device, const Workload& workload, bool animated = false);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  void commit();  // rtcCommitScene: the hierarchy build
  // Writes the spheres' new centres (count x 3) into their buffer and marks it updated; the next
  // commit refits (animated) or rebuilds.
  void moveSpheres(const std::vector<double>& centers);

  // Traces the camera's rays (Dürer's Camera<float>: the rays Dürer's float render makes) with
  // rtcIntersect8 on `threads` std::threads, and with a sun the occlusion rays of the hits facing it
  // with rtcOccluded8; given rays one at a time with rtcIntersect1 (Embree's call for incoherent rays).
  void trace(int threads, Image& image) const { trace(threads, image, m_workload.camera); }
  void trace(int threads, Image& image, const durer::CameraSpec& camera) const;  // another pose's rays

 private:
  void traceGivenRays(int threads, Image& image) const;
  void addSpheres(bool animated);
  void addGround();

  const EmbreeDevice& m_device;
  const Workload& m_workload;
  RTCScene m_scene;
  RTCGeometry m_spheres;
  unsigned m_groundId = RTC_INVALID_GEOMETRY_ID;
};

}  // namespace bench
