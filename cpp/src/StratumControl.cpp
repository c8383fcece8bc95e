// A pixel stratum's control variate (StratumControl.h): out of line, made once a stratum pixel.
#include "durer/render/StratumControl.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "durer/accel/SphereView.h"

namespace durer {

namespace {

// A part's integral of the ambient light and the lights' colours times their cosines (a light's
// direction in the part's frame: toward(l)), in its frame; sets the bit of each light that reaches
// it in `lights`.
template <typename Toward>
Vec3d shadingOver(const UnitDiskPart& part, const ControlLighting& light, const Toward& toward, uint8_t& lights) {
  Vec3d along = light.ambient * part.area;
  for (int l = 0; l < light.suns; ++l) {
    const Vec3d d = toward(light.sun[l]);
    const double cosine = part.clampedIntegral(d.x, d.y, d.z);
    if (!(cosine > 0)) continue;  // dark all over
    lights |= uint8_t(1u << l);
    along += cosine * light.sun[l].color;
  }
  return along;
}

// The ambient light plus the colours of the lights of `lights` times their cosines clamped at 0, the
// cosine with light l cosine(sun l).
template <typename Cosine>
Vec3d shadingAt(const ControlLighting& light, uint8_t lights, const Cosine& cosine) {
  Vec3d sum = light.ambient;
  for (int l = 0; l < light.suns; ++l) {
    if (lights & (1u << l)) sum += std::max(0.0, cosine(light.sun[l])) * light.sun[l].color;
  }
  return sum;
}

}  // namespace

bool overlapWithin(const PixelBall& a, const PixelBall& b, double x0, double x1, double y0, double y1, double& px, double& py) {
  const auto inDisk = [](const PixelBall& s, double x, double y) { return (x - s.x) * (x - s.x) + (y - s.y) * (y - s.y) < s.r * s.r; };
  bool found = false;
  const auto chord = [](const PixelBall& s, double line, double across, double& lo, double& hi) {
    const double h2 = s.r * s.r - (line - across) * (line - across);
    if (!(h2 > 0)) return false;
    lo = std::max(lo, -std::sqrt(h2)), hi = std::min(hi, std::sqrt(h2));
    return true;
  };
  for (int side = 0; side < 4 && !found; ++side) {
    const bool vertical = side < 2;
    const double line = vertical ? (side == 0 ? x0 : x1) : (side == 2 ? y0 : y1);
    const double from = vertical ? y0 : x0, to = vertical ? y1 : x1;
    double aLo = -1e300, aHi = 1e300, bLo = -1e300, bHi = 1e300;
    if (!chord(a, line, vertical ? a.x : a.y, aLo, aHi) || !chord(b, line, vertical ? b.x : b.y, bLo, bHi)) continue;
    const double ca = vertical ? a.y : a.x, cb = vertical ? b.y : b.x;
    const double lo = std::max({from, ca + aLo, cb + bLo}), hi = std::min({to, ca + aHi, cb + bHi});
    if (!(lo < hi)) continue;
    found = true;
    (vertical ? px : py) = line, (vertical ? py : px) = (lo + hi) / 2;
  }
  if (!found) {
    const double dx = b.x - a.x, dy = b.y - a.y, d = std::sqrt(dx * dx + dy * dy);
    if (d <= std::abs(a.r - b.r)) {
      const PixelBall& smaller = a.r < b.r ? a : b;
      px = smaller.x, py = smaller.y;
    } else {
      const double along = (d * d + a.r * a.r - b.r * b.r) / (2 * d);
      px = a.x + along * dx / d, py = a.y + along * dy / d;
    }
    found = px >= x0 && px <= x1 && py >= y0 && py <= y1 && inDisk(a, px, py) && inDisk(b, px, py);
  }
  return found;
}

namespace {

constexpr double kSlack = 1e-9;  // of a pixel: a crossing of the fronts' arc that near a side counts

// Where the fronts of two spheres that cut through each other meet: their intersection circle, of
// centre o and radius rho in the plane square to the line of their centres, its points o + rho (cos t
// e1 + sin t e2), e1 its direction of growing depth (its depth o.z + rho sigma cos t), e2 across the
// view; before both centres' depths (on both fronts) where cos t <= kappa. Seen orthographically,
// (x, y) of that: an arc of an ellipse, through the middle t = pi (the nearest point). `meets` false
// where the spheres' surfaces do not cross (apart, or one inside the other) or no part of the circle
// lies on both fronts.
struct FrontsMeet {
  bool meets = false;
  double ox = 0, oy = 0, rho = 0, ex1 = 1, ey1 = 0, ex2 = 0, ey2 = 1, kappa = -2;

