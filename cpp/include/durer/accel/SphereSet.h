#pragma once
#include <algorithm>
#include <atomic>
#include <limits>
#include <memory>
#include <mutex>
#include <cstdint>
#include <cstring>
#include <vector>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "durer/Inline.h"
#include "durer/geometry/Hit.h"
#include "durer/accel/PrimitiveSet.h"
#include "durer/geometry/RayPacket.h"
#include "durer/geometry/Sphere.h"
#include "durer/accel/Bvh.h"
#include "durer/accel/SphereGrid.h"
#include "durer/accel/SphereView.h"
#include "durer/geometry/SphereIntersection.h"
#include "durer/math/Float.h"
#include "durer/math/RadixSort.h"
#include "durer/math/Vec.h"

namespace durer {

#if defined(__AVX2__) && defined(__FMA__)
// Four spheres' fields as four lanes, for a leaf's prefilter (SphereSet::leafMayMeet): AVX doubles
// (a sphere is one 32-byte vector) or SSE floats (one 16-byte vector), transposed to a vector per field.
template <typename Real>
struct LeafLanes;

template <>
struct LeafLanes<double> {
  using V = __m256d;
  static V set1(double x) { return _mm256_set1_pd(x); }
  static V fmsub(V a, V b, V c) { return _mm256_fmsub_pd(a, b, c); }
  static V fnmadd(V a, V b, V c) { return _mm256_fnmadd_pd(a, b, c); }
  static V abs(V a) { return _mm256_andnot_pd(_mm256_set1_pd(-0.0), a); }
  static unsigned greaterMask(V a, V b) { return unsigned(_mm256_movemask_pd(_mm256_cmp_pd(a, b, _CMP_GT_OQ))); }
  static unsigned equalMask(V a, V b) { return unsigned(_mm256_movemask_pd(_mm256_cmp_pd(a, b, _CMP_EQ_OQ))); }
  // Spheres p[0], p[4 i1], p[4 i2], p[4 i3] (centre x, y, z, radius each) to x, y, z and r.
  static void transpose(const double* p, int i1, int i2, int i3, V& x, V& y, V& z, V& r) {
    const V a = _mm256_loadu_pd(p), b = _mm256_loadu_pd(p + 4 * i1), c = _mm256_loadu_pd(p + 4 * i2),
            d = _mm256_loadu_pd(p + 4 * i3);
    const V xzLo = _mm256_unpacklo_pd(a, b), yrLo = _mm256_unpackhi_pd(a, b);  // ax bx az bz, ay by ar br
    const V xzHi = _mm256_unpacklo_pd(c, d), yrHi = _mm256_unpackhi_pd(c, d);
    x = _mm256_permute2f128_pd(xzLo, xzHi, 0x20), z = _mm256_permute2f128_pd(xzLo, xzHi, 0x31);
    y = _mm256_permute2f128_pd(yrLo, yrHi, 0x20), r = _mm256_permute2f128_pd(yrLo, yrHi, 0x31);
  }
};

template <>
struct LeafLanes<float> {
  using V = __m128;
  static V set1(float x) { return _mm_set1_ps(x); }
  static V fmsub(V a, V b, V c) { return _mm_fmsub_ps(a, b, c); }
  static V fnmadd(V a, V b, V c) { return _mm_fnmadd_ps(a, b, c); }
  static V abs(V a) { return _mm_andnot_ps(_mm_set1_ps(-0.0f), a); }
  static unsigned greaterMask(V a, V b) { return unsigned(_mm_movemask_ps(_mm_cmp_ps(a, b, _CMP_GT_OQ))); }
  static unsigned equalMask(V a, V b) { return unsigned(_mm_movemask_ps(_mm_cmp_ps(a, b, _CMP_EQ_OQ))); }
  static void transpose(const float* p, int i1, int i2, int i3, V& x, V& y, V& z, V& r) {
    x = _mm_loadu_ps(p), y = _mm_loadu_ps(p + 4 * i1), z = _mm_loadu_ps(p + 4 * i2), r = _mm_loadu_ps(p + 4 * i3);
    _MM_TRANSPOSE4_PS(x, y, z, r);
  }
};
#endif

#if DURER_WALK_LANES
// Eight (ray, sphere) pairs as eight lanes, for the grid's walk in lanes (SphereSet::searchGrid):
// AVX-512 doubles or AVX floats. Each pair's ray is picked by its lane from vectors of the walks' rays.
template <typename Real>
struct PairLanes;

template <>
struct PairLanes<double> {
  using V = __m512d;
  using Index = __m512i;
  static V load(const double* p) { return _mm512_load_pd(p); }
  static Index index(const int32_t* lanes) {
    return _mm512_maskz_cvtepu32_epi64(0xff, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(lanes)));
  }
  static V pick(Index lanes, V v) { return _mm512_maskz_permutexvar_pd(0xff, lanes, v); }
  static V set1(double x) { return _mm512_set1_pd(x); }
  static V fmsub(V a, V b, V c) { return _mm512_fmsub_pd(a, b, c); }
  static V fnmadd(V a, V b, V c) { return _mm512_fnmadd_pd(a, b, c); }
  static V abs(V a) { return _mm512_abs_pd(a); }
  static unsigned greaterMask(V a, V b) { return unsigned(_mm512_cmp_pd_mask(a, b, _CMP_GT_OQ)); }
  static unsigned equalMask(V a, V b) { return unsigned(_mm512_cmp_pd_mask(a, b, _CMP_EQ_OQ)); }
  // Spheres s[at[0]], ..., s[at[7]] (centre x, y, z, radius each) to x, y, z and r.
  static void transpose(const Sphere<double>* s, const uint32_t* at, V& x, V& y, V& z, V& r) {
    const auto pair = [&](int i) {
      const __m512d low = _mm512_castpd256_pd512(_mm256_loadu_pd(&s[at[i]].center.x));
      return _mm512_maskz_insertf64x4(0xff, low, _mm256_loadu_pd(&s[at[i + 4]].center.x), 1);
    };
    const V a = pair(0), b = pair(1), c = pair(2), d = pair(3);  // a: x0 y0 z0 r0 x4 y4 z4 r4, ...
    const V xzLo = _mm512_maskz_unpacklo_pd(0xff, a, b), yrLo = _mm512_maskz_unpackhi_pd(0xff, a, b);  // x0 x1 z0 z1 x4 x5 z4 z5, ...
    const V xzHi = _mm512_maskz_unpacklo_pd(0xff, c, d), yrHi = _mm512_maskz_unpackhi_pd(0xff, c, d);
    const Index first = _mm512_setr_epi64(0, 1, 8, 9, 4, 5, 12, 13);
    const Index second = _mm512_setr_epi64(2, 3, 10, 11, 6, 7, 14, 15);
    x = _mm512_permutex2var_pd(xzLo, first, xzHi), z = _mm512_permutex2var_pd(xzLo, second, xzHi);
    y = _mm512_permutex2var_pd(yrLo, first, yrHi), r = _mm512_permutex2var_pd(yrLo, second, yrHi);
  }
};

