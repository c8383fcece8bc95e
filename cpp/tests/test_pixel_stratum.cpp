// Unit tests of a pixel's silhouette stratum: the exact area of the unit disk within a rectangle,
// a pixel's share of an ellipse, and of the union of several, and a sphere's front over a disk's part of a
// pixel (its control variate's moments), against numerical integration (doctest).
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

#include "durer/math/Float.h"
#include "durer/render/PixelStratum.h"

using namespace durer;

namespace {

// The same area by the midpoint rule over x of the chord's part within [v0, v1] (error ~1e-9 with
// this many steps: the chord's square-root ends).
double integrated(double u0, double u1, double v0, double v1) {
  const int steps = 400000;
  const double a = std::max(u0, -1.0), b = std::min(u1, 1.0);
  if (a >= b) return 0;
  const double h = (b - a) / steps;
  double sum = 0;
  for (int i = 0; i < steps; ++i) {
    const double x = a + (i + 0.5) * h, s = std::sqrt(1 - x * x);
    sum += std::max(0.0, std::min(v1, s) - std::max(v0, -s));
  }
  return sum * h;
}

// The share of pixel (x, y) a stratum's membership test counts inside, over a 1000 x 1000 grid of
// its points (within ~4e-3 of the exact share: the cells the edge crosses).
double gridShare(const PixelStratum& p, int x, int y) {
  const int n = 1000;
  int inside = 0;
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) inside += p.contains(x + (a + 0.5) / n, y + (b + 0.5) / n);
  }
  return double(inside) / (double(n) * n);
}

}  // namespace

TEST_CASE("the unit disk's area within a rectangle: exact cases and numerical integration") {
  CHECK(unitDiskRectangleArea(-2, 2, -2, 2) == doctest::Approx(kPi).epsilon(1e-15));
  CHECK(unitDiskRectangleArea(-2, 2, 0, 2) == doctest::Approx(kPi / 2).epsilon(1e-15));
  CHECK(unitDiskRectangleArea(0, 2, 0, 2) == doctest::Approx(kPi / 4).epsilon(1e-15));
  CHECK(unitDiskRectangleArea(-0.5, 0.5, -0.5, 0.5) == doctest::Approx(1.0).epsilon(1e-15));  // inside
  CHECK(unitDiskRectangleArea(1, 2, -1, 1) == 0);
  CHECK(unitDiskRectangleArea(0.8, 2, 0.8, 2) == 0);  // the corner beyond the disk
  CHECK(unitDiskRectangleArea(0.5, 0.5, -1, 1) == 0);  // empty
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> at(-1.6, 1.6), size(0.01, 1.5);
  for (int i = 0; i < 300; ++i) {
    const double u0 = at(rng), v0 = at(rng), u1 = u0 + size(rng), v1 = v0 + size(rng);
    const double exact = unitDiskRectangleArea(u0, u1, v0, v1);
    CHECK_MESSAGE(std::abs(exact - integrated(u0, u1, v0, v1)) < 1e-8, u0, " ", u1, " ", v0, " ", v1);
  }
  // A sliver: the rectangle grazing the disk's edge, its area tiny, neither negative nor lost.
  const double sliver = unitDiskRectangleArea(-0.1, 0.1, 0.999, 2);
  CHECK(sliver > 0);
  CHECK(sliver == doctest::Approx(integrated(-0.1, 0.1, 0.999, 2)).epsilon(1e-4));
}

TEST_CASE("a pixel's stratum: its share is the fraction of the pixel the ellipse covers, and its mean weighs the parts by it") {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> offset(-1.5, 2.5), axis(0.3, 2.5);
  int tested = 0;
  for (int i = 0; i < 200; ++i) {
    const int x = 5, y = 9;
    const PixelStratum p = PixelStratum::of(x, y, x + offset(rng), y + offset(rng), axis(rng), axis(rng));
    if (!p.any()) continue;
    ++tested;
    CHECK(p.share > 0);
    CHECK(p.share < 1);
    CHECK(std::abs(gridShare(p, x, y) - double(p.share)) < 4e-3);
  }
  CHECK(tested > 50);
  // An ellipse whose edge does not cross the pixel gives no stratum: covering it, or beside it.
  CHECK_FALSE(PixelStratum::of(0, 0, 0.5, 0.5, 3, 3).any());
  CHECK_FALSE(PixelStratum::of(0, 0, 5, 5, 1, 1).any());
  // The mean: a quarter of the pixel inside, where 1 of 8 samples fell (colour 1), the rest 0.2:
  // 0.25 * 1 + 0.75 * 0.2 = 0.4 (the plain mean: 0.3). With no sample inside, or none outside, the plain mean.
  const PixelStratum q = PixelStratum::of(0, 0, 0, 0, 1, 1);  // the unit disk about the corner: pi / 4
  REQUIRE(q.any());
  CHECK(double(q.share) == doctest::Approx(kPi / 4).epsilon(1e-7));
  PixelStratum quarter = q;
  quarter.share = 0.25f;
  CHECK(quarter.mean(1.0 + 7 * 0.2, 8.0, 1.0, 1.0) == doctest::Approx(0.4).epsilon(1e-15));
  CHECK(quarter.mean(1.6, 8.0, 0.0, 0.0) == doctest::Approx(0.2).epsilon(1e-15));
  CHECK(quarter.mean(8.0, 8.0, 8.0, 8.0) == doctest::Approx(1.0).epsilon(1e-15));
}