  FrontsMeet(const PixelBall& a, const PixelBall& b) {
    const Vec3d ca(a.x, a.y, a.z), cb(b.x, b.y, b.z), between = cb - ca;
    const double d = std::sqrt(dot(between, between));
    if (!(d > std::abs(a.r - b.r) && d < a.r + b.r)) return;
    const Vec3d n = between / d;
    const double t = (d * d + a.r * a.r - b.r * b.r) / (2 * d);
    rho = std::sqrt(std::max(0.0, a.r * a.r - t * t));
    const Vec3d o = ca + t * n;
    ox = o.x, oy = o.y;
    const double sigma = std::sqrt(std::max(0.0, 1 - n.z * n.z)), nearest = std::min(a.z, b.z);
    if (sigma > 1e-12) {
      ex1 = -n.z * n.x / sigma, ey1 = -n.z * n.y / sigma;
      const Vec3d e2 = cross(n, Vec3d(ex1, ey1, sigma));
      ex2 = e2.x, ey2 = e2.y;
      kappa = (nearest - o.z) / (rho * sigma);
    } else {  // the circle faces the view: all of it at o's depth
      kappa = o.z <= nearest ? 2.0 : -2.0;
    }
    meets = kappa >= -1 - kSlack && rho > 0;
  }
  bool onArc(double t) const { return std::cos(t) <= kappa + kSlack; }
  void at(double t, double& x, double& y) const {
    x = ox + rho * (std::cos(t) * ex1 + std::sin(t) * ex2), y = oy + rho * (std::cos(t) * ey1 + std::sin(t) * ey2);
  }
  void tangent(double t, double& x, double& y) const {
    x = rho * (-std::sin(t) * ex1 + std::cos(t) * ex2), y = rho * (-std::sin(t) * ey1 + std::cos(t) * ey2);
  }
  // The parameters t in (-pi, pi] where its ellipse crosses the line x = line (vertical) or y = line,
  // in `cut`; how many (0 to 2).
  int crossings(bool vertical, double line, double* cut) const {
    const double alpha = rho * (vertical ? ex1 : ey1), beta = rho * (vertical ? ex2 : ey2), gamma = line - (vertical ? ox : oy);
    const double reach = std::sqrt(alpha * alpha + beta * beta);
    if (!(reach > 0) || std::abs(gamma) > reach * (1 + kSlack)) return 0;
    const double phase = std::atan2(beta, alpha), off = std::acos(std::clamp(gamma / reach, -1.0, 1.0));
    cut[0] = phase + off, cut[1] = phase - off;
    return 2;
  }
};

}  // namespace

int seenWithin(const PixelBall& a, const PixelBall& b, double x0, double x1, double y0, double y1) {
  double px = 0, py = 0;
  if (!overlapWithin(a, b, x0, x1, y0, y1, px, py)) return 3;
  const FrontsMeet meet(a, b);
  if (meet.meets) {
    const auto within = [&](double x, double y) { return x >= x0 - kSlack && x <= x1 + kSlack && y >= y0 - kSlack && y <= y1 + kSlack; };
    for (int side = 0; side < 4; ++side) {  // where it crosses the lines of the rectangle's sides
      const bool vertical = side < 2;
      const double line = vertical ? (side == 0 ? x0 : x1) : (side == 2 ? y0 : y1);
      double cut[2];
      for (int k = 0, n = meet.crossings(vertical, line, cut); k < n; ++k) {
        double x, y;
        meet.at(cut[k], x, y);
        if (meet.onArc(cut[k]) && within(vertical ? line : x, vertical ? y : line)) return 0;
      }
    }
    double x, y;
    meet.at(kPi, x, y);  // else the arc lies all inside the rectangle or all outside it
    if (within(x, y)) return 0;
  }
  const auto front = [&](const PixelBall& s) { return s.z - std::sqrt(std::max(0.0, s.r * s.r - (px - s.x) * (px - s.x) - (py - s.y) * (py - s.y))); };
  const double fa = front(a), fb = front(b);
  return fa < fb ? 1 : fb < fa ? 2 : 0;
}

namespace {

// A piece of a region's boundary in PixelBall's frame: a segment from a to b (t in [0, 1]), an arc of
// the circle of centre a and radius b.x (t its angle), or of the fronts' ellipse (FrontsMeet's t);
// the region on its left as t runs from `from` to `to` (either way).
struct Curve {
  enum Kind { kSegment, kCircle, kEllipse } kind;
  double ax, ay, bx, by;
  const FrontsMeet* ellipse;
  double from, to;
  // Its point at t and the derivative there.
  void at(double t, double& x, double& y, double& dx, double& dy) const {
    if (kind == kSegment) {
      dx = bx - ax, dy = by - ay, x = ax + t * dx, y = ay + t * dy;
    } else if (kind == kCircle) {
      x = ax + bx * std::cos(t), y = ay + bx * std::sin(t), dx = -bx * std::sin(t), dy = bx * std::cos(t);
    } else {
      ellipse->at(t, x, y), ellipse->tangent(t, dx, dy);
    }
  }
};

// The region that `curves` bound in the frame of a member's disk (ball s): ClippedDiskPart's pieces,
// its own rim's arcs cut to quarter turns.
ClippedDiskPart inFrame(const Curve* curves, int count, const PixelBall& s) {
  ClippedDiskPart::Piece piece[64];
  int n = 0;
  const auto point = [&](double x, double y) { return DiskPieces::Point{(x - s.x) / s.r, (y - s.y) / s.r}; };
  for (int i = 0; i < count && n < 60; ++i) {
    const Curve& e = curves[i];
    double x0, y0, x1, y1, unused, unused2;
    e.at(e.from, x0, y0, unused, unused2), e.at(e.to, x1, y1, unused, unused2);
    const DiskPieces::Point p = point(x0, y0), q = point(x1, y1);
    if (e.kind == Curve::kSegment) {
      piece[n++] = {p, q, 0, 0, 0, 0, 0, 0};
    } else if (e.kind == Curve::kCircle) {
      const bool own = std::abs(e.ax - s.x) <= 1e-9 * s.r && std::abs(e.ay - s.y) <= 1e-9 * s.r && std::abs(e.bx - s.r) <= 1e-9 * s.r;
      if (!own) {
        piece[n++] = {p, q, 2, (e.ax - s.x) / s.r, (e.ay - s.y) / s.r, e.bx / s.r, e.from, e.to};
        continue;
      }
      const int quarters = std::max(1, static_cast<int>(std::ceil(std::abs(e.to - e.from) / (kPi / 2))));
      for (int k = 0; k < quarters && n < 60; ++k) {
        const double t0 = e.from + (e.to - e.from) * k / quarters, t1 = e.from + (e.to - e.from) * (k + 1) / quarters;
        piece[n++] = {{std::cos(t0), std::sin(t0)}, {std::cos(t1), std::sin(t1)}, 1, 0, 0, 0, 0, 0};
      }
    } else {
      const FrontsMeet& m = *e.ellipse;
      ClippedDiskPart::Piece arc{p, q, 3, (m.ox - s.x) / s.r, (m.oy - s.y) / s.r, 0, e.from, e.to};
      arc.au = m.rho * m.ex1 / s.r, arc.av = m.rho * m.ey1 / s.r, arc.bu = m.rho * m.ex2 / s.r, arc.bv = m.rho * m.ey2 / s.r;
      piece[n++] = arc;
    }
  }
  return ClippedDiskPart(piece, n);
}

// The boundaries of the parts of the overlap of a's and b's disks within the rectangle [0, 1] x [0, h]
// where each is seen (its front nearer), for spheres that cut through each other, `meet` their
// fronts' arc: the overlap's boundary (ClippedDiskPart, in a's frame) cut where the arc meets it,
// each stretch to the part of the sphere seen there, and the arc's stretches inside the rectangle
// to both, turned to have each part on their left. Where b is seen in `bSeen` (room for 96), where a
// is in `aSeen` (as much); their counts in `counts`.
void seenPart(const PixelBall& a, const PixelBall& b, const FrontsMeet& meet, double h, Curve* bSeen, Curve* aSeen, int* counts) {
  const double one[1] = {(b.x - a.x) / a.r}, two[1] = {(b.y - a.y) / a.r}, three[1] = {b.r / a.r};
  const ClippedDiskPart lens(-a.x / a.r, (1 - a.x) / a.r, -a.y / a.r, (h - a.y) / a.r, one, two, three, 1);
  const auto seesB = [&](double x, double y) {
    const double da = a.r * a.r - (x - a.x) * (x - a.x) - (y - a.y) * (y - a.y), db = b.r * b.r - (x - b.x) * (x - b.x) - (y - b.y) * (y - b.y);
    return b.z - std::sqrt(std::max(0.0, db)) < a.z - std::sqrt(std::max(0.0, da));
  };
  const auto inside = [&](double x, double y) { return x > 0 && x < 1 && y > 0 && y < h; };
  // The arc's stretch before both centres, and where it meets the rectangle's sides.
  const double start = std::acos(std::min(1.0, std::max(-1.0, meet.kappa))), end = 2 * kPi - start;
  double ts[10];
  int nt = 0;
  ts[nt++] = start, ts[nt++] = end;
  double meets[10][2];  // the points where it meets the sides (two a side), and its ends, where inside
  int nm = 0;
  for (int side = 0; side < 4; ++side) {
    const bool vertical = side < 2;
    const double line = vertical ? (side == 0 ? 0.0 : 1.0) : (side == 2 ? 0.0 : h);
    double cut[2];
    for (int k = 0, n = meet.crossings(vertical, line, cut); k < n; ++k) {
      double t = cut[k];
      while (t < start) t += 2 * kPi;
      while (t > end) t -= 2 * kPi;
      double x, y;
      meet.at(t, x, y);
      if (t < start || (vertical ? y < 0 || y > h : x < 0 || x > 1)) continue;
      ts[nt++] = t;
      meets[nm][0] = vertical ? line : x, meets[nm][1] = vertical ? y : line, ++nm;
    }
  }
  if (meet.kappa < 1) {
    for (const double t : {start, end}) {
      double x, y;
      meet.at(t, x, y);
      if (inside(x, y)) meets[nm][0] = x, meets[nm][1] = y, ++nm;
    }
  }
  counts[0] = counts[1] = 0;
  const auto add = [&](bool toB, const Curve& c) {
    if (counts[toB ? 0 : 1] < 96) (toB ? bSeen : aSeen)[counts[toB ? 0 : 1]++] = c;
  };
  // The overlap's boundary, cut at those points, to the part of the sphere seen there.
  for (int i = 0; i < lens.count; ++i) {
    const ClippedDiskPart::Piece& piece = lens.piece[i];
    Curve c{};
    if (piece.kind == 0) {
      c = {Curve::kSegment, a.x + a.r * piece.p.u, a.y + a.r * piece.p.v, a.x + a.r * piece.q.u, a.y + a.r * piece.q.v, nullptr, 0, 1};
    } else if (piece.kind == 1) {
      const double from = std::atan2(piece.p.v, piece.p.u);
      double to = std::atan2(piece.q.v, piece.q.u);
      while (to <= from) to += 2 * kPi;
      c = {Curve::kCircle, a.x, a.y, a.r, 0, nullptr, from, to};
    } else {
      c = {Curve::kCircle, a.x + a.r * piece.cu, a.y + a.r * piece.cv, a.r * piece.radius, 0, nullptr, piece.from, piece.to};
    }
    double at[12];  // its start, and those points on it
    int na = 0;
    at[na++] = c.from;
    for (int k = 0; k < nm; ++k) {  // a point on it: its parameter
      const double x = meets[k][0], y = meets[k][1];
      double t;
      if (c.kind == Curve::kSegment) {
        const double dx = c.bx - c.ax, dy = c.by - c.ay, l2 = dx * dx + dy * dy;
        if (!(l2 > 0) || std::abs(dx * (y - c.ay) - dy * (x - c.ax)) > 1e-9 * std::sqrt(l2)) continue;
        t = (dx * (x - c.ax) + dy * (y - c.ay)) / l2;
      } else {
        if (std::abs(std::hypot(x - c.ax, y - c.ay) - c.bx) > 1e-9 * (1 + c.bx)) continue;
        t = std::atan2(y - c.ay, x - c.ax);
        while (t < c.from) t += 2 * kPi;
      }
      if (t > c.from && t < c.to) at[na++] = t;
    }
    std::sort(at + 1, at + na);
    at[na] = c.to;
    for (int k = 0; k < na; ++k) {
      Curve part = c;
      part.from = at[k], part.to = at[k + 1];
      double x, y, dx, dy;
      part.at((part.from + part.to) / 2, x, y, dx, dy);
      add(seesB(x, y), part);
    }
  }
  // The arc's stretches inside the rectangle, both ways: b seen on the left of one, a on the other's.
  std::sort(ts, ts + nt);
  for (int k = 0; k + 1 < nt; ++k) {
    if (!(ts[k] >= start && ts[k + 1] <= end && ts[k + 1] > ts[k])) continue;
    const double mid = (ts[k] + ts[k + 1]) / 2;
    double x, y, dx, dy;
    meet.at(mid, x, y), meet.tangent(mid, dx, dy);
    if (!inside(x, y)) continue;
    const double l = std::hypot(dx, dy), step = 1e-7 * (1 + a.r + b.r);
    const bool left = seesB(x - step * dy / l, y + step * dx / l);
    add(true, {Curve::kEllipse, 0, 0, 0, 0, &meet, left ? ts[k] : ts[k + 1], left ? ts[k + 1] : ts[k]});
    add(false, {Curve::kEllipse, 0, 0, 0, 0, &meet, left ? ts[k + 1] : ts[k], left ? ts[k] : ts[k + 1]});
  }
}


// The shading (ambient light and the lights of `lights`) over a clipped part, in its frame.
Vec3d shadingOver(const ClippedDiskPart& part, const ControlLighting& light, uint8_t lights) {
  Vec3d along = light.ambient * part.area;
  for (int l = 0; l < light.suns; ++l) {
    if (lights & (1u << l)) along += part.clampedIntegral(light.sun[l].a, light.sun[l].b, light.sun[l].c) * light.sun[l].color;
  }
  return along;
}

// A lattice's rows over a stratum's members (lostToNearer, seenMean), in float, a row's points at
// once (the loops over its columns vectorise): each member's frame, and its lights' directions (0
// for a light that does not reach it).
struct LatticeRows {
  static constexpr int kMost = PixelStratum::kMostDisks, kMostGrid = kFinestLostGrid;
  static constexpr float kBig = std::numeric_limits<float>::max(), kFar = kBig / 2;
  static_assert(kLostGrid % 2 == 0 && kSeenGrid % 2 == 0, "a checkerboard's halves: lattices of even sides, doubled");
  int n, grid;
  double y0, dx, dy;  // the lattice's first row, and its spacing
  float cx[kMost], inverse[kMost], r[kMost], z[kMost], sa[kMost][kMostControlLights], sb[kMost][kMostControlLights],
      sc[kMost][kMostControlLights];
  alignas(64) float column[kMostGrid];
  // Row y's: each member's v, and at each column its u, w and front, pushed past kFar beyond its disk
  // by a sum rather than a selection (a loop whose floating-point work is all done unconditionally
  // vectorises); the nearest front.
  float v[kMost];
  alignas(64) float u[kMost][kMostGrid], w[kMost][kMostGrid], front[kMost][kMostGrid], nearest[kMostGrid];