template <>
struct PairLanes<float> {
  using V = __m256;
  using Index = __m256i;
  static V load(const float* p) { return _mm256_load_ps(p); }
  static Index index(const int32_t* lanes) { return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(lanes)); }
  static V pick(Index lanes, V v) { return _mm256_permutexvar_ps(lanes, v); }
  static V set1(float x) { return _mm256_set1_ps(x); }
  static V fmsub(V a, V b, V c) { return _mm256_fmsub_ps(a, b, c); }
  static V fnmadd(V a, V b, V c) { return _mm256_fnmadd_ps(a, b, c); }
  static V abs(V a) { return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), a); }
  static unsigned greaterMask(V a, V b) { return unsigned(_mm256_cmp_ps_mask(a, b, _CMP_GT_OQ)); }
  static unsigned equalMask(V a, V b) { return unsigned(_mm256_cmp_ps_mask(a, b, _CMP_EQ_OQ)); }
  static void transpose(const Sphere<float>* s, const uint32_t* at, V& x, V& y, V& z, V& r) {
    const auto pair = [&](int i) {
      const __m256 low = _mm256_castps128_ps256(_mm_loadu_ps(&s[at[i]].center.x));
      return _mm256_insertf128_ps(low, _mm_loadu_ps(&s[at[i + 4]].center.x), 1);
    };
    const V a = pair(0), b = pair(1), c = pair(2), d = pair(3);  // a: x0 y0 z0 r0 | x4 y4 z4 r4, ...
    const V xyLo = _mm256_unpacklo_ps(a, b), zrLo = _mm256_unpackhi_ps(a, b);  // x0 x1 y0 y1 | x4 x5 y4 y5, ...
    const V xyHi = _mm256_unpacklo_ps(c, d), zrHi = _mm256_unpackhi_ps(c, d);
    x = _mm256_shuffle_ps(xyLo, xyHi, _MM_SHUFFLE(1, 0, 1, 0)), y = _mm256_shuffle_ps(xyLo, xyHi, _MM_SHUFFLE(3, 2, 3, 2));
    z = _mm256_shuffle_ps(zrLo, zrHi, _MM_SHUFFLE(1, 0, 1, 0)), r = _mm256_shuffle_ps(zrLo, zrHi, _MM_SHUFFLE(3, 2, 3, 2));
  }
};
#endif

// All spheres of a group, contiguous. The search is t-only; the hit record is built once per ray.
template <typename Real>
class SphereSet : public PrimitiveSet<Sphere<Real>, Real> {
 public:
  SphereSet() = default;
  template <typename Other>
  explicit SphereSet(const SphereSet<Other>& other) {
    this->convertFrom(other, convert<Other>);
  }

  // Builds the bounding-volume hierarchy (and reorders the spheres and their ids to its order);
  // worth it from kBvhMinPrimitives spheres, after which intersect() traverses it.
  void buildBvh(int threads) {
    m_grid.clear(threads);
    Base::buildBvh(kBoxOf, threads);
  }

