#pragma once
// A bounding-volume hierarchy over spheres, traversed by whole packets: a node is entered when any
// ray of the packet may meet its box closer than that ray's current hit. Boxes are rounded outward
// and the slab test is widened by its own error bound (pbrt-v4's 1 + 2γ₃), so the hierarchy never
// hides a sphere that the sphere test would hit.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include "durer/RayOffset.h"
#include "durer/RayPacket.h"
#include "durer/Vec.h"

namespace durer {

template <typename Real>
struct BvhNode {
  Vec3<Real> lo, hi;  // bounds of the node's spheres, rounded outward
  int32_t first;      // leaf: first sphere; inner: index of the second child (the first is the next node)
  int32_t count;      // leaf: spheres in it (> 0); inner: 0
  int32_t axis;       // inner: the split axis (0, 1, 2), to visit the near child first
};

template <typename Real>
class SphereBvh {
 public:
  static constexpr int kLeafSize = 4;

  bool empty() const { return m_nodes.empty(); }
  const BvhNode<Real>& node(int32_t i) const { return m_nodes[static_cast<size_t>(i)]; }
  size_t size() const { return m_nodes.size(); }

  // Builds over spheres (centres, radii); returns the order the spheres must be stored in.
  std::vector<uint32_t> build(const std::vector<Vec3<Real>>& centers, const std::vector<Real>& radii) {
    const size_t n = centers.size();
    m_nodes.clear();
    std::vector<uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    m_lo.resize(n);
    m_hi.resize(n);
    constexpr Real inf = std::numeric_limits<Real>::infinity();
    for (size_t i = 0; i < n; ++i) {
      for (int a = 0; a < 3; ++a) {
        m_lo[i][a] = std::nextafter(centers[i][a] - radii[i], -inf);
        m_hi[i][a] = std::nextafter(centers[i][a] + radii[i], inf);
      }
    }
    m_nodes.reserve(2 * n / kLeafSize + 1);
    if (n) buildNode(order, 0, n, centers);
    m_lo.clear();
    m_hi.clear();
    return order;
  }

  // Whether any ray of the packet may meet the box at some t in [tMin, its tHit].
  static bool anyRayEnters(const RayPacket<Real>& p, const Real* invX, const Real* invY, const Real* invZ,
                           const BvhNode<Real>& box) {
    int entering = 0;  // an integer count, not a bool: the reduction then vectorises
    for (int k = 0; k < p.count; ++k) {
      Real nearT = p.tMin, farT = p.tHit[k];
      slab(box.lo.x, box.hi.x, p.ox[k], invX[k], nearT, farT);
      slab(box.lo.y, box.hi.y, p.oy[k], invY[k], nearT, farT);
      slab(box.lo.z, box.hi.z, p.oz[k], invZ[k], nearT, farT);
      entering += nearT <= farT ? 1 : 0;
    }
    return entering > 0;
  }

 private:
  // Narrows [nearT, farT] to one slab, widened by the test's rounding error (two roundings and the
  // reciprocal's: γ₃ each side); a NaN from 0·inf (a ray parallel to the slab, its origin on a
  // face, so inside it) leaves the range as it was.
  static void slab(Real lo, Real hi, Real o, Real inv, Real& nearT, Real& farT) {
    constexpr Real inf = std::numeric_limits<Real>::infinity();
    const Real t0 = (lo - o) * inv, t1 = (hi - o) * inv;
    const Real slack = 2 * errorGamma<Real>(3);
    const bool defined = (t0 == t0) & (t1 == t1);
    Real tNear = defined ? (t0 < t1 ? t0 : t1) : -inf;
    Real tFar = defined ? (t0 < t1 ? t1 : t0) : inf;
    // Widen finite ends only: inf - slack·inf would be NaN, and an infinite end needs no slack.
    const Real widenNear = slack * std::fabs(tNear), widenFar = slack * std::fabs(tFar);
    tNear -= widenNear < inf ? widenNear : Real(0);
    tFar += widenFar < inf ? widenFar : Real(0);
    nearT = tNear > nearT ? tNear : nearT;
    farT = tFar < farT ? tFar : farT;
  }

  int32_t buildNode(std::vector<uint32_t>& order, size_t begin, size_t end, const std::vector<Vec3<Real>>& centers) {
    const int32_t index = static_cast<int32_t>(m_nodes.size());
    m_nodes.push_back({});
    BvhNode<Real> node{};
    node.lo = m_lo[order[begin]];
    node.hi = m_hi[order[begin]];
    Vec3<Real> cLo = centers[order[begin]], cHi = cLo;
    for (size_t i = begin; i < end; ++i) {
      node.lo = glm::min(node.lo, m_lo[order[i]]);
      node.hi = glm::max(node.hi, m_hi[order[i]]);
      cLo = glm::min(cLo, centers[order[i]]);
      cHi = glm::max(cHi, centers[order[i]]);
    }
    if (end - begin <= static_cast<size_t>(kLeafSize)) {
      node.first = static_cast<int32_t>(begin);
      node.count = static_cast<int32_t>(end - begin);
      m_nodes[static_cast<size_t>(index)] = node;
      return index;
    }
    // Median split of the centres along the widest axis: O(n log n), balanced, no degenerate cases.
    const Vec3<Real> extent = cHi - cLo;
    const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
    const size_t middle = begin + (end - begin) / 2;
    std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(begin), order.begin() + static_cast<std::ptrdiff_t>(middle),
                     order.begin() + static_cast<std::ptrdiff_t>(end),
                     [&](uint32_t a, uint32_t b) { return centers[a][axis] < centers[b][axis]; });
    buildNode(order, begin, middle, centers);
    node.first = buildNode(order, middle, end, centers);
    node.count = 0;
    node.axis = axis;
    m_nodes[static_cast<size_t>(index)] = node;
    return index;
  }

  std::vector<BvhNode<Real>> m_nodes;  // depth-first: an inner node's first child follows it
  std::vector<Vec3<Real>> m_lo, m_hi;  // per-sphere boxes while building
};

}  // namespace durer
