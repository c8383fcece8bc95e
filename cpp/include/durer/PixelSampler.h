#pragma once
#include <cstdint>

namespace durer {

// Jittered stratified samples within a pixel: spp = nx * ny strata (nx the largest divisor of spp
// not above its square root, so every spp is stratified, primes into strips), one uniform point per
// stratum. One sample is the pixel centre. The jitter is a hash of (seed, pixel, sample): the image
// depends on the seed only, never on threads or tiling.
class PixelSampler {
 public:
  PixelSampler(int samplesPerPixel, uint64_t seed);

  int samplesPerPixel() const { return m_spp; }

  // Offset in [0, 1)^2 of sample s of the pixel with linear index `pixel`.
  void offset(uint64_t pixel, int s, double& u, double& v) const;

 private:
  int m_spp;
  int m_nx;
  int m_ny;
  uint64_t m_seed;
};

// SplitMix64's finaliser: a bijective 64-bit mix with full avalanche.
inline uint64_t mixBits(uint64_t x) {
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ull;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

inline PixelSampler::PixelSampler(int samplesPerPixel, uint64_t seed)
    : m_spp(samplesPerPixel), m_nx(1), m_ny(samplesPerPixel), m_seed(seed) {
  for (int nx = 1; nx * nx <= samplesPerPixel; ++nx) {
    if (samplesPerPixel % nx == 0) m_nx = nx;
  }
  m_ny = samplesPerPixel / m_nx;
}

inline void PixelSampler::offset(uint64_t pixel, int s, double& u, double& v) const {
  if (m_spp == 1) {
    u = v = 0.5;
    return;
  }
  const uint64_t key = mixBits(mixBits(m_seed ^ 0x9e3779b97f4a7c15ull) + pixel * 0x2545f4914f6cdd1dull +
                               static_cast<uint64_t>(s));
  const uint64_t other = mixBits(key + 0x9e3779b97f4a7c15ull);
  constexpr double kUnit = 1.0 / 9007199254740992.0;  // 2^-53: 53 random bits -> [0, 1)
  const double ju = static_cast<double>(key >> 11) * kUnit;
  const double jv = static_cast<double>(other >> 11) * kUnit;
  u = (s % m_nx + ju) / m_nx;
  v = (s / m_nx + jv) / m_ny;
}

}  // namespace durer