  // Over the box [x0, x1] x [y0, y1], `points` a side (at most kMostGrid).
  LatticeRows(const PixelBall* ball, const StratumControl& control, int members, const ControlLighting& light, double x0, double x1,
              double top, double y1, int points)
      : n(members), grid(std::min(points, kMostGrid)), y0(top), dx((x1 - x0) / grid), dy((y1 - top) / grid) {
    for (int m = 0; m < n; ++m) {
      cx[m] = static_cast<float>(ball[m].x), inverse[m] = static_cast<float>(1 / ball[m].r), r[m] = static_cast<float>(ball[m].r);
      z[m] = static_cast<float>(ball[m].z);
      for (int l = 0; l < light.suns; ++l) {
        const bool reaches = control.lights[m] & (1u << l);
        sa[m][l] = reaches ? static_cast<float>(light.sun[l].a) : 0, sb[m][l] = reaches ? static_cast<float>(light.sun[l].b) : 0;
        sc[m][l] = reaches ? static_cast<float>(light.sun[l].c) : 0;
      }
    }
    for (int c = 0; c < grid; ++c) column[c] = static_cast<float>(x0 + (c + 0.5) * dx);
  }

  void row(const PixelBall* ball, int index) {
    const double y = y0 + (index + 0.5) * dy;
    for (int m = 0; m < n; ++m) {
      v[m] = static_cast<float>((y - ball[m].y) / ball[m].r);
      const float rest0 = 1 - v[m] * v[m];
      for (int c = 0; c < grid; ++c) {
        const float um = (column[c] - cx[m]) * inverse[m], rest = rest0 - um * um, wm = std::sqrt(std::max(rest, 0.0f));
        u[m][c] = um, w[m][c] = wm, front[m][c] = (z[m] - r[m] * wm) + (rest > 0 ? 0.0f : kBig);
      }
    }
    std::copy(front[0], front[0] + grid, nearest);
    for (int m = 1; m < n; ++m) {
      for (int c = 0; c < grid; ++c) nearest[c] = std::min(nearest[c], front[m][c]);
    }
  }

