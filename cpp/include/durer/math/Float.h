#pragma once
// Floating-point helpers in one place (pbrt-v4's util/float.h): rounding-error bounds, outward
// rounding, exact error terms, power-of-two scaling, precision conversion and overflow-safe
// normalisation. Every routine is a template over Real (float or double).
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "durer/Inline.h"
#include "durer/math/Vec.h"
#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace durer {

constexpr double kPi = 3.14159265358979323846;

// gamma(n) = n·u / (1 - n·u), u the unit roundoff: bounds the relative error of n chained roundings
// (Higham; pbrt-v4 uses the same bound).
template <typename Real>
constexpr Real errorGamma(int n) {
  constexpr Real u = std::numeric_limits<Real>::epsilon() / 2;
  return n * u / (1 - n * u);
}

// t moved away from zero, or toward it, by the relative amount `factor` (> 0, small): a range
// [widenDown(a), widenUp(b)] holds [a, b] widened by that much; inf stays inf, and no NaN is made.
template <typename Real>
DURER_INLINE Real widenDown(Real t, Real factor) {
  return t * (t > 0 ? 1 - factor : 1 + factor);
}
template <typename Real>
DURER_INLINE Real widenUp(Real t, Real factor) {
  return t * (t > 0 ? 1 + factor : 1 - factor);
}


template <typename Real, typename Other>
Vec3<Real> toReal(const Vec3<Other>& v) {
  return Vec3<Real>(static_cast<Real>(v.x), static_cast<Real>(v.y), static_cast<Real>(v.z));
}

// |v| component by component, by std::fabs: glm::abs is x >= 0 ? x : -x, a compare and a branch
// per component, which mispredicts where the signs vary (a hit point's, for its error bound).
template <typename Real>
DURER_INLINE Vec3<Real> absolute(const Vec3<Real>& v) {
  return Vec3<Real>(std::fabs(v.x), std::fabs(v.y), std::fabs(v.z));
}

template <typename Real>
struct FloatBits;
template <>
struct FloatBits<double> {
  using Bits = uint64_t;
  using SignedBits = int64_t;
  static constexpr int kMantissaBits = 52;
  static constexpr int kBias = 1023;
};
template <>
struct FloatBits<float> {
  using Bits = uint32_t;
  using SignedBits = int32_t;
  static constexpr int kMantissaBits = 23;
  static constexpr int kBias = 127;
};

// The bits of x >= +0 (not NaN) as a signed integer, and back: for such numbers the integers order
// as the values do, so a loop of integer minima and maxima over them vectorises where one over the
// values stays a serial chain (GCC keeps a floating-point min in order under -ftrapping-math).
template <typename Real>
DURER_INLINE typename FloatBits<Real>::SignedBits nonNegativeBits(Real x) {
  typename FloatBits<Real>::SignedBits bits;
  std::memcpy(&bits, &x, sizeof x);
  return bits;
}
template <typename Real>
DURER_INLINE Real fromNonNegativeBits(typename FloatBits<Real>::SignedBits bits) {
  Real x;
  std::memcpy(&x, &bits, sizeof x);
  return x;
}

// The bits of any x but NaN as a signed integer that orders as the values do (-0 just below +0):
// a negative number's magnitude bits flipped (for x >= +0, nonNegativeBits). The flip is its own
// inverse: fromOrderedBits makes it again.
template <typename Signed>
DURER_INLINE Signed flipNegativeMagnitude(Signed bits) {
  return bits ^ ((bits >> (8 * sizeof(Signed) - 1)) & std::numeric_limits<Signed>::max());
}
template <typename Real>
DURER_INLINE typename FloatBits<Real>::SignedBits orderedBits(Real x) {
  return flipNegativeMagnitude(nonNegativeBits(x));
}
template <typename Real>
DURER_INLINE Real fromOrderedBits(typename FloatBits<Real>::SignedBits bits) {
  return fromNonNegativeBits<Real>(flipNegativeMagnitude(bits));
}

