#pragma once
#include <cstdint>

#include "durer/Options.h"

namespace durer {

// Where a pixel's samples go. Every position is a pure function of (seed, pixel, sample index): an
// image depends on the seed only, never on threads or tiling.
// SplitMix64's finaliser: a bijective 64-bit mix with full avalanche.
inline uint64_t mixBits(uint64_t x) {
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ull;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

class PixelSampler {
 public:
  PixelSampler(SamplerKind kind, int samplesPerPixel, uint64_t seed);

  SamplerKind kind() const { return m_kind; }
  int samplesPerPixel() const { return m_spp; }
  // Whether every sample sits at its pixel's centre; offset() then skips the per-pixel hash, which
  // at ~10 ns a primary ray would cost as much as the tracing.
  bool centred() const { return m_kind == SamplerKind::Center || (m_kind == SamplerKind::Stratified && m_spp == 1); }

  // Offset in [0, 1)^2 of sample s of the pixel with linear index `pixel`.
  void offset(uint64_t pixel, int s, double& u, double& v) const;

  // Point `index` in [0, 1)^2 of the 2-D Sobol sequence, Owen-scrambled by `seed`: indices 0 to
  // 2^k - 1 are stratified in every dyadic box of 2^k cells.
  static void scrambledSobol(uint32_t index, uint32_t seed, double& u, double& v);

 private:
  static uint32_t reverseBits(uint32_t x);
  static uint32_t sobolSecondDimension(uint32_t index);
  static uint32_t nestedUniformScramble(uint32_t x, uint32_t seed);

  SamplerKind m_kind;
  int m_spp;
  int m_nx;  // stratified: strata across (the largest divisor of spp not above its square root)
  int m_ny;  // stratified: strata down, spp / nx (primes give strips)
  uint64_t m_seed;
};

inline PixelSampler::PixelSampler(SamplerKind kind, int samplesPerPixel, uint64_t seed)
    : m_kind(kind), m_spp(samplesPerPixel), m_nx(1), m_ny(samplesPerPixel), m_seed(mixBits(seed ^ 0x9e3779b97f4a7c15ull)) {
  for (int nx = 1; nx * nx <= samplesPerPixel; ++nx) {
    if (samplesPerPixel % nx == 0) m_nx = nx;
  }
  m_ny = samplesPerPixel / m_nx;
}

inline uint32_t PixelSampler::reverseBits(uint32_t x) {
  x = (x << 16) | (x >> 16);
  x = ((x & 0x00ff00ffu) << 8) | ((x & 0xff00ff00u) >> 8);
  x = ((x & 0x0f0f0f0fu) << 4) | ((x & 0xf0f0f0f0u) >> 4);
  x = ((x & 0x33333333u) << 2) | ((x & 0xccccccccu) >> 2);
  x = ((x & 0x55555555u) << 1) | ((x & 0xaaaaaaaau) >> 1);
  return x;
}

// The second Sobol dimension (its generator matrix as in Burley 2020); the first is reverseBits.
inline uint32_t PixelSampler::sobolSecondDimension(uint32_t index) {
  uint32_t result = 0;
  for (uint32_t v = 1u << 31; index; index >>= 1, v ^= v >> 1) {
    if (index & 1u) result ^= v;
  }
  return result;
}

// Owen scrambling by hashing (Laine & Karras's permutation on the reversed bits, Burley 2020).
inline uint32_t PixelSampler::nestedUniformScramble(uint32_t x, uint32_t seed) {
  x = reverseBits(x);
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return reverseBits(x);
}

inline void PixelSampler::scrambledSobol(uint32_t index, uint32_t seed, double& u, double& v) {
  constexpr double k32 = 1.0 / 4294967296.0;  // 2^-32
  u = nestedUniformScramble(reverseBits(index), seed) * k32;
  v = nestedUniformScramble(sobolSecondDimension(index), seed ^ 0x5bd1e995u) * k32;
}

inline void PixelSampler::offset(uint64_t pixel, int s, double& u, double& v) const {
  constexpr double k53 = 1.0 / 9007199254740992.0;  // 2^-53: 53 random bits -> [0, 1)
  if (centred()) {  // Center, and Stratified with one stratum: no hash
    u = v = 0.5;
    return;
  }
  const uint64_t pixelSeed = mixBits(m_seed + pixel * 0x2545f4914f6cdd1dull);
  if (m_kind == SamplerKind::Sobol || m_kind == SamplerKind::Adaptive) {
    // Samples in a shuffled order (still stratified by powers of two): adaptive stops at any count.
    const uint32_t index = nestedUniformScramble(static_cast<uint32_t>(s), static_cast<uint32_t>(pixelSeed));
    scrambledSobol(index, static_cast<uint32_t>(pixelSeed >> 32), u, v);
    return;
  }
  // Random, or Stratified with several strata.
  const uint64_t key = mixBits(pixelSeed + static_cast<uint64_t>(s));
  const uint64_t other = mixBits(key + 0x9e3779b97f4a7c15ull);
  const double ju = static_cast<double>(key >> 11) * k53, jv = static_cast<double>(other >> 11) * k53;
  if (m_kind == SamplerKind::Random) {
    u = ju, v = jv;
  } else {
    u = (s % m_nx + ju) / m_nx;
    v = (s / m_nx + jv) / m_ny;
  }
}

}  // namespace durer
