// The general 6R solver's constants for one table and one arrangement (built in Python at
// construction: dhkin.ik.general6r_model refits the exact chain as a standard-DH model,
// dhkin.ik.general6r_elimination interpolates the elimination's coefficients; the math is in
// docs/general6r.md).
//
// Conventions. The model reaches H (model frame 0 -> model frame 6, lengths in units of `scale`)
// as A_1 ... A_6 = H with A_j = Rz(theta_j) Tz(d_j) Tx(a_j) Rx(alpha_j). The arrangement
// eliminates model joint k (0-based) and keeps theta_k+1, theta_k+2 in the monomial vector; the
// right side holds the two joints j < k or j > k + 3, and joint k + 3 is dropped (it comes from
// the orientation). Where `reversed`, the model describes the chain tip to base and solves T^-1.
// Joint values are URDF joint values (rad): theta_j = direction_j q_j + offset_j + phi_j.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <vector>

#include "dhkin/chain.hpp"
#include "dhkin/frame.hpp"

namespace dhkin::general6r {

// The 14 quantities of a direction l and point p: p, l, p.p, p.l, p x l, (p.p) l - 2 (p.l) p.
constexpr int kQuantities = 14;
// Products of (cos, sin, 1) of two angles (index 3 i + j).
constexpr int kProducts = 9;
// Monomials x_a^i x_b^j (i <= 3, j <= 2, index 3 i + j) of the half-angle tangents of the two
// joints after the eliminated one: the size of the matrix polynomial M(x).
constexpr int kMonomials = 12;
// Eigenvalues of the companion of M(x) = A x^2 + B x + C.
constexpr int kEigenvalues = 2 * kMonomials;

// The companion's spurious eigenvalues x = +-i (Raghavan and Roth's extraneous factor
// (1 + x^2)^4 of the determinant): the same at every pose, deflated before the eigenvalues.
constexpr int kSpurious = 8;

using Matrix12 = Eigen::Matrix<double, kMonomials, kMonomials>;
using Vector12 = Eigen::Matrix<double, kMonomials, 1>;
// The equations of one side, over the products of the two joints after the eliminated one.
using Coefficients = Eigen::Matrix<double, kQuantities, kProducts>;

// One standard-DH row (the lengths in units of the model's scale), with the cosine and sine of
// its twist computed once (back-substitution builds five frames per start).
struct DHRow {
  double d = 0.0, a = 0.0, alpha = 0.0;
  double cos_alpha = 1.0, sin_alpha = 0.0;

  DHRow() = default;
  DHRow(double d_, double a_, double alpha_)
      : d(d_), a(a_), alpha(alpha_), cos_alpha(std::cos(alpha_)), sin_alpha(std::sin(alpha_)) {}
};

// Rz(theta) Tz(d) Tx(a) Rx(alpha) from theta's cosine ct and sine st.
inline Frame dh_frame(double ct, double st, const DHRow& row) {
  const double ca = row.cos_alpha, sa = row.sin_alpha;
  Frame out;
  out.R[0][0] = ct, out.R[0][1] = -st * ca, out.R[0][2] = st * sa, out.p[0] = row.a * ct;
  out.R[1][0] = st, out.R[1][1] = ct * ca, out.R[1][2] = -ct * sa, out.p[1] = row.a * st;
  out.R[2][0] = 0.0, out.R[2][1] = sa, out.R[2][2] = ca, out.p[2] = row.d;
  return out;
}

// Rz(theta) Tz(d) Tx(a) Rx(alpha).
inline Frame dh_frame(double theta, const DHRow& row) {
  return dh_frame(std::cos(theta), std::sin(theta), row);
}

struct Elimination {
  // P(theta_k) = P[0] cos + P[1] sin + P[2]: the left side's 14 quantities over the products
  // of (cos, sin, 1) of theta_k+1 and theta_k+2.
  std::array<Coefficients, 3> P;
  // The right side at sample angles (a, b) of its two joints (index 3 a + b) is
  // before[s] H after[s] (the dropped joint's inverse at angle 0 included in after).
  std::array<Frame, kProducts> before, after;
  // The interpolation of an order-one trigonometric polynomial in two angles: values at the
  // 3 x 3 sample angles -> coefficients over the 9 products.
  Eigen::Matrix<double, kProducts, kProducts> right_inverse;
  // A fixed generic combination of the eliminating rows where more than six remain.
  Eigen::Matrix<double, 6, kQuantities> mix;
  // (cos, sin, 1) of two half-angles x_a, x_b times (1 + x_a^2)(1 + x_b^2), as coefficients of
  // the monomials x_a^i x_b^j (i, j <= 2, index 3 i + j).
  Eigen::Matrix<double, kProducts, kProducts> half2;
  std::array<DHRow, kDof> rows;
  Joints phi{};              // theta_j = v_j + phi_j
  Frame D0_inverse;          // the chain's DH frame 0 -> model frame 0, inverted
  Frame E_inverse;           // model frame 6 -> the chain's DH frame 6, inverted
  double shift = 0.0;        // theta_k = shift + 2 atan(x)
  int k = 1;                 // the eliminated model joint
  bool reversed = false;     // the model runs tip to base
  double scale = 1.0;        // the model's length unit (m)
  double band = 0.1;         // largest imaginary part of an eigenvalue's angle taken (rad)
  // An orthonormal basis of the companion's real invariant subspace for x = +-i
  // (general6r_elimination.Elimination.spurious_subspace), where the table has one.
  Eigen::Matrix<double, kEigenvalues, kSpurious> spurious =
      Eigen::Matrix<double, kEigenvalues, kSpurious>::Zero();
  bool has_spurious = false;
  Joints direction{}, offset{};  // v_j = direction_j q_j + offset_j (the table's joints)

  // URDF joint values of the model angles theta.
  Joints joint_values(const Joints& theta) const {
    Joints out{};
    for (int j = 0; j < kDof; ++j) {
      const double v = theta[j] - phi[j];
      if (reversed) {
        out[5 - j] = (-v - offset[5 - j]) / direction[5 - j];
      } else {
        out[j] = (v - offset[j]) / direction[j];
      }
    }
    return out;
  }
};

// How an ill-conditioned pose is moved (dhkin.ik.general6r_moves): a rigid motion of DH frame 0
// (a rotation vector, rad, then a translation, m), and the fixed starts added on such poses.
struct Moves {
  std::array<double, 6> twist{};
  std::vector<Joints> fallback;

  // The motion scaled by s: P(s), applied on the left of DH-frame-0 poses.
  Frame motion(double s) const {
    Frame out = rotation_vector({s * twist[0], s * twist[1], s * twist[2]});
    for (int r = 0; r < 3; ++r) out.p[r] = s * twist[3 + r];
    return out;
  }
};

}  // namespace dhkin::general6r
