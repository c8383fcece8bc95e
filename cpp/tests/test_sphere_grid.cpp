// The sphere grid (SphereGrid) that incoherent rays walk: when it is made, and that searches through
// it find what testing every sphere finds, bit for bit -- rays from inside and outside, rays parallel
// to the cells' faces and along their diagonals, rays leaving spheres' surfaces, shadow rays' any
// hit, and rays it will not walk (far origins), which the hierarchy takes.
#include <doctest/doctest.h>

#include <cmath>
#include <array>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "durer/accel/SphereSet.h"

using namespace durer;

namespace {

template <typename Real>
struct Cloud {
  SphereSet<Real> spheres[2];  // [0]: with a hierarchy (and so a grid), [1]: brute force

  // n spheres of radii [rMin, rMax] uniform in [-half, half]^3, or all of them in one corner.
  Cloud(unsigned seed, int n, double half, double rMin, double rMax, bool clustered = false) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-half, half), size(rMin, rMax), corner(-half, -half * 0.9);
    for (int32_t i = 0; i < n; ++i) {
      const bool inCorner = clustered && i % 10 != 0;  // a tenth spread out, the rest packed in a corner
      const Vec3d c = inCorner ? Vec3d(corner(rng), corner(rng), corner(rng)) : Vec3d(u(rng), u(rng), u(rng));
      const Sphere<Real> s{toReal<Real>(c), static_cast<Real>(size(rng))};
      for (int k = 0; k < 2; ++k) spheres[k].add(s, 0, i);
    }
    spheres[0].buildBvh(1);
  }
};

template <typename Real>
bool sameBits(Real a, Real b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

// Where ray k of p meets sphere s alone (the robust test's t; infinity where it misses).
template <typename Real>
Real tAlone(const RayPacket<Real>& p, int k, const Sphere<Real>& s) {
  RayPacket<Real> alone = p;
  alone.resetHits();
  const SphereRayTerms<Real> terms = sphereRayTerms<SphereMethod::Robust>(p.dx[k], p.dy[k], p.dz[k]);
  SphereSet<Real>::template intersectSphere<SphereMethod::Robust>(alone, terms, k, s, 0);
  return alone.tHit[k];
}

// Searches `rays` (incoherent) with the grid set and by brute force: the same nearest t bit for bit,
// the same sphere (or one tied at that t), and any-hit searches blocked exactly where a nearest hit exists.
template <typename Real>
void checkRays(const Cloud<Real>& cloud, const RayPacket<Real>& rays) {
  RayPacket<Real> fast = rays, slow = rays, shadow = rays;
  cloud.spheres[0].template intersect<SphereMethod::Robust, false>(fast, 0, nullptr);
  cloud.spheres[1].template intersect<SphereMethod::Robust, false>(slow, 0, nullptr);
  cloud.spheres[0].template intersect<SphereMethod::Robust, true>(shadow, 0, nullptr);
  for (int k = 0; k < rays.count; ++k) {
    CAPTURE(k);
    const double origin[3] = {double(rays.ox[k]), double(rays.oy[k]), double(rays.oz[k])};
    const double direction[3] = {double(rays.dx[k]), double(rays.dy[k]), double(rays.dz[k])};
    CAPTURE(origin[0]);
    CAPTURE(origin[1]);
    CAPTURE(origin[2]);
    CAPTURE(direction[0]);
    CAPTURE(direction[1]);
    CAPTURE(direction[2]);
    CHECK(sameBits(fast.tHit[k], slow.tHit[k]));
    REQUIRE((fast.prim[k] == kNoPrimitive) == (slow.prim[k] == kNoPrimitive));
    if (fast.prim[k] != kNoPrimitive && cloud.spheres[0].objectIds()[size_t(fast.prim[k])] !=
                                            cloud.spheres[1].objectIds()[size_t(slow.prim[k])]) {
      // Another sphere at exactly the same t (far rays' t are coarse): it must give that t alone.
      CHECK(sameBits(tAlone(rays, k, cloud.spheres[0].primitive(size_t(fast.prim[k]))), slow.tHit[k]));
    }
    CHECK((shadow.prim[k] == kNoPrimitive) == (slow.prim[k] == kNoPrimitive));
  }
}

template <typename Real>
RayPacket<Real> emptyPacket(Real tMin) {
  RayPacket<Real> p;
  p.count = kPacketSize;
  p.tMin = tMin;
  p.tMax = std::numeric_limits<Real>::infinity();
  return p;
}

template <typename Real>
void setRay(RayPacket<Real>& p, int k, const Vec3d& o, const Vec3d& d) {
  p.ox[k] = Real(o.x), p.oy[k] = Real(o.y), p.oz[k] = Real(o.z);
  p.dx[k] = Real(d.x), p.dy[k] = Real(d.y), p.dz[k] = Real(d.z);
}

// The nearest hits in `set` of rays (o, d) i < count, given by rayOf(i, o, d), searched kPacketSize at a
// time from t = 0: check(i, packet, k) for each, ray i being the packet's ray k.
template <typename Real, typename RayOf, typename Check>
void nearestInPackets(const SphereSet<Real>& set, size_t count, const RayOf& rayOf, const Check& check) {
  for (size_t first = 0; first < count; first += kPacketSize) {
    RayPacket<Real> p = emptyPacket(Real(0));
    p.count = int(std::min<size_t>(kPacketSize, count - first));
    for (int k = 0; k < p.count; ++k) {
      Vec3d o, d;
      rayOf(first + size_t(k), o, d);
      setRay(p, k, o, d);
    }
    p.resetHits();
    set.template intersect<SphereMethod::Robust, false>(p, 0, nullptr);
    for (int k = 0; k < p.count; ++k) check(first + size_t(k), p, k);
  }
}

// Whether the grid walks ray k (it declines rays it cannot follow exactly).
template <typename Real>
bool walks(const SphereGrid<Real>& grid, const RayPacket<Real>& p, int k) {
  const double o[3] = {double(p.ox[k]), double(p.oy[k]), double(p.oz[k])};
  const double d[3] = {double(p.dx[k]), double(p.dy[k]), double(p.dz[k])};
  return grid.walk(o, d, double(p.tMin), double(p.tMax), [](uint32_t, uint32_t) {}, [](double) { return false; });
}

}  // namespace

