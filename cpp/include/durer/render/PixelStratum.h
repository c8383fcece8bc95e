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
// inside part is their union. Through a perspective camera it is a rotated ellipse, and a pixel
// has a stratum only where one sphere's crosses it (TileRenderer::perspectiveStrata). Any region
// whose area is known exactly keeps the estimate consistent; the nearer it follows the colours'
// edges, the more it removes. Used by adaptive sampling (AdaptiveSampler).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "durer/math/Float.h"

namespace durer {

// 6-point Gauss-Legendre on [0, 1]: the strata's quadratures across fans (UnitDiskPart,
// ClippedDiskPart, StratumControl's regions).
inline constexpr double kGaussNode[6] = {0.033765242898423975, 0.16939530676686776, 0.38069040695840156,
                                         0.61930959304159844, 0.83060469323313224, 0.96623475710157603};
inline constexpr double kGaussWeight[6] = {0.085662246189585178, 0.18038078652406930, 0.23395696728634552,
                                           0.23395696728634552, 0.18038078652406930, 0.085662246189585178};

// Twice the area between an arc of angle `angle` of a circle of squared radius rr and its chord,
// rr (angle - sin angle), given rr sin angle (`cross`). Where the arc is short the difference
// cancels, so there it is the series, whose error stays relative: the arcs of a wide circle through
// a pixel are that short, and their segments are what the chords' polygon leaves out.
inline double twiceSegment(double angle, double rr, double cross) {
  if (!(std::abs(angle) < 0.5)) return rr * angle - cross;
  const double a2 = angle * angle;  // terms to angle^11 / 11!: the next is 1e-15 of the sum at 0.5
  return rr * angle * a2 / 6 * (1 - a2 / 20 * (1 - a2 / 42 * (1 - a2 / 72 * (1 - a2 / 110 * (1 - a2 / 156)))));
}

// The boundary of the unit disk's part of [u0, u1] x [v0, v1] (clipped to [-1, 1]^2 already, not
// empty), walked counter-clockwise: the points where it switches between the rectangle's sides and
// the circle, in pairs along a side (path[2i] to path[2i + 1]), the circle's arc from each pair's
// end to the next pair's start (none where the two points are one: a corner inside the disk).
// `count`: how many points (0: no side reaches into the disk, which then lies wholly inside or
// apart); `centreInside`: whether the centre lies on the inner side of the last side that reaches
// into it.
struct DiskRectanglePath {
  struct Point {
    double u, v;
  };
  Point point[8];
  int count = 0;
  bool centreInside = false;

