// The lane types: kLanes doubles worked on at once (one pose or one branch per lane), so that
// code written once for a lane type V runs on one value (V = double) or on kLanes values
// (V = Lanes) in the machine's vector registers.
//
// Lanes, Mask and LaneBits hold kLanes values as the machine's widest vectors (GCC and Clang
// vector extensions: 8 doubles with AVX-512, 4 with AVX, 2 otherwise), operated on part by part:
// arithmetic is element by element and IEEE, so each lane gives the same bits as the same
// operations on a double. The build keeps -ffp-contract=off (no fused multiply-adds) and turns
// the compiler's own vectoriser off (-fno-tree-vectorize: GCC's SLP vectoriser fuses a multiply
// into an alternating add/subtract, vfmaddsub, despite -ffp-contract=off), so that vector code
// is only what is written here. Code generic in V uses only what both provide: + - * / and
// comparisons, select(mask, a, b) for a ? b : c, sqrt, abs, max and min (defined as std::max
// and std::min are, NaN included), floor, ceil, nearbyint, any(mask), and lane(v, l) /
// set_lane(v, l, x) to run a rare case one lane at a time.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__AVX512F__) || defined(__AVX__) || defined(__SSE2__)
#include <immintrin.h>
#elif defined(__aarch64__) && defined(__ARM_NEON)
#include <arm_neon.h>
#endif

// Inlined wherever called: lane code passes 64-byte values, which a call would put in memory.
#if defined(__GNUC__)
#define DHKIN_INLINE inline __attribute__((always_inline))
#else
#define DHKIN_INLINE inline
#endif

namespace dhkin {

// Lanes of one lane type: a pose's eight branches fill one.
constexpr int kLanes = 8;

namespace simd {

// The widest vector of doubles the target has.
#if defined(__AVX512F__)
#define DHKIN_NATIVE_WIDTH 8
#elif defined(__AVX__)
#define DHKIN_NATIVE_WIDTH 4
#else
#define DHKIN_NATIVE_WIDTH 2
#endif
constexpr int kNative = DHKIN_NATIVE_WIDTH;
constexpr int kParts = kLanes / kNative;
static_assert(kParts * kNative == kLanes, "whole vectors");

typedef double Doubles __attribute__((vector_size(kNative * sizeof(double))));
typedef std::int64_t Ints __attribute__((vector_size(kNative * sizeof(std::int64_t))));

inline Doubles splat(double x) {
#if DHKIN_NATIVE_WIDTH == 8
  return Doubles{x, x, x, x, x, x, x, x};
#elif DHKIN_NATIVE_WIDTH == 4
  return Doubles{x, x, x, x};
#else
  return Doubles{x, x};
#endif
}
inline Ints splat(std::int64_t x) {
#if DHKIN_NATIVE_WIDTH == 8
  return Ints{x, x, x, x, x, x, x, x};
#elif DHKIN_NATIVE_WIDTH == 4
  return Ints{x, x, x, x};
#else
  return Ints{x, x};
#endif
}
constexpr std::int64_t kSignBit = static_cast<std::int64_t>(0x8000000000000000ULL);

// Square roots (IEEE, correctly rounded) by the target's instruction.
DHKIN_INLINE Doubles sqrt(Doubles a) {
#if defined(__AVX512F__)
  return (Doubles)_mm512_mask_sqrt_pd((__m512d)a, 0xFF, (__m512d)a);  // every lane
#elif defined(__AVX__)
  return (Doubles)_mm256_sqrt_pd((__m256d)a);
#elif defined(__SSE2__)
  return (Doubles)_mm_sqrt_pd((__m128d)a);
#elif defined(__aarch64__) && defined(__ARM_NEON)
  return (Doubles)vsqrtq_f64((float64x2_t)a);
#else
  Doubles out;
  for (int i = 0; i < kNative; ++i) out[i] = std::sqrt(a[i]);
  return out;
#endif
}

// Whether any element is not zero.
DHKIN_INLINE bool any(Ints m) {
#if defined(__AVX512F__)
  return _mm512_test_epi64_mask((__m512i)m, (__m512i)m) != 0;
#elif defined(__AVX__)
  return _mm256_testz_si256((__m256i)m, (__m256i)m) == 0;
#elif defined(__SSE2__)
  return _mm_movemask_pd((__m128d)m) != 0;  // masks are all ones or zeros
#else
  std::int64_t bits = 0;
  for (int i = 0; i < kNative; ++i) bits |= m[i];
  return bits != 0;
#endif
}

// Element i of a part takes element i ^ m (0 <= m < kNative): shuffles within one register
// (lane by lane, a vector load would wait for the element stores; see Lanes::gather).
#if defined(__clang__)
#define DHKIN_SHUFFLE(a, ...) __builtin_shufflevector(a, a, __VA_ARGS__)
#else
#define DHKIN_SHUFFLE(a, ...) __builtin_shuffle(a, Ints{__VA_ARGS__})
#endif
template <class Vector>
DHKIN_INLINE Vector swapped_within(Vector a, int m) {
#if DHKIN_NATIVE_WIDTH == 4
  switch (m) {
    case 1: return DHKIN_SHUFFLE(a, 1, 0, 3, 2);
    case 2: return DHKIN_SHUFFLE(a, 2, 3, 0, 1);
    case 3: return DHKIN_SHUFFLE(a, 3, 2, 1, 0);
    default: return a;
  }
#elif DHKIN_NATIVE_WIDTH == 2
  return m == 1 ? DHKIN_SHUFFLE(a, 1, 0) : a;
#else
  Vector out;
  for (int i = 0; i < kNative; ++i) out[i] = a[i ^ m];
  return out;
#endif
}
#undef DHKIN_SHUFFLE

}  // namespace simd

// A true or false per lane (all bits set, or none).
struct Mask {
  simd::Ints v[simd::kParts];
};

// kLanes doubles.
struct Lanes {
  simd::Doubles v[simd::kParts];

