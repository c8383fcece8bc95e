#include "durer/render/Camera.h"

#include <cmath>
#include <limits>
#include <string>
#include <type_traits>

#include "durer/math/Float.h"
#include "durer/scene/Validate.h"

namespace durer {

namespace {
// sin of the smallest angle between direction and up that still gives a trustworthy frame.
constexpr double kMinSinUpAngle = 1e-9;
}  // namespace

void validate(const CameraSpec& spec) {
  requireFinite(spec.center, "center");
  requireNonZero(spec.direction, "direction");
  requireNonZero(spec.up, "up");
  if (glm::length(glm::cross(safeNormalize(spec.direction), safeNormalize(spec.up))) < kMinSinUpAngle) {
    fail("up must not be parallel to direction");
  }
  if (spec.projection == Projection::Orthographic) {
    requirePositive(spec.size, "size");
  } else if (!(std::isfinite(spec.size) && spec.size > 0 && spec.size < 180)) {
    fail("fov_degrees must be in (0, 180), got " + std::to_string(spec.size));
  }
  requireFinite(spec.shiftX, "shift x");
  requireFinite(spec.shiftY, "shift y");
  requirePositive(spec.pixelAspect, "pixel_aspect");
  requireRange(spec.tMin, spec.tMax, "t_min", "t_max");
  if (spec.clipPlanes && spec.projection == Projection::Perspective && !(spec.tMin >= 0)) {
    fail("t_min must be >= 0 with clip_planes (planes before the eye), got " + show(spec.tMin));
  }
  if (!(std::isfinite(spec.apertureRadius) && spec.apertureRadius >= 0)) {
    fail("aperture_radius must be finite and >= 0, got " + show(spec.apertureRadius));
  }
  if (spec.apertureRadius > 0) requirePositive(spec.focusDistance, "focus_distance");
  if (spec.apertureBlades != 0 && (spec.apertureBlades < 3 || spec.apertureBlades > kMostApertureBlades)) {
    fail("aperture_blades must be 0 (a disc) or from 3 to " + std::to_string(kMostApertureBlades) + ", got " +
         std::to_string(spec.apertureBlades));
  }
  requireFinite(spec.apertureRotation, "aperture_rotation");
  requirePositive(spec.apertureRatio, "aperture_ratio");
}

ImageWindow imageWindow(const CameraSpec& spec, int width, int height) {
  const double extent = spec.projection == Projection::Perspective ? 2 * std::tan(spec.size * kPi / 360) : spec.size;
  // The fitted dimension's span in pixel widths: a row is `width` of them, a column height·aspect.
  const double tall = height * spec.pixelAspect;
  const double span = spec.fit == Fit::Horizontal ? width
                      : spec.fit == Fit::Vertical ? tall
                                                  : std::max<double>(width, tall);
  const double pixelSize = extent / span;
  return {pixelSize, pixelSize * spec.pixelAspect, -0.5 * width * pixelSize + spec.shiftX * extent,
          0.5 * tall * pixelSize + spec.shiftY * extent};
}

double requireRaysWithin(const CameraSpec& spec, int width, int height, const NumericLimits& limits) {
  const std::string where = withPrecision(limits.precision);
  requireWithin(maxAbs(spec.center), limits.coordinate, "center", where);
  const ImageWindow w = imageWindow(spec, width, height);
  // The farthest sample from the window's centre along each axis (the frame is orthonormal).
  const double x = w.reachX(width), y = w.reachY(height);
  // NaN (an aspect whose product with the height overflows) fails as well as a reach beyond the limit.
  const double window = std::isnan(x + y) ? std::numeric_limits<double>::infinity() : x + y;
  const bool perspective = spec.projection == Projection::Perspective;
  requireWithin(perspective ? 1 + window : maxAbs(spec.center) + window, limits.coordinate,
                std::string("the image window (center, ") + (perspective ? "fov_degrees" : "size") +
                    ", shift, pixel_aspect at " + std::to_string(width) + "x" + std::to_string(height) + ")",
                where);
  // An aperture moves the origins up to its reach off the pinhole's, and the rays aim at points up
  // to focus_distance times the window's reach (at unit distance) from the eye's plane.
  const double lens = apertureReach(spec);
  if (spec.apertureRadius > 0) {
    requireWithin(lens + (perspective ? maxAbs(spec.center) : maxAbs(spec.center) + window), limits.coordinate,
                  "aperture_radius (with center and aperture_ratio)", where);
    requireWithin(spec.focusDistance * (perspective ? 1 + window : 1), limits.coordinate,
                  "focus_distance (with the image window)", where);
  }
  return lens + (perspective ? maxAbs(spec.center) : maxAbs(spec.center) + window);
}

template <typename Real>
Camera<Real>::Camera(const CameraSpec& spec, int width, int height)
    : m_perspective(spec.projection == Projection::Perspective),
      m_width(width),
      m_height(height),
      m_tMin(static_cast<Real>(spec.tMin)),
      m_tMax(static_cast<Real>(spec.tMax)),
      m_clipPlanes(spec.clipPlanes && m_perspective),
      m_near(static_cast<Real>(spec.tMin)),
      m_far(static_cast<Real>(spec.tMax)),
      m_lensRadius(spec.apertureRadius),
      m_lensScaleX(1 / spec.apertureRatio),
      m_focus(static_cast<Real>(spec.focusDistance)),
      m_blades(spec.apertureBlades) {
  const Vec3d forward = safeNormalize(spec.direction);
  const Vec3d horizontal = glm::normalize(glm::cross(forward, safeNormalize(spec.up)));
  const Vec3d up = glm::cross(horizontal, forward);
  const ImageWindow window = imageWindow(spec, width, height);
  m_center = toReal<Real>(spec.center);
  m_forward = toReal<Real>(forward);
  m_horizontal = toReal<Real>(horizontal);
  m_up = toReal<Real>(up);
  m_pixelWidth = static_cast<Real>(window.pixelWidth);
  m_pixelHeight = static_cast<Real>(window.pixelHeight);
  m_xOffset = static_cast<Real>(window.xOffset);
  m_yOffset = static_cast<Real>(window.yOffset);
  const double x = window.reachX(width), y = window.reachY(height);  // the farthest sample, each axis
  const double reach = 1 + x + y;  // a direction's length at most, with room for the rounding
  m_inverseSqrt = std::is_same_v<Real, double> && m_perspective && reach * reach < kInverseSqrtMost;
  if (m_clipPlanes) {
    // A ray meets the far plane at far / cos(its angle to the axis), farthest through the window's
    // farthest corner (at distance 1); 1e-6 more covers the rays' rounding in float (8 ulps). The
    // near plane's distance bounds t from below (t >= depth: the planes are >= 0, validate()).
    double slope2 = x * x + y * y;
    if (hasLens()) {  // a lens tilts a ray by up to its reach over the focus distance more
      const double r = std::sqrt(slope2) + apertureReach(spec) / spec.focusDistance;
      slope2 = r * r;
    }
    m_tMax = static_cast<Real>(spec.tMax * std::sqrt(1 + slope2) * (1 + 1e-6));
  }
  for (int i = 0; hasLens() && m_blades > 0 && i <= m_blades; ++i) {  // corner i at rotation + (2i - 1) pi / blades
    const double angle = spec.apertureRotation + (2 * i - 1) * kPi / m_blades;
    m_corners.push_back(std::cos(angle));
    m_corners.push_back(std::sin(angle));
  }
}

template <typename Real>
double Camera<Real>::orthographicExtent(const ParallelProjection& image) const {
  const ImageWindow w = window();
  return maxAbs(image.center) + (w.reachX(m_width) + w.reachY(m_height));
}

template <typename Real>
SampleDisk Camera<Real>::perspectiveDisk(const ParallelProjection& image, const Vec3d& q, double distance, double grown,
                                         double shrunk) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  if (!(q.z > 0 && distance > grown)) return {0, 0, inf, 0};  // the eye in the (grown) sphere, or it beside the eye
  // On the image plane at distance 1: the centre's direction at tan phi = T from the axis, the
  // grown sphere's half-angle at tan theta = tau. Its silhouette is an ellipse whose major axis lies
  // along the radial line through the centre's point P; the point of an ellipse farthest from a
  // point on its major axis is a vertex, here at angle phi + theta or phi - theta (the ellipse is
  // unbounded where phi + theta reaches a right angle).
  const double T = std::hypot(q.x, q.y) / q.z;
  const double tau = grown / std::sqrt(distance * distance - grown * grown);
  const double outer = T * tau < 1 ? std::max((T + tau) / (1 - T * tau) - T, T - (T - tau) / (1 + T * tau)) : inf;
  // A line through P3 (P on the plane) and X3 at angle psi passes P3 at |P3| sin psi <= |X3 - P3|: a
  // point within |P3| shrunk / distance of P sees the centre under an angle whose sine is below
  // shrunk / distance, so its line passes within `shrunk` of the centre.
  const double inner = shrunk > 0 ? std::sqrt(1 + T * T) * shrunk / distance : 0;
  return {image.sampleX(q.x / q.z), image.sampleY(q.y / q.z),
          outer / std::min(image.pixelWidth, image.pixelHeight) + kFootprintMargin,
          inner / std::max(image.pixelWidth, image.pixelHeight) - kFootprintMargin};
}

