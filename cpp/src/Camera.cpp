#include "durer/render/Camera.h"

#include <cmath>

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

template <typename Real>
Camera<Real>::Camera(const CameraSpec& spec, int width, int height)
    : m_perspective(spec.projection == Projection::Perspective),
      m_tMin(static_cast<Real>(spec.tMin)),
      m_tMax(static_cast<Real>(spec.tMax)) {
  const Vec3d forward = safeNormalize(spec.direction);
  const Vec3d horizontal = glm::normalize(glm::cross(forward, safeNormalize(spec.up)));
  const Vec3d up = glm::cross(horizontal, forward);
  const double extent = m_perspective ? 2 * std::tan(spec.size * kPi / 360) : spec.size;
  // The fitted dimension's span in pixel widths: a row is `width` of them, a column height·aspect.
  const double tall = height * spec.pixelAspect;
  const double span = spec.fit == Fit::Horizontal ? width
                      : spec.fit == Fit::Vertical ? tall
                                                  : std::max<double>(width, tall);
  const double pixelSize = extent / span;
  m_center = toReal<Real>(spec.center);
  m_forward = toReal<Real>(forward);
  m_horizontal = toReal<Real>(horizontal);
  m_up = toReal<Real>(up);
  m_pixelWidth = static_cast<Real>(pixelSize);
  m_pixelHeight = static_cast<Real>(pixelSize * spec.pixelAspect);
  m_xOffset = static_cast<Real>(-0.5 * width * pixelSize + spec.shiftX * extent);
  m_yOffset = static_cast<Real>(0.5 * tall * pixelSize + spec.shiftY * extent);
}

template class Camera<float>;
template class Camera<double>;

}  // namespace durer
