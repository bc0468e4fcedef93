// Angles: sine and cosine together, atan2, wrapping to (-pi, pi].
//
// sincos and atan2 are written out (no C library call, no branch on the quadrant) because the IK
// evaluates hundreds of them per pose and the compiler can then inline and vectorise them.
// Accuracy: within ~2 ulp (sincos measured 2.3e-16 on [-8, 8], atan2 4.5e-16; the tests measure
// them against numpy). Inputs outside their range (|x| >= 2^19, infinities, NaN, zeros for atan2)
// go to the C library.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

namespace dhkin {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;
constexpr double kHalfPi = 0.5 * kPi;

struct SinCos {
  double s, c;
};

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

// (sin x, cos x) for |x| < 2^19: reduction by multiples of pi/2, Taylor polynomials on
// [-pi/4, pi/4], the quadrant by selects, not branches (vectorisable).
inline SinCos sincos_reduced(double x) {
  const double shifted = x * kTwoOverPi + kRounder;
  const double k = shifted - kRounder;
  std::int64_t bits;
  std::memcpy(&bits, &shifted, sizeof bits);
  const double r = (x - k * kHalfPiHead) - k * kHalfPiTail;
  const double r2 = r * r;
  const double s =
      r + r * r2 *
              (kS3 + r2 * (kS5 + r2 * (kS7 + r2 * (kS9 + r2 * (kS11 + r2 * (kS13 + r2 * (kS15 + r2 * kS17)))))));
  const double c =
      1.0 - 0.5 * r2 +
      r2 * r2 *
          (kC4 + r2 * (kC6 + r2 * (kC8 + r2 * (kC10 + r2 * (kC12 + r2 * (kC14 + r2 * (kC16 + r2 * kC18)))))));
  const std::int64_t quadrant = bits;  // k mod 4 in the low bits
  const bool odd = (quadrant & 1) != 0;
  const double sine = odd ? c : s;
  const double cosine = odd ? s : c;
  const double sine_sign = (quadrant & 2) ? -1.0 : 1.0;
  const double cosine_sign = ((quadrant + 1) & 2) ? -1.0 : 1.0;
  return {sine * sine_sign, cosine * cosine_sign};
}

}  // namespace elementary

// (sin x, cos x), each within ~2 ulp; beyond 2^19, NaN and infinities: the C library.
inline SinCos sincos(double x) {
  if (!(std::abs(x) < elementary::kReductionLimit)) return {std::sin(x), std::cos(x)};
  return elementary::sincos_reduced(x);
}

// atan2(y, x) within ~2 ulp, with the C library's values at zeros, signed zeros, infinities and
// NaN (those inputs go to it). Reduction to t = min/max of |x|, |y| in [0, 1], then
// atan(t) = atan(k/8) + atan((t - k/8) / (1 + t k/8)).
inline double atan2(double y, double x) {
  using namespace elementary;
  const double ax = std::abs(x), ay = std::abs(y);
  const double denominator = ay > ax ? ay : ax;
  const double numerator = ay > ax ? ax : ay;
  if (!(denominator > 0.0 && denominator < INFINITY && numerator == numerator)) {
    return std::atan2(y, x);
  }
  const double t = numerator / denominator;
  const double k = (t * 8.0 + kRounder) - kRounder;
  const double centre = k * 0.125;
  const double u = (t - centre) / (1.0 + t * centre);
  const double u2 = u * u;
  double a = kAtanTable[static_cast<int>(k)] +
             (u + u * u2 * (kA3 + u2 * (kA5 + u2 * (kA7 + u2 * (kA9 + u2 * (kA11 + u2 * (kA13 + u2 * kA15)))))));
  a = ay > ax ? kHalfPi - a : a;
  a = x < 0.0 ? kPi - a : a;
  return std::copysign(a, y);
}

// value wrapped to (-pi, pi] (-pi itself becomes pi): whole turns taken off by Cody and Waite's
// reduction (k * 2pi's head is exact), beyond 2^19 by the C library's exact fmod.
inline double wrap(double value) {
  if (-kPi < value && value <= kPi) return value;
  if (std::abs(value) < elementary::kReductionLimit) {
    using namespace elementary;
    const double k = (value * (0.25 * kTwoOverPi) + kRounder) - kRounder;  // value / 2pi, rounded
    double r = (value - k * (4.0 * kHalfPiHead)) - k * (4.0 * kHalfPiTail);  // 2pi = 4 (pi/2)
    if (r <= -kPi) r += kTwoPi;
    if (r > kPi) r -= kTwoPi;
    return r;
  }
  double r = std::fmod(kPi - value, kTwoPi);
  if (r < 0.0) r += kTwoPi;
  const double wrapped = kPi - r;
  return wrapped <= -kPi ? wrapped + kTwoPi : wrapped;
}

// x reduced to [-pi, pi) by whole turns (a distance between two angles).
inline double wrapped_difference(double x) {
  return x - kTwoPi * std::floor((x + kPi) / kTwoPi);
}

}  // namespace dhkin