TEST_CASE("a wide silhouette's share stays exact to 2e-6 of the pixel; wider ones keep no stratum") {
  // The share in the pixel's own frame, for a circle of radius r about (cx, cy): the midpoint rule
  // over x across the pixel of the chord's part within it, the chord's half height as
  // sqrt((r - d)(r + d)) (no r^2 - d^2 to cancel).
  const auto reference = [](int x, int y, double cx, double cy, double r) {
    const int steps = 200000;
    double sum = 0;
    for (int i = 0; i < steps; ++i) {
      const double d = std::abs(x + (i + 0.5) / steps - cx);
      if (d >= r) continue;
      const double half = std::sqrt((r - d) * (r + d));
      sum += std::max(0.0, std::min(y + 1.0, cy + half) - std::max(double(y), cy - half));
    }
    return sum / steps;
  };
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(0, 1);
  int tested = 0;
  for (int i = 0; i < 60; ++i) {
    const double r = std::pow(2.0, 12 * unit(rng));  // 1 to 4096 pixels
    const double angle = 2 * kPi * unit(rng), reach = r + unit(rng) - 0.5;  // the edge near pixel (0, 0)
    // The centre rounded to float (as the stratum keeps it), the radius a float's inverse's inverse.
    const double cx = double(float(0.5 - reach * std::cos(angle))), cy = double(float(0.5 - reach * std::sin(angle)));
    const PixelStratum p = PixelStratum::of(0, 0, cx, cy, r, r);
    if (!p.any()) continue;
    ++tested;
    const double radius = 1 / double(p.inverseAx[0]);
    CHECK_MESSAGE(std::abs(double(p.share) - reference(0, 0, cx, cy, radius)) < 2e-6, "r ", r, " angle ", angle);
  }
  CHECK(tested > 40);
  CHECK(PixelStratum::of(0, 0, 0.5 - 4095.5, 0.5, 4095.5, 4095.5).any());
  CHECK_FALSE(PixelStratum::of(0, 0, 0.5 - 5000, 0.5, 5000, 5000).any());  // beyond kMostAxis
}

namespace {

// The area of the union of circles within [0, w] x [0, h] by the midpoint rule over v of the union
// of their chords' intervals within [0, w] (error ~1e-7 with this many rows).
double unionIntegrated(const std::vector<double>& cu, const std::vector<double>& cv, const std::vector<double>& r, double w,
                       double h) {
  const int steps = 100000;
  double sum = 0;
  std::vector<std::pair<double, double>> spans;
  for (int i = 0; i < steps; ++i) {
    const double v = (i + 0.5) * h / steps;
    spans.clear();
    for (size_t c = 0; c < cu.size(); ++c) {
      const double dv = v - cv[c];
      if (std::abs(dv) >= r[c]) continue;
      const double half = std::sqrt((r[c] - dv) * (r[c] + dv));
      const double a = std::max(0.0, cu[c] - half), b = std::min(w, cu[c] + half);
      if (a < b) spans.emplace_back(a, b);
    }
    std::sort(spans.begin(), spans.end());
    double end = -1;
    for (const auto& [a, b] : spans) {
      if (b <= end) continue;
      sum += b - std::max(a, end), end = b;
    }
  }
  return sum * h / steps;
}

}  // namespace

TEST_CASE("the union of circles within a rectangle: exact cases and numerical integration") {
  const auto area = [](std::vector<double> cu, std::vector<double> cv, std::vector<double> r, double w, double h) {
    return circlesRectangleUnionArea(cu.data(), cv.data(), r.data(), static_cast<int>(cu.size()), w, h);
  };
  CHECK(area({0.5}, {0.5}, {0.25}, 1, 1) == doctest::Approx(kPi / 16).epsilon(1e-14));  // inside
  CHECK(area({0.5}, {0.5}, {5}, 1, 1) == doctest::Approx(1).epsilon(1e-14));            // covering
  CHECK(area({3}, {3}, {1}, 1, 1) == 0);                                                 // beside
  CHECK(area({0}, {0}, {1}, 2, 2) == doctest::Approx(kPi / 4).epsilon(1e-14));           // a quarter
  // The same circle twice counts once; a circle inside another adds nothing.
  CHECK(area({0.5, 0.5}, {0.5, 0.5}, {0.3, 0.3}, 1, 1) == doctest::Approx(kPi * 0.09).epsilon(1e-14));
  CHECK(area({0.5, 0.55}, {0.5, 0.5}, {0.3, 0.1}, 1, 1) == doctest::Approx(kPi * 0.09).epsilon(1e-14));
  // Two disjoint circles inside: the sum.
  CHECK(area({0.25, 0.75}, {0.5, 0.5}, {0.2, 0.2}, 1, 1) == doctest::Approx(2 * kPi * 0.04).epsilon(1e-14));
  // Two unit circles a unit apart: the lens is 2 pi / 3 - sqrt(3) / 2, so the union 2 pi - that.
  CHECK(area({5, 6}, {5, 5}, {1, 1}, 10, 10) == doctest::Approx(2 * kPi - (2 * kPi / 3 - std::sqrt(3.0) / 2)).epsilon(1e-13));
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> at(-1.5, 2.5), radius(0.05, 2.0), side(0.3, 1.5);
  std::uniform_int_distribution<int> circles(1, 5);
  for (int trial = 0; trial < 150; ++trial) {
    const int n = circles(rng);
    std::vector<double> cu(n), cv(n), r(n);
    for (int i = 0; i < n; ++i) cu[i] = at(rng), cv[i] = at(rng), r[i] = radius(rng);
    if (trial % 5 == 0 && n > 1) cu[1] = cu[0], cv[1] = cv[0];  // concentric
    const double w = side(rng), h = side(rng);
    const double exact = circlesRectangleUnionArea(cu.data(), cv.data(), r.data(), n, w, h);
    CHECK_MESSAGE(std::abs(exact - unionIntegrated(cu, cv, r, w, h)) < 1e-6, "trial ", trial);
  }
  // Near-degenerate arcs: a circle whose edge barely dips into the rectangle (two crossings close
  // together, the long arc between them outside), one barely poking out of it (the long arc
  // inside), and two circles barely overlapping.
  for (const auto& [cu, cv, r] : {std::tuple<std::vector<double>, std::vector<double>, std::vector<double>>{{0.5}, {-0.999}, {1.0}},
                                  {{0.5}, {0.5}, {0.50001}},
                                  {{0.3, 0.7}, {0.5, 0.5}, {0.2, 0.200001}},
                                  {{0.5, 0.5}, {0.5, 0.5}, {0.3, 0.3000001}}}) {
    const double exact = circlesRectangleUnionArea(cu.data(), cv.data(), r.data(), static_cast<int>(cu.size()), 1, 1);
    CHECK(std::abs(exact - unionIntegrated(cu, cv, r, 1, 1)) < 1e-6);
  }
  // Exact tangencies (a review's cases): a circle touching sides, one inside another touching it
  // (also one ulp apart), one touching the bottom and crossing the top, three meeting at a point.
  const double below = std::nextafter(0.2, 0.0);
  for (const auto& [cu, cv, r, w, h] :
       {std::tuple<std::vector<double>, std::vector<double>, std::vector<double>, double, double>{{0.5}, {0.5}, {0.5}, 1, 1},
        {{0.75}, {0.5}, {0.25}, 1, 1},
        {{0.375, 0.5}, {0.5, 0.5}, {0.375, 0.25}, 1, 1},
        {{0.4, 0.5}, {0.5, 0.5}, {0.3, 0.2}, 1, 1},
        {{0.4, 0.5}, {0.5, 0.5}, {0.3, below}, 1, 1},
        {{0.5}, {0.3}, {0.3}, 1, 0.5},
        {{0.25, 0.75, 0.5}, {0.5, 0.5, 0.5 + 0.25 * std::sqrt(3.0)}, {0.25, 0.25, 0.25}, 1, 1}}) {
    const double exact = circlesRectangleUnionArea(cu.data(), cv.data(), r.data(), static_cast<int>(cu.size()), w, h);
    CHECK_MESSAGE(std::abs(exact - unionIntegrated(cu, cv, r, w, h)) < 1e-6, cu[0], " ", cv[0], " ", r[0], " ", w, " ", h);
  }
}

