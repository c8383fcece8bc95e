#pragma once
#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <vector>

#include "durer/Inline.h"
#include "durer/math/Affine.h"
#include "durer/accel/BoxSet.h"
#include "durer/accel/Bvh.h"
#include "durer/accel/PlaneSet.h"
#include "durer/accel/SphereSet.h"
#include "durer/accel/TriangleSet.h"
#include "durer/math/Float.h"

namespace durer {

template <typename Real>
class Group;

// A group seen through an affine map: rays go into object space by objectFromWorld (origin as a
// point, direction as a vector, not renormalised, so t is the same number in both frames and stays
// in world units), normals come back by the inverse transpose. A scaled sphere is an ellipsoid.
template <typename Real>
struct Instance {
  Affine<Real> worldFromObject;
  Affine<Real> objectFromWorld;
  // No instances of its own (nested transforms are composed); shared by the instances of one mesh
  // (Group::addInstance), whose primitives and hierarchy then exist once.
  std::shared_ptr<Group<Real>> child;
  bool shared = false;                 // an instance of a shared child: never the group of its map
  bool colored = false;                // every hit through it takes `color` as kd (per-instance colours)
  Vec3<Real> color{0};
  int32_t primBase = 0;                // packed index of the child's first primitive in the parent
  bool bounded = false;                // whether [lo, hi] holds everything (no infinite plane)
  Vec3<Real> lo{0}, hi{0};             // world-space bounds, widened for rounding

  // The packet's rays in object space; hits still to beat: the world packet's.
  void toObject(const RayPacket<Real>& world, RayPacket<Real>& local) const {
    local.count = world.count;
    local.tMin = world.tMin;
    local.tMax = world.tMax;
    local.commonOrigin = world.commonOrigin;  // the same origin maps to the same point
    local.coherent = world.coherent;
    local.leaving = false;  // `from` holds the parent's packed indices, not the child's
    const Affine<Real>& m = objectFromWorld;
    for (int k = 0; k < world.count; ++k) {
      const Real ox = world.ox[k], oy = world.oy[k], oz = world.oz[k];
      const Real dx = world.dx[k], dy = world.dy[k], dz = world.dz[k];
      local.ox[k] = m.pointX(ox, oy, oz), local.oy[k] = m.pointY(ox, oy, oz), local.oz[k] = m.pointZ(ox, oy, oz);
      local.dx[k] = m.vectorX(dx, dy, dz), local.dy[k] = m.vectorY(dx, dy, dz), local.dz[k] = m.vectorZ(dx, dy, dz);
      local.tHit[k] = world.tHit[k];
      local.prim[k] = kNoPrimitive;
    }
  }
};

struct PrimitiveCounts {
  size_t spheres = 0, planes = 0, triangles = 0, boxes = 0, instances = 0;  // as traced: per instance
  size_t storedTriangles = 0;  // as stored: a shared child's once
};

// A group of objects, one contiguous set per primitive kind (no virtual call per primitive per ray),
// plus transformed groups. A scene's geometry is a group. Packed primitive index: [0, spheres)
// spheres, then planes, triangles, boxes, then each instance's primitives in turn.
template <typename Real>
class Group {
 public:
  Group() = default;
  Group(const Group& other) { assign(other); }
  template <typename Other>
  explicit Group(const Group<Other>& other) {
    assign(other);
  }
  Group& operator=(const Group&) = delete;

  SphereSet<Real>& spheres() { return m_spheres; }
  const SphereSet<Real>& spheres() const { return m_spheres; }
  PlaneSet<Real>& planes() { return m_planes; }
  const PlaneSet<Real>& planes() const { return m_planes; }
  TriangleSet<Real>& triangles() { return m_triangles; }
  const TriangleSet<Real>& triangles() const { return m_triangles; }
  BoxSet<Real>& boxes() { return m_boxes; }
  const BoxSet<Real>& boxes() const { return m_boxes; }
  const std::vector<Instance<Real>>& instances() const { return m_instances; }

