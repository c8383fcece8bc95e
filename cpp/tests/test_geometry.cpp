// Unit tests of the core's geometry kernels and float helpers, against closed forms (doctest).
// Built by -DDURER_BUILD_TESTS=ON as durer_cpp_tests; run by ctest (and by tests/core/test_cpp.py).
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "durer/accel/BoxSet.h"
#include "durer/accel/PlaneSet.h"
#include "durer/accel/SphereSet.h"
#include "durer/accel/TriangleSet.h"
#include "durer/geometry/Hit.h"
#include "durer/geometry/Slab.h"
#include "durer/geometry/SphericalRectangle.h"
#include "durer/math/Affine.h"
#include "durer/math/Float.h"

using namespace durer;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A packet of one ray, its hits reset, counting t in [tMin, tMax).
template <typename Real>
RayPacket<Real> oneRay(Vec3<Real> o, Vec3<Real> d, Real tMin = 0, Real tMax = std::numeric_limits<Real>::infinity()) {
  RayPacket<Real> p;
  p.count = 1;
  p.tMin = tMin;
  p.tMax = tMax;
  p.ox[0] = o.x, p.oy[0] = o.y, p.oz[0] = o.z;
  p.dx[0] = d.x, p.dy[0] = d.y, p.dz[0] = d.z;
  p.resetHits();
  return p;
}

template <typename Real>
Triangle<Real> triangle(Vec3<Real> a, Vec3<Real> b, Vec3<Real> c) {
  return {a, b, c, glm::normalize(glm::cross(b - a, c - a))};
}

}  // namespace

TEST_CASE("errorGamma is n·u / (1 - n·u) and bounds n roundings") {
  const double u = std::ldexp(1.0, -53);
  CHECK(errorGamma<double>(1) == u / (1 - u));
  CHECK(errorGamma<double>(3) == 3 * u / (1 - 3 * u));
  CHECK(errorGamma<float>(2) == 2 * std::ldexp(1.0f, -24) / (1 - 2 * std::ldexp(1.0f, -24)));
  // Three chained roundings of 1/3 + 1/3 + 1/3 stay within γ₃ of the exact 1.
  const double third = 1.0 / 3;
  CHECK(std::fabs((third + third + third) - 1.0) <= errorGamma<double>(3));
}

TEST_CASE("outward conversion brackets the value and is exact where it can be") {
  const float down = toRealDown<float>(0.1), up = toRealUp<float>(0.1);
  CHECK(double(down) < 0.1);
  CHECK(double(up) > 0.1);
  CHECK(std::nextafter(down, 1.0f) == up);
  CHECK(toRealDown<float>(0.5) == 0.5f);
  CHECK(toRealUp<float>(0.5) == 0.5f);
  CHECK(toRealUp<float>(-0.1) == -down);
  Vec3<float> lo(1, -2, 0), hi(3, 4, 0);
  roundOutward(lo, hi);
  CHECK(lo.x == std::nextafter(1.0f, -2.0f));
  CHECK(hi.y == std::nextafter(4.0f, 5.0f));
  CHECK(lo.z < 0);
  CHECK(hi.z > 0);
}

TEST_CASE("outward conversion steps as std::nextafter would, at the extremes too") {
  constexpr double inf = std::numeric_limits<double>::infinity();
  constexpr float finf = std::numeric_limits<float>::infinity();
  const double fmax = std::numeric_limits<float>::max();
  for (const double x : {0.1, -0.1, 1e39, -1e39, std::numeric_limits<double>::max(), -std::numeric_limits<double>::max(),
                         fmax, std::nextafter(fmax, inf), -std::nextafter(fmax, inf), 1e-50, -1e-50, 1e-45, -1e-45,
                         0.0, -0.0, inf, -inf, 3.0, -7.25}) {
    CAPTURE(x);
    const float r = static_cast<float>(x);
    const float down = double(r) > x ? std::nextafter(r, -finf) : r, up = double(r) < x ? std::nextafter(r, finf) : r;
    CHECK(toRealDown<float>(x) == down);
    CHECK(std::signbit(toRealDown<float>(x)) == std::signbit(down));
    CHECK(toRealUp<float>(x) == up);
    CHECK(std::signbit(toRealUp<float>(x)) == std::signbit(up));
    CHECK(double(toRealDown<float>(x)) <= x);
    CHECK(double(toRealUp<float>(x)) >= x);
  }
  CHECK(std::isnan(toRealDown<float>(std::nan(""))));
  CHECK(std::isnan(toRealUp<float>(std::nan(""))));
}