TEST_CASE_TEMPLATE("a grid is made for an even cloud, not for a cluster, a handful or a set without hierarchy", Real,
                   float, double) {
  const Cloud<Real> even(1, 4000, 10, 0.02, 0.1);
  CHECK(even.spheres[0].grid() != nullptr);
  CHECK(even.spheres[1].grid() == nullptr);  // no hierarchy to take the rays the grid declines
  const Cloud<Real> clustered(2, 4000, 10, 0.02, 0.1, true);
  CHECK(clustered.spheres[0].grid() == nullptr);
  const Cloud<Real> few(3, int(SphereGrid<Real>::kMinSpheres) - 1, 10, 0.02, 0.1);
  CHECK(few.spheres[0].grid() == nullptr);
  const Cloud<Real> large(4, 400, 10, 2, 4);  // spheres spanning many cells each
  CHECK(large.spheres[0].grid() == nullptr);
}

// The refusals are relative to the cells: a cloud packed unevenly but not into a cluster (60 % of it
// in an eighth of its box: in the cell of an average registration 16.5 spheres, against an even
// cloud's 5.5 there) keeps its grid; spheres spanning more cells than the limit (radius 0.3: 3.5 on
// average; 0.2: 2.5) do not get one.
TEST_CASE_TEMPLATE("a grid's refusals: uneven clouds keep one, spheres large for the cells do not", Real, float, double) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> whole(-10, 10), eighth(-10, 0);
  const auto cloud = [&](double share, double radius) {
    SphereSet<Real> set;
    for (int32_t i = 0; i < 20000; ++i) {
      const bool packed = i < int32_t(share * 20000);
      const Vec3d c = packed ? Vec3d(eighth(rng), eighth(rng), eighth(rng)) : Vec3d(whole(rng), whole(rng), whole(rng));
      set.add(Sphere<Real>{toReal<Real>(c), static_cast<Real>(radius)}, 0, i);
    }
    set.buildBvh(1);
    return set;
  };
  CHECK(cloud(0.6, 0.05).grid() != nullptr);
  CHECK(cloud(0, 0.2).grid() != nullptr);
  CHECK(cloud(0, 0.3).grid() == nullptr);
}

