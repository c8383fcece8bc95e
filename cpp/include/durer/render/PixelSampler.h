#pragma once
#include <cstdint>

#include "durer/Options.h"
#include "durer/math/Float.h"

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

  int samplesPerPixel() const { return m_spp; }
  // Whether every sample sits at its pixel's centre; pixelSeeds() and offsets() then skip the
  // per-pixel hash, which at ~10 ns a primary ray would cost as much as the tracing.
  bool centred() const { return m_kind == SamplerKind::Center || (m_kind == SamplerKind::Stratified && m_spp == 1); }

  // The lens samples (Camera::generate's) of samples index[j] of the pixels with linear indices
  // pixel[j], j < count, whatever the sampler (a centred one's too: the pixel's centre seen through
  // the whole lens): Owen-scrambled Sobol points of their own, in an order shuffled by a key of their
  // own, so that a pixel's lens points are a net at every power of two and paired with its positions
  // at random (Burley 2020's padding: where a sample lies in the pixel says nothing of where it
  // leaves the lens).
  void lensOffsets(const uint64_t* pixel, const uint32_t* index, int count, double* u, double* v) const {
    for (int j = 0; j < count; ++j) {
      const uint64_t key = mixBits(pixelSeed(pixel[j]) ^ 0x6a09e667f3bcc909ull);
      sobolPoint(index[j], static_cast<uint32_t>(key), static_cast<uint32_t>(key >> 32), u[j], v[j]);
    }
  }

  // The seeds of pixels with linear indices pixel[j], j < count, for offsets(): a pixel's hash,
  // made once for all its samples. A centred sampler's offsets read none: left as they are.
  void pixelSeeds(const uint64_t* pixel, int count, uint64_t* seed) const {
    if (centred()) return;
    for (int j = 0; j < count; ++j) seed[j] = pixelSeed(pixel[j]);
  }
  // Offsets in [0, 1)^2 of sample s of the pixels whose pixelSeeds are seed[j], j < count: one
  // packet's positions in one loop the compiler vectorises (a scalar hash per ray cost ~15 % of an
  // anti-aliased render).
  void offsets(const uint64_t* seed, int count, int s, double* u, double* v) const;

  // The Sobol samplers' two scrambling seeds of the pixel with linear index `pixel` (sample order,
  // then the points'): sobolOffsets of them gives each index the point offsets() does.
  void sobolSeeds(uint64_t pixel, uint32_t& order, uint32_t& points) const {
    const uint64_t seed = pixelSeed(pixel);
    order = static_cast<uint32_t>(seed), points = static_cast<uint32_t>(seed >> 32);
  }
  // Offsets of samples indices[j] of the pixels whose sobolSeeds are order[j], points[j], for j <
  // count: samples of several pixels in one loop that the compiler vectorises.
  static void sobolOffsets(const uint32_t* order, const uint32_t* points, const uint32_t* indices, int count,
                           double* u, double* v);

  // Point `index` in [0, 1)^2 of the 2-D Sobol sequence, Owen-scrambled by `seed`: indices 0 to
  // 2^k - 1 are stratified in every dyadic box of 2^k cells. The two coordinates' scrambles are tied
  // (seeds a constant apart: a scramble's bit k depends on the seed's bits up to k), so a point is
  // uniform over the square only at a random index — point 0 never falls in the lower-left or
  // upper-right quarter: callers shuffle the index (sobolPoint, hitSample).
  static void scrambledSobol(uint32_t index, uint32_t seed, double& u, double& v);

  // Point `index` of a hit's own samples (ambient occlusion directions, area light points), keyed by
  // `key`: a net at every power of two like a pixel's Sobol samples, shuffled as theirs are, so each
  // point is uniform over the square as keys vary and few samples are noisy, never biased.
  static void hitSample(uint32_t index, uint32_t key, double& u, double& v) {
    sobolPoint(index, static_cast<uint32_t>(mixBits(key ^ 0x2545f491u)), key, u, v);
  }

 private:
  // Sample `index` of the pixel whose sobolSeeds are `order` and `points`.
  static void sobolPoint(uint32_t index, uint32_t order, uint32_t points, double& u, double& v) {
    scrambledSobol(nestedUniformScramble(index, order), points, u, v);
  }
  static uint32_t reverseBits(uint32_t x);
  static uint32_t reversedSobolSecondDimension(uint32_t index);
  static uint32_t laineKarras(uint32_t x, uint32_t seed);
  static uint32_t nestedUniformScramble(uint32_t x, uint32_t seed);
  uint64_t pixelSeed(uint64_t pixel) const { return mixBits(m_seed + pixel * 0x2545f4914f6cdd1dull); }

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
  x = __builtin_bswap32(x);  // one instruction (a byte shuffle when vectorised) for the first two steps
  x = ((x & 0x0f0f0f0fu) << 4) | ((x & 0xf0f0f0f0u) >> 4);
  x = ((x & 0x33333333u) << 2) | ((x & 0xccccccccu) >> 2);
  x = ((x & 0x55555555u) << 1) | ((x & 0xaaaaaaaau) >> 1);
  return x;
}