  using Sums = float[2][kMost][1 + kMostControlLights][kMostGrid];  // [row parity][member][points, then lights][column]
  // Zeroes what `add` adds to for `suns` lights.
  void clear(Sums& sums, int suns) const {
    for (auto& byParity : sums) {
      for (int m = 0; m < n; ++m) {
        for (int k = 0; k <= suns; ++k) std::fill(byParity[m][k], byParity[m][k] + grid, 0.0f);
      }
    }
  }

  // Adds member m's `weight`ed points and its lights' clamped cosines there, by column, to into[0]
  // and into[1 + l].
  void add(int m, const float* weight, int suns, float (*into)[kMostGrid]) const {
    for (int c = 0; c < grid; ++c) into[0][c] += weight[c];
    for (int l = 0; l < suns; ++l) {
      const float a = sa[m][l], b = sb[m][l] * v[m], cz = sc[m][l];
      for (int c = 0; c < grid; ++c) into[1 + l][c] += weight[c] * std::max(0.0f, a * u[m][c] + b + cz * w[m][c]);
    }
  }

  // By row parity, each member's points inside its disk where `counts(its front, the nearest front)`,
  // and its lights' clamped cosines there, summed by column (the checkerboard's halves are the even
  // and odd rows' even and odd columns).
  template <typename Counts>
  void sum(const PixelBall* ball, int suns, const Counts& counts, Sums& sums) {
    clear(sums, suns);
    alignas(64) float weight[kMostGrid];
    for (int index = 0; index < grid; ++index) {
      row(ball, index);
      for (int m = 0; m < n; ++m) {
        for (int c = 0; c < grid; ++c) weight[c] = (front[m][c] < kFar) & counts(front[m][c], nearest[c]) ? 1.0f : 0.0f;
        add(m, weight, suns, sums[index & 1][m]);
      }
    }
  }

