// The hierarchy's three searches against brute force (doctest): camera packets walked together
// (Bvh::traversePacket), rays alone (Bvh::traverse) and shadow rays' any hit must find exactly what
// testing every primitive finds: the same nearest t, bit for bit, on the same object. Random
// scenes (seeded) of spheres, triangles and boxes, with packets tight enough to stay together and
// wide enough to split, perspective fans and incoherent rays.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <utility>
#include <vector>

#include "durer/accel/BoxSet.h"
#include "durer/accel/Group.h"
#include "durer/accel/SphereSet.h"
#include "durer/accel/TriangleSet.h"

using namespace durer;

namespace {

template <typename Real>
struct Scenes {
  SphereSet<Real> spheres[2];  // [0]: with a hierarchy, [1]: without (every primitive tested)
  TriangleSet<Real> triangles[2];
  BoxSet<Real> boxes[2];

  explicit Scenes(unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-10, 10), size(0.01, 0.6), unit(-1, 1);
    for (int32_t i = 0; i < 3000; ++i) {
      const Vec3d c(u(rng), u(rng), u(rng));
      const Sphere<Real> s{toReal<Real>(c), static_cast<Real>(size(rng))};
      const Vec3d e(size(rng), size(rng), size(rng));
      const Box<Real> b{toReal<Real>(c - e), toReal<Real>(c + e)};
      const Vec3d a = c + Vec3d(unit(rng), unit(rng), unit(rng)), p = c + Vec3d(unit(rng), unit(rng), unit(rng));
      const Vec3<Real> v0 = toReal<Real>(c), v1 = toReal<Real>(a), v2 = toReal<Real>(p);
      const Triangle<Real> t{v0, v1, v2, glm::normalize(glm::cross(v1 - v0, v2 - v0))};
      for (int k = 0; k < 2; ++k) spheres[k].add(s, 0, i), boxes[k].add(b, 0, i), triangles[k].add(t, 0, i);
    }
    spheres[0].buildBvh(2), triangles[0].buildBvh(2), boxes[0].buildBvh(2);
  }
};

enum class Rays { TightGrid, WideGrid, Fan, Random, Grazing };

// A packet of 64 rays of the given kind (camera kinds marked coherent, as Camera makes them).
template <typename Real>
RayPacket<Real> packetOf(Rays kind, std::mt19937& rng, Real tMin, const Sphere<Real>* aim = nullptr) {
  std::uniform_real_distribution<double> u(-12, 12), unit(-1, 1), spacing(0.0005, 0.02);
  RayPacket<Real> p;
  p.count = 64;
  p.tMin = tMin;
  p.tMax = std::numeric_limits<Real>::infinity();
  const Vec3d corner(u(rng), u(rng), 15);
  const Vec3d direction = glm::normalize(Vec3d(unit(rng) * 0.3, unit(rng) * 0.3, -1));
  const double step = kind == Rays::TightGrid ? spacing(rng) : kind == Rays::Grazing ? 1e-4 : 0.3;
  Vec3d start = corner;
  if (kind == Rays::Grazing) {  // a tight grid straddling a sphere's silhouette, straight down -z
    const double a = unit(rng) * 3.2, r = double(aim->radius);
    start = Vec3d(aim->center) + Vec3d(r * std::cos(a) - 3.5 * step, r * std::sin(a) - 3.5 * step, 15);
  }
  for (int k = 0; k < 64; ++k) {
    Vec3d o = start + Vec3d(step * (k % 8), step * (k / 8), 0), d = kind == Rays::Grazing ? Vec3d(0, 0, -1) : direction;
    if (kind == Rays::Fan) o = corner, d = glm::normalize(Vec3d(unit(rng) * 0.05 + direction.x, unit(rng) * 0.05 + direction.y, -1));
    if (kind == Rays::Random) o = Vec3d(u(rng), u(rng), u(rng)), d = Vec3d(unit(rng), unit(rng), unit(rng));
    p.ox[k] = Real(o.x), p.oy[k] = Real(o.y), p.oz[k] = Real(o.z);
    p.dx[k] = Real(d.x), p.dy[k] = Real(d.y), p.dz[k] = Real(d.z);
  }
  p.coherent = kind != Rays::Random;
  p.commonOrigin = kind == Rays::Fan;
  p.resetHits();
  return p;
}