  // The group that objects seen through worldFromObject go into (made on first use; one per map,
  // so that objects sharing a transform share its hierarchy). objectFromWorld: its inverse.
  Group& transformed(const Affine<Real>& worldFromObject, const Affine<Real>& objectFromWorld) {
    const auto key = keyOf(worldFromObject);
    const auto found = m_instanceOf.find(key);
    if (found != m_instanceOf.end()) return *m_instances[found->second].child;
    m_instanceOf.emplace(key, m_instances.size());
    Instance<Real> instance;
    instance.worldFromObject = worldFromObject;
    instance.objectFromWorld = objectFromWorld;
    instance.child = std::make_shared<Group>();
    m_instances.push_back(std::move(instance));
    return *m_instances.back().child;
  }

  // Another instance of `child`, seen through worldFromObject: its instances share its primitives
  // and hierarchy (each still has its own range of packed indices). Never merged with the group
  // transformed() makes for the same map.
  // `color`, if given, is every hit's kd through this instance, in place of the child's own.
  void addInstance(const Affine<Real>& worldFromObject, const Affine<Real>& objectFromWorld,
                   std::shared_ptr<Group<Real>> child, const Vec3<Real>* color = nullptr) {
    Instance<Real> instance;
    instance.worldFromObject = worldFromObject;
    instance.objectFromWorld = objectFromWorld;
    instance.child = std::move(child);
    instance.shared = true;
    if (color) instance.colored = true, instance.color = *color;
    m_instances.push_back(std::move(instance));
  }

  size_t ownPrimitiveCount() const {
    return m_spheres.size() + m_planes.size() + m_triangles.size() + m_boxes.size();
  }
  size_t primitiveCount() const {
    size_t n = ownPrimitiveCount();
    for (const Instance<Real>& inst : m_instances) n += inst.child->primitiveCount();
    return n;
  }
  PrimitiveCounts counts() const {
    PrimitiveCounts c{m_spheres.size(), m_planes.size(), m_triangles.size(), m_boxes.size(), m_instances.size(),
                      m_triangles.size()};
    std::set<const Group*> stored;
    for (const Instance<Real>& inst : m_instances) {
      const PrimitiveCounts d = inst.child->counts();
      c.spheres += d.spheres, c.planes += d.planes, c.triangles += d.triangles, c.boxes += d.boxes;
      if (stored.insert(inst.child.get()).second) c.storedTriangles += d.storedTriangles;
    }
    return c;
  }

  // Ready for tracing: hierarchies where they pay (built on up to `threads` threads; this group's own
  // spheres' only if `ownSpheres`), the instances' packed ranges and world bounds.
  void prepare(int threads, bool ownSpheres = true) {
    m_anyOneSided = m_spheres.anyOneSided();
    m_oneSidedRadius = m_spheres.largestOneSidedRadius();
    if (m_spheres.size() >= kBvhMinPrimitives) {
      if (ownSpheres) {
        m_spheres.buildBvh(threads);
      } else {
        m_spheres.arrange(threads);
      }
    }
    if (m_triangles.size() >= kBvhMinPrimitives) m_triangles.buildBvh(threads);
    if (m_boxes.size() >= kBvhMinPrimitives) m_boxes.buildBvh(threads);
    size_t base = ownPrimitiveCount();
    std::set<const Group*> prepared;  // a shared child once
    for (Instance<Real>& inst : m_instances) {
      if (prepared.insert(inst.child.get()).second) inst.child->prepare(threads);
      m_anyOneSided = m_anyOneSided || inst.child->m_anyOneSided;
      inst.primBase = static_cast<int32_t>(base);
      base += inst.child->primitiveCount();
      inst.bounded = inst.child->worldBounds(inst.worldFromObject, inst.lo, inst.hi);
    }
    buildInstanceBvh(threads);
  }