  // Without a hierarchy: the spheres (and their ids) in the order of their centres along a Morton
  // curve, as a hierarchy's order would keep spheres near each other near in memory: the camera's
  // view lists them cell by cell and its rays read them so (in the order given, often random, a new
  // pose of 1M spheres took 1.4x as long, each render again 1.2x).
  void arrange(int threads) {
    const size_t n = this->m_primitives.size();
    if (n < 2) return;
    Vec3d lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const Sphere<Real>& s : this->m_primitives) lo = glm::min(lo, Vec3d(s.center)), hi = glm::max(hi, Vec3d(s.center));
    constexpr double kSteps = 255;  // 8 bits an axis: 16M boxes, three passes of the sort
    const Vec3d scale = kSteps / glm::max(hi - lo, Vec3d(std::numeric_limits<double>::min()));
    // A step along each axis; 0 where the extent overflowed (NaN: inf times 0), the last step beyond.
    const auto step = [&](double v) { return uint32_t(v > 0 ? std::min(v, kSteps) : 0.0); };
    std::vector<uint64_t> keyed(n), scratch;
    parallelChunks(n, threads, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        const Vec3d q = (Vec3d(this->m_primitives[i].center) - lo) * scale;
        keyed[i] = uint64_t(mortonCode(step(q.x), step(q.y), step(q.z))) << 32 | i;
      }
    });
    radixSortByHigh32(keyed, scratch);
    std::vector<uint32_t> order(n);
    for (size_t j = 0; j < n; ++j) order[j] = uint32_t(keyed[j]);
    this->reorder(order, threads);
  }

  // The spheres of `source`, the set this one was made from, after they moved (Base::refitFrom).
  template <typename Other>
  bool refitFrom(const SphereSet<Other>& source, int threads) {
    m_views.clear();
    m_grid.clear(threads);
    return Base::refitFrom(source, convert<Other>, kBoxOf, threads);
  }

  // The view of these spheres made for `key` (SphereView): the one kept for this key (see ViewCache),
  // else make()'s (null where a view would not pay).
  template <typename Make>
  std::shared_ptr<const SphereView<Real>> view(const ViewKey& key, const Make& make) const {
    return m_views.find(key, make);
  }

  // The most lights whose shadow rays a render searches through views of these spheres, and the
  // light views kept between renders (TileRenderer::viewsLights): a view is made for each light (a
  // point light's ~40 bytes a sphere and its faces' cell bounds: 60 of them over 1M spheres took
  // 2.2 GB and 6.8 s at 320x180 with ~30 bytes a sphere),
  // where one hierarchy serves them all.
  static constexpr size_t kMostLightViews = 3;

  // Sphere i moved; the caller drops the grid once it has moved them all (dropGrid): taking the grid's
  // lock for each sphere would cost a third of moving 10M spheres.
  void setSphere(size_t i, const Sphere<Real>& sphere) { this->m_primitives[i] = sphere; }
  void dropGrid() { m_grid.clear(); }

  // The grid of these spheres for incoherent rays (SphereGrid), made on first use; null where the
  // spheres do not suit one or have no hierarchy (the grid sends the rays it cannot walk to it).
  const SphereGrid<Real>* grid() const { return this->hasBvh() ? m_grid.find(this->m_primitives) : nullptr; }

  // Grows [lo, hi] to hold every sphere (the bounds of a transformed group).
  void bounds(Vec3<Real>& lo, Vec3<Real>& hi) const {
    for (const Sphere<Real>& s : this->m_primitives) {
      lo = glm::min(lo, s.center - s.radius);
      hi = glm::max(hi, s.center + s.radius);
    }
  }

  // Lowers each ray's tHit to its closest sphere hit in [tMin, tHit) (with AnyHit: to some hit, for
  // rays without one yet); sphere i is recorded as primBase + i. Gives up if *cancel is set (checked
  // every ray or every few thousand spheres; the packet is then garbage).
  // Returns the ray-sphere tests made.
  template <SphereMethod M, bool AnyHit = false>
  int64_t intersect(RayPacket<Real>& packet, int32_t primBase, const std::atomic<bool>* cancel) const {
    if (this->m_primitives.empty()) return 0;
    PacketRayTerms<Real> terms;
    Leaving<M> left;
    bool computed = false;
    const auto compute = [&] {
      if (!computed) terms.template compute<M>(packet.dx, packet.dy, packet.dz, packet.count), computed = true;
    };
    if (packet.view) {
      if constexpr (AnyHit) {  // shadow rays toward a light, through its view (a sun's, or a point light's faces)
        compute();
        left.find(*this, packet, terms, primBase);
        return packet.view->occluders(packet, [&](int k, uint32_t i, double sureT) {
          if (sureT > 0 && packet.sureHits) {  // its sphere data is often cold: not read where the view knows the answer
            packet.prim[k] = primBase + static_cast<int32_t>(i);
            packet.tHit[k] = static_cast<Real>(sureT);
          } else if (!left.skips(k, i)) {
            intersectRay<M>(packet, terms[k], k, static_cast<size_t>(i), primBase);
          }
          return packet.prim[k] != kNoPrimitive;
        });
      } else {  // camera rays, through the camera's view
        // The rays' terms only once a sphere is to be tested: a camera tile often meets none.
        const int64_t tests = packet.view->search(packet, [&](uint32_t i, int kBegin, int kEnd, bool all) {
          compute();
          if (all) {
            intersectOne<M>(packet, terms, static_cast<size_t>(i), primBase, kBegin, kEnd);
          } else {  // the rays under the sphere's rows: the prefilter would rarely spare the test
            intersectOne<M, false>(packet, terms, static_cast<size_t>(i), primBase, kBegin, kEnd);
          }
        }, this->m_primitives.data());
        if (tests >= 0) return tests;
      }
    }
    compute();
    left.find(*this, packet, terms, primBase);
    const auto testLeaf = [&](int32_t first, int32_t count, int k) {
      intersectLeaf<M>(packet, terms[k], k, first, count, primBase, left.of(k));
    };
    if constexpr (M == SphereMethod::Robust) {  // the grid's bound on a root's error is the robust test's
      if (AnyHit || !packet.coherent) {          // the rays search() would walk one by one
        if (const SphereGrid<Real>* spheres = grid()) {
          return searchGrid<M, AnyHit>(*spheres, packet, terms, left, primBase, cancel, testLeaf);
        }
      }
    }
    return this->template search<AnyHit>(
        packet, cancel,
        [&](int32_t first, int32_t count) {
          for (int32_t i = first; i < first + count; ++i) intersectOne<M>(packet, terms, static_cast<size_t>(i), primBase);
        },
        testLeaf);
  }

  // The spheres of this set the packet's rays leave (RayPacket::leaving), where the robust test would
  // return at robustLeaves: ray k's by index (kNone: none) and by value (NaN: none). A search may skip
  // them (a test would record nothing) or test them: the same hits either way. Most of a bounce's or
  // shadow ray's search is otherwise spent on its own sphere: in the secondary scene 57 % of the
  // pairs passing the walk's prefilter (the rest are the hits and near misses) and most shadow rays'
  // first candidate in the sun's view, each taking the full test's branches to be turned away.
  template <SphereMethod M>
  struct Leaving {
    static constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
    bool any = false;  // whether some ray has one; the arrays are set only then
    uint32_t index[kPacketSize];
    Sphere<Real> sphere[kPacketSize];

    // Finds them (none for methods other than the robust one, or rays that may start at t <= 0): the
    // marked spheres gathered, then robustLeaves for all rays in one loop, which vectorises. 2.7 % of
    // the secondary scene's render (3.2 % a ray at a time), most of it the marked spheres' loads.
    void find(const SphereSet& set, const RayPacket<Real>& packet, const PacketRayTerms<Real>& terms, int32_t primBase) {
      any = false;
      if (M != SphereMethod::Robust || !packet.leaving || !(packet.tMin > 0)) return;
      const Sphere<Real> none{Vec3<Real>(std::numeric_limits<Real>::quiet_NaN()), std::numeric_limits<Real>::quiet_NaN()};
      const size_t n = set.m_primitives.size();
      alignas(64) Real cx[kPacketSize], cy[kPacketSize], cz[kPacketSize], cr[kPacketSize];
      for (int k = 0; k < packet.count; ++k) {
        const uint32_t i = static_cast<uint32_t>(packet.from[k] - primBase);  // from < primBase wraps past n
        const bool marked = packet.from[k] != kNoPrimitive && i < n;
        index[k] = marked ? i : kNone;
        sphere[k] = marked ? set.m_primitives[i] : none;
        cx[k] = sphere[k].center.x, cy[k] = sphere[k].center.y, cz[k] = sphere[k].center.z, cr[k] = sphere[k].radius;
      }
      alignas(64) int32_t leaves[kPacketSize];  // robustLeaves' outcome (NaN, unmarked: false)
      for (int k = 0; k < packet.count; ++k) {
        const RobustOrigin<Real> f = robustOrigin(packet.ox[k], packet.oy[k], packet.oz[k], Vec3<Real>(cx[k], cy[k], cz[k]), cr[k]);
        leaves[k] = (f.c > 0) & (robustB(f, terms[k]) > 0);
      }
      for (int k = 0; k < packet.count; ++k) {
        if (!leaves[k]) index[k] = kNone, sphere[k] = none;
        any |= leaves[k] != 0;
      }
    }
    const Sphere<Real>* of(int k) const { return any && index[k] != kNone ? &sphere[k] : nullptr; }
    bool skips(int k, uint32_t i) const { return any && index[k] == i; }  // sphere i, by index
  };

  // The nearest hit so far (recordHit), for intersectSphere and the runs and pairs that call it.
  struct NearestHit {
    DURER_INLINE void operator()(RayPacket<Real>& packet, int k, Real t, int32_t id) const { recordHit(packet, k, t, id); }
  };

  // The packet's rays through the grid (those it cannot walk through the hierarchy, testing its
  // leaves with testLeaf(first, count, k)), each lowering its tHit as intersect() does.
  template <SphereMethod M, bool AnyHit, typename TestLeaf>
  int64_t searchGrid(const SphereGrid<Real>& grid, RayPacket<Real>& packet, const PacketRayTerms<Real>& terms,
                     const Leaving<M>& left, int32_t primBase, const std::atomic<bool>* cancel,
                     const TestLeaf& testLeaf) const {
    if (cancel && cancel->load(std::memory_order_relaxed)) return 0;
    int64_t tests = 0;
    int others[kPacketSize], count = 0;
    const auto rayOf = [&](int k, double (&o)[3], double (&d)[3], double& tMin, double& tHit) DURER_INLINE_LAMBDA {
      if (AnyHit && packet.prim[k] != kNoPrimitive) return false;  // a hit already (from another set)
      o[0] = double(packet.ox[k]), o[1] = double(packet.oy[k]), o[2] = double(packet.oz[k]);
      d[0] = double(packet.dx[k]), d[1] = double(packet.dy[k]), d[2] = double(packet.dz[k]);
      tMin = double(packet.tMin), tHit = double(packet.tHit[k]);
      return true;
    };
    const auto done = [&](int k, double exitT) DURER_INLINE_LAMBDA {
      return AnyHit ? packet.prim[k] != kNoPrimitive : double(packet.tHit[k]) <= exitT;
    };
    // Hits are recorded by record during the walks and by sphere after them: a record's sphere index
    // is a cache miss, read once for each ray the grid hit rather than for each sphere it tests.
    Real tHitBefore[kPacketSize];
    std::copy(packet.tHit, packet.tHit + packet.count, tHitBefore);
    const auto idOf = [](size_t record) DURER_INLINE_LAMBDA { return int32_t(record); };
    // A hit at exactly the t of one this search recorded goes to the sphere of the lower index,
    // whatever order they were tested in: the walk in lanes skips records the one-ray walk tests (those
    // outside a ray's octants of its cell), so the kernel sets agree only if ties do not depend on it.
    const auto record = [&](RayPacket<Real>& p, int k, Real t, int32_t id) DURER_INLINE_LAMBDA {
      if (__builtin_expect(t == p.tHit[k], 0)) breakTie(grid, p, k, id, tHitBefore[k]);
      recordHit(p, k, t, id);
    };
#if DURER_WALK_LANES
    WalkRays rays;
    grid.walkLanes(
        packet.count, rayOf, [&](int k, int lane) DURER_INLINE_LAMBDA { rays.take(lane, packet, terms, left, k); },
        [&](const int32_t* lanes, const uint32_t* records, int n) DURER_INLINE_LAMBDA {
          tests += n;
          left.any ? intersectPairs<M, true>(packet, terms, rays, grid.records(), lanes, records, n, idOf, record)
                   : intersectPairs<M, false>(packet, terms, rays, grid.records(), lanes, records, n, idOf, record);
        },
        done, [&](int k) { others[count++] = k; });
#else
    for (int k = 0; k < packet.count; ++k) {
      double o[3], d[3], tMin, tHit;
      if (!rayOf(k, o, d, tMin, tHit)) continue;
      const SphereRayTerms<Real> rayTerms = terms[k];
      const bool walked = grid.walk(
          o, d, tMin, tHit,
          [&](uint32_t first, uint32_t n) DURER_INLINE_LAMBDA {
            tests += n;
            intersectRun<M>(packet, rayTerms, k, grid.records(), first, n, idOf, record, left.of(k));
          },
          [&](double exitT) DURER_INLINE_LAMBDA { return done(k, exitT); });
      if (!walked) others[count++] = k;
    }
#endif
    for (int k = 0; k < packet.count; ++k) {  // a hit lowers tHit: the rays the grid hit
      if (packet.tHit[k] < tHitBefore[k]) packet.prim[k] = primBase + grid.sphereOf(uint32_t(packet.prim[k]));
    }
    if (count == 0) return tests;
    return tests + this->template searchRays<AnyHit>(packet, others, count, testLeaf);
  }

  // Record `record` met at exactly ray k's tHit: it takes the hit if the hit is one of the grid's
  // records (found by this search: below tHitBefore) whose sphere has the higher index. Mostly it is
  // the kept sphere again, registered in the next cell too. A record equal to the kept one bit for
  // bit is that sphere or a copy of it, and a copy lies in the same cells with the same octants, after
  // the lower index in each (cells take their spheres in the set's order): where the two were first
  // met the lower was kept. So equal records decide nothing, and only unequal ones read their sphere
  // indices (two cache misses: 1 % of the secondary scene's render). Out of line: inlined, its
  // branches would turn recordHit's selects into branches too.
  [[gnu::cold, gnu::noinline]] static void breakTie(const SphereGrid<Real>& grid, RayPacket<Real>& packet, int k,
                                                    int32_t record, Real tHitBefore) {
    if (!(packet.tHit[k] < tHitBefore)) return;
    const uint32_t kept = uint32_t(packet.prim[k]), met = uint32_t(record);
    if (std::memcmp(&grid.records()[kept], &grid.records()[met], sizeof(Sphere<Real>)) == 0) return;
    if (grid.sphereOf(met) < grid.sphereOf(kept)) packet.prim[k] = record;
  }