TEST_CASE("widening keeps the range's ends on their sides, inf stays inf") {
  const double f = 1e-10;
  for (double t : {-3.0, -1e-300, 0.5, 7.0}) {
    CHECK(widenDown(t, f) <= t);
    CHECK(widenUp(t, f) >= t);
  }
  CHECK(widenDown(2.0, f) == 2.0 * (1 - f));
  CHECK(widenUp(-2.0, f) == -2.0 * (1 - f));
  CHECK(widenUp(kInf, f) == kInf);
  CHECK(widenDown(-kInf, f) == -kInf);
  CHECK(widenDown(0.0, f) == 0.0);
}

TEST_CASE_TEMPLATE("nextUp and nextDown step exactly as std::nextafter toward +inf and -inf", Real, float, double) {
  constexpr Real inf = std::numeric_limits<Real>::infinity();
  const Real values[] = {Real(0), -Real(0), Real(1), Real(-1), Real(3.5e-3), Real(-7e12),
                         std::numeric_limits<Real>::denorm_min(), -std::numeric_limits<Real>::denorm_min(),
                         std::numeric_limits<Real>::min(), std::numeric_limits<Real>::max(),
                         -std::numeric_limits<Real>::max(), inf, -inf};
  for (const Real x : values) {
    const Real up = nextUp(x), down = nextDown(x), refUp = std::nextafter(x, inf), refDown = std::nextafter(x, -inf);
    CHECK(std::memcmp(&up, &refUp, sizeof up) == 0);
    CHECK(std::memcmp(&down, &refDown, sizeof down) == 0);
  }
  CHECK(std::isnan(nextUp(std::numeric_limits<Real>::quiet_NaN())));
  CHECK(std::isnan(nextDown(std::numeric_limits<Real>::quiet_NaN())));
}

