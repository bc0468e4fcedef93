// Rigid transforms in three dimensions: vectors, rotations and frames (rotation + translation).
//
// A Frame maps coordinates in its own frame to its parent's: x_parent = R x + p. Matrices are
// row-major (R[row][column]). Lengths are metres, angles radians. Vectors and frames are written
// once for a lane type V (simd.hpp): Vec3 and Frame hold doubles, Vec3T<Lanes> and
// FrameT<Lanes> one vector or frame per lane; operations mix them (a constant frame of the
// geometry times the frames of kLanes poses), with the same operations in the same order.
#pragma once

#include <cmath>

#include "dhkin/simd.hpp"

namespace dhkin {

template <class V>
struct Vec3T {
  V x{}, y{}, z{};
};
using Vec3 = Vec3T<double>;

template <class A, class B>
using Product = decltype(A{} * B{});

template <class A, class B>
DHKIN_INLINE Vec3T<Product<A, B>> operator+(const Vec3T<A>& a, const Vec3T<B>& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class A, class B>
DHKIN_INLINE Vec3T<Product<A, B>> operator-(const Vec3T<A>& a, const Vec3T<B>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class S, class A>
DHKIN_INLINE Vec3T<Product<S, A>> operator*(S s, const Vec3T<A>& a) {
  return {s * a.x, s * a.y, s * a.z};
}
template <class A, class B>
DHKIN_INLINE Product<A, B> dot(const Vec3T<A>& a, const Vec3T<B>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class A, class B>
DHKIN_INLINE Vec3T<Product<A, B>> cross(const Vec3T<A>& a, const Vec3T<B>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class V>
DHKIN_INLINE V norm(const Vec3T<V>& a) {
  return sqrt(dot(a, a));
}

// norm(a) <= limit for limit >= 0: the same answer, with the square root taken only where some
// lane has |a|^2 <= 4 limit^2 (elsewhere |a| > 2 limit, rounding included).
template <class V>
DHKIN_INLINE MaskOf<V> norm_at_most(const Vec3T<V>& a, double limit) {
  const V squared = dot(a, a);
  auto maybe = !(squared > 4.0 * limit * limit);
  if (any(maybe)) maybe = maybe && sqrt(squared) <= limit;
  return maybe;
}

// Lane l of a vector of lanes.
inline Vec3 lane(const Vec3T<Lanes>& a, int l) { return {lane(a.x, l), lane(a.y, l), lane(a.z, l)}; }
inline Vec3 lane(const Vec3& a, int) { return a; }
template <class V>
inline void set_lane(Vec3T<V>& a, int l, const Vec3& x) {
  set_lane(a.x, l, x.x), set_lane(a.y, l, x.y), set_lane(a.z, l, x.z);
}

// A 3x3 matrix, row-major (constants of a geometry).
struct Mat3 {
  double m[3][3] = {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}};

  Vec3 row(int r) const { return {m[r][0], m[r][1], m[r][2]}; }
  Vec3 column(int c) const { return {m[0][c], m[1][c], m[2][c]}; }
  template <class V>
  Vec3T<V> operator*(const Vec3T<V>& v) const {
    return {dot(row(0), v), dot(row(1), v), dot(row(2), v)};
  }
  // M^T v
  template <class V>
  Vec3T<V> transposed_times(const Vec3T<V>& v) const {
    return {m[0][0] * v.x + m[1][0] * v.y + m[2][0] * v.z,
            m[0][1] * v.x + m[1][1] * v.y + m[2][1] * v.z,
            m[0][2] * v.x + m[1][2] * v.y + m[2][2] * v.z};
  }
};

// A rigid transform: rotation R, translation p (3 x 4, the top rows of the 4 x 4 matrix); the
// identity unless given.
template <class V>
struct FrameT {
  V R[3][3] = {{V(1.0), V(0.0), V(0.0)}, {V(0.0), V(1.0), V(0.0)}, {V(0.0), V(0.0), V(1.0)}};
  V p[3] = {V(0.0), V(0.0), V(0.0)};

  Vec3T<V> translation() const { return {p[0], p[1], p[2]}; }
  Vec3T<V> column(int c) const { return {R[0][c], R[1][c], R[2][c]}; }
  // R v + p
  template <class W>
  Vec3T<Product<V, W>> apply(const Vec3T<W>& v) const {
    return {R[0][0] * v.x + R[0][1] * v.y + R[0][2] * v.z + p[0],
            R[1][0] * v.x + R[1][1] * v.y + R[1][2] * v.z + p[1],
            R[2][0] * v.x + R[2][1] * v.y + R[2][2] * v.z + p[2]};
  }
  // R v
  template <class W>
  Vec3T<Product<V, W>> rotate(const Vec3T<W>& v) const {
    return {R[0][0] * v.x + R[0][1] * v.y + R[0][2] * v.z,
            R[1][0] * v.x + R[1][1] * v.y + R[1][2] * v.z,
            R[2][0] * v.x + R[2][1] * v.y + R[2][2] * v.z};
  }
};
using Frame = FrameT<double>;

// The same frame in every lane.
template <class V>
inline FrameT<V> broadcast(const Frame& f) {
  FrameT<V> out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.R[r][c] = V(f.R[r][c]);
    out.p[r] = V(f.p[r]);
  }
  return out;
}

// a * b
template <class A, class B>
DHKIN_INLINE FrameT<Product<A, B>> operator*(const FrameT<A>& a, const FrameT<B>& b) {
  FrameT<Product<A, B>> out;
  for (int r = 0; r < 3; ++r) {
    const A a0 = a.R[r][0], a1 = a.R[r][1], a2 = a.R[r][2];
    out.R[r][0] = a0 * b.R[0][0] + a1 * b.R[1][0] + a2 * b.R[2][0];
    out.R[r][1] = a0 * b.R[0][1] + a1 * b.R[1][1] + a2 * b.R[2][1];
    out.R[r][2] = a0 * b.R[0][2] + a1 * b.R[1][2] + a2 * b.R[2][2];
    out.p[r] = a0 * b.p[0] + a1 * b.p[1] + a2 * b.p[2] + a.p[r];
  }
  return out;
}

// The inverse of a rigid transform.
template <class V>
inline FrameT<V> inverse(const FrameT<V>& f) {
  FrameT<V> out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.R[r][c] = f.R[c][r];
  }
  for (int r = 0; r < 3; ++r) {
    out.p[r] = -(f.R[0][r] * f.p[0] + f.R[1][r] * f.p[1] + f.R[2][r] * f.p[2]);
  }
  return out;
}

// f = f * Rz(angle), given the angle's cosine and sine.
template <class V>
DHKIN_INLINE void turn_about_z(FrameT<V>& f, V c, V s) {
  for (int r = 0; r < 3; ++r) {
    const V x = f.R[r][0], y = f.R[r][1];
    f.R[r][0] = c * x + s * y;
    f.R[r][1] = c * y - s * x;
  }
}

// f = f * Tz(distance).
template <class V>
DHKIN_INLINE void slide_along_z(FrameT<V>& f, V distance) {
  for (int r = 0; r < 3; ++r) f.p[r] += distance * f.R[r][2];
}

// f = f * Tr(point): the same frame moved to `point` (given in f's coordinates).
template <class V>
DHKIN_INLINE FrameT<V> moved_to(const FrameT<V>& f, const Vec3& point) {
  FrameT<V> out = f;
  const Vec3T<V> shift = f.rotate(point);
  out.p[0] += shift.x;
  out.p[1] += shift.y;
  out.p[2] += shift.z;
  return out;
}

// Lane l of frames of lanes.
inline Frame lane(const FrameT<Lanes>& f, int l) {
  Frame out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.R[r][c] = lane(f.R[r][c], l);
    out.p[r] = lane(f.p[r], l);
  }
  return out;
}
inline Frame lane(const Frame& f, int) { return f; }
// Lane l of frames of lanes set to f.
inline void set_lane(FrameT<Lanes>& out, int l, const Frame& f) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) set_lane(out.R[r][c], l, f.R[r][c]);
    set_lane(out.p[r], l, f.p[r]);
  }
}