TEST_CASE("areas where arcs' ends nearly meet: two circles crossing on a side or at a corner, nearly one circle, a side tangent") {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> unit(0, 1), radius(0.2, 1.5), turn(0.1, kPi - 0.1);
  for (int trial = 0; trial < 600; ++trial) {
    std::vector<double> cu(2), cv(2), r{radius(rng), radius(rng)};
    const int kind = trial % 3;
    if (kind == 0) {  // meeting on the bottom side, from above or below it
      const double t = unit(rng);
      for (int i = 0; i < 2; ++i) {
        const double phi = turn(rng);
        cu[i] = t - r[i] * std::cos(phi), cv[i] = r[i] * std::sin(phi) * (unit(rng) < 0.5 ? 1 : -1);
      }
    } else if (kind == 1) {  // meeting at the corner (0, 0)
      for (int i = 0; i < 2; ++i) {
        const double phi = 2 * kPi * unit(rng);
        cu[i] = r[i] * std::cos(phi), cv[i] = r[i] * std::sin(phi);
      }
    } else {  // nearly the same circle: moved by 1e-16 to 1e-9
      const double e = std::exp(std::log(1e-16) + unit(rng) * std::log(1e7)), phi = 2 * kPi * unit(rng);
      cu[0] = unit(rng), cv[0] = unit(rng);
      cu[1] = cu[0] + e * std::cos(phi), cv[1] = cv[0] + e * std::sin(phi), r[1] = r[0] * (1 + e * (2 * unit(rng) - 1));
    }
    const double exact = circlesRectangleUnionArea(cu.data(), cv.data(), r.data(), 2, 1, 1);
    CHECK_MESSAGE(std::abs(exact - unionIntegrated(cu, cv, r, 1, 1)) < 1e-6, "trial ", trial);
  }
  // The top side tangent to the disk at the top, the circle leaving through both vertical sides.
  CHECK(std::abs(unitDiskRectangleArea(-0.5, 0.5, 0.2, 1) - integrated(-0.5, 0.5, 0.2, 1)) < 1e-8);
  CHECK(std::abs(unitDiskRectangleArea(-0.5, 0.5, -1, -0.2) - integrated(-0.5, 0.5, -1, -0.2)) < 1e-8);
}

TEST_CASE("a pixel's stratum of several silhouettes: the share of their union, and membership in any") {
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> offset(-1.0, 2.0), axis(0.2, 1.5);
  const double aspect = 1.25;  // pixels taller than wide: every ellipse's ay = ax / aspect
  int tested = 0;
  for (int i = 0; i < 120; ++i) {
    const int x = 3, y = 7, count = 2 + i % 2;
    PixelStratum::Ellipse e[3];
    for (int j = 0; j < count; ++j) {
      const double a = axis(rng);
      e[j] = {x + offset(rng), y + offset(rng), a, a / aspect};
    }
    const PixelStratum p = PixelStratum::of(x, y, e, count);
    if (!p.any()) continue;
    ++tested;
    CHECK(std::abs(gridShare(p, x, y) - double(p.share)) < 4e-3);
    for (int j = 0; j < count; ++j) CHECK(p.contains(e[j].cx, e[j].cy));  // each ellipse's centre is in the union
  }
  CHECK(tested > 40);
  // A pixel two silhouettes cross, neither covering it, whose union covers it: none.
  const PixelStratum::Ellipse halves[2] = {{0.0, 0.5, 0.8, 0.8}, {1.0, 0.5, 0.8, 0.8}};
  CHECK_FALSE(PixelStratum::of(0, 0, halves, 2).any());
  // Only the first kMostDisks (4) count.
  const PixelStratum::Ellipse five[5] = {{0, 0, 0.3, 0.3}, {1, 0, 0.3, 0.3}, {0, 1, 0.3, 0.3}, {1, 1, 0.3, 0.3}, {0.5, 0.5, 0.1, 0.1}};
  static_assert(PixelStratum::kMostDisks == 4);
  const PixelStratum q = PixelStratum::of(0, 0, five, 5);
  CHECK(q.disks == 4);
  CHECK(double(q.share) == doctest::Approx(kPi * 0.09).epsilon(1e-6));
  CHECK(q.contains(0.95, 0.95));
  CHECK_FALSE(q.contains(0.5, 0.5));
}

