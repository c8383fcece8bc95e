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
#include <memory>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#if defined(__SSE__)
#include <immintrin.h>
#endif

#include "durer/Inline.h"
#include "durer/geometry/Slab.h"
#include "durer/math/Float.h"

namespace durer {

// Below this many primitives a packet tests them all faster than its rays walk a hierarchy: a set
// builds none (Group::prepare).
inline constexpr size_t kBvhMinPrimitives = 16;

// The children's boxes are single precision in both precisions' trees, rounded outward (so still
// bounds): a double ray's slab test reads them exactly as doubles. A node is then two cache lines,
// not four, for double traversal too.
struct alignas(64) BvhNode {
  static constexpr int kWidth = 4;
  float bounds[2][3][kWidth];  // [lo, hi][axis][child]: the children's boxes, rounded outward
  int32_t child[kWidth];       // inner child: its node index; leaf: its first primitive; empty slot: -1
  int32_t count[kWidth];       // leaf: its primitives (> 0); inner child and empty slot: 0
};

// One ray as the traversal sees it, set up once per ray: origin, reciprocal direction, which bound
// of each axis it meets first (as the index of that bound's lanes in a node), how that bound minus
// the origin is moved outward (Bvh::childEntries), and the range of t it counts.
template <typename Real>
struct BvhRay {
  Real o[3];
  Real inv[3];
  Real nearShift[3];  // -tiny where lo is entered first (inv >= 0, +0 included), +tiny where hi is
  int nearLanes[3], farLanes[3];  // offsets in floats of the near and far bounds' lanes in BvhNode::bounds
  Real tMin;

