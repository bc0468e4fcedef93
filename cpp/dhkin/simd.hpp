// The lane types: kLanes doubles worked on at once (one pose or one branch per lane), so that
// code written once for a lane type V runs on one value (V = double) or on kLanes values
// (V = Lanes) in the machine's vector registers.
//
// Lanes and Mask wrap the compiler's vector types (GCC and Clang vector extensions): arithmetic
// is element by element and IEEE, so each lane gives the same bits as the same operations on a
// double. The build keeps -ffp-contract=off (no fused multiply-adds) and turns the compiler's
// own vectoriser off (-fno-tree-vectorize: GCC's SLP vectoriser fuses a multiply into an
// alternating add/subtract, vfmaddsub, despite -ffp-contract=off), so that vector code is only
// what is written here. Code generic in V uses only what both provide: + - * / and comparisons,
// select(mask, a, b) for a ? b : c, sqrt, abs, max and min (defined as std::max and std::min
// are, NaN included), any(mask), and lane(v, l) / set_lane(v, l, x) to run a rare case one lane
// at a time.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__AVX512F__) || defined(__AVX__) || defined(__SSE2__)
#include <immintrin.h>
#elif defined(__aarch64__) && defined(__ARM_NEON)
#include <arm_neon.h>
#endif

namespace dhkin {

// Lanes of one vector: 8 doubles (one AVX-512 register, two AVX ones); a pose's eight branches
// fill one.
constexpr int kLanes = 8;

namespace simd {
typedef double DoubleVector __attribute__((vector_size(kLanes * sizeof(double))));
typedef std::int64_t IntVector __attribute__((vector_size(kLanes * sizeof(std::int64_t))));
typedef double HalfVector __attribute__((vector_size(kLanes / 2 * sizeof(double))));
typedef double QuarterVector __attribute__((vector_size(kLanes / 4 * sizeof(double))));
static_assert(kLanes == 8, "the constructors below spell out eight lanes");

inline DoubleVector splat(double x) { return DoubleVector{x, x, x, x, x, x, x, x}; }
inline IntVector splat(std::int64_t x) { return IntVector{x, x, x, x, x, x, x, x}; }
constexpr std::int64_t kSignBit = static_cast<std::int64_t>(0x8000000000000000ULL);

// Square roots lane by lane (IEEE, correctly rounded), by the instruction the target has.
inline DoubleVector sqrt(DoubleVector a) {
#if defined(__AVX512F__)
  return (DoubleVector)_mm512_mask_sqrt_pd((__m512d)a, 0xFF, (__m512d)a);  // every lane
#elif defined(__AVX__)
  const HalfVector low = __builtin_shufflevector(a, a, 0, 1, 2, 3);
  const HalfVector high = __builtin_shufflevector(a, a, 4, 5, 6, 7);
  const HalfVector r0 = (HalfVector)_mm256_sqrt_pd((__m256d)low);
  const HalfVector r1 = (HalfVector)_mm256_sqrt_pd((__m256d)high);
  return __builtin_shufflevector(r0, r1, 0, 1, 2, 3, 4, 5, 6, 7);
#elif defined(__SSE2__) || (defined(__aarch64__) && defined(__ARM_NEON))
  QuarterVector part[4];
  for (int k = 0; k < 4; ++k) {
    const QuarterVector q = {a[2 * k], a[2 * k + 1]};
#if defined(__SSE2__)
    part[k] = (QuarterVector)_mm_sqrt_pd((__m128d)q);
#else
    part[k] = (QuarterVector)vsqrtq_f64((float64x2_t)q);
#endif
  }
  return DoubleVector{part[0][0], part[0][1], part[1][0], part[1][1],
                      part[2][0], part[2][1], part[3][0], part[3][1]};
#else
  DoubleVector out;
  for (int l = 0; l < kLanes; ++l) out[l] = std::sqrt(a[l]);
  return out;
#endif
}

// Whether any lane is not zero.
inline bool any(IntVector m) {
  typedef std::int64_t Half __attribute__((vector_size(kLanes / 2 * sizeof(std::int64_t))));
  typedef std::int64_t Quarter __attribute__((vector_size(kLanes / 4 * sizeof(std::int64_t))));
  const Half h = __builtin_shufflevector(m, m, 0, 1, 2, 3) | __builtin_shufflevector(m, m, 4, 5, 6, 7);
  const Quarter q = __builtin_shufflevector(h, h, 0, 1) | __builtin_shufflevector(h, h, 2, 3);
  return (q[0] | q[1]) != 0;
}
}  // namespace simd

// A true or false per lane (all bits set, or none).
struct Mask {
  simd::IntVector v;
};

inline Mask operator&&(Mask a, Mask b) { return {a.v & b.v}; }
inline Mask operator||(Mask a, Mask b) { return {a.v | b.v}; }
inline Mask operator!(Mask a) { return {~a.v}; }
// A condition that holds in every lane or in none (e.g. on a constant of the geometry).
inline Mask uniform(bool m) { return {simd::splat(static_cast<std::int64_t>(m ? -1 : 0))}; }
inline Mask operator&&(bool a, Mask b) { return uniform(a) && b; }
inline Mask operator&&(Mask a, bool b) { return a && uniform(b); }
inline Mask operator||(bool a, Mask b) { return uniform(a) || b; }
inline Mask operator||(Mask a, bool b) { return a || uniform(b); }
inline bool any(Mask m) { return simd::any(m.v); }
inline bool all(Mask m) { return !simd::any(~m.v); }
inline bool lane(Mask m, int l) { return m.v[l] != 0; }
inline void set_lane(Mask& m, int l, bool x) { m.v[l] = x ? -1 : 0; }

// kLanes doubles.
struct Lanes {
  simd::DoubleVector v;

