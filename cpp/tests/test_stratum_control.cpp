// The strata's control variates (StratumControl.h): each one's mean over its stratum's inside is
// its exact integral, so that the samples less their controls stay unbiased. Checked by numerical
// integration of the per-sample control over the inside of random pixels: along each row exactly
// piecewise (Gauss-Legendre between the disks' edges and the lights' terminators, where the control
// is smooth), the midpoint rule across the rows.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "durer/accel/SphereView.h"
#include "durer/render/StratumControl.h"

using namespace durer;

namespace {

// Roots x in (x0, x1) of a u^2 + b u + c = 0 for u = u0 + du x (|du| > 0), appended to `out`.
void rootsAlong(double a, double b, double c, double u0, double du, double x0, double x1, std::vector<double>& out) {
  const auto add = [&](double u) {
    const double x = (u - u0) / du;
    if (x > x0 && x < x1) out.push_back(x);
  };
  if (a == 0) {
    if (b != 0) add(-c / b);
    return;
  }
  const double d = b * b - 4 * a * c;
  if (d < 0) return;
  add((-b + std::sqrt(d)) / (2 * a)), add((-b - std::sqrt(d)) / (2 * a));
}

// The integral over pixel (x, y)'s part inside stratum p of f(sx, sy) (a control's channel sum),
// and the inside's area; `lights[i]`: the light directions (a, b, c) member i's shading reads in
// its frame, whose terminators cut the rows.
template <typename F, typename Seam>
std::array<double, 2> integrateInside(const PixelStratum& p, int x, int y, const std::vector<std::vector<Vec3d>>& lights, const F& f,
                                      const Seam& seam) {
  static constexpr double kNode[8] = {0.019855071751231856, 0.10166676129318664, 0.23723379504183550, 0.40828267875217510,
                                      0.59171732124782490, 0.76276620495816450, 0.89833323870681336, 0.98014492824876811};
  static constexpr double kWeight[8] = {0.050614268145188130, 0.11119051722668724, 0.15685332293894364, 0.18134189168918099,
                                        0.18134189168918099, 0.15685332293894364, 0.11119051722668724, 0.050614268145188130};
  const int rows = 3000;
  std::array<double, 2> sum{};
  for (int r = 0; r < rows; ++r) {
    const double sy = y + (r + 0.5) / rows;
    std::vector<double> cut{double(x), double(x + 1)};
    for (int i = 0; i < p.disks; ++i) {
      double u0, v, u1, unused;  // u along the row is linear in x: u0 at x's 0, du a unit's change
      p.frame(i, 0.0, sy, u0, v), p.frame(i, 1.0, sy, u1, unused);
      const double du = u1 - u0;
      rootsAlong(1, 0, v * v - 1, u0, du, x, x + 1, cut);  // the disk's edge
      for (const Vec3d& l : lights[size_t(i)]) {  // (l.x u + l.y v)^2 = l.z^2 (1 - u^2 - v^2)
        rootsAlong(l.x * l.x + l.z * l.z, 2 * l.x * l.y * v, l.y * l.y * v * v - l.z * l.z * (1 - v * v), u0, du, x, x + 1, cut);
      }
    }
    std::sort(cut.begin(), cut.end());
    // Where seam(x, y) changes along the row (the sphere seen, where disks overlap): found on 64
    // points between the cuts, then by bisection.
    for (size_t k = 0, n = cut.size(); k + 1 < n; ++k) {
      for (int step = 0; step < 64; ++step) {
        double lo = cut[k] + (cut[k + 1] - cut[k]) * step / 64, hi = cut[k] + (cut[k + 1] - cut[k]) * (step + 1) / 64;
        const int from = seam(lo, sy);
        if (seam(hi, sy) == from) continue;
        for (int it = 0; it < 50; ++it) ((seam((lo + hi) / 2, sy) == from) ? lo : hi) = (lo + hi) / 2;
        cut.push_back((lo + hi) / 2);
      }
    }
    std::sort(cut.begin(), cut.end());
    for (size_t k = 0; k + 1 < cut.size(); ++k) {
      const double a = cut[k], length = cut[k + 1] - a;
      for (int j = 0; j < 8; ++j) {
        const double sx = a + length * kNode[j];
        if (!p.contains(sx, sy)) continue;
        sum[0] += kWeight[j] * length * f(sx, sy), sum[1] += kWeight[j] * length;
      }
    }
  }
  for (double& s : sum) s /= rows;
  return sum;
}

double channels(const Vec3d& v) { return v.x + v.y + v.z; }

// `suns` (1 or 2) directional lights from random directions, the ambient light (0.1, 0.15, 0.2), and
// each light's direction for each of n members' rows (integrateInside's `lights`).
ControlLighting randomLighting(int suns, int n, std::mt19937_64& rng, std::normal_distribution<double>& normal,
                               std::vector<std::vector<Vec3d>>& toward) {
  ControlLighting light;
  light.ambient = Vec3d(0.1, 0.15, 0.2);
  light.suns = suns;
  toward.assign(static_cast<size_t>(n), {});
  for (int l = 0; l < light.suns; ++l) {
    Vec3d d(normal(rng), normal(rng), normal(rng));
    d /= std::sqrt(dot(d, d));
    light.sun[l] = {d.x, d.y, d.z, Vec3d(0.9, 0.8, 0.7) * (l + 1.0)};
    for (auto& t : toward) t.push_back(d);
  }
  return light;
}

// The member of stratum p seen at (x, y): the nearest front among the disks holding it (-1: none).
int seenMember(const PixelStratum& p, const ControlMember* member, double x, double y) {
  int nearest = -1;
  double front = 1e300;
  for (int i = 0; i < p.disks; ++i) {
    double u, v;
    p.frame(i, x, y, u, v);
    if (!(u * u + v * v < 1)) continue;
    const double f = member[i].centre.z - std::sqrt(1 - u * u - v * v) / double(p.inverseAx[i]);
    if (f < front) front = f, nearest = i;
  }
  return nearest;
}

// How far, at (x, y), the colour of the diffuse member seen there less control c is from c's mean
// (its largest channel; 0 where no member is seen).
double leftAt(const PixelStratum& p, const StratumControl& c, const ControlMember* member, const ControlLighting& light, double x, double y) {
  const int i = seenMember(p, member, x, y);
  if (i < 0) return 0;
  double u, v;
  p.frame(i, x, y, u, v);
  const double w = std::sqrt(1 - u * u - v * v);
  Vec3d shading = light.ambient;
  for (int l = 0; l < light.suns; ++l) {
    shading += std::max(0.0, light.sun[l].a * u + light.sun[l].b * v + light.sun[l].c * w) * light.sun[l].color;
  }
  const Vec3d left = Vec3d(Vec3<float>(member[i].kd)) * shading - diskControlAt(p, c, light, x, y) - Vec3d(c.mean);
  return std::max({std::abs(left.x), std::abs(left.y), std::abs(left.z)});
}

}  // namespace