#if DURER_WALK_LANES
  // The rays of the grid's eight walks, by lane: where each pair's ray is picked from.
  struct WalkRays {
    static constexpr int kLanes = SphereGrid<Real>::kLanes;
    alignas(64) Real ox[kLanes], oy[kLanes], oz[kLanes], sx[kLanes], sy[kLanes], sz[kLanes], invA[kLanes];
    alignas(64) Real leftX[kLanes], leftY[kLanes], leftZ[kLanes], leftR[kLanes];  // the sphere it leaves (Leaving::any)
    int ray[kLanes];

    template <typename Left>
    DURER_INLINE void take(int lane, const RayPacket<Real>& packet, const PacketRayTerms<Real>& terms, const Left& left, int k) {
      ox[lane] = packet.ox[k], oy[lane] = packet.oy[k], oz[lane] = packet.oz[k];
      sx[lane] = terms.sx[k], sy[lane] = terms.sy[k], sz[lane] = terms.sz[k], invA[lane] = terms.invA[k];
      if (left.any) {
        const Sphere<Real>& s = left.sphere[k];
        leftX[lane] = s.center.x, leftY[lane] = s.center.y, leftZ[lane] = s.center.z, leftR[lane] = s.radius;
      }
      ray[lane] = k;
    }
  };

  // The pairs (the ray of walk lanes[i], sphere spheres[records[i]]), i < n, in order, each
  // recording a hit as intersectSphere does: robustMayMeet's test for eight pairs at once
  // (mayMeetLanes), the full test for those it keeps. With SkipLeft, not a walk's pairs with the
  // sphere its ray leaves (WalkRays' left*: Leaving), matched by value (a copy of it, equal bit for
  // bit, would be turned away by the same test). The entries up to n rounded up to eight name lanes
  // and records too (walkLanes lists them so): a select of each past n cost the test 8 % in the caches.
  template <SphereMethod M, bool SkipLeft, typename IdOf, typename Record>
  DURER_INLINE static void intersectPairs(RayPacket<Real>& packet, const PacketRayTerms<Real>& terms, const WalkRays& rays,
                                          const Sphere<Real>* spheres, const int32_t* lanes, const uint32_t* records,
                                          int n, const IdOf& idOf, const Record& record) {
    using L = PairLanes<Real>;
    constexpr int kPairs = WalkRays::kLanes;  // a vector's lanes: the pairs tested at once
    const typename L::V ox = L::load(rays.ox), oy = L::load(rays.oy), oz = L::load(rays.oz);
    const typename L::V sx = L::load(rays.sx), sy = L::load(rays.sy), sz = L::load(rays.sz), invA = L::load(rays.invA);
    // Loaded once, as the rays are: the full tests' stores of hits (Real, as these) could alias them.
    [[maybe_unused]] typename L::V leftX, leftY, leftZ, leftR;
    if constexpr (SkipLeft) {
      leftX = L::load(rays.leftX), leftY = L::load(rays.leftY), leftZ = L::load(rays.leftZ), leftR = L::load(rays.leftR);
    }
    for (int j = 0; j < n; j += kPairs) {
      const uint32_t* at = records + j;  // past n: records too (walkLanes' list), their bits masked off
      typename L::V cx, cy, cz, r;
      L::transpose(spheres, at, cx, cy, cz, r);
      const typename L::Index pick = L::index(lanes + j);
      unsigned may = mayMeetLanes<L>(L::pick(pick, ox) - cx, L::pick(pick, oy) - cy, L::pick(pick, oz) - cz,
                                     L::pick(pick, sx), L::pick(pick, sy), L::pick(pick, sz), L::pick(pick, invA), r);
      if constexpr (SkipLeft) {
        may &= ~(L::equalMask(cx, L::pick(pick, leftX)) & L::equalMask(cy, L::pick(pick, leftY)) &
                 L::equalMask(cz, L::pick(pick, leftZ)) & L::equalMask(r, L::pick(pick, leftR)));
      }
      for (unsigned bits = may & (n - j >= kPairs ? 0xffu : (1u << (n - j)) - 1); bits != 0; bits &= bits - 1) {
        const int i = __builtin_ctz(bits);
        const int k = rays.ray[lanes[j + i]];
        intersectSphere<M, false>(packet, terms[k], k, spheres[at[i]], idOf(at[i]), record);
      }
    }
  }