  DiskRectanglePath(double u0, double u1, double v0, double v1) {
    // The chord of the line at `c` across (|c| < 1) within [lo, hi] along it, as [a, b].
    const auto chord = [](double c, double lo, double hi, double& a, double& b) {
      if (!(std::abs(c) < 1)) return false;
      const double t = std::sqrt((1 - c) * (1 + c));
      a = std::max(lo, -t), b = std::min(hi, t);
      return a < b;
    };
    double a, b;
    Point* p = point;
    if (chord(v0, u0, u1, a, b)) *p++ = {a, v0}, *p++ = {b, v0}, centreInside = v0 < 0;  // bottom, rightward
    if (chord(u1, v0, v1, a, b)) *p++ = {u1, a}, *p++ = {u1, b}, centreInside = u1 > 0;  // right, upward
    if (chord(v1, u0, u1, a, b)) *p++ = {b, v1}, *p++ = {a, v1}, centreInside = v1 > 0;  // top, leftward
    if (chord(u0, v0, v1, a, b)) *p++ = {u0, b}, *p++ = {u0, a}, centreInside = u0 < 0;  // left, downward
    count = static_cast<int>(p - point);
  }
};

// The area of the unit disk within [u0, u1] x [v0, v1], by Green's theorem: the polygon of the
// points where the region's boundary switches between the rectangle's sides and the circle
// (DiskRectanglePath), plus the circular segment of each arc between them. The polygon is taken
// about a corner, so its terms are the rectangle's size and a tiny pixel of a wide ellipse keeps
// its relative accuracy; one arctangent an arc.
inline double unitDiskRectangleArea(double u0, double u1, double v0, double v1) {
  u0 = std::max(u0, -1.0), u1 = std::min(u1, 1.0), v0 = std::max(v0, -1.0), v1 = std::min(v1, 1.0);
  if (!(u0 < u1 && v0 < v1)) return 0;
  const DiskRectanglePath path(u0, u1, v0, v1);
  const int n = path.count;
  if (n == 0) return u0 == -1 && u1 == 1 && v0 == -1 && v1 == 1 ? kPi : 0;  // the disk inside, or apart
  double twice = 0;
  for (int k = 0; k < n; ++k) {
    const DiskRectanglePath::Point p = path.point[k], q = path.point[k + 1 < n ? k + 1 : 0];
    twice += (p.u - u0) * (q.v - v0) - (p.v - v0) * (q.u - u0);
    if (k % 2 == 0 || (p.u == q.u && p.v == q.v)) continue;  // along a side, or through a corner inside the disk
    // The arc from where one side leaves the disk to where the next enters it: more than half a turn
    // only if one side cuts the disk and the centre is on the rectangle's side of it; with several,
    // at most three quarters (so a slightly negative angle is rounding of none).
    const double cross = p.u * q.v - p.v * q.u;
    double angle = std::atan2(cross, p.u * q.u + p.v * q.v);
    if (angle < (n == 2 && path.centreInside ? kPi / 2 : -kPi / 4)) angle += 2 * kPi;
    twice += twiceSegment(angle, 1, cross);
  }
  // Rounding keeps it within what the rectangle and the disk hold.
  return std::clamp(twice / 2, 0.0, std::min((u1 - u0) * (v1 - v0), kPi));
}

// The pieces of the boundary of the unit disk's part of a rectangle or a convex quadrilateral,
// counter-clockwise, as the region's fans from the disk's centre are taken: straight pieces along
// the sides (inside the disk), and arcs of the circle cut at their midpoints to at most a quarter
// turn each (the midpoint's direction: the chord's, turned clockwise by a quarter). The whole disk,
// if it lies inside: four quarter turns. At most 4 straight pieces and 4 arcs of under a turn in
// all, each cut into at most 4.
struct DiskPieces {
  using Point = DiskRectanglePath::Point;
  struct Piece {
    Point p, q;
    bool arc;
    double w = 0;  // the integral of w over its fan (UnitDiskPart::integrate)
  };
  Piece piece[20];
  int count = 0;

  // Of [u0, u1] x [v0, v1] (clipped to [-1, 1]^2, not empty).
  DiskPieces(double u0, double u1, double v0, double v1);
  // Of the convex polygon of `count` (3 or 4) corners counter-clockwise (a pixel's square in a
  // sheared disk's frame: PixelStratum::sheared).
  DiskPieces(const Point* corner, int count);

 private:
  void addArc(Point p, Point q, int depth);
};

// The unit disk's part of [u0, u1] x [v0, v1] as a sphere's front seen orthographically (u, v
// across the image in radii, w = sqrt(1 - u^2 - v^2) toward the viewer, the unit normal (u, v, w)):
// the integrals over it of 1, u, v and w, and of a light's cosine a u + b v + c w clamped at 0
// (diskControl's and ellipseControl's geometry). The part is the fans from the centre to the pieces of its boundary (DiskPieces),
// signed by their turn: its area, a straight piece's triangle and an arc's sector; u and v by
// Green's theorem (exact: polynomials of the pieces' ends); w, the hemisphere's volume over the
// part, an arc's fan's a third of its angle and a straight piece's the integral along it of the
// volume over its fan's rays ((1 - (1 - r^2)^1.5) / 3 over r^2, in a form that does not cancel near
// the centre) by 6-point Gauss-Legendre: against numerical integration over random disks of 0.3-5
// pixels' radius, within 1e-5 of the pixel (5e-6 seen), and over random sheared ones' pixels
// (parallelograms), within 3e-5 (2.2e-5 seen) (cpp/tests/test_pixel_stratum.cpp).
// Out of line (src/PixelStratum.cpp): adaptive sampling makes one a stratum pixel, not a sample.
struct UnitDiskPart {
  double area = 0, u = 0, v = 0, w = 0;  // the integrals of 1, u, v and w
  DiskPieces pieces;

  // The part of [u0, u1] x [v0, v1].
  UnitDiskPart(double u0, double u1, double v0, double v1);
  // The part of a convex polygon of 3 or 4 corners counter-clockwise.
  UnitDiskPart(const DiskPieces::Point* corner, int count);