TEST_CASE("an orthographic stratum's control integrates to 0 over its inside, and is the shading of the sphere seen less its mean") {
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> normal;
  int tested = 0, overlapping = 0, cutting = 0, changing = 0, refused = 0, unsplit = 0;
  for (int trial = 0; trial < 600 && tested < 120; ++trial) {
    // Two or three disks of 0.4-3 pixels' radius near pixel (0, 0); pixel units across and down;
    // their spheres' centres 0-3 units deep (many cut through each other) or 0-20.
    const int n = 2 + (trial % 3 == 0);
    const double deep = trial % 2 ? 3 : 20;
    PixelStratum::Ellipse e[3];
    ControlMember member[3];
    bool cut = false;
    for (int i = 0; i < n; ++i) {
      const double r = 0.4 + 2.6 * unit(rng), cx = -r + (1 + 2 * r) * unit(rng), cy = -r + (1 + 2 * r) * unit(rng);
      e[i] = {cx, cy, r, r};
      member[i] = {Vec3d(unit(rng), unit(rng), unit(rng)), Vec3d(cx, -cy, deep * unit(rng)), r};
    }
    bool overlaps = false;  // their disks' overlap, in the pixel's aspect (1 here)
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < i; ++j) {
        const Vec3d d = member[i].centre - member[j].centre;
        const bool overlap = std::hypot(e[i].cx - e[j].cx, e[i].cy - e[j].cy) < e[i].ax + e[j].ax;
        overlaps = overlaps || overlap;
        cut = cut || (overlap && std::sqrt(dot(d, d)) < member[i].radius + member[j].radius);
      }
    }
    const PixelStratum p = PixelStratum::of(0, 0, e, n);
    if (!p.any()) continue;
    std::vector<std::vector<Vec3d>> toward;
    const ControlLighting light = randomLighting(1 + trial % 2, n, rng, normal, toward);
    const StratumControl c = diskControl(0, 0, p, member, light, true, 0);
    if (!diskControl(0, 0, p, member, light, false, 0).any() && c.any()) ++unsplit;  // one seen changes: split only if asked
    if (!c.any()) {
      refused += cut;
      continue;
    }
    ++tested, overlapping += overlaps, cutting += cut;
    if (n == 2 && cut) {  // the sphere seen changes inside their overlap in the pixel (seenWithin)
      PixelBall ball[2];
      for (int i = 0; i < 2; ++i) ball[i] = {double(p.cx[i]), double(p.cy[i]) * double(p.aspect), member[i].centre.z, 1 / double(p.inverseAx[i])};
      changing += seenWithin(ball[0], ball[1], 0, 1, 0, double(p.aspect)) == 0;
    }
    const auto seen = [&](double x, double y) { return seenMember(p, member, x, y); };
    const auto [integral, inside] =
        integrateInside(p, 0, 0, toward, [&](double x, double y) { return channels(diskControlAt(p, c, light, x, y)); }, seen);
    CHECK_MESSAGE(inside == doctest::Approx(double(p.share)).epsilon(1e-4), trial);
    // In the pixel's units: the moments' quadrature (1e-5) and the rows' midpoint rule.
    CHECK_MESSAGE(std::abs(integral) < 3e-5 * 3, trial, " ", integral);
    // The colour of a diffuse sphere seen there (the nearest front among the disks holding it) less
    // the control is the mean, on a 60 x 60 grid of the inside.
    double worst = 0;
    for (int g = 0; g < 3600; ++g) worst = std::max(worst, leftAt(p, c, member, light, (g % 60 + 0.5) / 60, (g / 60 + 0.5) / 60));
    CHECK_MESSAGE(worst < 1e-5, trial, " ", worst);
  }
  CHECK(tested >= 100);
  CHECK(overlapping >= 20);  // strata whose disks overlap
  CHECK(cutting >= 10);      // of spheres that cut through each other, one seen all over the overlap in the pixel
  CHECK(changing >= 5);      // of those, the sphere seen changes inside the overlap in the pixel
  CHECK(unsplit == changing);  // and without `split` they have none
  CHECK(refused >= 5);       // three disks, the sphere seen changes in the pixel: no control
}