// std::max(Real(0), x) for x not NaN (-0 gives +0), from the bits: a loop of them vectorises where
// GCC leaves the compare and select as a branch per element (under -ftrapping-math).
template <typename Real>
DURER_INLINE Real positivePart(Real x) {
  const auto bits = nonNegativeBits(x);
  return fromNonNegativeBits<Real>(bits & ~(bits >> (8 * sizeof(Real) - 1)));
}

// The next Real above (nextUp) or below (nextDown) x, as std::nextafter toward ±inf but inline
// from the bits (pbrt-v4's NextFloatUp/Down): ±inf and NaN stay, -0 and +0 step to the least subnormal.
template <typename Real>
DURER_INLINE Real nextUp(Real x) {
  using Bits = typename FloatBits<Real>::Bits;
  if (!(x == x) || (std::isinf(x) && x > 0)) return x;
  if (x == 0) return std::numeric_limits<Real>::denorm_min();
  Bits bits;
  std::memcpy(&bits, &x, sizeof x);
  bits = x > 0 ? bits + 1 : bits - 1;
  std::memcpy(&x, &bits, sizeof x);
  return x;
}
template <typename Real>
DURER_INLINE Real nextDown(Real x) {
  return -nextUp(-x);
}

// nextUp(x) where `toward` > 0, nextDown(x) where it is < 0, x where it is 0 or NaN: the same bits,
// selected without a branch. A ray offset's step direction and its coordinate's sign are coin tosses
// for the branch predictor (offsetRayOrigin: 3.0 % of a secondary-ray render with the branches of
// the two calls, 2.1 % with this); the hierarchy build's steps, always predicted, keep nextUp/nextDown.
template <typename Real>
DURER_INLINE Real nextToward(Real x, Real toward) {
  using Bits = typename FloatBits<Real>::Bits;
  constexpr int kSign = 8 * sizeof(Bits) - 1;
  Bits bits;
  std::memcpy(&bits, &x, sizeof x);
  const Bits up = toward > 0, down = toward < 0, negative = bits >> kSign;
  const Bits away = (up & (negative ^ 1)) | (down & negative);  // the magnitude grows: +1 on the bits
  const Bits inward = (up & negative) | (down & (negative ^ 1));  // it shrinks: -1
  // ±0 steps to the least subnormal of the step's sign; NaN, and an infinity stepped outward, stay.
  const Bits zero = Bits((bits << 1) == 0) & (up | down);
  const Bits stays = Bits(!(x == x)) | (Bits(std::isinf(x)) & away);
  const Bits stepped = bits + away - inward;
  const Bits fromZero = (down << kSign) | 1;
  const Bits keep = Bits(0) - stays, reset = Bits(0) - zero;
  bits = (bits & keep) | (((fromZero & reset) | (stepped & ~reset)) & ~keep);
  std::memcpy(&x, &bits, sizeof x);
  return x;
}

// x converted to Real, rounded down (toward -inf) or up (toward +inf) where the conversion is inexact:
// the converted value then still bounds the given one from that side. As the nearest conversion
// stepped by nextDown / nextUp, but the step is a select on the bits, not a branch: which way a
// conversion rounded is a coin toss, and boxes are converted in loops over millions of primitives.
// (Stepping down is only asked of r > x, so never of -inf or NaN; a -0 from a tiny negative x steps
// to the least negative subnormal; +inf from a huge x to the largest finite Real.)
template <typename Real, typename Other>
DURER_INLINE Real toRealDown(Other x) {
  using Bits = typename FloatBits<Real>::Bits;
  Real r = static_cast<Real>(x);
  Bits bits;
  std::memcpy(&bits, &r, sizeof r);
  bits += static_cast<Other>(r) > x ? (r > 0 ? Bits(-1) : Bits(1)) : Bits(0);
  std::memcpy(&r, &bits, sizeof r);
  return r;
}
template <typename Real, typename Other>
DURER_INLINE Real toRealUp(Other x) {
  return -toRealDown<Real>(-x);  // negation is exact, and rounding to nearest symmetric
}

// The box [lo, hi] rounded outward by one ulp per side: a primitive's box computed in Real
// arithmetic may be a rounding short of the primitive.
template <typename Real>
DURER_INLINE void roundOutward(Vec3<Real>& lo, Vec3<Real>& hi) {
  for (int a = 0; a < 3; ++a) lo[a] = nextDown(lo[a]), hi[a] = nextUp(hi[a]);
}

