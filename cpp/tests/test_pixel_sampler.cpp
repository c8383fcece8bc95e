// Unit tests of the pixel sampler's Sobol points against the sequence's defining property (doctest).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "durer/render/PixelSampler.h"

using namespace durer;

namespace {

// Whether points 0 .. 2^m - 1 form a (0,m,2)-net: for every a + b = m, each of the 2^a x 2^b
// elementary boxes of [0, 1)^2 holds exactly one of them. A wrong generator matrix for either
// dimension breaks it at some m (Owen scrambling keeps it, as it must).
bool isNet(const std::vector<double>& u, const std::vector<double>& v, int m) {
  for (int a = 0; a <= m; ++a) {
    const int b = m - a;
    std::vector<int> count(size_t(1) << m, 0);
    for (size_t i = 0; i < u.size(); ++i) {
      const auto col = static_cast<size_t>(std::floor(u[i] * double(1 << a)));
      const auto row = static_cast<size_t>(std::floor(v[i] * double(1 << b)));
      if (++count[(row << a) + col] > 1) return false;
    }
  }
  return true;
}

}  // namespace

TEST_CASE("Owen-scrambled Sobol points: every power-of-two prefix is a (0,m,2)-net, for any seed") {
  for (const uint32_t seed : {0u, 1u, 0x9e3779b9u, 0xdeadbeefu}) {
    for (int m = 0; m <= 10; ++m) {
      std::vector<double> u(size_t(1) << m), v(size_t(1) << m);
      for (uint32_t i = 0; i < (1u << m); ++i) PixelSampler::scrambledSobol(i, seed, u[i], v[i]);
      CHECK_MESSAGE(isNet(u, v, m), "seed ", seed, ", m ", m);
    }
  }
}

TEST_CASE("a pixel's Sobol offsets: its samples in shuffled order, still a net at every power of two") {
  const PixelSampler sampler(SamplerKind::Sobol, 1024, 7);
  for (const uint64_t pixel : {uint64_t(0), uint64_t(12345), uint64_t(1) << 40}) {
    uint32_t order, points;
    sampler.sobolSeeds(pixel, order, points);
    for (int m = 0; m <= 10; ++m) {
      const int n = 1 << m;
      std::vector<uint32_t> orders(n, order), pointSeeds(n, points), indices(n);
      for (int i = 0; i < n; ++i) indices[i] = uint32_t(i);
      std::vector<double> u(n), v(n);
      PixelSampler::sobolOffsets(orders.data(), pointSeeds.data(), indices.data(), n, u.data(), v.data());
      CHECK_MESSAGE(isNet(u, v, m), "pixel ", pixel, ", m ", m);
      for (int i = 0; i < n; ++i) {
        double ui, vi;
        sampler.offset(pixel, i, ui, vi);
        REQUIRE(ui == u[i]);
        REQUIRE(vi == v[i]);
      }
    }
  }
}