  BvhRay() = default;
  BvhRay(Real ox, Real oy, Real oz, Real dx, Real dy, Real dz, Real tStart) : o{ox, oy, oz}, tMin(tStart) {
    constexpr Real tiny = std::numeric_limits<Real>::min();
    const Real d[3] = {dx, dy, dz};
    for (int a = 0; a < 3; ++a) {
      inv[a] = 1 / d[a];
      const int nearBound = std::signbit(inv[a]) ? 1 : 0;
      nearShift[a] = nearBound ? tiny : -tiny;
      nearLanes[a] = (nearBound * 3 + a) * 4, farLanes[a] = ((1 - nearBound) * 3 + a) * 4;
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

// f(chunk, begin, end) over [0, count) in `chunks` chunks, chunk 0 on this thread.
template <typename F>
void forChunks(size_t count, size_t chunks, const F& f) {
  std::vector<std::thread> workers;
  for (size_t c = 1; c < chunks; ++c) workers.emplace_back(f, c, count * c / chunks, count * (c + 1) / chunks);
  f(size_t(0), size_t(0), count / chunks);
  for (std::thread& w : workers) w.join();
}

// f() on `threads` threads at once, this one among them (none when 0).
template <typename F>
void runOnThreads(size_t threads, const F& f) {
  if (threads == 0) return;
  std::vector<std::thread> workers;
  for (size_t t = 1; t < threads; ++t) workers.emplace_back(f);
  f();
  for (std::thread& w : workers) w.join();
}

// How parallelChunks divides `count` items: a chunk per thread, or fewer so that each holds at least
// kMin items (below that starting threads costs more than it saves).
inline size_t chunksFor(size_t count, int threads) {
  constexpr size_t kMin = size_t(1) << 16;
  return count < kMin ? 1 : std::min<size_t>(static_cast<size_t>(std::max(threads, 1)), count / kMin);
}

// f(begin, end) over [0, count) in chunksFor(count, threads) chunks.
template <typename F>
void parallelChunks(size_t count, int threads, const F& f) {
  forChunks(count, chunksFor(count, threads), [&](size_t, size_t begin, size_t end) { f(begin, end); });
}

template <typename Real>
class Bvh {
 public:
  static constexpr int kMaxLeafSize = 4;
  static constexpr int kInterleaved = 8;  // rays walking at once in traverseInterleaved

  bool empty() const { return m_nodes.empty(); }

  // Builds over `count` primitives with boxes boxOf(i, lo, hi) (rounded outward by boxOf) on up to
  // `threads` threads; returns the order the primitives must be stored in.
  template <typename BoxOf>
  std::vector<uint32_t> build(size_t count, const BoxOf& boxOf, int threads);

  // Keeps the tree and recomputes its boxes from the primitives' boxes boxOf(i, lo, hi) (the
  // primitives in the order build returned, moved since) on up to `threads` threads: an animation
  // frame's refit instead of a rebuild. Returns the tree's SAH cost now over its cost when built:
  // moved primitives stretch boxes that were tight, and a caller rebuilds once the traversal would
  // pay more than a build.
  template <typename BoxOf>
  double refit(const BoxOf& boxOf, int threads);

  // Calls leaf(first, count) for every leaf the ray may meet before tHit (which leaf may lower),
  // nearest first, from the root or from inner node `node`; stops early when leaf returns true (a
  // shadow ray's any hit). Returns the primitives visited.
  template <typename Leaf>
  int64_t traverse(const BvhRay<Real>& ray, const Real& tHit, Leaf&& leaf, int32_t node = 0) const {
    Stack stack;
    int64_t visited = 0;
    int32_t child = node, count = 0;  // the next step: inner node `child` (count 0) or a leaf
    for (;;) {
      if (count == 0) {
        const BvhNode& inner = m_nodes[static_cast<size_t>(child)];
        Real entry[BvhNode::kWidth];
        const int nearest = pushFartherChildren(inner, childEntries(inner, ray, tHit, entry), entry, stack);
        if (nearest >= 0) {
          child = inner.child[nearest], count = inner.count[nearest];
          continue;
        }
      } else {
        visited += count;
        if (leaf(child, count)) return visited;
      }
      if (!stack.pop(tHit, child, count)) return visited;
    }
  }

  // traverse() for the packet's rays rays[0 .. count), several at once: one ray's walk is a chain of
  // dependent loads and node tests, each waiting on the one before, and incoherent rays (shadows,
  // reflections) through a tree larger than the cache wait on every load. Here kInterleaved walks
  // take turns, a turn ending where its ray needs a node or a leaf's primitives not read yet; those
  // are prefetched (touch(first, count) for a leaf) and read on its next turn, so the misses of
  // several rays overlap, and a round tests every walk's node before any walk branches on its test,
  // so the tests overlap too. A walk whose ray is done takes the next one. Each ray visits the same
  // nodes and leaves in the same order as with traverse(), calling leaf(first, count, k) for ray k:
  // the same hits. Returns the primitives visited.
  template <typename Leaf, typename Touch>
  int64_t traverseInterleaved(const RayPacket<Real>& p, const int* rays, int count, const Leaf& leaf,
                              const Touch& touch) const {
    struct Walk {
      BvhRay<Real> ray;
      Stack stack;
      int k;
      int32_t leafFirst, leafCount;  // leafCount > 0: test this leaf next
      int32_t node;                  // else: visit this node next
    };
    Walk walks[kInterleaved];
    int next = 0, active = 0;
    const auto start = [&](Walk& walk) {
      if (next == count) return false;
      const int k = walk.k = rays[next++];
      walk.ray = BvhRay<Real>(p.ox[k], p.oy[k], p.oz[k], p.dx[k], p.dy[k], p.dz[k], p.tMin);
      walk.stack.top = 0, walk.node = 0, walk.leafCount = 0;
      return true;
    };
    while (active < kInterleaved && start(walks[active])) ++active;
    int64_t visited = 0;
    // The walk's next step is child `child` (count > 0: a leaf), read on its next turn.
    const auto aim = [&](Walk& walk, int32_t child, int32_t childCount) {
      if (childCount == 0) {
        walk.node = child;
        const char* bytes = reinterpret_cast<const char*>(&m_nodes[static_cast<size_t>(child)]);
        __builtin_prefetch(bytes), __builtin_prefetch(bytes + 64);  // a node is two cache lines
      } else {
        walk.leafFirst = child, walk.leafCount = childCount;
        touch(child, childCount);
      }
    };
    while (active > 0) {
      // Every walk's node test first, before anything branches on an outcome: each test is a chain
      // of dependent operations, and made back to back the chains overlap. A walk about to test a
      // leaf tests its last node again, unused (cheaper than a branch that mispredicts).
      unsigned entered[kInterleaved];
      Real entries[kInterleaved][BvhNode::kWidth];
      for (int w = 0; w < active; ++w) {
        const Walk& walk = walks[w];
        entered[w] = childEntries(m_nodes[static_cast<size_t>(walk.node)], walk.ray, p.tHit[walk.k], entries[w]);
      }
      for (int w = 0; w < active; ++w) {
        Walk& walk = walks[w];
        bool done = false;
        if (walk.leafCount > 0) {
          visited += walk.leafCount;
          done = leaf(walk.leafFirst, walk.leafCount, walk.k);
          walk.leafCount = 0;
        } else {
          const BvhNode& node = m_nodes[static_cast<size_t>(walk.node)];
          const int nearest = pushFartherChildren(node, entered[w], entries[w], walk.stack);
          if (nearest >= 0) {
            aim(walk, node.child[nearest], node.count[nearest]);
            continue;
          }
        }
        int32_t child, childCount;
        if (!done && walk.stack.pop(p.tHit[walk.k], child, childCount)) {
          aim(walk, child, childCount);
        } else if (!start(walk)) {  // the last walk's turn moves here, with its node's test
          walk = walks[--active], entered[w] = entered[active];
          std::memcpy(entries[w], entries[active], sizeof entries[w]);
          --w;
        }
      }
    }
    return visited;
  }

  // A coherent packet (a camera tile's rays) walks the tree together while its rays still agree,
  // and each ray alone below that: a child the packet enters (any of its rays, tested a few rays
  // at a time with an early exit) is visited by the packet while its box is large next to the
  // packet's width there (its rays mostly take the same way through it), by each ray on its own
  // once smaller (they would split between its children, and the packet would visit them all).
  // Leaves reached together test all rays against their primitives in one vectorised loop:
  // packetLeaf(first, count); rays alone call rayLeaf(first, count, k). Children go nearest first
  // along the packet's first ray. Returns the ray-primitive tests made.
  template <typename PacketLeaf, typename RayLeaf>
  int64_t traversePacket(const RayPacket<Real>& p, const PacketLeaf& packetLeaf, const RayLeaf& rayLeaf) const {
    return walkPacket<true>(p, packetLeaf, rayLeaf);
  }

  // The packet walks the whole way together: packetLeaf(first, count) for every leaf any of its rays
  // enters (the top-level hierarchy over instances, whose leaves search the instances as packets).
  template <typename PacketLeaf>
  void traverseTogether(const RayPacket<Real>& p, const PacketLeaf& packetLeaf) const {
    walkPacket<false>(p, packetLeaf, [](int32_t, int32_t, int) {});
  }

 private:
  template <bool Split, typename PacketLeaf, typename RayLeaf>
  int64_t walkPacket(const RayPacket<Real>& p, const PacketLeaf& packetLeaf, const RayLeaf& rayLeaf) const {
    const PacketInverse<Real> inv(p);
    const PacketWidth width(p);
    const PacketInterval interval(p, inv);
    const BvhRay<Real> first(p.ox[0], p.oy[0], p.oz[0], p.dx[0], p.dy[0], p.dz[0], p.tMin);
    int32_t stack[kStackSize];
    int top = 0;
    stack[top++] = 0;
    int64_t tests = 0;
    while (top > 0) {
      const BvhNode& node = m_nodes[static_cast<size_t>(stack[--top])];
      Real entry[BvhNode::kWidth], mayEnter[BvhNode::kWidth];
      childEntries(node, first, std::numeric_limits<Real>::infinity(), entry);
      interval.mayEnter(node, mayEnter);
      int order[BvhNode::kWidth], found = 0;
      for (int i = 0; i < BvhNode::kWidth; ++i) {
        if (node.child[i] < 0 || !(mayEnter[i] > 0)) continue;
        const Vec3<Real> lo(node.bounds[0][0][i], node.bounds[0][1][i], node.bounds[0][2][i]);
        const Vec3<Real> hi(node.bounds[1][0][i], node.bounds[1][1][i], node.bounds[1][2][i]);
        if (!anyRayEnters(p, inv, lo, hi)) continue;
        if (node.count[i] > 0) {
          packetLeaf(node.child[i], node.count[i]);
          tests += int64_t(node.count[i]) * p.count;
        } else if (Split && width.splits(lo, hi, entry[i])) {
          for (int k = 0; k < p.count; ++k) {
            const BvhRay<Real> ray(p.ox[k], p.oy[k], p.oz[k], p.dx[k], p.dy[k], p.dz[k], p.tMin);
            tests += traverse(ray, p.tHit[k], [&](int32_t f, int32_t c) {
              rayLeaf(f, c, k);
              return false;
            }, node.child[i]);
          }
        } else {
          int j = found++;  // farthest first, so that the nearest is popped first
          for (; j > 0 && entry[order[j - 1]] < entry[i]; --j) order[j] = order[j - 1];
          order[j] = i;
        }
      }
      for (int j = 0; j < found; ++j) stack[top++] = node.child[order[j]];
    }
    return tests;
  }

  // Binary depth is bounded by the build (kMaxDepth); a 4-wide node pushes at most 3 entries per level.
  static constexpr int kMaxDepth = 64;
  static constexpr int kStackSize = 3 * kMaxDepth + 4;

  // Children still to visit, structure-of-arrays (a struct per entry costs store-forwarding stalls).
  struct Stack {
    Real tNear[kStackSize];
    int32_t child[kStackSize];
    int32_t count[kStackSize];
    int top = 0;

    // The next entry the ray may still reach before tHit into (next, nextCount), skipping those a
    // hit found since they were pushed is nearer than; false once none is left.
    DURER_INLINE bool pop(Real tHit, int32_t& next, int32_t& nextCount) {
      while (top > 0) {
        const int e = --top;
        if (tNear[e] > tHit) continue;
        next = child[e], nextCount = count[e];
        return true;
      }
      return false;
    }
  };

  // The four children's lanes as one SIMD vector (GCC/Clang vector extensions: SSE for float, AVX
  // for double where the kernel set has it, two SSE halves otherwise).
  using Lanes = typename NodeLanes<Real>::Type;
  // A node's four bounds of one axis, in Real's lanes (exact: every float is a double).
  DURER_INLINE static Lanes load(const float* p) {
#if defined(__AVX__)
    if constexpr (std::is_same_v<Real, double>) {  // one conversion (GCC splits the generic one in halves)
      const __m256d v = _mm256_cvtps_pd(_mm_loadu_ps(p));
      Lanes out;
      std::memcpy(&out, &v, sizeof out);
      return out;
    }
#endif
    typename NodeLanes<float>::Type v;
    std::memcpy(&v, p, sizeof v);
    return __builtin_convertvector(v, Lanes);
  }
  // Not Lanes{} + x, which GCC makes an addition of zero per lane (x + 0 is not x for x = -0).
  static Lanes broadcast(Real x) { return Lanes{x, x, x, x}; }

  // A bit per lane where the comparison `lanes` (GCC's vector of all-ones or zeros) holds.
  DURER_INLINE static unsigned maskOf(const decltype(Lanes{} < Lanes{})& lanes) {
#if defined(__AVX__)
    if constexpr (std::is_same_v<Real, double>) {
      __m256d v;
      std::memcpy(&v, &lanes, sizeof v);
      return unsigned(_mm256_movemask_pd(v));
    }
#endif
#if defined(__SSE__)
    if constexpr (std::is_same_v<Real, float>) {
      __m128 v;
      std::memcpy(&v, &lanes, sizeof v);
      return unsigned(_mm_movemask_ps(v));
    }
#endif
    unsigned mask = 0;
    for (int i = 0; i < BvhNode::kWidth; ++i) mask |= unsigned(lanes[i] != 0) << i;
    return mask;
  }

  // Each child's entry t along the ray, clamped to [tMin, tHit]; NaN for a child it misses (or an
  // empty slot); returns a bit per child it enters. Each axis' near and far bound are picked once
  // per ray (BvhRay), so a slab costs a subtraction and a product per bound and no min/max. A bound
  // minus the origin is moved outward by the least normal number (lo down, hi up; it rounds back
  // unless the difference is below ~1e-31 or 1e-292), so that a ray parallel to an axis (inv = ±inf)
  // whose origin lies on a box face gets ∓inf, inside, never 0·inf = NaN. (Not a subnormal: those
  // cost microcode assists.)
  DURER_INLINE static unsigned childEntries(const BvhNode& node, const BvhRay<Real>& ray, Real tHit, Real* out) {
    const float* bounds = &node.bounds[0][0][0];
    Lanes tn = broadcast(ray.tMin), tf = broadcast(tHit);
    Lanes nearT[3], farT[3];
    for (int a = 0; a < 3; ++a) {
      const Lanes o = broadcast(ray.o[a]), inv = broadcast(ray.inv[a]), shift = broadcast(ray.nearShift[a]);
      nearT[a] = ((load(bounds + ray.nearLanes[a]) - o) + shift) * inv;
      farT[a] = ((load(bounds + ray.farLanes[a]) - o) - shift) * inv;
    }
    Lanes entry = nearT[0] > nearT[1] ? nearT[0] : nearT[1];
    entry = nearT[2] > entry ? nearT[2] : entry;
    Lanes exit = farT[0] < farT[1] ? farT[0] : farT[1];
    exit = farT[2] < exit ? farT[2] : exit;
    // Widened once, after the max and min (kSlabWiden), as a product: inf stays inf, no NaN.
    entry *= entry > 0 ? broadcast(1 - kSlabWiden<Real>) : broadcast(1 + kSlabWiden<Real>);
    exit *= exit > 0 ? broadcast(1 + kSlabWiden<Real>) : broadcast(1 - kSlabWiden<Real>);
    tn = tn > entry ? tn : entry;
    tf = tf < exit ? tf : exit;
    const auto entered = tn <= tf;
    const Lanes result = entered ? tn : broadcast(std::numeric_limits<Real>::quiet_NaN());
    std::memcpy(out, &result, sizeof result);
    return maskOf(entered);
  }

  // Pushes the children of `node` that the ray enters in [tMin, tHit] (childEntries' mask `entered`
  // and entry t) but the nearest, whose slot it returns (-1: none entered), so that the farthest is
  // popped last; the nearest is the next step without a round trip through the stack, and usually it
  // is the only one entered (nothing is pushed). The entered ones come from the mask without a branch
  // per child (an empty slot's inverted box is never entered); among equal entries the later child
  // counts as nearer.
  DURER_INLINE static int pushFartherChildren(const BvhNode& node, unsigned entered, const Real* entry, Stack& stack) {
    if (entered == 0) return -1;
    int nearest = __builtin_ctz(entered);
    const int base = stack.top;
    for (entered &= entered - 1; entered != 0; entered &= entered - 1) {
      int i = __builtin_ctz(entered);
      if (entry[i] <= entry[nearest]) std::swap(i, nearest);  // the one displaced is pushed
      const Real t = entry[i];
      int j = stack.top++;
      for (; j > base && stack.tNear[j - 1] < t; --j) {
        stack.tNear[j] = stack.tNear[j - 1], stack.child[j] = stack.child[j - 1], stack.count[j] = stack.count[j - 1];
      }
      stack.tNear[j] = t, stack.child[j] = node.child[i], stack.count[j] = node.count[i];
    }
    return nearest;
  }

  // The packet's rays as intervals (Boulos et al.'s interval-arithmetic culling): the box of their
  // origins and of their reciprocal directions, when no axis mixes signs. A child no ray can enter
  // by this test (four at a time) costs one test instead of one per ray. Correctly rounded
  // operations are monotonic in each operand, so the bounds computed from the intervals' ends
  // bound what each ray's own test computes; the ends are shifted and widened as there.
  struct PacketInterval {
    Real oLo[3], oHi[3], invLo[3], invHi[3];
    Real tMin, tHitMax;
    bool usable = true;  // false: some axis mixes signs (or NaN): every child may be entered

    PacketInterval(const RayPacket<Real>& p, const PacketInverse<Real>& inv) : tMin(p.tMin), tHitMax(p.tHit[0]) {
      const Real* o[3] = {p.ox, p.oy, p.oz};
      const Real* r[3] = {inv.x, inv.y, inv.z};
      for (int a = 0; a < 3; ++a) {
        oLo[a] = oHi[a] = o[a][0], invLo[a] = invHi[a] = r[a][0];
        int negative = 0;
        for (int k = 0; k < p.count; ++k) {
          oLo[a] = std::min(oLo[a], o[a][k]), oHi[a] = std::max(oHi[a], o[a][k]);
          invLo[a] = std::min(invLo[a], r[a][k]), invHi[a] = std::max(invHi[a], r[a][k]);
          negative += std::signbit(r[a][k]) ? 1 : 0;
        }
        usable = usable && (negative == 0 || negative == p.count);
      }
      for (int k = 0; k < p.count; ++k) tHitMax = std::max(tHitMax, p.tHit[k]);
      for (int a = 0; a < 3; ++a) usable = usable && oLo[a] == oLo[a] && oHi[a] == oHi[a] && invLo[a] == invLo[a] && invHi[a] == invHi[a];
    }

    // Whether any ray may enter each child: > 0 in mayEnter[i] where it may.
    DURER_INLINE void mayEnter(const BvhNode& node, Real* out) const {
      constexpr Real tiny = std::numeric_limits<Real>::min();
      if (!usable) {
        for (int i = 0; i < BvhNode::kWidth; ++i) out[i] = 1;
        return;
      }
      Lanes nearT = broadcast(tMin), farT = broadcast(tHitMax);
      for (int a = 0; a < 3; ++a) {
        const Lanes lo = load(node.bounds[0][a]), hi = load(node.bounds[1][a]);
        // Each bound minus each origin end, as is (what a ray computes) and shifted outward (what
        // childEntries computes: never 0, so never 0·inf); a NaN product is skipped by the min/max.
        const Lanes d[8] = {lo - oHi[a], lo - oLo[a], hi - oHi[a], hi - oLo[a],
                            (lo - oHi[a]) - tiny, (lo - oLo[a]) - tiny, (hi - oHi[a]) + tiny, (hi - oLo[a]) + tiny};
        Lanes least = d[4] * invLo[a], most = least;
        for (int j = 0; j < 8; ++j) {
          for (const Real r : {invLo[a], invHi[a]}) {
            const Lanes t = d[j] * r;
            least = t < least ? t : least;
            most = t > most ? t : most;
          }
        }
        least *= least > 0 ? broadcast(1 - kSlabWiden<Real>) : broadcast(1 + kSlabWiden<Real>);
        most *= most > 0 ? broadcast(1 + kSlabWiden<Real>) : broadcast(1 - kSlabWiden<Real>);
        nearT = least > nearT ? least : nearT;
        farT = most < farT ? most : farT;
      }
      const Lanes result = nearT > farT ? broadcast(0) : broadcast(1);
      std::memcpy(out, &result, sizeof result);
    }
  };

  // How wide a packet's beam is at distance t: the spread of its origins plus t times the spread of
  // its directions (box diagonals). A node much smaller than that splits the packet's rays.
  struct PacketWidth {
    Real origins, directions;
    explicit PacketWidth(const RayPacket<Real>& p) {
      Vec3<Real> oLo(p.ox[0], p.oy[0], p.oz[0]), oHi = oLo, dLo(p.dx[0], p.dy[0], p.dz[0]), dHi = dLo;
      for (int k = 1; k < p.count; ++k) {
        const Vec3<Real> o(p.ox[k], p.oy[k], p.oz[k]), d(p.dx[k], p.dy[k], p.dz[k]);
        oLo = glm::min(oLo, o), oHi = glm::max(oHi, o), dLo = glm::min(dLo, d), dHi = glm::max(dHi, d);
      }
      origins = glm::length(oHi - oLo);
      directions = glm::length(dHi - dLo);
    }
    // Whether a box of this size, entered at t, is too small to keep the packet together. The ratio
    // was tuned on 1,000 large spheres (packets pay), 1M small ones in a slab (rays alone pay) and a
    // perspective view of 1,000 mid-sized ones: 4 sent the slab's packets through 3x the tests, 16
    // cost the perspective view 1.5x its time at 320x180.
    bool splits(const Vec3<Real>& lo, const Vec3<Real>& hi, Real t) const {
      constexpr Real kRatio = 8;
      const Real beam = origins + (t > 0 && t < std::numeric_limits<Real>::infinity() ? t : Real(0)) * directions;
      return glm::length(hi - lo) < kRatio * beam;
    }
  };

  // The surface-area heuristic's expected cost of a ray through the tree, in box tests: each child
  // box costs its area over the root's times its primitives (a leaf) or one (an inner node).
  double sahCost() const {
    double sum = 0;
    const auto area = [](const BvhNode& n, int s) {
      const double x = double(n.bounds[1][0][s]) - n.bounds[0][0][s], y = double(n.bounds[1][1][s]) - n.bounds[0][1][s],
                   z = double(n.bounds[1][2][s]) - n.bounds[0][2][s];
      return 2 * (x * y + y * z + z * x);
    };
    for (const BvhNode& n : m_nodes) {
      for (int s = 0; s < BvhNode::kWidth; ++s) {
        if (n.child[s] >= 0) sum += area(n, s) * (n.count[s] > 0 ? n.count[s] : 1);
      }
    }
    const BvhNode& root = m_nodes.front();
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = root.bounds[0][a][0], hi[a] = root.bounds[1][a][0];
      for (int s = 1; s < BvhNode::kWidth; ++s) {
        if (root.child[s] >= 0) lo[a] = std::min(lo[a], root.bounds[0][a][s]), hi[a] = std::max(hi[a], root.bounds[1][a][s]);
      }
    }
    const double x = double(hi[0]) - lo[0], y = double(hi[1]) - lo[1], z = double(hi[2]) - lo[2];
    const double rootArea = 2 * (x * y + y * z + z * x);
    return rootArea > 0 ? sum / rootArea : sum;
  }

  struct Builder;
  std::vector<BvhNode> m_nodes;  // the root first, every node before its children
  double m_builtCost = 0;              // sahCost() when built
};

// The binned-SAH build (Wald 2007; pbrt-v4's BVHAggregate): a binary tree first, each split the
// best of kBins planes per axis by surface area × primitives, then collapsed to 4-wide nodes by
// opening the largest child until four. Subtrees below the first levels build in parallel.
template <typename Real>
struct Bvh<Real>::Builder {
  // Boxes are binned in single precision whatever Real is (rounded outward, so still bounds): half
  // the memory traffic of doubles for the passes over large ranges, which are bound by it.
  using F = float;
  static constexpr int kBins = 16;
  static constexpr uint32_t kParallelMin = 1u << 14;  // smaller subtrees are not worth a thread

  using Lanes = typename NodeLanes<F>::Type;  // x, y, z and a spare lane
  static Lanes broadcast(F x) { return Lanes{} + x; }
  static F lane(const Lanes& v, int i) {
    F out[4];
    std::memcpy(out, &v, sizeof out);
    return out[i];
  }

  struct Box {
    Lanes lo = broadcast(kInf), hi = broadcast(-kInf);  // lanes 0-2; lane 3 is not part of the box
    void grow(const Lanes& l, const Lanes& h) { lo = l < lo ? l : lo, hi = h > hi ? h : hi; }
    void grow(const Box& b) { grow(b.lo, b.hi); }
    F lower(int axis) const { return lane(lo, axis); }
    F upper(int axis) const { return lane(hi, axis); }
    F area() const {
      const Lanes e = hi - lo;
      const F x = lane(e, 0), y = lane(e, 1), z = lane(e, 2);
      return x < 0 ? F(0) : x * y + y * z + z * x;
    }
  };
  // A primitive's box and index, moved (not referred to through an index) as ranges are
  // partitioned, so that every pass over a range streams through memory. The index rides in the
  // boxes' spare lanes as two exact integers below 2^24 (low and high bits). No initialiser: the
  // refs are first written by the setup, on all threads (zeroing them first took a serial pass).
  struct Ref {
    Lanes lo, hi;
    Box box() const {
      Box b;
      b.lo = lo, b.hi = hi;
      return b;
    }
    Lanes centroid() const { return lo + hi; }  // twice the centre: only compared
    uint32_t id() const { return static_cast<uint32_t>(lane(lo, 3)) | static_cast<uint32_t>(lane(hi, 3)) << 24; }
  };
  // A binary node: inner (count 0) with children left and right, or a leaf of primitives
  // refs[first, first + count).
  struct Node {
    Box box;
    int32_t left = -1, right = -1;
    uint32_t first = 0, count = 0;
  };
  // A subtree built on its own thread into nodes of its own; the parent's child index points at it.
  struct Subtree {
    std::vector<Node> nodes;
  };

  static constexpr F kInf = std::numeric_limits<Real>::infinity();
  size_t refCount;
  std::unique_ptr<Ref[]> refs;
  std::vector<Subtree> trees;  // tree 0: the top levels
  int threads;
  // Ranges above this many refs are split one at a time, each pass over them on all threads; those
  // below are subtrees, one per thread at a time.
  uint32_t grain;

  template <typename BoxOf>
  Builder(size_t count, const BoxOf& boxOf, int maxThreads)
      : refCount(count),
        refs(new Ref[count]),
        threads(std::max(maxThreads, 1)),
        grain(std::max<uint32_t>(kParallelMin, static_cast<uint32_t>(count / (4 * static_cast<size_t>(threads))))) {
    std::vector<Range> parts(chunksFor(count, threads));
    forChunks(count, parts.size(), [&](size_t c, size_t begin, size_t end) {
      // A block of boxes at a time, each step a loop of its own: the outward conversions then
      // vectorise (a loop doing all of a ref at once did not, and took most of the setup in double).
      constexpr size_t kBlock = 64;
      Real lo[3][kBlock], hi[3][kBlock];
      F down[3][kBlock], up[3][kBlock];
      Range& part = parts[c];
      for (size_t first = begin; first < end; first += kBlock) {
        const size_t n = std::min(kBlock, end - first);
        for (size_t j = 0; j < n; ++j) {
          Vec3<Real> l, h;
          boxOf(first + j, l, h);
          lo[0][j] = l.x, lo[1][j] = l.y, lo[2][j] = l.z, hi[0][j] = h.x, hi[1][j] = h.y, hi[2][j] = h.z;
        }
        for (int a = 0; a < 3; ++a) {
          for (size_t j = 0; j < n; ++j) down[a][j] = toRealDown<F>(lo[a][j]), up[a][j] = toRealUp<F>(hi[a][j]);
        }
        for (size_t j = 0; j < n; ++j) {
          const size_t i = first + j;
          const F low = static_cast<Real>(i & 0xFFFFFF), high = static_cast<Real>(i >> 24);
          const F l[4] = {down[0][j], down[1][j], down[2][j], low};
          const F h[4] = {up[0][j], up[1][j], up[2][j], high};
          std::memcpy(&refs[i].lo, l, sizeof l);
          std::memcpy(&refs[i].hi, h, sizeof h);
          part.grow(refs[i]);
        }
      }
    });
    for (const Range& part : parts) all.grow(part);
    all.begin = 0, all.end = static_cast<uint32_t>(count);
  }

  std::vector<uint32_t> order(int threads) const {
    std::vector<uint32_t> out(refCount);
    parallelChunks(refCount, threads, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) out[i] = refs[i].id();
    });
    return out;
  }