  Lanes() : v{} {}
  explicit Lanes(double x) {  // the same number in every lane
    for (int k = 0; k < simd::kParts; ++k) v[k] = simd::splat(x);
  }
  // kLanes consecutive doubles from memory, and back.
  static Lanes load(const double* data) {
    Lanes out;
    std::memcpy(&out.v, data, sizeof out.v);
    return out;
  }
  void store(double* data) const { std::memcpy(data, &v, sizeof v); }
  // Lane l of values at `data` with this stride (doubles).
  // Built in registers: a vector load of values just stored one by one would wait until the
  // stores retire (a load wider than the stores that wrote its bytes cannot take them from the
  // store buffer).
  static Lanes gather(const double* data, int stride) {
    Lanes out;
    for (int k = 0; k < simd::kParts; ++k) {
      const double* d = data + k * simd::kNative * stride;
#if DHKIN_NATIVE_WIDTH == 8
      out.v[k] = simd::Doubles{d[0],          d[stride],     d[2 * stride], d[3 * stride],
                               d[4 * stride], d[5 * stride], d[6 * stride], d[7 * stride]};
#elif DHKIN_NATIVE_WIDTH == 4
      out.v[k] = simd::Doubles{d[0], d[stride], d[2 * stride], d[3 * stride]};
#else
      out.v[k] = simd::Doubles{d[0], d[stride]};
#endif
    }
    return out;
  }
  double operator[](int l) const { return v[l / simd::kNative][l % simd::kNative]; }
  void set(int l, double x) { v[l / simd::kNative][l % simd::kNative] = x; }
};

// Small integers per lane (singularity bits).
struct LaneBits {
  simd::Ints v[simd::kParts];