template <typename Real>
bool sameBits(Real a, Real b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

// The nearest hits with and without the hierarchy agree bit for bit, on the same objects; any-hit
// searches agree on whether each ray is blocked.
template <typename Set, typename Real, typename Search>
void checkAgainstBruteForce(const Set* sets, const RayPacket<Real>& rays, Search&& search) {
  RayPacket<Real> fast = rays, slow = rays, shadow = rays;
  search(sets[0], fast, false);
  search(sets[1], slow, false);
  search(sets[0], shadow, true);
  for (int k = 0; k < rays.count; ++k) {
    CAPTURE(k);
    CHECK(sameBits(fast.tHit[k], slow.tHit[k]));
    REQUIRE((fast.prim[k] == kNoPrimitive) == (slow.prim[k] == kNoPrimitive));
    if (fast.prim[k] != kNoPrimitive) {
      CHECK(sets[0].objectIds()[size_t(fast.prim[k])] == sets[1].objectIds()[size_t(slow.prim[k])]);
    }
    CHECK((shadow.prim[k] == kNoPrimitive) == (slow.prim[k] == kNoPrimitive));
  }
}

}  // namespace

TEST_CASE_TEMPLATE("hierarchy searches find what brute force finds, bit for bit", Real, float, double) {
  const Scenes<Real> scenes(2024);
  std::mt19937 rng(7);
  for (Rays kind : {Rays::TightGrid, Rays::WideGrid, Rays::Fan, Rays::Random, Rays::Grazing}) {
    for (Real tMin : {-std::numeric_limits<Real>::infinity(), Real(0), std::numeric_limits<Real>::denorm_min()}) {
      for (int trial = 0; trial < 20; ++trial) {
        CAPTURE(int(kind));
        CAPTURE(tMin);
        const Sphere<Real>& aim = scenes.spheres[1].primitive(size_t(rng() % scenes.spheres[1].size()));
        const RayPacket<Real> rays = packetOf<Real>(kind, rng, tMin, &aim);
        checkAgainstBruteForce(scenes.spheres, rays, [](const SphereSet<Real>& s, RayPacket<Real>& p, bool anyHit) {
          anyHit ? s.template intersect<SphereMethod::Robust, true>(p, 0, nullptr)
                 : s.template intersect<SphereMethod::Robust, false>(p, 0, nullptr);
        });
        checkAgainstBruteForce(scenes.triangles, rays, [](const TriangleSet<Real>& s, RayPacket<Real>& p, bool anyHit) {
          anyHit ? s.template intersect<true>(p, 0, nullptr) : s.template intersect<false>(p, 0, nullptr);
        });
        checkAgainstBruteForce(scenes.boxes, rays, [](const BoxSet<Real>& s, RayPacket<Real>& p, bool anyHit) {
          anyHit ? s.template intersect<true>(p, 0, nullptr) : s.template intersect<false>(p, 0, nullptr);
        });
      }
    }
  }
}