  // The integral over the part of max(0, a u + b v + c w) (a light's cosine). Where the terminator
  // (where it is 0) crosses none of the part's pieces (an arc, at most a quarter turn on the rim,
  // where the cosine is a u + b v: its ends' signs differ where it does; a straight piece:
  // terminatorCrossings), the part lies on one side of it (the terminator ends on the rim): lit all
  // over, the moments' a u + b v + c w; dark, 0 exactly. Otherwise the sum over its fans: one whose
  // piece is lit all over, the light toward the viewer (c >= 0: along each ray from the centre the
  // lit stretch starts there), is lit all over, its moments' (a triangle's or a sector's first
  // moments exactly, w as integrate makes it); one whose piece is dark all over, the light behind
  // (c <= 0: the dark stretch starts at the centre), adds nothing; the rest cut where the terminator
  // crosses the piece or the cosine's rim term changes sign, between which each ray's integral takes
  // one closed form (lit all over: the stretch's moments; cut by the terminator: c (1 +- S / h) / 3,
  // S the rim term along the ray, h = sqrt(S^2 + c^2), whose integral across the fan is closed too,
  // an arcsine of the ray's angle). Within 1e-5 of numerical integration in the pixel's units over
  // random disks of 0.3-5 pixels' radius and random light directions, also in the view's plane or
  // along the view (6.3e-6 the worst of 6,000: a light along the view, w's quadrature by the rim).
  double clampedIntegral(double a, double b, double c) const;

  // Where the terminator of the light (a, b, c) crosses the straight piece from p to q: the roots s
  // in (0, 1) of (p0 + p1 s)^2 = c^2 (1 - |p + s d|^2) where p0 + p1 s, the cosine less c w, and c
  // are of opposite signs (at most 2, in `cut`); returns how many.
  static int terminatorCrossings(DiskRectanglePath::Point p, DiskRectanglePath::Point q, double a, double b, double c,
                                 double* cut);

 private:
  void integrate();  // the moments over the pieces (and each fan's of w)
};

// The unit disk's part of [u0, u1] x [v0, v1] within `circles` more circles (centres (cu[i],
// cv[i]), radii cr[i], in the disk's frame): where spheres' disks overlap, the part of a sphere's
// front that a nearer one's disk covers (StratumControl's exact mean where the spheres seen are
// known). A convex region (disks and a rectangle meet in one): its boundary the disk part's pieces
// (DiskPieces) clipped to each circle in turn, each circle's arc from where the boundary leaves it to
// where it comes back taking the stretch outside, counter-clockwise about the circle's centre. Its
// area (each fan's from the disk's centre: a triangle, a sector, or over another circle's arc in
// closed form) and the integral over it of a light's clamped cosine, by the fans (as
// UnitDiskPart::clampedIntegral's; across another circle's or an ellipse's arc by 6-point
// Gauss-Legendre in its parameter, cut where the terminator crosses it: found between points at
// most an eighth of a turn apart by false position).
struct ClippedDiskPart {
  static constexpr int kMostCircles = 2;
  struct Piece {
    DiskPieces::Point p, q;  // its ends
    // 0: straight, 1: an arc of the unit circle (at most a quarter turn, counter-clockwise), 2: another
    // circle's, 3: an ellipse's, (cu, cv) + (au, av) cos t + (bu, bv) sin t
    int kind;
    double cu, cv, radius, from, to;  // kinds 2 and 3: the centre, the circle's radius, and the arc's parameters
    double au = 0, av = 0, bu = 0, bv = 0;  // kind 3: its axes
  };
  Piece piece[64];
  int count = 0;
  double area = 0;

  ClippedDiskPart(double u0, double u1, double v0, double v1, const double* cu, const double* cv, const double* cr, int circles);
  // The region `count` pieces bound (each with the region on its left), in the disk's frame.
  ClippedDiskPart(const Piece* pieces, int count);
  double clampedIntegral(double a, double b, double c) const;