TEST_CASE_TEMPLATE("nextToward steps as nextUp, nextDown or not at all, bit for bit", Real, float, double) {
  // Special values, and random bit patterns (every sign, binade and subnormal), each stepped toward
  // a positive, a negative, a zero and a NaN direction.
  constexpr Real inf = std::numeric_limits<Real>::infinity(), nan = std::numeric_limits<Real>::quiet_NaN();
  using Bits = typename FloatBits<Real>::Bits;
  std::vector<Real> values = {Real(0), -Real(0), Real(1), Real(-1), std::numeric_limits<Real>::denorm_min(),
                              -std::numeric_limits<Real>::denorm_min(), std::numeric_limits<Real>::min(),
                              std::numeric_limits<Real>::max(), -std::numeric_limits<Real>::max(), inf, -inf};
  std::mt19937_64 rng(21);
  for (int i = 0; i < 20000; ++i) {
    const Bits bits = static_cast<Bits>(rng());
    Real x;
    std::memcpy(&x, &bits, sizeof x);
    if (x == x) values.push_back(x);
  }
  const auto same = [](Real a, Real b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  for (const Real x : values) {
    CAPTURE(x);
    CHECK(same(nextToward(x, Real(0.5)), nextUp(x)));
    CHECK(same(nextToward(x, -std::numeric_limits<Real>::denorm_min()), nextDown(x)));
    CHECK(same(nextToward(x, Real(0)), x));
    CHECK(same(nextToward(x, -Real(0)), x));
    CHECK(same(nextToward(x, nan), x));
  }
  CHECK(std::isnan(nextToward(nan, Real(1))));
  CHECK(std::isnan(nextToward(nan, Real(-1))));
}

TEST_CASE("inversePowerOfTwo is 2^-floor(log2 x) for normal x, NaN for the rest") {
  CHECK(inversePowerOfTwo(3.0) == 0.5);
  CHECK(inversePowerOfTwo(1.0) == 1.0);
  CHECK(inversePowerOfTwo(0.3) == 4.0);
  CHECK(inversePowerOfTwo(1024.0f) == std::ldexp(1.0f, -10));
  CHECK(std::isnan(inversePowerOfTwo(0.0)));
  CHECK(std::isnan(inversePowerOfTwo(std::numeric_limits<double>::denorm_min())));
  CHECK(std::isnan(inversePowerOfTwo(kInf)));
  CHECK(inversePowerOfTwo(std::ldexp(1.0, 1023)) == std::ldexp(1.0, -1023));  // subnormal, exact
  CHECK(inversePowerOfTwo(std::numeric_limits<float>::max()) == std::ldexp(1.0f, -127));
}

TEST_CASE_TEMPLATE("wellScaled keeps a unit vector's bits, and stands in where the squares underflow", Real, float,
                   double) {
  const Vec3<Real> v(Real(0.3), Real(-1.7), Real(2.9)), fallback(0, 0, -3);
  CHECK(glm::normalize(wellScaled(v, fallback)) == glm::normalize(v));  // exact power-of-two scaling
  const Real tiny = std::numeric_limits<Real>::min() * 4;  // normal, but its square underflows to 0
  CHECK(!std::isfinite(glm::normalize(Vec3<Real>(0, tiny, 0)).y));
  CHECK(glm::normalize(wellScaled(Vec3<Real>(0, tiny, 0), fallback)) == Vec3<Real>(0, 1, 0));
  CHECK(glm::normalize(wellScaled(Vec3<Real>(0), fallback)) == Vec3<Real>(0, 0, -1));
  CHECK(glm::normalize(wellScaled(Vec3<Real>(0, std::numeric_limits<Real>::denorm_min(), 0), fallback)) ==
        Vec3<Real>(0, 0, -1));
  // The largest magnitude found from the bits: a negative one's, and no direction from inf or NaN.
  const Vec3<Real> negative(Real(0.5), Real(-7.5), Real(2));
  CHECK(wellScaled(negative, fallback) == negative * Real(0.25));
  const Real inf = std::numeric_limits<Real>::infinity(), nan = std::numeric_limits<Real>::quiet_NaN();
  CHECK(glm::normalize(wellScaled(Vec3<Real>(1, inf, 0), fallback)) == Vec3<Real>(0, 0, -1));
  CHECK(glm::normalize(wellScaled(Vec3<Real>(1, 0, nan), fallback)) == Vec3<Real>(0, 0, -1));
}

TEST_CASE_TEMPLATE("absolute is std::fabs per component: no sign survives, not even zero's", Real, float, double) {
  const Real inf = std::numeric_limits<Real>::infinity(), nan = std::numeric_limits<Real>::quiet_NaN();
  const Vec3<Real> a = absolute(Vec3<Real>(Real(-2.5), -inf, Real(-0.0)));
  CHECK(a == Vec3<Real>(Real(2.5), inf, 0));
  CHECK(!std::signbit(a.z));                               // glm::abs keeps -0 (x >= 0 holds for it)
  CHECK(std::signbit(glm::abs(Vec3<Real>(Real(-0.0))).x));
  const Vec3<Real> n = absolute(Vec3<Real>(-nan, Real(1), std::numeric_limits<Real>::denorm_min()));
  CHECK((std::isnan(n.x) && !std::signbit(n.x)));
  CHECK(n.z == std::numeric_limits<Real>::denorm_min());
}

TEST_CASE_TEMPLATE("non-negative numbers' bits order as the numbers do, and come back the same", Real, float, double) {
  const Real values[] = {Real(0), std::numeric_limits<Real>::denorm_min(), std::numeric_limits<Real>::min(),
                         Real(0.5), std::nextafter(Real(1), Real(0)), Real(1), Real(1919.75),
                         std::numeric_limits<Real>::max(), std::numeric_limits<Real>::infinity()};
  for (const Real a : values) {
    CHECK(fromNonNegativeBits<Real>(nonNegativeBits(a)) == a);
    for (const Real b : values) {
      CHECK((nonNegativeBits(a) < nonNegativeBits(b)) == (a < b));
      CHECK(fromNonNegativeBits<Real>(std::min(nonNegativeBits(a), nonNegativeBits(b))) == std::min(a, b));
    }
  }
  CHECK(nonNegativeBits(Real(-1)) < 0);  // a negative number's bits do not order as it does: not for them
}

TEST_CASE_TEMPLATE("positivePart is std::max(0, x) bit for bit, -0 and negative infinity included", Real, float, double) {
  const Real inf = std::numeric_limits<Real>::infinity();
  const Real values[] = {-inf, -std::numeric_limits<Real>::max(), Real(-1.5), -std::numeric_limits<Real>::denorm_min(),
                         Real(-0.0), Real(0), std::numeric_limits<Real>::denorm_min(), Real(0.25), std::numeric_limits<Real>::max(), inf};
  for (const Real x : values) {
    const Real expected = std::max(Real(0), x), got = positivePart(x);
    CHECK(std::memcmp(&expected, &got, sizeof got) == 0);
  }
  CHECK(!std::signbit(positivePart(Real(-0.0))));
}

TEST_CASE("error-free transformations recover what plain arithmetic rounds away") {
  // 1 - 2^-60 rounds to 1; the lost part is exactly -2^-60.
  CHECK(twoDiffError(1.0, std::ldexp(1.0, -60), 1.0) == -std::ldexp(1.0, -60));
  // (1 + 2^-27)² - 1·1 = 2^-26 + 2^-54: the naive product loses the 2^-54.
  const double a = 1 + std::ldexp(1.0, -27);
  CHECK(a * a - 1.0 == std::ldexp(1.0, -26));
  CHECK(differenceOfProducts(a, a, 1.0, 1.0) == std::ldexp(1.0, -26) + std::ldexp(1.0, -54));
  // 3² + 4² + 0² - 5² = 0 exactly, and (1e8 + 1)² - (1e8)² ... = 2e8 + 1.
  CHECK(sumOfSquaresMinus(3.0, 4.0, 0.0, 5.0) == 0.0);
  CHECK(sumOfSquaresMinus(1e8 + 1, 0.0, 0.0, 1e8) == 2e8 + 1);
}

TEST_CASE("inverseSqrt is 1 / sqrt(s) to 3 units in the last place over its whole range") {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> exponent(std::log(kInverseSqrtLeast), std::log(kInverseSqrtMost));
  std::uniform_real_distribution<double> nearOne(1, 4);  // a camera ray's squared length
  double worst = 0;
  for (int i = 0; i < 200000; ++i) {
    const double s = i % 2 == 0 ? std::exp(exponent(rng)) : nearOne(rng);
    const long double exact = 1.0L / std::sqrt(static_cast<long double>(s));
    const double ulp = std::nextafter(static_cast<double>(exact), kInf) - static_cast<double>(exact);
    worst = std::max(worst, static_cast<double>(std::fabs(inverseSqrt(s) - exact) / ulp));
  }
  CHECK(worst <= 3);
  CHECK(worst > 1.5);  // more than the square root and division it stands in for (2.22 seen)
  CHECK(std::fabs(inverseSqrt(0x1.0336fb2e4829ep+0) - 1.0L / std::sqrt(0x1.0336fb2e4829ep+0L)) <
        3 * std::ldexp(1.0, -53));  // 2.21 ulps off, found by a review's search
  CHECK(inverseSqrt(1.0) == 1.0);
  CHECK(inverseSqrt(4.0) == 0.5);
  CHECK(inverseSqrt(kInverseSqrtLeast) == doctest::Approx(1e15).epsilon(1e-15));
  CHECK(inverseSqrt(kInverseSqrtMost) == doctest::Approx(1e-15).epsilon(1e-15));
}

TEST_CASE("safeNormalize neither under- nor overflows") {
  const Vec3d tiny = safeNormalize(Vec3d(1e-300, 0, 0));
  CHECK(tiny.x == 1.0);
  const Vec3d huge = safeNormalize(Vec3d(1e300, 1e300, 0));
  CHECK(huge.x == doctest::Approx(std::sqrt(0.5)).epsilon(1e-15));
  CHECK(huge.y == huge.x);
  CHECK(huge.z == 0.0);
}

TEST_CASE("slab: entry and exit, parallel rays inside, outside and on a face") {
  double nearT = -kInf, farT = kInf;
  // Ray from (-1, 0.5, 0.5) along +x against the unit cube: [1, 2].
  slab(0.0, 1.0, -1.0, 1.0, nearT, farT);
  slab(0.0, 1.0, 0.5, 1 / 0.0, nearT, farT);  // parallel, inside: ±inf, no narrowing
  CHECK(nearT == 1.0);
  CHECK(farT == 2.0);
  // Parallel with the origin exactly on a face: 0·inf = NaN counts as inside.
  slab(0.0, 1.0, 0.0, 1 / 0.0, nearT, farT);
  slab(0.0, 1.0, 1.0, -1 / 0.0, nearT, farT);
  CHECK(nearT == 1.0);
  CHECK(farT == 2.0);
  // Parallel and outside: the range empties.
  slab(0.0, 1.0, 2.0, 1 / 0.0, nearT, farT);
  CHECK_FALSE(nearT <= farT);
  // A negative direction (-2, from 3) swaps entry and exit: t = (1 - 3) / -2 and (0 - 3) / -2.
  nearT = -kInf, farT = kInf;
  slab(0.0, 1.0, 3.0, -0.5, nearT, farT);
  CHECK(nearT == 1.0);
  CHECK(farT == 1.5);
}

TEST_CASE_TEMPLATE("spheres: every method finds the closed-form roots", Real, float, double) {
  SphereSet<Real> spheres;
  spheres.add({Vec3<Real>(0, 0, 0), Real(1)}, 3, 7);
  // From (0.6, 0, -5) along +z (length 2): the chord at x = 0.6 has half-length 0.8, so
  // t = (5 - 0.8) / 2 in units of the direction.
  const auto check = [&](auto method) {
    RayPacket<Real> p = oneRay<Real>({Real(0.6), 0, -5}, {0, 0, 2});
    spheres.template intersect<decltype(method)::value>(p, 0, nullptr);
    CHECK(p.prim[0] == 0);
    CHECK(p.tHit[0] == doctest::Approx(2.1).epsilon(1e-6));
    const Hit<Real> h = spheres.hit(p, 0, 0);
    CHECK(h.objectId == 7);
    CHECK(h.materialId == 3);
    CHECK(h.normal.x == doctest::Approx(0.6).epsilon(1e-5));
    CHECK(h.normal.z == doctest::Approx(-0.8).epsilon(1e-5));
    // From inside, the far root; past the sphere, a miss.
    RayPacket<Real> inside = oneRay<Real>({0, 0, 0}, {0, 1, 0});
    spheres.template intersect<decltype(method)::value>(inside, 0, nullptr);
    CHECK(inside.tHit[0] == doctest::Approx(1).epsilon(1e-6));
    RayPacket<Real> wide = oneRay<Real>({Real(1.01), 0, -5}, {0, 0, 1});
    spheres.template intersect<decltype(method)::value>(wide, 0, nullptr);
    CHECK(wide.prim[0] == kNoPrimitive);
  };
  check(std::integral_constant<SphereMethod, SphereMethod::Algebraic>{});
  check(std::integral_constant<SphereMethod, SphereMethod::Geometric>{});
  check(std::integral_constant<SphereMethod, SphereMethod::Robust>{});
}

TEST_CASE_TEMPLATE("a ray leaving a sphere (robustLeaves) has no root at any t > 0", Real, float, double) {
  // Origins on, just outside and just inside spheres (r·(1 + k·epsilon), k from -8 to 64) at scales
  // from 2^-20 to 2^19, directions anywhere: wherever robustLeaves holds, robustRoots' roots are
  // below the least positive tMin, so skipping them changes no hit.
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> unit(-1, 1), radius(0.01, 1);
  std::uniform_int_distribution<int> ulps(-8, 64), exponent(-20, 19);
  const double eps = std::numeric_limits<Real>::epsilon();
  const Real tMin = std::numeric_limits<Real>::denorm_min();
  int leaving = 0, entering = 0;
  for (int trial = 0; trial < 40000; ++trial) {
    const double scale = std::ldexp(1.0, exponent(rng)), r = scale * radius(rng);
    const Vec3d c = scale * 10.0 * Vec3d(unit(rng), unit(rng), unit(rng));
    const Vec3d n = glm::normalize(Vec3d(unit(rng), unit(rng), unit(rng)) + Vec3d(0, 0, 1e-3));
    const Vec3<Real> o = toReal<Real>(c + r * (1 + ulps(rng) * eps) * n);
    const Vec3<Real> d = toReal<Real>(glm::normalize(Vec3d(unit(rng), unit(rng), unit(rng)) + Vec3d(1e-3, 0, 0)));
    const SphereRayTerms<Real> terms = sphereRayTerms<SphereMethod::Robust>(d.x, d.y, d.z);
    const RobustOrigin<Real> f = robustOrigin(o.x, o.y, o.z, toReal<Real>(c), static_cast<Real>(r));
    CAPTURE(trial);
    if (!robustLeaves(f, terms)) {
      ++entering;
      continue;
    }
    ++leaving;
    const SphereRoots<Real> roots = robustRoots(f, terms, static_cast<Real>(r));
    CHECK(!(firstRootFrom(roots, tMin) >= tMin));
  }
  CHECK(leaving > 10000);  // both outcomes, in earnest
  CHECK(entering > 10000);
}

#if defined(__AVX2__) && defined(__FMA__)
TEST_CASE_TEMPLATE("a leaf's prefilter, four spheres at once, decides for each as robustMayMeet does", Real, float, double) {
  // Rays aimed at spheres' silhouettes (line distance r·(1 + k·epsilon), k from -64 to 64, so the
  // outcome turns on the last bits), at scales from 2^-20 to 2^19, in leaves of one to four spheres
  // (lanes past the leaf are masked off): every lane's bit must be the scalar test's.
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> unit(-1, 1), radius(0.01, 1), along(-20, 20);
  std::uniform_int_distribution<int> ulps(-64, 64), exponent(-20, 19);
  const double eps = std::numeric_limits<Real>::epsilon();
  int met = 0, missed = 0;
  for (int trial = 0; trial < 40000; ++trial) {
    const double scale = std::ldexp(1.0, exponent(rng));
    const Vec3d d = glm::normalize(Vec3d(unit(rng), unit(rng), unit(rng)) + Vec3d(0, 0, 1e-3));
    const Vec3d o = scale * 10.0 * Vec3d(unit(rng), unit(rng), unit(rng));
    const Vec3<Real> oR = toReal<Real>(o), dR = toReal<Real>(d);
    const SphereRayTerms<Real> terms = sphereRayTerms<SphereMethod::Robust>(dR.x, dR.y, dR.z);
    const int count = 1 + trial % 4;
    Sphere<Real> leaf[4];
    unsigned expected = 0;
    for (int i = 0; i < count; ++i) {
      const double r = scale * radius(rng);
      const Vec3d side = glm::normalize(glm::cross(d, Vec3d(unit(rng), unit(rng), unit(rng))));
      const Vec3d c = o + scale * along(rng) * d + side * (r * (1 + ulps(rng) * eps));
      leaf[i] = {toReal<Real>(c), static_cast<Real>(r)};
      const Real fx = oR.x - leaf[i].center.x, fy = oR.y - leaf[i].center.y, fz = oR.z - leaf[i].center.z;
      const bool may = robustMayMeet(leaf[i].radius, lineDistanceSq(fx, fy, fz, terms), std::fabs(fx) + std::fabs(fy) + std::fabs(fz));
      expected |= unsigned(may) << i;
      (may ? met : missed) += 1;
    }
    CAPTURE(trial);
    CHECK(SphereSet<Real>::leafMayMeet(leaf, count, oR.x, oR.y, oR.z, terms) == expected);
  }
  CHECK(met > 20000);  // both outcomes, in earnest
  CHECK(missed > 20000);
}
#endif

#if DURER_WALK_LANES
TEST_CASE_TEMPLATE("the grid's pairs, eight at once, each decided as robustMayMeet decides it", Real, float, double) {
  // As the leaf's test above, but each lane its own ray (picked from eight walks' rays by lane, as the
  // grid's walk in lanes pairs them) and its own sphere (transposed from eight records).
  using L = PairLanes<Real>;
  std::mt19937_64 rng(18);
  std::uniform_real_distribution<double> unit(-1, 1), radius(0.01, 1), along(-20, 20);
  std::uniform_int_distribution<int> ulps(-64, 64), exponent(-20, 19), lane(0, 7);
  const double eps = std::numeric_limits<Real>::epsilon();
  int met = 0, missed = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    const double scale = std::ldexp(1.0, exponent(rng));
    alignas(64) Real ox[8], oy[8], oz[8], sx[8], sy[8], sz[8], invA[8];
    Vec3d origins[8], directions[8];
    for (int w = 0; w < 8; ++w) {
      directions[w] = glm::normalize(Vec3d(unit(rng), unit(rng), unit(rng)) + Vec3d(0, 0, 1e-3));
      origins[w] = scale * 10.0 * Vec3d(unit(rng), unit(rng), unit(rng));
      const Vec3<Real> dR = toReal<Real>(directions[w]);
      const SphereRayTerms<Real> t = sphereRayTerms<SphereMethod::Robust>(dR.x, dR.y, dR.z);
      ox[w] = Real(origins[w].x), oy[w] = Real(origins[w].y), oz[w] = Real(origins[w].z);
      sx[w] = t.sx, sy[w] = t.sy, sz[w] = t.sz, invA[w] = t.invA;
    }
    Sphere<Real> records[8];
    alignas(32) int32_t lanes[8];
    uint32_t at[8];
    unsigned expected = 0;
    for (int i = 0; i < 8; ++i) {
      const int w = lanes[i] = lane(rng);
      at[i] = uint32_t(7 - i);
      const double r = scale * radius(rng);
      const Vec3d side = glm::normalize(glm::cross(directions[w], Vec3d(unit(rng), unit(rng), unit(rng))));
      const Vec3d c = Vec3d(double(ox[w]), double(oy[w]), double(oz[w])) + scale * along(rng) * directions[w] +
                      side * (r * (1 + ulps(rng) * eps));
      Sphere<Real>& s = records[at[i]];
      s = {toReal<Real>(c), static_cast<Real>(r)};
      const Real fx = ox[w] - s.center.x, fy = oy[w] - s.center.y, fz = oz[w] - s.center.z;
      const SphereRayTerms<Real> t{0, 0, sx[w], sy[w], sz[w], 0, invA[w], 0};
      const bool may = robustMayMeet(s.radius, lineDistanceSq(fx, fy, fz, t), std::fabs(fx) + std::fabs(fy) + std::fabs(fz));
      expected |= unsigned(may) << i;
      (may ? met : missed) += 1;
    }
    typename L::V cx, cy, cz, r;
    L::transpose(records, at, cx, cy, cz, r);
    const typename L::Index pick = L::index(lanes);
    const unsigned got = SphereSet<Real>::template mayMeetLanes<L>(
        L::pick(pick, L::load(ox)) - cx, L::pick(pick, L::load(oy)) - cy, L::pick(pick, L::load(oz)) - cz,
        L::pick(pick, L::load(sx)), L::pick(pick, L::load(sy)), L::pick(pick, L::load(sz)), L::pick(pick, L::load(invA)), r);
    CAPTURE(trial);
    CHECK(got == expected);
  }
  CHECK(met > 20000);  // both outcomes, in earnest
  CHECK(missed > 8000);
}
#endif