// Random strata of two or three spheres of 0.4-2 pixels' radius cutting through each other near
// pixel (0, 0), where the sphere seen changes inside an overlap in the pixel (`changes`) or, with
// two, one is seen all over their overlap there: diskControl's controls without `split` at two
// tolerances (of the pixel's colour: a render's target of 0.02, and of 0.004) are found on the
// lattice (seenMean), each off by about its own estimate; with `split`, or at 0, exact geometry.
void latticeControlsOffByTheirEstimates(bool changes, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> normal;
  const double tolerances[2] = {0.01, 0.002};
  int tested = 0, three = 0, refused[2] = {}, made[2] = {}, exactly[2] = {};
  double offSquares[2] = {}, estimateSquares[2] = {}, worstRatio[2] = {};
  for (int trial = 0; trial < 20000 && tested < 60; ++trial) {
    const int n = changes ? 2 + (trial % 3 == 0) : 2;
    PixelStratum::Ellipse e[3];
    ControlMember member[3];
    PixelBall ball[3];
    for (int i = 0; i < n; ++i) {
      const double r = 0.4 + 1.6 * unit(rng), cx = -0.5 + 2 * unit(rng), cy = -0.5 + 2 * unit(rng);
      e[i] = {cx, cy, r, r};
      member[i] = {Vec3d(unit(rng), unit(rng), unit(rng)), Vec3d(cx, -cy, 1.5 * unit(rng)), r};
      ball[i] = {cx, cy, member[i].centre.z, r};
    }
    const PixelStratum p = PixelStratum::of(0, 0, e, n);
    if (p.disks != n) continue;
    int seenWithinPixel[3][3] = {};
    bool anyChange = false, oneSeen = false;
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < i; ++j) {
        const int seen = seenWithin(ball[i], ball[j], 0, 1, 0, 1);
        const Vec3d d = member[i].centre - member[j].centre;
        const bool cut = dot(d, d) < (member[i].radius + member[j].radius) * (member[i].radius + member[j].radius);
        seenWithinPixel[i][j] = seen;
        anyChange = anyChange || seen == 0;
        oneSeen = oneSeen || (cut && (seen == 1 || seen == 2));
      }
    }
    if (changes ? !anyChange : (anyChange || !oneSeen)) continue;
    std::vector<std::vector<Vec3d>> toward;
    const ControlLighting light = randomLighting(1 + trial % 2, n, rng, normal, toward);
    const StratumControl exact = diskControl(0, 0, p, member, light, false, 0), split = diskControl(0, 0, p, member, light, true, 0.01);
    // Exact geometry only: none where the one seen changes (without the split); else exact. With the
    // split, two members are exact.
    CHECK_MESSAGE((changes ? !exact.any() : exact.any() && exact.meanError == 0), trial);
    CHECK_MESSAGE((n > 2 || (split.any() && split.meanError == 0)), trial);
    ++tested, three += n == 3;
    const auto seen = [&](double x, double y) { return seenMember(p, member, x, y); };
    for (int t = 0; t < 2; ++t) {
      double share = 0;
      const StratumControl c = diskControl(0, 0, p, member, light, false, tolerances[t], &share);
      if (!c.any()) {
        ++refused[t];
        continue;
      }
      // The control's integral over the inside is how far its mean is off (times the share): a third
      // of it, the channels' mean, against the estimate.
      const auto [integral, inside] =
          integrateInside(p, 0, 0, toward, [&](double x, double y) { return channels(diskControlAt(p, c, light, x, y)); }, seen);
      CHECK_MESSAGE(inside == doctest::Approx(double(p.share)).epsilon(1e-4), trial);
      const double off = std::abs(integral) / 3;
      if (c.meanError == 0) {  // where no lattice meets the tolerance, one seen: exact geometry
        ++exactly[t];
        CHECK_MESSAGE((!changes && off < 3e-5 && share == doctest::Approx(p.unionShare(0, 0)).epsilon(1e-12)), trial);
        continue;
      }
      ++made[t];
      CHECK_MESSAGE(share == p.unionShare(0, 0), trial);
      CHECK_MESSAGE(c.meanError <= tolerances[t], trial);
      offSquares[t] += off * off, estimateSquares[t] += double(c.meanError) * c.meanError;
      worstRatio[t] = std::max(worstRatio[t], off / c.meanError);
      // At a point, the colour of the sphere seen less the control is still the mean.
      for (int g = 0; g < 400; ++g) CHECK_MESSAGE(leftAt(p, c, member, light, (g % 20 + 0.5) / 20, (g / 20 + 0.5) / 20) < 1e-5, trial);
    }
  }
  CHECK(tested >= 60);
  CHECK((!changes || three >= 10));
  CHECK(refused[0] == 0);  // the coarser lattices meet the looser tolerance, exactly[0] too
  CHECK(exactly[0] == 0);
  CHECK(made[1] >= tested / 2);
  // The lattices' errors, RMS over the pixels, within the tolerance; their estimate errs large, by
  // up to a factor 5.
  for (int t = 0; t < 2; ++t) {
    const double offRms = std::sqrt(offSquares[t] / made[t]), estimateRms = std::sqrt(estimateSquares[t] / made[t]);
    const std::string kind = changes ? "the one seen changing" : "one seen";
    MESSAGE(kind, ", tolerance ", tolerances[t], ": off RMS ", offRms, ", estimated ", estimateRms, ", worst ratio ", worstRatio[t],
            ", made ", made[t], " of ", tested, ", exact ", exactly[t]);
    CHECK(offRms < tolerances[t]);
    CHECK(offRms < estimateRms);
    CHECK(offRms > estimateRms / 5);
  }
}