  // Once prepared from `source` (the group this one was converted from) whose spheres have moved
  // since: the spheres converted again and their hierarchies refitted (or rebuilt where refitting
  // degraded them), the instances' bounds and the hierarchy over them made again. Returns the
  // sphere hierarchies rebuilt.
  template <typename Other>
  int refitFrom(const Group<Other>& source, int threads) {
    int rebuilt = m_spheres.refitFrom(source.spheres(), threads) ? 1 : 0;
    m_oneSidedRadius = m_spheres.largestOneSidedRadius();
    std::set<const Group*> refitted;  // a shared child once
    for (size_t i = 0; i < m_instances.size(); ++i) {
      Instance<Real>& inst = m_instances[i];
      if (refitted.insert(inst.child.get()).second) rebuilt += inst.child->refitFrom(*source.instances()[i].child, threads);
      inst.bounded = inst.child->worldBounds(inst.worldFromObject, inst.lo, inst.hi);
    }
    buildInstanceBvh(threads);
    return rebuilt;
  }

  // The cheap t-only search for each ray's closest primitive; returns the ray-primitive tests made.
  template <SphereMethod M>
  int64_t intersect(RayPacket<Real>& packet, const std::atomic<bool>* cancel) const {
    packet.resetHits();
    const int64_t tests = search<M, false>(packet, 0, cancel);
    return m_anyOneSided ? tests + passInsides<M, false>(packet, cancel) : tests;
  }

  // Shadow rays: whether each ray meets anything in [tMin, tMax) (prim != kNoPrimitive), its search
  // stopped at the first hit found, which need not be the closest.
  template <SphereMethod M>
  int64_t occluded(RayPacket<Real>& packet, const std::atomic<bool>* cancel) const {
    packet.resetHits();
    const int64_t tests = search<M, true>(packet, 0, cancel);
    return m_anyOneSided ? tests + passInsides<M, true>(packet, cancel) : tests;
  }

  // The searches of a render's or cast's sphere method, one of those `Methods` (SphereMethods)
  // lists: the method's search compiled once, the caller for all of them.
  template <typename Methods>
  int64_t intersect(SphereMethod method, RayPacket<Real>& packet, const std::atomic<bool>* cancel) const {
    return Methods::call(method, [&](auto m) { return intersect<decltype(m)::value>(packet, cancel); });
  }
  template <typename Methods>
  int64_t occluded(SphereMethod method, RayPacket<Real>& packet, const std::atomic<bool>* cancel) const {
    return Methods::call(method, [&](auto m) { return occluded<decltype(m)::value>(packet, cancel); });
  }

  // Lowers each ray's tHit to its closest hit among this group's primitives (its transformed
  // groups' included), recorded as primBase + their packed index; with AnyHit, to any hit.
  template <SphereMethod M, bool AnyHit>
  int64_t search(RayPacket<Real>& packet, int32_t primBase, const std::atomic<bool>* cancel) const {
    int64_t tests = searchOwn<M, AnyHit>(packet, primBase, cancel);
    if (!m_instances.empty()) tests += searchInstances<M, AnyHit>(packet, primBase, cancel);
    return tests;
  }

  // Calls make(k) for rays k = 0 .. count - 1 of the packet, in order, make building ray k's hit
  // record (hit(packet, k)), with what the record of ray k + kHitsAhead reads of the group's own
  // spheres asked for first: after a search among copies (SphereGrid's records) the set's arrays
  // are cold, and the misses of several records then overlap, no more in flight than the core tracks.
  template <typename Make>
  DURER_INLINE void forEachHitRecord(const RayPacket<Real>& packet, int count, const Make& make) const {
    for (int k = 0; k < std::min(count, kHitsAhead); ++k) prefetchHit(packet, k);
    for (int k = 0; k < count; ++k) {
      if (k + kHitsAhead < count) prefetchHit(packet, k + kHitsAhead);
      make(k);
    }
  }

