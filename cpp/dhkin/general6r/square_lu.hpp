// The 6 x 6 Jacobian's LU with partial pivoting on the lane type (simd.hpp): a Newton step's
// solve and the inverse's Frobenius norm, for one root (V = double) or eight starts at once
// (V = Lanes, one start per lane; docs/general6r.md, "Speed, eighth pass").
//
// The operations are those of Eigen 3.4's PartialPivLU<Matrix<double, 6, 6, RowMajor>> as this
// build compiles it (AVX: packets of four doubles), in the same order, so that each lane gives the
// bits Eigen's solve() and inverse().norm() give (checked on 10^6 random matrices, scaled and
// near-singular ones among them, and by scripts/compare_builds.py against the build that called
// Eigen): the pivot is the first row of largest magnitude, a zero pivot column is left undivided;
// the triangular solves of a vector sum their products as Eigen's unrolled reductions do
// (lengths 4 and 5 as one packet, ((p0 + p2) + (p1 + p3)) [+ p4]; length 3 as (p0 + p1) + p2);
// the inverse's triangular solves subtract one product at a time and multiply by the diagonal's
// reciprocal (Eigen's triangular_solve_matrix), its squared norm adds nine packets of four in
// halves. On a target whose Eigen packets differ the values are the same up to rounding, and
// the scalar and lane paths still agree, both being this code.
#pragma once

#include "dhkin/simd.hpp"

namespace dhkin::general6r {

// The factors of J (row-major 6 x 6) per lane: L below the diagonal (unit diagonal), U on and
// above it, rows in pivot order; `pivot[k]` is the row swapped with row k at step k (as a double).
template <class V>
struct SquareLU {
  V a[6][6];
  V pivot[5];
};

// Factorises J (row-major, 36 values) per lane.
template <class V>
DHKIN_INLINE void lu_factor6(const V* J, SquareLU<V>& lu) {
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) lu.a[r][c] = J[r * 6 + c];
  }
  for (int k = 0; k < 5; ++k) {
    V largest = abs(lu.a[k][k]);
    V pivot = V(static_cast<double>(k));
    for (int r = k + 1; r < 6; ++r) {
      const V size = abs(lu.a[r][k]);
      const MaskOf<V> larger = size > largest;
      largest = select(larger, size, largest);
      pivot = select(larger, V(static_cast<double>(r)), pivot);
    }
    lu.pivot[k] = pivot;
    for (int r = k + 1; r < 6; ++r) {
      const MaskOf<V> swap = pivot == static_cast<double>(r);
      if (!any(swap)) continue;
      for (int c = 0; c < 6; ++c) {
        const V row_k = lu.a[k][c];
        lu.a[k][c] = select(swap, lu.a[r][c], row_k);
        lu.a[r][c] = select(swap, row_k, lu.a[r][c]);
      }
    }
    const MaskOf<V> divide = largest != 0.0;  // a zero column is left as it is
    for (int r = k + 1; r < 6; ++r) lu.a[r][k] = select(divide, lu.a[r][k] / lu.a[k][k], lu.a[r][k]);
    for (int r = k + 1; r < 6; ++r) {
      for (int c = k + 1; c < 6; ++c) lu.a[r][c] = lu.a[r][c] - lu.a[r][k] * lu.a[k][c];
    }
  }
}

namespace square_lu_detail {

// The sum of n products (n = 1..5) in the order of Eigen's unrolled reduction.
template <class V>
DHKIN_INLINE V product_sum(const V* p, int n) {
  switch (n) {
    case 1: return p[0];
    case 2: return p[0] + p[1];
    case 3: return (p[0] + p[1]) + p[2];
    case 4: return (p[0] + p[2]) + (p[1] + p[3]);
    default: return ((p[0] + p[2]) + (p[1] + p[3])) + p[4];
  }
}

// b in place: the row swaps of the factorisation applied in order.
template <class V>
DHKIN_INLINE void permute(const SquareLU<V>& lu, V* b) {
  for (int k = 0; k < 5; ++k) {
    for (int r = k + 1; r < 6; ++r) {
      const MaskOf<V> swap = lu.pivot[k] == static_cast<double>(r);
      if (!any(swap)) continue;
      const V row_k = b[k];
      b[k] = select(swap, b[r], row_k);
      b[r] = select(swap, row_k, b[r]);
    }
  }
}

}  // namespace square_lu_detail

// x = J^-1 e per lane (Eigen's solve(): the permutation, L, then U).
template <class V>
DHKIN_INLINE void lu_solve6(const SquareLU<V>& lu, const V* e, V* x) {
  using square_lu_detail::product_sum;
  V b[6];
  for (int r = 0; r < 6; ++r) b[r] = e[r];
  square_lu_detail::permute(lu, b);
  V products[5];
  for (int i = 1; i < 6; ++i) {
    for (int j = 0; j < i; ++j) products[j] = lu.a[i][j] * b[j];
    b[i] = b[i] - product_sum(products, i);
  }
  for (int d = 5; d >= 0; --d) {
    const int after = 5 - d;
    if (after > 0) {
      for (int j = 0; j < after; ++j) products[j] = lu.a[d][d + 1 + j] * b[d + 1 + j];
      b[d] = b[d] - product_sum(products, after);
    }
    b[d] = b[d] / lu.a[d][d];
  }
  for (int r = 0; r < 6; ++r) x[r] = b[r];
}

// |J^-1|_F per lane (Eigen's inverse().norm(): each column of the identity permuted and solved,
// one product subtracted at a time, U's diagonal by its reciprocal; the squares summed in
// packets of four).
template <class V>
DHKIN_INLINE V inverse_norm6(const SquareLU<V>& lu) {
  V X[6][6];  // row-major, as Eigen's inverse
  for (int c = 0; c < 6; ++c) {
    V b[6];
    for (int r = 0; r < 6; ++r) b[r] = V(r == c ? 1.0 : 0.0);
    square_lu_detail::permute(lu, b);
    for (int i = 0; i < 6; ++i) {
      V y = b[i];
      for (int j = 0; j < i; ++j) y = y - lu.a[i][j] * b[j];
      b[i] = y;
    }
    for (int d = 5; d >= 0; --d) {
      V x = b[d];
      for (int j = d + 1; j < 6; ++j) x = x - lu.a[d][j] * b[j];
      b[d] = x * (1.0 / lu.a[d][d]);
    }
    for (int r = 0; r < 6; ++r) X[r][c] = b[r];
  }
  // nine packets of four consecutive squares (row-major order), added in halves (4 + 5, ...),
  // then the packet's four parts as (s0 + s2) + (s1 + s3)
  constexpr int kPackets = 9;
  V packets[kPackets][4];
  const V* values = &X[0][0];
  for (int p = 0; p < kPackets; ++p) {
    for (int l = 0; l < 4; ++l) packets[p][l] = values[4 * p + l] * values[4 * p + l];
  }
  const auto halves = [&](auto&& self, int first, int count, int part) -> V {
    if (count == 1) return packets[first][part];
    const int half = count / 2;
    return self(self, first, half, part) + self(self, first + half, count - half, part);
  };
  V sum[4];
  for (int l = 0; l < 4; ++l) sum[l] = halves(halves, 0, kPackets, l);
  return sqrt((sum[0] + sum[2]) + (sum[1] + sum[3]));
}

}  // namespace dhkin::general6r