TEST_CASE("where the sphere seen changes inside overlaps, a control's mean found numerically is off by about its own estimate") {
  latticeControlsOffByTheirEstimates(true, 47);
}

TEST_CASE("where spheres cut through each other and one is seen all over their overlap, a control's mean on the lattice is off by about its own estimate") {
  latticeControlsOffByTheirEstimates(false, 48);
}

TEST_CASE("four disks, the farthest behind three nearer ones that overlap it: its control found on the lattice") {
  // Four spheres apart in space (5 pixels apart in depth, at most 0.55 across), their disks
  // overlapping in pixel (0, 0): the farthest may lose its part to three nearer disks, more than
  // inclusion and exclusion takes exactly (ClippedDiskPart::kMostCircles), so its control is the
  // lattice's or, with exact geometry only, none.
  static_assert(PixelStratum::kMostDisks == 4 && ClippedDiskPart::kMostCircles == 2);
  std::mt19937_64 rng(53);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> normal;
  int tested = 0;
  double offSquares = 0, estimateSquares = 0;
  for (int trial = 0; trial < 400 && tested < 30; ++trial) {
    PixelStratum::Ellipse e[4];
    ControlMember member[4];
    for (int i = 0; i < 4; ++i) {
      const double r = 0.3 + 0.25 * unit(rng), cx = 0.25 + 0.5 * unit(rng), cy = 0.25 + 0.5 * unit(rng);
      e[i] = {cx, cy, r, r};
      member[i] = {Vec3d(unit(rng), unit(rng), unit(rng)), Vec3d(cx, -cy, 5.0 * (i + 1)), r};
    }
    const PixelStratum p = PixelStratum::of(0, 0, e, 4);
    bool behindThree = p.disks == 4;  // the farthest's disk overlaps the other three's
    for (int i = 0; i < 3; ++i) behindThree = behindThree && std::hypot(e[i].cx - e[3].cx, e[i].cy - e[3].cy) < e[i].ax + e[3].ax;
    if (!behindThree) continue;
    std::vector<std::vector<Vec3d>> toward;
    const ControlLighting light = randomLighting(1 + trial % 2, 4, rng, normal, toward);
    CHECK_MESSAGE(!diskControl(0, 0, p, member, light, true, 0).any(), trial);
    double share = 0;
    const StratumControl c = diskControl(0, 0, p, member, light, true, 0.002, &share);
    if (!c.any()) continue;  // a lattice of 32 x 32 may miss the tolerance
    ++tested;
    CHECK_MESSAGE(share == p.unionShare(0, 0), trial);
    CHECK_MESSAGE((c.meanError > 0 && c.meanError <= 0.002), trial);
    const auto seen = [&](double x, double y) { return seenMember(p, member, x, y); };
    const auto [integral, inside] =
        integrateInside(p, 0, 0, toward, [&](double x, double y) { return channels(diskControlAt(p, c, light, x, y)); }, seen);
    CHECK_MESSAGE(inside == doctest::Approx(double(p.share)).epsilon(1e-4), trial);
    offSquares += integral * integral / 9, estimateSquares += double(c.meanError) * c.meanError;
    for (int g = 0; g < 400; ++g) CHECK_MESSAGE(leftAt(p, c, member, light, (g % 20 + 0.5) / 20, (g / 20 + 0.5) / 20) < 1e-5, trial);
  }
  CHECK(tested >= 20);
  // Its mean's error (the control's integral over the inside, a third of it: the channels' mean), RMS
  // over the strata, within the tolerance and about its estimate.
  const double offRms = std::sqrt(offSquares / tested), estimateRms = std::sqrt(estimateSquares / tested);
  MESSAGE("four disks: off RMS ", offRms, ", estimated ", estimateRms, " over ", tested);
  CHECK(offRms < 0.002);
  CHECK(offRms < 2 * estimateRms);
  CHECK(offRms > estimateRms / 4);
}

