#pragma once
#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>

#include "durer/Inline.h"
#include "durer/Options.h"
#include "durer/accel/SphereView.h"
#include "durer/geometry/RayPacket.h"
#include "durer/math/Float.h"
#include "durer/math/Vec.h"
#include "durer/scene/Limits.h"

namespace durer {

// A camera as the user states it. direction and up need not be unit or orthogonal: the frame is
// horizontal = normalize(direction × up), up' = horizontal × direction (the 6.837 construction).
struct CameraSpec {
  Projection projection = Projection::Orthographic;
  Vec3d center{0};         // world space: the eye (perspective) or the image centre (orthographic)
  Vec3d direction{0, 0, -1};
  Vec3d up{0, 1, 0};
  double size = 1;         // orthographic: world-space extent of the fitted dimension; perspective: its field of view, degrees
  Fit fit = Fit::Auto;
  double shiftX = 0;       // image-plane offset in units of the fitted extent, right
  double shiftY = 0;       // likewise, up
  double pixelAspect = 1;  // a pixel's height / width on the image plane (Blender's pixel aspect y / x)
  double tMin = 0;         // camera rays count hits with t in [tMin, tMax), t in world units
  double tMax = 0;
  // Perspective: tMin and tMax bound the distance along the view axis, not along each ray (planes,
  // Blender's clip range); t stays along the ray.
  bool clipPlanes = false;
  // Depth of field, as a thin lens (Cycles' camera): each ray leaves a point of the aperture, in the
  // plane through the eye (perspective) or the pixel's origin (orthographic) across the view axis,
  // toward the point where the pinhole ray meets the plane of focus, focusDistance along the view
  // axis (world units). The aperture is a disc of radius apertureRadius (world units; 0: a pinhole,
  // everything in focus), or with apertureBlades >= 3 the regular polygon inscribed in it, turned
  // by apertureRotation radians (its first edge's corners at ±pi/blades); apertureRatio > 1 narrows it
  // horizontally (an anamorphic lens's oval bokeh).
  double apertureRadius = 0;
  double focusDistance = 1;
  int apertureBlades = 0;
  double apertureRotation = 0;
  double apertureRatio = 1;
};

void validate(const CameraSpec& spec);  // throws std::invalid_argument naming the field

// The most blades an aperture may have (Blender's limit); more would only round the polygon further.
constexpr int kMostApertureBlades = 100;

// How far a point of the aperture lies from its centre at most (world units; 0 without a lens).
inline double apertureReach(const CameraSpec& spec) {
  return spec.apertureRadius > 0 ? spec.apertureRadius * std::fmax(1, 1 / spec.apertureRatio) : 0;
}

// The image plane's pixel pitch and the position of sample (0, 0) on it (at distance 1 for
// perspective), in double: Camera<Real> rounds them to its precision.
struct ImageWindow {
  double pixelWidth, pixelHeight, xOffset, yOffset;

  // The farthest sample position of a width x height image from the window's centre, along each
  // axis (image-plane units).
  double reachX(int width) const { return std::fmax(std::fabs(xOffset), std::fabs(xOffset + width * pixelWidth)); }
  double reachY(int height) const { return std::fmax(std::fabs(yOffset), std::fabs(yOffset - height * pixelHeight)); }
};
ImageWindow imageWindow(const CameraSpec& spec, int width, int height);

// Throws std::invalid_argument naming the camera's fields unless its rays fit `limits`: the
// origins (orthographic: the window around the centre) and, for a perspective camera, the window at
// unit distance. Returns the largest |coordinate| of the rays' origins.
double requireRaysWithin(const CameraSpec& spec, int width, int height, const NumericLimits& limits);

// A camera set up for one image size. Sample positions are in pixels: x right from the left edge,
// y down from the top edge, so pixel (i, j)'s centre is (i + 0.5, j + 0.5). Directions are unit,
// so t is a distance.
template <typename Real>
class Camera {
 public:
  Camera(const CameraSpec& spec, int width, int height);

  // Rays through the sample positions; with a lens (hasLens) and lens samples (lensU, lensV in
  // [0, 1)^2, one per ray), from the aperture's points they map to; without them, through its centre.
  // The packet's sampleBox is the caller's to set where a view searches it (placeSamples finds it).
  void generate(RayPacket<Real>& packet, const Real* sampleX, const Real* sampleY, int count,
                const double* lensU = nullptr, const double* lensV = nullptr) const;

