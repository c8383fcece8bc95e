#pragma once
// What every primitive set (SphereSet, PlaneSet, TriangleSet, BoxSet) shares, after Embree's
// intersectors: a kernel finds t, and one epilog records it. Here: the primitives with their ids
// (ids, not pointers), the reorder to a hierarchy's order, the search over every primitive any ray
// of a packet may meet with one cancel policy, the closer-hit epilog of the search and the ids of the
// hit record, the primitives' own colours where an add gave them, and triangles' corner normals.
#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <vector>

#include "durer/Inline.h"
#include "durer/accel/Bvh.h"
#include "durer/geometry/Hit.h"
#include "durer/geometry/RayPacket.h"
#include "durer/math/Float.h"

namespace durer {

// The epilog of every intersection kernel: ray k's closest hit becomes (t, id) where t is a hit in
// [tMin, tHit) and `valid` (what the kernel itself decided). NaN never passes, nor -inf (an
// overflowed root, which tMin = -inf would accept).
template <typename Real>
DURER_INLINE void recordHit(RayPacket<Real>& packet, int k, Real t, int32_t id, bool valid = true) {
  const bool closer = valid & (t >= packet.tMin) & (t < packet.tHit[k]) & (t > -std::numeric_limits<Real>::infinity());
  packet.tHit[k] = closer ? t : packet.tHit[k];
  packet.prim[k] = closer ? id : packet.prim[k];
}

// kCorners: the colours a primitive carries when colours are given (1: one for the whole primitive;
// triangles: one per corner, interpolated).
template <typename Prim, typename Real, int kCorners = 1>
class PrimitiveSet {
 public:
  // A primitive's colour at each of its corners: linear RGB, its kd in place of its material's.
  using Colors = std::array<Vec3<Real>, kCorners>;
  // A smooth primitive's unit normal at each of its corners (TriangleSet).
  using Normals = std::array<Vec3<Real>, kCorners>;

  void add(const Prim& primitive, int32_t material, int32_t objectId) {
    m_primitives.push_back(primitive);
    m_materials.push_back(material);
    m_objectIds.push_back(objectId);
    if (anyOneSided()) m_oneSided.push_back(0);
  }
  // Once colored(), every primitive added needs its colours too (its material's kd if it has none).
  void add(const Prim& primitive, int32_t material, int32_t objectId, const Colors& colors) {
    add(primitive, material, objectId);
    m_colors.push_back(colors);
  }
  void reserve(size_t n) {
    m_primitives.reserve(n);
    m_materials.reserve(n);
    m_objectIds.reserve(n);
    if (colored()) m_colors.reserve(n);
    if (smooth()) m_normals.reserve(n);
    if (anyOneSided()) m_oneSided.reserve(n);
  }
  size_t size() const { return m_primitives.size(); }
  const Prim& primitive(size_t i) const { return m_primitives[i]; }
  const std::vector<int32_t>& materials() const { return m_materials; }  // material id of primitive i
  const std::vector<int32_t>& objectIds() const { return m_objectIds; }  // scene object id of primitive i
  // Whether the primitives carry colours: none do until an add gives some, and then all do.
  bool colored() const { return !m_colors.empty(); }
  const std::vector<Colors>& colors() const { return m_colors; }  // of primitive i; empty unless colored()
  // Whether the primitives carry normals at their corners: none do until an add gives some, and
  // then all do (TriangleSet gives the others their own normal at every corner).
  bool smooth() const { return !m_normals.empty(); }
  const std::vector<Normals>& normals() const { return m_normals; }  // of primitive i; empty unless smooth()
  // Spheres met from outside only (Group::passInsides): none until one is marked so, then every
  // primitive has an entry. A sphere's alone, kept here with the other per-primitive arrays that
  // add, convertFrom and reorder carry (other sets never mark one: an empty vector).
  bool anyOneSided() const { return !m_oneSided.empty(); }
  bool oneSided(size_t i) const { return anyOneSided() && m_oneSided[i]; }
  const std::vector<uint8_t>& oneSidedFlags() const { return m_oneSided; }
  void setOneSided(size_t i) {
    if (!anyOneSided()) m_oneSided.assign(m_primitives.size(), 0);
    m_oneSided[i] = 1;
  }

  // Asks for what the hit record of primitive `index` reads (the primitive, its ids and colour),
  // ahead of making it: a hit found through copies of the primitives (SphereGrid's records) finds
  // them cold, a cache miss each. Inlined where called: GCC takes a function of prefetches alone for
  // one without effects and drops its calls.
  DURER_INLINE void prefetchHit(size_t index) const {
    __builtin_prefetch(&m_primitives[index]);
    __builtin_prefetch(&m_objectIds[index]);
    __builtin_prefetch(&m_materials[index]);
    if (colored()) __builtin_prefetch(&m_colors[index]);
    if constexpr (kCorners == 3) {
      if (smooth()) __builtin_prefetch(&m_normals[index]);
    }
  }

