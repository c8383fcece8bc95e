#pragma once
// A 4-wide bounding-volume hierarchy over primitives given by their boxes (spheres, triangles,
// boxes), built by binned SAH and traversed one ray at a time (Embree's BVH4 and pbrt-v4's builder
// are the models). A node holds its four children's boxes structure-of-arrays, so one ray meets all
// four with one vectorised slab test; children are visited nearest first and a child is dropped as
// soon as its entry lies beyond the ray's current hit. Boxes are rounded outward and the slab test is
// widened by a bound on its own rounding error (as pbrt-v4's 1 + 2γ₃), so the hierarchy never hides
// a primitive that its own test would hit.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <thread>
#include <vector>

#include "durer/geometry/Slab.h"
#include "durer/math/Float.h"

namespace durer {

template <typename Real>
struct alignas(64) BvhNode {
  static constexpr int kWidth = 4;
  Real bounds[2][3][kWidth];  // [lo, hi][axis][child]: the children's boxes, rounded outward
  int32_t child[kWidth];      // inner child: its node index; leaf: its first primitive; empty slot: -1
  int32_t count[kWidth];      // leaf: its primitives (> 0); inner child and empty slot: 0
};

// One ray as the traversal sees it, set up once per ray: origin, reciprocal direction, which bound
// of each axis it meets first, and the range of t it counts.
template <typename Real>
struct BvhRay {
  Real o[3];
  Real inv[3];
  int nearBound[3];  // 0: lo is entered first on this axis (inv >= 0, +0 included), 1: hi
  Real tMin;

  BvhRay(Real ox, Real oy, Real oz, Real dx, Real dy, Real dz, Real tMin_) : o{ox, oy, oz}, tMin(tMin_) {
    const Real d[3] = {dx, dy, dz};
    for (int a = 0; a < 3; ++a) {
      inv[a] = 1 / d[a];
      nearBound[a] = std::signbit(inv[a]) ? 1 : 0;
    }
  }
};

// A node's four child lanes as one SIMD vector.
template <typename Real>
struct NodeLanes;
template <>
struct NodeLanes<float> {
  typedef float Type __attribute__((vector_size(16)));
};
template <>
struct NodeLanes<double> {
  typedef double Type __attribute__((vector_size(32)));
};

template <typename Real>
class Bvh {
 public:
  static constexpr int kMaxLeafSize = 4;

  bool empty() const { return m_nodes.empty(); }
  size_t size() const { return m_nodes.size(); }
  size_t bytes() const { return m_nodes.size() * sizeof(BvhNode<Real>); }

  // Builds over primitives with boxes [lo[i], hi[i]] (already rounded outward by the caller) on up to
  // `threads` threads; returns the order the primitives must be stored in.
  std::vector<uint32_t> build(const std::vector<Vec3<Real>>& lo, const std::vector<Vec3<Real>>& hi, int threads);

  // Calls leaf(first, count) for every leaf the ray may meet before tHit (which leaf may lower),
  // nearest first; stops early when leaf returns true (a shadow ray's any hit). Returns the
  // primitives visited.
  template <typename Leaf>
  int64_t traverse(const BvhRay<Real>& ray, const Real& tHit, Leaf&& leaf) const {
    Stack stack;
    int64_t visited = 0;
    int32_t node = 0;
    for (;;) {
      pushChildren(m_nodes[static_cast<size_t>(node)], ray, tHit, stack);
      for (;;) {
        if (stack.top == 0) return visited;
        const int e = --stack.top;
        if (stack.tNear[e] > tHit) continue;  // the hit found since it was pushed is nearer
        if (stack.count[e] == 0) {
          node = stack.child[e];
          break;
        }
        visited += stack.count[e];
        if (leaf(stack.child[e], stack.count[e])) return visited;
      }
    }
  }


 private:
  // Binary depth is bounded by the build (kMaxDepth); a 4-wide node pushes at most 3 entries per level.
  static constexpr int kMaxDepth = 64;
  static constexpr int kStackSize = 3 * kMaxDepth + 4;