  LaneBits() : v{} {}
  explicit LaneBits(int x) {  // the same bits in every lane
    for (int k = 0; k < simd::kParts; ++k) v[k] = simd::splat(static_cast<std::int64_t>(x));
  }
};

// Part by part: out.v[k] = expression of the operands' parts k.
#define DHKIN_PARTS(Type, expression)                                 \
  Type out;                                                           \
  for (int k = 0; k < simd::kParts; ++k) out.v[k] = (expression);     \
  return out

DHKIN_INLINE Mask operator&&(Mask a, Mask b) { DHKIN_PARTS(Mask, a.v[k] & b.v[k]); }
DHKIN_INLINE Mask operator||(Mask a, Mask b) { DHKIN_PARTS(Mask, a.v[k] | b.v[k]); }
DHKIN_INLINE Mask operator!(Mask a) { DHKIN_PARTS(Mask, ~a.v[k]); }
// A condition that holds in every lane or in none (e.g. on a constant of the geometry).
DHKIN_INLINE Mask uniform(bool m) { DHKIN_PARTS(Mask, simd::splat(static_cast<std::int64_t>(m ? -1 : 0))); }
DHKIN_INLINE Mask operator&&(bool a, Mask b) { return uniform(a) && b; }
DHKIN_INLINE Mask operator&&(Mask a, bool b) { return a && uniform(b); }
DHKIN_INLINE Mask operator||(bool a, Mask b) { return uniform(a) || b; }
DHKIN_INLINE Mask operator||(Mask a, bool b) { return a || uniform(b); }
DHKIN_INLINE bool any(Mask m) {
  simd::Ints bits = m.v[0];
  for (int k = 1; k < simd::kParts; ++k) bits |= m.v[k];
  return simd::any(bits);
}
inline bool all(Mask m) { return !any(!m); }
inline bool lane(Mask m, int l) { return m.v[l / simd::kNative][l % simd::kNative] != 0; }
inline void set_lane(Mask& m, int l, bool x) { m.v[l / simd::kNative][l % simd::kNative] = x ? -1 : 0; }

DHKIN_INLINE Lanes operator+(Lanes a, Lanes b) { DHKIN_PARTS(Lanes, a.v[k] + b.v[k]); }
DHKIN_INLINE Lanes operator-(Lanes a, Lanes b) { DHKIN_PARTS(Lanes, a.v[k] - b.v[k]); }
DHKIN_INLINE Lanes operator*(Lanes a, Lanes b) { DHKIN_PARTS(Lanes, a.v[k] * b.v[k]); }
DHKIN_INLINE Lanes operator/(Lanes a, Lanes b) { DHKIN_PARTS(Lanes, a.v[k] / b.v[k]); }
DHKIN_INLINE Lanes operator+(Lanes a, double b) { DHKIN_PARTS(Lanes, a.v[k] + b); }
DHKIN_INLINE Lanes operator-(Lanes a, double b) { DHKIN_PARTS(Lanes, a.v[k] - b); }
DHKIN_INLINE Lanes operator*(Lanes a, double b) { DHKIN_PARTS(Lanes, a.v[k] * b); }
DHKIN_INLINE Lanes operator/(Lanes a, double b) { DHKIN_PARTS(Lanes, a.v[k] / b); }
DHKIN_INLINE Lanes operator+(double a, Lanes b) { DHKIN_PARTS(Lanes, a + b.v[k]); }
DHKIN_INLINE Lanes operator-(double a, Lanes b) { DHKIN_PARTS(Lanes, a - b.v[k]); }
DHKIN_INLINE Lanes operator*(double a, Lanes b) { DHKIN_PARTS(Lanes, a * b.v[k]); }
DHKIN_INLINE Lanes operator/(double a, Lanes b) { DHKIN_PARTS(Lanes, a / b.v[k]); }
DHKIN_INLINE Lanes operator-(Lanes a) { DHKIN_PARTS(Lanes, -a.v[k]); }  // the sign flipped
DHKIN_INLINE Lanes& operator+=(Lanes& a, Lanes b) { return a = a + b; }
DHKIN_INLINE Lanes& operator-=(Lanes& a, Lanes b) { return a = a - b; }

DHKIN_INLINE Mask operator<(Lanes a, Lanes b) { DHKIN_PARTS(Mask, a.v[k] < b.v[k]); }
DHKIN_INLINE Mask operator<=(Lanes a, Lanes b) { DHKIN_PARTS(Mask, a.v[k] <= b.v[k]); }
DHKIN_INLINE Mask operator>(Lanes a, Lanes b) { DHKIN_PARTS(Mask, a.v[k] > b.v[k]); }
DHKIN_INLINE Mask operator>=(Lanes a, Lanes b) { DHKIN_PARTS(Mask, a.v[k] >= b.v[k]); }
DHKIN_INLINE Mask operator==(Lanes a, Lanes b) { DHKIN_PARTS(Mask, a.v[k] == b.v[k]); }
DHKIN_INLINE Mask operator!=(Lanes a, Lanes b) { DHKIN_PARTS(Mask, a.v[k] != b.v[k]); }
DHKIN_INLINE Mask operator<(Lanes a, double b) { DHKIN_PARTS(Mask, a.v[k] < b); }
DHKIN_INLINE Mask operator<=(Lanes a, double b) { DHKIN_PARTS(Mask, a.v[k] <= b); }
DHKIN_INLINE Mask operator>(Lanes a, double b) { DHKIN_PARTS(Mask, a.v[k] > b); }
DHKIN_INLINE Mask operator>=(Lanes a, double b) { DHKIN_PARTS(Mask, a.v[k] >= b); }
DHKIN_INLINE Mask operator==(Lanes a, double b) { DHKIN_PARTS(Mask, a.v[k] == b); }
DHKIN_INLINE Mask operator!=(Lanes a, double b) { DHKIN_PARTS(Mask, a.v[k] != b); }
DHKIN_INLINE Mask operator<(double a, Lanes b) { DHKIN_PARTS(Mask, a < b.v[k]); }
DHKIN_INLINE Mask operator<=(double a, Lanes b) { DHKIN_PARTS(Mask, a <= b.v[k]); }
DHKIN_INLINE Mask operator>(double a, Lanes b) { DHKIN_PARTS(Mask, a > b.v[k]); }
DHKIN_INLINE Mask operator>=(double a, Lanes b) { DHKIN_PARTS(Mask, a >= b.v[k]); }

DHKIN_INLINE Lanes select(Mask m, Lanes a, Lanes b) { DHKIN_PARTS(Lanes, m.v[k] ? a.v[k] : b.v[k]); }
DHKIN_INLINE Lanes sqrt(Lanes a) { DHKIN_PARTS(Lanes, simd::sqrt(a.v[k])); }
DHKIN_INLINE Lanes abs(Lanes a) {
  DHKIN_PARTS(Lanes, (simd::Doubles)((simd::Ints)a.v[k] & ~simd::kSignBit));
}
DHKIN_INLINE Lanes copysign(Lanes magnitude, Lanes sign) {
  DHKIN_PARTS(Lanes, (simd::Doubles)(((simd::Ints)magnitude.v[k] & ~simd::kSignBit) |
                                     ((simd::Ints)sign.v[k] & simd::kSignBit)));
}
// !(|x| < limit) lane by lane (NaN included), for a positive limit: on the bits, as the order
// of non-negative doubles (and NaN above infinity) is that of their bit patterns.
DHKIN_INLINE Mask outside(Lanes x, double limit) {
  std::int64_t bound;
  std::memcpy(&bound, &limit, sizeof bound);
  DHKIN_PARTS(Mask, ((simd::Ints)x.v[k] & ~simd::kSignBit) >= bound);
}
// std::max(a, b) and std::min(a, b) lane by lane: (a < b) ? b : a, (b < a) ? b : a.
DHKIN_INLINE Lanes max(Lanes a, Lanes b) { return select(a < b, b, a); }
DHKIN_INLINE Lanes min(Lanes a, Lanes b) { return select(b < a, b, a); }
inline double lane(const Lanes& a, int l) { return a[l]; }
inline void set_lane(Lanes& a, int l, double x) { a.set(l, x); }

// floor, ceil and nearbyint (half to even) lane by lane, as the C library's: x + 1.5 * 2^52
// rounds |x| < 2^51 to a whole number; the sign of x is kept (-0.3 gives -0); larger values and
// NaN go to the C library.
namespace simd {
constexpr double kWholeRounder = 6755399441055744.0;  // 1.5 * 2^52
template <class Round>
DHKIN_INLINE Lanes whole(Lanes x, Round&& c_library, int direction) {
  Lanes nearest;
  for (int k = 0; k < kParts; ++k) nearest.v[k] = (x.v[k] + kWholeRounder) - kWholeRounder;
  Lanes out = direction < 0   ? select(nearest > x, nearest - 1.0, nearest)
              : direction > 0 ? select(nearest < x, nearest + 1.0, nearest)
                              : nearest;
  out = copysign(out, x);
  const Mask outside = !(abs(x) < 2251799813685248.0);  // 2^51
  if (any(outside)) {
    for (int l = 0; l < kLanes; ++l) {
      if (lane(outside, l)) out.set(l, c_library(x[l]));
    }
  }
  return out;
}
}  // namespace simd
DHKIN_INLINE Lanes floor(Lanes x) { return simd::whole(x, [](double v) { return std::floor(v); }, -1); }
DHKIN_INLINE Lanes ceil(Lanes x) { return simd::whole(x, [](double v) { return std::ceil(v); }, 1); }
DHKIN_INLINE Lanes nearbyint(Lanes x) {
  return simd::whole(x, [](double v) { return std::nearbyint(v); }, 0);
}

DHKIN_INLINE LaneBits operator|(LaneBits a, LaneBits b) { DHKIN_PARTS(LaneBits, a.v[k] | b.v[k]); }
DHKIN_INLINE LaneBits operator&(LaneBits a, LaneBits b) { DHKIN_PARTS(LaneBits, a.v[k] & b.v[k]); }
DHKIN_INLINE LaneBits operator&(LaneBits a, int b) {
  DHKIN_PARTS(LaneBits, a.v[k] & static_cast<std::int64_t>(b));
}
DHKIN_INLINE LaneBits operator+(LaneBits a, int b) {
  DHKIN_PARTS(LaneBits, a.v[k] + static_cast<std::int64_t>(b));
}
DHKIN_INLINE LaneBits operator~(LaneBits a) { DHKIN_PARTS(LaneBits, ~a.v[k]); }
DHKIN_INLINE Mask operator!=(LaneBits a, int b) {
  DHKIN_PARTS(Mask, a.v[k] != static_cast<std::int64_t>(b));
}
DHKIN_INLINE Mask operator!=(LaneBits a, LaneBits b) { DHKIN_PARTS(Mask, a.v[k] != b.v[k]); }
DHKIN_INLINE Mask operator==(LaneBits a, int b) {
  DHKIN_PARTS(Mask, a.v[k] == static_cast<std::int64_t>(b));
}
DHKIN_INLINE LaneBits select(Mask m, LaneBits a, LaneBits b) {
  DHKIN_PARTS(LaneBits, m.v[k] ? a.v[k] : b.v[k]);
}
// The bits of each lane of a (reinterpreted, not converted).
DHKIN_INLINE LaneBits bits_of(Lanes a) { DHKIN_PARTS(LaneBits, (simd::Ints)a.v[k]); }
inline int lane(const LaneBits& a, int l) {
  return static_cast<int>(a.v[l / simd::kNative][l % simd::kNative]);
}
inline void set_lane(LaneBits& a, int l, int x) { a.v[l / simd::kNative][l % simd::kNative] = x; }

#undef DHKIN_PARTS

// Lanes and masks with lane l taken from lane l ^ m (0 < m < kLanes): the pairs of lanes whose
// indices differ by the bits of m swapped.
DHKIN_INLINE Lanes swapped(const Lanes& a, int m) {
#if defined(__AVX512F__)
  const __m512i index = _mm512_xor_si512(_mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0),
                                         _mm512_set1_epi64(m));
  Lanes out;
  // the masked form with every lane set (the plain one trips GCC 12's -Wmaybe-uninitialized)
  out.v[0] = (simd::Doubles)_mm512_mask_permutexvar_pd((__m512d)a.v[0], 0xFF, index,
                                                       (__m512d)a.v[0]);
  return out;
#else
  Lanes out;
  for (int k = 0; k < simd::kParts; ++k) {
    out.v[k] = simd::swapped_within(a.v[k ^ (m / simd::kNative)], m % simd::kNative);
  }
  return out;
#endif
}
DHKIN_INLINE Mask swapped(const Mask& a, int m) {
  Mask out;
  for (int k = 0; k < simd::kParts; ++k) {
    out.v[k] = simd::swapped_within(a.v[k ^ (m / simd::kNative)], m % simd::kNative);
  }
  return out;
}

