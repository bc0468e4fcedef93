// Steps 1-3 of a pose that needs none of the pipeline's repairs: the direct path.
//
// Most poses of an exact-family table (no refinement) are regular: no candidate of the closed
// form lies within the seed band of a singularity (no `near` bit of a free joint), every candidate
// verifies as computed, and no two branches give one solution. For such a pose steps 1-3 of
// solve_branches (pipeline.hpp) reduce to: check and project the pose, solve the family, wrap and
// verify each candidate (the eight at once, lanes.hpp), set the flags. direct_branches does
// exactly that, so its answer is the pipeline's bit for bit; for any other pose it returns false
// and the caller runs the pipeline (tests/test_ik_direct_path.py compares the two).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "dhkin/branch_lanes.hpp"
#include "dhkin/lanes.hpp"
#include "dhkin/plan.hpp"
#include "dhkin/pose.hpp"

namespace dhkin {

// A pose ready for the pipeline: its DH target, and the target of the TCP point (the chains of
// the plan end at the TCP).
struct PoseTargets {
  Frame T_dh;  // DH frame 0 -> DH frame n
  Frame T_at;  // T_dh followed by the TCP point: the target of the plan's chains
};

// The pose's status (a PoseStatus), or kBadSeed for a usable pose whose seed is not finite.
inline int pose_and_seed_status(const double* T, const Joints& seed) {
  const int status = pose_status(T);
  if (status != kUsable) return status;
  for (double v : seed) {
    if (!std::isfinite(v)) return kBadSeed;
  }
  return kUsable;
}

// The same status, and the pose's rotation projected onto the nearest rotation (`projection`:
// how far). False when the pose is not usable.
inline bool projected_pose(const double* T, const Joints& seed, int& status, double& projection,
                           Frame& projected) {
  status = pose_and_seed_status(T, seed);
  if (status != kUsable) return false;
  projected = projected_frame(T, projection);
  return true;
}

// The targets of a projected pose (per lane for V = Lanes): TargetFrames::to_dh, then the TCP.
template <class V>
inline void targets_of(const TargetFrames& frames, const FrameT<V>& projected, FrameT<V>& T_dh,
                       FrameT<V>& T_at) {
  // moved_to's values, each element written once: a frame copied whole right after its elements
  // were written one by one loads them back in wider pieces, which waits until the stores retire
  const FrameT<V> dh = frames.base_inverse * projected * frames.tool_inverse;
  const Vec3T<V> shift = dh.rotate(frames.tcp_point);
  const V moves[3] = {shift.x, shift.y, shift.z};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T_dh.R[r][c] = T_at.R[r][c] = dh.R[r][c];
    T_dh.p[r] = dh.p[r];
    T_at.p[r] = dh.p[r] + moves[r];
  }
}

// Step 1 without the bookkeeping: the pose's status, the projection's size and the targets.
// False when the pose is not usable.
inline bool pose_targets(const TargetFrames& frames, const double* T, const Joints& seed,
                         int& status, double& projection, PoseTargets& targets) {
  Frame projected;
  if (!projected_pose(T, seed, status, projection, projected)) return false;
  targets_of(frames, projected, targets.T_dh, targets.T_at);
  return true;
}

// Step 1: the pose and the seed checked (a rejection goes to info.status), the rotation
// projected (info.projection) and the targets computed. False when the pose is not usable.
inline bool begin_pose(const TargetFrames& frames, const double* T, const Joints& seed,
                       PoseInfo& info, Branches& branches, PoseTargets& targets) {
  info = PoseInfo{};
  info.why.fill(NAN);
  branches.ok.fill(false);
  branches.flags.fill(0);
  return pose_targets(frames, T, seed, info.status, info.projection, targets);
}

// What the closed form in branch lanes made of a pose (closed_form_lanes).
enum class LaneStart {
  answered,   // the pose or the seed was rejected: info.status says why
  irregular,  // a candidate within the seed band of a singularity: the pipeline's step 2
  solved,     // the eight branches are in `found`
};

// Steps 1-2 in branch lanes, shared by both direct paths (this one and refined_direct.hpp): the
// pose and the seed checked, the targets computed and the family's closed form solved with the
// eight branches in lanes. `tolerance` is the plan's verification tolerance.
inline LaneStart closed_form_lanes(const Plan& plan, const TargetFrames& frames, const double* T,
                                   const Joints& seed, double tolerance, Branches& branches,
                                   PoseInfo& info, PoseTargets& targets, BranchLanes& found) {
  if (!begin_pose(frames, T, seed, info, branches, targets)) return LaneStart::answered;
  const FamilyRequest request{&seed, 0, plan.seed_angle, plan.seed_length, plan.clamp(tolerance)};
  const bool regular =
      plan.family == Family::offset_wrist
          ? offset_wrist_lanes(plan.offset, targets.T_dh, request, found)
          : spherical_wrist_lanes(plan.spherical, targets.T_dh, request, found);
  return regular ? LaneStart::solved : LaneStart::irregular;
}

// The revolute joints of every lane wrapped into (-pi, pi].
inline void wrap_revolute_lanes(const Plan& plan, JointsT<Lanes>& q) {
  for (int j = 0; j < kDof; ++j) {
    if (plan.revolute(j)) q[j] = wrap(q[j]);
  }
}

// The valid branches' joint values, revolute joints wrapped; zero in the other lanes (ignored).
inline JointsT<Lanes> wrapped_branches(const Plan& plan, const BranchLanes& found) {
  JointsT<Lanes> q;
  for (int j = 0; j < kDof; ++j) q[j] = select(found.valid, found.q[j], Lanes(0.0));
  wrap_revolute_lanes(plan, q);
  return q;
}

