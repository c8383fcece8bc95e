// The parts of PixelStratum.h that adaptive sampling calls once a pixel (its control variate's
// geometry, StratumControl.h): out of line, compiled once rather than in every kernel set.
#include "durer/render/PixelStratum.h"

#include <algorithm>
#include <cmath>

namespace durer {

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
  static constexpr double kNode[6] = {0.033765242898423975, 0.16939530676686776, 0.38069040695840156,
                                      0.61930959304159844, 0.83060469323313224, 0.96623475710157603};
  static constexpr double kWeight[6] = {0.085662246189585178, 0.18038078652406930, 0.23395696728634552,
                                        0.23395696728634552, 0.18038078652406930, 0.085662246189585178};
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
    double sum = 0;
    for (int j = 0; j < 6; ++j) {
      const double bu = p.u + kNode[j] * du, bv = p.v + kNode[j] * dv, rest = std::max(0.0, 1 - bu * bu - bv * bv);
      sum += kWeight[j] * (1 + rest + rest * rest) / (1 + rest * std::sqrt(rest));  // (1 - rest^1.5) / r^2
    }
    fanW = cross * sum / 3;
    w += fanW;
  }
}

double UnitDiskPart::clampedIntegral(double a, double b, double c) const {
  static constexpr double kNode[6] = {0.033765242898423975, 0.16939530676686776, 0.38069040695840156,
                                      0.61930959304159844, 0.83060469323313224, 0.96623475710157603};
  static constexpr double kWeight[6] = {0.085662246189585178, 0.18038078652406930, 0.23395696728634552,
                                        0.23395696728634552, 0.18038078652406930, 0.085662246189585178};
  // Of max(0, slope t + c sqrt(1 - t^2)) t dt over [0, r]: its antiderivative (slope t^3 - c (1 -
  // t^2)^1.5) / 3, cut where the cosine turns negative.
  const auto fanRay = [c](double slope, double r) {
    const auto antiderivative = [&](double t, double w) { return (slope * t * t * t - c * w * w * w) / 3; };
    const double w = std::sqrt(std::max(0.0, (1 - r) * (1 + r)));
    const double h = std::sqrt(slope * slope + c * c);
    if (c > 0) {
      const double start = -c / 3;  // at t = 0
      if (slope >= 0 || r * h <= c) return antiderivative(r, w) - start;
      return antiderivative(c / h, -slope / h) - start;  // the terminator at t = c / h, w = |slope| / h
    }
    if (c < 0) {
      if (slope <= 0 || r * h <= -c) return 0.0;
      return antiderivative(r, w) - antiderivative(-c / h, slope / h);
    }
    return slope > 0 ? slope * r * r * r / 3 : 0.0;
  };
  // Each piece: where the terminator crosses it, and whether the light lights it all over (side 1),
  // leaves it dark all over (-1), or neither (0). Where none is crossed, the part lies on one side of
  // the terminator (which ends on the rim: where it enters the part, it crosses a piece).
  const int n = pieces.count;
  double crossing[20][2];
  int crossings[20];
  int side[20];
  bool lit = true, dark = true;
  for (int i = 0; i < n; ++i) {
    const auto& [p, q, arc, fanW] = pieces.piece[i];
    crossings[i] = arc ? 0 : terminatorCrossings(p, q, a, b, c, crossing[i]);
    const auto rim = [&](DiskPieces::Point e) { return arc ? 0.0 : std::sqrt(std::max(0.0, 1 - e.u * e.u - e.v * e.v)); };
    const double atP = a * p.u + b * p.v + c * rim(p), atQ = a * q.u + b * q.v + c * rim(q);  // the cosine at its ends
    side[i] = crossings[i] > 0 ? 0 : atP >= 0 && atQ >= 0 ? 1 : atP <= 0 && atQ <= 0 ? -1 : 0;
    lit = lit && side[i] == 1, dark = dark && side[i] == -1;
  }
  if (lit) return std::max(0.0, a * u + b * v + c * w);
  if (dark) return 0;
  double total = 0;
  for (int i = 0; i < n; ++i) {
    const auto& [p, q, arc, fanW] = pieces.piece[i];
    const double cross = p.u * q.v - p.v * q.u;
    if (cross == 0 || (side[i] == -1 && c <= 0)) continue;  // no fan, or one dark all over
    const double du = q.u - p.u, dv = q.v - p.v, p0 = a * p.u + b * p.v, p1 = a * du + b * dv;
    if (side[i] == 1 && c >= 0) {  // a fan lit all over: its moments
      total += (arc ? (a * dv - b * du) / 3 : cross * (a * (p.u + q.u) + b * (p.v + q.v)) / 6) + c * fanW;
      continue;
    }
    double cut[5] = {0, 1, 1, 1, 1};
    int cuts = 1;
    for (int k = 0; k < crossings[i]; ++k) cut[cuts++] = crossing[i][k];
    if (p1 != 0 && -p0 / p1 > 0 && -p0 / p1 < 1) cut[cuts++] = -p0 / p1;
    std::sort(cut, cut + cuts);
    cut[cuts] = 1;
    double sum = 0;
    for (int k = 0; k < cuts; ++k) {
      const double s0 = cut[k], length = cut[k + 1] - s0;
      for (int j = 0; j < 6; ++j) {
        const double s = s0 + length * kNode[j];
        const double bu = p.u + s * du, bv = p.v + s * dv, r2 = bu * bu + bv * bv, r = std::sqrt(r2);
        sum += kWeight[j] * length * fanRay((a * bu + b * bv) / r, arc ? 1.0 : std::min(r, 1.0)) / r2;
      }
    }
    total += cross * sum;
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

}  // namespace durer