  // Whether rays leave an aperture of some size (depth of field): no two share an origin.
  bool hasLens() const { return m_lensRadius > 0; }
  // How far the lens's rays through one sample position spread, in pixels, over the depths of the
  // sphere (center, radius) along the view axis: its blur's radius (0 where it reaches the lens's
  // plane of a perspective camera: its footprint is unbounded with or without a lens). 0 without a
  // lens.
  double lensBlur(const Vec3d& center, double radius) const;

  // Where camera rays may meet the sphere (center, radius): the box [x0, x1] x [y0, y1] of the
  // sample positions (pixels, as generate takes them) whose rays may meet it, and a lower bound on
  // the t they would meet it at. False if no camera ray can meet it. Conservative for the rays
  // generate makes in Real and the robust sphere test's roots (widened by bounds on both roundings
  // and by 1/64 pixel); infinite ends where the sphere reaches the plane of a perspective eye.
  // With `disk`, also the disk about its centre's position that holds the box's positions that may
  // meet it, and its core: the positions whose ray lines pass through the sphere, shrunk by the
  // same bounds and margin (an orthographic camera: the sphere's own disk; a perspective one: the
  // disks about the projected centre that hold its projected ellipse and lie within it). With a
  // lens, the box and the bound hold for rays from anywhere on it (the disk is the pinhole's: lights
  // have no lens).
  bool footprint(const Vec3d& center, double radius, SampleBox& box, double& tLow, SampleDisk* disk = nullptr) const;
  // That margin, in pixels, beyond the rounding bounds on every side of a footprint. The box bounds
  // the rays' own (rounded) sample positions; the margin keeps a ray whose position rounded up onto
  // its pixel's far edge in its pixel's row (SphereView's rows: floor of the box's ends). Whether a
  // pixel's closed square meets the sphere's disk needs none (TileRenderer::markSilhouettes).
  static constexpr double kFootprintMargin = 1.0 / 64;

  // footprint() of the spheres (centers[j], radii[j]), seen[j] its result, for j < n <=
  // SphereView's kFootprints; every array holds kFootprints entries (lanes from n on are the
  // caller's to fill and are computed, not used), `disks` footprint's disk (or null). A pinhole's
  // without disks (a camera's view) are made in the lanes of vectors (DoubleLanes), by pinhole()'s
  // or orthographic()'s operations, which do not branch: the same numbers as footprint()'s, eight
  // spheres an instruction.
  static constexpr int kFootprints = SphereView<Real>::kFootprints;
  static_assert(kFootprints == sizeof(DoubleLanes) / sizeof(double), "a footprint a lane");
  DURER_INLINE void footprints(int n, const Vec3d* centers, const double* radii, SampleBox* boxes, double* tLows,
                               SampleDisk* disks, bool* seen) const {
    if (hasLens() || disks) {
      for (int j = 0; j < n; ++j) seen[j] = footprint(centers[j], radii[j], boxes[j], tLows[j], disks ? &disks[j] : nullptr);
      return;
    }
    const ParallelProjection image = projection();
    DoubleLanes x, y, z, r, qx, qy, qz, distance;
    for (int j = 0; j < kFootprints; ++j) x[j] = centers[j].x, y[j] = centers[j].y, z[j] = centers[j].z, r[j] = radii[j];
    image.inFrame(x, y, z, qx, qy, qz, distance);
    const Pinhole<DoubleLanes> p = m_perspective ? pinhole(image, qx, qy, qz, distance, r)
                                                 : orthographic(image, qx, qy, qz, r, orthographicExtent(image), 1);
    const DoubleLanes low = p.distance - p.reach;
    for (int j = 0; j < n; ++j) boxes[j] = {p.x0[j], p.x1[j], p.y0[j], p.y1[j]}, tLows[j] = low[j], seen[j] = p.seen[j] != 0;
  }

  // The frame and image window in double, as rounded to Real (where a point lies on the image).
  ParallelProjection projection() const {
    return {Vec3d(m_center), Vec3d(m_horizontal), Vec3d(m_up), Vec3d(m_forward), m_pixelWidth, m_pixelHeight,
            m_xOffset, m_yOffset, m_perspective};
  }