TEST_CASE_TEMPLATE("rays through the grid find what brute force finds, bit for bit", Real, float, double) {
  const Cloud<Real> cloud(5, 6000, 10, 0.02, 0.3);
  REQUIRE(cloud.spheres[0].grid() != nullptr);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> inside(-11, 11), outside(-40, 40), unit(-1, 1);
  for (Real tMin : {-std::numeric_limits<Real>::infinity(), Real(0), std::numeric_limits<Real>::denorm_min()}) {
    for (int trial = 0; trial < 40; ++trial) {
      RayPacket<Real> p = emptyPacket(tMin);
      for (int k = 0; k < p.count; ++k) {
        const Vec3d o = k % 2 ? Vec3d(inside(rng), inside(rng), inside(rng)) : Vec3d(outside(rng), outside(rng), outside(rng));
        setRay(p, k, o, Vec3d(unit(rng), unit(rng), unit(rng)));
      }
      p.resetHits();
      checkRays(cloud, p);
    }
  }
}

TEST_CASE_TEMPLATE("rays along cell and octant faces, diagonals and off spheres' surfaces find brute force's hits",
                   Real, float, double) {
  const Cloud<Real> cloud(6, 6000, 10, 0.02, 0.3);
  const SphereGrid<Real>* grid = cloud.spheres[0].grid();
  REQUIRE(grid != nullptr);
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::uniform_int_distribution<int> line(-12, 12);
  std::uniform_int_distribution<size_t> pick(0, cloud.spheres[1].size() - 1);
  // Directions with zero components (the walk never steps along those axes) and with equal ones
  // (steps along two or three axes due at once, where rounding picks the order).
  for (int trial = 0; trial < 60; ++trial) {
    RayPacket<Real> p = emptyPacket(std::numeric_limits<Real>::denorm_min());
    for (int k = 0; k < p.count; ++k) {
      const int axis = k % 3;
      Vec3d o(line(rng), line(rng), line(rng)), d(0);
      switch (k % 5) {
        case 0:  // axis-parallel along whole-number lines
          o[axis] = -15, d[axis] = 1;
          break;
        case 1:  // diagonals through lattice points
          o = Vec3d(-15, line(rng), line(rng)), d = Vec3d(1, k % 8 < 4 ? 1 : -1, k % 16 < 8 ? 1 : -1);
          break;
        case 2: {  // off a sphere's surface, away from it, as a reflection leaves
          const Sphere<Real>& s = cloud.spheres[1].primitive(pick(rng));
          const Vec3d n = glm::normalize(Vec3d(unit(rng), unit(rng), unit(rng)));
          o = Vec3d(s.center) + double(s.radius) * n;
          d = n + Vec3d(unit(rng), unit(rng), unit(rng)) * 0.9;
          break;
        }
        case 3:  // in a plane of a whole-number coordinate, any direction within it
          o = Vec3d(unit(rng) * 12, unit(rng) * 12, line(rng)), d = Vec3d(unit(rng), unit(rng), 0);
          break;
        default: {  // in the plane between a cell's halves (its octants' face), or along two of them
          o = Vec3d(unit(rng) * 12, unit(rng) * 12, unit(rng) * 12), d = Vec3d(unit(rng), unit(rng), unit(rng));
          for (int a = 0; a <= (k / 4) % 2; ++a) {
            const int along = (axis + a) % 3;
            o[along] = grid->middle(along, grid->cellAlong(along, o[along])), d[along] = 0;
          }
        }
      }
      setRay(p, k, o, d);
      if (k % 5 != 2) CHECK(walks(*grid, p, k));
    }
    p.resetHits();
    checkRays(cloud, p);
  }
}