TEST_CASE_TEMPLATE("triangles: t and the normal from the winding; a shared edge is never missed", Real, float, double) {
  TriangleSet<Real> lower, upper;
  lower.add(triangle<Real>({0, 0, 0}, {1, 0, 0}, {1, 1, 0}), 0, 0);
  upper.add(triangle<Real>({0, 0, 0}, {1, 1, 0}, {0, 1, 0}), 0, 1);
  RayPacket<Real> p = oneRay<Real>({Real(0.75), Real(0.25), 2}, {0, 0, -4});
  lower.intersect(p, 0, nullptr);
  CHECK(p.prim[0] == 0);
  CHECK(p.tHit[0] == Real(0.5));
  CHECK(lower.hit(p, 0, 0).normal == Vec3<Real>(0, 0, 1));
  // Rays through the shared diagonal, and through its end vertices: one of the two is hit.
  for (Real s : {Real(0), Real(0.1), Real(1) / 3, Real(0.5), Real(0.9), Real(1)}) {
    RayPacket<Real> a = oneRay<Real>({s, s, 1}, {0, 0, -1}), b = a;
    lower.intersect(a, 0, nullptr);
    upper.intersect(b, 0, nullptr);
    CHECK((a.prim[0] == 0 || b.prim[0] == 0));
  }
}