#endif

  // A leaf's spheres [first, first + count) against ray k, in order (intersectRun), less the
  // sphere it leaves (`left`: Leaving's, or null).
  template <SphereMethod M>
  DURER_INLINE void intersectLeaf(RayPacket<Real>& packet, const SphereRayTerms<Real>& terms, int k, int32_t first,
                                  int32_t count, int32_t primBase, const Sphere<Real>* left) const {
    intersectRun<M>(packet, terms, k, this->m_primitives.data(), size_t(first), size_t(count),
                    [&](size_t i) { return primBase + static_cast<int32_t>(i); }, NearestHit(), left);
  }

  // Spheres [first, first + count) of `spheres` (a hierarchy leaf's, or a grid cell's records)
  // against ray k, in order, sphere i recorded as idOf(i) by `record` (recordHit's signature). The
  // robust test's prefilter (most spheres a ray's walk reaches miss it) is made four spheres at a time
  // where the kernel set has AVX2 and FMA: one branch a leaf instead of a mispredicted one every few
  // spheres. Spheres equal to `left` (the one the ray leaves, Leaving's; null: none) are not tested.
  template <SphereMethod M, typename IdOf, typename Record = NearestHit>
  DURER_INLINE static void intersectRun(RayPacket<Real>& packet, const SphereRayTerms<Real>& terms, int k,
                                        const Sphere<Real>* spheres, size_t first, size_t count, const IdOf& idOf,
                                        const Record& record = Record(), const Sphere<Real>* left = nullptr) {
#if defined(__AVX2__) && defined(__FMA__)
    if constexpr (M == SphereMethod::Robust) {  // four at a time: spheres the build cannot split share a leaf
      for (size_t quad = first; quad < first + count; quad += 4) {
        const int n = int(std::min<size_t>(4, first + count - quad));
        const unsigned may = leafMayMeet(&spheres[quad], n, packet.ox[k], packet.oy[k], packet.oz[k], terms, left);
        for (unsigned bits = may; bits != 0; bits &= bits - 1) {
          const size_t i = quad + size_t(__builtin_ctz(bits));
          intersectSphere<M, false>(packet, terms, k, spheres[i], idOf(i), record);
        }
      }
      return;
    }
#endif
    for (size_t i = first; i < first + count; ++i) {
      if (left && spheres[i].center == left->center && spheres[i].radius == left->radius) continue;
      intersectSphere<M>(packet, terms, k, spheres[i], idOf(i), record);
    }
  }

  // One sphere against ray k: the same arithmetic as intersectOne's loop, so the same t. Without
  // Prefilter, the caller has made robustMayMeet's test.
  template <SphereMethod M, bool Prefilter = true>
  DURER_INLINE void intersectRay(RayPacket<Real>& packet, const SphereRayTerms<Real>& terms, int k, size_t i, int32_t primBase) const {
    intersectSphere<M, Prefilter>(packet, terms, k, this->m_primitives[i], primBase + static_cast<int32_t>(i));
  }

  // Sphere s, recorded as `id` by `record`, against ray k: intersectRay's test, for a sphere given by value.
  template <SphereMethod M, bool Prefilter = true, typename Record = NearestHit>
  DURER_INLINE static void intersectSphere(RayPacket<Real>& packet, const SphereRayTerms<Real>& terms, int k,
                                           const Sphere<Real>& s, int32_t id, const Record& record = Record()) {
    const Vec3<Real> c = s.center;
    const Real r = s.radius;
    const Real ox = packet.ox[k], oy = packet.oy[k], oz = packet.oz[k];
    if constexpr (M == SphereMethod::Robust) {
      if constexpr (Prefilter) {
        const Real fx = ox - c.x, fy = oy - c.y, fz = oz - c.z;
        if (!robustMayMeet(r, lineDistanceSq(fx, fy, fz, terms), std::fabs(fx) + std::fabs(fy) + std::fabs(fz))) return;
      }
      // A ray leaving the sphere it starts on (a reflection or shadow ray off it, whose line meets
      // it, so the prefilter keeps it) skips the roots: it would record nothing (robustLeaves).
      const RobustOrigin<Real> f = robustOrigin(ox, oy, oz, c, r);
      if (packet.tMin > 0 && robustLeaves(f, terms)) return;
      record(packet, k, firstRootFrom(robustRoots(f, terms, r), packet.tMin), id);
      return;
    }
    const SphereRoots<Real> roots =
        sphereRoots<M>(ox, oy, oz, c, packet.dx[k], packet.dy[k], packet.dz[k], terms, r, packet.tMin);
    record(packet, k, firstRootFrom(roots, packet.tMin), id);
  }

  // One sphere against the packet's rays [kBegin, kEnd) (all by default): the vectorised inner loop.
  // Prefilter: first whether any ray may meet it (worth it where most spheres tested meet no ray, as
  // in a hierarchy's leaves, not for a view's sphere against the rays under it).
  template <SphereMethod M, bool Prefilter = true>
  DURER_INLINE void intersectOne(RayPacket<Real>& packet, const PacketRayTerms<Real>& terms, size_t i, int32_t primBase,
                                 int kBegin = 0, int kEnd = -1) const {
    const Vec3<Real> c = this->m_primitives[i].center;
    const Real r = this->m_primitives[i].radius;
    const int n = kEnd < 0 ? packet.count : kEnd;
    if constexpr (M == SphereMethod::Robust && Prefilter) {
      if (!anyRayMayMeet(packet, terms, c, r, kBegin, n)) return;
    }
    const Real tMin = packet.tMin;
    const int32_t id = primBase + static_cast<int32_t>(i);
    const Real* __restrict ox = packet.ox;
    const Real* __restrict oy = packet.oy;
    const Real* __restrict oz = packet.oz;
    const Real* __restrict dx = packet.dx;
    const Real* __restrict dy = packet.dy;
    const Real* __restrict dz = packet.dz;
    if constexpr (M == SphereMethod::Robust) {
      if (packet.commonOrigin) {  // the origin's part once per sphere, not once per ray
        const RobustOrigin<Real> origin = robustOrigin(ox[0], oy[0], oz[0], c, r);
        for (int k = kBegin; k < n; ++k) recordHit(packet, k, firstRootFrom(robustRoots(origin, terms[k], r), tMin), id);
        return;
      }
    }
    for (int k = kBegin; k < n; ++k) {
      const SphereRoots<Real> roots = sphereRoots<M>(ox[k], oy[k], oz[k], c, dx[k], dy[k], dz[k], terms[k], r, tMin);
      recordHit(packet, k, firstRootFrom(roots, tMin), id);
    }
  }

  // Whether the robust test may find a hit for any ray (robustMayMeet, implied by the full test).
  // Most spheres miss most packets; this skips their square roots and divisions.
  DURER_INLINE static bool anyRayMayMeet(const RayPacket<Real>& packet, const PacketRayTerms<Real>& terms, const Vec3<Real>& c,
                                         Real r, int kBegin, int kEnd) {
    int meeting = 0;  // an integer count, not a bool: the reduction then vectorises
    for (int k = kBegin; k < kEnd; ++k) {
      const Real fx = packet.ox[k] - c.x, fy = packet.oy[k] - c.y, fz = packet.oz[k] - c.z;
      const Real fL1 = std::fabs(fx) + std::fabs(fy) + std::fabs(fz);
      meeting += robustMayMeet(r, lineDistanceSq(fx, fy, fz, terms[k]), fL1) ? 1 : 0;
    }
    return meeting > 0;
  }