TEST_CASE("which of two spheres that cut through each other is seen over their disks' overlap in a rectangle, against a grid") {
  std::mt19937_64 rng(43);
  std::uniform_real_distribution<double> unit(0, 1);
  int counts[4] = {}, bothSeen = 0;
  for (int trial = 0; trial < 600; ++trial) {
    // Spheres of 0.4-3 pixels cutting through each other near the unit square.
    const double ra = 0.4 + 2.6 * unit(rng), rb = 0.4 + 2.6 * unit(rng);
    const PixelBall a{-ra + (1 + 2 * ra) * unit(rng), -ra + (1 + 2 * ra) * unit(rng), 3 * unit(rng), ra};
    PixelBall b{};
    do {
      b = {-rb + (1 + 2 * rb) * unit(rng), -rb + (1 + 2 * rb) * unit(rng), 3 * unit(rng), rb};
    } while (!(std::hypot(std::hypot(a.x - b.x, a.y - b.y), a.z - b.z) < ra + rb));
    const int seen = seenWithin(a, b, 0, 1, 0, 1);
    ++counts[seen];
    int grid[3] = {};  // points of the overlap where a, b is seen
    const int steps = 150;
    for (int gy = 0; gy < steps; ++gy) {
      for (int gx = 0; gx < steps; ++gx) {
        const double x = (gx + 0.5) / steps, y = (gy + 0.5) / steps;
        const double da = ra * ra - (x - a.x) * (x - a.x) - (y - a.y) * (y - a.y), db = rb * rb - (x - b.x) * (x - b.x) - (y - b.y) * (y - b.y);
        if (!(da > 0 && db > 0)) continue;
        ++grid[a.z - std::sqrt(da) < b.z - std::sqrt(db) ? 1 : 2];
      }
    }
    // One sphere seen: the grid sees only it; none of an overlap: the grid finds no point of one.
    if (seen == 1) CHECK_MESSAGE(grid[2] == 0, trial);
    if (seen == 2) CHECK_MESSAGE(grid[1] == 0, trial);
    if (seen == 3) CHECK_MESSAGE(grid[1] + grid[2] == 0, trial);
    // The one seen changes: the grid sees both, but where one shows in a sliver narrower than its
    // spacing.
    bothSeen += seen == 0 && grid[1] > 0 && grid[2] > 0;
  }
  CHECK(counts[0] > 50);
  CHECK(bothSeen > 0.9 * counts[0]);
  CHECK(counts[1] > 50);
  CHECK(counts[2] > 50);
  CHECK(counts[3] > 5);
}