  // A child reference: >= 0 a node of the same tree; < 0 the root of tree -(ref + 1).
  static int32_t treeRef(size_t tree) { return -static_cast<int32_t>(tree) - 1; }

  void run() {
    trees.resize(1);
    struct Task {
      size_t tree;
      Range range;
    };
    std::vector<Task> tasks;
    // The top levels split one range at a time until there is a subtree per thread and then some
    // (for balance). Node vectors are reserved for a node per ref, more than a tree of leaves of
    // kMaxLeafSize needs: growing them cost a quarter of the build in page faults.
    const uint32_t n = static_cast<uint32_t>(refCount);
    trees.reserve(n / kParallelMin + 2);  // a task per disjoint range of >= kParallelMin: no reallocation
    trees[0].nodes.reserve(threads <= 1 ? n : n / grain * 4 + kParallelMin);
    const auto spawn = [&](const Range& r) {
      if (threads <= 1 || r.count() < kParallelMin || r.count() > grain) return false;
      trees.emplace_back();
      tasks.push_back({trees.size() - 1, r});
      return true;
    };
    buildNode(trees[0].nodes, all, 0, spawn);
    std::atomic<size_t> next{0};
    runOnThreads(std::min(tasks.size(), static_cast<size_t>(threads)), [&] {
      for (size_t t; (t = next.fetch_add(1)) < tasks.size();) {
        const auto never = [](const Range&) { return false; };
        trees[tasks[t].tree].nodes.reserve(tasks[t].range.count());
        buildNode(trees[tasks[t].tree].nodes, tasks[t].range, 0, never);
      }
    });
  }

