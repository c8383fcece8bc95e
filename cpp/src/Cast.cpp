#include "durer/render/Cast.h"

#include <algorithm>
#include <chrono>
#include <type_traits>

#include "durer/render/Kernels.h"
#include "durer/scene/Validate.h"

namespace durer {

template <typename Real>
CastStats cast(const Scene& scene, const CastInput& input, const CastOutput<Real>& output, JobControl& control,
               const std::function<void()>& poll) {
  requireRange(input.tMin, input.tMax, "t_min", "t_max");
  if (input.threads < 0) fail("threads must be >= 0 (0: all cores), got " + std::to_string(input.threads));
  const auto start = std::chrono::steady_clock::now();
  const CastJob<Real> job{scene, input, output, control, poll};
  CastStats stats;
  if (input.sphereMethod != SphereMethod::Robust) {
    stats = castLecture<Real>(job, input.sphereMethod);
  } else if constexpr (std::is_same_v<Real, float>) {
    stats = kernels().castFloat(job);
  } else {
    stats = kernels().castDouble(job);
  }
  stats.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

template CastStats cast<float>(const Scene&, const CastInput&, const CastOutput<float>&, JobControl&,
                               const std::function<void()>&);
template CastStats cast<double>(const Scene&, const CastInput&, const CastOutput<double>&, JobControl&,
                                const std::function<void()>&);

}  // namespace durer