TEST_CASE("a perspective stratum's control integrates to 0 over its inside; a sphere too large in view has none") {
  // A camera at the origin looking down -z (the frame's forward), a 200 x 200 image 0.5 wide at
  // distance 1: sample position (sx, sy) looks along (sx pw - 0.25, 0.25 - sy pw, -1).
  ParallelProjection image;
  image.center = Vec3d(0), image.horizontal = Vec3d(1, 0, 0), image.up = Vec3d(0, 1, 0), image.forward = Vec3d(0, 0, -1);
  image.pixelWidth = image.pixelHeight = 0.0025, image.xOffset = -0.25, image.yOffset = 0.25, image.perspective = true;
  std::mt19937_64 rng(43);
  std::uniform_real_distribution<double> unit(0, 1), slant(-0.8, 0.8);
  std::normal_distribution<double> normal;
  int tested = 0;
  for (int trial = 0; trial < 200 && tested < 40; ++trial) {
    const double l11 = 1 / (0.4 + 3.6 * unit(rng)), l22 = 1 / (0.4 + 3.6 * unit(rng)), l12 = slant(rng) * std::min(l11, l22);
    const double cx = 20 + 160 * unit(rng), cy = 20 + 160 * unit(rng);
    const int x = int(std::floor(cx + (unit(rng) - 0.5) * 2 / l11)), y = int(std::floor(cy + (unit(rng) - 0.5) * 2 / l22));
    const PixelStratum p = PixelStratum::sheared(x, y, cx, cy, l11, l12, l22);
    if (!p.any()) continue;
    ControlLighting light;
    light.ambient = Vec3d(0.1, 0.15, 0.2);
    light.suns = 2;
    for (int l = 0; l < 2; ++l) {
      Vec3d d(normal(rng), normal(rng), normal(rng));
      d /= std::sqrt(dot(d, d));
      light.sun[l] = {d.x, d.y, d.z, Vec3d(0.9, 0.8, 0.7)};
    }
    const Vec3d kd(0.8, 0.5, 0.3);
    CHECK_FALSE(ellipseControl(x, y, p, kd, 0.2, image, light).any());
    const StratumControl c = ellipseControl(x, y, p, kd, 0.05, image, light);
    if (!c.any()) continue;
    ++tested;
    Vec3d axes[3];
    ellipseAxes(p, image, axes);
    std::vector<std::vector<Vec3d>> toward(1);
    for (int l = 0; l < 2; ++l) {
      const Vec3d d(light.sun[l].a, light.sun[l].b, light.sun[l].c);
      toward[0].push_back(Vec3d(dot(d, axes[0]), dot(d, axes[1]), dot(d, axes[2])));
    }
    const auto [integral, inside] =
        integrateInside(p, x, y, toward, [&](double sx, double sy) { return channels(ellipseControlAt(p, c, image, light, sx, sy)); },
                        [](double, double) { return 0; });
    CHECK_MESSAGE(inside == doctest::Approx(double(p.share)).epsilon(1e-4), trial);
    CHECK_MESSAGE(std::abs(integral) < 3e-5 * 3, trial, " ", integral);
    // The model's axes: unit, w's toward the camera along the ray through the ellipse's centre.
    for (const Vec3d& a : axes) CHECK(std::sqrt(dot(a, a)) == doctest::Approx(1).epsilon(1e-12));
    CHECK(std::abs(dot(axes[0], axes[2])) < 1e-12);
    CHECK(std::abs(dot(axes[1], axes[2])) < 1e-12);
  }
  CHECK(tested >= 30);
}