// 2^-floor(log2 x) for x > 0, built from x's exponent bits (no library call, so it vectorises);
// NaN where x is zero, subnormal, inf or NaN (2^-floor(log2 x) would overflow or x has no exponent).
// For x in the top binade [2^bias, max] it is 2^-bias, a subnormal: multiplying by it is still exact
// where the product is normal, so directions of any finite length scale exactly.
template <typename Real>
DURER_INLINE Real inversePowerOfTwo(Real x) {
  using B = FloatBits<Real>;
  using Bits = typename B::Bits;
  Bits bits;
  std::memcpy(&bits, &x, sizeof x);
  // In Bits throughout: a narrower int between them kept loops over hits' normals scalar.
  constexpr Bits kTop = 2 * B::kBias;  // the largest finite biased exponent
  const Bits exponent = (bits >> B::kMantissaBits) & (kTop + 1);  // biased
  const bool usable = exponent >= 1 && exponent <= kTop;
  const Bits scaleBits = exponent == kTop ? Bits(1) << (B::kMantissaBits - 1) : (kTop - exponent) << B::kMantissaBits;
  Real scale;
  std::memcpy(&scale, &scaleBits, sizeof scale);
  return usable ? scale : std::numeric_limits<Real>::quiet_NaN();
}

// v scaled by a power of two (exact) so that its largest |component| is in [1, 2): no square of it
// under- or overflows, and a unit vector made from it has the bits one made from v has wherever
// that works. `otherwise` (finite, normal) stands in where v is 0 or subnormal, or has an infinite
// or NaN component: no direction to trust.
template <typename Real>
DURER_INLINE Vec3<Real> wellScaled(const Vec3<Real>& v, const Vec3<Real>& otherwise) {
  // The largest magnitude by the magnitudes' bits (nonNegativeBits; a NaN's are the largest, and
  // leave inversePowerOfTwo nothing usable): std::max of doubles stays a branch under
  // -ftrapping-math, which kept loops over hits' normals scalar.
  const auto largest = [](const Vec3<Real>& u) {
    const auto x = nonNegativeBits(std::fabs(u.x)), y = nonNegativeBits(std::fabs(u.y)), z = nonNegativeBits(std::fabs(u.z));
    const auto xy = x < y ? y : x;
    return fromNonNegativeBits<Real>(xy < z ? z : xy);
  };
  const Real power = inversePowerOfTwo(largest(v));
  return power == power ? v * power : otherwise * inversePowerOfTwo(largest(otherwise));
}

// 1 / sqrt(s) for s in [kInverseSqrtLeast, kInverseSqrtMost], to 3 units in the last place (a
// square root and a division: 1.5; about 3 roundings of 2^-53 each in the last step, an ulp 2^-52
// or 2^-53 of the result): the float square root and division's 24 bits, then two Newton steps in
// double. Where a loop vectorises it, the double square root and division it replaces wait
// on the divider (a perspective camera's ray directions: 13 % of a one-sphere render,
// docs/benchmarks.md). Plain IEEE operations, no estimate instructions (whose bits differ between
// instruction sets): every kernel set computes the same number.
constexpr double kInverseSqrtLeast = 1e-30, kInverseSqrtMost = 1e30;  // float(s) normal, s·y² finite
DURER_INLINE double inverseSqrt(double s) {
  const double y0 = 1.0f / std::sqrt(static_cast<float>(s));
  const double half = 0.5 * s;
  const double y1 = y0 * (1.5 - half * y0 * y0);
  return y1 * (1.5 - half * y1 * y1);
}

// a·b - c·d with one rounding error instead of a catastrophic cancellation (Kahan; pbrt-v4's
// DifferenceOfProducts): the fma recovers the rounding error of c·d exactly.
template <typename Real>
DURER_INLINE Real differenceOfProducts(Real a, Real b, Real c, Real d) {
  const Real cd = c * d;
  const Real error = std::fma(-c, d, cd);
  return std::fma(a, b, -cd) + error;
}