TEST_CASE_TEMPLATE("rays marked as leaving their sphere find what they find unmarked, bit for bit", Real, float, double) {
  // Off random spheres' surfaces, outward (a reflection or shadow ray: the search may skip the sphere
  // it leaves) and inward (a refraction: it must meet that sphere's far side), some off spheres that
  // have a copy (the copy is skipped by value where the ray leaves it), some marked with a sphere
  // they do not start on, or with none; through the grid of an even cloud and the hierarchy of a
  // clustered one (no grid).
  for (const bool clustered : {false, true}) {
    CAPTURE(clustered);
    SphereSet<Real> set;
    std::mt19937 rng(15);
    std::uniform_real_distribution<double> unit(-1, 1), size(0.02, clustered ? 0.05 : 0.3), corner(-10, -7);
    std::vector<Sphere<Real>> copied;
    for (int32_t i = 0; i < 6000; ++i) {
      const Vec3d c = clustered && i % 10 != 0 ? Vec3d(corner(rng), corner(rng), corner(rng)) : Vec3d(unit(rng), unit(rng), unit(rng)) * 10.0;
      const Sphere<Real> s{toReal<Real>(c), static_cast<Real>(size(rng))};
      set.add(s, 0, i);
      if (i % 60 == 0) copied.push_back(s);
    }
    for (size_t c = 0; c < copied.size(); ++c) set.add(copied[c], 0, int32_t(6000 + c));
    set.buildBvh(2);
    REQUIRE((set.grid() == nullptr) == clustered);
    std::vector<size_t> twins;  // the spheres with a copy (and the copies), after the hierarchy's reordering
    for (size_t i = 0; i < set.size(); ++i) {
      for (const Sphere<Real>& c : copied) {
        if (std::memcmp(&set.primitive(i), &c, sizeof c) == 0) twins.push_back(i);
      }
    }
    REQUIRE(twins.size() == 2 * copied.size());
    std::uniform_int_distribution<size_t> pick(0, set.size() - 1), pickTwin(0, twins.size() - 1);
    int inward = 0, ownHits = 0;
    for (int trial = 0; trial < 80; ++trial) {
      RayPacket<Real> marked = emptyPacket(std::numeric_limits<Real>::denorm_min());
      for (int k = 0; k < marked.count; ++k) {
        const size_t i = k % 4 == 1 ? twins[pickTwin(rng)] : pick(rng);
        const Sphere<Real>& s = set.primitive(i);
        const Vec3d n = glm::normalize(Vec3d(unit(rng), unit(rng), unit(rng)));
        const bool in = k % 3 == 0;
        const Vec3d o = Vec3d(s.center) + double(s.radius) * n * (in ? 0.999 : 1.001);
        const Vec3d d = in ? -n + Vec3d(unit(rng), unit(rng), unit(rng)) * 0.5 : n + Vec3d(unit(rng), unit(rng), unit(rng)) * 0.9;
        setRay(marked, k, o, d);
        marked.from[k] = k % 11 == 0 ? kNoPrimitive : k % 13 == 0 ? int32_t(pick(rng)) : int32_t(i);
        inward += in;
      }
      marked.leaving = true;
      marked.resetHits();
      RayPacket<Real> plain = marked, markedShadow = marked, plainShadow = marked;
      plain.leaving = plainShadow.leaving = false;
      set.template intersect<SphereMethod::Robust, false>(marked, 0, nullptr);
      set.template intersect<SphereMethod::Robust, false>(plain, 0, nullptr);
      set.template intersect<SphereMethod::Robust, true>(markedShadow, 0, nullptr);
      set.template intersect<SphereMethod::Robust, true>(plainShadow, 0, nullptr);
      for (int k = 0; k < marked.count; ++k) {
        CAPTURE(k);
        CHECK(sameBits(marked.tHit[k], plain.tHit[k]));
        CHECK(marked.prim[k] == plain.prim[k]);
        CHECK((markedShadow.prim[k] == kNoPrimitive) == (plainShadow.prim[k] == kNoPrimitive));
        ownHits += k % 3 == 0 && marked.prim[k] == marked.from[k];
      }
    }
    CHECK(inward > 1500);
    CHECK(ownHits > 1000);  // the inward rays meet the sphere they start in (those marked with it)
  }
}

