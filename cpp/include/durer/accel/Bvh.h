#pragma once
// A bounding-volume hierarchy over primitives given by their boxes (spheres, triangles, boxes),
// traversed by whole packets: a node is entered when any ray of the packet may meet its box closer
// than that ray's current hit. Boxes are rounded outward and the slab test is widened by a bound on
// its own rounding error (as pbrt-v4's 1 + 2γ₃), so the hierarchy never hides a primitive that its
// own test would hit.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include "durer/geometry/RayPacket.h"
#include "durer/geometry/Slab.h"
#include "durer/math/Float.h"

namespace durer {

template <typename Real>
struct BvhNode {
  Vec3<Real> lo, hi;  // bounds of the node's primitives, rounded outward
  int32_t first;      // leaf: first primitive; inner: index of the second child (the first is the next node)
  int32_t count;      // leaf: primitives in it (> 0); inner: 0
  int32_t axis;       // inner: the split axis (0, 1, 2), to visit the near child first
};

// Each ray's reciprocal direction, for slab tests (computed once per packet and hierarchy).
template <typename Real>
struct PacketInverse {
  alignas(64) Real x[kPacketSize], y[kPacketSize], z[kPacketSize];
  explicit PacketInverse(const RayPacket<Real>& p) {
    for (int k = 0; k < p.count; ++k) x[k] = 1 / p.dx[k], y[k] = 1 / p.dy[k], z[k] = 1 / p.dz[k];
  }
};

template <typename Real>
class Bvh {
 public:
  static constexpr int kLeafSize = 4;

  bool empty() const { return m_nodes.empty(); }
  size_t size() const { return m_nodes.size(); }

  // Builds over primitives with boxes [lo[i], hi[i]] (already rounded outward by the caller);
  // returns the order the primitives must be stored in.
  std::vector<uint32_t> build(std::vector<Vec3<Real>> lo, std::vector<Vec3<Real>> hi) {
    const size_t n = lo.size();
    m_nodes.clear();
    std::vector<uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    m_lo = std::move(lo);
    m_hi = std::move(hi);
    m_centroids.resize(n);
    for (size_t i = 0; i < n; ++i) m_centroids[i] = (m_lo[i] + m_hi[i]) * Real(0.5);
    m_nodes.reserve(2 * n / kLeafSize + 1);
    if (n) buildNode(order, 0, n);
    m_lo.clear();
    m_hi.clear();
    m_centroids.clear();
    return order;
  }

  // Calls leaf(first, count) for every leaf that any ray of the packet may enter before its current
  // hit, near child first (judged by the first ray), so tHit shrinks early and prunes the far one.
  // Gives up when *cancel is set (checked every kCancelStride visits). Returns the primitives visited.
  template <typename Leaf>
  int64_t traverse(const RayPacket<Real>& packet, const std::atomic<bool>* cancel, Leaf&& leaf) const {
    const PacketInverse<Real> inv(packet);
    int64_t visited = 0;
    int32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    for (size_t visits = 1; top > 0; ++visits) {
      if ((visits & kCancelStride) == 0 && cancel && cancel->load(std::memory_order_relaxed)) break;
      const int32_t index = stack[--top];
      const BvhNode<Real>& node = m_nodes[static_cast<size_t>(index)];
      if (!anyRayEnters(packet, inv, node.lo, node.hi)) continue;
      if (node.count > 0) {
        leaf(node.first, node.count);
        visited += node.count;
        continue;
      }
      const Real along = node.axis == 0 ? packet.dx[0] : node.axis == 1 ? packet.dy[0] : packet.dz[0];
      const int32_t first = index + 1, second = node.first;
      stack[top++] = along > 0 ? second : first;
      stack[top++] = along > 0 ? first : second;
    }
    return visited;
  }