// The exact rounding error of a - b given its rounded result (Knuth's TwoSum, branch-free): with
// diff = fl(a - b), a - b = diff + twoDiffError(a, b, diff) exactly (no fused multiply-adds allowed:
// the core is built with -ffp-contract=off).
template <typename Real>
DURER_INLINE Real twoDiffError(Real a, Real b, Real diff) {
  const Real bVirtual = a - diff;
  const Real aVirtual = diff + bVirtual;
  return (a - aVirtual) + (bVirtual - b);
}

// x² + y² + z² - r² with about one rounding of the result instead of one of the largest term
// (products split exactly by fma, sums compensated: Ogita, Rump & Oishi's Dot2).
template <typename Real>
DURER_INLINE Real sumOfSquaresMinus(Real x, Real y, Real z, Real r) {
  Real sum = x * x;
  Real error = std::fma(x, x, -sum);
  const Real terms[3] = {y * y, z * z, -(r * r)};
  const Real termErrors[3] = {std::fma(y, y, -terms[0]), std::fma(z, z, -terms[1]), -std::fma(r, r, terms[2])};
  for (int i = 0; i < 3; ++i) {
    const Real next = sum + terms[i];
    const Real virtualTerm = next - sum;
    error += (sum - (next - virtualTerm)) + (terms[i] - virtualTerm) + termErrors[i];
    sum = next;
  }
  return sum + error;
}

// x < 2^53 as a double, exactly as static_cast gives it, in steps that vectorise without AVX-512
// (which alone converts 64-bit integers): each 26-bit half placed in the mantissa of 2^52, then joined.
DURER_INLINE double exactDouble53(uint64_t x) {
  constexpr uint64_t kTwo52Bits = 0x4330000000000000ull;
  constexpr double kTwo52 = 4503599627370496.0, kTwo26 = 67108864.0;
  const uint64_t highBits = kTwo52Bits | (x >> 26), lowBits = kTwo52Bits | (x & 0x3ffffffu);
  double high, low;
  std::memcpy(&high, &highBits, sizeof high);
  std::memcpy(&low, &lowBits, sizeof low);
  return (high - kTwo52) * kTwo26 + (low - kTwo52);  // every step exact: the sum is below 2^53
}

// The largest |component|: a vector's infinity norm (NaN components are skipped).
inline double maxAbs(const Vec3d& v) { return std::fmax(std::fabs(v.x), std::fmax(std::fabs(v.y), std::fabs(v.z))); }

// Unit vector without overflow or underflow for any finite non-zero input.
inline Vec3d safeNormalize(const Vec3d& v) { return glm::normalize(v / maxAbs(v)); }

// Eight doubles as one GCC vector: arithmetic, comparisons (lanes of -1 or 0) and selects (a
// mask ? a : b) act lane by lane with the operations a double's would make, so code written for a
// number D that is either gives each lane the number's result bit for bit (Camera::footprints).
// AVX-512 registers where the kernel set has them, halves or quarters elsewhere.
typedef double DoubleLanes __attribute__((vector_size(8 * sizeof(double))));
template <typename D>
using LaneMask = decltype(D{} > D{});  // bool for a number

// |x| of a number, or of each lane (its sign bit cleared, as std::fabs does).
DURER_INLINE double magnitude(double x) { return std::fabs(x); }
DURER_INLINE DoubleLanes magnitude(DoubleLanes x) {
  typedef int64_t Bits __attribute__((vector_size(sizeof(DoubleLanes))));
  return DoubleLanes(Bits(x) & std::numeric_limits<int64_t>::max());
}

// The square root of a number, or of each lane: GCC has no vector square root of its own.
DURER_INLINE double squareRoot(double x) { return std::sqrt(x); }
DURER_INLINE DoubleLanes squareRoot(DoubleLanes x) {
#if defined(__AVX512F__)
  return DoubleLanes(_mm512_sqrt_pd(__m512d(x)));
#else
  DoubleLanes root;
  for (int j = 0; j < 8; ++j) root[j] = std::sqrt(x[j]);
  return root;
#endif
}

}  // namespace durer