TEST_CASE_TEMPLATE("rays the grid declines (far origins) are searched through the hierarchy", Real, float, double) {
  const Cloud<Real> cloud(7, 3000, 10, 0.02, 0.3);
  const SphereGrid<Real>* grid = cloud.spheres[0].grid();
  REQUIRE(grid != nullptr);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> unit(-1, 1), target(-10, 10);
  const double far = std::is_same_v<Real, float> ? 1e7 : 1e17;
  RayPacket<Real> p = emptyPacket(Real(0));
  int declined = 0;
  for (int k = 0; k < p.count; ++k) {
    const Vec3d aim(target(rng), target(rng), target(rng));
    const Vec3d o = k % 2 ? Vec3d(far, unit(rng) * far, 0) : Vec3d(unit(rng) * 12, unit(rng) * 12, unit(rng) * 12);
    setRay(p, k, o, aim - o);
    declined += walks(*grid, p, k) ? 0 : 1;
  }
  CHECK(declined == kPacketSize / 2);
  p.resetHits();
  checkRays(cloud, p);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double o[3] = {0, 0, 0}, d[3] = {nan, 1, 0};
  CHECK_FALSE(grid->walk(o, d, 0.0, 1e30, [](uint32_t, uint32_t) {}, [](double) { return false; }));
}

// Two spheres through one point of the circle where they meet, every coordinate exact in binary, are
// met at exactly the same t by a ray through that point: a tie that the order of the tests would
// decide. The walk in lanes skips records the one-ray walk tests, so the grid gives a tie to the
// sphere of the lower index, in every kernel set.
TEST_CASE_TEMPLATE("exact ties among the grid's spheres go to the sphere of the lower index", Real, float, double) {
  std::mt19937 rng(15);
  std::uniform_real_distribution<double> u(-10, 10);
  std::uniform_int_distribution<int> grain(-1200, 1200);  // a 128th of a unit
  constexpr double kStep = 1.0 / 128;
  SphereSet<Real> set;
  int32_t id = 0;
  for (; id < 4000; ++id) set.add(Sphere<Real>{toReal<Real>(Vec3d(u(rng), u(rng), u(rng))), Real(0.05)}, 0, id);
  struct Tie {
    int32_t first, second;  // object ids
    Vec3d o, d;
  };
  std::vector<Tie> ties;
  for (int i = 0; i < 320; ++i, id += 2) {
    const int a = i % 3, b = (a + 1 + (i / 3) % 2) % 3;
    const Vec3d c(grain(rng) * kStep, grain(rng) * kStep, grain(rng) * kStep);
    Vec3d apart(0), up(0);
    apart[a] = 6 * kStep, up[b] = 1;
    // The sphere of the lower id first or second along the axis: 3-4-5 triangles put the point on both.
    const bool lowerFirst = (i / 6) % 2 == 0;
    set.add(Sphere<Real>{toReal<Real>(lowerFirst ? c : c + apart), Real(5 * kStep)}, 0, id);
    set.add(Sphere<Real>{toReal<Real>(lowerFirst ? c + apart : c), Real(5 * kStep)}, 0, id + 1);
    const Vec3d meet = c + 0.5 * apart + 4 * kStep * up;
    // Toward the point, square on or slanting along the axis (entering both spheres there still).
    Vec3d d = -up;
    d[a] = (i % 4 == 0 ? 0.0 : i % 4 == 1 ? 0.5 : -0.5);
    ties.push_back({id, id + 1, meet - (i % 8 < 4 ? 2.0 : 0.5) * d, d});
  }
  set.buildBvh(1);
  REQUIRE(set.grid() != nullptr);
  std::vector<size_t> indexOf(static_cast<size_t>(id));
  for (size_t i = 0; i < set.size(); ++i) indexOf[size_t(set.objectIds()[i])] = i;
  int tied = 0;
  nearestInPackets(
      set, ties.size(), [&](size_t i, Vec3d& o, Vec3d& d) { o = ties[i].o, d = ties[i].d; },
      [&](size_t i, const RayPacket<Real>& p, int k) {
        const size_t one = indexOf[size_t(ties[i].first)], other = indexOf[size_t(ties[i].second)];
        const Real t[2] = {tAlone(p, k, set.primitive(one)), tAlone(p, k, set.primitive(other))};
        if (!(t[0] == t[1] && p.tHit[k] == t[0])) return;  // no tie, or another sphere in front
        ++tied;
        CAPTURE(k);
        CHECK(size_t(p.prim[k]) == std::min(one, other));
      });
  CHECK(tied > 200);
}

