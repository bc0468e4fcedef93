// Which long shots of a refined table the exact chain can reach: a bound from the ideal model's
// reach function and the stated model deviation.
//
// A long shot is a branch whose candidate the ideal model clamps onto a reach boundary violated
// by more than the clamp band (Plan::clamp: tolerance x (1 + lever) + twice the model deviation).
// The pipeline chases it on the exact chain anyway, because the band assumes that the reach
// function moves by at most about the pose's own change, and near a singular set of the closed
// form (q6 of an offset wrist near q5 = 0, q1 near the shoulder merge) it moves faster.
//
// The bound. If the exact chain verifies T at q*, the ideal model reaches T* = FK_ideal(q*) at
// q*, where T* is within the tolerance plus the model deviation of T: at most the clamp band in
// position and the band over the lever in rotation (each is at least the tolerance plus the model
// deviation in that unit: the band counts the deviation, a largest value over sampled joint
// vectors, twice). The branch's reach value
// rho(T*) >= 0 there (rho: the least of the reach conditions' margins, metres; negative beyond
// a boundary). So the branch can be reached only if rho can climb from rho(T) to 0 within that
// box of poses. Its climb is bounded by the sum over the six directions (three translations, three
// rotations about the flange) of the largest increase of rho over a step of the box's half-width
// each way: the secant over the whole step takes rho's curvature along each direction, and the sum
// the directions' combination to first order. A long shot whose bound stays below 0 is not
// chased (neither its refinement nor a corrected-target retry): the exact chain has no root on it.
//
// Not at a fold of the ideal model: where a valid branch lies within the clamp band of its own
// reach boundary, the exact chain's two roots beside the fold may be one double root (a pose on
// the exact chain's fold, e.g. sampled with the elbow stretched), which Newton from the valid
// candidates approaches only linearly and stops ~1e-6 rad short of, on both sides. A chase from a
// clamped candidate beyond the boundary can land on the double root itself, and merged with the
// two it is the pose's one solution there: every long shot of such a pose is chased as before.
//
// Only the offset-wrist family (UR, Techman: its shoulder and elbow reach conditions in `why`) and
// only a candidate away from every singular set (no `near` bit of a free joint): there the closed
// form is a smooth function of the pose and the secants measure it. Any other long shot is
// chased as before.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "dhkin/plan.hpp"
#include "dhkin/simd.hpp"

namespace dhkin {

namespace reach_bound {

// rho of each branch (m): the least margin of its reach conditions, from the closed form's `why`
// (offset wrist: the wrist point's distance from axis 1 and the least it needs, the arm span of
// each shoulder-wrist branch k = 2 s + w).
inline std::array<double, kBranches> margins(const Plan& plan,
                                             const std::array<double, kWhySize>& why) {
  const OffsetGeometry& g = plan.offset;
  const double high = g.upper_length + g.forearm_length;
  const double low = std::abs(g.upper_length - g.forearm_length);
  const double shoulder = why[0] - why[1];
  std::array<double, kBranches> out{};
  for (int b = 0; b < kBranches; ++b) {
    const double span = why[2 + 2 * (b / 4) + b % 2];
    out[b] = std::min(shoulder, std::min(high - span, span - low));
  }
  return out;
}

// The box of poses the bound climbs over: T_dh moved by +-steps[0] (m) along each axis of DH
// frame 0, then turned by +-steps[1] (rad) about each axis through the flange's origin; pose
// 2 d + side is direction d (x, y, z moves, then x, y, z turns) with side 0 the + step.
constexpr int kBoxPoses = 12;
inline std::array<Frame, kBoxPoses> box_poses(const Frame& T_dh, const double (&steps)[2]) {
  std::array<Frame, kBoxPoses> out;
  for (int kind = 0; kind < 2; ++kind) {  // translations, rotations
    for (int axis = 0; axis < 3; ++axis) {
      for (int side = 0; side < 2; ++side) {
        const double sign = side == 0 ? 1.0 : -1.0;
        Vec3 step{0.0, 0.0, 0.0};
        (axis == 0 ? step.x : axis == 1 ? step.y : step.z) = sign * steps[kind];
        Frame T = T_dh;
        if (kind == 0) {
          T.p[0] += step.x, T.p[1] += step.y, T.p[2] += step.z;
        } else {  // turned about the flange's origin
          T = rotation_vector(step) * T_dh;
          for (int r = 0; r < 3; ++r) T.p[r] = T_dh.p[r];
        }
        out[2 * (3 * kind + axis) + side] = T;
      }
    }
  }
  return out;
}

}  // namespace reach_bound

// Per branch: whether the exact chain may reach the branch (the bound above). True for every
// branch where the bound does not apply (a family other than the offset wrist, a non-finite
// reach value). `why` is the closed form's for T_dh (DH frame 0 -> n).
inline std::array<bool, kBranches> long_shots_in_reach(const Plan& plan, const Frame& T_dh,
                                                       const std::array<double, kWhySize>& why,
                                                       const std::array<bool, kBranches>& valid,
                                                       double tolerance) {
  std::array<bool, kBranches> out;
  out.fill(true);
  if (plan.family != Family::offset_wrist) return out;
  const std::array<double, kBranches> at = reach_bound::margins(plan, why);
  const double band = plan.clamp(tolerance);
  for (int b = 0; b < kBranches; ++b) {
    if (valid[b] && !(at[b] >= band)) return out;  // at a fold of the ideal model
  }
  const double steps[2] = {band, band / plan.lever};  // m, rad: the box's half-widths
  const std::array<Frame, reach_bound::kBoxPoses> box = reach_bound::box_poses(T_dh, steps);
  // the closed form at the box's poses, kLanes at a time (each lane's values as for that pose
  // alone); spare lanes take T_dh and are not read
  std::array<std::array<double, kBranches>, reach_bound::kBoxPoses> there;
  JointsT<Lanes> none;
  none.fill(Lanes(0.0));
  for (int first = 0; first < reach_bound::kBoxPoses; first += kLanes) {
    FrameT<Lanes> T = broadcast<Lanes>(T_dh);
    const int count = std::min(kLanes, reach_bound::kBoxPoses - first);
    for (int l = 0; l < count; ++l) set_lane(T, l, box[first + l]);
    CandidatesT<Lanes> moved;
    plan.solve_family(T, none, 0, band, moved);
    for (int l = 0; l < count; ++l) {
      std::array<double, kWhySize> why_l;
      for (int i = 0; i < kWhySize; ++i) why_l[i] = lane(moved.why[i], l);
      there[first + l] = reach_bound::margins(plan, why_l);
    }
  }
  std::array<double, kBranches> climb{};
  for (int direction = 0; direction < 6; ++direction) {
    std::array<double, kBranches> rise{};
    for (int side = 0; side < 2; ++side) {
      for (int b = 0; b < kBranches; ++b) {
        const double change = there[2 * direction + side][b] - at[b];
        rise[b] = std::isfinite(change) ? std::max(rise[b], change) : INFINITY;
      }
    }
    for (int b = 0; b < kBranches; ++b) climb[b] += rise[b];
  }
  for (int b = 0; b < kBranches; ++b) out[b] = !(at[b] + climb[b] < 0.0);  // NaN: in reach
  return out;
}

}  // namespace dhkin
