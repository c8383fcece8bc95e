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

StratumControl diskControl(int x, int y, const PixelStratum& p, const ControlMember* members, const ControlLighting& light) {
  constexpr int kMost = PixelStratum::kMostDisks;
  StratumControl control{};
  if (p.shear != 0) return control;
  const bool overlap = p.overlaps();
  for (int i = 0; overlap && i < p.disks; ++i) {
    for (int j = 0; j < i; ++j) {
      const Vec3d d = members[i].centre - members[j].centre;
      const double reach = members[i].radius + members[j].radius;
      if (!(dot(d, d) >= reach * reach)) return control;  // they cut through each other (or touch)
    }
  }
  Vec3d sum(0);
  double area[kMost] = {};  // each member's part, in pixels (of a member whose part is empty, 0 and no shading)
  for (int i = 0; i < p.disks; ++i) {
    double u0, v0, u1, v1;  // the pixel's corners in the member's frame (unsheared: a rectangle)
    p.frame(i, x, y, u0, v0), p.frame(i, x + 1, y + 1, u1, v1);
    const double scale = (u1 - u0) * (v1 - v0);  // a pixel's area in the frame
    const UnitDiskPart part(u0, u1, v0, v1);
    if (!(part.area > 0)) continue;
    control.kd[i] = Vec3<float>(members[i].kd);
    const Vec3d along = shadingOver(part, light, [](const ControlLighting::Sun& s) { return Vec3d(s.a, s.b, s.c); }, control.lights[i]);
    area[i] = part.area / scale;
    const Vec3d shading = Vec3d(control.kd[i]) * along / scale;
    sum += shading, control.hidden[i] = Vec3<float>(shading / area[i]);
  }
  // The part of each member's part that nearer ones cover, where any two disks overlap: its part
  // plus the nearer ones' union less their union with it (pixel units across, the strata's aspect
  // down: PixelStratum::of's frame).
  double inside = 0;  // the union's area
  for (int i = 0; i < p.disks; ++i) inside += area[i];
  int order[kMost] = {0, 1, 2};  // nearest first
  std::sort(order, order + p.disks, [&](int a, int b) { return members[a].centre.z < members[b].centre.z; });
  double cu[kMost], cv[kMost], radius[kMost], nearer = 0;  // in order; the nearer ones' union
  for (int n = 0; n < p.disks; ++n) {
    const int i = order[n];
    control.rank[i] = uint8_t(n);
    if (!overlap) continue;
    cu[n] = double(p.cx[i]) - x, cv[n] = (double(p.cy[i]) - y) * double(p.aspect), radius[n] = 1 / double(p.inverseAx[i]);
    const double both = circlesRectangleUnionArea(cu, cv, radius, n + 1, 1, double(p.aspect)) / double(p.aspect);
    const double covered = std::clamp(nearer + area[i] - both, 0.0, area[i]);
    sum -= Vec3d(control.hidden[i]) * covered, inside -= covered;
    nearer = both;
  }
  if (!(inside > 0)) return {};
  control.mean = Vec3<float>(sum / inside);
  return control;
}

Vec3d diskControlAt(const PixelStratum& p, const StratumControl& c, const ControlLighting& light, double x, double y) {
  Vec3d total(0), hidden(0);  // the shadings' sum; the members' `hidden` but the nearest's
  int nearest = -1;
  for (int i = 0; i < p.disks; ++i) {
    double u, v;
    p.frame(i, x, y, u, v);
    if (!(u * u + v * v < 1)) continue;
    const double w = std::sqrt(1 - u * u - v * v);
    total += Vec3d(c.kd[i]) * shadingAt(light, c.lights[i], [&](const ControlLighting::Sun& s) { return s.a * u + s.b * v + s.c * w; });
    if (nearest < 0) {
      nearest = i;
    } else {
      const bool nearer = c.rank[i] < c.rank[nearest];
      hidden += Vec3d(c.hidden[nearer ? nearest : i]);
      if (nearer) nearest = i;
    }
  }
  return nearest < 0 ? Vec3d(0) : total - hidden - Vec3d(c.mean);
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