  // Where every ray of the packet met one of the group's own spheres or planes (most camera packets
  // where the objects span many pixels, few of a point cloud's; mirror and refracted packets too,
  // where they agree), each ray's hit record, as hit(packet, k) makes it, made in place by make(k, f)
  // from the record f() returns, in loops over that one primitive that vectorise (SphereSet::hitsOn);
  // false, and nothing made, otherwise.
  template <typename Make>
  bool makeUniformHits(const RayPacket<Real>& packet, const Make& make) const {
    const int32_t first = packet.prim[0];
    int others = 0;  // an integer count, not a bool: the reduction then vectorises
    for (int k = 1; k < packet.count; ++k) others += packet.prim[k] != first ? 1 : 0;
    const auto index = static_cast<size_t>(first);
    if (others != 0 || first == kNoPrimitive || index >= m_spheres.size() + m_planes.size()) return false;
    if (index < m_spheres.size()) {
      m_spheres.hitsOn(packet, index, make);
    } else {
      m_planes.hitsOn(packet, index - m_spheres.size(), make);
    }
    return true;
  }

  // The full hit record of ray k, once its search is over (a miss gives the default record).
  Hit<Real> hit(const RayPacket<Real>& packet, int k) const {
    const int32_t prim = packet.prim[k];
    // Spheres, most scenes' primitives, first: one count to compare with, not the four of ownPrimitiveCount.
    const auto index = static_cast<size_t>(prim);
    if (prim == kNoPrimitive || index < m_spheres.size() || index < ownPrimitiveCount()) return hitOwn(packet, k);
    return instanceHit(instanceOf(prim), packet, k);
  }

  // Material id of every packed primitive, in packed order.
  void appendMaterials(std::vector<int32_t>& out) const {
    appendPerPrimitive(out, [](const auto& set) -> const std::vector<int32_t>& { return set.materials(); });
  }

  // Object id of every packed primitive, in packed order (the ids a hit record reports).
  void appendObjectIds(std::vector<int32_t>& out) const {
    appendPerPrimitive(out, [](const auto& set) -> const std::vector<int32_t>& { return set.objectIds(); });
  }

 private:
  // One-sided spheres (Scene::addSpheres: a point cloud's points, which Cycles meets from outside
  // only) are found from both sides by the kernels, as every sphere; a ray whose hit is the far side
  // of one it starts inside is searched again here, alone: past that side (with AnyHit, before and
  // past it), as often as it meets such a side. Only those rays pay: a camera in a point's sphere, a
  // clip start through some, a point seen inside another's sphere. A ray starting inside K such
  // spheres searches up to K times, each meeting them again: K² tests (a camera deep in an
  // overlapping cloud).
  template <SphereMethod M, bool AnyHit>
  int64_t passInsides(RayPacket<Real>& packet, const std::atomic<bool>* cancel) const {
    if (!(packet.tMin > -std::numeric_limits<Real>::infinity())) return 0;  // no ray starts anywhere
    // A ray leaves a sphere it starts inside within twice its radius: a hit on the group's own
    // spheres farther on is not such a side, told without reading the sphere (most rays; a loop
    // that vectorises). The margins: the radius rounded to this precision, the roots' rounding.
    const Real reach = 2 * m_oneSidedRadius * (1 + Real(1) / 64);
    const Real eps = std::numeric_limits<Real>::epsilon();
    const auto own = static_cast<uint32_t>(m_spheres.size());
    alignas(64) int32_t maybe[kPacketSize];
    for (int k = 0; k < packet.count; ++k) {
      const Real t = packet.tHit[k];
      const Real ahead = t - packet.tMin - 16 * eps * (std::fabs(t) + std::fabs(packet.tMin));
      const Real lengthSq = packet.dx[k] * packet.dx[k] + packet.dy[k] * packet.dy[k] + packet.dz[k] * packet.dz[k];
      const bool far = static_cast<uint32_t>(packet.prim[k]) < own && ahead > 0 && ahead * ahead * lengthSq > reach * reach;
      maybe[k] = far || packet.prim[k] == kNoPrimitive ? 0 : 1;
    }
    int any = 0;
    for (int k = 0; k < packet.count; ++k) any |= maybe[k];
    if (!any) return 0;  // most packets
    int64_t tests = 0;
    for (int k = 0; k < packet.count; ++k) {
      Real exit;
      if (!maybe[k] || !startsInside<M>(packet, k, packet.tMin, exit)) continue;
      RayPacket<Real> alone;
      takeAlone(packet, k, alone);
      bool hit;
      if constexpr (AnyHit) {
        hit = occludedBesides<M>(alone, packet.tMin, exit, packet.tMax, tests, cancel);
      } else {
        hit = false;
        for (Real from = nextUp(std::max(exit, packet.tHit[k])); from < packet.tMax;
             from = nextUp(std::max(exit, alone.tHit[0]))) {
          tests += searchAlone<M, false>(alone, from, packet.tMax, cancel);
          hit = alone.prim[0] != kNoPrimitive;
          if (!hit || !startsInside<M>(alone, 0, from, exit)) break;
          hit = false;
        }
      }
      packet.prim[k] = hit ? alone.prim[0] : kNoPrimitive;
      packet.tHit[k] = hit ? alone.tHit[0] : packet.tMax;
    }
    return tests;
  }