  const Node& node(size_t tree, int32_t ref) const {
    return ref < 0 ? trees[static_cast<size_t>(-ref - 1)].nodes[0] : trees[tree].nodes[static_cast<size_t>(ref)];
  }
  size_t treeOf(size_t tree, int32_t ref) const { return ref < 0 ? static_cast<size_t>(-ref - 1) : tree; }

  // A range of refs with the box of their boxes and of their centres.
  struct Range {
    uint32_t begin = 0, end = 0;
    Box box, centroids;
    uint32_t count() const { return end - begin; }
    void grow(const Ref& r) { box.grow(r.lo, r.hi), centroids.grow(r.centroid(), r.centroid()); }
    void grow(const Range& r) { box.grow(r.box), centroids.grow(r.centroids); }
  };
  Range all;  // every ref, measured by the setup

  // The threads a pass over range r takes: in the top levels, all of them with at least 2^16 refs
  // each (each pass starts and joins them: on a loaded machine a join can wait for a time slice),
  // else this one.
  int threadsFor(const Range& r) const { return r.count() > grain ? static_cast<int>(chunksFor(r.count(), threads)) : 1; }

  Range measured(uint32_t begin, uint32_t end) const {
    Range r;
    r.begin = begin, r.end = end;
    for (uint32_t i = begin; i < end; ++i) r.grow(refs[i]);
    return r;
  }