TEST_CASE_TEMPLATE("planes: t = (offset - n·o) / (n·d); parallel rays miss; bounds clip", Real, float, double) {
  PlaneSet<Real> planes;
  const Vec3<Real> n(0, 0, 1);
  planes.add({n, Vec3<Real>(0, 0, 2), false, Vec3<Real>(0), Vec3<Real>(0)}, 0, 0);
  RayPacket<Real> p = oneRay<Real>({0, 0, 0}, {0, 0, 4});
  planes.intersect(p, 0, nullptr);
  CHECK(p.tHit[0] == Real(0.5));
  RayPacket<Real> parallel = oneRay<Real>({0, 0, 0}, {1, 0, 0});
  planes.intersect(parallel, 0, nullptr);
  CHECK(parallel.prim[0] == kNoPrimitive);
  // The unit square at z = 2 (corner at the origin's foot, duals = the edges themselves).
  PlaneSet<Real> square;
  square.add({n, Vec3<Real>(0, 0, 2), true, Vec3<Real>(1, 0, 0), Vec3<Real>(0, 1, 0)}, 0, 0);
  RayPacket<Real> in = oneRay<Real>({Real(0.5), Real(0.5), 0}, {0, 0, 1});
  RayPacket<Real> out = oneRay<Real>({Real(1.5), Real(0.5), 0}, {0, 0, 1});
  square.intersect(in, 0, nullptr);
  square.intersect(out, 0, nullptr);
  CHECK(in.tHit[0] == Real(2));
  CHECK(out.prim[0] == kNoPrimitive);
}