  // Children still to visit, structure-of-arrays (a struct per entry costs store-forwarding stalls).
  struct Stack {
    Real tNear[kStackSize];
    int32_t child[kStackSize];
    int32_t count[kStackSize];
    int top = 0;
  };

  // The slab's t are each within γ₃ of the exact ones (two roundings and the reciprocal's); widening
  // the range's ends by 2γ₃ keeps every ray that truly meets the box. Widening commutes with the max
  // and min over the slabs (it is monotonic), so it is done once, as a product: inf stays inf, no NaN.
  // The factor is 2γ₅: the product and the rounded factor add two roundings of their own.
  static constexpr Real kWiden = 2 * errorGamma<Real>(5);

  // The four children's lanes as one SIMD vector (GCC/Clang vector extensions: SSE for float, AVX
  // for double where the kernel set has it, two SSE halves otherwise).
  using Lanes = typename NodeLanes<Real>::Type;
  static Lanes load(const Real* p) {
    Lanes v;
    std::memcpy(&v, p, sizeof v);
    return v;
  }
  static Lanes broadcast(Real x) { return Lanes{} + x; }

  // Pushes the children of `node` that the ray enters in [tMin, tHit], farthest first. Each axis'
  // near and far bound are picked once per ray, so a slab costs a subtraction and a product per
  // bound and no min/max. A bound minus the origin is moved outward by the least normal number (lo
  // down, hi up; it rounds back unless the difference is below ~1e-31 or 1e-292), so that a ray
  // parallel to an axis (inv = ±inf) whose origin lies on a box face gets ∓inf, inside, never
  // 0·inf = NaN. (Not a subnormal: those cost microcode assists on x86.)
  static void pushChildren(const BvhNode<Real>& node, const BvhRay<Real>& ray, Real tHit, Stack& stack) {
    constexpr Real tiny = std::numeric_limits<Real>::min();
    constexpr int W = BvhNode<Real>::kWidth;
    Lanes tn = broadcast(ray.tMin), tf = broadcast(tHit);
    Lanes nearT[3], farT[3];
    for (int a = 0; a < 3; ++a) {
      const int n = ray.nearBound[a];
      const Real shift = n ? tiny : -tiny;
      const Lanes o = broadcast(ray.o[a]), inv = broadcast(ray.inv[a]);
      nearT[a] = ((load(node.bounds[n][a]) - o) + shift) * inv;
      farT[a] = ((load(node.bounds[1 - n][a]) - o) - shift) * inv;
    }
    Lanes entry = nearT[0] > nearT[1] ? nearT[0] : nearT[1];
    entry = nearT[2] > entry ? nearT[2] : entry;
    Lanes exit = farT[0] < farT[1] ? farT[0] : farT[1];
    exit = farT[2] < exit ? farT[2] : exit;
    entry *= entry > 0 ? broadcast(1 - kWiden) : broadcast(1 + kWiden);
    exit *= exit > 0 ? broadcast(1 + kWiden) : broadcast(1 - kWiden);
    tn = tn > entry ? tn : entry;
    tf = tf < exit ? tf : exit;
    Real near[W], enters[W];
    std::memcpy(near, &tn, sizeof near);
    const Lanes entered = tn <= tf ? broadcast(1) : broadcast(0);
    std::memcpy(enters, &entered, sizeof enters);
    // Insertion by entry t: the nearest child ends on top of the stack.
    const int base = stack.top;
    for (int i = 0; i < W; ++i) {
      if (!(enters[i] > 0) || node.child[i] < 0) continue;
      int j = stack.top++;
      for (; j > base && stack.tNear[j - 1] < near[i]; --j) {
        stack.tNear[j] = stack.tNear[j - 1], stack.child[j] = stack.child[j - 1], stack.count[j] = stack.count[j - 1];
      }
      stack.tNear[j] = near[i], stack.child[j] = node.child[i], stack.count[j] = node.count[i];
    }
  }

