#pragma once
// Checks that turn bad input into std::invalid_argument naming the field (ValueError in Python),
// so that nothing downstream sees NaN, a zero vector or an empty range.
#include <string>

#include "durer/math/Vec.h"

namespace durer {

// A number or a vector as an error message shows it: 6 significant digits, 1e-09 not 0.000000.
std::string show(double value);
std::string show(const Vec3d& value);
void requireFinite(double value, const std::string& field);
void requireFinite(const Vec3d& value, const std::string& field);
void requirePositive(double value, const std::string& field);  // finite and > 0
void requireNonZero(const Vec3d& value, const std::string& field);  // finite and of non-zero length
void requireNonNegativeColor(const Vec3d& value, const std::string& field);  // finite, each in [0, color limit]
// largest (a colour's largest channel, or a scalar) <= the colour limit (Limits.h); `shown`: the value as given.
void requireColorWithin(double largest, const std::string& field, const std::string& shown);
// |every component| <= limit (finite): else "<field> must lie within ±limit<where>, got <value>".
void requireWithin(double magnitude, double limit, const std::string& field, const std::string& where = "");
// " with precision='<precision>'": requireWithin's `where` for a precision's limits (Limits.h).
std::string withPrecision(const char* precision);
void requireRange(double tMin, double tMax, const std::string& minField, const std::string& maxField);
[[noreturn]] void fail(const std::string& message);

}  // namespace durer
