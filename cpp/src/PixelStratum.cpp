// The parts of PixelStratum.h that adaptive sampling calls once a pixel (its control variate's
// geometry, StratumControl.h): out of line, compiled into each kernel set (CMakeLists.txt) but not
// inlined into its renders.
#include "durer/render/PixelStratum.h"

#include <algorithm>
#include <cmath>

namespace durer {

namespace {

// The integral of w over the fan from the centre to the straight piece from p to q (inside the disk),
// the hemisphere's volume over it: along the piece, (1 - (1 - r^2)^1.5) / 3 over r^2 (in a form that
// does not cancel near the centre) by 6-point Gauss-Legendre, times the fan's turn.
double wFan(DiskPieces::Point p, DiskPieces::Point q) {
  const double du = q.u - p.u, dv = q.v - p.v;
  // The nodes' terms in one pass of vector roots and quotients, summed in order below.
  double term[6];
  for (int j = 0; j < 6; ++j) {
    const double bu = p.u + kGaussNode[j] * du, bv = p.v + kGaussNode[j] * dv, rest = positivePart(1 - bu * bu - bv * bv);
    term[j] = kGaussWeight[j] * (1 + rest + rest * rest) / (1 + rest * std::sqrt(rest));  // (1 - rest^1.5) / r^2
  }
  double sum = 0;
  for (int j = 0; j < 6; ++j) sum += term[j];
  return (p.u * q.v - p.v * q.u) * sum / 3;
}

// Along a fan's ray from the disk's centre, of direction e (any length), out to r, the light's cosine
// is S t + c sqrt(1 - t^2) (S = (a, b) . e / |e|): the terminator, where it is 0, crosses the ray at
// t = |c| / h (h = sqrt(S^2 + c^2)) if S and c differ in sign and r h > |c|. The ray's integral of
// the cosine clamped at 0 (times t dt) is then one of three closed forms: the whole ray's, lit all
// over (kLit: (S r^3 - c w^3 + c) / 3, w = sqrt(1 - r^2)); where the light faces the viewer (c > 0)
// and the ray leaves it, its stretch before the terminator (kNear: c (1 + S / h) / 3, whatever r);
// where the light is behind (c < 0) and the ray reaches it, its stretch beyond the terminator
// (kFar: the whole ray's less c (1 - S / h) / 3); or nothing (kDark). raysOf tells which from r^2:
// r h > |c| squared and times |e|^2, r^2 (s^2 + c^2 |e|^2) > c^2 |e|^2 with s = (a, b) . e, of S's
// sign — no root nor quotient, whose latencies chained were a third of chordFan's time.
enum class FanRays { kLit, kNear, kFar, kDark };

FanRays raysOf(double ex, double ey, double r2, double a, double b, double c) {
  const double s = a * ex + b * ey, reach = c * c * (ex * ex + ey * ey);
  const bool crossed = r2 * (s * s + reach) > reach;
  if (c > 0) return s < 0 && crossed ? FanRays::kNear : FanRays::kLit;
  if (c < 0) return s > 0 && crossed ? FanRays::kFar : FanRays::kDark;
  return s > 0 ? FanRays::kLit : FanRays::kDark;
}

// The integral of c (1 + side S / h) / 3 (kNear's with side 1, kFar's less with -1) across the fan
// from direction p to direction q (any lengths; less than half a turn apart): c / 3 times the angle
// plus side times that of S / h, whose antiderivative in the ray's angle t is asin(A sin(t - psi) /
// H) (A, psi the polar form of (a, b), H = sqrt(A^2 + c^2)), the argument of (h, A sin(t - psi)),
// here scaled by |e|. As 1 + side S / h lies in [0, 1] on such rays, the sum lies within half a turn:
// one argument, of the product of the three complex numbers.
double terminatorFan(DiskPieces::Point p, DiskPieces::Point q, double a, double b, double c, double side) {
  const auto antiderivative = [&](DiskPieces::Point e, double& re, double& im) {
    const double along = a * e.u + b * e.v;
    re = std::sqrt(along * along + c * c * (e.u * e.u + e.v * e.v)), im = side * (a * e.v - b * e.u);
  };
  double pr, pi, qr, qi;
  antiderivative(p, pr, pi), antiderivative(q, qr, qi);
  const double turnRe = qr * pr + qi * pi, turnIm = qi * pr - qr * pi;  // q's times p's conjugate
  const double angleRe = p.u * q.u + p.v * q.v, angleIm = p.u * q.v - p.v * q.u;
  return c / 3 * std::atan2(angleRe * turnIm + angleIm * turnRe, angleRe * turnRe - angleIm * turnIm);
}

// kLit's integral across the fan from the centre to the straight piece from p to q (inside the
// disk): the triangle's moments of a u + b v exactly, and c times its fan's of w (wFan).
double litFan(DiskPieces::Point p, DiskPieces::Point q, double a, double b, double c) {
  const double cross = p.u * q.v - p.v * q.u;
  return cross * (a * (p.u + q.u) + b * (p.v + q.v)) / 6 + c * wFan(p, q);
}

// kLit's across the fan to an arc of the unit circle from p to q (on it; at most a quarter turn).
double litArcFan(DiskPieces::Point p, DiskPieces::Point q, double a, double b, double c) {
  return (a * (q.v - p.v) - b * (q.u - p.u)) / 3 + c * std::atan2(p.u * q.v - p.v * q.u, p.u * q.u + p.v * q.v) / 3;
}

// The fan integral of the clamped cosine over the fan from the centre to a straight piece (arc
// false) or an arc of the unit circle (its points the chord's pushed out to the circle), cut at `cut`
// (sorted, within (0, 1): where the terminator crosses it) and where the rim term a u + b v changes
// sign: between cuts its rays are of one kind (FanRays), each stretch's fan in closed form but for
// a straight piece's w (wFan).
double chordFan(DiskPieces::Point p, DiskPieces::Point q, bool arc, double a, double b, double c, const double* cuts, int count) {
  if (p.u * q.v - p.v * q.u == 0) return 0;
  const double du = q.u - p.u, dv = q.v - p.v, p0 = a * p.u + b * p.v, p1 = a * du + b * dv;
  double cut[5] = {0, 1, 1, 1, 1};
  int n = 1;
  for (int k = 0; k < count; ++k) cut[n++] = cuts[k];
  if (p1 != 0 && -p0 / p1 > 0 && -p0 / p1 < 1) cut[n++] = -p0 / p1;
  for (int i = 2; i < n; ++i) {  // cut[1..n) sorted by insertion: at most four
    for (int j = i; j > 1 && cut[j] < cut[j - 1]; --j) std::swap(cut[j], cut[j - 1]);
  }
  cut[n] = 1;
  const auto at = [&](double s) { return s == 0 ? p : s == 1 ? q : DiskPieces::Point{p.u + s * du, p.v + s * dv}; };
  const auto onRim = [](DiskPieces::Point e) {
    const double l = std::sqrt(e.u * e.u + e.v * e.v);
    return DiskPieces::Point{e.u / l, e.v / l};
  };
  double sum = 0;
  for (int k = 0; k < n; ++k) {
    if (!(cut[k] < cut[k + 1])) continue;
    const DiskPieces::Point from = at(cut[k]), to = at(cut[k + 1]), mid = at((cut[k] + cut[k + 1]) / 2);
    const FanRays rays = raysOf(mid.u, mid.v, arc ? 1.0 : std::min(1.0, mid.u * mid.u + mid.v * mid.v), a, b, c);
    if (rays == FanRays::kDark) continue;
    if (rays != FanRays::kNear) sum += arc ? litArcFan(onRim(from), onRim(to), a, b, c) : litFan(from, to, a, b, c);
    if (rays == FanRays::kNear) sum += terminatorFan(from, to, a, b, c, 1);
    if (rays == FanRays::kFar) sum -= terminatorFan(from, to, a, b, c, -1);
  }
  return sum;
}

// A root of f between x0 and x1, where f's values f0 and f1 differ in sign: false position with the
// Illinois rule (the end kept twice has its value halved), to the last bits of x.
template <typename F>
double signChange(double x0, double f0, double x1, double f1, const F& f) {
  double x = x1;
  for (int it = 0, side = 0; it < 60; ++it) {
    const double next = (f0 * x1 - f1 * x0) / (f0 - f1);
    if (!(next > std::min(x0, x1) && next < std::max(x0, x1)) || next == x) return next == next ? next : (x0 + x1) / 2;
    x = next;
    const double fx = f(x);
    if (fx == 0) return x;
    if ((fx < 0) == (f1 < 0)) {
      x1 = x, f1 = fx;
      if (side == -1) f0 /= 2;
      side = -1;
    } else {
      x0 = x, f0 = fx;
      if (side == 1) f1 /= 2;
      side = 1;
    }
  }
  return x;
}

// The area the pieces bound: half the integral of u dv - v du along them (each piece's fan from the
// centre: a triangle, a sector, or in closed form over another circle's or an ellipse's arc).
double areaOf(const ClippedDiskPart::Piece* piece, int count) {
  double twice = 0;
  for (int i = 0; i < count; ++i) {
    const ClippedDiskPart::Piece& e = piece[i];
    const double cross = e.p.u * e.q.v - e.p.v * e.q.u;
    if (e.kind == 0) {
      twice += cross;
    } else if (e.kind == 1) {
      twice += std::atan2(cross, e.p.u * e.q.u + e.p.v * e.q.v);
    } else if (e.kind == 2) {
      twice += e.radius * (e.cu * (std::sin(e.to) - std::sin(e.from)) - e.cv * (std::cos(e.to) - std::cos(e.from))) +
               e.radius * e.radius * (e.to - e.from);
    } else {  // u dv - v du = cu (bv cos - av sin) - cv (bu cos - au sin) + au bv - av bu
      const double ds = std::sin(e.to) - std::sin(e.from), dc = std::cos(e.to) - std::cos(e.from);
      twice += e.cu * (e.bv * ds + e.av * dc) - e.cv * (e.bu * ds + e.au * dc) + (e.au * e.bv - e.av * e.bu) * (e.to - e.from);
    }
  }
  return std::max(0.0, twice / 2);
}

}  // namespace

DiskPieces::DiskPieces(double u0, double u1, double v0, double v1) {
  const DiskRectanglePath path(u0, u1, v0, v1);
  const int n = path.count;
  if (n == 0) {
    if (!(u0 == -1 && u1 == 1 && v0 == -1 && v1 == 1)) return;  // apart
    const Point e{1, 0}, north{0, 1}, w{-1, 0}, south{0, -1};
    piece[0] = {e, north, true}, piece[1] = {north, w, true}, piece[2] = {w, south, true}, piece[3] = {south, e, true};
    count = 4;
    return;
  }
  for (int k = 0; k < n; ++k) {
    const Point p = path.point[k], q = path.point[k + 1 < n ? k + 1 : 0];
    if (k % 2 == 0) {
      piece[count++] = {p, q, false};
    } else if (!(p.u == q.u && p.v == q.v)) {
      addArc(p, q, 0);
    }
  }
}

DiskPieces::DiskPieces(const Point* corner, int n) {
  // Each side's chord inside the disk, where it has one: from a + t0 d to a + t1 d, 0 <= t0 < t1 <= 1
  // (roots of |a + t d|^2 = 1 in the form that does not cancel); whether it leaves through the circle.
  Point start[4], end[4];
  bool leaves[4];
  int chords = 0;
  for (int k = 0; k < n; ++k) {
    const Point a = corner[k], b = corner[k + 1 < n ? k + 1 : 0];
    const double du = b.u - a.u, dv = b.v - a.v, qa = du * du + dv * dv;
    const double qb = a.u * du + a.v * dv, qc = a.u * a.u + a.v * a.v - 1, discriminant = qb * qb - qa * qc;
    if (!(qa > 0 && discriminant > 0)) continue;
    const double q = -(qb + std::copysign(std::sqrt(discriminant), qb));
    const double r0 = q / qa, r1 = q != 0 ? qc / q : -r0;
    const double t0 = std::clamp(std::min(r0, r1), 0.0, 1.0), t1 = std::clamp(std::max(r0, r1), 0.0, 1.0);
    if (!(t0 < t1)) continue;
    start[chords] = {a.u + t0 * du, a.v + t0 * dv}, end[chords] = t1 < 1 ? Point{a.u + t1 * du, a.v + t1 * dv} : b;
    leaves[chords++] = t1 < 1;
  }
  if (chords == 0) {  // no side reaches into the disk: the polygon holds all of it, or none
    bool holds = true;
    for (int k = 0; k < n; ++k) {
      const Point a = corner[k], b = corner[k + 1 < n ? k + 1 : 0];
      holds = holds && (b.u - a.u) * (0 - a.v) - (b.v - a.v) * (0 - a.u) > 0;  // the centre left of each side
    }
    if (!holds) return;
    const Point e{1, 0}, north{0, 1}, w{-1, 0}, south{0, -1};
    piece[0] = {e, north, true}, piece[1] = {north, w, true}, piece[2] = {w, south, true}, piece[3] = {south, e, true};
    count = 4;
    return;
  }
  // The chords in order, an arc from where one leaves the disk to where the next enters it.
  for (int k = 0; k < chords; ++k) {
    piece[count++] = {start[k], end[k], false};
    const Point next = start[k + 1 < chords ? k + 1 : 0];
    if (leaves[k] && !(end[k].u == next.u && end[k].v == next.v)) addArc(end[k], next, 0);
  }
}

void DiskPieces::addArc(Point p, Point q, int depth) {
  const bool quarter = p.u * q.v - p.v * q.u > 0 && p.u * q.u + p.v * q.v >= 0;
  if (quarter || depth == 2) {
    piece[count++] = {p, q, true};
    return;
  }
  double mu = q.v - p.v, mv = p.u - q.u;
  const double l = std::sqrt(mu * mu + mv * mv);
  const Point m{mu / l, mv / l};
  addArc(p, m, depth + 1), addArc(m, q, depth + 1);
}

UnitDiskPart::UnitDiskPart(double u0, double u1, double v0, double v1)
    : pieces(std::max(u0, -1.0), std::min(u1, 1.0), std::max(v0, -1.0), std::min(v1, 1.0)) {
  integrate();
}

UnitDiskPart::UnitDiskPart(const DiskPieces::Point* corner, int count) : pieces(corner, count) { integrate(); }

void UnitDiskPart::integrate() {
  for (int i = 0; i < pieces.count; ++i) {
    auto& [p, q, arc, fanW] = pieces.piece[i];
    const double cross = p.u * q.v - p.v * q.u;
    if (arc) {  // u = cos, v = sin: the integrals of cos^3 / 2 and sin^3 / 2 over its angle
      u += (q.v - q.v * q.v * q.v / 3 - (p.v - p.v * p.v * p.v / 3)) / 2;
      v += (-q.u + q.u * q.u * q.u / 3 - (-p.u + p.u * p.u * p.u / 3)) / 2;
      const double angle = std::atan2(cross, p.u * q.u + p.v * q.v);
      fanW = angle / 3;
      area += angle / 2, w += fanW;
      continue;
    }
    const double du = q.u - p.u, dv = q.v - p.v;
    area += cross / 2;
    u += dv / 6 * (p.u * p.u + p.u * q.u + q.u * q.u);
    v -= du / 6 * (p.v * p.v + p.v * q.v + q.v * q.v);
    fanW = wFan(p, q);
    w += fanW;
  }
}

double UnitDiskPart::clampedIntegral(double a, double b, double c) const {
  // The cosine at each piece's ends. The part is convex, and over it the cosine is concave where
  // c >= 0 (c w is) and convex where c <= 0: its least value (c >= 0), or its greatest (c <= 0), lies
  // at a straight piece's end or on an arc, where it is a u + b v and, over at most a quarter turn,
  // lies between its ends' values unless both are of the other sign. So where c >= 0 and every end
  // is lit, the part is lit all over; where c <= 0 and every end is dark, dark all over; and a
  // straight piece whose ends are both so is crossed by no terminator.
  const int n = pieces.count;
  double atP[20], atQ[20];
  bool lit = c >= 0, dark = c <= 0;
  for (int i = 0; i < n; ++i) {
    const auto& [p, q, arc, fanW] = pieces.piece[i];
    const auto rim = [&](DiskPieces::Point e) { return arc ? 0.0 : std::sqrt(std::max(0.0, 1 - e.u * e.u - e.v * e.v)); };
    atP[i] = a * p.u + b * p.v + c * rim(p), atQ[i] = a * q.u + b * q.v + c * rim(q);
    lit = lit && atP[i] >= 0 && atQ[i] >= 0, dark = dark && atP[i] <= 0 && atQ[i] <= 0;
  }
  if (lit) return std::max(0.0, a * u + b * v + c * w);
  if (dark) return 0;
  lit = dark = true;
  // Otherwise each piece: where the terminator crosses it, and whether the light lights it all over
  // (side 1), leaves it dark all over (-1), or neither (0); the sum over its fans.
  double crossing[20][2];
  int crossings[20];
  int side[20];
  for (int i = 0; i < n; ++i) {
    const auto& [p, q, arc, fanW] = pieces.piece[i];
    const bool litEnds = atP[i] >= 0 && atQ[i] >= 0, darkEnds = atP[i] <= 0 && atQ[i] <= 0;
    const bool oneSide = arc || (c >= 0 && litEnds) || (c <= 0 && darkEnds);
    crossings[i] = oneSide ? 0 : terminatorCrossings(p, q, a, b, c, crossing[i]);
    side[i] = crossings[i] > 0 ? 0 : litEnds ? 1 : darkEnds ? -1 : 0;
    lit = lit && side[i] == 1, dark = dark && side[i] == -1;
  }
  // Where the terminator crosses no piece, the part lies on one side of it (it ends on the rim: where
  // it enters the part, it crosses a piece).
  if (lit) return std::max(0.0, a * u + b * v + c * w);
  if (dark) return 0;
  double total = 0;
  for (int i = 0; i < n; ++i) {
    const auto& [p, q, arc, fanW] = pieces.piece[i];
    const double cross = p.u * q.v - p.v * q.u;
    if (cross == 0 || (side[i] == -1 && c <= 0)) continue;  // no fan, or one dark all over
    if (side[i] == 1 && c >= 0) {  // a fan lit all over: its moments
      const double du = q.u - p.u, dv = q.v - p.v;
      total += (arc ? (a * dv - b * du) / 3 : cross * (a * (p.u + q.u) + b * (p.v + q.v)) / 6) + c * fanW;
      continue;
    }
    total += chordFan(p, q, arc, a, b, c, crossing[i], crossings[i]);
  }
  return std::max(total, 0.0);
}

int UnitDiskPart::terminatorCrossings(DiskRectanglePath::Point p, DiskRectanglePath::Point q, double a, double b, double c,
                               double* cut) {
  const double du = q.u - p.u, dv = q.v - p.v, p0 = a * p.u + b * p.v, p1 = a * du + b * dv;
  const double e0 = p.u * p.u + p.v * p.v, e1 = 2 * (p.u * du + p.v * dv), e2 = du * du + dv * dv;
  const double qa = p1 * p1 + c * c * e2, qb = 2 * p0 * p1 + c * c * e1, qc = p0 * p0 - c * c * (1 - e0);
  const double discriminant = qb * qb - 4 * qa * qc;
  int n = 0;
  if (!(discriminant > 0 && qa > 0)) return n;
  for (const double root : {(-qb + std::sqrt(discriminant)) / (2 * qa), (-qb - std::sqrt(discriminant)) / (2 * qa)}) {
    if (root > 0 && root < 1 && (p0 + p1 * root) * c < 0) cut[n++] = root;
  }
  return n;
}


ClippedDiskPart::ClippedDiskPart(double u0, double u1, double v0, double v1, const double* cu, const double* cv,
                                 const double* cr, int circles) {
  u0 = std::max(u0, -1.0), u1 = std::min(u1, 1.0), v0 = std::max(v0, -1.0), v1 = std::min(v1, 1.0);
  if (!(u0 < u1 && v0 < v1)) return;
  const DiskPieces pieces(u0, u1, v0, v1);
  for (int i = 0; i < pieces.count; ++i) {
    const auto& from = pieces.piece[i];
    piece[count++] = {from.p, from.q, from.arc ? 1 : 0, 0, 0, 0, 0, 0};
  }
  for (int i = 0; i < std::min(circles, kMostCircles) && count > 0; ++i) clip(cu[i], cv[i], cr[i], u0, u1, v0, v1, i, cu, cv, cr);
  area = areaOf(piece, count);
}

ClippedDiskPart::ClippedDiskPart(const Piece* pieces, int n) : count(std::min(n, 64)) {
  std::copy(pieces, pieces + count, piece);
  area = areaOf(piece, count);
}

void ClippedDiskPart::clip(double ku, double kv, double radius, double u0, double u1, double v0, double v1, int done,
                           const double* pu, const double* pv, const double* pr) {
  using Point = DiskPieces::Point;
  const double rr = radius * radius;
  const auto inside = [&](Point m) { return (m.u - ku) * (m.u - ku) + (m.v - kv) * (m.v - kv) < rr; };
  // Where the circle meets another of centre (ou, ov) and radius orr's root: its points, as seen
  // from that circle's centre (none where they do not cross).
  const auto meet = [&](double ou, double ov, double other, Point* at) {
    const double du = ku - ou, dv = kv - ov, d = std::sqrt(du * du + dv * dv);
    if (!(d > std::abs(other - radius) && d < other + radius)) return 0;
    const double along = (other * other - rr + d * d) / (2 * d), half = std::sqrt(std::max(0.0, other * other - along * along));
    const double eu = du / d, ev = dv / d;
    at[0] = {along * eu - half * ev, along * ev + half * eu}, at[1] = {along * eu + half * ev, along * ev - half * eu};
    return 2;
  };
  struct Sub {
    Piece piece;
    bool in;
  };
  Sub sub[160];
  int n = 0;
  for (int i = 0; i < count; ++i) {
    const Piece& e = piece[i];
    if (e.kind == 0) {  // p + s d on the circle: a s^2 + 2 b s + c = 0
      const double du = e.q.u - e.p.u, dv = e.q.v - e.p.v, wu = e.p.u - ku, wv = e.p.v - kv;
      const double a = du * du + dv * dv, b = wu * du + wv * dv, c = wu * wu + wv * wv - rr, disc = b * b - a * c;
      double s[4] = {0, 1, 1, 1};
      int m = 1;
      if (a > 0 && disc > 0) {
        const double q = -(b + std::copysign(std::sqrt(disc), b)), r0 = q / a, r1 = q != 0 ? c / q : -r0;
        for (const double r : {std::min(r0, r1), std::max(r0, r1)}) {
          if (r > 0 && r < 1) s[m++] = r;
        }
      }
      s[m] = 1;
      for (int k = 0; k < m; ++k) {
        const Point from{e.p.u + s[k] * du, e.p.v + s[k] * dv}, to = k + 1 == m ? e.q : Point{e.p.u + s[k + 1] * du, e.p.v + s[k + 1] * dv};
        const double mid = (s[k] + s[k + 1]) / 2;
        sub[n++] = {{k == 0 ? e.p : from, to, 0, 0, 0, 0, 0, 0}, inside({e.p.u + mid * du, e.p.v + mid * dv})};
      }
    } else if (e.kind == 1) {  // an arc of the unit circle, at most a quarter turn: cut where the circle crosses it
      Point at[2];
      const int met = meet(0, 0, 1, at);
      Point cut[2];
      int m = 0;
      for (int k = 0; k < met; ++k) {
        if (e.p.u * at[k].v - e.p.v * at[k].u > 0 && at[k].u * e.q.v - at[k].v * e.q.u > 0) cut[m++] = at[k];
      }
      if (m == 2 && e.p.u * cut[0].u + e.p.v * cut[0].v < e.p.u * cut[1].u + e.p.v * cut[1].v) std::swap(cut[0], cut[1]);
      Point ends[4] = {e.p};
      for (int k = 0; k < m; ++k) ends[k + 1] = cut[k];
      ends[m + 1] = e.q;
      for (int k = 0; k <= m; ++k) {
        const double su = ends[k].u + ends[k + 1].u, sv = ends[k].v + ends[k + 1].v, l = std::sqrt(su * su + sv * sv);
        sub[n++] = {{ends[k], ends[k + 1], 1, 0, 0, 0, 0, 0}, inside({su / l, sv / l})};
      }
    } else {  // an arc of an earlier circle: cut where this one crosses it
      Point at[2];
      const int met = meet(e.cu, e.cv, e.radius, at);
      double angle[4] = {e.from};
      int m = 1;
      for (int k = 0; k < met; ++k) {
        double t = std::atan2(at[k].v, at[k].u);
        while (t < e.from) t += 2 * kPi;
        if (t < e.to) angle[m++] = t;
      }
      if (m == 3 && angle[2] < angle[1]) std::swap(angle[1], angle[2]);
      angle[m] = e.to;
      for (int k = 0; k < m; ++k) {
        const auto point = [&](double t) { return Point{e.cu + e.radius * std::cos(t), e.cv + e.radius * std::sin(t)}; };
        sub[n++] = {{k == 0 ? e.p : point(angle[k]), k + 1 == m ? e.q : point(angle[k + 1]), 2, e.cu, e.cv, e.radius, angle[k], angle[k + 1]},
                    inside(point((angle[k] + angle[k + 1]) / 2))};
      }
    }
  }
  int start = -1, kept = 0;
  for (int j = 0; j < n; ++j) {
    kept += sub[j].in;
    if (sub[j].in && !sub[j > 0 ? j - 1 : n - 1].in) start = j;
  }
  if (kept == n) return;  // the region lies inside the circle
  if (kept == 0) {        // none of its boundary does: the circle lies inside the region, or apart
    const Point e{ku + radius, kv};
    bool within = e.u * e.u + e.v * e.v < 1 && e.u > u0 && e.u < u1 && e.v > v0 && e.v < v1;
    for (int i = 0; i < done && within; ++i) within = (e.u - pu[i]) * (e.u - pu[i]) + (e.v - pv[i]) * (e.v - pv[i]) < pr[i] * pr[i];
    count = 0;
    if (within) piece[count++] = {e, e, 2, ku, kv, radius, 0, 2 * kPi};
    return;
  }
  count = 0;
  Point leaves{};
  for (int j = 0, k = start; j < n; ++j, k = k + 1 < n ? k + 1 : 0) {
    const Sub& t = sub[k];
    const Sub& next = sub[k + 1 < n ? k + 1 : 0];
    if (t.in) {
      piece[count++] = t.piece;
      if (!next.in) leaves = t.piece.q;
    } else if (next.in) {  // back into the circle: its arc from where the boundary left it
      const Point comes = next.piece.p;
      const double from = std::atan2(leaves.v - kv, leaves.u - ku);
      double to = std::atan2(comes.v - kv, comes.u - ku);
      while (to <= from) to += 2 * kPi;
      piece[count++] = {leaves, comes, 2, ku, kv, radius, from, to};
    }
  }
}

double ClippedDiskPart::clampedIntegral(double a, double b, double c) const {
  double total = 0;
  for (int i = 0; i < count; ++i) {
    const Piece& e = piece[i];
    if (e.kind == 0) {
      double crossing[2];
      const int crossings = UnitDiskPart::terminatorCrossings(e.p, e.q, a, b, c, crossing);
      total += chordFan(e.p, e.q, false, a, b, c, crossing, crossings);
      continue;
    }
    if (e.kind == 1) {
      total += chordFan(e.p, e.q, true, a, b, c, nullptr, 0);
      continue;
    }
    // Another circle's arc, in the angle t about its centre: b(t) = centre + radius (cos t, sin t); an
    // ellipse's, b(t) = centre + a cos t + b sin t. The fan's angle about the disk's centre turns by
    // b x b'(t) / |b|^2 dt. The cosine at b(t), whose sign changes where the terminator crosses the arc.
    const bool circle = e.kind == 2;
    const double au = circle ? e.radius : e.au, av = circle ? 0 : e.av, bu2 = circle ? 0 : e.bu, bv2 = circle ? e.radius : e.bv;
    const auto at = [&](double t, double& bu, double& bv) {
      bu = e.cu + au * std::cos(t) + bu2 * std::sin(t), bv = e.cv + av * std::cos(t) + bv2 * std::sin(t);
    };
    const auto cosine = [&](double t) {
      double bu, bv;
      at(t, bu, bv);
      return a * bu + b * bv + c * std::sqrt(std::max(0.0, 1 - bu * bu - bv * bv));
    };
    const int quarters = std::max(1, static_cast<int>(std::ceil(std::abs(e.to - e.from) / (kPi / 2))));
    for (int h = 0; h < quarters; ++h) {
      const double t0 = e.from + (e.to - e.from) * h / quarters, t1 = e.from + (e.to - e.from) * (h + 1) / quarters;
      double cut[24] = {t0};
      int n = 1;
      // Where the rim term a u + b v changes sign: a cu + b cv + alpha cos t + beta sin t = 0.
      const double alpha = a * au + b * av, beta = a * bu2 + b * bv2, reach = std::sqrt(alpha * alpha + beta * beta);
      const double lo = std::min(t0, t1), hi = std::max(t0, t1);
      if (reach > 0) {
        const double x = -(a * e.cu + b * e.cv) / reach;
        if (std::abs(x) < 1) {
          const double phase = std::atan2(beta, alpha), off = std::acos(x);
          for (double t : {phase + off, phase - off}) {
            while (t < lo) t += 2 * kPi;
            while (t - 2 * kPi >= lo) t -= 2 * kPi;
            if (t < hi) cut[n++] = t;
          }
        }
      }
      // Where the cosine changes sign: between points at most an eighth of a turn apart, then by
      // false position (Illinois).
      const int steps = std::max(1, static_cast<int>(std::ceil(std::abs(t1 - t0) / (kPi / 8))));
      double before = cosine(t0);
      for (int k = 1; k <= steps && n < 23; ++k) {
        const double now = cosine(t0 + (t1 - t0) * k / steps);
        if ((before < 0) != (now < 0)) cut[n++] = signChange(t0 + (t1 - t0) * (k - 1) / steps, before, t0 + (t1 - t0) * k / steps, now, cosine);
        before = now;
      }
      std::sort(cut + 1, cut + n, [&](double x, double y) { return t1 > t0 ? x < y : x > y; });
      cut[n] = t1;
      // Between cuts the rays are of one kind (FanRays); across the stretch by 6-point Gauss-Legendre
      // in tau = tan(sigma / 2), t = its middle + sigma (no sine or cosine a point: cos sigma = (1 -
      // tau^2) / (1 + tau^2), sin sigma = 2 tau / (1 + tau^2), d sigma = 2 d tau / (1 + tau^2)), the
      // fan's turn b x b' / |b|^2 times its ray's integral (kLit's, over r^2 without cancelling: a u +
      // b v plus c (1 + w + w^2) / (1 + w)).
      for (int k = 0; k < n; ++k) {
        const double middle = (cut[k] + cut[k + 1]) / 2, half = (cut[k + 1] - cut[k]) / 2;
        const double cm = std::cos(middle), sm = std::sin(middle);
        // b(middle + sigma) = centre + p cos sigma + q sin sigma
        const double pu = au * cm + bu2 * sm, pv = av * cm + bv2 * sm, qu = bu2 * cm - au * sm, qv = bv2 * cm - av * sm;
        const double mu = e.cu + pu, mv = e.cv + pv, mr = std::sqrt(mu * mu + mv * mv);
        if (!(half != 0 && mr > 0)) continue;
        const FanRays rays = raysOf(mu, mv, std::min(mu * mu + mv * mv, 1.0), a, b, c);
        if (rays == FanRays::kDark) continue;
        const double reach = std::tan(half / 2);
        for (int j = 0; j < 6; ++j) {
          const double tau = reach * (2 * kGaussNode[j] - 1), d = 1 / (1 + tau * tau), cs = (1 - tau * tau) * d, sn = 2 * tau * d;
          const double bu = e.cu + pu * cs + qu * sn, bv = e.cv + pv * cs + qv * sn, du = qu * cs - pu * sn, dv = qv * cs - pv * sn;
          const double r2 = bu * bu + bv * bv;
          if (!(r2 > 0)) continue;
          const double along = a * bu + b * bv;
          double ray = 0;
          if (rays != FanRays::kNear) {
            const double w = std::sqrt(std::max(0.0, 1 - r2));
            ray += along + c * (1 + w + w * w) / (1 + w);
          }
          if (rays != FanRays::kLit) {
            const double slope = along / std::sqrt(r2), side = rays == FanRays::kNear ? 1 : -1;
            ray += side * c * (1 + side * slope / std::sqrt(slope * slope + c * c)) / r2;
          }
          total += kGaussWeight[j] * 4 * reach * d * (bu * dv - bv * du) * ray / 3;
        }
      }
    }
  }
  return std::max(total, 0.0);
}

}  // namespace durer
