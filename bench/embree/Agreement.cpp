#include "Agreement.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace bench {

namespace {
bool lit(const Image& image, size_t pixel) { return !image.lit.empty() && image.lit[pixel]; }
}  // namespace

bool Agreement::passed() const {
  const auto share = [&](int64_t count) { return static_cast<double>(count) / static_cast<double>(pixels); };
  return share(hitMismatches + depthMismatches) <= kMaxDisagreeing && share(litMismatches) <= kMaxLitDisagreeing;
}

Agreement compare(const Image& embree, const Image& durer) {
  Agreement a;
  a.pixels = static_cast<int64_t>(embree.depth.size());
  std::vector<double> differences;
  for (size_t i = 0; i < embree.depth.size(); ++i) {
    const bool embreeHit = std::isfinite(embree.depth[i]), durerHit = std::isfinite(durer.depth[i]);
    if (embreeHit != durerHit) ++a.hitMismatches;
    if (lit(embree, i) != lit(durer, i)) {
      ++a.litMismatches;
      a.litByEmbreeOnly += lit(embree, i);
    }
    if (!(embreeHit && durerHit)) continue;
    const double t = embree.depth[i];
    differences.push_back(std::abs(static_cast<double>(durer.depth[i]) - t) / std::max(t, 1e-30));
    if (differences.back() > Agreement::kDepthTolerance) ++a.depthMismatches;
  }
  a.bothHit = static_cast<int64_t>(differences.size());
  if (!differences.empty()) {
    auto at = differences.begin() + static_cast<std::ptrdiff_t>(0.999 * static_cast<double>(differences.size() - 1));
    std::nth_element(differences.begin(), at, differences.end());
    a.depthDifference999 = *at;
    a.maxDepthDifference = *std::max_element(at, differences.end());
  }
  return a;
}

}  // namespace bench
