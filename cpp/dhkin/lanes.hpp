// The exact chain's FK and pose errors of the eight branch candidates of one pose at once, lane
// by lane (structure of arrays: one lane per branch), in loops without branches or calls that the
// compiler vectorises. Each lane does the same floating-point operations in the same order as the
// scalar fk() and pose_error() of chain.hpp, so both give the same bits (tests compare them).
#pragma once

#include <array>
#include <cmath>

#include "dhkin/angles.hpp"
#include "dhkin/chain.hpp"
#include "dhkin/family.hpp"

namespace dhkin {

namespace lanes {

constexpr int kLanes = kBranches;
using Lane = double[kLanes];

// Frames of all lanes: rotation R[r][c][lane], translation p[r][lane].
struct Frames {
  alignas(64) double R[3][3][kLanes];
  alignas(64) double p[3][kLanes];
};

// state = state * P for every lane (P the same constant frame for all).
inline void times_constant(Frames& f, const Frame& P) {
  for (int r = 0; r < 3; ++r) {
#pragma GCC ivdep
    for (int l = 0; l < kLanes; ++l) {
      const double a0 = f.R[r][0][l], a1 = f.R[r][1][l], a2 = f.R[r][2][l];
      f.R[r][0][l] = a0 * P.R[0][0] + a1 * P.R[1][0] + a2 * P.R[2][0];
      f.R[r][1][l] = a0 * P.R[0][1] + a1 * P.R[1][1] + a2 * P.R[2][1];
      f.R[r][2][l] = a0 * P.R[0][2] + a1 * P.R[1][2] + a2 * P.R[2][2];
      f.p[r][l] = a0 * P.p[0] + a1 * P.p[1] + a2 * P.p[2] + f.p[r][l];
    }
  }
}

// state = state * Rz(v) (revolute) or state * Tz(v) (prismatic), v per lane.
inline void times_motion(Frames& f, bool revolute, const Lane& v) {
  if (revolute) {
    alignas(64) double s[kLanes], c[kLanes];
#pragma GCC ivdep
    for (int l = 0; l < kLanes; ++l) {
      const SinCos t = elementary::sincos_reduced(v[l]);
      s[l] = t.s, c[l] = t.c;
    }
    for (int r = 0; r < 3; ++r) {
#pragma GCC ivdep
      for (int l = 0; l < kLanes; ++l) {
        const double x = f.R[r][0][l], y = f.R[r][1][l];
        f.R[r][0][l] = c[l] * x + s[l] * y;
        f.R[r][1][l] = c[l] * y - s[l] * x;
      }
    }
  } else {
    for (int r = 0; r < 3; ++r) {
#pragma GCC ivdep
      for (int l = 0; l < kLanes; ++l) f.p[r][l] += v[l] * f.R[r][2][l];
    }
  }
}

}  // namespace lanes

// The errors of T(q[b]) against `target` for the eight joint vectors q (lanes whose DH variables
// reach 2^19 in magnitude, where the written-out sincos does not apply, are computed one by one).
inline std::array<PoseError, kBranches> check_lanes(const Chain& chain,
                                                    const std::array<Joints, kBranches>& q,
                                                    const Frame& target) {
  using namespace lanes;
  std::array<PoseError, kBranches> out;
  Frames f;
  alignas(64) double v[kLanes];
  bool reduced = true;
  for (int j = 0; j < kDof && reduced; ++j) {
    for (int l = 0; l < kLanes; ++l) {
      reduced = reduced && std::abs(chain.joints[j].motion(q[l][j])) < elementary::kReductionLimit;
    }
  }
  if (!reduced) {
    for (int b = 0; b < kBranches; ++b) out[b] = check(chain, q[b].data(), target);
    return out;
  }
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      for (int l = 0; l < kLanes; ++l) f.R[r][c][l] = chain.joints[0].before.R[r][c];
    }
    for (int l = 0; l < kLanes; ++l) f.p[r][l] = chain.joints[0].before.p[r];
  }
  for (int j = 0; j < kDof; ++j) {
    const ChainJoint& joint = chain.joints[j];
    if (j > 0) times_constant(f, joint.before);
    for (int l = 0; l < kLanes; ++l) v[l] = joint.motion(q[l][j]);
    times_motion(f, joint.revolute, v);
  }
  times_constant(f, chain.tail);
  // errors against the target: |p - p_t| and atan2(s, c) of E = R^T R_t, s = |vee(E - E^T)| / 2
  alignas(64) double position[kLanes], s[kLanes], c[kLanes];
#pragma GCC ivdep
  for (int l = 0; l < kLanes; ++l) {
    double e[3][3];
    for (int r = 0; r < 3; ++r) {
      for (int k = 0; k < 3; ++k) {
        e[r][k] = f.R[0][r][l] * target.R[0][k] + f.R[1][r][l] * target.R[1][k] +
                  f.R[2][r][l] * target.R[2][k];
      }
    }
    const double dx = f.p[0][l] - target.p[0], dy = f.p[1][l] - target.p[1],
                 dz = f.p[2][l] - target.p[2];
    s[l] = 0.5 * std::sqrt((e[2][1] - e[1][2]) * (e[2][1] - e[1][2]) +
                           (e[0][2] - e[2][0]) * (e[0][2] - e[2][0]) +
                           (e[1][0] - e[0][1]) * (e[1][0] - e[0][1]));
    c[l] = 0.5 * (e[0][0] + e[1][1] + e[2][2] - 1.0);
    position[l] = std::sqrt(dx * dx + dy * dy + dz * dz);
  }
  for (int l = 0; l < kLanes; ++l) out[l] = {position[l], atan2(s[l], c[l])};
  return out;
}

}  // namespace dhkin
