#pragma once
// The cast kernel: batches of arbitrary rays, kRaysPerItem per work item, searched as packets and
// their hit records written out. Instantiated per precision and sphere method in src/kernels.
#include <algorithm>
#include <atomic>
#include <limits>

#include "durer/geometry/RayPacket.h"
#include "durer/render/Kernels.h"

namespace durer {


constexpr int64_t kRaysPerItem = 16 * kPacketSize;  // enough work per queue item to hide its cost

// Casts one work item's rays; returns the ray-primitive tests made.
template <typename Real, typename Methods>
int64_t castRays(const Group<Real>& group, const CastInput& in, const CastOutput<Real>& out, int64_t item,
                 const std::atomic<bool>& cancel) {
  const size_t begin = static_cast<size_t>(item * kRaysPerItem);
  const size_t end = std::min(in.count, begin + kRaysPerItem);
  int64_t tests = 0;
  RayPacket<Real> packet;
  packet.tMin = static_cast<Real>(in.tMin);
  packet.tMax = static_cast<Real>(in.tMax);
  for (size_t first = begin; first < end; first += kPacketSize) {
    packet.count = static_cast<int>(std::min<size_t>(kPacketSize, end - first));
    for (int k = 0; k < packet.count; ++k) {
      const double* o = in.origins + 3 * (first + k);
      const double* d = in.directions + 3 * (first + k);
      packet.ox[k] = static_cast<Real>(o[0]);
      packet.oy[k] = static_cast<Real>(o[1]);
      packet.oz[k] = static_cast<Real>(o[2]);
      packet.dx[k] = static_cast<Real>(d[0]);
      packet.dy[k] = static_cast<Real>(d[1]);
      packet.dz[k] = static_cast<Real>(d[2]);
    }
    tests += in.anyHit ? group.template occluded<Methods>(in.sphereMethod, packet, &cancel)
                       : group.template intersect<Methods>(in.sphereMethod, packet, &cancel);
    if (cancel.load(std::memory_order_relaxed)) return tests;
    if (in.anyHit) {
      for (int k = 0; k < packet.count; ++k) {
        out.t[first + k] = packet.prim[k] != kNoPrimitive ? packet.tHit[k] : std::numeric_limits<Real>::infinity();
      }
      continue;
    }
    group.forEachHitRecord(packet, packet.count, [&](int k) {
      const size_t i = first + k;
      const Hit<Real> hit = group.hit(packet, k);
      out.t[i] = hit.t;
      for (int c = 0; c < 3; ++c) out.normal[3 * i + c] = hit.normal[c];
      out.objectId[i] = hit.objectId;
      out.materialId[i] = hit.materialId;
    });
  }
  return tests;
}

template <typename Real, typename Methods>
CastStats castWith(const CastJob<Real>& job) {
  const Scene& scene = job.scene;
  const CastInput& in = job.input;
  const CastOutput<Real>& out = job.output;
  JobControl& control = job.control;
  const std::shared_ptr<const Group<Real>> prepared = scene.prepared<Real>(in.threads);
  const Group<Real>& group = *prepared;
  const int64_t items = (static_cast<int64_t>(in.count) + kRaysPerItem - 1) / kRaysPerItem;
  const int threads = in.threads > 0 ? in.threads : defaultThreadCount();
  std::atomic<int64_t> tests{0};
  runParallel(
      items, threads, control,
      [&](int64_t item, int) {
        tests.fetch_add(castRays<Real, Methods>(group, in, out, item, control.cancel));
      },
      job.poll);
  CastStats stats;
  stats.intersectionTests = tests.load();
  return stats;
}

}  // namespace durer
