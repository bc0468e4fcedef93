// Input poses: checks, projection onto the nearest rotation, conversion to DH frame 0 -> n.
//
// A pose comes as it comes: computed (exact to rounding), printed with a few digits, or float32.
// Its rotation block R is accepted when it is within kOrthonormalityGate of a rotation (largest
// entry of |R R^T - I|, and det R > 0) and replaced by the nearest rotation (the orthogonal polar
// factor, which minimises the Frobenius distance); the solutions are exact for that projected pose
// and `project` returns how far the projection moved R (Frobenius norm of the change). The bottom
// row must be [0, 0, 0, 1] to within kBottomRowTolerance. Poses arrive as 4 x 4 row-major arrays.
#pragma once

#include <algorithm>
#include <cmath>

#include "dhkin/frame.hpp"

namespace dhkin {

// Largest |R R^T - I| entry of an accepted rotation block. Rounded sources stay far below it:
// float32 poses ~2e-7, six printed decimals ~3e-6, four printed decimals ~3e-4; a block further
// off is not a rounded rotation but a wrong matrix.
constexpr double kOrthonormalityGate = 1e-3;
// Largest deviation of the bottom row from [0, 0, 0, 1]: rounding only.
constexpr double kBottomRowTolerance = 1e-12;
// Newton steps of the polar decomposition (quadratic convergence: from 1e-3 off, three steps
// reach rounding; the loop stops as soon as a step changes nothing beyond rounding).
constexpr int kPolarSteps = 8;

// Why a pose (or seed) cannot be used; the values are dhkin.ik.inputs' STATUS_*.
enum PoseStatus : int {
  kUsable = 0,
  kNotFinite = 1,
  kBottomRow = 2,
  kNotRotation = 3,
  kBadSeed = 4,
};

inline double orthonormality(const double* T) {  // T: 4x4 (or 3x4) row-major, stride 4
  double worst = 0.0;
  for (int a = 0; a < 3; ++a) {
    for (int b = a; b < 3; ++b) {
      const double d = T[4 * a] * T[4 * b] + T[4 * a + 1] * T[4 * b + 1] +
                       T[4 * a + 2] * T[4 * b + 2];
      worst = std::max(worst, std::abs(d - (a == b ? 1.0 : 0.0)));
    }
  }
  return worst;
}

inline double rotation_determinant(const double* T) {
  return T[0] * (T[5] * T[10] - T[6] * T[9]) - T[1] * (T[4] * T[10] - T[6] * T[8]) +
         T[2] * (T[4] * T[9] - T[5] * T[8]);
}

// kUsable for a usable pose (4 x 4 row-major), else why not.
inline PoseStatus pose_status(const double* T) {
  for (int k = 0; k < 16; ++k) {
    if (!(std::abs(T[k]) < INFINITY)) return kNotFinite;
  }
  const double bottom = std::max({std::abs(T[12]), std::abs(T[13]), std::abs(T[14]),
                                  std::abs(T[15] - 1.0)});
  if (!(bottom <= kBottomRowTolerance)) return kBottomRow;
  if (!(orthonormality(T) <= kOrthonormalityGate) || rotation_determinant(T) <= 0.0) {
    return kNotRotation;
  }
  return kUsable;
}

// `raw` with its rotation block replaced by the nearest rotation (Newton's iteration
// X <- (X + X^-T) / 2 for the polar factor, until a step changes nothing beyond rounding), in the
// lanes where `active` holds (per lane for V = Lanes: each lane stops at its own step, as the
// scalar loop would); `moved` receives the Frobenius norm of the change of the rotation block.
template <class V>
inline FrameT<V> projected_frame(const FrameT<V>& raw, MaskOf<V> active, V& moved) {
  FrameT<V> out = raw;
  for (int step = 0; step < kPolarSteps && any(active); ++step) {
    const V a = out.R[0][0], b = out.R[0][1], c = out.R[0][2];
    const V d = out.R[1][0], e = out.R[1][1], f = out.R[1][2];
    const V g = out.R[2][0], h = out.R[2][1], i = out.R[2][2];
    const V det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
    // X^-T = cofactor(X) / det
    const V cofactor[3][3] = {{e * i - f * h, f * g - d * i, d * h - e * g},
                              {c * h - b * i, a * i - c * g, b * g - a * h},
                              {b * f - c * e, c * d - a * f, a * e - b * d}};
    V change(0.0);
    for (int r = 0; r < 3; ++r) {
      for (int k = 0; k < 3; ++k) {
        const V updated = 0.5 * (out.R[r][k] + cofactor[r][k] / det);
        change = max(change, abs(updated - out.R[r][k]));
        out.R[r][k] = select(active, updated, out.R[r][k]);
      }
    }
    active = active && !(change <= 4e-16);
  }
  V total(0.0);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      const V d = out.R[r][c] - raw.R[r][c];
      total += d * d;
    }
  }
  moved = sqrt(total);
  return out;
}

// The frame of a 4 x 4 row-major pose as it is (the top three rows).
inline Frame raw_frame(const double* T) {
  Frame out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.R[r][c] = T[4 * r + c];
    out.p[r] = T[4 * r + 3];
  }
  return out;
}

// The rigid frame of a usable pose (4 x 4 row-major), its rotation block replaced by the nearest
// rotation; `moved` receives the Frobenius norm of the change of the rotation block.
inline Frame projected_frame(const double* T, double& moved) {
  return projected_frame<double>(raw_frame(T), true, moved);
}

// How a call's targets become DH targets: T_dh = base^-1 T (tool tcp)^-1, and the TCP's origin
// in DH frame n (errors are measured at the TCP, not at DH frame n's origin).
struct TargetFrames {
  Frame base_inverse;      // base^-1
  Frame tool_inverse;      // (tool @ tcp)^-1
  Vec3 tcp_point;          // the translation of tool @ tcp: the TCP in DH frame n
  bool at_tcp = false;     // whether tcp_point is not DH frame n's origin

  static TargetFrames from(const Frame& base_inverse, const Frame& tool_inverse) {
    TargetFrames out;
    out.base_inverse = base_inverse;
    out.tool_inverse = tool_inverse;
    out.tcp_point = inverse(tool_inverse).translation();
    out.at_tcp = out.tcp_point.x != 0.0 || out.tcp_point.y != 0.0 || out.tcp_point.z != 0.0;
    return out;
  }

  // DH frame 0 -> DH frame n of a target base_link -> TCP.
  Frame to_dh(const Frame& target) const { return base_inverse * target * tool_inverse; }
};

}  // namespace dhkin
