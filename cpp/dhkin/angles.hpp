// Angles: sine and cosine together, atan2, wrapping to (-pi, pi].
//
// sincos and atan2 are written out (no C library call, no branch on the quadrant) because the IK
// evaluates hundreds of them per pose and the compiler can then inline and vectorise them. Each
// is written once for a lane type V (simd.hpp): V = double for one value, V = Lanes for kLanes
// at once, with the same bits in each lane as for the double. Accuracy: within ~2 ulp (sincos
// measured 2.3e-16 on [-8, 8], atan2 4.5e-16; the tests measure them against numpy). Inputs
// outside their range (|x| >= 2^19, infinities, NaN, zeros for atan2) go to the C library, one
// lane at a time.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#include "dhkin/simd.hpp"

namespace dhkin {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;
constexpr double kHalfPi = 0.5 * kPi;

template <class V>
struct SinCosT {
  V s, c;
};
using SinCos = SinCosT<double>;

template <class V>
inline SinCos lane(const SinCosT<V>& t, int l) {
  return {lane(t.s, l), lane(t.c, l)};
}
template <class V>
inline void set_lane(SinCosT<V>& t, int l, const SinCos& x) {
  set_lane(t.s, l, x.s), set_lane(t.c, l, x.c);
}

namespace elementary {

// x + kRounder - kRounder rounds x to an integer (half to even) for |x| < 2^51, and the integer
// sits in the low bits of x + kRounder.
constexpr double kRounder = 6755399441055744.0;
// pi/2 as head + tail: the head has 33 significant bits, so k * head is exact for |k| < 2^20,
// and tail = pi/2 - head to double precision (Cody and Waite's reduction).
constexpr double kHalfPiHead = 0x1.921fb54400000p+0;
constexpr double kHalfPiTail = 0x1.0b4611a626331p-34;
constexpr double kTwoOverPi = 2.0 / kPi;
// At and above this |x| the reduction is not exact: sincos falls back on the C library.
constexpr double kReductionLimit = 524288.0;  // 2^19
// Taylor coefficients of sin and cos: on |r| <= pi/4 the truncation error is below 1e-19.
constexpr double kS3 = -1.0 / 6.0, kS5 = 1.0 / 120.0, kS7 = -1.0 / 5040.0,
                 kS9 = 1.0 / 362880.0, kS11 = -1.0 / 39916800.0, kS13 = 1.0 / 6227020800.0,
                 kS15 = -1.0 / 1307674368000.0, kS17 = 1.0 / 355687428096000.0;
constexpr double kC4 = 1.0 / 24.0, kC6 = -1.0 / 720.0, kC8 = 1.0 / 40320.0,
                 kC10 = -1.0 / 3628800.0, kC12 = 1.0 / 479001600.0,
                 kC14 = -1.0 / 87178291200.0, kC16 = 1.0 / 20922789888000.0,
                 kC18 = -1.0 / 6402373705728000.0;
// atan(k / 8), k = 0..8 (correctly rounded).
constexpr double kAtanTable[9] = {0.0,
                                  0x1.fd5ba9aac2f6ep-4,
                                  0x1.f5b75f92c80ddp-3,
                                  0x1.6f61941e4def1p-2,
                                  0x1.dac670561bb4fp-2,
                                  0x1.1e00babdefeb4p-1,
                                  0x1.4978fa3269ee1p-1,
                                  0x1.700a7c5784634p-1,
                                  0x1.921fb54442d18p-1};
// Taylor coefficients of atan(u) - u: on |u| <= 1/16 the truncation error is below 1e-20.
constexpr double kA3 = -1.0 / 3.0, kA5 = 1.0 / 5.0, kA7 = -1.0 / 7.0, kA9 = 1.0 / 9.0,
                 kA11 = -1.0 / 11.0, kA13 = 1.0 / 13.0, kA15 = -1.0 / 15.0;

// The low bits of x + kRounder (x rounded to an integer, |x| < 2^51), per lane.
inline std::int64_t rounded_bits(double shifted) {
  std::int64_t bits;
  std::memcpy(&bits, &shifted, sizeof bits);
  return bits;
}
DHKIN_INLINE LaneBits rounded_bits(Lanes shifted) { return bits_of(shifted); }

// atan(k / 8) for the integer k in the low bits of `bits` (lanes outside 0..8 read entry 8;
// their result is not used).
inline double atan_table(std::int64_t bits) {
  const std::int64_t k = bits & 15;
  return kAtanTable[k < 8 ? k : 8];
}
DHKIN_INLINE Lanes atan_table(const LaneBits& bits) {
#if defined(__AVX512F__)
  // one two-register permutation: entries 0..8 of the table, then entry 8 up to index 15
  const __m512d low = _mm512_loadu_pd(kAtanTable);
  const __m512d high = _mm512_set1_pd(kAtanTable[8]);
  Lanes out;
  for (int k = 0; k < simd::kParts; ++k) {
    const __m512i index = _mm512_and_si512((__m512i)bits.v[k], _mm512_set1_epi64(15));
    out.v[k] = (simd::Doubles)_mm512_permutex2var_pd(low, index, high);
  }
  return out;
#elif defined(__AVX2__)
  // In registers, not lane by lane through memory (eight scalar stores then one vector load of
  // them: the load waits for the stores to retire, no store-to-load forwarding; perf put ~1 %
  // of a UR5 batch on one such load). Entry k & 3 of entries 0..3 and of 4..7 by a permutation
  // of 32-bit halves (each double's two halves: 2 (k & 3) and 2 (k & 3) + 1), the half by bit
  // 2 of k, entry 8 where bit 3 is set (k = 8, and the unused 9..15): the same entries.
  const __m256i low = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(kAtanTable));
  const __m256i high = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(kAtanTable + 4));
  const __m256d last = _mm256_set1_pd(kAtanTable[8]);
  static_assert(simd::kNative == 4, "AVX vectors");
  Lanes out;
  for (int k = 0; k < simd::kParts; ++k) {
    const __m256i index = (__m256i)bits.v[k];
    const __m256i pair = _mm256_slli_epi64(_mm256_and_si256(index, _mm256_set1_epi64x(3)), 1);
    const __m256i halves = _mm256_or_si256(
        pair, _mm256_slli_epi64(_mm256_add_epi64(pair, _mm256_set1_epi64x(1)), 32));
    const __m256i bit2 = _mm256_set1_epi64x(4), bit3 = _mm256_set1_epi64x(8);
    const __m256d upper = _mm256_castsi256_pd(
        _mm256_cmpeq_epi64(_mm256_and_si256(index, bit2), bit2));
    const __m256d beyond = _mm256_castsi256_pd(
        _mm256_cmpeq_epi64(_mm256_and_si256(index, bit3), bit3));
    const __m256d entry =
        _mm256_blendv_pd(_mm256_castsi256_pd(_mm256_permutevar8x32_epi32(low, halves)),
                         _mm256_castsi256_pd(_mm256_permutevar8x32_epi32(high, halves)), upper);
    out.v[k] = (simd::Doubles)_mm256_blendv_pd(entry, last, beyond);
  }
  return out;
#else
  alignas(64) std::int64_t index[kLanes];
  alignas(64) double out[kLanes];
  std::memcpy(index, &bits.v, sizeof index);
  for (int l = 0; l < kLanes; ++l) out[l] = atan_table(index[l]);
  return Lanes::load(out);
#endif
}

