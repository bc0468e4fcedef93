// The eigenvalues x = +-i that every pose's companion matrix carries, and their deflation
// (docs/general6r.md, "Speed").
//
// Raghavan and Roth's determinant of degree 24 holds 16 roots and the factor (1 + x^2)^4. Here
// is why, and why it can be removed once per table. With theta_k = lead + 2 atan(x), the matrix
// polynomial is M(x) = (1 + x^2) (Pc cos theta_k + Ps sin theta_k + P1) stacked, whose constant
// part (P1, the only one that holds the pose's right side r) carries the factor 1 + x^2; at
// x = i, M(i) = 2 e^(-i lead) N S, with S = stacked((Pc + i Ps) half2) (28 x 12 over all 14
// quantities) and N the pose's eliminating rows. So every null vector v of S, a constant of the
// table, is a null vector of M(i) at every pose and every lead: (4 of them on the CRX-10iA and
// the xArm6; computed to ~1e-15 by the companion on random poses.) For the companion
// K = [[0, I], [X, Y]] (X = -A^-1 C, Y = -A^-1 B), M(i) v = 0 means K [v; i v] = i [v; i v]:
// the real vectors [Re v; -Im v] and [Im v; Re v] span an invariant subspace Z of K (eigenvalues
// +-i) that does not depend on the pose. With an orthogonal basis [Z W] of R^24 (a constant),
// W^T K Z = 0 and the other eigenvalues are those of W^T K W (16 x 16): the QR iteration then
// works on 16 rows instead of 24, a third of the flops.
#pragma once

#include <Eigen/Dense>
#include <Eigen/SVD>
#include <complex>
#include <limits>

#include "dhkin/general6r/elimination.hpp"

namespace dhkin::general6r {

// A singular value of S at most this fraction of its largest is a null direction (its computed
// size is rounding, ~1e-16 on every table tried); one between kNullFraction and kRegularFraction
// is neither clearly null nor clearly not, and the deflation is then not used (a table whose
// extraneous roots are not exactly at +-i for every pose keeps the whole companion).
constexpr double kNullFraction = 1e3 * std::numeric_limits<double>::epsilon();
constexpr double kRegularFraction = 1e-6;

// The deflation of the elimination's companion (from P and half2; the same for every pose).
inline Deflation spurious_deflation(const Elimination& el) {
  using Complex = std::complex<double>;
  using Stacked = Eigen::Matrix<Complex, 2 * kQuantities, kMonomials>;
  const Eigen::Matrix<Complex, kQuantities, kProducts> W =
      (el.P[0].cast<Complex>() + Complex(0.0, 1.0) * el.P[1].cast<Complex>()) *
      el.half2.cast<Complex>();
  Stacked S = Stacked::Zero();
  S.block<kQuantities, kProducts>(0, 0) = W;
  S.block<kQuantities, kProducts>(kQuantities, 3) = W;
  const Eigen::JacobiSVD<Stacked> svd(S, Eigen::ComputeFullV);
  const auto& sv = svd.singularValues();
  Deflation out;
  if (!(sv(0) > 0.0) || !sv.allFinite()) return out;
  int nulls = 0;
  for (int i = 0; i < kMonomials; ++i) {
    const double ratio = sv(i) / sv(0);
    if (ratio <= kNullFraction) {
      ++nulls;
    } else if (ratio < kRegularFraction) {
      return out;  // no clear gap: no deflation
    }
  }
  if (nulls == 0) return out;
  // the real invariant subspace: [Re v; -Im v] and [Im v; Re v] of each null vector v
  Eigen::Matrix<double, kEigenvalues, Eigen::Dynamic, 0, kEigenvalues, kEigenvalues> Z(
      kEigenvalues, 2 * nulls);
  for (int n = 0; n < nulls; ++n) {
    const Eigen::Matrix<Complex, kMonomials, 1> v = svd.matrixV().col(kMonomials - 1 - n);
    Z.col(2 * n) << v.real(), -v.imag();
    Z.col(2 * n + 1) << v.imag(), v.real();
  }
  const Eigen::HouseholderQR<decltype(Z)> qr(Z);
  const auto R = qr.matrixQR().topLeftCorner(2 * nulls, 2 * nulls);
  const double largest = R.diagonal().cwiseAbs().maxCoeff();
  if (!(R.diagonal().cwiseAbs().minCoeff() > kRegularFraction * largest)) return out;
  out.dimension = 2 * nulls;
  out.basis = qr.householderQ();
  const int rest = kEigenvalues - out.dimension;
  const auto complement = out.basis.rightCols(rest);
  out.top_bottom.topLeftCorner(rest, rest) =
      complement.topRows(kMonomials).transpose() * complement.bottomRows(kMonomials);
  return out;
}

}  // namespace dhkin::general6r