TEST_CASE("a point of a stratum's outside: in the pixel, a thousandth of a pixel clear of every ellipse, where a lattice finds one") {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> offset(-1.0, 2.0), axis(0.2, 3.0);
  const double aspect = 1.25;
  const auto clearance = [&](const PixelStratum::Ellipse* e, int count, double px, double py) {  // pixels, at least
    double least = std::numeric_limits<double>::infinity();
    for (int j = 0; j < count; ++j) {  // (radial distance to an ellipse over its largest axis's: under the true one's)
      const double u = (px - e[j].cx) / e[j].ax, v = (py - e[j].cy) / e[j].ay;
      least = std::min(least, (std::sqrt(u * u + v * v) - 1) * std::min(e[j].ax, e[j].ay));
    }
    return least;
  };
  int found = 0, none = 0, small = 0;
  for (int i = 0; i < 800; ++i) {
    const int x = 40, y = -12, count = 1 + i % 4;
    PixelStratum::Ellipse e[4];
    for (int j = 0; j < count; ++j) {
      const double a = axis(rng);
      e[j] = {x + offset(rng), y + offset(rng), a, a / aspect};
    }
    const PixelStratum p = PixelStratum::of(x, y, e, count);
    if (!p.any()) continue;
    double u = -1, v = -1;
    if (!p.outsidePoint(x, y, u, v)) {
      // Nothing outside, or a sliver between the finest lattice's points (1/64 of a pixel from a side).
      CHECK(gridShare(p, x, y) > 1 - 0.04);
      ++none;
      continue;
    }
    ++found;
    small += 1 - double(p.share) < 0.05;
    CHECK((u > 0 && u < 1 && v > 0 && v < 1));
    CHECK_FALSE(p.contains(x + u, y + v));
    CHECK(clearance(e, count, x + u, y + v) > 1e-3 * (1 - 1e-6));
  }
  CHECK(found > 150);
  CHECK(small >= 5);
  CHECK(none >= 3);
  // A corner's sliver of 0.0044 of the pixel beside a wide disk is found; the pixel a disk covers has none.
  const PixelStratum::Ellipse wide{-2.4, -2.4, 4.74, 4.74};
  const PixelStratum corner = PixelStratum::of(0, 0, &wide, 1);
  REQUIRE(corner.any());
  const double sliver = 1 - double(corner.share);
  CHECK((sliver > 0.003 && sliver < 0.006));
  double u = 0, v = 0;
  REQUIRE(corner.outsidePoint(0, 0, u, v));
  CHECK((u > 0.9 && v > 0.9));
  const PixelStratum::Ellipse over{0.5, 0.5, 0.8, 0.8};
  CHECK_FALSE(PixelStratum::shaped(&over, 1).filling().outsidePoint(0, 0, u, v));
}

namespace {

// The unit disk's area within the convex polygon (u[i], v[i]) by the midpoint rule over x of the
// disk's chord clipped to the polygon's span at x (error ~1e-8 with this many steps).
// The span [low, high] of the convex polygon (u[i], v[i], counter-clockwise) along the vertical line
// at x, cut from [low, high] (the disk's chord there).
void clipToPolygon(const double* u, const double* v, int count, double x, double& low, double& high) {
  for (int e = 0; e < count; ++e) {
    const int f = (e + 1) % count;
    const double ex = u[f] - u[e], ey = v[f] - v[e];  // counter-clockwise: the inside on the left
    // ex (y - v[e]) - ey (x - u[e]) >= 0
    if (ex > 0) low = std::max(low, v[e] + ey * (x - u[e]) / ex);
    else if (ex < 0) high = std::min(high, v[e] + ey * (x - u[e]) / ex);
    else if (-ey * (x - u[e]) < 0) high = low;  // a vertical edge with x outside it
  }
}

double integratedPolygon(const double* u, const double* v, int count) {
  const int steps = 200000;
  const double h = 2.0 / steps;
  double sum = 0;
  for (int i = 0; i < steps; ++i) {
    const double x = -1 + (i + 0.5) * h, s = std::sqrt(1 - x * x);
    double low = -s, high = s;
    clipToPolygon(u, v, count, x, low, high);
    sum += std::max(0.0, high - low);
  }
  return sum * h;
}

}  // namespace

TEST_CASE("the unit disk's area within a convex polygon: rectangles, parallelograms, either order") {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> at(-1.6, 1.6), size(0.01, 1.5), slant(-1.5, 1.5);
  for (int i = 0; i < 200; ++i) {  // rectangles: as unitDiskRectangleArea, in either order
    const double u0 = at(rng), v0 = at(rng), u1 = u0 + size(rng), v1 = v0 + size(rng);
    const double u[4] = {u0, u1, u1, u0}, v[4] = {v0, v0, v1, v1};
    const double ru[4] = {u0, u0, u1, u1}, rv[4] = {v0, v1, v1, v0};
    const double expected = unitDiskRectangleArea(u0, u1, v0, v1);
    CHECK(std::abs(unitDiskPolygonArea(u, v, 4) - expected) < 1e-13);
    CHECK(std::abs(unitDiskPolygonArea(ru, rv, 4) - expected) < 1e-13);
  }
  for (int i = 0; i < 150; ++i) {  // parallelograms, counter-clockwise
    const double u0 = at(rng), v0 = at(rng), a = size(rng), b = size(rng), s = slant(rng);
    const double u[4] = {u0, u0 + a, u0 + a + s * b, u0 + s * b}, v[4] = {v0, v0, v0 + b, v0 + b};
    const double area = unitDiskPolygonArea(u, v, 4);
    CHECK_MESSAGE(std::abs(area - integratedPolygon(u, v, 4)) < 1e-7, u0, " ", v0, " ", a, " ", b, " ", s);
  }
  // Exact cases: a square around the disk, a triangle inside it, a polygon beside it, a half-plane's
  // square cut through the centre, and one whose edge touches the circle.
  const double bigU[4] = {-2, 2, 2, -2}, bigV[4] = {-2, -2, 2, 2};
  CHECK(unitDiskPolygonArea(bigU, bigV, 4) == doctest::Approx(kPi).epsilon(1e-15));
  const double triU[3] = {0, 0.5, 0}, triV[3] = {0, 0, 0.5};
  CHECK(unitDiskPolygonArea(triU, triV, 3) == doctest::Approx(0.125).epsilon(1e-15));
  const double farU[4] = {1.5, 3, 3, 1.5}, farV[4] = {-1, -1, 1, 1};
  CHECK(unitDiskPolygonArea(farU, farV, 4) == 0);
  const double halfU[4] = {0, 2, 2, 0}, halfV[4] = {-2, -2, 2, 2};
  CHECK(unitDiskPolygonArea(halfU, halfV, 4) == doctest::Approx(kPi / 2).epsilon(1e-15));
  const double touchU[4] = {1, 2, 2, 1}, touchV[4] = {-1, -1, 1, 1};
  CHECK(unitDiskPolygonArea(touchU, touchV, 4) == 0);
}

