// The 12 x 12 LU with partial pivoting that inverse iteration solves with (null_space.hpp: M(x)
// at one eigenvalue, one factorisation and a few solves per start).
//
// Conventions. Matrix12 is column-major (Eigen's default): a column's twelve entries are
// contiguous and are worked on whole, as three Fours (four.hpp). Each entry gets the operations
// it got when these loops were Eigen column expressions (M.col(j) -= M(k, j) * multipliers on
// all twelve rows, the multipliers zero at and above row k), in the same order, so the factors
// and the solutions have the same bits; rows that a zero multiplier leaves as they are (x - a * 0)
// are still computed, so that signed zeros and non-finite entries come out as before too. What
// changed is where the work goes: the multipliers are kept below the diagonal of M itself (as
// LAPACK stores them), so that one row swap moves the rows of L and of U together, and the
// columns stay in vector registers instead of going through memory one entry at a time (the
// factorisation and its solves were a sixth of a CRX-10iA pose's time).
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "dhkin/general6r/elimination.hpp"
#include "dhkin/general6r/four.hpp"

namespace dhkin::general6r {

// M's LU factors with partial pivoting: L (unit lower, its unit diagonal implicit) and U
// (upper), each stored with zeros elsewhere; row k was swapped with pivots[k].
struct LU {
  Matrix12 L, U;
  std::array<int, kMonomials> pivots;
};

namespace monomial_lu_detail {

// A column of twelve as three Fours: entry r in part r / 4, element r % 4.
constexpr int kParts = kMonomials / 4;
static_assert(kParts * 4 == kMonomials, "whole Fours");

struct Column {
  Four part[kParts];
};

inline Column load_column(const double* c) {
  Column out;
  for (int i = 0; i < kParts; ++i) out.part[i] = load_four(c + 4 * i);
  return out;
}

inline void store_column(double* c, const Column& v) {
  for (int i = 0; i < kParts; ++i) store_four(c + 4 * i, v.part[i]);
}

// The row numbers of part i's four entries.
inline Four rows_of(int i) {
  const double first = 4.0 * i;
  return Four{first, first + 1.0, first + 2.0, first + 3.0};
}

// Entry by entry, the entries of `below` in rows below row k, those of `other` at and above it.
inline Column below_row(int k, const Column& below, const Column& other) {
  const Four row = splat_four(static_cast<double>(k));
  Column out;
  for (int i = 0; i < kParts; ++i) out.part[i] = rows_of(i) > row ? below.part[i] : other.part[i];
  return out;
}

// v with its entry in row r set to value's (value: four copies).
inline Column at_row(int r, const Four& value, const Column& v) {
  const Four row = splat_four(static_cast<double>(r));
  Column out;
  for (int i = 0; i < kParts; ++i) out.part[i] = rows_of(i) == row ? value : v.part[i];
  return out;
}

// Four copies of v's entry in row r.
inline Four entry_of(const Column& v, int r) { return splat_four(v.part[r / 4][r % 4]); }

// v with rows k and p swapped (x_k, x_p: its entries there; p == k leaves it as it is).
inline Column swap_rows(const Column& v, int k, double x_k, int p, double x_p) {
  return at_row(k, splat_four(x_p), at_row(p, splat_four(x_k), v));
}

// v - f * c, entry by entry (the product rounded, then the difference: no fused multiply-add).
inline Column minus_multiple(const Column& v, const Four& factor, const Column& c) {
  Column out;
  for (int i = 0; i < kParts; ++i) out.part[i] = v.part[i] - factor * c.part[i];
  return out;
}

// The first row r >= k of largest |c[r]| (Eigen's maxCoeff(&index) on the column's tail: a
// later entry replaces the largest only where strictly larger, so a NaN neither replaces one nor,
// first, is replaced).
inline int pivot_row(const double* c, int k) {
  int best = k;
  double largest = std::abs(c[k]);
  for (int r = k + 1; r < kMonomials; ++r) {
    const double size = std::abs(c[r]);
    if (size > largest) largest = size, best = r;
  }
  return best;
}

}  // namespace monomial_lu_detail

// The LU factors of M (destroyed: L's multipliers below its diagonal, U on and above). A pivot of
// exactly zero (M singular in the arithmetic: the eigenvalue exact) is replaced by rounding's
// size, eps |M|, as inverse iteration does, so that the solve amplifies the null direction
// instead of failing. Each step reads and writes every column it changes once, whole: the row
// swap is made in registers (writing the two entries alone and then reading the whole column
// back stalled on every column: a load cannot be forwarded from two stores).
inline void lu_factor(Matrix12& M, LU& out) {
  using namespace monomial_lu_detail;
  const double tiny = std::max(M.cwiseAbs().maxCoeff() * std::numeric_limits<double>::epsilon(),
                               1e-300);
  double* a = M.data();  // entry (r, c) at a[kMonomials * c + r]
  for (int k = 0; k < kMonomials; ++k) {
    double* column_k = a + kMonomials * k;
    const int p = pivot_row(column_k, k);
    out.pivots[k] = p;
    // column c with rows k and p swapped (U's rows and, before column k, L's multipliers)
    const auto swapped = [&](int c) {
      const double* column = a + kMonomials * c;
      return swap_rows(load_column(column), k, column[k], p, column[p]);
    };
    Column column = swapped(k);
    double pivot = column_k[p];  // the swapped column's entry k
    if (pivot == 0.0) {
      pivot = tiny;
      column = at_row(k, splat_four(tiny), column);
    }
    if (k + 1 == kMonomials) {
      store_column(column_k, column);
      break;
    }
    // the multipliers below row k, zeros at and above it: subtracting them times row k leaves
    // rows 0 .. k as they are (x - a * 0 = x)
    const Four divisor = splat_four(pivot);
    Column quotients;
    for (int i = 0; i < kParts; ++i) quotients.part[i] = column.part[i] / divisor;
    const Column multipliers = below_row(k, quotients, Column{});
    store_column(column_k, below_row(k, multipliers, column));
    if (p != k) {
      for (int c = 0; c < k; ++c) store_column(a + kMonomials * c, swapped(c));
    }
    for (int j = k + 1; j < kMonomials; ++j) {
      double* column_j = a + kMonomials * j;
      const double row_k = column_j[p];  // entry k after the swap
      store_column(column_j, minus_multiple(swapped(j), splat_four(row_k), multipliers));
    }
  }
  for (int k = 0; k < kMonomials; ++k) {
    const Column column = load_column(a + kMonomials * k);
    store_column(out.L.data() + kMonomials * k, below_row(k, column, Column{}));
    store_column(out.U.data() + kMonomials * k, below_row(k, Column{}, column));
  }
}

// v <- M^-1 v from lu_factor's factors: the row swaps, then L and U column by column (each
// column's multiple subtracted from all twelve entries; U's own diagonal entry restored). Each
// step's factor is broadcast from its lane, in the vector it was computed in.
inline void lu_solve(const LU& lu, Vector12& v) {
  using namespace monomial_lu_detail;
  for (int k = 0; k < kMonomials; ++k) {
    if (lu.pivots[k] != k) std::swap(v(k), v(lu.pivots[k]));
  }
  Column x = load_column(v.data());
  const double* L = lu.L.data();
  const double* U = lu.U.data();
  for (int k = 0; k + 1 < kMonomials; ++k) {
    x = minus_multiple(x, entry_of(x, k), load_column(L + kMonomials * k));
  }
  for (int i = kMonomials - 1; i >= 0; --i) {
    const Four value = entry_of(x, i) / splat_four(U[kMonomials * i + i]);
    if (i > 0) x = minus_multiple(x, value, load_column(U + kMonomials * i));
    x = at_row(i, value, x);  // the column's own diagonal entry: the quotient
  }
  store_column(v.data(), x);
}

}  // namespace dhkin::general6r
