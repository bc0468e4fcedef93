// The monomial vectors of the general 6R elimination at one eigenvalue: the joints theta_k+1,
// theta_k+2 of every root whose eliminated joint is that eigenvalue (docs/general6r.md, "Every
// root").
//
// At a root, M(x) m = 0 with m (12) the monomials x_a^i x_b^j (i <= 3, j <= 2, index 3 i + j)
// of the half-angle tangents of theta_k+1 (a) and theta_k+2 (b). Written homogeneously,
// m_ij = c_a^(3-i) s_a^i c_b^(2-j) s_b^j with (c, s) the cosine and sine of the half angle, so
// theta = pi (x infinite) is an ordinary vector. Where several roots share the eigenvalue (four
// of the CRX-10iA's eight share theta_2 = 90 deg at special angles), the null space of M(x) has
// one dimension per root, and any one null vector is a mixture of theirs: split() recovers each.
//
// Monomial vectors have a shift structure: the rows with i >= 1 are (s_a / c_a) times the rows
// with i <= 2 (one row lower), and likewise along j. So in a basis V (12 x m) of the null space,
// each root's coordinates c (V c = m) are an eigenvector of X = (R0 V)^+ (R1 V), R0 and R1 the
// row selections (rotated by a half-angle delta, so that no root sits at X's infinity), exactly,
// whatever else the basis holds, as long as R0 V has full column rank. Roots sharing theta_k+1
// too share X's eigenvalue; the eigenvectors of X + gamma Y (Y: the same along j) separate every
// pair for all but one gamma, so of m (m - 1) / 2 + 1 gammas one separates them all.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

#include "dhkin/angles.hpp"
#include "dhkin/general6r/decomposed_types.hpp"  // kMaxSplit, Small, ShiftRows
#include "dhkin/general6r/elimination.hpp"
#include "dhkin/general6r/monomial_lu.hpp"  // LU, lu_factor, lu_solve

namespace dhkin::general6r {

// kMaxSplit, the largest null space split: decomposed_types.hpp.
// Half-angle rotations tried for the shift operators: a root makes one rotation singular (its
// half angle at delta + pi / 2); with up to kMaxSplit roots, kMaxSplit + 1 rotations spread over
// pi leave one at least pi / 18 (10 deg) from all of them.
constexpr int kRotations = kMaxSplit + 1;
// The gammas of split() are tried until the eigenvalues of X + gamma Y lie at least this far
// apart relative to their size: an eigenvector is then accurate to about eps / this (sqrt(eps),
// ~1.5e-8: a start well within Newton's reach).
const double kSeparated = std::sqrt(std::numeric_limits<double>::epsilon());
// Steps of inverse iteration for a simple eigenvalue's null vector (from a vector of ones).
constexpr int kInverseIterations = 2;

// A basis of a null space (12 x m, m <= kMaxSplit).
using Basis = Eigen::Matrix<double, kMonomials, Eigen::Dynamic, 0, kMonomials, kMaxSplit>;
// Small (X, Y) and ShiftRows (the low and the high rows of shift_operator): decomposed_types.hpp.

}  // namespace dhkin::general6r

// Compiled once, in cpp/eigen_instances.cpp (docs/architecture.md, "Build time").
extern template Eigen::EigenSolver<dhkin::general6r::Small>&
Eigen::EigenSolver<dhkin::general6r::Small>::compute(const Eigen::EigenBase<dhkin::general6r::Small>&,
                                                   bool);
extern template Eigen::EigenSolver<dhkin::general6r::Small>::EigenvectorsType
Eigen::EigenSolver<dhkin::general6r::Small>::eigenvectors() const;
extern template Eigen::JacobiSVD<dhkin::general6r::ShiftRows>&
Eigen::JacobiSVD<dhkin::general6r::ShiftRows>::compute(const dhkin::general6r::ShiftRows&, unsigned int);

