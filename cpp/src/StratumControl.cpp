// A pixel stratum's control variate (StratumControl.h): out of line, made once a stratum pixel.
#include "durer/render/StratumControl.h"

#include <algorithm>
#include <cmath>

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

int seenWithin(const PixelBall& a, const PixelBall& b, double x0, double x1, double y0, double y1) {
  double px = 0, py = 0;
  if (!overlapWithin(a, b, x0, x1, y0, y1, px, py)) return 3;
  // The fronts' intersection: the circle of centre o and radius rho in the plane square to n, its
  // points o + rho (cos t e1 + sin t e2), e1 its direction of growing depth (its depth o.z + rho
  // sigma cos t), e2 across the view. Before both centres' depths where cos t <= kappa.
  const Vec3d ca(a.x, a.y, a.z), cb(b.x, b.y, b.z), between = cb - ca;
  const double d = std::sqrt(dot(between, between));
  if (d > std::abs(a.r - b.r) && d < a.r + b.r) {
    const Vec3d n = between / d;
    const double t = (d * d + a.r * a.r - b.r * b.r) / (2 * d), rho = std::sqrt(std::max(0.0, a.r * a.r - t * t));
    const Vec3d o = ca + t * n;
    const double sigma = std::sqrt(std::max(0.0, 1 - n.z * n.z)), nearest = std::min(a.z, b.z);
    constexpr double kSlack = 1e-9;  // of a pixel: a crossing that near a side counts
    double kappa, ex1, ey1, ex2, ey2;
    if (sigma > 1e-12) {
      ex1 = -n.z * n.x / sigma, ey1 = -n.z * n.y / sigma;
      const Vec3d e1(ex1, ey1, sigma), e2 = cross(n, e1);
      ex2 = e2.x, ey2 = e2.y;
      kappa = (nearest - o.z) / (rho * sigma);
    } else {  // the circle faces the view: all of it at o's depth
      ex1 = 1, ey1 = 0, ex2 = 0, ey2 = 1;
      kappa = o.z <= nearest ? 2.0 : -2.0;
    }
    if (kappa >= -1 - kSlack) {
      const auto onArc = [&](double angle) { return std::cos(angle) <= kappa + kSlack; };
      const auto at = [&](double angle, double& x, double& y) {
        x = o.x + rho * (std::cos(angle) * ex1 + std::sin(angle) * ex2), y = o.y + rho * (std::cos(angle) * ey1 + std::sin(angle) * ey2);
      };
      const auto within = [&](double x, double y) { return x >= x0 - kSlack && x <= x1 + kSlack && y >= y0 - kSlack && y <= y1 + kSlack; };
      // Where it crosses the lines of the rectangle's sides: alpha cos t + beta sin t = gamma.
      for (int side = 0; side < 4; ++side) {
        const bool vertical = side < 2;
        const double line = vertical ? (side == 0 ? x0 : x1) : (side == 2 ? y0 : y1);
        const double alpha = rho * (vertical ? ex1 : ey1), beta = rho * (vertical ? ex2 : ey2), gamma = line - (vertical ? o.x : o.y);
        const double reach = std::sqrt(alpha * alpha + beta * beta);
        if (!(reach > 0) || std::abs(gamma) > reach * (1 + kSlack)) continue;
        const double phase = std::atan2(beta, alpha), off = std::acos(std::clamp(gamma / reach, -1.0, 1.0));
        for (const double angle : {phase + off, phase - off}) {
          double x, y;
          at(angle, x, y);
          if (onArc(angle) && within(vertical ? line : x, vertical ? y : line)) return 0;
        }
      }
      double x, y;
      at(kPi, x, y);  // the arc's middle (cos t = -1: the nearest point)
      if (within(x, y)) return 0;
    }
  }
  const auto front = [&](const PixelBall& s) { return s.z - std::sqrt(std::max(0.0, s.r * s.r - (px - s.x) * (px - s.x) - (py - s.y) * (py - s.y))); };
  const double fa = front(a), fb = front(b);
  return fa < fb ? 1 : fb < fa ? 2 : 0;
}