TEST_CASE_TEMPLATE("leaves the build cannot split (spheres sharing a centre) are searched whole", Real, float, double) {
  // Concentric spheres have one centroid, so no plane splits them: the build halves their range
  // down to leaves of up to eight, past the four a leaf's vectorised prefilter takes at once.
  SphereSet<Real> spheres[2];
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-10, 10), size(0.01, 0.3);
  for (int32_t i = 0; i < 2000; ++i) {
    const Sphere<Real> s = i < 77 ? Sphere<Real>{Vec3<Real>(1, 2, 3), static_cast<Real>(0.5 + i * 0.02)}
                                  : Sphere<Real>{toReal<Real>(Vec3d(u(rng), u(rng), u(rng))), static_cast<Real>(size(rng))};
    for (SphereSet<Real>& set : spheres) set.add(s, 0, i);
  }
  spheres[0].buildBvh(1);
  for (int trial = 0; trial < 40; ++trial) {
    RayPacket<Real> rays = packetOf<Real>(Rays::Random, rng, Real(0));
    for (int k = 0; k < rays.count; k += 2) {  // half aimed through the shared centre's shells
      rays.dx[k] = Real(1 + 0.1 * (k % 7)) - rays.ox[k], rays.dy[k] = Real(2) - rays.oy[k], rays.dz[k] = Real(3) - rays.oz[k];
    }
    checkAgainstBruteForce(spheres, rays, [](const SphereSet<Real>& s, RayPacket<Real>& p, bool anyHit) {
      anyHit ? s.template intersect<SphereMethod::Robust, true>(p, 0, nullptr)
             : s.template intersect<SphereMethod::Robust, false>(p, 0, nullptr);
    });
  }
}

TEST_CASE_TEMPLATE("rays walking interleaved visit the leaves each visits alone, in the same order", Real, float, double) {
  // Bvh::traverseInterleaved against Bvh::traverse, ray by ray: the same leaves in the same order,
  // with each leaf lowering the ray's tHit (so later culling depends on it), some rays stopping at a
  // leaf (a shadow ray's any hit), fewer rays than lanes and many more, and rays skipped.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-10, 10), size(0.01, 0.6);
  std::vector<Vec3<Real>> lo, hi;
  for (int i = 0; i < 5000; ++i) {
    const Vec3d c(u(rng), u(rng), u(rng)), e(size(rng), size(rng), size(rng));
    lo.push_back(toReal<Real>(c - e)), hi.push_back(toReal<Real>(c + e));
  }
  Bvh<Real> bvh;
  bvh.build(lo.size(), [&](size_t i, Vec3<Real>& l, Vec3<Real>& h) { l = lo[i], h = hi[i], roundOutward(l, h); }, 2);
  using Visits = std::vector<std::pair<int32_t, int32_t>>;
  // Leaf visit j of ray k: lowers tHit (to t = 30 − 2j, as if a hit were found) and stops the walk at
  // visit k % 7 for rays with k % 3 == 0.
  const auto visit = [](RayPacket<Real>& p, Visits& visits, int k, int32_t first, int32_t count) {
    visits.emplace_back(first, count);
    const Real t = Real(30) - Real(2 * visits.size());
    p.tHit[k] = std::min(p.tHit[k], t);
    return k % 3 == 0 && int(visits.size()) == k % 7 + 1;
  };
  for (int count : {1, 3, 8, 9, 64}) {
    for (int trial = 0; trial < 10; ++trial) {
      RayPacket<Real> p = packetOf<Real>(Rays::Random, rng, Real(0));
      p.count = count;
      RayPacket<Real> alone = p, together = p;
      std::vector<Visits> expected(static_cast<size_t>(count)), visited(static_cast<size_t>(count));
      std::vector<int> rays;
      for (int k = 0; k < count; ++k) {
        if (k % 5 == 4) continue;  // skipped (a shadow ray blocked by another set)
        rays.push_back(k);
        const BvhRay<Real> ray(p.ox[k], p.oy[k], p.oz[k], p.dx[k], p.dy[k], p.dz[k], p.tMin);
        bvh.traverse(ray, alone.tHit[k], [&](int32_t first, int32_t n) { return visit(alone, expected[size_t(k)], k, first, n); });
      }
      int32_t touched = 0;
      bvh.traverseInterleaved(
          together, rays.data(), int(rays.size()),
          [&](int32_t first, int32_t n, int k) { return visit(together, visited[size_t(k)], k, first, n); },
          [&](int32_t, int32_t) { ++touched; });
      size_t leaves = 0;
      for (int k = 0; k < count; ++k) {
        CAPTURE(k);
        CHECK(visited[size_t(k)] == expected[size_t(k)]);
        CHECK(sameBits(together.tHit[k], alone.tHit[k]));
        leaves += expected[size_t(k)].size();
      }
      CHECK(size_t(touched) == leaves);  // every leaf was prefetched before it was tested
    }
  }
}