// Copies of a sphere (the same centre and radius, other ids) are met at the same t wherever a ray
// meets them, in every cell they share: the copy of the lowest index keeps the hit, however many cells
// the walk meets them in before the one their hit lies in (SphereSet::breakTie passes over a record
// equal to the kept one). Copies large for the cells, rays from all sides aimed at points of them.
TEST_CASE_TEMPLATE("copies of a sphere: the one of the lowest index keeps the hit in every cell", Real, float, double) {
  std::mt19937 rng(16);
  std::uniform_real_distribution<double> u(-10, 10), unit(-1, 1), radius(0.3, 1.2);
  SphereSet<Real> set;
  int32_t id = 0;
  for (; id < 4000; ++id) set.add(Sphere<Real>{toReal<Real>(Vec3d(u(rng), u(rng), u(rng))), Real(0.05)}, 0, id);
  std::vector<std::vector<int32_t>> copies;  // object ids of each sphere's copies
  std::vector<Sphere<Real>> shapes;
  for (int i = 0; i < 60; ++i) {
    const Sphere<Real> s{toReal<Real>(Vec3d(u(rng), u(rng), u(rng))), Real(radius(rng))};
    copies.emplace_back();
    for (int c = 0; c < 2 + i % 3; ++c, ++id) set.add(s, 0, id), copies.back().push_back(id);
    shapes.push_back(s);
  }
  set.buildBvh(1);
  REQUIRE(set.grid() != nullptr);
  std::vector<size_t> indexOf(static_cast<size_t>(id));
  for (size_t i = 0; i < set.size(); ++i) indexOf[size_t(set.objectIds()[i])] = i;
  struct Aim {
    size_t group;
    Vec3d o, d;
  };
  std::vector<Aim> aims;
  for (size_t g = 0; g < shapes.size(); ++g) {
    for (int j = 0; j < 24; ++j) {  // at a point within 0.9 of the radius of the centre, from 3 to 8 units away
      const Vec3d c(shapes[g].center);
      const Vec3d target = c + 0.9 * double(shapes[g].radius) * glm::normalize(Vec3d(unit(rng), unit(rng), unit(rng)));
      const Vec3d d = glm::normalize(Vec3d(unit(rng), unit(rng), unit(rng)));
      aims.push_back({g, target - (3 + 5 * (unit(rng) + 1) / 2) * d, d});
    }
  }
  int checked = 0;
  nearestInPackets(
      set, aims.size(), [&](size_t i, Vec3d& o, Vec3d& d) { o = aims[i].o, d = aims[i].d; },
      [&](size_t i, const RayPacket<Real>& p, int k) {
        size_t lowest = set.size();
        for (int32_t copy : copies[aims[i].group]) lowest = std::min(lowest, indexOf[size_t(copy)]);
        if (!(p.tHit[k] == tAlone(p, k, set.primitive(lowest)))) return;  // another sphere in front
        ++checked;
        CAPTURE(k);
        CHECK(size_t(p.prim[k]) == lowest);
      });
  CHECK(checked > 1000);
}