  // Ray k of `packet` as a packet of its own: searched through the packet's view (a camera tile's
  // cell, every sphere of its rows and columns, or a light's), without the view's sure hits (which
  // hold for a shadow ray's whole segment to the light, not for part of it).
  static void takeAlone(const RayPacket<Real>& packet, int k, RayPacket<Real>& alone) {
    alone.count = 1;
    alone.commonOrigin = true;
    alone.coherent = false;
    alone.view = packet.view;
    alone.sureHits = false;
    std::copy(packet.sampleBox, packet.sampleBox + 4, alone.sampleBox);
    alone.tileX = packet.tileX, alone.tileY = packet.tileY, alone.tileWidth = 0;
    alone.ox[0] = packet.ox[k], alone.oy[0] = packet.oy[k], alone.oz[0] = packet.oz[k];
    alone.dx[0] = packet.dx[k], alone.dy[0] = packet.dy[k], alone.dz[0] = packet.dz[k];
  }

  // Whether ray 0 of `alone` meets anything in [from, to) but the one-sided spheres it starts inside,
  // one of which it leaves at `exit` (in [from, to)): its hit is then in `alone`. The parts of
  // [from, to) still to search are kept in a list, not a recursion as deep as the spheres nest.
  template <SphereMethod M>
  bool occludedBesides(RayPacket<Real>& alone, Real from, Real exit, Real to, int64_t& tests,
                       const std::atomic<bool>* cancel) const {
    std::vector<std::pair<Real, Real>> parts{{from, exit}, {nextUp(exit), to}};
    while (!parts.empty()) {
      const auto [lo, hi] = parts.back();
      parts.pop_back();
      if (!(lo < hi)) continue;
      tests += searchAlone<M, true>(alone, lo, hi, cancel);
      if (alone.prim[0] == kNoPrimitive) continue;
      Real inner;
      if (!startsInside<M>(alone, 0, lo, inner)) return true;
      // The search's own t of that side, should its kernel round the root otherwise: always past lo.
      inner = std::max(inner, alone.tHit[0]);
      parts.push_back({lo, inner});
      parts.push_back({nextUp(inner), hi});
    }
    return false;
  }

  // Searches `alone` (takeAlone's) in [from, to).
  template <SphereMethod M, bool AnyHit>
  int64_t searchAlone(RayPacket<Real>& alone, Real from, Real to, const std::atomic<bool>* cancel) const {
    alone.tMin = from;
    alone.tMax = to;
    alone.resetHits();
    return search<M, AnyHit>(alone, 0, cancel);
  }

