// The singular values and right singular vectors of a 6 x 6 matrix (a scaled Jacobian) by
// one-sided Jacobi rotations (Hestenes): plane rotations V applied to the columns of A until every
// pair of columns of A V is orthogonal to the rounding, so that A V = U S with S the columns'
// norms. V is a product of rotations, orthogonal to the rounding whatever the spread of the
// singular values, and the singular values are those of A to its rounding (eps |A|, as LAPACK's;
// tests/test_right_svd.py): a curve of solutions' ~1e-15 is told from a regular root's 1e-3 as
// by Eigen's two-sided JacobiSVD, at a fraction of its cost (that one rotates rows and columns
// and solves a 2 x 2 SVD per pair: 5-12 us against 2.6 us per random 6 x 6 matrix here, best of
// 15 runs of 1,000 at a load of 3).
//
// The products A v (the columns of A V, sigma u) are kept instead of U: a left singular vector
// divided out of a singular value near the rounding would be noise, and the least-squares steps
// that use them need u . r / sigma = (A v) . r / sigma^2 only where sigma is well above it.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "dhkin/jacobi_rotation.hpp"

namespace dhkin {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

using Padded = Eigen::Matrix<double, 8, 6>;
using Column = Eigen::Matrix<double, 8, 1>;

struct RightSvd {
  Vector6d values;  // singular values, largest first
  Matrix6 V;        // right singular vectors, column w for values(w)
  Matrix6 AV;       // A V: column w is values(w) u_w
};

namespace jacobi {

// Rotations of the column pairs of `work` (and the same on V) until every pair is orthogonal to
// the rounding (jacobi_rotation.hpp).
inline void sweep(Padded& work, Padded& V) {
  for (int sweep = 0; sweep < kMaxJacobiSweeps; ++sweep) {
    bool rotated = false;
    for (int p = 0; p < 5; ++p) {
      for (int q = p + 1; q < 6; ++q) {
        const double alpha = work.col(p).squaredNorm();
        const double beta = work.col(q).squaredNorm();
        const double gamma = work.col(p).dot(work.col(q));
        PlaneRotation r;
        if (!orthogonalising_rotation(alpha, beta, gamma, r)) continue;
        rotated = true;
        const Column wp = work.col(p), wq = work.col(q);
        work.col(p) = r.c * wp - r.s * wq;
        work.col(q) = r.s * wp + r.c * wq;
        const Column vp = V.col(p), vq = V.col(q);
        V.col(p) = r.c * vp - r.s * vq;
        V.col(q) = r.s * vp + r.c * vq;
      }
    }
    if (!rotated) break;
  }
}

// The power of two that brings the largest entry of A into [1, 2) (jacobi_rotation.hpp).
struct Scale : PowerOfTwoScale {
  explicit Scale(const Matrix6& A) : PowerOfTwoScale(A.cwiseAbs().maxCoeff()) {}
};

// The SVD from the converged columns: values largest first, each with its V and A V column.
inline RightSvd sorted(const Padded& work, const Padded& V, const Scale& scale) {
  std::array<int, 6> order{0, 1, 2, 3, 4, 5};
  Vector6d norms;
  for (int w = 0; w < 6; ++w) norms(w) = work.col(w).norm();
  std::stable_sort(order.begin(), order.end(),
                   [&norms](int a, int b) { return norms(a) > norms(b); });
  RightSvd out;
  const double down_first = 1.0 / scale.first, down_second = 1.0 / scale.second;
  for (int w = 0; w < 6; ++w) {
    out.values(w) = norms(order[w]) * down_first * down_second;
    out.V.col(w) = V.col(order[w]).head<6>();
    out.AV.col(w) = work.col(order[w]).head<6>() * down_first * down_second;
  }
  return out;
}

}  // namespace jacobi

// The SVD of A (one-sided Jacobi), A first scaled by a power of two (exact; jacobi::Scale).
inline RightSvd right_svd(const Matrix6& A) {
  const jacobi::Scale scale(A);
  // Columns of eight rows (the last two zero), so that Eigen's packets take a column whole.
  Padded work = Padded::Zero(), V = Padded::Zero();
  work.topRows<6>() = A * scale.first * scale.second;
  V.topRows<6>().setIdentity();
  jacobi::sweep(work, V);
  return jacobi::sorted(work, V, scale);
}

// The SVD of A started from `start`, an orthogonal matrix near A's right singular vectors (those
// of a Jacobian a Newton step away): A start is then nearly column-orthogonal, and a sweep or two
// finish what takes six to eight from the identity. The same SVD to the rounding; V = start R
// carries start's own departure from orthogonality (~1e-15 per SVD it came from) on to it.
inline RightSvd right_svd(const Matrix6& A, const Matrix6& start) {
  const jacobi::Scale scale(A);
  Padded work = Padded::Zero(), V = Padded::Zero();
  work.topRows<6>() = (A * scale.first * scale.second) * start;
  V.topRows<6>() = start;
  jacobi::sweep(work, V);
  return jacobi::sorted(work, V, scale);
}

}  // namespace dhkin