TEST_CASE_TEMPLATE("boxes: entry from outside, exit from inside, grazing a face", Real, float, double) {
  BoxSet<Real> boxes;
  boxes.add({Vec3<Real>(1, -1, -1), Vec3<Real>(2, 1, 1)}, 0, 0);
  RayPacket<Real> outside = oneRay<Real>({0, 0, 0}, {1, 0, 0});
  boxes.intersect(outside, 0, nullptr);
  CHECK(outside.tHit[0] == Real(1));
  CHECK(boxes.hit(outside, 0, 0).normal == Vec3<Real>(-1, 0, 0));
  RayPacket<Real> inside = oneRay<Real>({Real(1.5), 0, 0}, {2, 0, 0});
  boxes.intersect(inside, 0, nullptr);
  CHECK(inside.tHit[0] == Real(0.25));
  // Along the face y = 1 (parallel, on it): inside by the slab rule, so hit.
  RayPacket<Real> graze = oneRay<Real>({0, 1, 0}, {1, 0, 0});
  boxes.intersect(graze, 0, nullptr);
  CHECK(graze.tHit[0] == Real(1));
  RayPacket<Real> above = oneRay<Real>({0, Real(1.5), 0}, {1, 0, 0});
  boxes.intersect(above, 0, nullptr);
  CHECK(above.prim[0] == kNoPrimitive);
}