  // Whether ray k's hit is a one-sided sphere (of this group or of a transformed group's child)
  // that it meets first before `from` (it starts inside it); then `exit` is its far side's t.
  template <SphereMethod M>
  bool startsInside(const RayPacket<Real>& packet, int k, Real from, Real& exit) const {
    const int32_t prim = packet.prim[k];
    if (prim == kNoPrimitive) return false;
    const auto index = static_cast<size_t>(prim);
    if (index < m_spheres.size()) return m_spheres.oneSided(index) && m_spheres.template startsInside<M>(packet, k, index, from, exit);
    if (index < ownPrimitiveCount() || m_instances.empty()) return false;
    const Instance<Real>& inst = instanceOf(prim);
    const SphereSet<Real>& spheres = inst.child->m_spheres;
    const auto local = static_cast<size_t>(prim - inst.primBase);
    if (!(local < spheres.size() && spheres.oneSided(local))) return false;
    RayPacket<Real> object;
    objectRay(inst, packet, k, object);
    return spheres.template startsInside<M>(object, 0, local, from, exit);
  }

  // ids(set), a per-primitive table of each primitive set, joined in packed order.
  template <typename Ids>
  void appendPerPrimitive(std::vector<int32_t>& out, const Ids& ids) const {
    for (const std::vector<int32_t>* table : {&ids(m_spheres), &ids(m_planes), &ids(m_triangles), &ids(m_boxes)}) {
      out.insert(out.end(), table->begin(), table->end());
    }
    for (const Instance<Real>& inst : m_instances) inst.child->appendPerPrimitive(out, ids);
  }

  template <typename Other>
  friend class Group;

  template <typename Other>
  void assign(const Group<Other>& other) {
    m_spheres = SphereSet<Real>(other.spheres());
    m_planes = PlaneSet<Real>(other.planes());
    m_triangles = TriangleSet<Real>(other.triangles());
    m_boxes = BoxSet<Real>(other.boxes());
    std::map<const Group<Other>*, std::shared_ptr<Group>> converted;  // shared children stay shared
    for (const Instance<Other>& source : other.instances()) {
      Instance<Real> inst;
      inst.worldFromObject = Affine<Real>::from(source.worldFromObject);
      inst.objectFromWorld = Affine<Real>::from(source.objectFromWorld);
      std::shared_ptr<Group>& child = converted[source.child.get()];
      if (!child) child = std::make_shared<Group>(*source.child);
      inst.child = child;
      inst.shared = source.shared;
      inst.colored = source.colored;
      inst.color = Vec3<Real>(source.color);
      if (!inst.shared) m_instanceOf.emplace(keyOf(inst.worldFromObject), m_instances.size());
      m_instances.push_back(std::move(inst));
    }
  }

  static std::array<Real, 12> keyOf(const Affine<Real>& m) {
    std::array<Real, 12> key;
    for (int i = 0; i < 3; ++i) key[4 * i] = m.row[i].x, key[4 * i + 1] = m.row[i].y, key[4 * i + 2] = m.row[i].z,
                                key[4 * i + 3] = m.offset[i];
    return key;
  }

  // The search and hit record over this group's own primitives. A transformed group's child has no
  // instances, and calling these (not search/hit) on it keeps the hot path free of recursion, which
  // the compiler could not inline.
  template <SphereMethod M, bool AnyHit>
  int64_t searchOwn(RayPacket<Real>& packet, int32_t primBase, const std::atomic<bool>* cancel) const {
    int32_t base = primBase;
    int64_t tests = m_spheres.template intersect<M, AnyHit>(packet, base, cancel);
    base += static_cast<int32_t>(m_spheres.size());
    tests += m_planes.intersect(packet, base, cancel);
    base += static_cast<int32_t>(m_planes.size());
    tests += m_triangles.template intersect<AnyHit>(packet, base, cancel);
    base += static_cast<int32_t>(m_triangles.size());
    tests += m_boxes.template intersect<AnyHit>(packet, base, cancel);
    return tests;
  }

  static constexpr int kHitsAhead = 8;
  // Inlined where called: see PrimitiveSet::prefetchHit.
  DURER_INLINE void prefetchHit(const RayPacket<Real>& packet, int k) const {
    const auto index = static_cast<uint32_t>(packet.prim[k]);  // a miss (-1) lies past every set
    if (index < m_spheres.size()) m_spheres.prefetchHit(index);
  }

