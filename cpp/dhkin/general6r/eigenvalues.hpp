// The eigenvalues of the general 6R elimination's 24 x 24 companion matrix and pencil.
//
// A real matrix: balanced (as LAPACK's dgeev does first), then Eigen's EigenSolver (Hessenberg
// reduction, Francis double-shift QR), eigenvalues only. A pencil: Eigen's real QZ
// (GeneralizedEigenSolver).
#pragma once

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>

#include "dhkin/general6r/elimination.hpp"

namespace dhkin::general6r {

using Matrix24 = Eigen::Matrix<double, kEigenvalues, kEigenvalues>;
using Eigenvalues = Eigen::Matrix<std::complex<double>, kEigenvalues, 1>;

namespace eigenvalues_detail {

// Radix of the balancing scale factors (powers of two: scaling is exact).
constexpr double kRadix = 2.0;
// A row and column pair is rescaled when that shrinks their combined norm below this fraction.
constexpr double kBalanceGain = 0.95;

// K balanced in place by a diagonal similarity D^-1 K D (Parlett and Reinsch, as LAPACK's
// dgebal, which dgeev runs first): each row and its column brought to comparable norms by
// powers of two. The eigenvalues are K's; their computed accuracy is not: the companion of a
// badly scaled M(x) unbalanced lost two real roots 5.5e-11 apart (a CRX-10iA pose at a joint
// limit) into one complex pair, balanced it keeps them apart.
inline void balance(Matrix24& K) {
  for (bool done = false; !done;) {
    done = true;
    for (int i = 0; i < kEigenvalues; ++i) {
      double column = 0.0, row = 0.0;
      for (int j = 0; j < kEigenvalues; ++j) {
        if (j == i) continue;
        column += std::abs(K(j, i));
        row += std::abs(K(i, j));
      }
      if (column == 0.0 || row == 0.0) continue;
      const double total = column + row;
      double factor = 1.0;
      for (double g = row / kRadix; column < g; column *= kRadix * kRadix) factor *= kRadix;
      for (double g = row * kRadix; column > g; column /= kRadix * kRadix) factor /= kRadix;
      if ((column + row) / factor < kBalanceGain * total) {
        done = false;
        K.row(i) /= factor;
        K.col(i) *= factor;
      }
    }
  }
}

}  // namespace eigenvalues_detail

// The eigenvalues of K (balanced in place first); false where the QR iteration does not
// converge.
inline bool matrix_eigenvalues(Matrix24& K, Eigenvalues& out) {
  eigenvalues_detail::balance(K);
  const Eigen::EigenSolver<Matrix24> eigen(K, false);
  if (eigen.info() != Eigen::Success) return false;
  out = eigen.eigenvalues();
  return true;
}

// The eigenvalues of the pencil L - x R (an infinite one, beta = 0, as infinity); false where QZ
// does not converge.
inline bool pencil_eigenvalues(const Matrix24& L, const Matrix24& R, Eigenvalues& out) {
  const Eigen::GeneralizedEigenSolver<Matrix24> qz(L, R, false);
  if (qz.info() != Eigen::Success) return false;
  for (int i = 0; i < kEigenvalues; ++i) {
    const double beta = qz.betas()(i);
    out(i) = beta != 0.0 ? qz.alphas()(i) / beta : std::complex<double>(INFINITY, 0.0);
  }
  return true;
}

}  // namespace dhkin::general6r