  // Builds range r into `nodes`, returning its index there (or, when spawn takes the range, a
  // reference to the subtree that will hold it).
  template <typename Spawn>
  int32_t buildNode(std::vector<Node>& nodes, const Range& r, int depth, const Spawn& spawn) {
    if (depth > 0 && spawn(r)) return treeRef(trees.size() - 1);
    const int32_t index = static_cast<int32_t>(nodes.size());
    nodes.emplace_back();
    Range left, right;
    bool inner = r.count() > static_cast<uint32_t>(kMaxLeafSize) && depth < kMaxDepth - 1 && split(r, left, right);
    // No plane separates them (equal centroids) but they are too many for a leaf: halve the range.
    if (!inner && r.count() > 2 * static_cast<uint32_t>(kMaxLeafSize) && depth < kMaxDepth - 1) {
      const uint32_t middle = r.begin + r.count() / 2;
      left = measured(r.begin, middle), right = measured(middle, r.end);
      inner = true;
    }
    if (!inner) {
      nodes[static_cast<size_t>(index)].box = r.box;
      nodes[static_cast<size_t>(index)].first = r.begin;
      nodes[static_cast<size_t>(index)].count = r.count();
      return index;
    }
    const int32_t leftIndex = buildNode(nodes, left, depth + 1, spawn);
    const int32_t rightIndex = buildNode(nodes, right, depth + 1, spawn);
    Node& n = nodes[static_cast<size_t>(index)];
    n.box = r.box, n.left = leftIndex, n.right = rightIndex;
    return index;
  }

