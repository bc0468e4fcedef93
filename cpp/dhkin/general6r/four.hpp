// Four doubles in one vector register, for the general 6R solver's small dense kernels
// (hessenberg_qr.hpp, monomial_lu.hpp). GCC and Clang vector extensions: the build turns the
// compiler's own vectoriser off, so vector code is written out. Arithmetic on them is element by
// element and IEEE: each element gets the same bits as the same operations on a double.
#pragma once

#include <cstring>

namespace dhkin::general6r {

typedef double Four __attribute__((vector_size(4 * sizeof(double))));

inline Four load_four(const double* p) {
  Four out;
  std::memcpy(&out, p, sizeof(out));
  return out;
}

inline void store_four(double* p, const Four& v) { std::memcpy(p, &v, sizeof(v)); }

inline Four splat_four(double x) { return Four{x, x, x, x}; }

}  // namespace dhkin::general6r
