// The Moore-Penrose pseudo-inverse of the descent's task Jacobian (at most 6 rows, at most
// kMaxJoints columns) by one-sided Jacobi rotations (Hestenes), as right_svd.hpp does for the
// closed forms' 6 x 6 Jacobians: plane rotations V applied to the columns of B (J, or J^T when J
// has more columns than rows, so that B has k = min(rows, columns) <= 6 columns) until every pair
// of them is orthogonal to the rounding; then B V = U S with S the columns' norms, and
// B^+ = V S^-1 U^T = sum_c v_c (B v)_c^T / s_c^2. The singular values are those of J to its
// rounding (eps |J|), as those of Eigen's two-sided JacobiSVD, which this replaced: GCC spent
// half of cpp/bindings_numerical.cpp's compile time instantiating JacobiSVD for a dynamic matrix
// (26.5 s of CPU with it, 13.8 s with this; docs/architecture.md, "Build time (helper i25ag)").
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>

#include "dhkin/chain.hpp"  // kMaxJoints
#include "dhkin/jacobi_rotation.hpp"

namespace dhkin::numerical {

// Rows of a task: 6 for a pose, 3 or 2 for a position.
constexpr int kMaxTaskRows = 6;

using TaskJacobian =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxTaskRows, kMaxJoints>;
using PseudoInverse =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxJoints, kMaxTaskRows>;

// J^+ with the singular values at most rcond x the largest dropped (their directions get 0).
inline PseudoInverse pseudo_inverse(const TaskJacobian& J, double rcond) {
  const int rows = static_cast<int>(J.rows()), columns = static_cast<int>(J.cols());
  const bool transposed = columns > rows;  // B = J^T
  const int k = transposed ? rows : columns, m = transposed ? columns : rows;
  PseudoInverse out = PseudoInverse::Zero(columns, rows);
  if (k == 0) return out;
  // J scaled by a power of two (exact) that brings its largest entry into [1, 2)
  double largest = 0.0;
  for (int c = 0; c < columns; ++c) {
    for (int r = 0; r < rows; ++r) largest = std::max(largest, std::abs(J(r, c)));
  }
  const PowerOfTwoScale scale(largest);
  const double up_first = scale.first, up_second = scale.second;
  double b[kMaxTaskRows][kMaxJoints];  // column c of B (scaled), entries 0..m-1
  double v[kMaxTaskRows][kMaxTaskRows];  // column c of V, entries 0..k-1
  for (int c = 0; c < k; ++c) {
    for (int i = 0; i < m; ++i) b[c][i] = (transposed ? J(c, i) : J(i, c)) * up_first * up_second;
    for (int i = 0; i < k; ++i) v[c][i] = i == c ? 1.0 : 0.0;
  }
  const auto dot = [m](const double* x, const double* y) {
    double sum = 0.0;
    for (int i = 0; i < m; ++i) sum += x[i] * y[i];
    return sum;
  };
  for (int sweep = 0; sweep < kMaxJacobiSweeps; ++sweep) {
    bool rotated = false;
    for (int p = 0; p + 1 < k; ++p) {
      for (int q = p + 1; q < k; ++q) {
        PlaneRotation r;
        if (!orthogonalising_rotation(dot(b[p], b[p]), dot(b[q], b[q]), dot(b[p], b[q]), r)) {
          continue;
        }
        rotated = true;
        for (int i = 0; i < m; ++i) {
          const double bp = b[p][i], bq = b[q][i];
          b[p][i] = r.c * bp - r.s * bq;
          b[q][i] = r.s * bp + r.c * bq;
        }
        for (int i = 0; i < k; ++i) {
          const double vp = v[p][i], vq = v[q][i];
          v[p][i] = r.c * vp - r.s * vq;
          v[q][i] = r.s * vp + r.c * vq;
        }
      }
    }
    if (!rotated) break;
  }
  double norms[kMaxTaskRows], largest_norm = 0.0;
  for (int c = 0; c < k; ++c) {
    norms[c] = std::sqrt(dot(b[c], b[c]));
    largest_norm = std::max(largest_norm, norms[c]);
  }
  const double cutoff = rcond * largest_norm;
  for (int c = 0; c < k; ++c) {
    if (!(norms[c] > cutoff)) continue;
    // v_c (B v)_c^T / s_c^2, with B, B v and s_c scaled up by the power of two: one factor of
    // it back
    const double factor = up_first * up_second / (norms[c] * norms[c]);
    for (int i = 0; i < m; ++i) {
      const double weighted = b[c][i] * factor;
      for (int j = 0; j < k; ++j) {
        if (transposed) {
          out(i, j) += weighted * v[c][j];  // J^+ = (B^+)^T: columns x rows = m x k
        } else {
          out(j, i) += v[c][j] * weighted;  // J^+ = B^+: columns x rows = k x m
        }
      }
    }
  }
  return out;
}

}  // namespace dhkin::numerical