  struct Builder;
  std::vector<BvhNode<Real>> m_nodes;  // the root first
};

// The binned-SAH build (Wald 2007; pbrt-v4's BVHAggregate): a binary tree first, each split the
// best of kBins planes per axis by surface area × primitives, then collapsed to 4-wide nodes by
// opening the largest child until four. Subtrees below the first levels build in parallel.
template <typename Real>
struct Bvh<Real>::Builder {
  static constexpr int kBins = 16;
  static constexpr uint32_t kParallelMin = 1u << 14;  // smaller subtrees are not worth a thread

  struct Box {
    Vec3<Real> lo{std::numeric_limits<Real>::infinity()}, hi{-std::numeric_limits<Real>::infinity()};
    void grow(const Vec3<Real>& l, const Vec3<Real>& h) { lo = glm::min(lo, l), hi = glm::max(hi, h); }
    void grow(const Box& b) { grow(b.lo, b.hi); }
    Real area() const {
      const Vec3<Real> e = hi - lo;
      return e.x < 0 ? Real(0) : e.x * e.y + e.y * e.z + e.z * e.x;
    }
  };
  // A binary node: inner (count 0) with children left and right, or a leaf of primitives
  // order[first, first + count).
  struct Node {
    Box box;
    int32_t left = -1, right = -1;
    uint32_t first = 0, count = 0;
  };
  // A subtree built on its own thread into nodes of its own; the parent's child index points at it.
  struct Subtree {
    std::vector<Node> nodes;
  };

  const std::vector<Vec3<Real>>& lo;
  const std::vector<Vec3<Real>>& hi;
  std::vector<Vec3<Real>> centroid;
  std::vector<uint32_t> order;
  std::vector<Subtree> trees;  // tree 0: the top levels

  Builder(const std::vector<Vec3<Real>>& l, const std::vector<Vec3<Real>>& h) : lo(l), hi(h) {
    centroid.resize(lo.size());
    for (size_t i = 0; i < lo.size(); ++i) centroid[i] = (lo[i] + hi[i]) * Real(0.5);
    order.resize(lo.size());
    std::iota(order.begin(), order.end(), 0u);
  }

  // A child reference: >= 0 a node of the same tree; < 0 the root of tree -(ref + 1).
  static int32_t treeRef(size_t tree) { return -static_cast<int32_t>(tree) - 1; }

  void run(int threads) {
    trees.resize(1);
    struct Task {
      size_t tree;
      uint32_t begin, end;
    };
    std::vector<Task> tasks;
    // The top levels split serially until there is a subtree per thread and then some (for balance).
    const uint32_t grain = std::max<uint32_t>(kParallelMin, static_cast<uint32_t>(order.size() / (4 * std::max(threads, 1))));
    trees.reserve(order.size() / kParallelMin + 2);  // a task per disjoint range of >= kParallelMin: no reallocation
    const auto spawn = [&](uint32_t begin, uint32_t end) {
      if (threads <= 1 || end - begin < kParallelMin || end - begin > grain) return false;
      trees.emplace_back();
      tasks.push_back({trees.size() - 1, begin, end});
      return true;
    };
    buildNode(trees[0].nodes, 0, static_cast<uint32_t>(order.size()), 0, spawn);
    std::vector<std::thread> workers;
    std::atomic<size_t> next{0};
    const auto work = [&] {
      for (size_t t; (t = next.fetch_add(1)) < tasks.size();) {
        const auto never = [](uint32_t, uint32_t) { return false; };
        buildNode(trees[tasks[t].tree].nodes, tasks[t].begin, tasks[t].end, 0, never);
      }
    };
    for (int t = 1; t < threads && static_cast<size_t>(t) < tasks.size(); ++t) workers.emplace_back(work);
    work();
    for (std::thread& w : workers) w.join();
  }

  const Node& node(size_t tree, int32_t ref) const {
    return ref < 0 ? trees[static_cast<size_t>(-ref - 1)].nodes[0] : trees[tree].nodes[static_cast<size_t>(ref)];
  }
  size_t treeOf(size_t tree, int32_t ref) const { return ref < 0 ? static_cast<size_t>(-ref - 1) : tree; }