#if DURER_WALK_LANES
// The walk in lanes (the AVX-512 kernel set's) must visit each ray's records in the order walk()
// visits them, less those outside the ray's octants of their cell, stop where walk() stops and
// decline the rays walk() declines, in order: then every search finds the same hit in every kernel
// set (with exact ties decided by index, above). Rays of every kind above, each stopped at a random
// t (or never), in packets where rays end at different rounds and lanes change rays; an even cloud,
// and one with 43 % of it in an eighth of its box and 400 spheres in one cell (rays aimed there list
// more pairs in a round than are tested at once).
TEST_CASE_TEMPLATE("the walk in lanes visits each ray's records in walk()'s order", Real, float, double) {
  std::mt19937 rng(14);
  std::uniform_real_distribution<double> unit(-1, 1), inside(-11, 11), outside(-40, 40), stopAt(0, 30), eighth(-10, 0);
  // An even cloud in a cube of equal cells (spheres at its corners): rays with equal coordinates and
  // equal direction components cross cell edges and corners, where boundaries are due at the same t.
  SphereSet<Real> even;
  for (int32_t i = 0; i < 5000; ++i) {
    const Vec3d c = i < 8 ? 10.0 * Vec3d(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1) : 9.5 * Vec3d(unit(rng), unit(rng), unit(rng));
    even.add(Sphere<Real>{toReal<Real>(c), Real(0.125)}, 0, i);
  }
  even.buildBvh(1);
  SphereSet<Real> uneven;
  const Vec3d crowded(-5.5, -5.5, -5.5);
  for (int32_t i = 0; i < 20000; ++i) {
    const Vec3d c = i < 400 ? crowded + 0.01 * Vec3d(unit(rng), unit(rng), unit(rng))
                    : i < 9000 ? Vec3d(eighth(rng), eighth(rng), eighth(rng)) : 10.0 * Vec3d(unit(rng), unit(rng), unit(rng));
    uneven.add(Sphere<Real>{toReal<Real>(c), Real(0.05)}, 0, i);
  }
  uneven.buildBvh(1);
  int declined = 0, stopped = 0, crowdedRounds = 0;
  int64_t skipped = 0;  // records of a cell the ray's octants of it spare
  for (const SphereGrid<Real>* grid : {even.grid(), uneven.grid()}) {
    REQUIRE(grid != nullptr);
    for (int trial = 0; trial < 100; ++trial) {
      const int count = 1 + trial % kPacketSize;
      const size_t rays = static_cast<size_t>(count);
      std::vector<std::array<double, 3>> o(rays), d(rays);
      std::vector<double> stop(rays);
      for (int k = 0; k < count; ++k) {
        Vec3d ro(inside(rng), inside(rng), inside(rng)), rd(unit(rng), unit(rng), unit(rng));
        switch ((k + trial) % 8) {
          case 0: ro = Vec3d(outside(rng), outside(rng), outside(rng)); break;
          case 1: ro = Vec3d(std::round(ro.x), std::round(ro.y), std::round(ro.z)), rd = Vec3d(0), rd[k % 3] = k % 2 ? 1 : -1; break;
          case 2: rd = Vec3d(1, k % 4 < 2 ? 1 : -1, k % 8 < 4 ? 1 : -1); break;
          case 3: ro = Vec3d(1e17, unit(rng), unit(rng)); break;  // declined (too far for the cells)
          case 4: rd = Vec3d(unit(rng), unit(rng), 0); break;
          case 5: rd = crowded - ro; break;
          case 6: {  // boundaries due at once along two or three axes
            const double sign = k % 2 ? 1 : -1;
            ro = Vec3d(ro.x, ro.x, k % 4 < 2 ? ro.x : ro.z), rd = Vec3d(sign, sign, k % 4 < 2 ? sign : 0.3);
            break;
          }
          default: break;
        }
        o[size_t(k)] = {ro.x, ro.y, ro.z}, d[size_t(k)] = {rd.x, rd.y, rd.z};
        stop[size_t(k)] = k % 3 ? stopAt(rng) : std::numeric_limits<double>::infinity();
      }
      const auto ray = [&](int k, double (&ro)[3], double (&rd)[3]) {
        for (int a = 0; a < 3; ++a) ro[a] = o[size_t(k)][size_t(a)], rd[a] = d[size_t(k)][size_t(a)];
      };
      std::vector<std::vector<uint32_t>> alone(rays), inLanes(rays);
      std::vector<int> refusedAlone, refusedInLanes;
      for (int k = 0; k < count; ++k) {
        double ro[3], rd[3];
        ray(k, ro, rd);
        const bool walked = grid->walk(
            ro, rd, 0.0, std::numeric_limits<double>::infinity(),
            [&](uint32_t first, uint32_t n) {
              for (uint32_t i = first; i < first + n; ++i) alone[size_t(k)].push_back(i);
            },
            [&](double exitT) { return stop[size_t(k)] <= exitT; });
        if (!walked) refusedAlone.push_back(k);
      }
      int rayOfLane[SphereGrid<Real>::kLanes];
      grid->walkLanes(
          count,
          [&](int k, double (&ro)[3], double (&rd)[3], double& tMin, double& tHit) {
            ray(k, ro, rd);
            tMin = 0, tHit = std::numeric_limits<double>::infinity();
            return true;
          },
          [&](int k, int lane) { rayOfLane[lane] = k; },
          [&](const int32_t* lanes, const uint32_t* records, int n) {
            CHECK(n <= SphereGrid<Real>::kMostPairs);
            crowdedRounds += n > SphereGrid<Real>::kMostPairs - SphereGrid<Real>::kLanes;
            for (int i = 0; i < n; ++i) inLanes[size_t(rayOfLane[lanes[i]])].push_back(records[i]);
          },
          [&](int k, double exitT) { return stop[size_t(k)] <= exitT; }, [&](int k) { refusedInLanes.push_back(k); });
      CAPTURE(trial);
      CHECK(refusedInLanes == refusedAlone);
      for (int k = 0; k < count; ++k) {
        CAPTURE(k);
        // In walk()'s order, less the records outside the ray's octants of their cell.
        const std::vector<uint32_t>& all = alone[size_t(k)];
        size_t at = 0;
        for (const uint32_t record : inLanes[size_t(k)]) {
          while (at < all.size() && all[at] != record) ++at;
          REQUIRE(at < all.size());
          ++at;
        }
        skipped += int64_t(all.size() - inLanes[size_t(k)].size());
        stopped += std::isfinite(stop[size_t(k)]) && !alone[size_t(k)].empty();
      }
      declined += int(refusedAlone.size());
    }
  }
  CHECK(declined > 100);  // every kind, in earnest
  CHECK(stopped > 1000);
  CHECK(crowdedRounds > 10);
  CHECK(skipped > 10000);
}
#endif