  // Partitions refs[begin, end) at the cheapest binned SAH plane, filling leftRange and rightRange;
  // returns false where no plane separates the refs or a leaf is cheaper than any split (only for a
  // few primitives). Ranges of kOneAxisMin refs or more are binned along the widest axis of their
  // centres only: a third of the binning and of the sweep over the bins, which near the leaves cost
  // more than the binning. The few smaller ones (the level above the leaves) are binned along all
  // three axes in one pass.
  bool split(const Range& r, Range& leftRange, Range& rightRange) {
    // On 1M random spheres 8 rather than 64 builds the binary tree in 174 rather than 196 ms on one
    // thread, for an SAH cost 2 % higher.
    constexpr uint32_t kOneAxisMin = 8;
    const uint32_t begin = r.begin, end = r.end, count = r.count();
    const Box& box = r.box;
    const Box& centroids = r.centroids;
    const int bins = static_cast<int>(std::min<uint32_t>(kBins, std::max<uint32_t>(4, count / 2)));
    F extent[3], scale[3];
    for (int a = 0; a < 3; ++a) {
      extent[a] = centroids.upper(a) - centroids.lower(a);
      scale[a] = extent[a] > 0 ? F(bins) * (1 - std::numeric_limits<Real>::epsilon()) / extent[a] : 0;
    }
    const int widest = extent[0] >= extent[1] && extent[0] >= extent[2] ? 0 : extent[1] >= extent[2] ? 1 : 2;
    const bool oneAxis = count >= kOneAxisMin;
    Bins perAxis[3];
    const int passThreads = threadsFor(r);
    if (oneAxis) {
      binOneAxis(begin, end, widest, centroids.lower(widest), scale[widest], bins, perAxis[widest], passThreads);
    } else {
      binThreeAxes(begin, end, centroids, scale, bins, perAxis);
    }
    F bestCost = kInf;
    int bestAxis = -1, bestBin = 0;
    for (int a = oneAxis ? widest : 0; a <= (oneAxis ? widest : 2); ++a) {
      if (!(extent[a] > 0)) continue;
      const Bins& b = perAxis[a];
      F rightArea[kBins];
      uint32_t rightCount[kBins];
      Box right;
      uint32_t n = 0;
      for (int i = bins - 1; i > 0; --i) {
        right.grow(b.lo[i], b.hi[i]), n += b.count[i];
        rightArea[i] = right.area(), rightCount[i] = n;
      }
      Box left;
      n = 0;
      for (int i = 1; i < bins; ++i) {  // plane between bin i - 1 and bin i
        left.grow(b.lo[i - 1], b.hi[i - 1]), n += b.count[i - 1];
        const F cost = left.area() * F(n) + rightArea[i] * F(rightCount[i]);
        if (n > 0 && rightCount[i] > 0 && cost < bestCost) bestCost = cost, bestAxis = a, bestBin = i;
      }
    }
    // A traversal step costs about one primitive test: split while that is cheaper than testing all.
    if (bestAxis < 0) return false;
    if (count <= 2 * static_cast<uint32_t>(kMaxLeafSize) && bestCost / box.area() + 1 >= F(count)) return false;
    const F axisLo = centroids.lower(bestAxis), axisScale = scale[bestAxis];
    const auto isLeft = [&](const Ref& ref) { return binOf(lane(ref.centroid(), bestAxis), axisLo, axisScale, bins) < bestBin; };
    const uint32_t middle = passThreads > 1 ? partitionParallel(begin, end, isLeft, passThreads) : partition(begin, end, isLeft);
    // The children's boxes are their bins' (the partition puts each ref on its bin's side).
    const Bins& b = perAxis[bestAxis];
    for (int i = 0; i < bins; ++i) {
      Range& side = i < bestBin ? leftRange : rightRange;
      side.box.grow(b.lo[i], b.hi[i]), side.centroids.grow(b.centroidLo[i], b.centroidHi[i]);
    }
    leftRange.begin = begin, leftRange.end = middle, rightRange.begin = middle, rightRange.end = end;
    return true;
  }

  // A run [first, second) of refs on the wrong side of a parallel partition's middle.
  using Span = std::pair<uint32_t, uint32_t>;