namespace dhkin::general6r {

// M at the half angle `half`, homogeneously: A s^2 + B s c + C c^2 (c, s its cosine and sine),
// scaled so that its largest weight is one (x = tan(half); x = infinity is c = 0).
inline Matrix12 homogeneous(const Matrix12& A, const Matrix12& B, const Matrix12& C,
                            double half) {
  const double c = std::cos(half), s = std::sin(half);
  if (std::abs(s) <= std::abs(c)) {
    const double t = s / c;
    return A * (t * t) + B * t + C;
  }
  const double y = c / s;
  return A + B * y + C * (y * y);
}

// The null vector of M at the half angle `half` (a simple eigenvalue), by inverse iteration,
// up to scale; false if the iteration breaks down (not finite).
inline bool null_vector(const Matrix12& A, const Matrix12& B, const Matrix12& C, double half,
                        Vector12& out) {
  Matrix12 M = homogeneous(A, B, C, half);
  LU lu;
  lu_factor(M, lu);
  out.setOnes();
  for (int step = 0; step < kInverseIterations; ++step) {
    lu_solve(lu, out);
    const double size = out.cwiseAbs().maxCoeff();
    if (!(size > 0.0 && size < INFINITY)) return false;
    out /= size;
  }
  return true;
}

// Block inverse iteration's steps for the null space of an eigenvalue shared by m roots: the
// steps of a simple eigenvalue's (kInverseIterations), and one more for the block's start, which
// is not a vector of ones along one direction but m generic directions.
constexpr int kBlockIterations = kInverseIterations + 1;

// An orthonormal basis of the null space of M at the half angle `half` shared by m roots (its
// computed copies lie within rounding of each other), into out (12 x m): block inverse iteration
// from m fixed generic directions (one LU, lu_factor; each step multiplies the components
// outside the m directions of smallest |eigenvalue| of M by at least their ratio to the next,
// ~1e-5 at a double root beside a close cluster, far less at an exact one), the columns kept
// orthonormal by Gram-Schmidt, twice. False if M is not finite or the iteration breaks down.
inline bool null_space(const Matrix12& A, const Matrix12& B, const Matrix12& C, double half,
                       int m, Basis& out) {
  Matrix12 M = homogeneous(A, B, C, half);
  if (!M.allFinite()) return false;
  LU lu;
  lu_factor(M, lu);
  out.resize(kMonomials, m);
  for (int c = 0; c < m; ++c) {  // generic directions: no monomial pattern, independent
    for (int i = 0; i < kMonomials; ++i) out(i, c) = std::cos(1.0 + (i + 1) * (c + 0.6180339887));
  }
  for (int step = 0; step < kBlockIterations; ++step) {
    for (int c = 0; c < m; ++c) {
      Vector12 column = out.col(c);
      lu_solve(lu, column);
      out.col(c) = column;
    }
    for (int c = 0; c < m; ++c) {
      for (int pass = 0; pass < 2; ++pass) {
        for (int d = 0; d < c; ++d) out.col(c) -= out.col(d).dot(out.col(c)) * out.col(d);
      }
      const double size = out.col(c).norm();
      if (!(size > 0.0 && size < INFINITY)) return false;
      out.col(c) /= size;
    }
  }
  return true;
}

// X (m x m) with X c = t c for the coordinates c of every monomial vector V c in the span of V,
// t = tan(half angle - delta) of joint a (`along_b` false: rows i <= 2 against i >= 1) or joint
// b (rows j <= 1 against j >= 1); delta the first of kRotations whose low rows R0 V have a
// reciprocal condition of at least kSeparated (X then accurate to ~sqrt(eps)), else the best.
inline Small shift_operator(const Basis& V, bool along_b) {
  const int m = static_cast<int>(V.cols());
  const int n_rows = along_b ? 8 : 9;
  ShiftRows low(n_rows, m), high(n_rows, m);
  int row = 0;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (along_b ? j <= 1 : i <= 2) {
        const int next = along_b ? 3 * i + j + 1 : 3 * i + j + 3;
        low.row(row) = V.row(3 * i + j);
        high.row(row) = V.row(next);
        ++row;
      }
    }
  }
  double best = -1.0;
  Small result = Small::Zero(m, m);
  for (int k = 0; k < kRotations; ++k) {
    const double delta = k * kPi / kRotations;
    const double cd = std::cos(delta), sd = std::sin(delta);
    const ShiftRows R0 = cd * low + sd * high;
    const ShiftRows R1 = cd * high - sd * low;
    const Eigen::JacobiSVD<ShiftRows> svd(R0, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const auto& sv = svd.singularValues();
    if (!(sv(0) > 0.0)) continue;
    const double score = sv(m - 1) / sv(0);
    if (score > best) {
      best = score;
      // X = R0^+ R1 = W diag(1 / sv) U^T R1
      Small projected = svd.matrixU().transpose() * R1;
      for (int r = 0; r < m; ++r) projected.row(r) /= sv(r) > 0.0 ? sv(r) : 1.0;
      result = svd.matrixV() * projected;
    }
    if (score >= kSeparated) break;
  }
  return result;
}