  // The checkerboard's halves (even rows' even columns and odd rows' odd ones, and the rest) of what
  // `add` summed by row parity: the members' shading (diffuse colours times the ambient light and the
  // lights' colours) and the points.
  void halves(const Sums& sums, const StratumControl& control, const ControlLighting& light, Vec3d* shading, double* points) const {
    shading[0] = shading[1] = Vec3d(0), points[0] = points[1] = 0;
    for (int parity = 0; parity < 2; ++parity) {
      for (int m = 0; m < n; ++m) {
        for (int k = 0; k <= light.suns; ++k) {
          double even = 0, odd = 0;  // two sums in registers (an array indexed by c & 1 went through memory)
          for (int c = 0; c < grid; c += 2) even += sums[parity][m][k][c], odd += sums[parity][m][k][c + 1];
          const Vec3d colour = Vec3d(control.kd[m]) * (k == 0 ? light.ambient : light.sun[k - 1].color);
          shading[parity] += colour * even, shading[1 - parity] += colour * odd;
          if (k == 0) points[parity] += even, points[1 - parity] += odd;
        }
      }
    }
  }

  // The brightest member's colour under every light it reaches, RMS over the channels: what a sliver
  // between the points may hold.
  double brightest(const StratumControl& control, const ControlLighting& light) const {
    double most = 0;
    for (int m = 0; m < n; ++m) {
      const Vec3d colour = Vec3d(control.kd[m]) * shadingAt(light, control.lights[m], [](const ControlLighting::Sun&) { return 1.0; });
      most = std::max(most, std::sqrt(dot(colour, colour) / 3));
    }
    return most;
  }
};

// The shading the members of a stratum lose where another member is seen before them inside the
// overlaps of their disks within the pixel's rectangle [0, 1] x [0, h] (PixelBall's frame): each
// member's diffuse colour times the ambient light and the lights of its bit mask (its cosines clamped
// at 0) over the points where its disk and a nearer front's hold them, summed over the members, as a
// share of the pixel. By the midpoint rule on a grid x grid lattice over the box that holds the
// overlaps in the pixel; `error`, the RMS over the channels of half the difference of the lattice's
// two checkerboard halves' sums, but at least half a cell's share of the brightest member's colour (a
// sliver of an overlap may lie between the points), estimates its error. Over random strata of two
// or three spheres cutting through each other (tests/test_stratum_control.cpp) the lattices that
// meet a tolerance of 0.01 are off by 4.0e-3 of the pixel's colour RMS, estimated 5.0e-3; of 0.002,
// 7.6e-4 and 1.1e-3: the estimate errs large, and is seldom under half the error.
struct LostShading {
  Vec3d shading{0};
  double error = 0;
};

LostShading lostToNearer(const PixelBall* ball, const StratumControl& control, int n, const ControlLighting& light, double h, int grid) {
  double x0 = 1, x1 = 0, y0 = h, y1 = 0;  // the box: empty until an overlap reaches into the pixel
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < i; ++j) {
      const double a0 = std::max({0.0, ball[i].x - ball[i].r, ball[j].x - ball[j].r}), a1 = std::min({1.0, ball[i].x + ball[i].r, ball[j].x + ball[j].r});
      const double b0 = std::max({0.0, ball[i].y - ball[i].r, ball[j].y - ball[j].r}), b1 = std::min({h, ball[i].y + ball[i].r, ball[j].y + ball[j].r});
      if (!(a0 < a1 && b0 < b1)) continue;
      x0 = std::min(x0, a0), x1 = std::max(x1, a1), y0 = std::min(y0, b0), y1 = std::max(y1, b1);
    }
  }
  LostShading lost;
  if (!(x0 < x1 && y0 < y1)) return lost;
  LatticeRows rows(ball, control, n, light, x0, x1, y0, y1, grid);
  // What each member loses there: a point its disk holds where another's front is nearer (equal
  // fronts, a set of no area, both keep).
  alignas(64) LatticeRows::Sums sums;
  rows.sum(ball, light.suns, [](float own, float nearest) { return own > nearest; }, sums);
  Vec3d halves[2];
  double points[2];
  rows.halves(sums, control, light, halves, points);
  const double cell = rows.dx * rows.dy / h, brightest = rows.brightest(control, light);  // a point's share of the pixel
  const Vec3d apart = (halves[0] - halves[1]) * cell;
  lost.shading = (halves[0] + halves[1]) * cell;
  lost.error = std::max(std::sqrt(dot(apart, apart) / 3), cell * brightest / 2);
  return lost;
}

// The mean over the union's part of the pixel of the shading of the member seen (the nearest front
// among those whose disks hold the point): each member's diffuse colour times the ambient light and
// the lights (cosines clamped at 0), by the midpoint rule on a grid x grid lattice over the box the
// members' disks span within the pixel's rectangle [0, 1] x [0, h] (PixelBall's frame), the mean of
// the points inside the union. `error`: the RMS over the channels of half the difference of the
// lattice's two checkerboard halves' means, but at least half the brightest member's colour over
// the points inside (a sliver may lie between them); `count`: the points inside.
struct SeenMean {
  Vec3d mean{0};
  double error = 0;
  int count = 0;
};