  // Makes the set colored(): each primitive already in it takes kdOf(its material id) at every corner.
  template <typename KdOf>
  void startColors(const KdOf& kdOf) {
    m_colors.reserve(m_primitives.capacity());
    for (const int32_t material : m_materials) {
      Colors colors;
      colors.fill(kdOf(material));
      m_colors.push_back(colors);
    }
  }

  static constexpr size_t kCancelBatch = 4096;  // primitives between cancel checks without a hierarchy

 protected:
  // The primitives of `other` (another precision's set) converted one by one, with their ids.
  template <typename OtherSet, typename Convert>
  void convertFrom(const OtherSet& other, Convert&& convert) {
    m_primitives.reserve(other.size());
    for (size_t i = 0; i < other.size(); ++i) m_primitives.push_back(convert(other.primitive(i)));
    m_materials = other.materials();
    m_objectIds = other.objectIds();
    m_oneSided = other.oneSidedFlags();
    m_colors.reserve(other.colors().size());
    for (const auto& colors : other.colors()) {
      Colors converted;
      for (int c = 0; c < kCorners; ++c) converted[c] = toReal<Real>(colors[c]);
      m_colors.push_back(converted);
    }
    m_normals.reserve(other.normals().size());
    for (const auto& normals : other.normals()) {
      Normals converted;
      for (int c = 0; c < kCorners; ++c) converted[c] = toReal<Real>(normals[c]);
      m_normals.push_back(converted);
    }
  }

  // Builds the hierarchy over the primitives' boxes boxOf(primitive, lo, hi) on up to `threads`
  // threads and reorders the primitives and their ids to its order.
  template <typename BoxOf>
  void buildBvh(const BoxOf& boxOf, int threads) {
    const auto boxOfIndex = [&](size_t i, Vec3<Real>& lo, Vec3<Real>& hi) { boxOf(m_primitives[i], lo, hi); };
    reorder(m_bvh.build(m_primitives.size(), boxOfIndex, threads), threads);
  }

  // Puts primitive order[j] (and its ids) at place j, for every j.
  void reorder(const std::vector<uint32_t>& order, int threads) {
    permute(m_primitives, order, threads);
    permute(m_materials, order, threads);
    permute(m_objectIds, order, threads);
    if (colored()) permute(m_colors, order, threads);
    if (smooth()) permute(m_normals, order, threads);
    if (anyOneSided()) permute(m_oneSided, order, threads);
    if (m_sourceIndex.empty()) {
      m_sourceIndex = order;
    } else {
      permute(m_sourceIndex, order, threads);
    }
  }

