#pragma once
// A pixel's samples split by the silhouettes of spheres (post-stratification). Where the edges of
// spheres' images cross a pixel, its samples' colours form two populations: those inside the
// silhouettes and those outside. The plain mean weighs each by the share of samples that happened to
// fall in it; the stratified mean weighs each by its exact share of the pixel's area, so what the
// samples' positions decide is gone and only the colours' spread within each part is left (what it
// gains and costs: docs/benchmarks.md, forty-second and forty-seventh rounds).
//
// A silhouette is a sphere's image through an orthographic camera: a disk (an axis-aligned ellipse
// where pixels are not square; TileRenderer::silhouetteStrata); where several cross a pixel, the
// inside part is their union. Any region whose area is known exactly keeps the estimate consistent;
// the nearer it follows the colours' edges, the more it removes. Used by adaptive sampling
// (AdaptiveSampler).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "durer/math/Float.h"

namespace durer {

// The area of the unit disk within [u0, u1] x [v0, v1]: the integral over x of the chord's part
// within [v0, v1], piecewise in closed form between the x where the circle crosses v = v0 or v1
// (there the integrand changes form, and nowhere else: its pieces keep their sign in between).
inline double unitDiskRectangleArea(double u0, double u1, double v0, double v1) {
  u0 = std::max(u0, -1.0), u1 = std::min(u1, 1.0);
  if (!(u0 < u1) || !(v0 < v1) || v0 >= 1 || v1 <= -1) return 0;
  double xs[6] = {u0, u1};
  int n = 2;
  for (const double v : {v0, v1}) {
    if (std::abs(v) >= 1) continue;
    const double x = std::sqrt(1 - v * v);
    if (-x > u0 && -x < u1) xs[n++] = -x;
    if (x > u0 && x < u1) xs[n++] = x;
  }
  for (int i = 1; i < n; ++i) {  // insertion sort of at most six
    for (int j = i; j > 0 && xs[j] < xs[j - 1]; --j) std::swap(xs[j], xs[j - 1]);
  }
  // The integral of sqrt(1 - x^2) from 0 to x.
  const auto arc = [](double x) { return (x * std::sqrt(std::max(0.0, 1 - x * x)) + std::asin(x)) / 2; };
  double area = 0;
  for (int i = 0; i + 1 < n; ++i) {
    const double a = xs[i], b = xs[i + 1];
    if (!(a < b)) continue;
    const double m = (a + b) / 2, s = std::sqrt(1 - m * m), chord = arc(b) - arc(a);
    const bool topArc = s < v1, bottomArc = -s > v0;  // the chord's ends, where they lie inside [v0, v1]
    const double top = topArc ? s : v1, bottom = bottomArc ? -s : v0;
    if (top <= bottom) continue;
    area += (topArc ? chord : v1 * (b - a)) - (bottomArc ? -chord : v0 * (b - a));
  }
  // Rounding keeps it within what the rectangle and the disk hold.
  return std::clamp(area, 0.0, std::min((u1 - u0) * (std::min(v1, 1.0) - std::max(v0, -1.0)), kPi));
}

// The area of the union of `count` circles (centres (cu[i], cv[i]), radii r[i] > 0) within the
// rectangle [0, w] x [0, h]: Green's theorem, half the integral of u dv - v du counter-clockwise
// around the region's boundary, which is made of the arcs of each circle inside the rectangle and
// outside every other circle, and the parts of the rectangle's sides inside some circle. Each
// circle's arcs run between the points where the others and the sides cross it (found and ordered
// around it without trigonometry: one arctangent an arc that counts), tangent points included (an
// arc's midpoint then lies off the point of contact); an arc's midpoint says whether it bounds the
// region, a circle nothing crosses or touches is inside the rectangle and outside the others by its
// extent. A circle equal to an earlier one adds nothing (its arcs would count twice).
inline double circlesRectangleUnionArea(const double* cu, const double* cv, const double* r, int count, double w, double h) {
  constexpr int kMost = 8;  // circles read at most (the first)
  count = std::min(count, kMost);
  bool duplicate[kMost] = {};
  for (int i = 0; i < count; ++i) {
    for (int j = 0; j < i && !duplicate[i]; ++j) duplicate[i] = cu[i] == cu[j] && cv[i] == cv[j] && r[i] == r[j];
  }
  const auto inCircle = [&](int i, double u, double v) {
    const double du = u - cu[i], dv = v - cv[i];
    return !duplicate[i] && du * du + dv * dv < r[i] * r[i];
  };
  // A point on circle i as its offset (x, y) from the centre, and a key that grows with its angle
  // from +u counter-clockwise: 1 - cos in the upper half, 3 + cos in the lower, so that half a turn
  // adds exactly 2.
  struct Point {
    double key, x, y;
  };
  double twice = 0;  // twice the area
  for (int i = 0; i < count; ++i) {
    if (duplicate[i]) continue;
    const double ri = r[i];
    Point points[2 * kMost + 8];
    int n = 0;
    const auto add = [&](double x, double y) { points[n++] = {y >= 0 ? 1 - x / ri : 3 + x / ri, x, y}; };
    for (int j = 0; j < count; ++j) {  // where circle j crosses circle i
      if (j == i || duplicate[j]) continue;
      const double du = cu[j] - cu[i], dv = cv[j] - cv[i], d = std::sqrt(du * du + dv * dv);
      if (!(d <= ri + r[j] && d >= std::abs(ri - r[j]) && d > 0)) continue;  // tangents too: an arc ends there
      const double along = (ri * ri - r[j] * r[j] + d * d) / (2 * d), half = std::sqrt(std::max(0.0, ri * ri - along * along));
      const double eu = du / d, ev = dv / d;
      add(along * eu - half * ev, along * ev + half * eu);
      add(along * eu + half * ev, along * ev - half * eu);
    }
    // Where it crosses or touches the sides (between two such points an arc lies all inside the
    // rectangle or all outside it): those at 0 and `extent` across (u = 0 and w when `vertical`,
    // else v = 0 and h), within [0, length] along them.
    const auto sides = [&](bool vertical, double extent, double length) {
      const double across = vertical ? cu[i] : cv[i], along = vertical ? cv[i] : cu[i];
      for (const double line : {0.0, extent}) {
        const double s = line - across;
        if (std::abs(s) > ri) continue;
        const double t = std::sqrt((ri - s) * (ri + s));
        for (const double a : {t, -t}) {
          if (along + a >= 0 && along + a <= length) vertical ? add(s, a) : add(a, s);
        }
      }
    };
    sides(true, w, h), sides(false, h, w);
    for (int k = 1; k < n; ++k) {  // insertion sort by the key: at most 2 (kMost - 1) + 8 points
      for (int m = k; m > 0 && points[m].key < points[m - 1].key; --m) std::swap(points[m], points[m - 1]);
    }
    const auto bounds = [&](double u, double v) {
      if (!(u > 0 && u < w && v > 0 && v < h)) return false;
      for (int j = 0; j < count; ++j) {
        if (j != i && inCircle(j, u, v)) return false;
      }
      return true;
    };
    if (n == 0) {  // nothing crosses or touches it: the whole circle, or none of it, by its extent
      bool counts = cu[i] - ri >= 0 && cu[i] + ri <= w && cv[i] - ri >= 0 && cv[i] + ri <= h;
      for (int j = 0; j < count && counts; ++j) {  // and within no other
        const double du = cu[j] - cu[i], dv = cv[j] - cv[i];
        counts = j == i || duplicate[j] || std::sqrt(du * du + dv * dv) + ri > r[j];
      }
      if (counts) twice += 2 * kPi * ri * ri;
      continue;
    }
    for (int k = 0; k < n; ++k) {
      const Point& a = points[k];
      const Point& b = points[k + 1 < n ? k + 1 : 0];
      const double span = k + 1 < n ? b.key - a.key : b.key + 4 - a.key;  // 2: half a turn
      if (!(span > 0)) continue;
      // The arc's midpoint, from well-conditioned directions: the sum's (turned back beyond half a
      // turn) away from half a turn, else the chord's turned clockwise by a quarter.
      const double sx = a.x + b.x, sy = a.y + b.y;
      double mx = span > 2 ? -sx : sx, my = span > 2 ? -sy : sy;
      if (sx * sx + sy * sy < ri * ri) mx = b.y - a.y, my = a.x - b.x;
      const double scale = ri / std::sqrt(mx * mx + my * my);
      if (!(scale < std::numeric_limits<double>::infinity()) || !bounds(cu[i] + mx * scale, cv[i] + my * scale)) continue;
      double angle = std::atan2(a.x * b.y - a.y * b.x, a.x * b.x + a.y * b.y);  // in (-pi, pi]
      if (angle < 0 || (span > 2 && angle < kPi)) angle += 2 * kPi;
      twice += ri * ri * angle + cu[i] * (b.y - a.y) - cv[i] * (b.x - a.x);
    }
  }
  // The sides along the axes (v = 0, u = 0) add nothing to u dv - v du; the right side (u = w,
  // upward) adds w times its length inside the union, the top side (v = h, leftward) h times its.
  const auto coveredLength = [&](bool vertical, double line, double length) {
    double lo[kMost], hi[kMost];
    int n = 0;
    for (int i = 0; i < count; ++i) {  // each circle's chord on the line, within the side, by its start
      const double across = line - (vertical ? cu[i] : cv[i]), centre = vertical ? cv[i] : cu[i];
      if (duplicate[i] || !(std::abs(across) < r[i])) continue;
      const double t = std::sqrt((r[i] - across) * (r[i] + across));
      const double start = std::max(0.0, centre - t), end = std::min(length, centre + t);
      if (!(start < end)) continue;
      int m = n++;
      for (; m > 0 && lo[m - 1] > start; --m) lo[m] = lo[m - 1], hi[m] = hi[m - 1];
      lo[m] = start, hi[m] = end;
    }
    double covered = 0, reached = 0;
    for (int k = 0; k < n; ++k) {
      if (hi[k] > reached) covered += hi[k] - std::max(lo[k], reached), reached = hi[k];
    }
    return covered;
  };
  twice += w * coveredLength(true, w, h) + h * coveredLength(false, h, w);
  return std::clamp(twice / 2, 0.0, w * h);
}

// One pixel's stratum: up to kMostDisks axis-aligned ellipses of one shape's family (the
// silhouettes of spheres crossing the pixel, a sphere's a disk stretched by the pixels' aspect) in
// image coordinates (pixels), and the share of the pixel's unit square inside their union. The
// union, not each sphere's own region: where spheres overlap, which of them shows (in front, or
// cutting through each other) is not the question the stratum answers, only where some sphere's
// colour is against where the background's is; the union's area is exact (to rounding) however
// they overlap.
// share 0 (as PixelStratum{} makes it): the pixel has none (its samples' plain mean stands).
// Trivial, for adaptive sampling's tile states (HugeArray).
struct PixelStratum {
  static constexpr int kMostDisks = 3;
  float cx[kMostDisks], cy[kMostDisks];                // the ellipses' centres
  float inverseAx[kMostDisks], inverseAy[kMostDisks];  // their semi-axes' inverses
  float share;   // of pixel (x, y)'s square [x, x + 1] x [y, y + 1] inside the union, in (0, 1)
  float aspect;  // of several: each one's semi-axes' ratio ay / ax, as its membership and the share take it
  int32_t disks;  // how many ellipses

