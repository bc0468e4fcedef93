// The closed form of one regular pose with its eight branches in the lanes of one lane type:
// lane b holds branch b = 4 * shoulder + 2 * elbow + wrist (family.hpp).
//
// solve_offset_wrist and solve_spherical_wrist (offset.hpp, spherical.hpp) run the branches of
// one pose one after the other in scalar code, each transcendental function once per branch
// (about fifty per pose), or kLanes poses at once in a batch. A single call has one pose: here its
// branches fill the lanes, so each step of the closed form (q1's sine and cosine, q5's angle,
// the elbow's law of cosines, ...) is one vector operation for all eight branches. Every lane
// does the operations the scalar code does for its branch, in the same order (shared values,
// such as the shoulder's roots, are computed once in scalar code, as there), so each lane has the
// scalar code's bits (tests/test_ik_direct_path.py compares the direct path with the pipeline).
//
// Only for the direct path (direct.hpp): no seeded candidates (use_seed 0). Where the scalar code
// would set a `near` bit of a free joint on any branch (a pose within the seed band of a
// singularity, which the direct path declines), these return false and leave `out` undefined.
#pragma once

#include <array>
#include <cmath>

#include "dhkin/angles.hpp"
#include "dhkin/bands.hpp"
#include "dhkin/family.hpp"
#include "dhkin/frame.hpp"
#include "dhkin/offset.hpp"
#include "dhkin/simd.hpp"
#include "dhkin/spherical.hpp"