  Lanes() : v{} {}
  explicit Lanes(double x) : v(simd::splat(x)) {}  // the same number in every lane
  static Lanes of(simd::DoubleVector x) {
    Lanes out;
    out.v = x;
    return out;
  }
  // kLanes consecutive doubles from memory, and back.
  static Lanes load(const double* data) {
    Lanes out;
    std::memcpy(&out.v, data, sizeof out.v);
    return out;
  }
  void store(double* data) const { std::memcpy(data, &v, sizeof v); }
  // Lane l of values at `data` with this stride (doubles).
  static Lanes gather(const double* data, int stride) {
    return of(simd::DoubleVector{data[0], data[stride], data[2 * stride], data[3 * stride],
                                 data[4 * stride], data[5 * stride], data[6 * stride],
                                 data[7 * stride]});
  }
  Lanes& operator+=(Lanes b) { v += b.v; return *this; }
  Lanes& operator-=(Lanes b) { v -= b.v; return *this; }
};

inline Lanes operator+(Lanes a, Lanes b) { return Lanes::of(a.v + b.v); }
inline Lanes operator-(Lanes a, Lanes b) { return Lanes::of(a.v - b.v); }
inline Lanes operator*(Lanes a, Lanes b) { return Lanes::of(a.v * b.v); }
inline Lanes operator/(Lanes a, Lanes b) { return Lanes::of(a.v / b.v); }
inline Lanes operator+(Lanes a, double b) { return Lanes::of(a.v + b); }
inline Lanes operator-(Lanes a, double b) { return Lanes::of(a.v - b); }
inline Lanes operator*(Lanes a, double b) { return Lanes::of(a.v * b); }
inline Lanes operator/(Lanes a, double b) { return Lanes::of(a.v / b); }
inline Lanes operator+(double a, Lanes b) { return Lanes::of(a + b.v); }
inline Lanes operator-(double a, Lanes b) { return Lanes::of(a - b.v); }
inline Lanes operator*(double a, Lanes b) { return Lanes::of(a * b.v); }
inline Lanes operator/(double a, Lanes b) { return Lanes::of(a / b.v); }
inline Lanes operator-(Lanes a) { return Lanes::of(-a.v); }  // the sign flipped, as for a double

inline Mask operator<(Lanes a, Lanes b) { return {a.v < b.v}; }
inline Mask operator<=(Lanes a, Lanes b) { return {a.v <= b.v}; }
inline Mask operator>(Lanes a, Lanes b) { return {a.v > b.v}; }
inline Mask operator>=(Lanes a, Lanes b) { return {a.v >= b.v}; }
inline Mask operator==(Lanes a, Lanes b) { return {a.v == b.v}; }
inline Mask operator!=(Lanes a, Lanes b) { return {a.v != b.v}; }
inline Mask operator<(Lanes a, double b) { return {a.v < b}; }
inline Mask operator<=(Lanes a, double b) { return {a.v <= b}; }
inline Mask operator>(Lanes a, double b) { return {a.v > b}; }
inline Mask operator>=(Lanes a, double b) { return {a.v >= b}; }
inline Mask operator==(Lanes a, double b) { return {a.v == b}; }
inline Mask operator!=(Lanes a, double b) { return {a.v != b}; }
inline Mask operator<(double a, Lanes b) { return {a < b.v}; }
inline Mask operator<=(double a, Lanes b) { return {a <= b.v}; }
inline Mask operator>(double a, Lanes b) { return {a > b.v}; }
inline Mask operator>=(double a, Lanes b) { return {a >= b.v}; }

inline Lanes select(Mask m, Lanes a, Lanes b) { return Lanes::of(m.v ? a.v : b.v); }
inline Lanes sqrt(Lanes a) { return Lanes::of(simd::sqrt(a.v)); }
inline Lanes abs(Lanes a) {
  return Lanes::of((simd::DoubleVector)((simd::IntVector)a.v & ~simd::kSignBit));
}
// std::max(a, b) and std::min(a, b) lane by lane: (a < b) ? b : a, (b < a) ? b : a.
inline Lanes max(Lanes a, Lanes b) { return select(a < b, b, a); }
inline Lanes min(Lanes a, Lanes b) { return select(b < a, b, a); }
inline Lanes copysign(Lanes magnitude, Lanes sign) {
  const simd::IntVector m = (simd::IntVector)magnitude.v, s = (simd::IntVector)sign.v;
  return Lanes::of((simd::DoubleVector)((m & ~simd::kSignBit) | (s & simd::kSignBit)));
}
// floor, ceil and nearbyint (half to even) lane by lane, as the C library's: x + 1.5 * 2^52
// rounds |x| < 2^51 to a whole number; the sign of x is kept (-0.3 gives -0); larger values and
// NaN go to the C library.
namespace simd {
constexpr double kWholeRounder = 6755399441055744.0;  // 1.5 * 2^52
template <class Round>
inline Lanes whole(Lanes x, Round&& c_library, int direction) {
  const Lanes nearest = Lanes::of((x.v + kWholeRounder) - kWholeRounder);
  Lanes out = direction < 0   ? select(nearest > x, nearest - 1.0, nearest)
              : direction > 0 ? select(nearest < x, nearest + 1.0, nearest)
                              : nearest;
  out = copysign(out, x);
  const Mask outside = !(abs(x) < 2251799813685248.0);  // 2^51
  if (any(outside)) {
    for (int l = 0; l < kLanes; ++l) {
      if (outside.v[l] != 0) out.v[l] = c_library(x.v[l]);
    }
  }
  return out;
}
}  // namespace simd
inline Lanes floor(Lanes x) { return simd::whole(x, [](double v) { return std::floor(v); }, -1); }
inline Lanes ceil(Lanes x) { return simd::whole(x, [](double v) { return std::ceil(v); }, 1); }
inline Lanes nearbyint(Lanes x) {
  return simd::whole(x, [](double v) { return std::nearbyint(v); }, 0);
}
inline double lane(Lanes a, int l) { return a.v[l]; }
inline void set_lane(Lanes& a, int l, double x) { a.v[l] = x; }

// Small integers per lane (singularity bits).
struct LaneBits {
  simd::IntVector v;