// (sin x, cos x) for |x| < 2^19: reduction by multiples of pi/2, Taylor polynomials on
// [-pi/4, pi/4], the quadrant by selects, not branches (vectorisable).
template <class V>
DHKIN_INLINE SinCosT<V> sincos_reduced(V x) {
  const V shifted = x * kTwoOverPi + kRounder;
  const V k = shifted - kRounder;
  const auto quadrant = rounded_bits(shifted);  // k mod 4 in the low bits
  const V r = (x - k * kHalfPiHead) - k * kHalfPiTail;
  const V r2 = r * r;
  const V s =
      r + r * r2 *
              (kS3 + r2 * (kS5 + r2 * (kS7 + r2 * (kS9 + r2 * (kS11 + r2 * (kS13 + r2 * (kS15 + r2 * kS17)))))));
  const V c =
      1.0 - 0.5 * r2 +
      r2 * r2 *
          (kC4 + r2 * (kC6 + r2 * (kC8 + r2 * (kC10 + r2 * (kC12 + r2 * (kC14 + r2 * (kC16 + r2 * kC18)))))));
  const auto odd = (quadrant & 1) != 0;
  const V sine = select(odd, c, s);
  const V cosine = select(odd, s, c);
  const V sine_sign = select((quadrant & 2) != 0, V(-1.0), V(1.0));
  const V cosine_sign = select(((quadrant + 1) & 2) != 0, V(-1.0), V(1.0));
  return {sine * sine_sign, cosine * cosine_sign};
}

}  // namespace elementary

// (sin x, cos x), each within ~2 ulp; beyond 2^19, NaN and infinities: the C library.
template <class V>
DHKIN_INLINE SinCosT<V> sincos(V x) {
  SinCosT<V> out = elementary::sincos_reduced(x);
  for_each_lane(outside(x, elementary::kReductionLimit), [&](int l) {
    set_lane(out.s, l, std::sin(lane(x, l)));
    set_lane(out.c, l, std::cos(lane(x, l)));
  });
  return out;
}