  Hit<Real> hitOwn(const RayPacket<Real>& packet, int k) const {
    const int32_t prim = packet.prim[k];
    if (prim == kNoPrimitive) return Hit<Real>{};
    size_t index = static_cast<size_t>(prim);
    if (index < m_spheres.size()) return m_spheres.hit(packet, k, index);
    index -= m_spheres.size();
    if (index < m_planes.size()) return m_planes.hit(packet, k, index);
    index -= m_planes.size();
    if (index < m_triangles.size()) return m_triangles.hit(packet, k, index);
    return m_boxes.hit(packet, k, index - m_triangles.size());
  }

  // The instance whose child holds packed primitive `prim` (one of an instance's).
  const Instance<Real>& instanceOf(int32_t prim) const {
    return *(std::upper_bound(m_instances.begin(), m_instances.end(), prim,
                              [](int32_t p, const Instance<Real>& inst) { return p < inst.primBase; }) - 1);
  }

  // Ray k of `packet` alone, in instance inst's object space (the same t along it), with its hit:
  // `local`'s ray 0, its primitive the child's own index.
  static void objectRay(const Instance<Real>& inst, const RayPacket<Real>& packet, int k, RayPacket<Real>& local) {
    RayPacket<Real> world;
    world.count = 1;
    world.tMin = packet.tMin;
    world.tMax = packet.tMax;
    world.ox[0] = packet.ox[k], world.oy[0] = packet.oy[k], world.oz[0] = packet.oz[k];
    world.dx[0] = packet.dx[k], world.dy[0] = packet.dy[k], world.dz[0] = packet.dz[k];
    world.tHit[0] = packet.tHit[k];
    inst.toObject(world, local);  // the hit so far too
    local.prim[0] = packet.prim[k] - inst.primBase;
  }

  // The top-level hierarchy over the bounded instances' world boxes, from a few instances on (so
  // that thousands cost a walk down a tree, not a loop); the unbounded ones (an infinite plane)
  // are searched by every packet.
  void buildInstanceBvh(int threads) {
    constexpr size_t kInstanceBvhMin = 8;
    std::vector<uint32_t> bounded;
    m_unboundedInstances.clear();
    for (size_t i = 0; i < m_instances.size(); ++i) (m_instances[i].bounded ? bounded : m_unboundedInstances).push_back(uint32_t(i));
    m_boundedInstances = bounded;
    if (bounded.size() < kInstanceBvhMin) return;
    const std::vector<uint32_t> order = m_instanceBvh.build(
        bounded.size(),
        [&](size_t i, Vec3<Real>& lo, Vec3<Real>& hi) { lo = m_instances[bounded[i]].lo, hi = m_instances[bounded[i]].hi; },
        threads);
    for (size_t i = 0; i < order.size(); ++i) m_boundedInstances[i] = bounded[order[i]];
  }

  template <SphereMethod M, bool AnyHit>
  int64_t searchInstances(RayPacket<Real>& packet, int32_t primBase, const std::atomic<bool>* cancel) const {
    const PacketInverse<Real> inv(packet);
    int64_t tests = 0;
    RayPacket<Real> local;
    const auto searchOne = [&](uint32_t index) {
      const Instance<Real>& inst = m_instances[index];
      if (inst.bounded && !anyRayEnters(packet, inv, inst.lo, inst.hi)) return;
      inst.toObject(packet, local);
      tests += inst.child->template searchOwn<M, AnyHit>(local, primBase + inst.primBase, cancel);
      for (int k = 0; k < packet.count; ++k) {
        const bool closer = local.prim[k] != kNoPrimitive;  // the child only records hits closer than tHit
        packet.tHit[k] = closer ? local.tHit[k] : packet.tHit[k];
        packet.prim[k] = closer ? local.prim[k] : packet.prim[k];
      }
    };
    for (uint32_t index : m_unboundedInstances) searchOne(index);
    if (m_instanceBvh.empty()) {
      for (uint32_t index : m_boundedInstances) searchOne(index);
    } else {
      m_instanceBvh.traverseTogether(packet, [&](int32_t first, int32_t count) {
        for (int32_t i = first; i < first + count; ++i) searchOne(m_boundedInstances[static_cast<size_t>(i)]);
      });
    }
    return tests;
  }