// The monomial vector of every root whose null vectors span V (12 x m, m >= 2), into out's
// columns (12 x m), each up to scale: eigenvectors of X + gamma Y for the first gamma whose
// eigenvalues lie kSeparated apart, else the one among m (m - 1) / 2 + 1 whose eigenvalues are
// farthest apart. A complex eigenvector (a direction of V that is no real root) gives the real
// part of its vector, phase-aligned on its largest entry: a start that Newton may reject.
inline void split(const Basis& V, Basis& out) {
  const int m = static_cast<int>(V.cols());
  const Small X = shift_operator(V, false);
  const Small Y = shift_operator(V, true);
  using ComplexSmall =
      Eigen::Matrix<std::complex<double>, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxSplit, kMaxSplit>;
  const int tries = m * (m - 1) / 2 + 1;
  double best = -1.0;
  ComplexSmall vectors = ComplexSmall::Zero(m, m);
  constexpr double kGolden = 0.6180339887498949;
  for (int k = 0; k < tries; ++k) {
    const double gamma = (k + 1) * (k % 2 == 0 ? kGolden : -kGolden);
    const Small Z = X + gamma * Y;
    const Eigen::EigenSolver<Small> eigen(Z, true);
    if (eigen.info() != Eigen::Success) continue;
    const auto& values = eigen.eigenvalues();
    double gap = INFINITY, size = 0.0;
    for (int a = 0; a < m; ++a) {
      size = std::max(size, std::abs(values(a)));
      for (int b = 0; b < a; ++b) gap = std::min(gap, std::abs(values(a) - values(b)));
    }
    if (gap > best) {
      best = gap;
      vectors = eigen.eigenvectors();
    }
    if (gap >= kSeparated * std::max(size, 1.0)) break;
  }
  out.resize(kMonomials, m);
  for (int r = 0; r < m; ++r) {
    const Eigen::Matrix<std::complex<double>, kMonomials, 1> v = V.cast<std::complex<double>>() *
                                                                 vectors.col(r);
    int top = 0;
    for (int i = 0; i < kMonomials; ++i) {
      if (std::abs(v(i)) > std::abs(v(top))) top = i;
    }
    const std::complex<double> phase = std::abs(v(top)) > 0.0
                                           ? std::conj(v(top)) / std::abs(v(top))
                                           : std::complex<double>(1.0, 0.0);
    for (int i = 0; i < kMonomials; ++i) out(i, r) = (v(i) * phase).real();
  }
}

// The angle of joint a (`along_b` false) or b from a monomial vector v: 2 atan2(next, this) on
// the pair of consecutive monomials along that joint of largest size (homogeneous: right at
// x = infinity too).
inline double ratio_angle(const double* v, bool along_b) {
  double best = -1.0, low = 0.0, high = 1.0;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (along_b ? j == 2 : i == 3) continue;
      const double a = v[3 * i + j], b = v[along_b ? 3 * i + j + 1 : 3 * i + j + 3];
      const double size = a * a + b * b;
      if (size > best) best = size, low = a, high = b;
    }
  }
  return 2.0 * std::atan2(high, low);
}

}  // namespace dhkin::general6r