 private:
  void clip(double cu, double cv, double radius, double u0, double u1, double v0, double v1, int done, const double* pu,
            const double* pv, const double* pr);
};

// The area of the unit disk within the convex polygon of `count` vertices (u[i], v[i]), in either
// order: the sum over its edges of the signed area the disk shares with the triangle of the origin
// and the edge, which together cover the region once — the triangle's over the part of the edge
// inside the disk, the sector's (one arctangent) over each part outside it. An edge's ends on the
// circle come from the quadratic's roots in the form that does not cancel. Where no edge enters the
// disk, the polygon holds all of it or none (its sectors sum to about 2 pi or 0 by rounding): pi or
// 0 exactly.
inline double unitDiskPolygonArea(const double* u, const double* v, int count) {
  const auto sector = [](double ax, double ay, double bx, double by) {
    return std::atan2(ax * by - ay * bx, ax * bx + ay * by) / 2;
  };
  double twice = 0, area = 0;  // the polygon's own area (twice, signed), the disk's share of it
  bool entered = false;        // whether an edge runs inside the disk
  for (int i = 0; i < count; ++i) {
    const int j = i + 1 < count ? i + 1 : 0;
    const double ax = u[i], ay = v[i], bx = u[j], by = v[j];
    twice += ax * by - ay * bx;
    const double dx = bx - ax, dy = by - ay, a = dx * dx + dy * dy;
    if (!(a > 0)) continue;
    // Points a + t d on the circle: a t^2 + 2 b t + c = 0.
    const double b = ax * dx + ay * dy, c = ax * ax + ay * ay - 1, discriminant = b * b - a * c;
    if (!(discriminant > 0)) {
      area += sector(ax, ay, bx, by);
      continue;
    }
    const double q = -(b + std::copysign(std::sqrt(discriminant), b));
    const double r0 = q / a, r1 = q != 0 ? c / q : -r0;
    const double t0 = std::clamp(std::min(r0, r1), 0.0, 1.0), t1 = std::clamp(std::max(r0, r1), 0.0, 1.0);
    if (!(t0 < t1)) {
      area += sector(ax, ay, bx, by);
      continue;
    }
    entered = true;
    const double px = ax + t0 * dx, py = ay + t0 * dy, qx = ax + t1 * dx, qy = ay + t1 * dy;
    area += (t0 > 0 ? sector(ax, ay, px, py) : 0.0) + (px * qy - py * qx) / 2 + (t1 < 1 ? sector(qx, qy, bx, by) : 0.0);
  }
  if (!entered) return std::abs(area) > kPi / 2 ? kPi : 0.0;
  // Rounding keeps it within what the polygon and the disk hold.
  return std::clamp(std::abs(area), 0.0, std::min(std::abs(twice) / 2, kPi));
}

// The area of the union of `count` circles (centres (cu[i], cv[i]), radii r[i] > 0) within the
// rectangle [0, w] x [0, h]: Green's theorem, half the integral of u dv - v du counter-clockwise
// around the region's boundary, which is made of the arcs of each circle inside the rectangle and
// outside every other circle, and the parts of the rectangle's sides inside some circle. Each
// circle's arcs run between the points where the others and the sides cross it (found and ordered
// around it without trigonometry: one arctangent an arc that counts), tangent points included (an
// arc's midpoint then lies off the point of contact); an arc's midpoint says whether it bounds the
// region, a circle nothing crosses or touches is inside the rectangle and outside the others by its
// extent. A circle equal to an earlier one adds nothing (its arcs would count twice). An arc adds
// its chord's term and its circular segment's, so a wide circle's short arcs add terms the
// rectangle's size (not the radius's, which would cancel).
inline double circlesRectangleUnionArea(const double* cu, const double* cv, const double* r, int count, double w, double h) {
  constexpr int kMost = 8;  // circles read at most (the first)
  count = std::min(count, kMost);
  bool duplicate[kMost] = {};
  for (int i = 0; i < count; ++i) {
    for (int j = 0; j < i && !duplicate[i]; ++j) duplicate[i] = cu[i] == cu[j] && cv[i] == cv[j] && r[i] == r[j];
  }
  // A point on a circle as its offset (x, y) from the centre, where it is (u, v), and a key that
  // grows with its angle from +u counter-clockwise: 1 - cos in the upper half, 3 + cos in the
  // lower, so that half a turn adds exactly 2.
  struct Point {
    double key, x, y, u, v;
  };
  Point points[kMost][2 * (kMost - 1) + 8];
  int n[kMost] = {};
  double inverse[kMost];
  for (int i = 0; i < count; ++i) inverse[i] = 1 / r[i];
  // Written always, kept if `keep` (which way the tests go is as unpredictable as the geometry).
  const auto add = [&](int i, double x, double y, double u, double v, bool keep = true) {
    points[i][n[i]] = {y >= 0 ? 1 - x * inverse[i] : 3 + x * inverse[i], x, y, u, v};
    n[i] += keep;
  };
  // Which directions from circle i's centre (offsets) lie inside circle j: none, all, or those
  // counter-clockwise from (ax, ay) to (bx, by), the points where they cross (the side facing j). By
  // the crossings' directions rather than by distance, so that both circles agree where they nearly
  // touch or nearly coincide (where a distance says nothing, and one arc counted without the other
  // would leave the boundary open).
  enum Inside { kNone, kAll, kBetween };
  struct Facing {
    Inside inside;
    bool wide;       // more than half a turn (the crossings' chord is beyond the centre, away from j)
    double ex, ey;   // towards j
    double ax, ay, bx, by;
  };
  Facing facing[kMost][kMost];  // the rest of a pair's only where it is kBetween
  const auto insideCircle = [&](int i, int j, double x, double y) {
    const Facing& f = facing[i][j];
    if (f.inside != kBetween) return f.inside == kAll;
    // Within the turn from a to b, on j's side (open), or not within the turn back from b to a on
    // the other side (closed): so where a and b meet at a tangent point, none or all but it.
    const double fromA = f.ax * y - f.ay * x, toB = x * f.by - y * f.bx, towards = x * f.ex + y * f.ey;
    return f.wide ? fromA >= 0 || toB >= 0 || towards >= 0 : fromA > 0 && toB > 0 && towards > 0;
  };
  // Where two circles cross, found once for both (the same point ends both arcs), from the smaller
  // one's centre (its distance along the line of centres cancels least there). A crossing outside
  // the rectangle only splits arcs that are outside it too.
  const auto crossings = [&](int i, int j) {
    const double du = cu[j] - cu[i], dv = cv[j] - cv[i], d = std::sqrt(du * du + dv * dv);
    if (!(d <= r[i] + r[j] && d >= std::abs(r[i] - r[j]) && d > 0)) {  // tangents cross: an arc ends there
      const bool iInJ = d < r[j] - r[i] || (d == 0 && r[i] < r[j]), jInI = d < r[i] - r[j] || (d == 0 && r[j] < r[i]);
      facing[i][j].inside = iInJ ? kAll : kNone, facing[j][i].inside = jInI ? kAll : kNone;
      return;
    }
    const bool iSmall = r[i] <= r[j];
    const double rs = iSmall ? r[i] : r[j], rb = iSmall ? r[j] : r[i];
    const double along = (d < rs ? (rs - rb) * (rs + rb) + d * d : rs * rs + (d - rb) * (d + rb)) / (2 * d);
    const double half = std::sqrt(std::max(0.0, (rs - along) * (rs + along)));
    const double eu = (iSmall ? du : -du) / d, ev = (iSmall ? dv : -dv) / d;  // from the smaller towards the other
    const int s = iSmall ? i : j, b = iSmall ? j : i;
    const double ax = along * eu + half * ev, ay = along * ev - half * eu;  // from s's centre, clockwise of e
    const double bx = along * eu - half * ev, by = along * ev + half * eu;
    const double ou = cu[b] - cu[s], ov = cv[b] - cv[s];  // b's centre from s's
    facing[s][b] = {kBetween, along < 0, eu, ev, ax, ay, bx, by};
    facing[b][s] = {kBetween, d - along < 0, -eu, -ev, bx - ou, by - ov, ax - ou, ay - ov};
    for (const auto& [x, y] : {std::pair{ax, ay}, std::pair{bx, by}}) {
      const double u = cu[s] + x, v = cv[s] + y;
      if (u < 0 || u > w || v < 0 || v > h) continue;
      add(s, x, y, u, v), add(b, x - ou, y - ov, u, v);
    }
  };
  // Where circle i crosses or touches the sides (between two such points an arc lies all inside the
  // rectangle or all outside it): those at 0 and `extent` across (u = 0 and w when `vertical`, else
  // v = 0 and h), within [0, length] along them to rounding (a point just beyond a corner only
  // splits an arc outside; one missed where the circle passes through the corner would leave an arc
  // that is partly inside).
  const auto sides = [&](int i, bool vertical, double extent, double length) {
    const double across = vertical ? cu[i] : cv[i], along = vertical ? cv[i] : cu[i];
    const double slack = 8 * std::numeric_limits<double>::epsilon() * (std::abs(along) + r[i]);
    for (const double line : {0.0, extent}) {
      const double s = line - across, t = std::sqrt(std::max(0.0, (r[i] - s) * (r[i] + s)));
      const bool meets = std::abs(s) <= r[i];
      for (const double a : {t, -t}) {
        const bool keep = meets & (along + a >= -slack) & (along + a <= length + slack);
        vertical ? add(i, s, a, line, along + a, keep) : add(i, a, s, along + a, line, keep);
      }
    }
  };
  for (int i = 0; i < count; ++i) {
    for (int j = i + 1; j < count; ++j) {
      if (duplicate[i] || duplicate[j]) {
        facing[i][j].inside = facing[j][i].inside = kNone;
      } else {
        crossings(i, j);
      }
    }
    if (duplicate[i]) continue;
    sides(i, true, w, h), sides(i, false, h, w);
  }
  double twice = 0;  // twice the area
  for (int i = 0; i < count; ++i) {
    if (duplicate[i]) continue;
    const double ri = r[i];
    Point* const p = points[i];
    const int m = n[i];
    for (int k = 1; k < m; ++k) {  // insertion sort by the key: at most 2 (kMost - 1) + 8 points
      for (int l = k; l > 0 && p[l].key < p[l - 1].key; --l) std::swap(p[l], p[l - 1]);
    }
    // Whether its point in the direction (x, y) is inside the rectangle and outside the others. The
    // point's offset times the direction's length (no division on the way to the branch) against the
    // sides' offsets as `sides` and `coveredLength` take them: where the circle barely reaches past a
    // side, its arc there is outside exactly when the side has the chord instead.
    const auto bounds = [&](double x, double y) {
      const double length = std::sqrt(x * x + y * y), ru = ri * x, rv = ri * y;
      if (!(ru > -cu[i] * length && ru < (w - cu[i]) * length && rv > -cv[i] * length && rv < (h - cv[i]) * length)) return false;
      for (int j = 0; j < count; ++j) {
        if (j != i && insideCircle(i, j, x, y)) return false;
      }
      return true;
    };
    if (m == 0) {  // nothing crosses or touches it: the whole circle, or none of it, by its extent
      bool counts = cu[i] - ri >= 0 && cu[i] + ri <= w && cv[i] - ri >= 0 && cv[i] + ri <= h;
      for (int j = 0; j < count && counts; ++j) counts = j == i || facing[i][j].inside != kAll;  // and within no other
      if (counts) twice += 2 * kPi * ri * ri;
      continue;
    }
    for (int k = 0; k < m; ++k) {
      const Point& a = p[k];
      const Point& b = p[k + 1 < m ? k + 1 : 0];
      const double span = k + 1 < m ? b.key - a.key : b.key + 4 - a.key;  // 2: half a turn
      if (!(span > 0)) continue;
      // The arc's midpoint, from well-conditioned directions: the sum's (turned back beyond half a
      // turn) away from half a turn, else the chord's turned clockwise by a quarter.
      const double sx = a.x + b.x, sy = a.y + b.y;
      double mx = span > 2 ? -sx : sx, my = span > 2 ? -sy : sy;
      if (sx * sx + sy * sy < ri * ri) mx = b.y - a.y, my = a.x - b.x;
      if (!bounds(mx, my)) continue;
      // The keys say which half of a turn the arc spans; the arctangent near 0 or half a turn
      // may fall on the other side of it by rounding (where the ends nearly meet).
      const double cross = a.x * b.y - a.y * b.x;
      double angle = std::atan2(cross, a.x * b.x + a.y * b.y);  // in (-pi, pi]
      if (angle < (span > 2 ? kPi / 2 : -kPi / 2)) angle += 2 * kPi;
      twice += a.u * b.v - a.v * b.u + twiceSegment(angle, ri * ri, cross);
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
// they overlap. (A union filling the pixel, share 1 — filling() — is there for a control
// variate alone: its members may include a disk covering the pixel.)
// share 0 (as PixelStratum{} makes it): the pixel has none (its samples' plain mean stands).
// Trivial, for adaptive sampling's tile states (HugeArray).
struct PixelStratum {
  static constexpr int kMostDisks = 4;
  float cx[kMostDisks], cy[kMostDisks];                // the ellipses' centres
  float inverseAx[kMostDisks], inverseAy[kMostDisks];  // their semi-axes' inverses
  float share;   // of pixel (x, y)'s square [x, x + 1] x [y, y + 1] inside the union, in (0, 1); 1: filling it
  float aspect;  // of several: each one's semi-axes' ratio ay / ax, as its membership and the share take it
  int32_t disks;  // how many ellipses
  float shear;   // of one: a rotated ellipse's (sheared): u = (x - cx) inverseAx + (y - cy) shear; 0 else

  // The longest semi-axis (pixels) a stratum is made for. The share is found in the unit disk's
  // frame, where a pixel is 1/a^2 of the disk; the rounding of where the circle crosses the pixel's
  // sides (~1e-16 of the disk, over a side 1/a long) becomes ~1e-16 a of the pixel: at most 3e-13 at
  // a = 4096 and 8e-11 up to 1e6, measured against 50-digit integration; a rotated ellipse's share
  // (sheared, about the disk's centre) ~1e-16 a^2: at most 1.5e-9 measured. A sphere wider than this
  // over its pixels (a planet seen as a ground) keeps the plain mean.
  static constexpr double kMostAxis = 4096;

  // An ellipse of centre (cx, cy) and semi-axes ax, ay (pixels).
  struct Ellipse {
    double cx, cy, ax, ay;
  };

  // The stratum of pixel (x, y) by the union of `count` ellipses (the first kMostDisks), if its edge
  // crosses the pixel (and no axis exceeds kMostAxis); otherwise none: shaped(), its share by
  // unionShare().
  static PixelStratum of(int x, int y, const Ellipse* ellipses, int count) {
    const PixelStratum p = shaped(ellipses, count);
    return p.disks > 0 ? p.withShare(p.unionShare(x, y)) : p;
  }

  // The ellipses of a stratum (the first kMostDisks of `count`) as its members test them (centres
  // and inverses rounded to float), its share not yet known (0: any() is false until withShare);
  // none (no disk) where an axis exceeds kMostAxis or is not a positive finite number.
  static PixelStratum shaped(const Ellipse* ellipses, int count) {
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
    // Of several: pixel units across, the first ellipse's aspect down (v = (y - y0) iv / iu), which
    // every member takes (contains): circles of radius 1 / inverseAx.
    if (p.disks > 1) p.aspect = static_cast<float>(double(p.inverseAy[0]) / double(p.inverseAx[0]));
    return p;
  }

  // The share of pixel (x, y)'s square inside the union of a shaped() stratum's ellipses: one
  // ellipse's in the unit disk's frame (unitDiskRectangleArea); a union's in the frame where the
  // first is a circle, where the others are too (all of them one family: their axes' ratio is the
  // pixels' aspect, to float's rounding) — circlesRectangleUnionArea.
  double unionShare(int x, int y) const {
    const double iu = inverseAx[0], iv = inverseAy[0];
    if (disks == 1) {
      return unitDiskRectangleArea((x - double(cx[0])) * iu, (x + 1 - double(cx[0])) * iu, (y - double(cy[0])) * iv,
                                   (y + 1 - double(cy[0])) * iv) / (iu * iv);
    }
    double cu[kMostDisks], cv[kMostDisks], radius[kMostDisks];
    for (int i = 0; i < disks; ++i) {
      cu[i] = double(cx[i]) - x, cv[i] = (double(cy[i]) - y) * double(aspect), radius[i] = 1 / double(inverseAx[i]);
    }
    return circlesRectangleUnionArea(cu, cv, radius, disks, 1, double(aspect)) / double(aspect);
  }

  // This shaped() stratum filling its pixel (share 1: every sample lies inside), for its control
  // alone (TileRenderer's silhouetteStrata: a union that covers the pixel; fill: one disk that does);
  // none where shaped() made none.
  PixelStratum filling() const {
    PixelStratum p = *this;
    p.share = disks > 0 ? 1.0f : 0.0f;
    return p;
  }

  // This shaped() stratum with `share` (of its pixel inside the union), if that lies in (0, 1) as
  // rounded to float; otherwise none (its edge does not cross the pixel).
  PixelStratum withShare(double share) const {
    PixelStratum p = *this;
    p.share = static_cast<float>(share);
    return p.share > 0 && p.share < 1 ? p : PixelStratum{};
  }

  // The stratum of pixel (x, y) by one ellipse of centre (cx, cy) and semi-axes ax, ay.
  static PixelStratum of(int x, int y, double cx, double cy, double ax, double ay) {
    const Ellipse e{cx, cy, ax, ay};
    return of(x, y, &e, 1);
  }

  // The stratum of pixel (x, y) by a rotated ellipse of centre (cx, cy): the points where
  // (l11 du + l12 dv)^2 + (l22 dv)^2 < 1, du = x - cx and dv = y - cy (its quadratic form's Cholesky
  // factor: a sphere's silhouette through a perspective camera, TileRenderer::perspectiveStrata), if
  // its edge crosses the pixel and it reaches no farther than kMostAxis from its centre; otherwise
  // none. The share is the unit disk's within the pixel's square mapped to its frame (a
  // parallelogram), for the factor as rounded to float.
  static PixelStratum sheared(int x, int y, double cx, double cy, double l11, double l12, double l22) {
    PixelStratum p{};
    p.disks = 1;
    p.cx[0] = static_cast<float>(cx), p.cy[0] = static_cast<float>(cy);
    p.inverseAx[0] = static_cast<float>(l11), p.inverseAy[0] = static_cast<float>(l22), p.shear = static_cast<float>(l12);
    const double iu = p.inverseAx[0], iv = p.inverseAy[0], shear = p.shear;
    // Its reach from the centre: |dv| < 1 / l22 and |du| < (1 + |l12| / l22) / l11.
    const double reachV = 1 / iv, reachU = (1 + std::abs(shear) * reachV) / iu;
    if (!(iu > 0 && iv > 0 && reachU <= kMostAxis && reachV <= kMostAxis && std::isfinite(shear) &&
          std::isfinite(p.cx[0]) && std::isfinite(p.cy[0]))) {
      return {};
    }
    const double du0 = x - double(p.cx[0]), dv0 = y - double(p.cy[0]);
    const double du[4] = {du0, du0 + 1, du0 + 1, du0}, dv[4] = {dv0, dv0, dv0 + 1, dv0 + 1};
    double u[4], v[4];
    for (int i = 0; i < 4; ++i) u[i] = du[i] * iu + dv[i] * shear, v[i] = dv[i] * iv;
    p.share = static_cast<float>(unitDiskPolygonArea(u, v, 4) / (iu * iv));
    return p.share > 0 && p.share < 1 ? p : PixelStratum{};  // as rounded
  }

  bool any() const { return share > 0; }

  // Whether a sample at (x, y) lies inside the union (false for a pixel without a stratum): one
  // ellipse by its own axes and shear, several as circles in the frame of the first's aspect (as the share is
  // found; their own axes' ratios differ from it by float's rounding).
  bool contains(double x, double y) const {
    bool in = false;
    for (int i = 0; i < disks; ++i) {
      double u, v;
      frame(i, x, y, u, v);
      in = in || u * u + v * v < 1;
    }
    return any() && in;
  }

  // A point (x + u, y + v) of pixel (x, y)'s square outside the union and a thousandth of a pixel
  // clear of every member (the members' ellipses are silhouettes rounded to float, off by less than
  // that in an image under 16,384 pixels across): the first that is of the centres of the four
  // corner cells of a lattice of 32 cells a side (where a disk's edge leaves the outside, mostly),
  // then of every cell of lattices of 2 to 32 cells a side, coarse to fine, each row by row; false
  // where none is (no outside, or one thinner than the finest cells).
  bool outsidePoint(int x, int y, double& u, double& v) const {
    constexpr int kFinest = 32;
    const auto clear = [&](double pu, double pv) {
      for (int i = 0; i < disks; ++i) {
        double a, b;
        frame(i, x + pu, y + pv, a, b);
        const double reach = 1 + 1e-3 * std::max(double(inverseAx[i]), double(inverseAy[i]));  // over the smaller axis
        if (!(a * a + b * b > reach * reach)) return false;
      }
      u = pu, v = pv;
      return true;
    };
    constexpr double kNear = 0.5 / kFinest, kFar = 1 - kNear;
    if (clear(kNear, kNear) || clear(kFar, kNear) || clear(kNear, kFar) || clear(kFar, kFar)) return true;
    for (int grid = 2; grid <= kFinest; grid *= 2) {
      for (int cell = 0; cell < grid * grid; ++cell) {
        if (clear((cell % grid + 0.5) / grid, (cell / grid + 0.5) / grid)) return true;
      }
    }
    return false;
  }

  // Where (x, y) lies in the frame of ellipse i, where it is the unit disk (as contains tests it).
  void frame(int i, double x, double y, double& u, double& v) const {
    if (disks == 1) {
      const double dv = y - double(cy[0]);
      u = (x - double(cx[0])) * double(inverseAx[0]) + dv * double(shear), v = dv * double(inverseAy[0]);
      return;
    }
    u = (x - double(cx[i])) * double(inverseAx[i]), v = (y - double(cy[i])) * double(aspect) * double(inverseAx[i]);
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