TEST_CASE("a rotated ellipse's stratum: its share is the fraction of the pixel it covers; unsheared, the axis-aligned one's") {
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> offset(-1.5, 2.5), inverse(0.4, 3.0), shear(-2.0, 2.0);
  int tested = 0;
  for (int i = 0; i < 200; ++i) {
    const int x = 5, y = 9;
    const double l11 = inverse(rng), l22 = inverse(rng), l12 = shear(rng);
    const PixelStratum p = PixelStratum::sheared(x, y, x + offset(rng), y + offset(rng), l11, l12, l22);
    if (!p.any()) continue;
    ++tested;
    CHECK(std::abs(gridShare(p, x, y) - double(p.share)) < 4e-3);
  }
  CHECK(tested > 50);
  // Without shear, the same stratum as the axis-aligned ellipse's of semi-axes 1 / l11, 1 / l22.
  for (int i = 0; i < 100; ++i) {
    const double cx = 3 + offset(rng), cy = 4 + offset(rng), l11 = inverse(rng), l22 = inverse(rng);
    const PixelStratum a = PixelStratum::sheared(3, 4, cx, cy, double(float(l11)), 0.0, double(float(l22)));
    const PixelStratum b = PixelStratum::of(3, 4, cx, cy, 1 / double(float(l11)), 1 / double(float(l22)));
    CHECK(a.any() == b.any());
    if (a.any() && b.any()) CHECK(std::abs(double(a.share) - double(b.share)) < 1e-6);
  }
  // Covering the pixel, or beside it: none; one reaching farther than kMostAxis: none.
  CHECK_FALSE(PixelStratum::sheared(0, 0, 0.5, 0.5, 0.2, 0.1, 0.2).any());
  CHECK_FALSE(PixelStratum::sheared(0, 0, 5, 5, 1, 0.5, 1).any());
  CHECK_FALSE(PixelStratum::sheared(0, 0, 0.5, 0.5 + 1e5, 1e-5, 0, 1e-5).any());
}

namespace {

// A sphere's front over the unit disk's part of [u0, u1] x [v0, v1]: the integrals of 1, u, v and
// w = sqrt(1 - u^2 - v^2), by the midpoint rule over u of the chord's part within [v0, v1] (each
// closed form along v).
std::array<double, 4> momentsIntegrated(double u0, double u1, double v0, double v1) {
  const int steps = 200000;
  const double a = std::max(u0, -1.0), b = std::min(u1, 1.0);
  std::array<double, 4> sum{};
  if (a >= b) return sum;
  const double h = (b - a) / steps;
  for (int i = 0; i < steps; ++i) {
    const double u = a + (i + 0.5) * h, s = std::sqrt(1 - u * u), lo = std::max(v0, -s), hi = std::min(v1, s);
    if (!(lo < hi)) continue;
    // The integral of sqrt(s^2 - v^2) dv: (v sqrt(s^2 - v^2) + s^2 asin(v / s)) / 2.
    const auto w = [&](double v) { return (v * std::sqrt(std::max(0.0, s * s - v * v)) + s * s * std::asin(std::clamp(v / s, -1.0, 1.0))) / 2; };
    sum[0] += hi - lo, sum[1] += u * (hi - lo), sum[2] += (hi * hi - lo * lo) / 2, sum[3] += w(hi) - w(lo);
  }
  for (double& x : sum) x *= h;
  return sum;
}

// The integral over [from, to] of max(0, slope t + offset + c sqrt(s2 - t^2)) dt (a light's cosine
// along a chord of the unit disk at half-length sqrt(s2)), exact: split where it changes sign (with c
// 0, where slope t + offset does: the quadratic's double root, which rounding may lose).
double clampedAlongChord(double slope, double offset, double c, double s2, double from, double to) {
  const double s = std::sqrt(s2);
  const auto root = [&](double t) { return std::sqrt(std::max(0.0, s2 - t * t)); };
  const auto cosine = [&](double t) { return slope * t + offset + c * root(t); };
  const auto antiderivative = [&](double t) {
    return slope * t * t / 2 + offset * t + c / 2 * (t * root(t) + s2 * std::asin(std::clamp(t / s, -1.0, 1.0)));
  };
  std::vector<double> ends{from, to};
  // The discriminant qb^2 - 4 qa qc as 4 c^2 (qa s2 - offset^2), which does not cancel where c is near 0.
  const double qa = slope * slope + c * c, qb = 2 * slope * offset, qc = offset * offset - c * c * s2, d = 4 * c * c * (qa * s2 - offset * offset);
  if (d > 0 && qa > 0) {  // the roots in the form that does not cancel
    const double q = -(qb + std::copysign(std::sqrt(d), qb)) / 2;
    for (const double t : {q / qa, q != 0 ? qc / q : -q / qa}) {
      if (t > from && t < to) ends.push_back(t);
    }
  }
  if (c == 0 && slope != 0 && -offset / slope > from && -offset / slope < to) ends.push_back(-offset / slope);
  std::sort(ends.begin(), ends.end());
  double sum = 0;
  for (size_t k = 0; k + 1 < ends.size(); ++k) {
    if (cosine((ends[k] + ends[k + 1]) / 2) > 0) sum += antiderivative(ends[k + 1]) - antiderivative(ends[k]);
  }
  return sum;
}

// The area of the unit disk's part of [u0, u1] x [v0, v1] within `count` circles, and the integral
// over it of max(0, a u + b v + c w): the midpoint rule over v of each chord's part (the disk's,
// clipped to the rectangle and to each circle's chord), exact along u (clampedAlongChord).
std::array<double, 2> clippedIntegrated(double u0, double u1, double v0, double v1, const double* cu, const double* cv,
                                        const double* cr, int count, double a, double b, double c) {
  const int steps = 40000;
  const double lo = std::max(v0, -1.0), hi = std::min(v1, 1.0);
  std::array<double, 2> sum{};
  if (lo >= hi) return sum;
  const double h = (hi - lo) / steps;
  for (int i = 0; i < steps; ++i) {
    const double v = lo + (i + 0.5) * h, s2 = 1 - v * v, s = std::sqrt(s2);
    double from = std::max(u0, -s), to = std::min(u1, s);
    for (int k = 0; k < count; ++k) {
      const double dv = v - cv[k], half2 = cr[k] * cr[k] - dv * dv;
      if (!(half2 > 0)) from = to;
      const double half = std::sqrt(std::max(0.0, half2));
      from = std::max(from, cu[k] - half), to = std::min(to, cu[k] + half);
    }
    if (from < to) sum[0] += to - from, sum[1] += clampedAlongChord(a, b * v, c, s2, from, to);
  }
  return {sum[0] * h, sum[1] * h};
}

}  // namespace

