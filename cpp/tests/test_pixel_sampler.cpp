// Unit tests of the pixel sampler's Sobol points against the sequence's defining property (doctest).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
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

// Sample s of one pixel on its own: pixelSeeds and offsets of a one-pixel packet.
void offsetOf(const PixelSampler& sampler, uint64_t pixel, int s, double& u, double& v) {
  uint64_t seed = 0;
  sampler.pixelSeeds(&pixel, 1, &seed);
  sampler.offsets(&seed, 1, s, &u, &v);
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

TEST_CASE("a hit's samples: each uniform over the square as keys vary, a net at every power of two") {
  // 16,384 keys into a 4x4 grid: 1,024 a cell, standard deviation 31. Unshuffled, the scrambles'
  // tied coordinates kept point 0 out of the lower-left and upper-right quarters (a few AO or area
  // light samples per hit were biased).
  for (const uint32_t index : {0u, 1u, 2u, 3u, 6u, 1000u}) {
    int cells[4][4] = {};
    for (uint32_t k = 0; k < 16384; ++k) {
      double u, v;
      PixelSampler::hitSample(index, k * 0x9e3779b9u, u, v);
      ++cells[int(u * 4)][int(v * 4)];
    }
    for (const auto& row : cells) {
      for (const int count : row) CHECK_MESSAGE(std::abs(count - 1024) < 160, "index ", index, ", count ", count);
    }
  }
  for (const uint32_t key : {0u, 7u, 0xdeadbeefu}) {
    for (int m = 0; m <= 8; ++m) {
      std::vector<double> u(size_t(1) << m), v(size_t(1) << m);
      for (uint32_t i = 0; i < (1u << m); ++i) PixelSampler::hitSample(i, key, u[i], v[i]);
      CHECK_MESSAGE(isNet(u, v, m), "key ", key, ", m ", m);
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
        offsetOf(sampler, pixel, i, ui, vi);
        REQUIRE(ui == u[i]);
        REQUIRE(vi == v[i]);
      }
    }
  }
}

TEST_CASE("exactDouble53 converts every integer below 2^53 as static_cast does") {
  const uint64_t top = (uint64_t(1) << 53) - 1;
  for (const uint64_t x : {uint64_t(0), uint64_t(1), uint64_t(0x3ffffff), uint64_t(0x4000000), uint64_t(1) << 52,
                           (uint64_t(1) << 52) - 1, (uint64_t(1) << 52) + 1, top, top - 1}) {
    REQUIRE(exactDouble53(x) == static_cast<double>(x));
  }
  uint64_t state = 12345;
  for (int i = 0; i < 100000; ++i) {
    state = mixBits(state + 0x9e3779b97f4a7c15ull);
    const uint64_t x = state >> 11;
    REQUIRE(exactDouble53(x) == static_cast<double>(x));
  }
}

// offsets() for a packet against each pixel on its own (offsetOf: the vectorised loop against
// the one-ray one), and the strata they fall in.
TEST_CASE("a packet's offsets are each pixel's offset, for every sampler") {
  const SamplerKind kinds[] = {SamplerKind::Center, SamplerKind::Random, SamplerKind::Stratified, SamplerKind::Sobol,
                               SamplerKind::Adaptive};
  for (const SamplerKind kind : kinds) {
    for (const int spp : {1, 2, 6, 7, 64}) {
      const PixelSampler sampler(kind, spp, 99);
      std::vector<uint64_t> pixels, seeds(61);
      for (uint64_t p = 0; p < 61; ++p) pixels.push_back(p * p * 7919 + (uint64_t(1) << (p % 41)));
      sampler.pixelSeeds(pixels.data(), 61, seeds.data());
      for (int s = 0; s < spp; ++s) {
        std::vector<double> u(61), v(61);
        sampler.offsets(seeds.data(), 61, s, u.data(), v.data());
        for (size_t j = 0; j < pixels.size(); ++j) {
          double ui, vi;
          offsetOf(sampler, pixels[j], s, ui, vi);
          REQUIRE(ui == u[j]);
          REQUIRE(vi == v[j]);
          REQUIRE((u[j] >= 0 && u[j] < 1 && v[j] >= 0 && v[j] < 1));
          if (kind == SamplerKind::Stratified) {  // sample s in its stratum: column s % nx, row s / nx
            const int nx = spp == 6 ? 2 : spp == 64 ? 8 : 1, ny = spp / nx;
            REQUIRE(int(u[j] * nx) == s % nx);
            REQUIRE(int(v[j] * ny) == s / nx);
          }
        }
      }
    }
  }
}