TEST_CASE_TEMPLATE("a hierarchy whose top ranges were split on all threads at once finds what brute force finds", Real,
                   float, double) {
  // Ranges above the builder's grain are binned and partitioned by every thread, each a chunk of at
  // least 2^16 refs; 3 threads so that the refs on the wrong side of the middle lie in several runs.
  SphereSet<Real> spheres[2];
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-10, 10), size(0.01, 0.3);
  for (int32_t i = 0; i < 200000; ++i) {
    const Sphere<Real> s{toReal<Real>(Vec3d(u(rng), u(rng), u(rng))), static_cast<Real>(size(rng))};
    for (SphereSet<Real>& set : spheres) set.add(s, 0, i);
  }
  spheres[0].buildBvh(3);
  for (Rays kind : {Rays::TightGrid, Rays::Fan, Rays::Random}) {
    for (int trial = 0; trial < 2; ++trial) {
      CAPTURE(int(kind));
      const RayPacket<Real> rays = packetOf<Real>(kind, rng, Real(0));
      checkAgainstBruteForce(spheres, rays, [](const SphereSet<Real>& s, RayPacket<Real>& p, bool anyHit) {
        anyHit ? s.template intersect<SphereMethod::Robust, true>(p, 0, nullptr)
               : s.template intersect<SphereMethod::Robust, false>(p, 0, nullptr);
      });
    }
  }
}

TEST_CASE_TEMPLATE("the top-level hierarchy over instances finds the nearest instance's hit, bit for bit", Real, float,
                   double) {
  // 60 transformed clusters of spheres in one group (hierarchy over their world boxes), and each
  // alone in a group of its own (no top-level hierarchy): the nearest of the lone hits is the
  // group's hit.
  constexpr int kInstances = 60;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-10, 10), unit(-1, 1), radius(0.05, 0.4);
  Group<double> all;
  std::vector<Group<double>> alone(kInstances);
  for (int i = 0; i < kInstances; ++i) {
    const double angle = unit(rng) * 3, c = std::cos(angle), s = std::sin(angle), scale = 0.5 + radius(rng);
    Affined worldFromObject{{Vec3d(c * scale, -s * scale, 0), Vec3d(s * scale, c * scale, 0), Vec3d(0, 0, scale)},
                            Vec3d(u(rng), u(rng), u(rng))};
    const Affined objectFromWorld = inverse(worldFromObject);
    Group<double>& a = all.transformed(worldFromObject, objectFromWorld);
    Group<double>& b = alone[size_t(i)].transformed(worldFromObject, objectFromWorld);
    for (int32_t j = 0; j < 20; ++j) {
      const Sphere<double> sphere{Vec3d(unit(rng), unit(rng), unit(rng)) * 2.0, radius(rng)};
      a.spheres().add(sphere, 0, i * 20 + j);
      b.spheres().add(sphere, 0, i * 20 + j);
    }
  }
  Group<Real> world(all);
  world.prepare(2);
  std::vector<Group<Real>> lone;
  lone.reserve(alone.size());  // a copied group is unprepared: no reallocation
  for (const Group<double>& g : alone) lone.emplace_back(g), lone.back().prepare(1);
  for (Rays kind : {Rays::TightGrid, Rays::WideGrid, Rays::Fan, Rays::Random}) {
    for (int trial = 0; trial < 10; ++trial) {
      CAPTURE(int(kind));
      RayPacket<Real> rays = packetOf<Real>(kind, rng, Real(0));
      RayPacket<Real> nearest = rays;
      std::vector<int32_t> object(64, -1);
      for (Group<Real>& g : lone) {
        RayPacket<Real> p = rays;
        g.template intersect<SphereMethod::Robust>(p, nullptr);
        for (int k = 0; k < 64; ++k) {
          if (p.prim[k] != kNoPrimitive && p.tHit[k] < nearest.tHit[k]) nearest.tHit[k] = p.tHit[k], object[size_t(k)] = g.hit(p, k).objectId;
        }
      }
      world.template intersect<SphereMethod::Robust>(rays, nullptr);
      for (int k = 0; k < 64; ++k) {
        CAPTURE(k);
        CHECK(sameBits(rays.tHit[k], nearest.tHit[k]));
        CHECK((rays.prim[k] == kNoPrimitive ? -1 : world.hit(rays, k).objectId) == object[size_t(k)]);
      }
    }
  }
}