// The second Sobol dimension (its generator matrix as in Burley 2020), bit-reversed: the scramble
// reverses it first, and reversal, a permutation of bits, commutes with XOR. The matrix product over
// GF(2) is a XOR of one column per set index bit; index bit k's column, reversed, is (1 + x)^k:
// bit i set where C(k, i) is odd, that is where i's bits are among k's (Lucas). So output bit i is
// the parity of the index bits k whose bits hold i's: a sum over supersets, five shifted XORs (no
// table to look up, so a loop over points vectorises without gathers).
inline uint32_t PixelSampler::reversedSobolSecondDimension(uint32_t index) {
  uint32_t x = index;
  x ^= (x & 0xaaaaaaaau) >> 1;  // bit k into bit k - 1 for the k with bit 0 set
  x ^= (x & 0xccccccccu) >> 2;  // ... with bit 1 set, and so on over the five bits of a position
  x ^= (x & 0xf0f0f0f0u) >> 4;
  x ^= (x & 0xff00ff00u) >> 8;
  x ^= (x & 0xffff0000u) >> 16;
  return x;
}

// Owen scrambling by hashing (Burley 2020): Laine & Karras's permutation, which scrambles each bit by
// the bits below it, applied to the reversed bits (each bit by the bits above it).
inline uint32_t PixelSampler::nestedUniformScramble(uint32_t x, uint32_t seed) {
  return reverseBits(laineKarras(reverseBits(x), seed));
}

inline uint32_t PixelSampler::laineKarras(uint32_t x, uint32_t seed) {
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}

inline void PixelSampler::scrambledSobol(uint32_t index, uint32_t seed, double& u, double& v) {
  constexpr double k32 = 1.0 / 4294967296.0;  // 2^-32
  u = reverseBits(laineKarras(index, seed)) * k32;  // nestedUniformScramble(reverseBits(index), seed)
  // nestedUniformScramble of the second dimension, its first reversal made by reversedSobolSecondDimension.
  v = reverseBits(laineKarras(reversedSobolSecondDimension(index), seed ^ 0x5bd1e995u)) * k32;
}

inline void PixelSampler::offsets(const uint64_t* seed, int count, int s, double* u, double* v) const {
  constexpr double k53 = 1.0 / 9007199254740992.0;  // 2^-53: 53 random bits -> [0, 1)
  if (centred()) {  // Center, and Stratified with one stratum: no hash
    for (int j = 0; j < count; ++j) u[j] = v[j] = 0.5;
    return;
  }
  if (m_kind == SamplerKind::Sobol || m_kind == SamplerKind::Adaptive) {
    const auto index = static_cast<uint32_t>(s);
    for (int j = 0; j < count; ++j) {
      sobolPoint(index, static_cast<uint32_t>(seed[j]), static_cast<uint32_t>(seed[j] >> 32), u[j], v[j]);
    }
    return;
  }
  // Random, or Stratified with several strata: sample s's stratum, then a jitter from two hashes.
  const bool stratified = m_kind == SamplerKind::Stratified;
  const double columns = stratified ? m_nx : 1, rows = stratified ? m_ny : 1;
  const double column = stratified ? s % m_nx : 0, row = stratified ? s / m_nx : 0;
  for (int j = 0; j < count; ++j) {
    const uint64_t key = mixBits(seed[j] + static_cast<uint64_t>(s));
    const uint64_t other = mixBits(key + 0x9e3779b97f4a7c15ull);
    u[j] = (column + exactDouble53(key >> 11) * k53) / columns;
    v[j] = (row + exactDouble53(other >> 11) * k53) / rows;
  }
}

inline void PixelSampler::sobolOffsets(const uint32_t* order, const uint32_t* points, const uint32_t* indices,
                                       int count, double* u, double* v) {
  // Each pixel's samples in a shuffled order (still stratified by powers of two): adaptive sampling
  // stops at any count.
  for (int j = 0; j < count; ++j) sobolPoint(indices[j], order[j], points[j], u[j], v[j]);
}

}  // namespace durer