TEST_CASE("a sphere's front over the unit disk's part of a rectangle: its area, its normal's integrals, and where a light lights it all") {
  // The whole disk: area pi, the normal's u and v integrate to 0, w to the hemisphere's volume 2 pi / 3.
  const UnitDiskPart whole(-2, 2, -2, 2);
  CHECK(whole.area == doctest::Approx(kPi).epsilon(1e-14));
  CHECK(std::abs(whole.u) < 1e-14);
  CHECK(std::abs(whole.v) < 1e-14);
  CHECK(whole.w == doctest::Approx(2 * kPi / 3).epsilon(1e-14));
  // The right half: u's integral is 2/3 (the half disk's first moment), v's 0.
  const UnitDiskPart right(0, 2, -2, 2);
  CHECK(right.area == doctest::Approx(kPi / 2).epsilon(1e-14));
  CHECK(right.u == doctest::Approx(2.0 / 3).epsilon(1e-14));
  CHECK(std::abs(right.v) < 1e-14);
  CHECK(right.w == doctest::Approx(kPi / 3).epsilon(3e-6));
  // A light toward the viewer lights the whole front, to its rim: the moments' w; one from -u leaves
  // the half dark (0 exactly); one from +v lights its upper quarter (the terminator along v = 0),
  // whose first moment in v is 1/3.
  CHECK(right.clampedIntegral(0, 0, 1) == doctest::Approx(right.w).epsilon(1e-15));
  CHECK(right.clampedIntegral(-1, 0, 0) == 0);
  CHECK(right.clampedIntegral(0, 1, 0) == doctest::Approx(1.0 / 3).epsilon(1e-14));
  const UnitDiskPart apart(1.2, 2, 0, 1);
  CHECK(apart.area == 0);
  CHECK(apart.w == 0);
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> normal;
  int tested = 0, lit = 0, dark = 0, crossed = 0;
  for (int trial = 0; trial < 150; ++trial) {
    // A pixel's square in the frame of a disk of radius 0.3 to 5 pixels, where the disk reaches it.
    const double r = 0.3 + 4.7 * unit(rng), cx = -r - 1 + (2 * r + 1) * unit(rng), cy = -r - 1 + (2 * r + 1) * unit(rng);
    const double u0 = -cx / r, u1 = (1 - cx) / r, v0 = -cy / r, v1 = (1 - cy) / r;
    const UnitDiskPart part(u0, u1, v0, v1);
    if (!(part.area > 0)) continue;
    ++tested;
    const std::array<double, 4> expected = momentsIntegrated(u0, u1, v0, v1);
    // In the pixel's units (times r^2): the area's and the first moments' error is the midpoint
    // rule's; w's the fans' quadrature's (6 points: within 1e-5 of the pixel).
    CHECK_MESSAGE(std::abs(part.area - expected[0]) * r * r < 1e-8, trial);
    CHECK_MESSAGE(std::abs(part.u - expected[1]) * r * r < 1e-8, trial);
    CHECK_MESSAGE(std::abs(part.v - expected[2]) * r * r < 1e-8, trial);
    CHECK_MESSAGE(std::abs(part.w - expected[3]) * r * r < 1e-5, trial);
    CHECK(part.area == doctest::Approx(unitDiskRectangleArea(u0, u1, v0, v1)).epsilon(1e-12));
    // A light in a random direction, and its cosine's extremes over a 200 x 200 grid of the part's
    // points.
    double l[3] = {normal(rng), normal(rng), normal(rng)};
    const double length = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    for (double& x : l) x /= length;
    double darkest = 2, brightest = -2;
    for (int i = 0; i < 200; ++i) {
      for (int j = 0; j < 200; ++j) {
        const double u = std::max(u0, -1.0) + (std::min(u1, 1.0) - std::max(u0, -1.0)) * (i + 0.5) / 200;
        const double v = std::max(v0, -1.0) + (std::min(v1, 1.0) - std::max(v0, -1.0)) * (j + 0.5) / 200;
        if (u * u + v * v >= 1) continue;
        const double cosine = l[0] * u + l[1] * v + l[2] * std::sqrt(1 - u * u - v * v);
        darkest = std::min(darkest, cosine), brightest = std::max(brightest, cosine);
      }
    }
    // Its clamped cosine's integral, in the pixel's units; lit all over (no point of the grid within
    // 1e-3 of the terminator or beyond it), the cosine's, whose integral is the moments'; dark all
    // over, 0 exactly.
    const double clamped = part.clampedIntegral(l[0], l[1], l[2]);
    CHECK_MESSAGE(std::abs(clamped - clippedIntegrated(u0, u1, v0, v1, nullptr, nullptr, nullptr, 0, l[0], l[1], l[2])[1]) * r * r < 1e-5, trial);
    if (darkest > 1e-3) CHECK(std::abs(clamped - (l[0] * part.u + l[1] * part.v + l[2] * part.w)) * r * r < 1e-12);
    if (brightest < -1e-3) CHECK(clamped == 0);
    lit += darkest > 1e-3, dark += brightest < -1e-3, crossed += darkest < -1e-3 && brightest > 1e-3;
  }
  CHECK(tested > 80);
  CHECK(lit > 10);
  CHECK(dark > 10);
  CHECK(crossed > 10);
}