TEST_CASE("invertibility: one scale-free rule") {
  Affined m{{Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(0, 0, 1)}, Vec3d(5, 6, 7)};
  CHECK(isInvertible(m));
  m.row[2] = Vec3d(0, 0, 1e-200);  // a tiny axis scale: scale-free, so invertible
  CHECK(isInvertible(m));
  m.row[2] = Vec3d(0, 0, 1e-310);  // subnormal: its inverse overflows
  CHECK_FALSE(isInvertible(m));
  m.row[2] = Vec3d(1, 0, 1e-14);  // nearly the first row: |det| / Hadamard bound = 1e-14
  CHECK_FALSE(isInvertible(m));
  m.row[2] = Vec3d(1, 0, 1e-11);
  CHECK(isInvertible(m));
  m.row[2] = Vec3d(0, 0, std::numeric_limits<double>::quiet_NaN());
  CHECK_FALSE(isInvertible(m));
}

TEST_CASE("facing: the shading normal flips only for shadeBack and a ray from behind") {
  const Vec3d n(0, 0, 1);
  CHECK(shadingNormal(n, Vec3d(0, 0, -1), true) == n);
  CHECK(shadingNormal(n, Vec3d(0, 0, 1), true) == -n);
  CHECK(shadingNormal(n, Vec3d(0, 0, 1), false) == n);
  CHECK(facingSign(0.0, true) == 1.0);  // grazing: kept
}