TEST_CASE("an orthographic control's parts make its stratum's share: the union's area, where no split cuts them") {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0, 1);
  ControlLighting light;
  light.suns = 1;
  light.sun[0] = {0.3, -0.5, 0.81, Vec3d(1)};
  int single = 0, several = 0, split = 0, large = 0;
  double worst = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    // One to three disks of 0.3-3 pixels' radius (a tenth of them up to 16, a tenth up to 300) near
    // pixel (0, 0); their spheres' centres 0-3 units deep (many cut through each other) or 0-20.
    const int n = 1 + trial % 3;
    const double deep = trial % 2 ? 3 : 20;
    PixelStratum::Ellipse e[3];
    ControlMember member[3];
    bool small = true;
    for (int i = 0; i < n; ++i) {
      const double most = trial % 10 == 0 ? 300 : trial % 10 == 1 ? kMostPartsShareRadius : 3;
      const double r = 0.3 + (most - 0.3) * unit(rng);
      // Their edges near the pixel: centres r - 1 to r + 1 from its middle.
      const double angle = 2 * kPi * unit(rng), reach = r - 1 + 2 * unit(rng);
      const double cx = 0.5 + reach * std::cos(angle), cy = 0.5 + reach * std::sin(angle);
      e[i] = {cx, cy, r, r};
      member[i] = {Vec3d(0.5), Vec3d(cx, -cy, deep * unit(rng)), r};
      small = small && 1 / double(float(1 / r)) <= kMostPartsShareRadius;
    }
    const PixelStratum p = PixelStratum::shaped(e, n);
    const double area = p.unionShare(0, 0);
    if (!(area > 0 && area < 1)) continue;
    for (const bool splits : {false, true}) {
      double share = 0;
      const StratumControl c = diskControl(0, 0, p, member, light, splits, 0, &share);
      if (!small) {
        CHECK_MESSAGE(std::isnan(share), trial);
        large += c.any();
        continue;
      }
      if (std::isnan(share)) {  // a split's parts are bounded by the arc where the fronts meet, or none
        split += splits && c.any();
        CHECK_MESSAGE((splits || !c.any()), trial);
        continue;
      }
      CHECK_MESSAGE(c.any(), trial);
      worst = std::max(worst, std::abs(share - area));
      single += n == 1, several += n > 1;
    }
  }
  CHECK(worst < 1e-13);
  CHECK(single > 1000);
  CHECK(several > 1500);
  CHECK(split > 40);
  CHECK(large > 200);
}