namespace dhkin {

static_assert(kLanes == kBranches, "one lane per branch");

// Candidates of one pose, branch b in lane b (CandidatesT without the `near` bits; `clamped`:
// the near bit kClamped, the candidate moved onto a reach boundary).
struct BranchLanes {
  JointsT<Lanes> q{};
  Mask valid{};
  Mask clamped{};
  LaneBits flags{};
  std::array<double, kWhySize> why{};
};

namespace branch_lanes {

// Lanes whose branch index has `bit` set: 4 shoulder (back), 2 elbow, 1 wrist.
DHKIN_INLINE Mask branch_bit(int bit) {
  alignas(64) static const double kIndex[kLanes] = {0, 1, 2, 3, 4, 5, 6, 7};
  alignas(64) double set[kLanes];
  for (int l = 0; l < kLanes; ++l) set[l] = (static_cast<int>(kIndex[l]) & bit) ? 1.0 : 0.0;
  return Lanes::load(set) != 0.0;
}

}  // namespace branch_lanes

// solve_offset_wrist (offset.hpp) of one pose with use_seed 0, in branch lanes.
inline bool offset_wrist_lanes(const OffsetGeometry& g, const Frame& T,
                               const FamilyRequest& request, BranchLanes& out) {
  using namespace offset;
  const Mask back = branch_lanes::branch_bit(4), down = branch_lanes::branch_bit(2),
             flip = branch_lanes::branch_bit(1);
  // the shoulder, as the scalar code computes it
  const Frame T_home = T * g.home_inverse;
  const Vec3 h = T.apply(g.wrist_in_flange) - g.points[0];
  const double along_n = dot(h, g.n), along_side = dot(h, g.side);
  const double distance = sqrt(along_n * along_n + along_side * along_side);
  const double c = g.lateral;
  out.why[0] = distance, out.why[1] = std::abs(c);
  if (c == 0.0 && distance <= request.seed_length) return false;  // shoulder near
  const double gap = distance - std::abs(c);
  const bool shoulder_ok = gap >= -request.clamp;
  double root = sqrt(max(gap, g.spread) * (distance + std::abs(c)));
  const bool shoulder_merged = c != 0.0 && small_angle(root, std::abs(c), kMergeAngle);
  root = select(shoulder_merged, 0.0, root);
  const std::uint8_t shoulder_flag =
      bits_if(shoulder_merged || root <= kFlagBand * g.scale, kShoulder);
  double q1_uncertainty = 0.0;
  if (c != 0.0) {
    q1_uncertainty = min(request.clamp / max(root, 1e-300),
                         std::sqrt(2.0 * request.clamp / std::abs(c)));
  }
  const double phase = atan2(along_side, along_n);
  const double half = atan2(root, c);
  const double front_q1 = phase + g.left_sign * half, back_q1 = phase - g.left_sign * half;
  // every branch in its lane
  const FrameT<Lanes> T_lanes = broadcast<Lanes>(T), home = broadcast<Lanes>(T_home);
  const Vec3& w6 = g.directions[5];
  const Lanes q1 = select(back, Lanes(back_q1), Lanes(front_q1));
  const Lanes reach_side = select(back, Lanes(-g.lateral_sign), Lanes(g.lateral_sign));
  const Mask q1_valid = shoulder_ok && (!back || !shoulder_merged);
  const SinCosT<Lanes> t1 = sincos(q1);
  const Vec3T<Lanes> m = rotate_about(g.directions[0], t1.c, t1.s, g.n);
  const Vec3T<Lanes> f{T_lanes.R[0][0] * m.x + T_lanes.R[1][0] * m.y + T_lanes.R[2][0] * m.z,
                       T_lanes.R[0][1] * m.x + T_lanes.R[1][1] * m.y + T_lanes.R[2][1] * m.z,
                       T_lanes.R[0][2] * m.x + T_lanes.R[1][2] * m.y + T_lanes.R[2][2] * m.z};
  const Vec3T<Lanes> u = g.home_rotation * f;
  const Lanes cosine = dot(u, w6);
  const Lanes sine = norm(cross(w6, u));
  if (any(sine <= request.seed_angle + q1_uncertainty)) return false;  // wrist near
  const LaneBits wrist_flag = bits_if(sine <= kFlagBand, kWrist);
  const Lanes q5_half = atan2(sine, cosine);
  const Vec3T<Lanes> a = u - cosine * w6;
  const SinCosT<Lanes> minus_q1 = negated(t1);
  const Lanes q5 = g.psi + select(flip, Lanes(-g.up_sign), Lanes(g.up_sign)) * q5_half;
  const SinCosT<Lanes> minus_q5 = sincos(-q5);
  const Vec3T<Lanes> t = rotate_about(g.directions[4], minus_q5.c, minus_q5.s, g.n);
  const Vec3T<Lanes> b = t - dot(t, w6) * w6;
  const Lanes q6 = atan2(dot(w6, cross(a, b)), dot(a, b));
  const TurnsT<Lanes> turns{minus_q5, sincos(-q6), minus_q1};
  const Vec3T<Lanes> arm = arm_point(g, home, turns);
  const Lanes span = norm(arm);
  for (int s = 0; s < 2; ++s) {
    for (int w = 0; w < 2; ++w) out.why[2 + 2 * s + w] = lane(span, 4 * s + w);
  }
  const Mask wrist_valid = !flip || sine != 0.0;
  const ElbowSetup<Lanes> setup = elbow_setup(g, home, turns, span, reach_side, request.clamp);
  // elbow (offset.hpp) with the elbow branch per lane
  const Lanes q3 = select(down, setup.q3[1], setup.q3[0]);
  const SinCosT<Lanes> t3 = sincos(q3);
  const Vec3T<Lanes> bent = g.upper_arm + t3.c * g.forearm + t3.s * g.axis3_x_forearm;
  if (any(norm_at_most(bent, request.seed_length))) return false;  // elbow near
  const Lanes q2 = atan2(dot(g.n, cross(bent, arm)), dot(bent, arm));
  const Lanes q4 = g.sign4 * (setup.total - q2 - g.sign3 * q3);
  const Mask elbow_valid = setup.reach_ok && (!down || !setup.merged);
  out.q = {q1, q2, q3, q4, q5, q6};
  out.valid = q1_valid && wrist_valid && elbow_valid;
  out.clamped = gap < 0.0 || setup.clamped;
  out.flags = LaneBits(shoulder_flag) | wrist_flag | setup.flag;
  for (int j = 0; j < kDof; ++j) out.valid = out.valid && abs(out.q[j]) < INFINITY;
  return true;
}

// solve_spherical_wrist (spherical.hpp) of one pose with use_seed 0, in branch lanes.
inline bool spherical_wrist_lanes(const SphericalGeometry& g, const Frame& T,
                                  const FamilyRequest& request, BranchLanes& out) {
  using namespace spherical;
  const Mask back = branch_lanes::branch_bit(4), down = branch_lanes::branch_bit(2),
             flip = branch_lanes::branch_bit(1);
  Candidates shoulder_out;
  const ShoulderRoots<double> arm = shoulder(g, T, (*request.seed)[0], request, shoulder_out);
  if (arm.near & kFree) return false;  // shoulder near
  out.why[0] = shoulder_out.why[0], out.why[1] = shoulder_out.why[1];
  const double upper = g.upper_length, fore = g.forearm_length;
  const FrameT<Lanes> T_lanes = broadcast<Lanes>(T);
  const Lanes turn1 = select(back, Lanes(arm.back_turn), Lanes(arm.front_turn));
  const PlanarT<Lanes> target{Lanes(arm.height),
                              select(back, Lanes(arm.back_reach), Lanes(arm.front_reach))};
  const TargetColumns<Lanes> columns = target_columns(g, T_lanes, turn1);
  const Lanes distance = sqrt(target.height * target.height + target.reach * target.reach);
  out.why[2] = lane(distance, 0), out.why[3] = lane(distance, 4);
  if (any(distance <= request.seed_length)) return false;  // elbow near
  const Lanes outer = (upper + fore) - distance;
  const Lanes inner = distance - std::abs(upper - fore);
  const Mask reachable = outer >= -request.clamp && inner >= -request.clamp;
  Lanes sine_scaled = sqrt(max(outer, Lanes(g.spread)) * (upper + fore + distance) *
                           max(inner, Lanes(g.spread)) * (distance + std::abs(upper - fore)));
  const Lanes cosine_scaled = distance * distance - upper * upper - fore * fore;
  const Mask merged = small_angle(sine_scaled, abs(cosine_scaled), kMergeAngle);
  sine_scaled = select(merged, Lanes(0.0), sine_scaled);
  const LaneBits elbow_flag = bits_if(merged || elbow_flagged(g, sine_scaled), kElbow);
  const Lanes psi = atan2(select(down, -sine_scaled, sine_scaled), cosine_scaled);
  const Lanes turn3 = psi - g.bend_at_zero;
  const SinCosT<Lanes> t3 = sincos(turn3);
  const PlanarT<Lanes> bent{
      g.upper_arm.height + (t3.c * g.forearm.height - t3.s * g.forearm.reach),
      g.upper_arm.reach + (t3.c * g.forearm.reach + t3.s * g.forearm.height)};
  const Lanes turn2 = turn_to(target, bent);
  const Mask arm_valid = ((back && arm.back_valid) || (!back && arm.front_valid)) && reachable &&
                         (!down || !merged);
  // wrist (spherical.hpp) with the wrist branch per lane
  const WristColumns<Lanes> h = wrist_columns(g, columns, sincos(turn2 + turn3));
  const Vec3T<Lanes> h0 = h.h0, h2 = h.h2;  // columns 0 and 2 of H
  const Lanes h00 = h0.x, h10 = h0.y, h20 = h0.z, h02 = h2.x, h12 = h2.y, h22 = h2.z;
  const double d4 = g.wrist_directions[0], d5 = g.wrist_directions[1], d6 = g.wrist_directions[2];
  const Lanes sine = sqrt(h02 * h02 + h12 * h12);
  const Lanes turn_uncertainty = elbow_uncertainty(g, distance, sine_scaled, request.clamp);
  if (any(sine <= request.seed_angle + turn_uncertainty)) return false;  // wrist near
  const LaneBits wrist_flag = bits_if(sine <= kFlagBand, kWrist);
  const Lanes theta = atan2(sine, h22);
  const Lanes alpha = atan2(h12, h02);
  const SinCosT<Lanes> s_theta = sincos(theta);
  const Lanes t4 = alpha + select(flip, Lanes(kPi), Lanes(0.0));
  const Lanes t5 = select(flip, -theta, theta);
  const SinCosT<Lanes> s4 = sincos(t4);
  const SinCosT<Lanes> s5{select(flip, -s_theta.s, s_theta.s), s_theta.c};
  const Lanes t6 =
      atan2(-s4.s * h00 + s4.c * h10, s5.c * (s4.c * h00 + s4.s * h10) - s5.s * h20);
  out.q = {g.signs[0] * turn1, g.signs[1] * turn2, g.signs[2] * turn3,
           d4 * t4,            d5 * (t5 - g.tilt), d6 * t6};
  out.valid = arm_valid;
  out.clamped = (arm.near & kClamped) != 0 || outer < 0.0 || inner < 0.0;
  out.flags = LaneBits(arm.flag) | elbow_flag | wrist_flag;
  return true;
}

}  // namespace dhkin