TEST_CASE("a spherical rectangle: its solid angle in closed form, its points on it, uniform in solid angle") {
  // A 2a x 2b rectangle seen from height h above its centre: Ω = 4·asin(ab / √((a² + h²)(b² + h²))).
  for (const double h : {0.01, 0.3, 1.0, 7.0}) {
    const double a = 0.5, b = 0.25;
    const SphericalRectangle seen(Vec3d(0, 0, h), Vec3d(-a, -b, 0), Vec3d(2 * a, 0, 0), Vec3d(0, 2 * b, 0));
    CHECK(seen.solidAngle() == doctest::Approx(4 * std::asin(a * b / std::sqrt((a * a + h * h) * (b * b + h * h))))
                                   .epsilon(1e-12));
  }
  // From behind (the side ex × ey points away from) or in its plane: nothing.
  CHECK(SphericalRectangle(Vec3d(0, 0, -1), Vec3d(-1, -1, 0), Vec3d(2, 0, 0), Vec3d(0, 2, 0)).solidAngle() == 0);
  CHECK(SphericalRectangle(Vec3d(3, 0, 0), Vec3d(-1, -1, 0), Vec3d(2, 0, 0), Vec3d(0, 2, 0)).solidAngle() == 0);
  // Seen from off its axis, close: points lie on it, and the share falling in its lower-left quarter
  // is that quarter's share of the solid angle.
  const Vec3d p(0.3, -0.2, 0.15), corner(-1, -0.5, 0), ex(2, 0, 0), ey(0, 1, 0);
  const SphericalRectangle seen(p, corner, ex, ey);
  const double quarter = SphericalRectangle(p, corner, ex / 2.0, ey / 2.0).solidAngle() / seen.solidAngle();
  const int n = 256;
  int inQuarter = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const Vec3d q = seen.point((i + 0.5) / n, (j + 0.5) / n);
      REQUIRE(std::fabs(q.z) < 1e-12);
      REQUIRE(q.x >= -1 - 1e-12);
      REQUIRE(q.x <= 1 + 1e-12);
      REQUIRE(q.y >= -0.5 - 1e-12);
      REQUIRE(q.y <= 0.5 + 1e-12);
      inQuarter += q.x < 0 && q.y < 0;
    }
  }
  CHECK(double(inQuarter) / (n * n) == doctest::Approx(quarter).epsilon(0.01));
}