  // Each thread partitions a chunk of its own; then the refs on the wrong side of the middle (right
  // ones of the first chunks, left ones of the last) are swapped pairwise, also on all threads.
  template <typename Left>
  uint32_t partitionParallel(uint32_t begin, uint32_t end, const Left& isLeft, int passThreads) {
    const size_t chunks = static_cast<size_t>(passThreads);
    std::vector<uint32_t> firsts(chunks), middles(chunks), lasts(chunks);  // [first, middle): left, [middle, last): right
    forChunks(end - begin, chunks, [&](size_t c, size_t b, size_t e) {
      firsts[c] = begin + static_cast<uint32_t>(b), lasts[c] = begin + static_cast<uint32_t>(e);
      middles[c] = partition(firsts[c], lasts[c], isLeft);
    });
    uint32_t middle = begin;
    for (size_t c = 0; c < chunks; ++c) middle += middles[c] - firsts[c];
    std::vector<Span> strayRights, strayLefts;
    uint32_t strays = 0;
    for (size_t c = 0; c < chunks; ++c) {
      if (middles[c] < middle && middles[c] < lasts[c]) strayRights.emplace_back(middles[c], std::min(lasts[c], middle));
      if (middles[c] > middle && firsts[c] < middles[c]) {
        strayLefts.emplace_back(std::max(firsts[c], middle), middles[c]);
        strays += strayLefts.back().second - strayLefts.back().first;
      }
    }
    forChunks(strays, chunks, [&](size_t, size_t b, size_t e) {
      if (b == e) return;
      SpanCursor r(strayRights, static_cast<uint32_t>(b)), l(strayLefts, static_cast<uint32_t>(b));
      for (size_t k = b; k < e; ++k) std::swap(refs[r.next()], refs[l.next()]);
    });
    return middle;
  }

  // Walks the refs of a list of spans, from the k-th on.
  struct SpanCursor {
    const std::vector<Span>& spans;
    size_t span = 0;
    uint32_t at;
    SpanCursor(const std::vector<Span>& s, uint32_t k) : spans(s) {
      while (k >= spans[span].second - spans[span].first) k -= spans[span].second - spans[span].first, ++span;
      at = spans[span].first + k;
    }
    uint32_t next() {
      const uint32_t i = at++;
      if (at == spans[span].second && span + 1 < spans.size()) at = spans[++span].first;
      return i;
    }
  };

  // Moves the refs of [begin, end) that go left before the others; returns the first of the others.
  // Lomuto's partition with a swap at every step, so no branch on the side: which side a ref goes
  // is unpredictable, and the branches of std::partition's swaps were most of the build.
  template <typename Left>
  uint32_t partition(uint32_t begin, uint32_t end, const Left& isLeft) {
    uint32_t middle = begin;
    for (uint32_t k = begin; k < end; ++k) {
      const Ref ref = refs[k];
      const bool left = isLeft(ref);
      refs[k] = refs[middle];
      refs[middle] = ref;
      middle += left ? 1 : 0;
    }
    return middle;
  }

  // The boxes, boxes of centres and counts of the refs in each bin along an axis; only the first
  // `bins` are set.
  struct Bins {
    Lanes lo[kBins], hi[kBins], centroidLo[kBins], centroidHi[kBins];
    uint32_t count[kBins];
    void clear(int bins) {
      for (int i = 0; i < bins; ++i) {
        lo[i] = centroidLo[i] = broadcast(kInf), hi[i] = centroidHi[i] = broadcast(-kInf), count[i] = 0;
      }
    }
    void add(int i, const Box& box, const Lanes& centroid) {
      lo[i] = box.lo < lo[i] ? box.lo : lo[i], hi[i] = box.hi > hi[i] ? box.hi : hi[i], ++count[i];
      centroidLo[i] = centroid < centroidLo[i] ? centroid : centroidLo[i];
      centroidHi[i] = centroid > centroidHi[i] ? centroid : centroidHi[i];
    }
    void merge(const Bins& other, int bins) {
      for (int i = 0; i < bins; ++i) {
        lo[i] = other.lo[i] < lo[i] ? other.lo[i] : lo[i], hi[i] = other.hi[i] > hi[i] ? other.hi[i] : hi[i];
        centroidLo[i] = other.centroidLo[i] < centroidLo[i] ? other.centroidLo[i] : centroidLo[i];
        centroidHi[i] = other.centroidHi[i] > centroidHi[i] ? other.centroidHi[i] : centroidHi[i];
        count[i] += other.count[i];
      }
    }
  };

  // Large ranges: two sets of bins, for even and odd refs, so that neighbours (often in the same
  // bin) do not wait for each other's update of it.
  void binOneAxis(uint32_t begin, uint32_t end, int axis, F lo, F scale, int bins, Bins& out, int passThreads) const {
    if (passThreads > 1) {
      std::vector<Bins> parts(static_cast<size_t>(passThreads));
      forChunks(end - begin, parts.size(), [&](size_t c, size_t b, size_t e) {
        binOneAxis(begin + static_cast<uint32_t>(b), begin + static_cast<uint32_t>(e), axis, lo, scale, bins, parts[c], 1);
      });
      out = parts[0];
      for (size_t c = 1; c < parts.size(); ++c) out.merge(parts[c], bins);
      return;
    }
    Bins odd;
    out.clear(bins), odd.clear(bins);
    const auto add = [&](Bins& to, const Ref& ref) {
      const Lanes centroid = ref.centroid();
      to.add(binOf(lane(centroid, axis), lo, scale, bins), ref.box(), centroid);
    };
    uint32_t i = begin;
    for (; i + 1 < end; i += 2) add(out, refs[i]), add(odd, refs[i + 1]);
    if (i < end) add(out, refs[i]);
    out.merge(odd, bins);
  }

  // Small ranges: each ref's three bins from one vector of its centre (lane by lane the same
  // operations as binOf, so the partition puts each ref where it was binned).
  void binThreeAxes(uint32_t begin, uint32_t end, const Box& centroids, const F* scale, int bins, Bins* out) const {
    typedef int32_t IntLanes __attribute__((vector_size(16)));
    for (int a = 0; a < 3; ++a) out[a].clear(bins);
    const Lanes lo = centroids.lo, scales = Lanes{scale[0], scale[1], scale[2], 0};
    const IntLanes last = IntLanes{} + (bins - 1);
    for (uint32_t i = begin; i < end; ++i) {
      const Lanes centroid = refs[i].centroid();
      IntLanes b = __builtin_convertvector((centroid - lo) * scales, IntLanes);
      b = b < 0 ? IntLanes{} : b;
      b = b > last ? last : b;
      const Box box = refs[i].box();
      for (int a = 0; a < 3; ++a) out[a].add(b[a], box, centroid);
    }
  }

  static int binOf(F c, F lo, F scale, int bins) {
    return std::min(std::max(static_cast<int>((c - lo) * scale), 0), bins - 1);
  }

  // A slot of a top-level wide node whose child is a node of a subtree: that node is collapsed on
  // its own, on some thread, and the slot then points at it.
  struct Link {
    int32_t node;
    int slot;
    size_t tree;
    int32_t ref;
  };

