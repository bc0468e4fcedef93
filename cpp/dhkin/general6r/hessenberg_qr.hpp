// The eigenvalues of an upper Hessenberg matrix (n <= kEigenvalues) by Francis's implicit
// double-shift QR, eigenvalues only (docs/general6r.md, "Speed").
//
// The textbook algorithm (Golub and Van Loan, "Matrix Computations", 7.5; the structure of
// LAPACK's dlahqr without the Schur vectors): the active window [low, high] is the trailing
// unreduced block; each sweep chases a 3 x 1 bulge from the double shift (the eigenvalues of the
// window's trailing 2 x 2, or an exceptional shift every kExceptional sweeps) down the window,
// and a subdiagonal entry below eps times its two diagonal neighbours splits the window. Since
// only the eigenvalues are wanted, every reflector is applied inside the window alone (Eigen's
// RealSchur builds the whole Schur form T, so it updates every row and column). The deflation
// test is Eigen's (the same accuracy as before).
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

#include "dhkin/general6r/elimination.hpp"
#include "dhkin/general6r/four.hpp"

namespace dhkin::general6r {

// The storage of the matrices of the eigenproblem (the leading n x n block is used).
using Matrix24 = Eigen::Matrix<double, kEigenvalues, kEigenvalues>;
using Eigenvalues = Eigen::Matrix<std::complex<double>, kEigenvalues, 1>;

namespace hessenberg_qr_detail {

// QR sweeps allowed on one window (between two deflations) per row of the matrix, at least
// kMinimumRows rows (LAPACK's dlahqr: 30 max(10, n)).
constexpr int kSweepsPerRow = 30;
constexpr int kMinimumRows = 10;
// Every kExceptional sweeps of one window an exceptional shift is taken (dlahqr's, at 10 and
// 20): one from the top of the window, then one from its bottom, alternately, to break a cycle
// of the standard shifts.
constexpr int kExceptional = 10;
// A window still whole after kStalled sweeps (both exceptional shifts tried) is split at its
// smallest subdiagonal entry relative to its diagonal neighbours, where that is at most
// kStalledSplit. Francis's iteration cannot converge on a nearly defective multiple eigenvalue
// (every shift polynomial takes nearly the same value at its copies, so the subdiagonal entries
// between them keep their size): on a CRX-10iA special-angle pose (tests/test_ik_general6r.py,
// LOST_ROOT_POSES) a triple eigenvalue's last subdiagonal entries, 1.8e-14 and 5.9e-14 beside
// diagonal entries of 0.54, only changed sign, sweep after sweep, exceptional shifts included.
// The entry set to zero is the backward error the split commits: there ~3e-14 relative, which
// moves the triple eigenvalue's copies by ~(3e-14)^(1/3) ~ 3e-5, within kCluster, so they are
// still split as one cluster. The split is refused above sqrt(eps) (1.5e-8), the error the
// companion already carries where the leading matrix is conditioned at kLeadCondition (rounding
// over its reciprocal condition, ~2e-8); such a window fails as before.
constexpr int kStalled = 3 * kExceptional;
const double kStalledSplit = std::sqrt(std::numeric_limits<double>::epsilon());
// dlahqr's exceptional shift: the trailing 2 x 2 replaced by [[w + 0.75 s, -0.4375 s], [s,
// w + 0.75 s]], s the last two subdiagonals' size, w the last diagonal entry.
constexpr double kExceptionalDiagonal = 0.75;
constexpr double kExceptionalCorner = -0.4375;

// The eigenvalues of [[a, b], [c, d]] into first and second (a real pair or a conjugate pair,
// the one with positive imaginary part first), computed as LAPACK's dlanv2 decides between them:
// real when (p^2 + b c) >= 0 (p = (a - d) / 2), scaled against overflow; the larger real root
// from the sum without cancellation, the other from the product.
inline void two_by_two(double a, double b, double c, double d, std::complex<double>& first,
                       std::complex<double>& second) {
  if (c == 0.0 || b == 0.0) {
    first = a, second = d;
    return;
  }
  const double p = 0.5 * (a - d);
  const double bc_max = std::max(std::abs(b), std::abs(c));
  const double bc_min = std::min(std::abs(b), std::abs(c)) * (b < 0.0 ? -1.0 : 1.0) *
                        (c < 0.0 ? -1.0 : 1.0);
  const double scale = std::max(std::abs(p), bc_max);
  const double z = (p / scale) * p + (bc_max / scale) * bc_min;  // (p^2 + b c) / scale
  if (z >= 0.0) {
    const double root = std::sqrt(scale) * std::sqrt(z);
    const double sum = p + (p < 0.0 ? -root : root);
    const double larger = d + sum;
    const double smaller = sum != 0.0 ? d - (bc_max / sum) * bc_min : d;
    first = larger, second = smaller;
    return;
  }
  const double imaginary = std::sqrt(scale) * std::sqrt(-z);
  first = {d + p, imaginary};
  second = {d + p, -imaginary};
}

// A reflector I - tau v v^T, v = (1, v1, v2), mapping (x0, x1, x2) onto (beta, 0, 0) (x2 = 0 and
// v2 = 0 for a 2-vector); tau = 0 (the identity) where x1 = x2 = 0.
struct Reflector {
  double tau = 0.0, v1 = 0.0, v2 = 0.0, beta = 0.0;
};

inline Reflector reflector(double x0, double x1, double x2) {
  Reflector out;
  const double tail = x1 * x1 + x2 * x2;
  if (tail == 0.0) {
    out.beta = x0;
    return out;
  }
  const double length = std::sqrt(x0 * x0 + tail);
  out.beta = x0 >= 0.0 ? -length : length;
  out.tau = (out.beta - x0) / out.beta;
  const double pivot = 1.0 / (x0 - out.beta);
  out.v1 = x1 * pivot;
  out.v2 = x2 * pivot;
  return out;
}

// The reflector r (on rows and columns k .. k + 2, or k .. k + 1 without `Three`) applied to H
// from both sides within the window [low, high]: from the left on columns k .. high, from the
// right on rows low .. min(k + 3, high) (the eigenvalues alone need no more). From the right the
// three columns' rows are contiguous: four rows at a time. From the left each column's three
// entries are contiguous, the columns 24 doubles apart: one column at a time.
template <bool Three>
void apply_reflector(Matrix24& H, const Reflector& r, int k, int low, int high) {
  const double t1 = r.tau, t2 = r.tau * r.v1, t3 = r.tau * r.v2;
  for (int j = k; j <= high; ++j) {
    double* h = &H(k, j);
    double sum = h[0] + r.v1 * h[1];
    if (Three) sum += r.v2 * h[2];
    h[0] -= sum * t1;
    h[1] -= sum * t2;
    if (Three) h[2] -= sum * t3;
  }
  const int end = std::min(k + 3, high) + 1;  // rows low .. end - 1
  double* c0 = &H(0, k);
  double* c1 = &H(0, k + 1);
  double* c2 = Three ? &H(0, k + 2) : nullptr;
  int i = low;
  const Four v1 = {r.v1, r.v1, r.v1, r.v1}, v2 = {r.v2, r.v2, r.v2, r.v2};
  const Four f1 = {t1, t1, t1, t1}, f2 = {t2, t2, t2, t2}, f3 = {t3, t3, t3, t3};
  for (; i + 4 <= end; i += 4) {
    const Four a = load_four(c0 + i), b = load_four(c1 + i);
    Four sum = a + v1 * b;
    if (Three) {
      const Four c = load_four(c2 + i);
      sum += v2 * c;
      store_four(c2 + i, c - f3 * sum);
    }
    store_four(c0 + i, a - f1 * sum);
    store_four(c1 + i, b - f2 * sum);
  }
  for (; i < end; ++i) {
    double sum = c0[i] + r.v1 * c1[i];
    if (Three) {
      sum += r.v2 * c2[i];
      c2[i] -= t3 * sum;
    }
    c0[i] -= t1 * sum;
    c1[i] -= t2 * sum;
  }
}

}  // namespace hessenberg_qr_detail

// H (its leading n x n block) reduced in place to upper Hessenberg form by Householder
// similarities (Golub and Van Loan, 7.4.3): the same eigenvalues, zeros below the subdiagonal.
// Each reflector is applied as a matrix-vector product and a rank-one update of whole blocks
// (Eigen's vectorised kernels; the build leaves the compiler's own vectoriser off): two fifths
// of the eigenvalues' time went into these loops written out element by element.
inline void reduce_to_hessenberg(Matrix24& H, int n) {
  using Column = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kEigenvalues, 1>;
  Column v, w;
  for (int k = 0; k + 2 < n; ++k) {
    // the reflector I - tau v v^T (v(0) = 1 at row k + 1) taking column k below the
    // subdiagonal to zero
    const int length = n - k - 1;  // rows and columns k + 1 .. n - 1
    const double tail = H.col(k).segment(k + 2, length - 1).squaredNorm();
    if (tail == 0.0) continue;
    const double x0 = H(k + 1, k);
    const double size = std::sqrt(x0 * x0 + tail);
    const double beta = x0 >= 0.0 ? -size : size;
    const double tau = (beta - x0) / beta;
    v = H.col(k).segment(k + 1, length) * (1.0 / (x0 - beta));
    v(0) = 1.0;
    H.col(k).segment(k + 2, length - 1).setZero();
    H(k + 1, k) = beta;
    // from the left: rows and columns k + 1 .. n - 1
    auto lower = H.block(k + 1, k + 1, length, length);
    w.noalias() = lower.transpose() * v;
    lower.noalias() -= (tau * v) * w.transpose();
    // from the right: every row, columns k + 1 .. n - 1
    auto right = H.block(0, k + 1, n, length);
    w.noalias() = right * v;
    right.noalias() -= w * (tau * v).transpose();
  }
}

// The eigenvalues of the upper Hessenberg matrix H (its leading n x n block; destroyed) into
// out(0 .. n-1); false where a window did not split within kSweepsPerRow max(kMinimumRows, n)
// sweeps. The entries below the subdiagonal must be zeros (the bulge is chased through them).
inline bool hessenberg_eigenvalues(Matrix24& H, int n, Eigenvalues& out) {
  using namespace hessenberg_qr_detail;
  const double eps = std::numeric_limits<double>::epsilon();
  double norm = 0.0;  // the deflation test's scale where both diagonal neighbours vanish
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i <= std::min(j + 1, n - 1); ++i) norm += std::abs(H(i, j));
  }
  const double negligible = norm * eps;
  int high = n - 1;
  int sweeps = 0;
  while (high >= 0) {
    // the window [low, high]: split at the last negligible subdiagonal entry
    int low = high;
    while (low > 0) {
      const double s = std::abs(H(low - 1, low - 1)) + std::abs(H(low, low));
      if (std::abs(H(low, low - 1)) <= (s != 0.0 ? eps * s : negligible)) {
        H(low, low - 1) = 0.0;
        break;
      }
      --low;
    }
    if (low == high) {
      out(high) = H(high, high);
      --high;
      sweeps = 0;
      continue;
    }
    if (low == high - 1) {
      two_by_two(H(low, low), H(low, high), H(high, low), H(high, high), out(low), out(high));
      high -= 2;
      sweeps = 0;
      continue;
    }
    if (++sweeps > kSweepsPerRow * std::max(kMinimumRows, n)) return false;
    if (sweeps % kStalled == 0) {
      int split = low + 1;
      double smallest = INFINITY;
      for (int k = low + 1; k <= high; ++k) {
        const double s = std::abs(H(k - 1, k - 1)) + std::abs(H(k, k));
        const double relative = std::abs(H(k, k - 1)) / (s != 0.0 ? s : norm);
        if (relative < smallest) smallest = relative, split = k;
      }
      if (smallest <= kStalledSplit) {
        H(split, split - 1) = 0.0;
        sweeps = 0;
        continue;
      }
    }
    // the double shift: trace and determinant of the trailing 2 x 2 (or the exceptional one)
    double trace = 0.0, determinant = 0.0;
    if (sweeps % kExceptional == 0) {
      const bool top = sweeps % (2 * kExceptional) != 0;
      const double s = top ? std::abs(H(low + 1, low)) + std::abs(H(low + 2, low + 1))
                           : std::abs(H(high, high - 1)) + std::abs(H(high - 1, high - 2));
      const double diagonal = (top ? H(low, low) : H(high, high)) + kExceptionalDiagonal * s;
      trace = 2.0 * diagonal;
      determinant = diagonal * diagonal - kExceptionalCorner * s * s;
    } else {
      const double a = H(high - 1, high - 1), b = H(high - 1, high);
      const double c = H(high, high - 1), d = H(high, high);
      trace = a + d;
      determinant = a * d - b * c;
    }
    // the first column of (H - s1)(H - s2) at the sweep's first row: from `start`, the lowest row
    // where two consecutive subdiagonal entries are small enough for the bulge to start there
    int start = high - 2;
    double x = 0.0, y = 0.0, z = 0.0;
    for (;; --start) {
      const double h00 = H(start, start), h10 = H(start + 1, start);
      const double h01 = H(start, start + 1), h11 = H(start + 1, start + 1);
      x = h00 * h00 + h01 * h10 - trace * h00 + determinant;
      y = h10 * (h00 + h11 - trace);
      z = h10 * H(start + 2, start + 1);
      const double size = std::abs(x) + std::abs(y) + std::abs(z);
      if (size != 0.0) x /= size, y /= size, z /= size;
      if (start == low) break;
      const double coupling = std::abs(H(start, start - 1)) * (std::abs(y) + std::abs(z));
      const double scale =
          std::abs(x) * (std::abs(H(start - 1, start - 1)) + std::abs(h00) + std::abs(h11));
      if (coupling <= eps * scale) break;
    }
    // chase the bulge from `start` down to the window's end
    for (int k = start; k < high; ++k) {
      const bool three = k < high - 1;
      if (k > start) {
        x = H(k, k - 1);
        y = H(k + 1, k - 1);
        z = three ? H(k + 2, k - 1) : 0.0;
      }
      const Reflector r = reflector(x, y, three ? z : 0.0);
      if (k > start) {
        H(k, k - 1) = r.beta;
        H(k + 1, k - 1) = 0.0;
        if (three) H(k + 2, k - 1) = 0.0;
      } else if (start > low) {
        H(k, k - 1) *= 1.0 - r.tau;  // the reflector on the small entry above the bulge
      }
      if (r.tau == 0.0) continue;
      if (three) {
        apply_reflector<true>(H, r, k, low, high);
      } else {
        apply_reflector<false>(H, r, k, low, high);
      }
    }
  }
  return true;
}

}  // namespace dhkin::general6r