namespace {

// The shading (ambient light and the lights of `lights`) over a clipped part, in its frame.
Vec3d shadingOver(const ClippedDiskPart& part, const ControlLighting& light, uint8_t lights) {
  Vec3d along = light.ambient * part.area;
  for (int l = 0; l < light.suns; ++l) {
    if (lights & (1u << l)) along += part.clampedIntegral(light.sun[l].a, light.sun[l].b, light.sun[l].c) * light.sun[l].color;
  }
  return along;
}

// An order of n members (rank[i]: 0 first) in which before[i][j] puts i before j, if one exists.
bool rankBy(const bool (*before)[PixelStratum::kMostDisks], int n, uint8_t* rank) {
  int order[PixelStratum::kMostDisks] = {0, 1, 2};
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

}  // namespace

StratumControl diskControl(int x, int y, const PixelStratum& p, const ControlMember* members, const ControlLighting& light) {
  constexpr int kMost = PixelStratum::kMostDisks;
  StratumControl control{};
  if (p.shear != 0) return control;
  const int n = p.disks;
  // Which member is seen where two disks overlap: the rank. In the frame of several disks (pixel
  // units across, the first's aspect down, depth in the same units).
  bool overlap[kMost][kMost] = {}, before[kMost][kMost] = {};
  if (n > 1) {
    const double scale = 1 / (double(p.inverseAx[0]) * members[0].radius);  // pixel units a world unit
    PixelBall ball[kMost];
    for (int i = 0; i < n; ++i) {
      ball[i] = {double(p.cx[i]) - x, (double(p.cy[i]) - y) * double(p.aspect), members[i].centre.z * scale, 1 / double(p.inverseAx[i])};
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < i; ++j) {
        double px, py;
        if (!overlapWithin(ball[i], ball[j], 0, 1, 0, double(p.aspect), px, py)) continue;
        overlap[i][j] = overlap[j][i] = true;
        const Vec3d d = members[i].centre - members[j].centre;
        const double apart = members[i].radius + members[j].radius;
        if (dot(d, d) >= apart * apart) {  // apart in space: the nearer centre in front
          (members[i].centre.z < members[j].centre.z ? before[i][j] : before[j][i]) = true;
          continue;
        }
        const int seen = seenWithin(ball[i], ball[j], 0, 1, 0, double(p.aspect));
        if (seen == 0) return control;  // the one seen changes in the pixel
        (seen == 1 ? before[i][j] : before[j][i]) = true;
      }
    }
    if (!rankBy(before, n, control.rank)) return control;
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
    // inclusion and exclusion.
    double cu[kMost], cv[kMost], cr[kMost];
    int nearer = 0;
    for (int j = 0; j < n; ++j) {
      if (!overlap[i][j] || control.rank[j] > control.rank[i]) continue;
      cu[nearer] = (double(p.cx[j]) - double(p.cx[i])) * double(p.inverseAx[i]);
      cv[nearer] = (double(p.cy[j]) - double(p.cy[i])) * double(p.aspect) * double(p.inverseAx[i]);
      cr[nearer++] = double(p.inverseAx[i]) / double(p.inverseAx[j]);
    }
    const auto cover = [&](int first, int count, double sign) {
      const ClippedDiskPart covered(u0, u1, v0, v1, cu + first, cv + first, cr + first, count);
      sum -= sign * kd * shadingOver(covered, light, control.lights[i]) / scale, inside -= sign * covered.area / scale;
    };
    if (nearer >= 1) cover(0, 1, 1);
    if (nearer == 2) cover(1, 1, 1), cover(0, 2, -1);
  }
  if (!(inside > 0)) return {};
  control.mean = Vec3<float>(sum / inside);
  return control;
}

Vec3d diskControlAt(const PixelStratum& p, const StratumControl& c, const ControlLighting& light, double x, double y) {
  int seen = -1;  // the first by rank whose disk holds it
  double seenU = 0, seenV = 0;
  for (int i = 0; i < p.disks; ++i) {
    double u, v;
    p.frame(i, x, y, u, v);
    if (!(u * u + v * v < 1) || (seen >= 0 && c.rank[seen] < c.rank[i])) continue;
    seen = i, seenU = u, seenV = v;
  }
  if (seen < 0) return Vec3d(0);
  const double w = std::sqrt(1 - seenU * seenU - seenV * seenV);
  return Vec3d(c.kd[seen]) * shadingAt(light, c.lights[seen], [&](const ControlLighting::Sun& s) { return s.a * seenU + s.b * seenV + s.c * w; }) -
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