template <typename Real>
bool Camera<Real>::footprint(const Vec3d& center, double radius, SampleBox& box, double& tLow, SampleDisk* disk) const {
  // In double from the frame as rounded to Real (what generate uses); kFootprintEps says why.
  const double eps = kFootprintEps;
  const ParallelProjection image = projection();
  Vec3d q;
  double fromEye;  // perspective: the centre's distance from the eye
  image.inFrame(center.x, center.y, center.z, q.x, q.y, q.z, fromEye);
  constexpr double m = kFootprintMargin;
  if (!m_perspective) {
    // A lens's rays lean from the axis by up to lensSlope: t exceeds the depth by up to that factor.
    const double lean = hasLens() ? std::sqrt(1 + lensSlope() * lensSlope()) * (1 + 1e-6) : 1;
    const Pinhole<double> flat = orthographic(image, q.x, q.y, q.z, radius, orthographicExtent(image), lean);
    if (!flat.seen) return false;  // wholly before t_min
    const double reach = flat.reach, deepest = q.z + reach;
    box = {flat.x0, flat.x1, flat.y0, flat.y1};
    tLow = q.z - reach;
    if (hasLens()) {
      // A lens ray through sample x meets depth z at x + L (1 - z / focus), L its point on the lens.
      const double spread = lensShift(q.z - reach, deepest);
      const double slack = eps * ((1 + lensSlope()) * (std::fabs(q.z) + reach) + lensReach());
      widen(box, lensReachX() * spread + slack, lensReachY() * spread + slack, image);
      tLow = (tLow < 0 ? tLow * lean : tLow) - slack;
    }
    if (disk) {
      const double shrunk = radius - (reach - radius);
      *disk = {image.sampleX(q.x), image.sampleY(q.y), reach / std::min(image.pixelWidth, image.pixelHeight) + m,
               shrunk / std::max(image.pixelWidth, image.pixelHeight) - m};
    }
    return true;
  }
  const Pinhole<double> seen = pinhole(image, q.x, q.y, q.z, fromEye, radius);
  if (!seen.seen) return false;
  const double distance = seen.distance, reach = seen.reach;
  box = {seen.x0, seen.x1, seen.y0, seen.y1};
  tLow = distance - reach;
  if (hasLens()) {
    // A lens ray through the sample at x (at unit distance) meets depth z where the eye sees
    // x + L (1/z - 1/focus), L its point on the lens: the pinhole's footprint, widened by that shift
    // over the sphere's depths. Its origin lies within the lens's reach of the eye, so its t within
    // that of the eye's.
    const double near = q.z - reach, far = q.z + reach;
    const ImageWindow w = window();
    const double window = std::hypot(w.reachX(m_width), w.reachY(m_height));
    const double origin = eps * (maxAbs(image.center) + lensReach());  // the origins' rounding, world units
    if (near > 0) {
      const double slack = eps * (1 + window + lensSlope()) + origin / near;
      widen(box, lensReachX() * lensShift(near, far) + slack, lensReachY() * lensShift(near, far) + slack, image);
    } else {
      // Across the lens's plane the shift is unbounded; in three dimensions, such a ray lies at
      // L (1 - z/focus) + z x across the axis at depth z in (0, far], so it meets the sphere only if
      // x lies beyond (q - r - |L| m) / far on a side the sphere and the lens leave clear along an
      // axis (m: the most |1 - z/focus| reaches), anywhere otherwise.
      constexpr double inf = std::numeric_limits<double>::infinity();
      const double most = std::max(1.0, std::fabs(1 - far / static_cast<double>(m_focus)));
      const double slack = eps * (1 + window + lensSlope());
      const auto range = [&](double across, double lens, double& lo, double& hi) {
        const double low = across - (reach + origin) - lens * most, high = across + (reach + origin) + lens * most;
        lo = low > 0 ? low / far - slack : -inf;
        hi = high < 0 ? high / far + slack : inf;
      };
      double x0, x1, y0, y1;
      range(q.x, lensReachX(), x0, x1);
      range(q.y, lensReachY(), y0, y1);
      box = {image.sampleX(x0) - m, image.sampleX(x1) + m, image.sampleY(y1) - m, image.sampleY(y0) + m};
    }
    // Every lens ray leaves the lens's plane (to its rounding) with t at least the depth it reaches.
    tLow = std::max(tLow - lensReach(), near) - origin;
  }
  if (disk) {  // seenRange's widening of the angles, as a radius
    const double widening = kAngleWidening * eps * distance;
    *disk = perspectiveDisk(image, q, distance, reach + widening, radius - (reach - radius) - widening);
  }
  return true;
}

template <typename Real>
double Camera<Real>::lensShift(double near, double far) const {
  const double focus = static_cast<double>(m_focus);
  if (!m_perspective) return std::max(std::fabs(1 - near / focus), std::fabs(1 - far / focus));
  if (!(near > 0)) return std::numeric_limits<double>::infinity();
  return std::max(std::fabs(1 / near - 1 / focus), std::fabs(1 / far - 1 / focus));
}

template <typename Real>
double Camera<Real>::lensBlur(const Vec3d& center, double radius) const {
  if (!hasLens()) return 0;
  const ParallelProjection image = projection();
  const double depth = image.inFrame(center).z;
  // Wholly behind the lens's plane, no ray meets it; across it, its footprint is unbounded on a side
  // through a lens as through the pinhole (Camera::footprint): the lens adds nothing to count.
  if (m_perspective && !(depth - radius > 0)) return 0;
  return lensReach() * lensShift(depth - radius, depth + radius) / std::min(image.pixelWidth, image.pixelHeight);
}

template class Camera<float>;
template class Camera<double>;

}  // namespace durer
