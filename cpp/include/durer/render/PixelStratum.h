#pragma once
// A pixel's samples split by a sphere's silhouette (post-stratification). Where the edge of a
// sphere's image crosses a pixel, its samples' colours form two populations: those inside the
// silhouette and those outside. The plain mean weighs each by the share of samples that happened to
// fall in it; the stratified mean weighs each by its exact share of the pixel's area, so what the
// samples' positions decide is gone and only the colours' spread within each part is left (what it
// gains and costs: docs/benchmarks.md, forty-second round).
//
// The silhouette is a sphere's image through an orthographic camera: a disk (an axis-aligned ellipse
// where pixels are not square; TileRenderer::silhouetteStrata). Any region whose area is known
// exactly keeps the estimate consistent; the nearer it follows the colours' edge, the more it
// removes. Used by adaptive sampling (AdaptiveSampler).
#include <algorithm>
#include <cmath>
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

// One pixel's stratum: an axis-aligned ellipse in image coordinates (pixels), and the share of the
// pixel's unit square inside it. share 0 (as PixelStratum{} makes it): the pixel has none (its
// samples' plain mean stands). Trivial, for adaptive sampling's tile states (HugeArray).
struct PixelStratum {
  float cx, cy;                // the ellipse's centre
  float inverseAx, inverseAy;  // its semi-axes' inverses
  float share;                 // of pixel (x, y)'s square [x, x + 1] x [y, y + 1], in (0, 1)

  // The longest semi-axis (pixels) a stratum is made for. The share is found in the unit disk's
  // frame, where a pixel is 1/a^2 of the disk and the arcs' rounding (~1e-16 of the disk) becomes
  // ~1e-16 a^2 of the pixel, more near a vertical edge (asin's slope): at most 6e-8 at a = 1e3 and
  // 5e-6 at 1e4, measured against the same formula in 128-bit floats; 0.02 at 1e6. A sphere wider
  // than this over its pixels (a planet seen as a ground) keeps the plain mean.
  static constexpr double kMostAxis = 4096;

  // The stratum of pixel (x, y) by the ellipse of centre (cx, cy) and semi-axes ax, ay, if its edge
  // crosses the pixel (and neither axis exceeds kMostAxis); otherwise none. The share is computed for
  // the ellipse as the members test it (the centre and inverses rounded to float).
  static PixelStratum of(int x, int y, double cx, double cy, double ax, double ay) {
    if (!(ax <= kMostAxis && ay <= kMostAxis)) return {};
    PixelStratum p{};
    p.cx = static_cast<float>(cx), p.cy = static_cast<float>(cy);
    p.inverseAx = static_cast<float>(1 / ax), p.inverseAy = static_cast<float>(1 / ay);
    const double iu = p.inverseAx, iv = p.inverseAy;
    if (!(std::isfinite(iu) && std::isfinite(iv) && iu > 0 && iv > 0 && std::isfinite(p.cx) && std::isfinite(p.cy))) return {};
    const double share = unitDiskRectangleArea((x - double(p.cx)) * iu, (x + 1 - double(p.cx)) * iu,
                                               (y - double(p.cy)) * iv, (y + 1 - double(p.cy)) * iv) / (iu * iv);
    p.share = static_cast<float>(share);
    return p.share > 0 && p.share < 1 ? p : PixelStratum{};  // as rounded
  }

  bool any() const { return share > 0; }

  // Whether a sample at (x, y) lies inside the ellipse (false for a pixel without a stratum).
  bool contains(double x, double y) const {
    const double u = (x - double(cx)) * double(inverseAx), v = (y - double(cy)) * double(inverseAy);
    return any() && u * u + v * v < 1;
  }

  // The pixel's mean of one channel from the sum of all its `count` samples and of the `inside` of
  // them that lie in the ellipse (summing `inSum`): each part's mean weighed by its share of the
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
