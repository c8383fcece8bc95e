#include "durer/render/Cast.h"

#include <chrono>
#include <limits>
#include <sstream>
#include <cmath>
#include <string>
#include <type_traits>

#include "durer/render/Kernels.h"
#include "durer/scene/Validate.h"

namespace durer {

namespace {
// The largest |coordinate| of the rays' origins. An origin beyond the limits, or a direction whose
// largest component is not a normal number of the precision (it would round to 0 or inf, or has no
// exact power-of-two scale), is an error naming it; non-finite and zero rays (cast with check=False)
// are left to miss.
template <typename Real>
double requireCastRaysWithin(const CastInput& input, const NumericLimits& limits) {
  const std::string where = withPrecision(limits.precision);
  double reach = 0;
  for (size_t i = 0; i < input.count; ++i) {
    const Vec3d o(input.origins[3 * i], input.origins[3 * i + 1], input.origins[3 * i + 2]);
    const Vec3d d(input.directions[3 * i], input.directions[3 * i + 1], input.directions[3 * i + 2]);
    const double length = maxAbs(d), extent = maxAbs(o);
    if (!std::isfinite(extent + length) || length == 0) continue;
    requireWithin(extent, limits.coordinate, "origins[" + std::to_string(i) + "]", where);
    if (!(length >= std::numeric_limits<Real>::min() && length <= std::numeric_limits<Real>::max())) {
      std::ostringstream message;
      message << "directions[" << i << "] must have its largest |component| in [" << std::numeric_limits<Real>::min()
              << ", " << std::numeric_limits<Real>::max() << "]" << where << ", got " << length;
      fail(message.str());
    }
    reach = std::fmax(reach, extent);
  }
  return reach;
}
}  // namespace

template <typename Real>
CastStats cast(const Scene& scene, const CastInput& input, const CastOutput<Real>& output, JobControl& control,
               const std::function<void()>& poll) {
  requireRange(input.tMin, input.tMax, "t_min", "t_max");
  if (input.threads < 0) fail("threads must be >= 0 (0: all cores), got " + std::to_string(input.threads));
  const NumericLimits& limits = limitsFor(std::is_same_v<Real, float> ? Precision::Float : Precision::Double);
  scene.requireFits(limits, requireCastRaysWithin<Real>(input, limits));
  const auto start = std::chrono::steady_clock::now();
  const CastJob<Real> job{scene, input, output, control, poll};
  CastStats stats;
  const KernelSet& set = kernelsFor(input.sphereMethod);
  if constexpr (std::is_same_v<Real, float>) {
    stats = set.castFloat(job);
  } else {
    stats = set.castDouble(job);
  }
  stats.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

template CastStats cast<float>(const Scene&, const CastInput&, const CastOutput<float>&, JobControl&,
                               const std::function<void()>&);
template CastStats cast<double>(const Scene&, const CastInput&, const CastOutput<double>&, JobControl&,
                                const std::function<void()>&);

}  // namespace durer
