#include "durer/scene/Validate.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "durer/math/Float.h"
#include "durer/scene/Limits.h"

namespace durer {

namespace {
bool isFinite(const Vec3d& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
}  // namespace

std::string show(double value) {
  std::ostringstream s;
  s << value;
  return s.str();
}

std::string show(const Vec3d& value) {
  std::ostringstream s;
  s << "(" << value.x << ", " << value.y << ", " << value.z << ")";
  return s.str();
}

void fail(const std::string& message) { throw std::invalid_argument(message); }

void requireFinite(double value, const std::string& field) {
  if (!std::isfinite(value)) fail(field + " must be finite, got " + show(value));
}

void requireFinite(const Vec3d& value, const std::string& field) {
  if (!isFinite(value)) fail(field + " must be finite, got " + show(value));
}

void requirePositive(double value, const std::string& field) {
  if (!(std::isfinite(value) && value > 0)) fail(field + " must be finite and > 0, got " + show(value));
}

void requireNonZero(const Vec3d& value, const std::string& field) {
  requireFinite(value, field);
  // Tested on the largest |component|: the squared length can underflow to 0 (or overflow) for a
  // usable vector.
  if (maxAbs(value) == 0) fail(field + " must not be the zero vector");
}

void requireNonNegativeColor(const Vec3d& value, const std::string& field) {
  requireFinite(value, field);
  if (value.x < 0 || value.y < 0 || value.z < 0) fail(field + " must be >= 0 in each channel, got " + show(value));
  requireColorWithin(maxAbs(value), field, show(value));
}

void requireColorWithin(double largest, const std::string& field, const std::string& shown) {
  const double limit = widestLimits().color;
  if (largest <= limit) return;
  std::ostringstream message;
  message << field << " must be <= " << limit << (shown.empty() || shown[0] != '(' ? "" : " in each channel")
          << ", got " << shown;
  fail(message.str());
}

void requireWithin(double magnitude, double limit, const std::string& field, const std::string& where) {
  if (magnitude <= limit) return;
  std::ostringstream message;
  message << field << " must lie within ±" << limit << where << ", got " << magnitude;
  fail(message.str());
}

std::string withPrecision(const char* precision) { return std::string(" with precision='") + precision + "'"; }

void requireRange(double tMin, double tMax, const std::string& minField, const std::string& maxField) {
  if (std::isnan(tMin)) fail(minField + " must not be NaN");
  if (std::isnan(tMax)) fail(maxField + " must not be NaN");
  if (!(tMin < tMax)) fail(minField + " must be < " + maxField + ", got " + show(tMin) + " and " + show(tMax));
}

}  // namespace durer