  // Whether hits must lie between the near and far planes (CameraSpec::clipPlanes, perspective):
  // the search's [tMin, tMax) along each ray holds them, and clip() keeps only them.
  bool clipsAtPlanes() const { return m_clipPlanes; }

  // The search's range [tMin, tMax) along each camera ray (CameraSpec).
  double tMin() const { return double(m_tMin); }
  double tMax() const { return double(m_tMax); }

  // Ray k of a packet this camera generated, searched (tHit, prim): a miss if its hit lies beyond the
  // far plane; true if it lies before the near plane, which only rays off the axis can meet (the
  // search counts t from tMin along the ray), and `tMin` is then where the ray crosses that plane.
  bool clip(RayPacket<Real>& packet, int k, Real& tMin) const {
    if (packet.prim[k] == kNoPrimitive) return false;
    const Real scale = planarScale(packet.dx[k], packet.dy[k], packet.dz[k]);
    const Real depth = packet.tHit[k] * scale;
    if (!(depth < m_far)) {
      packet.prim[k] = kNoPrimitive;
      packet.tHit[k] = packet.tMax;
      return false;
    }
    tMin = m_near / scale;
    return depth < m_near && tMin > packet.tHit[k];
  }

  // The factor that turns t along a unit camera ray with direction (dx, dy, dz) into the distance
  // along the view axis: the cosine to it for perspective rays and a lens's, exactly 1 for
  // orthographic pinhole ones (along the axis).
  Real planarScale(Real dx, Real dy, Real dz) const {
    return m_perspective || hasLens() ? dx * m_forward.x + dy * m_forward.y + dz * m_forward.z : Real(1);
  }

 private:
  // The rays' own rounding: each coordinate of an orthographic origin within a few units in the last
  // place of its magnitude, a direction within a few of its angle; the robust test's roots within a
  // few of t (docs/numerics.md). 64 epsilons of every magnitude involved bounds all of them with room
  // to spare.
  static constexpr double kFootprintEps = 64 * static_cast<double>(std::numeric_limits<Real>::epsilon());

  // The range of x/z over the disk of radius r around (x, z) in the half plane z > 0, the tangents of
  // the angles under which an eye at the origin sees it; infinite ends where it reaches z = 0 on that
  // side. `angle`: widening of those angles. False if it lies wholly in z <= 0.
  // Without trigonometry (tan, atan2 and asin per sphere would dominate a view's making): the disk's
  // two tangents from the eye, (x L + z r, z L - x r) and (x L - z r, z L + x r) for the tangent
  // length L = sqrt(d^2 - r^2), are its extreme directions. Their z decides each end: at or behind
  // z = 0 the range reaches that side's infinity. The disk spans less than half a turn (d > r), so
  // the directions between them lie in front wherever both ends do, and behind wherever neither does.
  // A radius grown by kAngleWidening angle D, for any D >= d (the caller's distance in three
  // dimensions), widens the angles by at least that many times angle (asin's slope is at least 1):
  // `angle`, and room for the few units in the last place the products here round by. Every
  // operation is made and its result selected, without branches (footprints()), in numbers or lanes.
  static constexpr double kAngleWidening = 1.25;
  template <typename D>
  DURER_INLINE static LaneMask<D> seenRange(D x, D z, D r, double angle, D distance, D& lo, D& hi) {
    const D zero{}, inf = zero + std::numeric_limits<double>::infinity();
    const D distanceSq = x * x + z * z;
    const D reach = r + kAngleWidening * angle * distance;
    const D tangentSq = distanceSq - reach * reach;
    const LaneMask<D> around = !(tangentSq > zero);  // the eye is inside (or on) the widened disk: every direction
    const D tangent = squareRoot(around ? zero : tangentSq);
    const D lowX = x * tangent - z * reach, lowZ = z * tangent + x * reach;
    const D highX = x * tangent + z * reach, highZ = z * tangent - x * reach;
    const D lowSlope = lowX / lowZ, highSlope = highX / highZ;
    const LaneMask<D> lowAhead = lowZ > zero, highAhead = highZ > zero;  // bitwise below: no branch
    lo = ((!around) & lowAhead) ? lowSlope : -inf;
    hi = ((!around) & highAhead) ? highSlope : inf;
    return around | lowAhead | highAhead;
  }

