#include "durer/render/Camera.h"

#include <cmath>
#include <limits>
#include <string>

#include "durer/math/Float.h"
#include "durer/scene/Validate.h"

namespace durer {

namespace {
constexpr double kPi = 3.14159265358979323846;
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
  const std::string where = std::string(" with precision='") + limits.precision + "'";
  requireWithin(maxAbs(spec.center), limits.coordinate, "center", where);
  const ImageWindow w = imageWindow(spec, width, height);
  // The farthest sample from the window's centre along each axis (the frame is orthonormal).
  const double x = std::fmax(std::fabs(w.xOffset), std::fabs(w.xOffset + width * w.pixelWidth));
  const double y = std::fmax(std::fabs(w.yOffset), std::fabs(w.yOffset - height * w.pixelHeight));
  // NaN (an aspect whose product with the height overflows) fails as well as a reach beyond the limit.
  const double window = std::isnan(x + y) ? std::numeric_limits<double>::infinity() : x + y;
  const bool perspective = spec.projection == Projection::Perspective;
  requireWithin(perspective ? 1 + window : maxAbs(spec.center) + window, limits.coordinate,
                std::string("the image window (center, ") + (perspective ? "fov_degrees" : "size") +
                    ", shift, pixel_aspect at " + std::to_string(width) + "x" + std::to_string(height) + ")",
                where);
  return perspective ? maxAbs(spec.center) : maxAbs(spec.center) + window;
}

template <typename Real>
Camera<Real>::Camera(const CameraSpec& spec, int width, int height)
    : m_perspective(spec.projection == Projection::Perspective),
      m_tMin(static_cast<Real>(spec.tMin)),
      m_tMax(static_cast<Real>(spec.tMax)) {
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
}

template class Camera<float>;
template class Camera<double>;

}  // namespace durer