// ---- the scalar lane type: double, bool and small integers ------------------------------------

inline double select(bool m, double a, double b) { return m ? a : b; }
inline std::uint8_t select(bool m, std::uint8_t a, std::uint8_t b) { return m ? a : b; }
DHKIN_INLINE bool any(bool m) { return m; }
inline bool all(bool m) { return m; }
inline double lane(double a, int) { return a; }
inline bool lane(bool a, int) { return a; }
inline int lane(std::uint8_t a, int) { return a; }
inline void set_lane(double& a, int, double x) { a = x; }
inline void set_lane(bool& a, int, bool x) { a = x; }
inline void set_lane(std::uint8_t& a, int, int x) { a = static_cast<std::uint8_t>(x); }
inline double max(double a, double b) { return a < b ? b : a; }
inline double min(double a, double b) { return b < a ? b : a; }
inline double sqrt(double a) { return std::sqrt(a); }
inline double abs(double a) { return std::fabs(a); }
inline double copysign(double magnitude, double sign) { return std::copysign(magnitude, sign); }
inline double floor(double a) { return std::floor(a); }
inline double ceil(double a) { return std::ceil(a); }
inline double nearbyint(double a) { return std::nearbyint(a); }
inline bool outside(double x, double limit) { return !(std::fabs(x) < limit); }