  // Builds order[begin, end) into `nodes`, returning its index there (or, when spawn takes the
  // range, a reference to the subtree that will hold it).
  template <typename Spawn>
  int32_t buildNode(std::vector<Node>& nodes, uint32_t begin, uint32_t end, int depth, const Spawn& spawn) {
    if (depth > 0 && spawn(begin, end)) return treeRef(trees.size() - 1);
    const int32_t index = static_cast<int32_t>(nodes.size());
    nodes.emplace_back();
    Box box, centroids;
    for (uint32_t i = begin; i < end; ++i) {
      box.grow(lo[order[i]], hi[order[i]]);
      centroids.grow(centroid[order[i]], centroid[order[i]]);
    }
    const uint32_t count = end - begin;
    uint32_t middle = end;  // end: a leaf
    if (count > static_cast<uint32_t>(kMaxLeafSize) && depth < kMaxDepth - 1) {
      middle = split(begin, end, box, centroids);
      // No plane separates them (equal centroids): halve the range.
      if (middle == begin || (middle == end && count > 2 * static_cast<uint32_t>(kMaxLeafSize))) middle = begin + count / 2;
    }
    if (middle == end) {
      nodes[static_cast<size_t>(index)].box = box;
      nodes[static_cast<size_t>(index)].first = begin;
      nodes[static_cast<size_t>(index)].count = count;
      return index;
    }
    const int32_t left = buildNode(nodes, begin, middle, depth + 1, spawn);
    const int32_t right = buildNode(nodes, middle, end, depth + 1, spawn);
    Node& n = nodes[static_cast<size_t>(index)];
    n.box = box, n.left = left, n.right = right;
    return index;
  }

  // Partitions order[begin, end) at the cheapest binned SAH plane; returns the first index of the
  // right side, or `end` when a leaf is cheaper than any split (only for a few primitives).
  uint32_t split(uint32_t begin, uint32_t end, const Box& box, const Box& centroids) {
    const Vec3<Real> extent = centroids.hi - centroids.lo;
    Box bins[3][kBins];
    uint32_t counts[3][kBins] = {};
    Vec3<Real> scale;
    for (int a = 0; a < 3; ++a) scale[a] = extent[a] > 0 ? Real(kBins) * (1 - std::numeric_limits<Real>::epsilon()) / extent[a] : 0;
    for (uint32_t i = begin; i < end; ++i) {
      const uint32_t p = order[i];
      for (int a = 0; a < 3; ++a) {
        const int b = binOf(centroid[p][a], centroids.lo[a], scale[a]);
        ++counts[a][b];
        bins[a][b].grow(lo[p], hi[p]);
      }
    }
    Real bestCost = std::numeric_limits<Real>::infinity();
    int bestAxis = -1, bestBin = 0;
    for (int a = 0; a < 3; ++a) {
      if (!(extent[a] > 0)) continue;
      Real rightArea[kBins];
      uint32_t rightCount[kBins];
      Box right;
      uint32_t n = 0;
      for (int b = kBins - 1; b > 0; --b) {
        right.grow(bins[a][b]), n += counts[a][b];
        rightArea[b] = right.area(), rightCount[b] = n;
      }
      Box left;
      n = 0;
      for (int b = 1; b < kBins; ++b) {  // plane between bin b - 1 and bin b
        left.grow(bins[a][b - 1]), n += counts[a][b - 1];
        const Real cost = left.area() * Real(n) + rightArea[b] * Real(rightCount[b]);
        if (n > 0 && rightCount[b] > 0 && cost < bestCost) bestCost = cost, bestAxis = a, bestBin = b;
      }
    }
    const uint32_t count = end - begin;
    // A traversal step costs about one primitive test: split while that is cheaper than testing all.
    if (bestAxis < 0) return end;
    if (count <= 2 * static_cast<uint32_t>(kMaxLeafSize) && bestCost / box.area() + 1 >= Real(count)) return end;
    const Real axisLo = centroids.lo[bestAxis], axisScale = scale[bestAxis];
    const auto mid = std::partition(order.begin() + begin, order.begin() + end, [&](uint32_t p) {
      return binOf(centroid[p][bestAxis], axisLo, axisScale) < bestBin;
    });
    return static_cast<uint32_t>(mid - order.begin());
  }