  // A perspective camera's footprint of a sphere (its centre q in the frame and its distance from the
  // eye: image.inFrame) through its pinhole (footprint() without a lens), and what footprint()
  // builds on for a lens or a disk: the radius grown by the rounding bounds. Numbers or lanes.
  template <typename D>
  struct Pinhole {
    D distance, reach;  // distance - reach: the footprint's tLow (orthographic: distance is the depth)
    D x0, x1, y0, y1;   // the box (SampleBox)
    LaneMask<D> seen;
  };
  template <typename D>
  DURER_INLINE static Pinhole<D> pinhole(const ParallelProjection& image, D qx, D qy, D qz, D distance, D radius) {
    constexpr double eps = kFootprintEps, m = kFootprintMargin;
    Pinhole<D> p;
    p.distance = distance;
    p.reach = radius + eps * (distance + radius);
    D x0, x1, y0, y1;
    const LaneMask<D> seenX = seenRange(qx, qz, p.reach, eps, distance, x0, x1);
    const LaneMask<D> seenY = seenRange(qy, qz, p.reach, eps, distance, y0, y1);
    p.seen = seenX & seenY;
    p.x0 = image.sampleX(x0) - m, p.x1 = image.sampleX(x1) + m;
    p.y0 = image.sampleY(y1) - m, p.y1 = image.sampleY(y0) + m;
    return p;
  }

  // The same through an orthographic camera (its centre's depth q.z the distance; `extent`:
  // orthographicExtent()): the box of the radius grown by the rounding bounds (the reach: the
  // footprint's half width in world units), before a lens widens it, and whether some ray may meet
  // the sphere at t_min or beyond: a lens's rays lean from the axis, their t exceeding the depth by
  // up to `lean` (1 without a lens).
  template <typename D>
  DURER_INLINE Pinhole<D> orthographic(const ParallelProjection& image, D qx, D qy, D qz, D radius, double extent,
                                       double lean) const {
    constexpr double m = kFootprintMargin;
    Pinhole<D> p;
    p.distance = qz;
    p.reach = radius + kFootprintEps * (extent + magnitude(qz) + radius);
    const D deepest = qz + p.reach, zero{};
    p.seen = !((deepest > zero ? deepest * lean : deepest) < zero + static_cast<double>(m_tMin));
    p.x0 = image.sampleX(qx - p.reach) - m, p.x1 = image.sampleX(qx + p.reach) + m;
    p.y0 = image.sampleY(qy + p.reach) - m, p.y1 = image.sampleY(qy - p.reach) + m;
    return p;
  }
  // The magnitudes in an orthographic footprint's rounding bound that do not depend on the sphere:
  // the frame's centre and the image window's reach.
  double orthographicExtent(const ParallelProjection& image) const;
  // A perspective footprint's disk (footprint's), from the sphere's centre q in the frame, its
  // distance and radius grown and shrunk by the rounding bounds.
  static SampleDisk perspectiveDisk(const ParallelProjection& image, const Vec3d& q, double distance, double grown,
                                    double shrunk);

  bool m_perspective;
  // Whether generate scales a perspective ray's direction to unit length by inverseSqrt: in double,
  // where its squared length (1 + the window's reach squared at most) lies in inverseSqrt's range.
  bool m_inverseSqrt;
  int m_width, m_height;
  Vec3<Real> m_center, m_forward, m_horizontal, m_up;  // unit, orthonormal frame
  Real m_pixelWidth, m_pixelHeight;                    // image-plane units per pixel (at distance 1 for perspective)
  Real m_xOffset, m_yOffset;                           // image-plane position of sample (0, 0)
  Real m_tMin, m_tMax;   // the search's range along each ray
  bool m_clipPlanes;
  Real m_near, m_far;    // clipsAtPlanes(): the planes' distances along the view axis
  // The aperture (CameraSpec): radius (0: none), the plane of focus's distance, horizontal scale
  // (1 / apertureRatio), its blades (0: a disc) and their corners (x, y on the unit circle, the
  // first again at the end; none without a lens).
  double m_lensRadius, m_lensScaleX;
  Real m_focus;
  int m_blades;
  std::vector<double> m_corners;