#if defined(__AVX2__) && defined(__FMA__)
  // robustMayMeet for one ray and one to four spheres s[0 .. count), a lane each: a bit per sphere
  // that may meet the ray. Each lane makes the scalar test's operations in its order (the fused
  // multiply-adds of differenceOfProducts included), so the bits are the scalar outcomes. Lanes past
  // `count` repeat the last sphere (nothing is read beyond the leaf) and are masked off, as are
  // spheres equal to `left` (null: none).
  DURER_INLINE static unsigned leafMayMeet(const Sphere<Real>* s, int count, Real ox, Real oy, Real oz,
                                           const SphereRayTerms<Real>& t, const Sphere<Real>* left = nullptr) {
    using L = LeafLanes<Real>;
    using V = typename L::V;
    const int last = count - 1;
    V cx, cy, cz, r;
    static_assert(sizeof(Sphere<Real>) == 4 * sizeof(Real), "a sphere is four numbers");
    L::transpose(&s[0].center.x, last < 1 ? last : 1, last < 2 ? last : 2, last < 3 ? last : 3, cx, cy, cz, r);
    unsigned may = mayMeetLanes<L>(L::set1(ox) - cx, L::set1(oy) - cy, L::set1(oz) - cz, L::set1(t.sx), L::set1(t.sy),
                                   L::set1(t.sz), L::set1(t.invA), r) &
                   ((1u << count) - 1);
    if (left) {
      may &= ~(L::equalMask(cx, L::set1(left->center.x)) & L::equalMask(cy, L::set1(left->center.y)) &
               L::equalMask(cz, L::set1(left->center.z)) & L::equalMask(r, L::set1(left->radius)));
    }
    return may;
  }

  // robustMayMeet in each lane of L's vectors, for f = o - c, the ray's s and 1 / (s·s), and r: the
  // scalar test's operations in its order (the fused multiply-adds of differenceOfProducts
  // included), so each lane's bit is the scalar outcome.
  template <typename L, typename V = typename L::V>
  DURER_INLINE static unsigned mayMeetLanes(V fx, V fy, V fz, V sx, V sy, V sz, V invA, V r) {
    const auto differenceOfProducts = [](V a, V b, V c, V d) {
      const V cd = c * d;
      return L::fmsub(a, b, cd) + L::fnmadd(c, d, cd);
    };
    const V crossX = differenceOfProducts(fy, sz, fz, sy);
    const V crossY = differenceOfProducts(fz, sx, fx, sz);
    const V crossZ = differenceOfProducts(fx, sy, fy, sx);
    const V lineDistance2 = (crossX * crossX + crossY * crossY + crossZ * crossZ) * invA;
    const V fL1 = L::abs(fx) + L::abs(fy) + L::abs(fz);
    const V wide = r + L::set1(std::numeric_limits<Real>::epsilon()) * fL1;
    const V r2 = wide * wide;
    const V bound = L::set1(kGrazingBound * std::numeric_limits<Real>::epsilon()) * (r2 + lineDistance2);
    return L::greaterMask(r2 - lineDistance2, bound);
  }