  // The child's hit record for ray k, found again in object space (the same map gives the same
  // object-space ray, bit for bit), then brought back to world space.
  Hit<Real> instanceHit(const Instance<Real>& inst, const RayPacket<Real>& packet, int k) const {
    RayPacket<Real> local;
    objectRay(inst, packet, k, local);
    Hit<Real> h = inst.child->hitOwn(local, 0);
    if (inst.colored) h.colored = true, h.color = inst.color;
    const bool smooth = h.normal != h.geometricNormal;
    if (h.lift != 0) h.lift *= static_cast<float>(glm::length(inst.worldFromObject.vector(h.normal)));
    h.normal = worldNormal(inst, h.normal);
    h.geometricNormal = smooth ? worldNormal(inst, h.geometricNormal) : h.normal;
    h.pointError = inst.worldFromObject.pointError(h.point, h.pointError);
    h.point = inst.worldFromObject.point(h.point);
    return h;
  }

  static Vec3<Real> worldNormal(const Instance<Real>& inst, const Vec3<Real>& normal) {
    const Vec3<Real> n = wellScaled(inst.objectFromWorld.transposed(normal), normal);
    return n / glm::length(n);
  }

  // The world-space box of everything in this group seen through worldFromObject; false (no
  // culling) if unbounded (an infinite plane), empty or not finite.
  bool worldBounds(const Affine<Real>& worldFromObject, Vec3<Real>& lo, Vec3<Real>& hi) const {
    if (m_planes.size() > 0) return false;
    constexpr Real inf = std::numeric_limits<Real>::infinity();
    Vec3<Real> objLo(inf), objHi(-inf);
    m_spheres.bounds(objLo, objHi);
    m_triangles.bounds(objLo, objHi);
    m_boxes.bounds(objLo, objHi);
    if (!(objLo.x <= objHi.x)) return false;
    lo = Vec3<Real>(inf), hi = Vec3<Real>(-inf);
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3<Real> c((corner & 1) ? objHi.x : objLo.x, (corner & 2) ? objHi.y : objLo.y,
                         (corner & 4) ? objHi.z : objLo.z);
      // The corner's own rounding, from the products' magnitudes: a map whose rotation and offset
      // cancel puts a corner near 0 with an error of its terms' size (a float box 0.8 from the origin
      // was 1e-5 off, and culled rays that met the sphere inside it).
      const Vec3<Real> p = worldFromObject.point(c), e = worldFromObject.pointError(c, Vec3<Real>(0));
      lo = glm::min(lo, p - e), hi = glm::max(hi, p + e);
    }
    // Generous slack: the box only culls, and the object-space ray carries the map's rounding.
    const Vec3<Real> widen = Real(1e-3) * (hi - lo) + errorGamma<Real>(32) * (absolute(lo) + absolute(hi));
    lo -= widen, hi += widen;
    roundOutward(lo, hi);
    return std::isfinite(lo.x + lo.y + lo.z + hi.x + hi.y + hi.z);
  }

  SphereSet<Real> m_spheres;
  PlaneSet<Real> m_planes;
  TriangleSet<Real> m_triangles;
  BoxSet<Real> m_boxes;
  std::vector<Instance<Real>> m_instances;  // sorted by primBase (the order they were made)
  Bvh<Real> m_instanceBvh;                    // over m_boundedInstances' world boxes; empty below a few
  std::vector<uint32_t> m_boundedInstances;   // indices into m_instances, in m_instanceBvh's order
  std::vector<uint32_t> m_unboundedInstances;
  std::map<std::array<Real, 12>, size_t> m_instanceOf;
  bool m_anyOneSided = false;  // whether a one-sided sphere is among the spheres, its children's too (prepare)
  Real m_oneSidedRadius = 0;   // the largest of this group's own one-sided spheres' radii (prepare, refitFrom)
};

}  // namespace durer