  // The primitives of `source` (the set this one was converted from, same primitives in its own
  // order, moved since) converted again, and the hierarchy refitted to them, or rebuilt once
  // refitting has made it kRebuildCost times as costly as when built. Returns whether it was rebuilt.
  template <typename OtherSet, typename Convert, typename BoxOf>
  bool refitFrom(const OtherSet& source, Convert&& convert, const BoxOf& boxOf, int threads) {
    parallelChunks(m_primitives.size(), threads, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        m_primitives[i] = convert(source.primitive(m_sourceIndex.empty() ? i : m_sourceIndex[i]));
      }
    });
    if (m_bvh.empty()) return false;
    constexpr double kRebuildCost = 1.5;
    const double cost =
        m_bvh.refit([&](size_t i, Vec3<Real>& lo, Vec3<Real>& hi) { boxOf(m_primitives[i], lo, hi); }, threads);
    if (cost <= kRebuildCost) return false;
    buildBvh(boxOf, threads);
    return true;
  }

  // Finds each ray's hits among the primitives it may meet. With a hierarchy, a coherent packet
  // (camera rays) walks it together where its rays agree (Bvh::traversePacket), any other ray by ray,
  // several at once (Bvh::traverseInterleaved): testRay(first, count, k) for ray k and each leaf it
  // may meet before its current hit (with AnyHit, none after its first hit); touching a leaf
  // prefetches its primitives. Without one, the whole packet against every primitive, kCancelBatch
  // at a time: testRange(first, count). Gives up once *cancel is set (the packet is then garbage).
  // Returns the ray-primitive tests made.
  template <bool AnyHit, typename TestRange, typename TestRay>
  int64_t search(RayPacket<Real>& packet, const std::atomic<bool>* cancel, TestRange&& testRange,
                 TestRay&& testRay) const {
    if (m_bvh.empty()) return searchAll(packet, cancel, testRange);
    if (packet.coherent && !AnyHit) {
      if (cancel && cancel->load(std::memory_order_relaxed)) return 0;
      return m_bvh.traversePacket(packet, testRange, testRay);
    }
    if (cancel && cancel->load(std::memory_order_relaxed)) return 0;
    // AnyHit: the rays with a hit already (from another set) are done.
    int rays[kPacketSize], count = 0;
    for (int k = 0; k < packet.count; ++k) {
      if (!AnyHit || packet.prim[k] == kNoPrimitive) rays[count++] = k;
    }
    return searchRays<AnyHit>(packet, rays, count, testRay);
  }

  // The rays rays[0 .. count) of the packet, each walking the hierarchy (several at once), as search()
  // walks a packet that is not coherent.
  template <bool AnyHit, typename TestRay>
  int64_t searchRays(RayPacket<Real>& packet, const int* rays, int count, TestRay&& testRay) const {
    return m_bvh.traverseInterleaved(
        packet, rays, count,
        [&](int32_t first, int32_t n, int k) {
          testRay(first, n, k);
          return AnyHit && packet.prim[k] != kNoPrimitive;
        },
        [&](int32_t first, int32_t n) {
          const uintptr_t begin = reinterpret_cast<uintptr_t>(&m_primitives[size_t(first)]) & ~uintptr_t(63);
          const uintptr_t end = reinterpret_cast<uintptr_t>(&m_primitives[size_t(first + n - 1)] + 1);
          for (uintptr_t line = begin; line < end; line += 64) __builtin_prefetch(reinterpret_cast<const void*>(line));
        });
  }

  // The whole packet against every primitive (sets without a hierarchy), kCancelBatch at a time.
  template <typename TestRange>
  int64_t searchAll(const RayPacket<Real>& packet, const std::atomic<bool>* cancel, TestRange&& testRange) const {
    int64_t visited = 0;
    for (size_t first = 0; first < m_primitives.size(); first += kCancelBatch) {
      if (first && cancel && cancel->load(std::memory_order_relaxed)) break;
      const size_t count = std::min(kCancelBatch, m_primitives.size() - first);
      testRange(static_cast<int32_t>(first), static_cast<int32_t>(count));
      visited += static_cast<int64_t>(count);
    }
    return visited * packet.count;
  }

  // Whether a hierarchy was built (buildBvh), not just the primitives arranged.
  bool hasBvh() const { return !m_bvh.empty(); }

  // The records of every ray k of a packet, all of which met primitive `index`, from the unit
  // normals (both the shaded and the geometric one), points and points' error bounds a loop over
  // the packet made (`v`: their x, y, z components in turn), each made in place by make(k, f) from
  // the record f() returns (SphereSet::hitsOn).
  template <typename Make>
  DURER_INLINE void recordsFrom(const RayPacket<Real>& packet, size_t index, const Real (&v)[9][kPacketSize],
                                const Make& make) const {
    for (int k = 0; k < packet.count; ++k) {
      make(k, [&] {
        const Vec3<Real> normal(v[0][k], v[1][k], v[2][k]);
        Hit<Real> hit;
        hit.t = packet.tHit[k];
        hit.normal = normal, hit.geometricNormal = normal;
        hit.point = Vec3<Real>(v[3][k], v[4][k], v[5][k]);
        hit.pointError = Vec3<Real>(v[6][k], v[7][k], v[8][k]);
        recordIds(hit, index);
        return hit;
      });
    }
  }

  // The hit record's epilog: the ids of primitive `index`, and its colour if it has one colour
  // (a primitive with one per corner interpolates them itself).
  void recordIds(Hit<Real>& hit, size_t index) const {
    hit.objectId = m_objectIds[index];
    hit.materialId = m_materials[index];
    if constexpr (kCorners == 1) {
      if (colored()) hit.colored = true, hit.color = m_colors[index][0];
    }
  }

  std::vector<Prim> m_primitives;
  std::vector<Normals> m_normals;  // empty, or one entry per primitive

 private:
  template <typename T>
  static void permute(std::vector<T>& items, const std::vector<uint32_t>& order, int threads) {
    std::vector<T> sorted(order.size());
    parallelChunks(order.size(), threads, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) sorted[i] = items[order[i]];
    });
    items.swap(sorted);
  }

  std::vector<int32_t> m_materials;
  std::vector<int32_t> m_objectIds;
  std::vector<Colors> m_colors;         // empty, or one entry per primitive
  std::vector<uint8_t> m_oneSided;      // empty, or one entry per primitive (1: met from outside only)
  Bvh<Real> m_bvh;                      // empty: brute force
  std::vector<uint32_t> m_sourceIndex;  // once reordered: primitive i's index in the set converted from
};

}  // namespace durer