SeenMean seenMean(const PixelBall* ball, const StratumControl& control, int n, const ControlLighting& light, double h, int grid) {
  double x0 = 1, x1 = 0, y0 = h, y1 = 0;
  for (int i = 0; i < n; ++i) {
    x0 = std::min(x0, std::max(0.0, ball[i].x - ball[i].r)), x1 = std::max(x1, std::min(1.0, ball[i].x + ball[i].r));
    y0 = std::min(y0, std::max(0.0, ball[i].y - ball[i].r)), y1 = std::max(y1, std::min(h, ball[i].y + ball[i].r));
  }
  SeenMean seen;
  if (!(x0 < x1 && y0 < y1)) return seen;
  LatticeRows rows(ball, control, n, light, x0, x1, y0, y1, grid);
  // Where each member is seen: its front the nearest (ties, a set of no area, go to each).
  alignas(64) LatticeRows::Sums sums;
  rows.sum(ball, light.suns, [](float own, float nearest) { return own <= nearest; }, sums);
  Vec3d shade[2];
  double count[2];
  rows.halves(sums, control, light, shade, count);
  const double brightest = rows.brightest(control, light);
  seen.count = static_cast<int>(count[0] + count[1]);
  if (!(count[0] > 0 && count[1] > 0)) return seen;
  seen.mean = (shade[0] + shade[1]) / (count[0] + count[1]);
  const Vec3d apart = (shade[0] / count[0] - shade[1] / count[1]) / 2.0;
  seen.error = std::max(std::sqrt(dot(apart, apart) / 3), brightest / (2 * (count[0] + count[1])));
  return seen;
}

// An order of n members (rank[i]: 0 first) in which before[i][j] puts i before j, if one exists.
bool rankBy(const bool (*before)[PixelStratum::kMostDisks], int n, uint8_t* rank) {
  int order[PixelStratum::kMostDisks];
  std::iota(order, order + PixelStratum::kMostDisks, 0);
  do {
    bool fits = true;
    for (int i = 0; i < n && fits; ++i) {
      for (int j = i + 1; j < n && fits; ++j) fits = !before[order[j]][order[i]];
    }
    if (fits) {
      for (int i = 0; i < n; ++i) rank[order[i]] = uint8_t(i);
      return true;
    }
  } while (std::next_permutation(order, order + n));
  return false;
}

// Whether two spheres cut through each other (or one holds the other): their centres nearer than the
// sum of their radii.
bool cutThrough(const ControlMember& a, const ControlMember& b) {
  const Vec3d d = a.centre - b.centre;
  return dot(d, d) < (a.radius + b.radius) * (a.radius + b.radius);
}

// diskControl's control of a one-member stratum's outside by its cover (sphere c, disk e), where the
// member (m) is seen before it all over its part of the pixel.
void coverOutside(int x, int y, const PixelStratum& p, const ControlMember& m, const ControlMember& c, const PixelStratum::Ellipse& e,
                  const ControlLighting& light, StratumControl& control) {
  const float cx = static_cast<float>(e.cx), cy = static_cast<float>(e.cy);
  const float inverseAx = static_cast<float>(1 / e.ax), inverseAy = static_cast<float>(1 / e.ay);
  const double iu = inverseAx, iv = inverseAy;
  if (!(std::isfinite(iu) && std::isfinite(iv) && iu > 0 && iv > 0 && std::isfinite(cx) && std::isfinite(cy))) return;
  if (cutThrough(m, c)) {  // the member seen all over its part
    const double scale = 1 / (double(p.inverseAx[0]) * m.radius);  // pixel units a world unit
    const double aspect = double(p.inverseAy[0]) / double(p.inverseAx[0]);
    const PixelBall own{double(p.cx[0]) - x, (double(p.cy[0]) - y) * aspect, m.centre.z * scale, 1 / double(p.inverseAx[0])};
    const PixelBall behind{double(cx) - x, (double(cy) - y) * aspect, c.centre.z * scale, 1 / iu};
    if (seenWithin(own, behind, 0, 1, 0, aspect) != 1) return;
  }
  // The pixel's square in the cover's frame, and the member's disk there (a circle: the disks are of
  // one family, their axes' ratio the pixels' aspect).
  const double u0 = (x - double(cx)) * iu, u1 = (x + 1 - double(cx)) * iu, v0 = (y - double(cy)) * iv, v1 = (y + 1 - double(cy)) * iv;
  const double cu = (double(p.cx[0]) - double(cx)) * iu, cv = (double(p.cy[0]) - double(cy)) * iv, cr = iu / double(p.inverseAx[0]);
  const UnitDiskPart whole(u0, u1, v0, v1);
  const ClippedDiskPart under(u0, u1, v0, v1, &cu, &cv, &cr, 1);
  const double outside = whole.area - under.area;
  if (!(outside > 0)) return;
  uint8_t lights = 0;
  const Vec3d all = shadingOver(whole, light, [](const ControlLighting::Sun& s) { return Vec3d(s.a, s.b, s.c); }, lights);
  const Vec3<float> kd(c.kd);
  control.coverKd = kd, control.coverLights = lights;
  control.coverCx = cx, control.coverCy = cy, control.coverInverseAx = inverseAx, control.coverInverseAy = inverseAy;
  control.coverMean = Vec3<float>(Vec3d(kd) * (all - shadingOver(under, light, lights)) / outside);
}

}  // namespace

