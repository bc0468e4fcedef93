// The eigenvalues of the general 6R elimination's companion matrix and pencil.
//
// The companion K = [[0, I], [X, Y]] (X = -A^-1 C, Y = -A^-1 B, 24 x 24) less its eigenvalues
// +-i, which every pose has (spurious.hpp): W^T K W (16 x 16 on every table tried), balanced
// (as LAPACK's dgeev does first), reduced to Hessenberg form, then Francis's double-shift QR,
// eigenvalues only (hessenberg_qr.hpp). A pencil: Eigen's real QZ (GeneralizedEigenSolver) on the
// whole 24 x 24.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>

#include "dhkin/general6r/elimination.hpp"
#include "dhkin/general6r/hessenberg_qr.hpp"

namespace dhkin::general6r {

namespace eigenvalues_detail {

// Radix of the balancing scale factors (powers of two: scaling is exact).
constexpr double kRadix = 2.0;
// A row and column pair is rescaled when that shrinks their combined norm below this fraction.
constexpr double kBalanceGain = 0.95;

// K (its leading n x n block) balanced in place by a diagonal similarity D^-1 K D (Parlett and
// Reinsch, as LAPACK's dgebal, which dgeev runs first): each row and its column brought to
// comparable norms by powers of two. The eigenvalues are K's; their computed accuracy is not:
// the companion of a badly scaled M(x) unbalanced lost two real roots 5.5e-11 apart (a CRX-10iA
// pose at a joint limit) into one complex pair, balanced it keeps them apart.
inline void balance(Matrix24& K, int n) {
  for (bool done = false; !done;) {
    done = true;
    for (int i = 0; i < n; ++i) {
      double column = 0.0, row = 0.0;
      for (int j = 0; j < n; ++j) {
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
        for (int j = 0; j < n; ++j) K(i, j) /= factor;
        for (int j = 0; j < n; ++j) K(j, i) *= factor;
      }
    }
  }
}

}  // namespace eigenvalues_detail

// The eigenvalues of K's leading n x n block (balanced in place first, then destroyed) into
// out(0 .. n-1); false where the QR iteration does not converge.
inline bool matrix_eigenvalues(Matrix24& K, int n, Eigenvalues& out) {
  eigenvalues_detail::balance(K, n);
  reduce_to_hessenberg(K, n);
  return hessenberg_eigenvalues(K, n, out);
}

// The eigenvalues of the companion of M(x) = A x^2 + B x + C but the +-i that `deflation` takes
// out, into out(0 .. count-1): those of W^T K W (W the deflation's complement), or of K itself
// where the table has no deflation. A_inverse = A^-1. False where the QR iteration does not
// converge.
inline bool companion_eigenvalues(const Deflation& deflation, const Matrix12& A_inverse,
                                  const Matrix12& B, const Matrix12& C, Eigenvalues& out,
                                  int& count) {
  Matrix24 K;
  count = kEigenvalues - deflation.dimension;
  if (deflation.dimension == 0) {
    K.setZero();
    K.topRightCorner<kMonomials, kMonomials>().setIdentity();
    K.bottomLeftCorner<kMonomials, kMonomials>() = -A_inverse * C;
    K.bottomRightCorner<kMonomials, kMonomials>() = -A_inverse * B;
  } else {
    // W^T K W = W1^T W2 + W2^T (X W1 + Y W2), X W1 + Y W2 = -A^-1 (C W1 + B W2)
    const auto W = deflation.basis.rightCols(count);
    const auto W1 = W.topRows(kMonomials);
    const auto W2 = W.bottomRows(kMonomials);
    using Block = Eigen::Matrix<double, kMonomials, Eigen::Dynamic, 0, kMonomials, kEigenvalues>;
    const Block G = C * W1 + B * W2;
    const Block XY = -(A_inverse * G);
    K.topLeftCorner(count, count) =
        deflation.top_bottom.topLeftCorner(count, count) + W2.transpose() * XY;
  }
  return matrix_eigenvalues(K, count, out);
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