TEST_CASE("a cover's control integrates to 0 over the stratum's outside, where the member is seen before the cover") {
  // One disk of 0.4-3 pixels' radius crossing pixel (0, 0), a disk of 4-30 covering it; their
  // spheres apart in space (the member nearer) or cutting through each other. Outside the member's
  // disk the cover is seen: its control there is its shading less coverMean, whose integral over the
  // outside is checked row by row (Gauss-Legendre between the member's edge and the cover's
  // terminators, the midpoint rule across 3000 rows).
  static constexpr double kNode[8] = {0.019855071751231856, 0.10166676129318664, 0.23723379504183550, 0.40828267875217510,
                                      0.59171732124782490, 0.76276620495816450, 0.89833323870681336, 0.98014492824876811};
  static constexpr double kWeight[8] = {0.050614268145188130, 0.11119051722668724, 0.15685332293894364, 0.18134189168918099,
                                        0.18134189168918099, 0.15685332293894364, 0.11119051722668724, 0.050614268145188130};
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> normal;
  int covered = 0, cutting = 0, refused = 0;
  for (int trial = 0; trial < 400 && covered < 60; ++trial) {
    const double r = 0.4 + 2.6 * unit(rng), angle = 2 * kPi * unit(rng), reach = r - 0.7 + 1.4 * unit(rng);
    const PixelStratum::Ellipse e{0.5 + reach * std::cos(angle), 0.5 + reach * std::sin(angle), r, r};
    const PixelStratum p = PixelStratum::of(0, 0, &e, 1);
    if (!p.any()) continue;
    const double cr = 4 + 26 * unit(rng), ca = 2 * kPi * unit(rng), cd = (cr - 1.5) * unit(rng);
    const PixelStratum::Ellipse ce{0.5 + cd * std::cos(ca), 0.5 + cd * std::sin(ca), cr, cr};
    // Depths (pixel units): the member's centre before the cover's; apart, or cutting through it
    // with its centre near the cover's front (before it or behind, by up to half its radius).
    const bool cut = trial % 2 == 1;
    const double lateral = std::hypot(e.cx - ce.cx, e.cy - ce.cy);
    const double gap = cut ? std::sqrt(std::max(0.0, cr * cr - lateral * lateral)) + r * (1.5 * unit(rng) - 0.5) : cr + r + 1 + 5 * unit(rng);
    const ControlMember member{Vec3d(0.6, 0.5, 0.4), Vec3d(e.cx, -e.cy, 10.0), r};
    const ControlMember cover{Vec3d(0.3, 0.6, 0.9), Vec3d(ce.cx, -ce.cy, 10.0 + gap), cr};
    ControlLighting light;
    light.ambient = Vec3d(0.1, 0.15, 0.2);
    light.suns = 1;
    Vec3d l(normal(rng), normal(rng), normal(rng));
    l /= std::sqrt(dot(l, l));
    light.sun[0] = {l.x, l.y, l.z, Vec3d(0.9, 0.8, 0.7)};
    const StratumControl c = diskControl(0, 0, p, &member, light, true, 0, nullptr, &cover, &ce);
    REQUIRE(c.any());
    if (!c.covered()) {
      refused += cut;
      continue;
    }
    ++covered, cutting += cut;
    // The cover's shading less its mean, integrated over the outside.
    const int rows = 3000;
    double sum = 0, area = 0;
    for (int row = 0; row < rows; ++row) {
      const double sy = (row + 0.5) / rows;
      std::vector<double> cuts{0.0, 1.0};
      const double dv = sy - e.cy;
      if (std::abs(dv) < r) {
        const double half = std::sqrt(r * r - dv * dv);
        for (const double x : {e.cx - half, e.cx + half}) {
          if (x > 0 && x < 1) cuts.push_back(x);
        }
      }
      const double v = (sy - ce.cy) / cr;  // the cover's terminator: (l.x u + l.y v)^2 = l.z^2 (1 - u^2 - v^2)
      const double a = l.x * l.x + l.z * l.z, b = 2 * l.x * l.y * v, k = l.y * l.y * v * v - l.z * l.z * (1 - v * v), disc = b * b - 4 * a * k;
      if (disc >= 0) {
        for (const double u : {(-b + std::sqrt(disc)) / (2 * a), (-b - std::sqrt(disc)) / (2 * a)}) {
          const double x = ce.cx + u * cr;
          if (x > 0 && x < 1) cuts.push_back(x);
        }
      }
      std::sort(cuts.begin(), cuts.end());
      for (size_t s = 0; s + 1 < cuts.size(); ++s) {
        const double x0 = cuts[s], length = cuts[s + 1] - x0;
        for (int j = 0; j < 8; ++j) {
          const double sx = x0 + length * kNode[j];
          if (p.contains(sx, sy)) continue;
          const double u = (sx - ce.cx) / cr, w = std::sqrt(std::max(0.0, 1 - u * u - v * v));
          const double shading = std::max(0.0, l.x * u + l.y * v + l.z * w);
          const Vec3d colour = Vec3d(Vec3<float>(cover.kd)) * (light.ambient + shading * light.sun[0].color);
          const Vec3d left = colour - diskControlAt(p, c, light, sx, sy);  // the cover's mean there
          sum += kWeight[j] * length * (channels(colour) - channels(Vec3d(c.coverMean)));
          area += kWeight[j] * length;
          CHECK_MESSAGE(std::abs(channels(left) - channels(Vec3d(c.coverMean))) < 1e-5, trial);
        }
      }
    }
    CHECK_MESSAGE(area / rows == doctest::Approx(1 - double(p.share)).epsilon(1e-4), trial);
    CHECK_MESSAGE(std::abs(sum / rows) < 3e-5, trial, " ", sum / rows);
  }
  CHECK(covered >= 60);
  CHECK(cutting >= 15);  // the member seen all over its part where they cut through each other
  CHECK(refused >= 5);   // and not where the cover is seen in part of it
}
