// The companion's eight spurious eigenvalues x = +-i removed before the eigenvalues
// (docs/general6r.md, "Speed, seventh pass"): 24 x 24 -> 16 x 16.
//
// U (24 x 8, Elimination::spurious) spans the companion K's real invariant subspace for +-i at
// every pose. The balanced companion D^-1 K D has the invariant subspace V = D^-1 U. With P the
// 8 rows of V chosen by a pivoted QR (V_P invertible, as well conditioned as the greedy choice
// makes it) and S the other 16, the similarity T = [[I, 0], [G, I]] (coordinates P, S;
// G = V_S V_P^-1) has [I; G] = V V_P^-1 as its first columns, so T^-1 K T is block upper
// triangular and its lower right block K_SS - G K_PS (16 x 16) holds the other 16 eigenvalues.
// The update mixes no coordinates of different scale (an orthogonal complement of U, tried
// before, undid the balancing and lost roots at nearly double eigenvalues).
//
// Its accuracy: with the companion's rounding E, the deflated matrix carries E_SS - G E_PS, at
// most (1 + |G|) |E|, and an eigenvalue's condition in it is at most (1 + |G|) times its condition
// in K (its right eigenvector is x_S - G x_P, its left one y_S, and y_S . (x_S - G x_P) = y . x).
// That first-order bound does not tell where it loses digits (|G| stays below 4 on random poses,
// and was 0.005 at the HC10 pose that lost a root; docs/general6r.md, "Speed, seventh pass"):
// candidates.hpp deflates only where the leading matrix is conditioned within
// kCompanionCondition.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cmath>

#include "dhkin/general6r/elimination.hpp"
#include "dhkin/general6r/hessenberg_qr.hpp"

namespace dhkin::general6r {

// The size of the companion with the spurious eigenvalues deflated.
constexpr int kDeflated = kEigenvalues - kSpurious;

using Spurious = Eigen::Matrix<double, kEigenvalues, kSpurious>;
using CompanionScale = Eigen::Matrix<double, kEigenvalues, 1>;

namespace deflation_detail {

// The kSpurious rows of V chosen as a QR of V^T with column pivoting chooses its columns
// (Businger and Golub): each time the row with the largest part orthogonal to the rows already
// chosen (whose own parts are then zero), the others' parts made orthogonal to it. Each step is a
// matrix-vector product and a rank-one update of all 24 rows (Eigen's vector kernels; by row,
// element by element, it cost 1.7x the whole deflation). Marks the rows in `pivot`; false where V
// has not full rank (a step finds no part left).
inline bool pivot_rows(const Spurious& V, std::array<bool, kEigenvalues>& pivot) {
  pivot.fill(false);
  Spurious W = V;
  Eigen::Matrix<double, kEigenvalues, 1> parts;
  for (int step = 0; step < kSpurious; ++step) {
    parts = W.rowwise().squaredNorm();
    int best = 0;
    const double largest = parts.maxCoeff(&best);
    if (!(largest > 0.0)) return false;
    pivot[best] = true;
    const Eigen::Matrix<double, 1, kSpurious> direction = W.row(best) / std::sqrt(largest);
    const Eigen::Matrix<double, kEigenvalues, 1> along = W * direction.transpose();
    W.noalias() -= along * direction;
  }
  return true;
}

}  // namespace deflation_detail

// The deflated 16 x 16 of the balanced companion K (K = D^-1 K0 D, `scale` = D's diagonal; U
// the invariant subspace of K0 for +-i) into the leading block of `deflated`; false where V has
// not full rank or V_P is singular (G not finite).
inline bool deflate_spurious(const Matrix24& K, const CompanionScale& scale, const Spurious& U,
                             Matrix24& deflated) {
  using namespace deflation_detail;
  const Spurious V = scale.cwiseInverse().asDiagonal() * U;
  std::array<bool, kEigenvalues> pivot;
  if (!pivot_rows(V, pivot)) return false;
  std::array<int, kSpurious> P;
  std::array<int, kDeflated> S;
  for (int i = 0, p = 0, s = 0; i < kEigenvalues; ++i) {
    if (pivot[i]) {
      P[p++] = i;
    } else {
      S[s++] = i;
    }
  }
  Eigen::Matrix<double, kSpurious, kSpurious> V_P;
  Eigen::Matrix<double, kDeflated, kSpurious> V_S;
  for (int p = 0; p < kSpurious; ++p) V_P.row(p) = V.row(P[p]);
  for (int s = 0; s < kDeflated; ++s) V_S.row(s) = V.row(S[s]);
  // G^T = V_P^-T V_S^T
  const Eigen::Matrix<double, kSpurious, kDeflated> G_transposed =
      V_P.transpose().partialPivLu().solve(V_S.transpose());
  if (!G_transposed.allFinite()) return false;
  Eigen::Matrix<double, kSpurious, kDeflated> K_PS;
  for (int s = 0; s < kDeflated; ++s) {
    for (int p = 0; p < kSpurious; ++p) K_PS(p, s) = K(P[p], S[s]);
  }
  for (int c = 0; c < kDeflated; ++c) {
    for (int r = 0; r < kDeflated; ++r) deflated(r, c) = K(S[r], S[c]);
  }
  deflated.topLeftCorner<kDeflated, kDeflated>().noalias() -= G_transposed.transpose() * K_PS;
  return true;
}

}  // namespace dhkin::general6r