TEST_CASE_TEMPLATE("a packet that met one sphere or plane gets ray by ray's hit records, bit for bit", Real, float,
                   double) {
  // Group::makeUniformHits makes a packet's records in a loop over its one primitive: each must
  // equal the record Group::hit makes for the ray alone, field by field.
  Group<double> scene;
  scene.spheres().add(Sphere<double>{Vec3d(0.3, -0.2, 0.1), 3.0}, 2, 7);
  scene.planes().add(Plane<double>{glm::normalize(Vec3d(0.1, 0.2, 1)), Vec3d(0, 0, -5), false, Vec3d(0), Vec3d(0)}, 3, 8);
  Group<Real> group(scene);
  group.prepare(1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(-1, 1), spacing(1e-6, 0.05);
  const auto same = [](const auto& a, const auto& b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  for (int trial = 0; trial < 200; ++trial) {
    const bool onPlane = trial % 2 == 1;  // the plane's rays pass beside the sphere
    const double step = spacing(rng);
    const Vec3d start(unit(rng) + (onPlane ? 9 : -0.5), unit(rng) - 0.5, 15);
    RayPacket<Real> p;
    p.count = 1 + trial % 64;
    p.tMin = Real(0), p.tMax = std::numeric_limits<Real>::infinity();
    for (int k = 0; k < p.count; ++k) {
      const Vec3d d(unit(rng) * 0.01, unit(rng) * 0.01, -1);
      p.ox[k] = Real(start.x + step * (k % 8)), p.oy[k] = Real(start.y + step * (k / 8)), p.oz[k] = Real(start.z);
      p.dx[k] = Real(d.x), p.dy[k] = Real(d.y), p.dz[k] = Real(d.z);
    }
    p.coherent = true;
    p.resetHits();
    group.template intersect<SphereMethod::Robust>(p, nullptr);
    const int32_t expected = onPlane ? 1 : 0;  // the packed primitive: spheres first
    REQUIRE(std::all_of(p.prim, p.prim + p.count, [&](int32_t prim) { return prim == expected; }));
    HitRecords<Real, kPacketSize> records;
    REQUIRE(group.makeUniformHits(p, [&](int k, const auto& f) { records.make(k, f); }));
    for (int k = 0; k < p.count; ++k) {
      CAPTURE(trial);
      CAPTURE(k);
      const Hit<Real> alone = group.hit(p, k), &made = records[k];
      CHECK(same(made.t, alone.t));
      CHECK(same(made.normal, alone.normal));
      CHECK(same(made.geometricNormal, alone.geometricNormal));
      CHECK(same(made.point, alone.point));
      CHECK(same(made.pointError, alone.pointError));
      CHECK(made.objectId == alone.objectId);
      CHECK(made.materialId == alone.materialId);
      CHECK(made.colored == alone.colored);
    }
    // One ray sent elsewhere (missing both): the packet is no longer uniform, and nothing is made.
    if (p.count > 1) {
      p.prim[p.count - 1] = kNoPrimitive;
      CHECK_FALSE(group.makeUniformHits(p, [&](int, const auto&) { FAIL("a record was made"); }));
    }
    std::fill(p.prim, p.prim + p.count, kNoPrimitive);  // every ray a miss: no primitive's records
    CHECK_FALSE(group.makeUniformHits(p, [&](int, const auto&) { FAIL("a record was made"); }));
  }
}
