// The right side of the general 6R elimination at one pose: Q's rank, its pseudo-inverse (for
// back-substitution) and the rows N with N Q = 0 that eliminate its products (docs/general6r.md,
// "How it works", step 3).
//
// Q (14 x 8) has full rank at every pose but where a joint is free (axis 6 on axis 1). There a
// Householder QR, Q = H [R; 0], gives all three at once: rank 8, pseudo-inverse R^-1 H1^T, and N
// = H2^T (H = [H1 H2], the last six columns span Q's left null space): a third of the SVD's cost
// (Jacobi rotations on 8 columns were ~5 us a pose). The SVD's rank rule (singular values above
// kRankFraction of the largest) is kept exactly: Q has full rank by it for certain where
// 1 / (|R|_F |R^-1|_F), a lower bound of sigma_min / sigma_max, is above kRankFraction; elsewhere
// the SVD decides and gives the three, as before. The eliminating rows differ from the SVD's by
// a 6 x 6 rotation, which leaves M(x)'s eigenvalues and null vectors as they are.
#pragma once

#include <Eigen/Dense>
#include <Eigen/SVD>

#include "dhkin/general6r/back_substitution.hpp"
#include "dhkin/general6r/elimination.hpp"

// Compiled once, in cpp/eigen_instances.cpp (docs/architecture.md, "Build time").
extern template Eigen::JacobiSVD<dhkin::general6r::RightSide>&
Eigen::JacobiSVD<dhkin::general6r::RightSide>::compute(const dhkin::general6r::RightSide&, unsigned int);

namespace dhkin::general6r {

// Rows of Q whose singular value is below this fraction of the largest are its null space.
constexpr double kRankFraction = 1e-10;

using EliminatingRows = Eigen::Matrix<double, 6, kQuantities>;

namespace right_side_detail {

// The SVD's rank, pseudo-inverse and eliminating rows (a generic mix of them where more than
// six).
inline void by_svd(const Elimination& el, Right& right, EliminatingRows& N) {
  const Eigen::JacobiSVD<RightSide> svd(right.Q, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const auto& sv = svd.singularValues();
  right.rank = 0;
  for (int i = 0; i < 8; ++i) right.rank += sv(i) > sv(0) * kRankFraction ? 1 : 0;
  right.pseudo_inverse.setZero();
  for (int i = 0; i < right.rank; ++i) {
    right.pseudo_inverse += svd.matrixV().col(i) * svd.matrixU().col(i).transpose() / sv(i);
  }
  const int null_rows = kQuantities - right.rank;
  const auto left_null = svd.matrixU().rightCols(null_rows).transpose();
  if (null_rows > 6) {
    N = el.mix.leftCols(null_rows) * left_null;
  } else {
    N = left_null;
  }
}

}  // namespace right_side_detail

// right.rank and right.pseudo_inverse from right.Q, and the eliminating rows N (N Q = 0).
inline void factor_right(const Elimination& el, Right& right, EliminatingRows& N) {
  const Eigen::HouseholderQR<RightSide> qr(right.Q);
  const Eigen::Matrix<double, 8, 8> R = qr.matrixQR().topRows<8>().triangularView<Eigen::Upper>();
  const Eigen::Matrix<double, 8, 8> R_inverse =
      R.triangularView<Eigen::Upper>().solve(Eigen::Matrix<double, 8, 8>::Identity());
  const double ratio_bound = 1.0 / (R.norm() * R_inverse.norm());
  if (!(ratio_bound > kRankFraction)) {
    right_side_detail::by_svd(el, right, N);
    return;
  }
  const Eigen::Matrix<double, kQuantities, kQuantities> H = qr.householderQ();
  right.rank = 8;
  right.pseudo_inverse = R_inverse * H.leftCols<8>().transpose();
  N = H.rightCols<6>().transpose();
}

}  // namespace dhkin::general6r