// What a lane type comes with: its mask, its small integers, its number of lanes.
template <class V>
struct LaneTraits;

template <>
struct LaneTraits<double> {
  using MaskType = bool;
  using BitsType = std::uint8_t;
  static constexpr int width = 1;
};

template <>
struct LaneTraits<Lanes> {
  using MaskType = Mask;
  using BitsType = LaneBits;
  static constexpr int width = kLanes;
};

template <class V>
using MaskOf = typename LaneTraits<V>::MaskType;
template <class V>
using BitsOf = typename LaneTraits<V>::BitsType;
template <class V>
constexpr int kWidth = LaneTraits<V>::width;

// A condition that holds in every lane or in none.
template <class V>
inline MaskOf<V> every_lane(bool m);
template <>
inline bool every_lane<double>(bool m) { return m; }
template <>
inline Mask every_lane<Lanes>(bool m) { return uniform(m); }

// `bit` where `m` holds, else none.
inline std::uint8_t bits_if(bool m, std::uint8_t bit) { return m ? bit : 0; }
inline LaneBits bits_if(Mask m, std::uint8_t bit) {
  LaneBits out;
  for (int k = 0; k < simd::kParts; ++k) out.v[k] = m.v[k] & static_cast<std::int64_t>(bit);
  return out;
}

// fn(l) for each lane l where m holds (a rare case, one lane at a time).
template <class Fn>
inline void for_each_lane(bool m, Fn&& fn) {
  if (m) fn(0);
}
template <class Fn>
inline void for_each_lane(Mask m, Fn&& fn) {
  if (!any(m)) return;
  for (int l = 0; l < kLanes; ++l) {
    if (lane(m, l)) fn(l);
  }
}

}  // namespace dhkin