  static int binOf(Real c, Real lo, Real scale) {
    const int b = static_cast<int>((c - lo) * scale);
    return b < 0 ? 0 : b >= kBins ? kBins - 1 : b;
  }

  // The 4-wide node of binary inner node `ref` of `tree`, and those below it, appended to out.
  int32_t collapse(size_t tree, int32_t ref, std::vector<BvhNode<Real>>& out) const {
    const int32_t index = static_cast<int32_t>(out.size());
    out.emplace_back();
    // Open the largest inner child until there are four (or only leaves).
    struct Slot {
      size_t tree;
      int32_t ref;
    };
    Slot slots[4];
    const Node& n = node(tree, ref);
    const size_t t = treeOf(tree, ref);
    slots[0] = {t, n.left}, slots[1] = {t, n.right};
    int used = 2;
    while (used < 4) {
      int largest = -1;
      Real largestArea = -1;
      for (int s = 0; s < used; ++s) {
        const Node& c = node(slots[s].tree, slots[s].ref);
        if (c.count == 0 && c.box.area() > largestArea) largest = s, largestArea = c.box.area();
      }
      if (largest < 0) break;
      const Node& c = node(slots[largest].tree, slots[largest].ref);
      const size_t ct = treeOf(slots[largest].tree, slots[largest].ref);
      slots[largest] = {ct, c.left};
      slots[used++] = {ct, c.right};
    }
    BvhNode<Real> wide;
    for (int s = 0; s < 4; ++s) {
      const bool present = s < used;
      const Node* c = present ? &node(slots[s].tree, slots[s].ref) : nullptr;
      for (int a = 0; a < 3; ++a) {
        wide.bounds[0][a][s] = present ? c->box.lo[a] : std::numeric_limits<Real>::infinity();
        wide.bounds[1][a][s] = present ? c->box.hi[a] : -std::numeric_limits<Real>::infinity();
      }
      wide.child[s] = present ? static_cast<int32_t>(c->first) : -1;
      wide.count[s] = present ? static_cast<int32_t>(c->count) : 0;
    }
    for (int s = 0; s < used; ++s) {
      const Node& c = node(slots[s].tree, slots[s].ref);
      if (c.count == 0) wide.child[s] = collapse(slots[s].tree, slots[s].ref, out);
    }
    out[static_cast<size_t>(index)] = wide;
    return index;
  }
};

template <typename Real>
std::vector<uint32_t> Bvh<Real>::build(const std::vector<Vec3<Real>>& lo, const std::vector<Vec3<Real>>& hi,
                                       int threads) {
  m_nodes.clear();
  if (lo.empty()) return {};
  Builder builder(lo, hi);
  builder.run(threads);
  const typename Builder::Node& root = builder.trees[0].nodes[0];
  if (root.count > 0) {  // a single leaf: a root node with one child
    BvhNode<Real> wide;
    for (int s = 0; s < 4; ++s) {
      for (int a = 0; a < 3; ++a) {
        wide.bounds[0][a][s] = s == 0 ? root.box.lo[a] : std::numeric_limits<Real>::infinity();
        wide.bounds[1][a][s] = s == 0 ? root.box.hi[a] : -std::numeric_limits<Real>::infinity();
      }
      wide.child[s] = s == 0 ? 0 : -1;
      wide.count[s] = s == 0 ? static_cast<int32_t>(root.count) : 0;
    }
    m_nodes.push_back(wide);
  } else {
    size_t binaryNodes = 0;
    for (const auto& t : builder.trees) binaryNodes += t.nodes.size();
    m_nodes.reserve(binaryNodes / 2 + 1);
    builder.collapse(0, 0, m_nodes);
  }
  return std::move(builder.order);
}

}  // namespace durer