  // The longest semi-axis (pixels) a stratum is made for. The share is found in the unit disk's
  // frame, where a pixel is 1/a^2 of the disk and the arcs' rounding (~1e-16 of the disk) becomes
  // ~1e-16 a^2 of the pixel, more near a vertical edge (asin's slope): at most 6e-8 at a = 1e3 and
  // 5e-6 at 1e4, measured against the same formula in 128-bit floats; 0.02 at 1e6. A sphere wider
  // than this over its pixels (a planet seen as a ground) keeps the plain mean.
  static constexpr double kMostAxis = 4096;

  // An ellipse of centre (cx, cy) and semi-axes ax, ay (pixels).
  struct Ellipse {
    double cx, cy, ax, ay;
  };

  // The stratum of pixel (x, y) by the union of `count` ellipses (the first kMostDisks), if its edge
  // crosses the pixel (and no axis exceeds kMostAxis); otherwise none. The share is computed for the
  // ellipses as the members test them (centres and inverses rounded to float): one ellipse's in the
  // unit disk's frame (unitDiskRectangleArea); a union's in the frame where the first is a circle,
  // where the others are too (all of them one family: their axes' ratio is the pixels' aspect, to
  // float's rounding) — circlesRectangleUnionArea.
  static PixelStratum of(int x, int y, const Ellipse* ellipses, int count) {
    PixelStratum p{};
    p.disks = std::min(count, kMostDisks);
    for (int i = 0; i < p.disks; ++i) {
      const Ellipse& e = ellipses[i];
      if (!(e.ax <= kMostAxis && e.ay <= kMostAxis)) return {};
      p.cx[i] = static_cast<float>(e.cx), p.cy[i] = static_cast<float>(e.cy);
      p.inverseAx[i] = static_cast<float>(1 / e.ax), p.inverseAy[i] = static_cast<float>(1 / e.ay);
      const double iu = p.inverseAx[i], iv = p.inverseAy[i];
      if (!(std::isfinite(iu) && std::isfinite(iv) && iu > 0 && iv > 0 && std::isfinite(p.cx[i]) && std::isfinite(p.cy[i]))) {
        return {};
      }
    }
    if (p.disks == 0) return {};
    const double iu = p.inverseAx[0], iv = p.inverseAy[0];
    double share;
    if (p.disks == 1) {
      share = unitDiskRectangleArea((x - double(p.cx[0])) * iu, (x + 1 - double(p.cx[0])) * iu,
                                    (y - double(p.cy[0])) * iv, (y + 1 - double(p.cy[0])) * iv) / (iu * iv);
    } else {
      // Pixel units across, the first ellipse's aspect down (v = (y - y0) iv / iu), which every
      // member takes (contains): circles of radius 1 / inverseAx.
      p.aspect = static_cast<float>(iv / iu);
      const double aspect = p.aspect;
      double cu[kMostDisks], cv[kMostDisks], radius[kMostDisks];
      for (int i = 0; i < p.disks; ++i) {
        cu[i] = double(p.cx[i]) - x, cv[i] = (double(p.cy[i]) - y) * aspect, radius[i] = 1 / double(p.inverseAx[i]);
      }
      share = circlesRectangleUnionArea(cu, cv, radius, p.disks, 1, aspect) / aspect;
    }
    p.share = static_cast<float>(share);
    return p.share > 0 && p.share < 1 ? p : PixelStratum{};  // as rounded
  }

