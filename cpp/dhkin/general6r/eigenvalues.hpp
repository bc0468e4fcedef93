// The eigenvalues of the general 6R elimination's companion matrix and pencil.
//
// The companion K = [[0, I], [X, Y]] (X = -A^-1 C, Y = -A^-1 B, 24 x 24), balanced (as
// LAPACK's dgeev does first), its eight spurious eigenvalues +-i deflated (deflation.hpp; the
// 16 x 16 balanced again), reduced to Hessenberg form, then Francis's double-shift QR,
// eigenvalues only (hessenberg_qr.hpp). A pencil: Eigen's real QZ (GeneralizedEigenSolver) on the
// whole 24 x 24.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>

#include "dhkin/general6r/deflation.hpp"
#include "dhkin/general6r/elimination.hpp"
#include "dhkin/general6r/hessenberg_qr.hpp"
#include "dhkin/general6r/qz_shifts.hpp"

// Compiled once, in cpp/eigen_instances.cpp (docs/architecture.md, "Build time").
extern template Eigen::GeneralizedEigenSolver<dhkin::general6r::Matrix24>&
Eigen::GeneralizedEigenSolver<dhkin::general6r::Matrix24>::compute(const dhkin::general6r::Matrix24&,
                                                                  const dhkin::general6r::Matrix24&,
                                                                  bool);

namespace dhkin::general6r {

namespace eigenvalues_detail {

// Radix of the balancing scale factors (powers of two: scaling is exact).
constexpr double kRadix = 2.0;
// A row and column pair is rescaled when that shrinks their combined norm below this fraction.
constexpr double kBalanceGain = 0.95;

// Row and column i of the leading n x n block of H rescaled by a power of two where that brings
// their off-diagonal norms `column` and `row` (both nonzero) to comparable size and shrinks their
// sum below kBalanceGain of what it was; returns the factor (1: left as they were).
inline double rescale(Matrix24& H, int n, int i, double column, double row) {
  const double total = column + row;
  double factor = 1.0;
  for (double g = row / kRadix; column < g; column *= kRadix * kRadix) factor *= kRadix;
  for (double g = row * kRadix; column > g; column /= kRadix * kRadix) factor /= kRadix;
  if (!((column + row) / factor < kBalanceGain * total)) return 1.0;
  // The row divided by the factor as multiplied by its reciprocal: the factor is a power of two,
  // so where its reciprocal is a normal number that is exact and both give the exact quotient
  // rounded once, the same bits (dividing entry by entry was a quarter of the balancing's time).
  const double reciprocal = 1.0 / factor;
  if (std::isnormal(reciprocal)) {
    for (int j = 0; j < n; ++j) H(i, j) *= reciprocal;
  } else {
    for (int j = 0; j < n; ++j) H(i, j) /= factor;
  }
  for (int j = 0; j < n; ++j) H(j, i) *= factor;
  return factor;
}

// The companion K = [[0, I], [X, Y]] (24 x 24) balanced in place by a diagonal similarity
// D^-1 K D (Parlett and Reinsch, as LAPACK's dgebal, which dgeev runs first): each row and its
// column brought to comparable norms by powers of two; D's diagonal into `scale`. The eigenvalues
// are K's; their computed accuracy is not: the companion of a badly scaled M(x) unbalanced lost
// two real roots 5.5e-11 apart (a CRX-10iA pose at a joint limit) into one complex pair, balanced
// it keeps them apart. A diagonal similarity keeps K's zero blocks zero, so the norms skip them:
// row i < 12 holds only K(i, 12 + i), column i < 12 only rows 12 ..; column i >= 12 row i - 12
// and rows 12 .. (each sum in the order of the whole row or column: adding zeros is exact, the
// same bits).
inline void balance_companion(Matrix24& K, CompanionScale& scale) {
  constexpr int n = kEigenvalues, half = kMonomials;
  scale.setOnes();
  for (bool done = false; !done;) {
    done = true;
    for (int i = 0; i < n; ++i) {
      double column = 0.0, row = 0.0;
      if (i < half) {
        for (int j = half; j < n; ++j) column += std::abs(K(j, i));
        row = std::abs(K(i, half + i));
      } else {
        column = std::abs(K(i - half, i));
        for (int j = half; j < n; ++j) {
          if (j != i) column += std::abs(K(j, i));
        }
        for (int j = 0; j < n; ++j) {
          if (j != i) row += std::abs(K(i, j));
        }
      }
      if (column == 0.0 || row == 0.0) continue;
      const double factor = rescale(K, n, i, column, row);
      if (factor != 1.0) done = false, scale(i) *= factor;
    }
  }
}

// The leading n x n block of H balanced in place as balance_companion does, every entry counted
// (the deflated companion has no zero blocks).
inline void balance_matrix(Matrix24& H, int n) {
  for (bool done = false; !done;) {
    done = true;
    for (int i = 0; i < n; ++i) {
      double column = 0.0, row = 0.0;
      for (int j = 0; j < n; ++j) {
        if (j != i) column += std::abs(H(j, i)), row += std::abs(H(i, j));
      }
      if (column == 0.0 || row == 0.0) continue;
      if (rescale(H, n, i, column, row) != 1.0) done = false;
    }
  }
}

}  // namespace eigenvalues_detail

// The eigenvalues of the companion of M(x) = A x^2 + B x + C (A_inverse = A^-1) into out; returns
// how many (kDeflated where the spurious eigenvalues +-i were deflated, else kEigenvalues), 0
// where the QR iteration does not converge. `spurious` (null: the whole 24 x 24) is the table's
// invariant subspace for +-i (the whole 24 x 24 also where its pivot rows are singular).
inline int companion_eigenvalues(const Matrix12& A_inverse, const Matrix12& B, const Matrix12& C,
                                 const Spurious* spurious, Eigenvalues& out) {
  Matrix24 K = Matrix24::Zero();
  K.topRightCorner<kMonomials, kMonomials>().setIdentity();
  K.bottomLeftCorner<kMonomials, kMonomials>() = -A_inverse * C;
  K.bottomRightCorner<kMonomials, kMonomials>() = -A_inverse * B;
  CompanionScale scale;
  eigenvalues_detail::balance_companion(K, scale);
  if (spurious != nullptr) {
    Matrix24 deflated;
    if (deflate_spurious(K, scale, *spurious, deflated)) {
      eigenvalues_detail::balance_matrix(deflated, kDeflated);
      reduce_to_hessenberg(deflated, kDeflated);
      return hessenberg_eigenvalues(deflated, kDeflated, out) ? kDeflated : 0;
    }
  }
  reduce_to_hessenberg(K, kEigenvalues);
  return hessenberg_eigenvalues(K, kEigenvalues, out) ? kEigenvalues : 0;
}

// The eigenvalues of the pencil L - x R (an infinite one, beta = 0, as infinity); false where QZ
// does not converge. QZ's exceptional shifts restart their sequence here (qz_shifts.hpp): the
// eigenvalues depend on the pencil alone.
inline bool pencil_eigenvalues(const Matrix24& L, const Matrix24& R, Eigenvalues& out) {
  qz_shifts.restart();
  const Eigen::GeneralizedEigenSolver<Matrix24> qz(L, R, false);
  if (qz.info() != Eigen::Success) return false;
  for (int i = 0; i < kEigenvalues; ++i) {
    const double beta = qz.betas()(i);
    out(i) = beta != 0.0 ? qz.alphas()(i) / beta : std::complex<double>(INFINITY, 0.0);
  }
  return true;
}

}  // namespace dhkin::general6r