// The rotation by the rotation vector w (Rodrigues' formula; first order below 1e-12 rad,
// exact to rounding at that size).
inline Frame rotation_vector(const Vec3& w) {
  const double angle = norm(w);
  double k0, k1, k2, a, b;
  if (angle > 1e-12) {
    k0 = w.x / angle, k1 = w.y / angle, k2 = w.z / angle;
    a = std::sin(angle), b = 1.0 - std::cos(angle);
  } else {
    k0 = w.x, k1 = w.y, k2 = w.z;
    a = 1.0, b = 0.0;
  }
  Frame out;
  out.R[0][0] = 1.0 - b * (k1 * k1 + k2 * k2);
  out.R[1][1] = 1.0 - b * (k0 * k0 + k2 * k2);
  out.R[2][2] = 1.0 - b * (k0 * k0 + k1 * k1);
  out.R[0][1] = -a * k2 + b * k0 * k1;
  out.R[1][0] = a * k2 + b * k0 * k1;
  out.R[0][2] = a * k1 + b * k0 * k2;
  out.R[2][0] = -a * k1 + b * k0 * k2;
  out.R[1][2] = -a * k0 + b * k1 * k2;
  out.R[2][1] = a * k0 + b * k1 * k2;
  return out;
}

// Rotation of v by the angle with cosine c and sine s about the unit vector k.
template <class V, class W>
DHKIN_INLINE Vec3T<Product<V, W>> rotate_about(const Vec3& k, V c, V s, const Vec3T<W>& v) {
  using T = Product<V, W>;
  const T along = (1.0 - c) * dot(k, v);
  return {c * v.x + s * (k.y * v.z - k.z * v.y) + along * k.x,
          c * v.y + s * (k.z * v.x - k.x * v.z) + along * k.y,
          c * v.z + s * (k.x * v.y - k.y * v.x) + along * k.z};
}

}  // namespace dhkin