// The grid made on several threads (a chunk of the spheres each, their registrations placed after
// the chunks' before them) is the grid made on one: every ray's walk visits the same cells' records,
// the same records in the same order, the same spheres. 200,000 spheres: three chunks of them.
TEST_CASE_TEMPLATE("a grid made on three threads is the one made on one, record for record", Real, float, double) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> unit(-1, 1), inside(-11, 11);
  std::vector<Sphere<Real>> spheres;
  for (int i = 0; i < 200000; ++i) {
    const Vec3d c = i % 1000 == 0 ? Vec3d(0.5, 0.5, 0.5) : 10.0 * Vec3d(unit(rng), unit(rng), unit(rng));  // copies too
    spheres.push_back(Sphere<Real>{toReal<Real>(c), Real(i % 7 == 0 ? 0.2 : 0.03)});  // some across cells
  }
  const auto one = SphereGrid<Real>::make(spheres, 1), three = SphereGrid<Real>::make(spheres, 3);
  REQUIRE(one != nullptr);
  REQUIRE(three != nullptr);
  int64_t records = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const double o[3] = {inside(rng), inside(rng), inside(rng)}, d[3] = {unit(rng), unit(rng), unit(rng)};
    std::vector<uint32_t> visits[2];
    for (int g = 0; g < 2; ++g) {
      const SphereGrid<Real>& grid = g == 0 ? *one : *three;
      REQUIRE(grid.walk(o, d, 0.0, std::numeric_limits<double>::infinity(), [&](uint32_t first, uint32_t n) {
        visits[g].push_back(first), visits[g].push_back(n);
      }, [](double) { return false; }));
    }
    REQUIRE(visits[0] == visits[1]);
    for (size_t v = 0; v < visits[0].size(); v += 2) {
      for (uint32_t r = visits[0][v]; r < visits[0][v] + visits[0][v + 1]; ++r, ++records) {
        CHECK(std::memcmp(&one->records()[r], &three->records()[r], sizeof(Sphere<Real>)) == 0);
        CHECK(one->sphereOf(r) == three->sphereOf(r));
        if (r > visits[0][v]) CHECK(three->sphereOf(r - 1) < three->sphereOf(r));  // the set's order in a cell
      }
    }
  }
  CHECK(records > 100000);
}