#endif

  // The largest radius of a one-sided sphere (0 without any).
  Real largestOneSidedRadius() const {
    Real largest = 0;
    if (!this->anyOneSided()) return largest;
    for (size_t i = 0; i < this->m_primitives.size(); ++i) {
      if (this->oneSided(i)) largest = std::max(largest, this->m_primitives[i].radius);
    }
    return largest;
  }

  // Whether ray k meets sphere `index` first before `from` (its near root is below: it starts
  // inside it); then `exit` is its far side's t. The roots are the search's own test's; a ray whose
  // point at `from` lies plainly outside the sphere skips them.
  template <SphereMethod M>
  bool startsInside(const RayPacket<Real>& packet, int k, size_t index, Real from, Real& exit) const {
    const Sphere<Real>& s = this->m_primitives[index];
    const Real dx = packet.dx[k], dy = packet.dy[k], dz = packet.dz[k];
    const Real qx = packet.ox[k] + from * dx - s.center.x, qy = packet.oy[k] + from * dy - s.center.y,
               qz = packet.oz[k] + from * dz - s.center.z;
    // q's rounding, a few units of its terms' magnitudes: a point farther out than that is outside.
    const Real slack = 8 * std::numeric_limits<Real>::epsilon() *
                       (std::fabs(packet.ox[k]) + std::fabs(packet.oy[k]) + std::fabs(packet.oz[k]) +
                        std::fabs(from) * (std::fabs(dx) + std::fabs(dy) + std::fabs(dz)) + std::fabs(s.center.x) +
                        std::fabs(s.center.y) + std::fabs(s.center.z));
    const Real reach = s.radius + slack;
    if (!(qx * qx + qy * qy + qz * qz <= reach * reach)) return false;  // also a `from` of ±inf
    const SphereRoots<Real> roots =
        sphereRoots<M>(packet.ox[k], packet.oy[k], packet.oz[k], s.center, dx, dy, dz, sphereRayTerms<M>(dx, dy, dz), s.radius, from);
    exit = roots.far;
    return roots.near < from;
  }

  DURER_INLINE Vec3<Real> normal(const RayPacket<Real>& packet, int k, size_t index) const {
    return normalOn(this->m_primitives[index], packet, k);
  }
  DURER_INLINE static Vec3<Real> normalOn(const Sphere<Real>& sphere, const RayPacket<Real>& packet, int k) {
    const Real t = packet.tHit[k];
    const Vec3<Real> p(packet.ox[k] + t * packet.dx[k], packet.oy[k] + t * packet.dy[k],
                       packet.oz[k] + t * packet.dz[k]);
    // A sphere smaller than the spacing of numbers at its hit point can be met exactly at its centre
    // (p - c = 0): the normal then faces the ray.
    return glm::normalize(wellScaled(p - sphere.center, -Vec3<Real>(packet.dx[k], packet.dy[k], packet.dz[k])));
  }

  // Reprojection onto the sphere (pbrt-v4) of the hit whose unit normal is n: the point's error no
  // longer depends on t's error. Its error bound is pointError's.
  DURER_INLINE static Vec3<Real> pointOn(const Sphere<Real>& sphere, const Vec3<Real>& n) {
    return sphere.center + sphere.radius * n;
  }
  DURER_INLINE static Vec3<Real> pointError(const Sphere<Real>& sphere, const Vec3<Real>& point) {
    return errorGamma<Real>(6) * (absolute(point - sphere.center) + absolute(sphere.center));
  }

  // Full record of ray k's hit on sphere `index` at packet.tHit[k]. (Its fields are set from values
  // in registers, never read back from the record: a vector read from a record just written, in
  // other pieces than it was stored in, waits for the stores to drain, about 5 % of a lit render.)
  Hit<Real> hit(const RayPacket<Real>& packet, int k, size_t index) const {
    const Sphere<Real>& sphere = this->m_primitives[index];
    const Vec3<Real> n = normalOn(sphere, packet, k), point = pointOn(sphere, n);
    Hit<Real> h;
    h.t = packet.tHit[k];
    h.normal = n, h.geometricNormal = n;
    h.point = point;
    h.pointError = pointError(sphere, point);
    this->recordIds(h, index);
    return h;
  }

  // hit(packet, k, index) for every ray k of the packet, all of which met sphere `index`, each made
  // in place by make(k, f) from the record f() returns: the same records, their vectors made in a
  // loop over the one sphere's fields that vectorises (a primary render's packets mostly meet one
  // primitive; cpp/tests/test_traversal.cpp checks them against hit's).
  template <typename Make>
  void hitsOn(const RayPacket<Real>& packet, size_t index, const Make& make) const {
    const Sphere<Real> sphere = this->m_primitives[index];
    alignas(64) Real v[9][kPacketSize];
    for (int k = 0; k < packet.count; ++k) {
      const Vec3<Real> n = normalOn(sphere, packet, k), point = pointOn(sphere, n), error = pointError(sphere, point);
      for (int i = 0; i < 3; ++i) v[i][k] = n[i], v[3 + i][k] = point[i], v[6 + i][k] = error[i];
    }
    this->recordsFrom(packet, index, v, make);
  }

 private:
  using Base = PrimitiveSet<Sphere<Real>, Real>;

  // The bits of x, y and z (up to 10 each) interleaved, x lowest.
  static uint32_t mortonCode(uint32_t x, uint32_t y, uint32_t z) {
    const auto spread = [](uint32_t v) {  // bit i to bit 3i
      v = (v | (v << 16)) & 0x030000ffu;
      v = (v | (v << 8)) & 0x0300f00fu;
      v = (v | (v << 4)) & 0x030c30c3u;
      return (v | (v << 2)) & 0x09249249u;
    };
    return spread(x) | spread(y) << 1 | spread(z) << 2;
  }

  // The views last made: the last camera's (an animation's moving camera leaves no trail of stale
  // views) and the last few lights'. The next render of the same camera and lights reuses them. A copy
  // of the set starts without any.
  struct ViewCache {
    std::mutex mutex;
    std::vector<std::pair<ViewKey, std::shared_ptr<const SphereView<Real>>>> views;  // oldest first
    ViewCache() = default;
    ViewCache(const ViewCache&) {}
    ViewCache& operator=(const ViewCache&) {
      clear();
      return *this;
    }
    void clear() {
      const std::lock_guard<std::mutex> lock(mutex);
      views.clear();
    }
    template <typename Make>
    std::shared_ptr<const SphereView<Real>> find(const ViewKey& key, const Make& make) {
      const std::lock_guard<std::mutex> lock(mutex);
      for (const auto& [made, view] : views) {
        if (made == key) return view;
      }
      const size_t kept = key.light ? kMostLightViews - 1 : 0;  // of the same kind, besides the new one
      size_t same = 0;
      for (auto it = views.end(); it != views.begin();) {
        --it;
        if (it->first.light != key.light) continue;
        if (same < kept) {
          ++same;
        } else {
          it = views.erase(it);
        }
      }
      views.emplace_back(key, make());
      return views.back().second;
    }
  };
  mutable ViewCache m_views;

  // The grid, made by the first search that wants it (render threads share the set, and wait for it),
  // on as many threads as the hierarchy was last built or refitted on; a copy of the set, or spheres
  // moved or reordered, start without one.
  struct GridCache {
    std::mutex mutex;
    std::atomic<bool> made{false};
    std::unique_ptr<const SphereGrid<Real>> grid;
    int threads = 1;
    GridCache() = default;
    GridCache(const GridCache&) {}
    GridCache& operator=(const GridCache&) {
      clear(1);
      return *this;
    }
    void clear() {
      const std::lock_guard<std::mutex> lock(mutex);
      grid.reset();
      made.store(false, std::memory_order_release);
    }
    // Where no search runs: the hierarchy's build or refit.
    void clear(int makeThreads) {
      clear();
      threads = makeThreads;
    }
    const SphereGrid<Real>* find(const std::vector<Sphere<Real>>& spheres) {
      if (!made.load(std::memory_order_acquire)) {
        const std::lock_guard<std::mutex> lock(mutex);
        if (!made.load(std::memory_order_relaxed)) {
          grid = SphereGrid<Real>::make(spheres, threads);
          made.store(true, std::memory_order_release);
        }
      }
      return grid.get();
    }
  };
  mutable GridCache m_grid;

  template <typename Other>
  static Sphere<Real> convert(const Sphere<Other>& s) {
    return Sphere<Real>{toReal<Real>(s.center), static_cast<Real>(s.radius)};
  }
  // A sphere's box, rounded outward, for the hierarchy's builds and refits: a lambda, so that it
  // inlines into their loops (a function reference was called per sphere).
  static constexpr auto kBoxOf = [](const Sphere<Real>& s, Vec3<Real>& lo, Vec3<Real>& hi) {
    lo = s.center - s.radius, hi = s.center + s.radius;
    roundOutward(lo, hi);
  };
};

}  // namespace durer