namespace {

// A sphere's front over the unit disk's part of a convex polygon: the integrals of 1, u, v, w and
// of max(0, a u + b v + c w), by the midpoint rule over u of each chord's part within the polygon,
// exact along v (clampedAlongChord).
std::array<double, 5> polygonIntegrated(const double* pu, const double* pv, int count, double a, double b, double c) {
  const int steps = 100000;
  const double from = std::max(-1.0, *std::min_element(pu, pu + count)), to = std::min(1.0, *std::max_element(pu, pu + count));
  const double h = (to - from) / steps;
  std::array<double, 5> sum{};
  for (int i = 0; i < steps && from < to; ++i) {
    const double u = from + (i + 0.5) * h, s2 = 1 - u * u, s = std::sqrt(s2);
    double lo = -s, hi = s;
    clipToPolygon(pu, pv, count, u, lo, hi);
    if (!(lo < hi)) continue;
    const auto w = [&](double v) { return (v * std::sqrt(std::max(0.0, s2 - v * v)) + s2 * std::asin(std::clamp(v / s, -1.0, 1.0))) / 2; };
    sum[0] += hi - lo, sum[1] += u * (hi - lo), sum[2] += (hi * hi - lo * lo) / 2, sum[3] += w(hi) - w(lo);
    sum[4] += clampedAlongChord(b, a * u, c, s2, lo, hi);
  }
  for (double& x : sum) x *= h;
  return sum;
}

}  // namespace

TEST_CASE("a sphere's front over the unit disk's part of a parallelogram: as a rectangle's where it is one, and numerical integration") {
  using Point = DiskPieces::Point;
  std::mt19937_64 rng(37);
  std::uniform_real_distribution<double> unit(0, 1), slant(-1.5, 1.5);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 100; ++trial) {  // a rectangle given by its corners is the rectangle
    const double u0 = -2 + 3 * unit(rng), v0 = -2 + 3 * unit(rng), u1 = u0 + 0.01 + 1.5 * unit(rng), v1 = v0 + 0.01 + 1.5 * unit(rng);
    const Point corner[4] = {{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}};
    const UnitDiskPart rectangle(u0, u1, v0, v1), polygon(corner, 4);
    CHECK_MESSAGE(std::abs(polygon.area - rectangle.area) < 1e-13, trial);
    CHECK_MESSAGE(std::abs(polygon.u - rectangle.u) < 1e-13, trial);
    CHECK_MESSAGE(std::abs(polygon.v - rectangle.v) < 1e-13, trial);
    CHECK_MESSAGE(std::abs(polygon.w - rectangle.w) < 1e-6, trial);  // the fans' quadrature, differently cut
  }
  const Point around[4] = {{-2, -2}, {2, -2}, {2.5, 2}, {-1.5, 2}};  // holds the whole disk
  const UnitDiskPart whole(around, 4);
  CHECK(whole.area == doctest::Approx(kPi).epsilon(1e-14));
  CHECK(whole.w == doctest::Approx(2 * kPi / 3).epsilon(1e-14));
  const Point beside[4] = {{1.1, -1}, {3, -1}, {3.5, 1}, {1.6, 1}};
  CHECK(UnitDiskPart(beside, 4).area == 0);
  int tested = 0;
  for (int trial = 0; trial < 120; ++trial) {
    // A pixel's square in the frame of a sheared ellipse of 0.3 to 5 pixels (u = (x l11 + y l12),
    // v = y l22), where the disk reaches it.
    const double l11 = 1 / (0.3 + 4.7 * unit(rng)), l22 = 1 / (0.3 + 4.7 * unit(rng)), l12 = slant(rng) * std::min(l11, l22);
    const double x0 = -1 / l11 - 2 + (2 / l11 + 3) * unit(rng), y0 = -1 / l22 - 1 + (2 / l22 + 1) * unit(rng);
    Point corner[4];
    const double xs[4] = {x0, x0 + 1, x0 + 1, x0}, ys[4] = {y0, y0, y0 + 1, y0 + 1};
    double pu[4], pv[4];
    for (int k = 0; k < 4; ++k) corner[k] = {xs[k] * l11 + ys[k] * l12, ys[k] * l22}, pu[k] = corner[k].u, pv[k] = corner[k].v;
    const UnitDiskPart part(corner, 4);
    if (!(part.area > 0)) continue;
    ++tested;
    double l[3] = {normal(rng), normal(rng), normal(rng)};
    const double length = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    for (double& x : l) x /= length;
    const std::array<double, 5> expected = polygonIntegrated(pu, pv, 4, l[0], l[1], l[2]);
    const double scale = 1 / (l11 * l22);  // the frame's area of a pixel: errors in the pixel's units
    CHECK_MESSAGE(std::abs(part.area - expected[0]) * scale < 1e-7, trial);
    CHECK_MESSAGE(std::abs(part.u - expected[1]) * scale < 1e-7, trial);
    CHECK_MESSAGE(std::abs(part.v - expected[2]) * scale < 1e-7, trial);
    CHECK_MESSAGE(std::abs(part.w - expected[3]) * scale < 3e-5, trial);
    CHECK(part.area == doctest::Approx(unitDiskPolygonArea(pu, pv, 4)).epsilon(1e-12));
    CHECK_MESSAGE(std::abs(part.clampedIntegral(l[0], l[1], l[2]) - expected[4]) * scale < 1e-5, trial);
  }
  CHECK(tested > 60);
}