  // Whether any ray of the packet may meet the box [lo, hi] at some t in [tMin, its tHit]. Rays are
  // tested kChunk at a time (a vectorised loop each), stopping at the first chunk with a ray that
  // enters: a box the packet enters is usually entered by its first rays.
  static bool anyRayEnters(const RayPacket<Real>& p, const PacketInverse<Real>& inv, const Vec3<Real>& lo,
                           const Vec3<Real>& hi) {
    constexpr int kChunk = 16;
    for (int first = 0; first < p.count; first += kChunk) {
      if (anyEnters(p, inv, lo, hi, first, std::min(first + kChunk, p.count))) return true;
    }
    return false;
  }

  static constexpr size_t kCancelStride = 4095;  // a cancel check per 4096 visits: well under a millisecond

 private:
  static bool anyEnters(const RayPacket<Real>& p, const PacketInverse<Real>& inv, const Vec3<Real>& lo,
                        const Vec3<Real>& hi, int begin, int end) {
    constexpr Real inf = std::numeric_limits<Real>::infinity();
    int entering = 0;  // an integer count, not a bool: the reduction then vectorises
    for (int k = begin; k < end; ++k) {
      Real nearT = -inf, farT = inf;
      slab(lo.x, hi.x, p.ox[k], inv.x[k], nearT, farT);
      slab(lo.y, hi.y, p.oy[k], inv.y[k], nearT, farT);
      slab(lo.z, hi.z, p.oz[k], inv.z[k], nearT, farT);
      nearT = widenDown(nearT, kWiden);
      farT = widenUp(farT, kWiden);
      nearT = p.tMin > nearT ? p.tMin : nearT;
      farT = p.tHit[k] < farT ? p.tHit[k] : farT;
      entering += nearT <= farT ? 1 : 0;
    }
    return entering > 0;
  }

  // The slab's t are each within γ₃ of the exact ones (two roundings and the reciprocal's); widening
  // the range's ends by 2γ₃ keeps every ray that truly meets the box. Widening commutes with the max
  // and min over the slabs (it is monotonic), so it is done once, as a product: inf stays inf, no NaN.
  // The factor is 2γ₅: the product and the rounded factor add two roundings of their own.
  static constexpr Real kWiden = 2 * errorGamma<Real>(5);

  int32_t buildNode(std::vector<uint32_t>& order, size_t begin, size_t end) {
    const int32_t index = static_cast<int32_t>(m_nodes.size());
    m_nodes.push_back({});
    BvhNode<Real> node{};
    node.lo = m_lo[order[begin]];
    node.hi = m_hi[order[begin]];
    Vec3<Real> cLo = m_centroids[order[begin]], cHi = cLo;
    for (size_t i = begin; i < end; ++i) {
      node.lo = glm::min(node.lo, m_lo[order[i]]);
      node.hi = glm::max(node.hi, m_hi[order[i]]);
      cLo = glm::min(cLo, m_centroids[order[i]]);
      cHi = glm::max(cHi, m_centroids[order[i]]);
    }
    if (end - begin <= static_cast<size_t>(kLeafSize)) {
      node.first = static_cast<int32_t>(begin);
      node.count = static_cast<int32_t>(end - begin);
      m_nodes[static_cast<size_t>(index)] = node;
      return index;
    }
    // Median split of the centroids along the widest axis: O(n log n), balanced, no degenerate cases.
    const Vec3<Real> extent = cHi - cLo;
    const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
    const size_t middle = begin + (end - begin) / 2;
    std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(begin), order.begin() + static_cast<std::ptrdiff_t>(middle),
                     order.begin() + static_cast<std::ptrdiff_t>(end),
                     [&](uint32_t a, uint32_t b) { return m_centroids[a][axis] < m_centroids[b][axis]; });
    buildNode(order, begin, middle);
    node.first = buildNode(order, middle, end);
    node.count = 0;
    node.axis = axis;
    m_nodes[static_cast<size_t>(index)] = node;
    return index;
  }

  std::vector<BvhNode<Real>> m_nodes;  // depth-first: an inner node's first child follows it
  std::vector<Vec3<Real>> m_lo, m_hi, m_centroids;  // per-primitive boxes while building
};

}  // namespace durer