// Whether two valid branches give one solution (within twice the merge angle): the pipeline
// then merges them. Every pair a < b at once: lane a against lane b = a ^ m, for m = 1..7.
// plan.same's test joint by joint, in another order (the test is their conjunction): first the
// joint where branches m apart split (kSplitJoint), which decides nearly every pair.
inline bool two_branches_one_solution(const Plan& plan, const JointsT<Lanes>& q, Mask valid) {
  alignas(64) static const double kIndex[kLanes] = {0, 1, 2, 3, 4, 5, 6, 7};
  const Lanes index = Lanes::load(kIndex);
  const double distance = 2.0 * kMergeAngle;
  for (int m = 1; m < kBranches; ++m) {
    Mask close = valid && swapped(valid, m) && index < swapped(index, m);
    const int first = kSplitJoint[m];
    for (int k = 0; k < kDof && any(close); ++k) {
      const int j = joint_from(first, k);
      Lanes d = q[j] - swapped(q[j], m);
      if (plan.revolute(j)) d = wrap(d);
      close = close && !(abs(d) > distance);
    }
    if (any(close)) return true;
  }
  return false;
}

// direct_branches of the spherical-wrist and offset-wrist families: the closed form, the wrap,
// the check and the flags with the pose's eight branches in lanes (branch_lanes.hpp); the same
// steps on the same values as the scalar code below, so the same bits.
inline bool direct_branch_lanes(const Plan& plan, const TargetFrames& frames, const double* T,
                                const Joints& seed, double tolerance, Branches& branches,
                                PoseInfo& info) {
  tolerance = plan.verification_tolerance(tolerance);
  PoseTargets targets;
  BranchLanes found;
  switch (closed_form_lanes(plan, frames, T, seed, tolerance, branches, info, targets, found)) {
    case LaneStart::answered: return true;
    case LaneStart::irregular: return false;
    case LaneStart::solved: break;
  }
  info.why = found.why;
  const JointsT<Lanes> q = wrapped_branches(plan, found);
  const PoseErrorT<Lanes> errors = check(plan.chain, q.data(), targets.T_at);
  if (any(found.valid && !errors.within(tolerance))) return false;  // the pipeline's step 3
  if (two_branches_one_solution(plan, q, found.valid)) return false;  // the pipeline merges them
  alignas(64) double values[kDof][kLanes], position[kLanes], rotation[kLanes];
  alignas(64) std::int64_t flags[kLanes];
  for (int j = 0; j < kDof; ++j) q[j].store(values[j]);
  errors.position.store(position);
  errors.rotation.store(rotation);
  const LaneBits bits = (found.flags & kShoulder) | plan.value_flags(q);
  std::memcpy(flags, &bits.v, sizeof flags);
  for (int b = 0; b < kBranches; ++b) {
    if (!lane(found.valid, b)) continue;
    for (int j = 0; j < kDof; ++j) branches.q[b][j] = values[j][b];
    branches.ok[b] = true;
    branches.errors[b] = {position[b], rotation[b]};
    branches.flags[b] = static_cast<std::uint8_t>(flags[b]);
    ++info.candidates;
    ++info.verified;
  }
  return true;
}

// Steps 1-3 for a regular pose of an exact-family table; false (outputs undefined) for a pose
// that needs the full pipeline. A rejected pose or seed is answered here (info.status).
inline bool direct_branches(const Plan& plan, const TargetFrames& frames, const double* T,
                            const Joints& seed, double tolerance, Branches& branches,
                            PoseInfo& info) {
  if (plan.refine) return false;
  if (plan.family != Family::stanford) {
    return direct_branch_lanes(plan, frames, T, seed, tolerance, branches, info);
  }
  tolerance = plan.verification_tolerance(tolerance);
  PoseTargets targets;
  if (!begin_pose(frames, T, seed, info, branches, targets)) return true;
  Candidates found;
  plan.solve_family(targets.T_dh, seed, 0, plan.clamp(tolerance), found);
  for (int b = 0; b < kBranches; ++b) {
    if (found.near[b] & kFree) return false;  // a seeded candidate to try: the pipeline's step 2
  }
  info.why = found.why;
  std::array<Joints, kBranches> candidates{};  // zero where not valid (its lane is ignored)
  for (int b = 0; b < kBranches; ++b) {
    if (!found.valid[b]) continue;
    candidates[b] = found.q[b];
    plan.wrap_revolute(candidates[b]);
  }
  const std::array<PoseError, kBranches> errors = check_lanes(plan.chain, candidates, targets.T_at);
  for (int b = 0; b < kBranches; ++b) {
    if (!found.valid[b]) continue;
    if (!errors[b].within(tolerance)) return false;  // to be polished: the pipeline's step 3
    branches.q[b] = candidates[b];
    branches.ok[b] = true;
    branches.errors[b] = errors[b];
    ++info.candidates;
  }
  for (int a = 0; a < kBranches; ++a) {
    for (int b = a + 1; b < kBranches; ++b) {
      if (branches.ok[a] && branches.ok[b] &&
          plan.same(branches.q[a], branches.q[b], 2.0 * kMergeAngle)) {
        return false;  // one solution from two branches: the pipeline merges them
      }
    }
  }
  for (int b = 0; b < kBranches; ++b) {
    if (branches.ok[b]) {
      branches.flags[b] = (found.flags[b] & kShoulder) | plan.value_flags(branches.q[b]);
      ++info.verified;
    }
  }
  return true;
}

}  // namespace dhkin
