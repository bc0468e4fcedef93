// Rigid transforms in three dimensions: vectors, rotations and frames (rotation + translation).
//
// A Frame maps coordinates in its own frame to its parent's: x_parent = R x + p. Matrices are
// row-major (R[row][column]). Lengths are metres, angles radians.
#pragma once

#include <cmath>

namespace dhkin {

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
};

inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(double s, const Vec3& a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }

// A 3x3 matrix, row-major.
struct Mat3 {
  double m[3][3] = {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}};

  Vec3 row(int r) const { return {m[r][0], m[r][1], m[r][2]}; }
  Vec3 column(int c) const { return {m[0][c], m[1][c], m[2][c]}; }
  Vec3 operator*(const Vec3& v) const { return {dot(row(0), v), dot(row(1), v), dot(row(2), v)}; }
  // M^T v
  Vec3 transposed_times(const Vec3& v) const {
    return {m[0][0] * v.x + m[1][0] * v.y + m[2][0] * v.z,
            m[0][1] * v.x + m[1][1] * v.y + m[2][1] * v.z,
            m[0][2] * v.x + m[1][2] * v.y + m[2][2] * v.z};
  }
};

// A rigid transform: rotation R, translation p (3 x 4, the top rows of the 4 x 4 matrix).
struct Frame {
  double R[3][3] = {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}};
  double p[3] = {0.0, 0.0, 0.0};

  Vec3 translation() const { return {p[0], p[1], p[2]}; }
  Vec3 column(int c) const { return {R[0][c], R[1][c], R[2][c]}; }
  // R v + p
  Vec3 apply(const Vec3& v) const {
    return {R[0][0] * v.x + R[0][1] * v.y + R[0][2] * v.z + p[0],
            R[1][0] * v.x + R[1][1] * v.y + R[1][2] * v.z + p[1],
            R[2][0] * v.x + R[2][1] * v.y + R[2][2] * v.z + p[2]};
  }
  // R v
  Vec3 rotate(const Vec3& v) const {
    return {R[0][0] * v.x + R[0][1] * v.y + R[0][2] * v.z,
            R[1][0] * v.x + R[1][1] * v.y + R[1][2] * v.z,
            R[2][0] * v.x + R[2][1] * v.y + R[2][2] * v.z};
  }
};

// a * b
inline Frame operator*(const Frame& a, const Frame& b) {
  Frame out;
  for (int r = 0; r < 3; ++r) {
    const double a0 = a.R[r][0], a1 = a.R[r][1], a2 = a.R[r][2];
    out.R[r][0] = a0 * b.R[0][0] + a1 * b.R[1][0] + a2 * b.R[2][0];
    out.R[r][1] = a0 * b.R[0][1] + a1 * b.R[1][1] + a2 * b.R[2][1];
    out.R[r][2] = a0 * b.R[0][2] + a1 * b.R[1][2] + a2 * b.R[2][2];
    out.p[r] = a0 * b.p[0] + a1 * b.p[1] + a2 * b.p[2] + a.p[r];
  }
  return out;
}

// The inverse of a rigid transform.
inline Frame inverse(const Frame& f) {
  Frame out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.R[r][c] = f.R[c][r];
  }
  for (int r = 0; r < 3; ++r) {
    out.p[r] = -(f.R[0][r] * f.p[0] + f.R[1][r] * f.p[1] + f.R[2][r] * f.p[2]);
  }
  return out;
}

// f = f * Rz(angle), given the angle's cosine and sine.
inline void turn_about_z(Frame& f, double c, double s) {
  for (int r = 0; r < 3; ++r) {
    const double x = f.R[r][0], y = f.R[r][1];
    f.R[r][0] = c * x + s * y;
    f.R[r][1] = c * y - s * x;
  }
}

// f = f * Tz(distance).
inline void slide_along_z(Frame& f, double distance) {
  for (int r = 0; r < 3; ++r) f.p[r] += distance * f.R[r][2];
}

// f = f * Tr(point): the same frame moved to `point` (given in f's coordinates).
inline Frame moved_to(const Frame& f, const Vec3& point) {
  Frame out = f;
  const Vec3 shift = f.rotate(point);
  out.p[0] += shift.x;
  out.p[1] += shift.y;
  out.p[2] += shift.z;
  return out;
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
inline Vec3 rotate_about(const Vec3& k, double c, double s, const Vec3& v) {
  const double along = (1.0 - c) * dot(k, v);
  return {c * v.x + s * (k.y * v.z - k.z * v.y) + along * k.x,
          c * v.y + s * (k.z * v.x - k.x * v.z) + along * k.y,
          c * v.z + s * (k.x * v.y - k.y * v.x) + along * k.z};
}

}  // namespace dhkin