TEST_CASE("a sphere's front over its disk's part of a pixel within other disks: area and clamped cosine, against numerical integration") {
  // Within a circle that holds the whole part: the part's; a circle inside the part: its area.
  const double far[1] = {5}, big[1] = {10};
  const UnitDiskPart whole(-0.3, 0.4, -0.2, 0.5);
  const ClippedDiskPart held(-0.3, 0.4, -0.2, 0.5, far, far, big, 1);
  CHECK(held.area == doctest::Approx(whole.area).epsilon(1e-13));
  CHECK(std::abs(held.clampedIntegral(0.3, -0.2, 0.9) - whole.clampedIntegral(0.3, -0.2, 0.9)) < 1e-9);
  const double inU[1] = {0.05}, inV[1] = {0.1}, small[1] = {0.15};
  const ClippedDiskPart within(-0.3, 0.4, -0.2, 0.5, inU, inV, small, 1);
  CHECK(within.area == doctest::Approx(kPi * 0.15 * 0.15).epsilon(1e-13));
  const double awayU[1] = {3}, awayV[1] = {0}, one[1] = {1};
  CHECK(ClippedDiskPart(-0.3, 0.4, -0.2, 0.5, awayU, awayV, one, 1).area == 0);
  std::mt19937_64 rng(47);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> normal;
  int tested = 0, cut = 0;
  for (int trial = 0; trial < 160; ++trial) {
    // A pixel's square in the frame of a disk of radius 0.3 to 5 pixels, and one or two more disks of
    // 0.3 to 5 pixels overlapping it near the pixel.
    const double r = 0.3 + 4.7 * unit(rng), cx = -r - 1 + (2 * r + 1) * unit(rng), cy = -r - 1 + (2 * r + 1) * unit(rng);
    const double u0 = -cx / r, u1 = (1 - cx) / r, v0 = -cy / r, v1 = (1 - cy) / r;
    const int circles = 1 + trial % 2;
    double cu[2], cv[2], cr[2];
    for (int k = 0; k < circles; ++k) {
      cr[k] = (0.3 + 4.7 * unit(rng)) / r;
      cu[k] = (u0 + u1) / 2 + (unit(rng) - 0.5) * 2 * (cr[k] + 1 / r), cv[k] = (v0 + v1) / 2 + (unit(rng) - 0.5) * 2 * (cr[k] + 1 / r);
    }
    double l[3] = {normal(rng), normal(rng), normal(rng)};
    const double length = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    for (double& x : l) x /= length;
    const ClippedDiskPart part(u0, u1, v0, v1, cu, cv, cr, circles);
    const std::array<double, 2> expected = clippedIntegrated(u0, u1, v0, v1, cu, cv, cr, circles, l[0], l[1], l[2]);
    // In the pixel's units (times r^2): the area's error is the midpoint rule's, the clamped
    // cosine's the fans' quadrature's.
    CHECK_MESSAGE(std::abs(part.area - expected[0]) * r * r < 1e-7, trial);
    CHECK_MESSAGE(std::abs(part.clampedIntegral(l[0], l[1], l[2]) - expected[1]) * r * r < 1e-5, trial);
    ++tested;
    cut += expected[0] > 0 && expected[0] < UnitDiskPart(u0, u1, v0, v1).area - 1e-9;
  }
  CHECK(tested == 160);
  CHECK(cut > 30);
}

TEST_CASE("the clamped cosine's closed forms hold for lights in the view's plane, nearly so, and straight along the view") {
  // The terminator seen edge on (c 0 or 1e-9: the rays' stretch before it shrinks to nothing), or as
  // the rim (a = b = 0), against numerical integration; over a disk's part alone and within one more
  // disk (ClippedDiskPart's arcs). Within 1e-5 of the pixel (w's quadrature near the rim).
  std::mt19937_64 rng(53);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 90; ++trial) {
    const double r = 0.3 + 4.7 * unit(rng), cx = -r - 1 + (2 * r + 1) * unit(rng), cy = -r - 1 + (2 * r + 1) * unit(rng);
    const double u0 = -cx / r, u1 = (1 - cx) / r, v0 = -cy / r, v1 = (1 - cy) / r;
    double l[3] = {normal(rng), normal(rng), normal(rng)};
    if (trial % 3 == 0) l[2] = 0;
    if (trial % 3 == 1) l[2] *= 1e-9;
    if (trial % 3 == 2) l[0] = l[1] = 0;
    const double length = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    for (double& x : l) x /= length;
    const double expected = clippedIntegrated(u0, u1, v0, v1, nullptr, nullptr, nullptr, 0, l[0], l[1], l[2])[1];
    CHECK_MESSAGE(std::abs(UnitDiskPart(u0, u1, v0, v1).clampedIntegral(l[0], l[1], l[2]) - expected) * r * r < 1e-5, trial);
    const double cr[1] = {(0.3 + 4.7 * unit(rng)) / r};
    const double cu[1] = {(u0 + u1) / 2 + (unit(rng) - 0.5) * 2 * (cr[0] + 1 / r)}, cv[1] = {(v0 + v1) / 2 + (unit(rng) - 0.5) * 2 * (cr[0] + 1 / r)};
    const double clipped = clippedIntegrated(u0, u1, v0, v1, cu, cv, cr, 1, l[0], l[1], l[2])[1];
    CHECK_MESSAGE(std::abs(ClippedDiskPart(u0, u1, v0, v1, cu, cv, cr, 1).clampedIntegral(l[0], l[1], l[2]) - clipped) * r * r < 1e-5, trial);
  }
}