// sincos(-x) from t = sincos(x): (-sin x, cos x), the same bits sincos(-x) gives (the reduction
// and both polynomials are symmetric, and so is the C library's).
template <class V>
DHKIN_INLINE SinCosT<V> negated(const SinCosT<V>& t) {
  return {-t.s, t.c};
}

// |sin x| <= band for a band in (0, 1e-3], the same answer as abs(sincos(x).s) <= band without
// the cosine: with x = k pi/2 + r, |sin x| is |sin r| for even k, else |cos r| > 0.7; and where
// |r| > 2 band, |sin r| > band (sin r >= r (1 - r^2 / 6)), so the polynomial is evaluated only
// where some lane is closer. Lanes outside `wanted` are not measured (false).
template <class V>
DHKIN_INLINE MaskOf<V> small_sine(V x, double band, MaskOf<V> wanted = every_lane<V>(true)) {
  using namespace elementary;
  const V shifted = x * kTwoOverPi + kRounder;
  const V k = shifted - kRounder;
  const V r = (x - k * kHalfPiHead) - k * kHalfPiTail;
  auto result = wanted && (rounded_bits(shifted) & 1) == 0 && abs(r) <= 2.0 * band;
  if (any(result)) result = result && abs(sincos(x).s) <= band;
  for_each_lane(wanted && outside(x, kReductionLimit),
                [&](int l) { set_lane(result, l, std::fabs(std::sin(lane(x, l))) <= band); });
  return result;
}

// atan2(y, x) <= limit for y, x >= 0 and a limit in (0, 1e-3]: the same answer, with atan2
// evaluated only where some lane has y <= 2 limit x (elsewhere the angle is at least
// atan(2 limit) > limit; NaN goes to atan2 as well).
template <class V>
DHKIN_INLINE MaskOf<V> small_angle(V y, V x, double limit) {
  auto maybe = !(y > (2.0 * limit) * x);
  if (any(maybe)) maybe = maybe && atan2(y, x) <= limit;
  return maybe;
}

// atan2(y, x) within ~2 ulp, with the C library's values at zeros, signed zeros, infinities and
// NaN (those inputs go to it). Reduction to t = min/max of |x|, |y| in [0, 1], then
// atan(t) = atan(k/8) + atan((t - k/8) / (1 + t k/8)).
template <class V>
DHKIN_INLINE V atan2(V y, V x) {
  using namespace elementary;
  const V ax = abs(x), ay = abs(y);
  const auto steep = ay > ax;
  const V denominator = select(steep, ay, ax);
  const V numerator = select(steep, ax, ay);
  const V t = numerator / denominator;
  const V shifted = t * 8.0 + kRounder;
  const V k = shifted - kRounder;
  const V centre = k * 0.125;
  const V u = (t - centre) / (1.0 + t * centre);
  const V u2 = u * u;
  V a = atan_table(rounded_bits(shifted)) +
        (u + u * u2 * (kA3 + u2 * (kA5 + u2 * (kA7 + u2 * (kA9 + u2 * (kA11 + u2 * (kA13 + u2 * kA15)))))));
  a = select(steep, kHalfPi - a, a);
  a = select(x < 0.0, kPi - a, a);
  a = copysign(a, y);
  for_each_lane(!(denominator > 0.0 && denominator < INFINITY && numerator == numerator),
                [&](int l) { set_lane(a, l, std::atan2(lane(y, l), lane(x, l))); });
  return a;
}

// value wrapped to (-pi, pi] (-pi itself becomes pi): whole turns taken off by Cody and Waite's
// reduction (k * 2pi's head is exact), beyond 2^19 by the C library's exact fmod.
template <class V>
DHKIN_INLINE V wrap(V value) {
  using namespace elementary;
  const auto inside = -kPi < value && value <= kPi;
  if (all(inside)) return value;  // most values (the reduction below keeps them as they are)
  const V k = (value * (0.25 * kTwoOverPi) + kRounder) - kRounder;  // value / 2pi, rounded
  V r = (value - k * (4.0 * kHalfPiHead)) - k * (4.0 * kHalfPiTail);  // 2pi = 4 (pi/2)
  r = select(r <= -kPi, r + kTwoPi, r);
  r = select(r > kPi, r - kTwoPi, r);
  r = select(inside, value, r);
  for_each_lane(outside(value, kReductionLimit), [&](int l) {
    double remainder = std::fmod(kPi - lane(value, l), kTwoPi);
    if (remainder < 0.0) remainder += kTwoPi;
    const double wrapped = kPi - remainder;
    set_lane(r, l, wrapped <= -kPi ? wrapped + kTwoPi : wrapped);
  });
  return r;
}

// x reduced to [-pi, pi) by whole turns (a distance between two angles).
inline double wrapped_difference(double x) {
  return x - kTwoPi * std::floor((x + kPi) / kTwoPi);
}

}  // namespace dhkin