StratumControl diskControl(int x, int y, const PixelStratum& p, const ControlMember* members, const ControlLighting& light,
                           bool split, double tolerance, double* share, const ControlMember* cover, const PixelStratum::Ellipse* coverDisk) {
  constexpr int kMost = PixelStratum::kMostDisks;
  StratumControl control{};
  if (share) *share = std::numeric_limits<double>::quiet_NaN();
  if (p.shear != 0) return control;
  const int n = p.disks;
  // Which member is seen where two disks overlap in the pixel: a rank, or (two members) where it
  // changes, the part each is seen in. In the frame of several disks (pixel units across, the
  // first's aspect down, depth in the same units).
  bool overlap[kMost][kMost] = {}, before[kMost][kMost] = {}, changes = false, numeric = false;
  uint8_t rank[kMost] = {};
  // Where a rank holds, each member's nearer members whose disks overlap its own in the pixel (in
  // index order): what its part loses to them is taken off exactly (below).
  int nearer[kMost][kMost], nearers[kMost] = {};
  PixelBall ball[kMost];
  double inUnion = 0;  // the union's share, where the lattice of the one seen was tried (kept if it missed)
  if (n > 1) {
    const double scale = 1 / (double(p.inverseAx[0]) * members[0].radius);  // pixel units a world unit
    for (int i = 0; i < n; ++i) {
      ball[i] = {double(p.cx[i]) - x, (double(p.cy[i]) - y) * double(p.aspect), members[i].centre.z * scale, 1 / double(p.inverseAx[i])};
      control.depth[i] = static_cast<float>(ball[i].z - ball[0].z);
    }
    // Where members cut through each other and the exact split is not asked for, the mean of the
    // shading of the one seen over the union's part, found on a lattice (seenMean) where that is within
    // `tolerance` of the pixel's colour: cheaper than the members' exact parts, their ranks and the
    // parts their overlaps take off.
    bool cutting = false;
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < i; ++j) cutting = cutting || cutThrough(members[i], members[j]);
    }
    inUnion = cutting && !split && tolerance > 0 ? p.unionShare(x, y) : 0;
    if (inUnion > 0) {
      StratumControl seen = control;
      for (int i = 0; i < n; ++i) seen.kd[i] = Vec3<float>(members[i].kd), seen.lights[i] = uint8_t((1u << light.suns) - 1);
      for (int grid = kSeenGrid; grid <= kFinestLostGrid; grid *= 2) {
        const SeenMean m = seenMean(ball, seen, n, light, double(p.aspect), grid);
        if (!(m.count >= kLeastSeenPoints && m.error * inUnion <= tolerance)) continue;
        seen.mean = Vec3<float>(m.mean), seen.meanError = static_cast<float>(m.error * inUnion);
        if (share) *share = inUnion;
        return seen;
      }
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < i; ++j) {
        double px, py;
        if (!overlapWithin(ball[i], ball[j], 0, 1, 0, double(p.aspect), px, py)) continue;
        overlap[i][j] = overlap[j][i] = true;
        if (!cutThrough(members[i], members[j])) {  // apart in space: the nearer centre in front
          (members[i].centre.z < members[j].centre.z ? before[i][j] : before[j][i]) = true;
          continue;
        }
        const int seen = seenWithin(ball[i], ball[j], 0, 1, 0, double(p.aspect));
        numeric = numeric || (seen == 0 && (n > 2 || !split));  // the one seen changes in the pixel, among three
        changes = changes || seen == 0;
        if (seen != 0) (seen == 1 ? before[i][j] : before[j][i]) = true;
      }
    }
    numeric = numeric || (!changes && !rankBy(before, n, rank));
    // Nearer members' disks are taken off a member's part exactly by inclusion and exclusion of at most
    // ClippedDiskPart::kMostCircles of them; beyond, numerically.
    for (int i = 0; i < n && !numeric && !changes; ++i) {
      for (int j = 0; j < n; ++j) {
        if (overlap[i][j] && rank[j] < rank[i]) nearer[i][nearers[i]++] = j;
      }
      numeric = nearers[i] > ClippedDiskPart::kMostCircles;
    }
    if (numeric && !(tolerance > 0)) return control;
    changes = changes && !numeric;
  }
  Vec3d sum(0);
  double inside = 0;  // the union's area, in pixels
  for (int i = 0; i < n; ++i) {
    double u0, v0, u1, v1;  // the pixel's corners in the member's frame (unsheared: a rectangle)
    p.frame(i, x, y, u0, v0), p.frame(i, x + 1, y + 1, u1, v1);
    const double scale = (u1 - u0) * (v1 - v0);  // a pixel's area in the frame
    const UnitDiskPart part(u0, u1, v0, v1);
    if (!(part.area > 0)) continue;
    control.kd[i] = Vec3<float>(members[i].kd);
    const Vec3d kd(control.kd[i]);
    const Vec3d along = shadingOver(part, light, [](const ControlLighting::Sun& s) { return Vec3d(s.a, s.b, s.c); }, control.lights[i]);
    sum += kd * along / scale, inside += part.area / scale;
    // Less the part that nearer members' disks cover (in the member's frame): one's, or two's by
    // inclusion and exclusion; where the one seen changes, each the part of the overlap where the
    // other is seen (below).
    const int count = changes || numeric ? 0 : nearers[i];
    double cu[kMost], cv[kMost], cr[kMost];
    for (int m = 0; m < count; ++m) {
      const int j = nearer[i][m];
      cu[m] = (double(p.cx[j]) - double(p.cx[i])) * double(p.inverseAx[i]);
      cv[m] = (double(p.cy[j]) - double(p.cy[i])) * double(p.aspect) * double(p.inverseAx[i]);
      cr[m] = double(p.inverseAx[i]) / double(p.inverseAx[j]);
    }
    const auto cover = [&](int first, int circles, double sign) {
      const ClippedDiskPart covered(u0, u1, v0, v1, cu + first, cv + first, cr + first, circles);
      sum -= sign * kd * shadingOver(covered, light, control.lights[i]) / scale, inside -= sign * covered.area / scale;
    };
    if (count >= 1) cover(0, 1, 1);
    if (count == 2) cover(1, 1, 1), cover(0, 2, -1);
  }
  if (changes) {  // two members: each loses the part of their overlap where the other is seen
    const FrontsMeet meet(ball[0], ball[1]);
    Curve seen[2][96];
    int counts[2];
    seenPart(ball[0], ball[1], meet, double(p.aspect), seen[0], seen[1], counts);
    for (int i = 0; i < 2; ++i) {  // a pixel's area in a member's frame: the aspect over its radius squared
      const double pixel = double(p.aspect) / (ball[i].r * ball[i].r);
      const ClippedDiskPart lost = inFrame(seen[i], counts[i], ball[i]);
      sum -= Vec3d(control.kd[i]) * shadingOver(lost, light, control.lights[i]) / pixel, inside -= lost.area / pixel;
    }
  }
  // Without the split, the members' parts less what nearer ones cover partition the union's part of
  // the pixel, each bounded by circles and the pixel's sides: its share. Their fans from each disk's
  // centre round to about 1e-16 a^2 of the pixel (a disk of a pixels' radius), the union's area
  // (PixelStratum::unionShare) to about 1e-16 a: the parts make it up to kMostPartsShareRadius.
  if (numeric) {  // each loses the parts of the overlaps where another is seen, numerically
    LostShading lost;
    for (int grid = kLostGrid; grid <= kFinestLostGrid; grid *= 2) {
      lost = lostToNearer(ball, control, n, light, double(p.aspect), grid);
      if (lost.error <= tolerance) break;
    }
    if (!(lost.error <= tolerance)) return {};
    sum -= lost.shading, inside = inUnion > 0 ? inUnion : p.unionShare(x, y), control.meanError = static_cast<float>(lost.error);
    if (share) *share = inside;
  }
  bool small = true;
  for (int i = 0; i < n; ++i) small = small && 1 / double(p.inverseAx[i]) <= kMostPartsShareRadius;
  if (share && !changes && !numeric && small) *share = inside;
  if (!(inside > 0)) return {};
  control.mean = Vec3<float>(sum / inside);
  if (cover && n == 1 && control.any()) coverOutside(x, y, p, members[0], *cover, *coverDisk, light, control);
  return control;
}