  // The image window as rounded to Real, in double (projection()'s).
  ImageWindow window() const { return {m_pixelWidth, m_pixelHeight, m_xOffset, m_yOffset}; }
  // The aperture's point for lens sample (u, v), in world units along the horizontal and up axes.
  void lensPoint(double u, double v, Real& x, Real& y) const;
  // How far a lens point lies from the lens's centre at most: along the horizontal axis, the up axis,
  // and either (with room for their rounding); the largest lean of a lens ray off the pinhole ray's
  // direction it replaces, as a slope (the reach over the focus distance).
  double lensReachX() const { return m_lensRadius * m_lensScaleX * (1 + 1e-6); }
  double lensReachY() const { return m_lensRadius * (1 + 1e-6); }
  double lensReach() const { return std::max(lensReachX(), lensReachY()); }  // apertureReach, with room
  double lensSlope() const { return lensReach() / static_cast<double>(m_focus); }
  // A lens ray's shift off the pinhole ray of its sample position, per unit of its lens point's
  // distance from the centre, at most over the depths [near, far] along the view axis: at unit
  // distance for a perspective camera (|1/z - 1/focus|; inf from the lens's plane on), in world
  // units for an orthographic one (|1 - z/focus|).
  double lensShift(double near, double far) const;
  // Widens a footprint's box by dx, dy (image-plane units: world units orthographic, at unit distance
  // perspective) on each side.
  static void widen(SampleBox& box, double dx, double dy, const ParallelProjection& image) {
    box.x0 -= dx / image.pixelWidth, box.x1 += dx / image.pixelWidth;
    box.y0 -= dy / image.pixelHeight, box.y1 += dy / image.pixelHeight;
  }
};

// Sample positions (x[k] + u[k], y[k] + v[k]) in Real for k < count (pixels' corners and offsets in
// [0, 1): positions >= +0), and their box [x0, x1, y0, y1] (RayPacket::sampleBox, which the camera's
// view searches by), found over the positions' bits in the same loop: a reduction over the positions
// once they were stored waited on the stores (10 % of a 16-spp render of one sphere; a centred
// sampler's tile knows its box: docs/benchmarks.md).
template <typename Real, typename Pixel>
DURER_INLINE void placeSamples(const Pixel* x, const Pixel* y, const double* u, const double* v, int count,
                               Real* sampleX, Real* sampleY, Real* box) {
  auto x0 = nonNegativeBits(std::numeric_limits<Real>::infinity()), x1 = nonNegativeBits(Real(0)), y0 = x0, y1 = x1;
  for (int k = 0; k < count; ++k) {
    const Real sx = static_cast<Real>(x[k] + u[k]), sy = static_cast<Real>(y[k] + v[k]);
    sampleX[k] = sx, sampleY[k] = sy;
    x0 = std::min(x0, nonNegativeBits(sx)), x1 = std::max(x1, nonNegativeBits(sx));
    y0 = std::min(y0, nonNegativeBits(sy)), y1 = std::max(y1, nonNegativeBits(sy));
  }
  box[0] = fromNonNegativeBits<Real>(x0), box[1] = fromNonNegativeBits<Real>(x1);
  box[2] = fromNonNegativeBits<Real>(y0), box[3] = fromNonNegativeBits<Real>(y1);
}

// Inline so that render kernels can inline (and clone) it.
template <typename Real>
inline void Camera<Real>::generate(RayPacket<Real>& packet, const Real* sampleX, const Real* sampleY, int count,
                                   const double* lensU, const double* lensV) const {
  const bool lens = lensU != nullptr && hasLens();
  packet.count = count;
  packet.tMin = m_tMin;
  packet.tMax = m_tMax;
  packet.commonOrigin = m_perspective && !lens;
  // A lens's rays spread over the aperture from the start: where no view serves them (the camera's
  // view of the scene's own spheres does, its footprints widened by their blur, while that blur is
  // small: TileRenderer::viewOf), they walk the hierarchy (or a cloud's grid) ray by ray, as shadow
  // and mirror rays do (docs/benchmarks.md: depth of field).
  packet.coherent = !lens;
  packet.view = nullptr;
  packet.tileWidth = 0;
  packet.sampleX = sampleX, packet.sampleY = sampleY;
  // Plain component arithmetic so that the loop vectorises.
  const Vec3<Real> c = m_center, f = m_forward, h = m_horizontal, u = m_up;
  if (lens) {
    for (int k = 0; k < count; ++k) {
      const Real x = sampleX[k] * m_pixelWidth + m_xOffset;
      const Real y = m_yOffset - sampleY[k] * m_pixelHeight;
      Real lx, ly;
      lensPoint(lensU[k], lensV[k], lx, ly);
      const Vec3<Real> offset = lx * h + ly * u;  // from the pinhole ray's origin to the aperture's point
      // The pinhole ray's origin, and where it meets the plane of focus, relative to it.
      const Vec3<Real> origin = m_perspective ? c : c + x * h + y * u;
      const Vec3<Real> focus = m_perspective ? m_focus * (f + x * h + y * u) : m_focus * f;
      const Vec3<Real> d = focus - offset;
      const Real inv = 1 / std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
      packet.ox[k] = origin.x + offset.x, packet.oy[k] = origin.y + offset.y, packet.oz[k] = origin.z + offset.z;
      packet.dx[k] = d.x * inv, packet.dy[k] = d.y * inv, packet.dz[k] = d.z * inv;
    }
  } else if (m_perspective) {
    const auto directions = [&](auto unitScale) DURER_INLINE_LAMBDA {
      for (int k = 0; k < count; ++k) {
        const Real x = sampleX[k] * m_pixelWidth + m_xOffset;
        const Real y = m_yOffset - sampleY[k] * m_pixelHeight;
        const Real dx = f.x + x * h.x + y * u.x, dy = f.y + x * h.y + y * u.y, dz = f.z + x * h.z + y * u.z;
        const Real inv = unitScale(dx * dx + dy * dy + dz * dz);
        packet.ox[k] = c.x, packet.oy[k] = c.y, packet.oz[k] = c.z;
        packet.dx[k] = dx * inv, packet.dy[k] = dy * inv, packet.dz[k] = dz * inv;
      }
    };
    if constexpr (std::is_same_v<Real, double>) {
      if (m_inverseSqrt) return directions([](double s) DURER_INLINE_LAMBDA { return inverseSqrt(s); });
    }
    directions([](Real s) DURER_INLINE_LAMBDA { return 1 / std::sqrt(s); });
  } else {
    for (int k = 0; k < count; ++k) {
      const Real x = sampleX[k] * m_pixelWidth + m_xOffset;
      const Real y = m_yOffset - sampleY[k] * m_pixelHeight;
      packet.ox[k] = c.x + x * h.x + y * u.x, packet.oy[k] = c.y + x * h.y + y * u.y;
      packet.oz[k] = c.z + x * h.z + y * u.z;
      packet.dx[k] = f.x, packet.dy[k] = f.y, packet.dz[k] = f.z;
    }
  }
}

template <typename Real>
inline void Camera<Real>::lensPoint(double u, double v, Real& x, Real& y) const {
  double px, py;
  if (m_blades == 0) {  // Shirley and Chiu's concentric map: the square's strata stay compact on the disc
    const double a = 2 * u - 1, b = 2 * v - 1;
    if (a == 0 && b == 0) {
      px = py = 0;
    } else {
      const bool wide = std::fabs(a) > std::fabs(b);
      const double r = wide ? a : b, phi = wide ? kPi / 4 * (b / a) : kPi / 2 - kPi / 4 * (a / b);
      px = r * std::cos(phi), py = r * std::sin(phi);
    }
  } else {  // a corner's triangle (centre and two corners) by u, then uniform in it
    const double scaled = u * m_blades;
    const int corner = std::min(static_cast<int>(scaled), m_blades - 1);
    const double s = std::sqrt(scaled - corner);  // the distance's fraction from the centre
    const double* p = &m_corners[2 * static_cast<size_t>(corner)];
    px = s * ((1 - v) * p[0] + v * p[2]), py = s * ((1 - v) * p[1] + v * p[3]);
  }
  x = static_cast<Real>(px * m_lensScaleX * m_lensRadius), y = static_cast<Real>(py * m_lensRadius);
}

}  // namespace durer