  // The stratum of pixel (x, y) by one ellipse of centre (cx, cy) and semi-axes ax, ay.
  static PixelStratum of(int x, int y, double cx, double cy, double ax, double ay) {
    const Ellipse e{cx, cy, ax, ay};
    return of(x, y, &e, 1);
  }

  bool any() const { return share > 0; }

  // Whether a sample at (x, y) lies inside the union (false for a pixel without a stratum): one
  // ellipse by its own axes, several as circles in the frame of the first's aspect (as the share is
  // found; their own axes' ratios differ from it by float's rounding).
  bool contains(double x, double y) const {
    if (disks == 1) {
      const double u = (x - double(cx[0])) * double(inverseAx[0]), v = (y - double(cy[0])) * double(inverseAy[0]);
      return any() && u * u + v * v < 1;
    }
    bool in = false;
    for (int i = 0; i < disks; ++i) {
      const double u = (x - double(cx[i])) * double(inverseAx[i]), v = (y - double(cy[i])) * double(aspect) * double(inverseAx[i]);
      in = in || u * u + v * v < 1;
    }
    return any() && in;
  }

  // The pixel's mean of one channel from the sum of all its `count` samples and of the `inside` of
  // them that lie in the union (summing `inSum`): each part's mean weighed by its share of the
  // pixel. Where a part has no sample yet, or the sum overflowed (the outside part's would be
  // inf - inf), the plain mean.
  template <typename Real>
  Real mean(Real sum, Real count, Real inSum, Real inside) const {
    if (!(inside > 0 && inside < count && std::isfinite(sum))) return sum / count;
    const Real s = static_cast<Real>(share);
    return s * (inSum / inside) + (1 - s) * ((sum - inSum) / (count - inside));
  }
};

}  // namespace durer