  LaneBits() : v{} {}
  explicit LaneBits(int x) : v(simd::splat(static_cast<std::int64_t>(x))) {}  // in every lane
  LaneBits& operator|=(LaneBits b) { v |= b.v; return *this; }
};
inline LaneBits operator|(LaneBits a, LaneBits b) { LaneBits o; o.v = a.v | b.v; return o; }
inline LaneBits operator&(LaneBits a, LaneBits b) { LaneBits o; o.v = a.v & b.v; return o; }
inline LaneBits operator&(LaneBits a, int b) { LaneBits o; o.v = a.v & b; return o; }
inline LaneBits operator+(LaneBits a, int b) { LaneBits o; o.v = a.v + b; return o; }
inline LaneBits operator~(LaneBits a) { LaneBits o; o.v = ~a.v; return o; }
inline Mask operator!=(LaneBits a, int b) { return {a.v != b}; }
inline Mask operator==(LaneBits a, int b) { return {a.v == b}; }
inline LaneBits select(Mask m, LaneBits a, LaneBits b) { LaneBits o; o.v = m.v ? a.v : b.v; return o; }
inline int lane(LaneBits a, int l) { return static_cast<int>(a.v[l]); }
inline void set_lane(LaneBits& a, int l, int x) { a.v[l] = x; }

// ---- the scalar lane type: double, bool and small integers ------------------------------------

inline double select(bool m, double a, double b) { return m ? a : b; }
inline std::uint8_t select(bool m, std::uint8_t a, std::uint8_t b) { return m ? a : b; }
inline bool any(bool m) { return m; }
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
  LaneBits o;
  o.v = m.v & static_cast<std::int64_t>(bit);
  return o;
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
    if (m.v[l] != 0) fn(l);
  }
}

}  // namespace dhkin