  // The 4-wide node of binary inner node `ref` of `tree`, and those below it, appended to out. With
  // links, only tree 0's part: the wide nodes of the subtrees' nodes are left to the links.
  int32_t collapse(size_t tree, int32_t ref, std::vector<BvhNode>& out, std::vector<Link>* links = nullptr) const {
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
      F largestArea = -1;
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
    BvhNode wide;
    for (int s = 0; s < 4; ++s) {
      const bool present = s < used;
      const Node* c = present ? &node(slots[s].tree, slots[s].ref) : nullptr;
      for (int a = 0; a < 3; ++a) {
        wide.bounds[0][a][s] = present ? c->box.lower(a) : kInf;
        wide.bounds[1][a][s] = present ? c->box.upper(a) : -kInf;
      }
      wide.child[s] = present ? static_cast<int32_t>(c->first) : -1;
      wide.count[s] = present ? static_cast<int32_t>(c->count) : 0;
    }
    for (int s = 0; s < used; ++s) {
      const Node& c = node(slots[s].tree, slots[s].ref);
      if (c.count > 0) continue;
      const size_t ct = treeOf(slots[s].tree, slots[s].ref);
      if (links && ct != 0) {
        links->push_back({index, s, ct, slots[s].ref < 0 ? 0 : slots[s].ref});
      } else {
        wide.child[s] = collapse(slots[s].tree, slots[s].ref, out, links);
      }
    }
    out[static_cast<size_t>(index)] = wide;
    return index;
  }

  // The tree collapsed to 4-wide nodes into out: the top's nodes on this thread, then each subtree
  // node a link of theirs points at, with those below it, on all threads, appended in the links'
  // order (each block's inner children moved by its offset there).
  void collapseAll(std::vector<BvhNode>& out) const {
    std::vector<Link> links;
    collapse(0, 0, out, &links);
    std::vector<std::vector<BvhNode>> blocks(links.size());
    std::atomic<size_t> next{0};
    runOnThreads(std::min(links.size(), static_cast<size_t>(threads)), [&] {
      for (size_t l; (l = next.fetch_add(1)) < links.size();) {
        blocks[l].reserve(trees[links[l].tree].nodes.size() / 2 + 1);
        collapse(links[l].tree, links[l].ref, blocks[l]);
      }
    });
    std::vector<size_t> offsets(links.size());
    size_t total = out.size();
    for (size_t l = 0; l < links.size(); ++l) {
      offsets[l] = total, total += blocks[l].size();
      out[static_cast<size_t>(links[l].node)].child[links[l].slot] = static_cast<int32_t>(offsets[l]);
    }
    out.resize(total);
    next = 0;
    runOnThreads(std::min(links.size(), static_cast<size_t>(threads)), [&] {
      for (size_t l; (l = next.fetch_add(1)) < links.size();) {
        const int32_t offset = static_cast<int32_t>(offsets[l]);
        BvhNode* to = &out[offsets[l]];
        for (BvhNode n : blocks[l]) {
          for (int s = 0; s < BvhNode::kWidth; ++s) n.child[s] += n.count[s] == 0 && n.child[s] >= 0 ? offset : 0;
          *to++ = n;
        }
      }
    });
  }
};

template <typename Real>
template <typename BoxOf>
std::vector<uint32_t> Bvh<Real>::build(size_t count, const BoxOf& boxOf, int threads) {
  m_nodes.clear();
  if (count == 0) return {};
  Builder builder(count, boxOf, threads);
  builder.run();
  const typename Builder::Node& root = builder.trees[0].nodes[0];
  if (root.count > 0) {  // a single leaf: a root node with one child
    BvhNode wide;
    for (int s = 0; s < 4; ++s) {
      for (int a = 0; a < 3; ++a) {
        wide.bounds[0][a][s] = s == 0 ? root.box.lower(a) : std::numeric_limits<float>::infinity();
        wide.bounds[1][a][s] = s == 0 ? root.box.upper(a) : -std::numeric_limits<float>::infinity();
      }
      wide.child[s] = s == 0 ? 0 : -1;
      wide.count[s] = s == 0 ? static_cast<int32_t>(root.count) : 0;
    }
    m_nodes.push_back(wide);
  } else {
    m_nodes.reserve(builder.trees[0].nodes.size() / 2 + 1);
    builder.collapseAll(m_nodes);
  }
  m_builtCost = sahCost();
  return builder.order(threads);
}

template <typename Real>
template <typename BoxOf>
double Bvh<Real>::refit(const BoxOf& boxOf, int threads) {
  constexpr Real kInf = std::numeric_limits<Real>::infinity();
  const auto store = [](BvhNode& n, int s, const Vec3<Real>& lo, const Vec3<Real>& hi) {
    for (int a = 0; a < 3; ++a) n.bounds[0][a][s] = toRealDown<float>(lo[a]), n.bounds[1][a][s] = toRealUp<float>(hi[a]);
  };
  // The leaves' boxes first, from their primitives alone: nodes in chunks on all threads (a chunk of
  // nodes holds thousands of primitives, unlike parallelChunks' minimum of items).
  constexpr size_t kNodesPerChunk = 4096;
  const size_t chunks = std::max<size_t>(1, std::min(static_cast<size_t>(std::max(threads, 1)), m_nodes.size() / kNodesPerChunk));
  forChunks(m_nodes.size(), chunks, [&](size_t, size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      BvhNode& n = m_nodes[i];
      for (int s = 0; s < BvhNode::kWidth; ++s) {
        if (n.child[s] < 0 || n.count[s] == 0) continue;
        Vec3<Real> lo(kInf), hi(-kInf);
        for (int32_t p = n.child[s]; p < n.child[s] + n.count[s]; ++p) {
          Vec3<Real> pLo, pHi;
          boxOf(static_cast<size_t>(p), pLo, pHi);
          lo = glm::min(lo, pLo), hi = glm::max(hi, pHi);
        }
        store(n, s, lo, hi);
      }
    }
  });
  // Then the inner children's, bottom-up: a node's children come after it.
  for (size_t i = m_nodes.size(); i-- > 0;) {
    BvhNode& n = m_nodes[i];
    for (int s = 0; s < BvhNode::kWidth; ++s) {
      if (n.child[s] < 0 || n.count[s] > 0) continue;
      const BvhNode& c = m_nodes[static_cast<size_t>(n.child[s])];
      Vec3<Real> lo(kInf), hi(-kInf);
      for (int cs = 0; cs < BvhNode::kWidth; ++cs) {
        if (c.child[cs] < 0) continue;
        lo = glm::min(lo, Vec3<Real>(c.bounds[0][0][cs], c.bounds[0][1][cs], c.bounds[0][2][cs]));
        hi = glm::max(hi, Vec3<Real>(c.bounds[1][0][cs], c.bounds[1][1][cs], c.bounds[1][2][cs]));
      }
      store(n, s, lo, hi);
    }
  }
  return m_builtCost > 0 ? sahCost() / m_builtCost : 1;
}

}  // namespace durer
