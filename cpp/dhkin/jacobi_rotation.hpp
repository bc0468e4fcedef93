// One-sided Jacobi (Hestenes) rotations, the step both of the core's SVDs are made of
// (right_svd.hpp for 6 x 6 Jacobians, numerical/pseudo_inverse.hpp for the numerical IK's task
// Jacobians): the plane rotation of two columns that makes them orthogonal, and the power of two
// that keeps the columns' squared norms and inner products in range.
#pragma once

#include <cmath>
#include <limits>

namespace dhkin {

// Sweeps over the column pairs until none is rotated; a sweep's rotations shrink the
// off-diagonal mass quadratically once it is small (five to eight sweeps on a 6 x 6 Jacobian).
// The cap is a guard, never reached on finite input.
constexpr int kMaxJacobiSweeps = 60;

// The rotation [c -s; s c] of a column pair (a_p, a_q) -> (c a_p - s a_q, s a_p + c a_q).
struct PlaneRotation {
  double c = 1.0, s = 0.0;
};

// The rotation that makes columns p and q orthogonal, from alpha = |a_p|^2, beta = |a_q|^2 and
// gamma = a_p . a_q; false where there is none to take: the pair counts as orthogonal already
// when |gamma| <= eps sqrt(alpha beta), the rounding of the dot product itself, or the rotation's
// tangent is below the rounding (zeta^2 overflowed).
inline bool orthogonalising_rotation(double alpha, double beta, double gamma,
                                     PlaneRotation& rotation) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  if (!(std::abs(gamma) > eps * std::sqrt(alpha * beta))) return false;
  // t = tan(theta), the smaller root of t^2 + 2 zeta t - 1 = 0
  const double zeta = (beta - alpha) / (2.0 * gamma);
  const double t = std::copysign(1.0, zeta) / (std::abs(zeta) + std::sqrt(1.0 + zeta * zeta));
  rotation.c = 1.0 / std::sqrt(1.0 + t * t);
  rotation.s = rotation.c * t;
  return rotation.s != 0.0;
}

// The power of two (as two factors, each within range even for subnormal or huge entries) that
// brings the largest entry `largest` (>= 0) of a matrix into [1, 2): the squared column norms and
// inner products can then neither overflow nor lose a column that matters to underflow (one of
// entries below 1e-154 of the largest is below its rounding). 1 for 0 or a non-finite largest.
struct PowerOfTwoScale {
  double first = 1.0, second = 1.0;
  explicit PowerOfTwoScale(double largest) {
    const int exponent = largest > 0.0 && std::isfinite(largest) ? std::ilogb(largest) : 0;
    first = std::ldexp(1.0, -(exponent / 2));
    second = std::ldexp(1.0, -(exponent - exponent / 2));
  }
};

}  // namespace dhkin