Vec3d diskControlAt(const PixelStratum& p, const StratumControl& c, const ControlLighting& light, double x, double y) {
  int seen = -1;  // the member whose front is nearest among those whose disks hold it
  double seenU = 0, seenV = 0, seenW = 0, front = 0;
  for (int i = 0; i < p.disks; ++i) {
    double u, v;
    p.frame(i, x, y, u, v);
    if (!(u * u + v * v < 1)) continue;
    const double w = std::sqrt(1 - u * u - v * v), f = double(c.depth[i]) - w / double(p.inverseAx[i]);
    if (seen >= 0 && !(f < front)) continue;
    seen = i, seenU = u, seenV = v, seenW = w, front = f;
  }
  if (seen < 0 && c.covered()) {  // outside: the cover's
    const double u = (x - double(c.coverCx)) * double(c.coverInverseAx), v = (y - double(c.coverCy)) * double(c.coverInverseAy);
    const double w = std::sqrt(std::max(0.0, 1 - u * u - v * v));
    return Vec3d(c.coverKd) * shadingAt(light, c.coverLights, [&](const ControlLighting::Sun& s) { return s.a * u + s.b * v + s.c * w; }) -
           Vec3d(c.coverMean);
  }
  if (seen < 0) return Vec3d(0);
  return Vec3d(c.kd[seen]) * shadingAt(light, c.lights[seen], [&](const ControlLighting::Sun& s) { return s.a * seenU + s.b * seenV + s.c * seenW; }) -
         Vec3d(c.mean);
}

StratumControl ellipseControl(int x, int y, const PixelStratum& p, const Vec3d& kd, double sine, const ParallelProjection& image,
                              const ControlLighting& light) {
  StratumControl control{};
  if (!(sine <= kMostControlSine)) return control;
  DiskPieces::Point corner[4];
  const int xs[4] = {x, x + 1, x + 1, x}, ys[4] = {y, y, y + 1, y + 1};
  for (int k = 0; k < 4; ++k) p.frame(0, xs[k], ys[k], corner[k].u, corner[k].v);
  const UnitDiskPart part(corner, 4);
  if (!(part.area > 0)) return control;
  control.kd[0] = Vec3<float>(kd);
  Vec3d axes[3];
  ellipseAxes(p, image, axes);
  const auto toward = [&](const ControlLighting::Sun& s) {
    const Vec3d d(s.a, s.b, s.c);
    return Vec3d(dot(d, axes[0]), dot(d, axes[1]), dot(d, axes[2]));
  };
  const Vec3d along = shadingOver(part, light, toward, control.lights[0]);
  control.mean = Vec3<float>(Vec3d(control.kd[0]) * along / part.area);
  return control;
}

Vec3d ellipseControlAt(const PixelStratum& p, const StratumControl& c, const ParallelProjection& image, const ControlLighting& light,
                       double x, double y) {
  double u, v;
  p.frame(0, x, y, u, v);
  const double w = std::sqrt(std::max(0.0, 1 - u * u - v * v));
  Vec3d axes[3];
  ellipseAxes(p, image, axes);
  const Vec3d normal = u * axes[0] + v * axes[1] + w * axes[2];
  return Vec3d(c.kd[0]) * shadingAt(light, c.lights[0], [&](const ControlLighting::Sun& s) { return dot(Vec3d(s.a, s.b, s.c), normal); }) -
         Vec3d(c.mean);
}

void ellipseAxes(const PixelStratum& p, const ParallelProjection& image, Vec3d* axes) {
  const double l11 = p.inverseAx[0], l22 = p.inverseAy[0], l12 = p.shear;
  const auto ray = [&](double du, double dv) {  // the unit direction through sample position centre + (du, dv)
    const double x = double(p.cx[0]) + du, y = double(p.cy[0]) + dv;
    const Vec3d d(x * image.pixelWidth + image.xOffset, y * image.pixelHeight - image.yOffset, -1.0);
    return d / std::sqrt(dot(d, d));
  };
  const Vec3d centre = ray(0, 0);
  const auto across = [&](const Vec3d& d) {
    const Vec3d off = d - dot(d, centre) * centre;
    return off / std::sqrt(dot(off, off));
  };
  axes[0] = across(ray(1 / l11, 0));
  axes[1] = across(ray(-l12 / (l11 * l22), 1 / l22));
  axes[2] = -centre;
}

}  // namespace durer
