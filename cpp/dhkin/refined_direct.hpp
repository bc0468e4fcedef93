// Steps 1-3 of a regular pose of a refined table (corrections, rounded constants): the direct
// path of the refined road.
//
// For most poses of a refined table the pipeline (solve_branches, pipeline.hpp) reduces to: the
// ideal model's closed form, each candidate settled by Newton on the exact chain and verified, the
// seed's root looked for (seed_root), the flags set. That holds when no candidate lies within the
// seed band of a singularity (no `near` bit of a free joint: no seeded candidate, no valley scan),
// no branch is a long shot that the exact chain may reach (a candidate clamped onto a reach
// boundary that the ideal model cannot reach: the pipeline chases those by refinement and
// corrected-target retries, except where reach_bound.hpp shows the exact chain cannot reach the
// branch either), every
// candidate settles as Newton does near a regular root (refine_lanes; no polish, continuation or
// retry then applies) and verifies, and no two branches give one solution (no merge, no twin
// search). direct_refined_branches does those steps with the eight branches in lanes
// (branch_lanes.hpp, newton_lanes.hpp); for any other pose it returns false and the caller runs
// the pipeline. Its answer is the pipeline's up to the last bits of Newton's iterates (the lanes
// solve the square Gauss-Newton system without the damping floor of the scalar least squares):
// the same branches, flags and counts, residuals at the limit of the arithmetic.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

#include "dhkin/branch_lanes.hpp"
#include "dhkin/direct.hpp"
#include "dhkin/newton_lanes.hpp"
#include "dhkin/plan.hpp"
#include "dhkin/reach_bound.hpp"
#include "dhkin/roots.hpp"

namespace dhkin {

// Whether every joint value of the lane is finite.
inline Mask finite_lanes(const JointsT<Lanes>& q) {
  Mask out = uniform(true);
  for (int j = 0; j < kDof; ++j) out = out && abs(q[j]) < INFINITY;
  return out;
}

// Whether refinement moved some valid branch farther than the band angle from its ideal
// candidate on some revolute joint (mod 2pi).
inline bool moved_beyond_band(const Plan& plan, const JointsT<Lanes>& ideal_q,
                              const JointsT<Lanes>& q, Mask valid) {
  Mask moved = every_lane<Lanes>(false);
  for (int j = 0; j < kDof; ++j) {
    if (plan.revolute(j)) moved = moved || abs(wrap(q[j] - ideal_q[j])) > plan.band_angle;
  }
  return any(valid && moved);
}

// Steps 1-3 for a regular pose of a refined table of the spherical-wrist or offset-wrist family;
// false (outputs undefined) for a pose that needs the pipeline. A rejected pose or seed is
// answered here (info.status).
inline bool direct_refined_branches(const Plan& plan, const TargetFrames& frames, const double* T,
                                    const Joints& seed, double tolerance, Branches& branches,
                                    PoseInfo& info) {
  if (!plan.refine || plan.family == Family::stanford) return false;
  tolerance = plan.verification_tolerance(tolerance);
  PoseTargets targets;
  BranchLanes found;
  switch (closed_form_lanes(plan, frames, T, seed, tolerance, branches, info, targets, found)) {
    case LaneStart::answered: return true;
    case LaneStart::irregular: return false;  // a seeded candidate to try
    case LaneStart::solved: break;
  }
  const Mask long_shots = !found.valid && found.clamped && finite_lanes(found.q);
  if (any(long_shots)) {
    // a long shot that the exact chain may reach (reach_bound.hpp; every candidate here is away
    // from the singular sets) is chased by the pipeline; one it cannot reach is not chased there
    // either
    std::array<bool, kBranches> valid;
    for (int b = 0; b < kBranches; ++b) valid[b] = lane(found.valid, b);
    const std::array<bool, kBranches> in_reach =
        long_shots_in_reach(plan, targets.T_dh, found.why, valid, tolerance);
    for (int b = 0; b < kBranches; ++b) {
      if (lane(long_shots, b) && in_reach[b]) return false;
    }
  }
  JointsT<Lanes> q = wrapped_branches(plan, found);
  const JointsT<Lanes> ideal_q = q;
  const LaneRefinement refined =
      refine_lanes(plan.chain, ChainShape(plan.chain), targets.T_at, q, found.valid, tolerance);
  if (any(found.valid && !refined.settled)) return false;  // for the scalar refinement
  wrap_revolute_lanes(plan, q);
  const PoseErrorT<Lanes> errors = check(plan.chain, q.data(), targets.T_at);
  if (any(found.valid && !errors.within(tolerance))) return false;
  if (two_branches_one_solution(plan, q, found.valid)) return false;  // to be merged
  info.why = found.why;
  // from the regular candidates alone (before the seed's root is looked for): a property of the
  // pose, whatever the seed
  info.beyond_band = moved_beyond_band(plan, ideal_q, q, found.valid);
  alignas(64) double values[kDof][kLanes], regular_q[kDof][kLanes], position[kLanes],
      rotation[kLanes];
  alignas(64) std::int64_t regular_flags[kLanes];
  for (int j = 0; j < kDof; ++j) {
    q[j].store(values[j]);
    found.q[j].store(regular_q[j]);
  }
  errors.position.store(position);
  errors.rotation.store(rotation);
  std::memcpy(regular_flags, &found.flags.v, sizeof regular_flags);
  for (int b = 0; b < kBranches; ++b) {
    branches.flags[b] = static_cast<std::uint8_t>(regular_flags[b]);
    if (!lane(found.valid, b)) {
      for (int j = 0; j < kDof; ++j) branches.q[b][j] = regular_q[j][b];
      continue;
    }
    for (int j = 0; j < kDof; ++j) branches.q[b][j] = values[j][b];
    branches.ok[b] = true;
    branches.errors[b] = {position[b], rotation[b]};
    ++info.candidates;
  }
  seed_root(plan, targets.T_at, seed, tolerance, branches);
  for (int b = 0; b < kBranches; ++b) {
    if (!branches.ok[b]) continue;
    branches.flags[b] = (regular_flags[b] & kShoulder) | plan.value_flags(branches.q[b]);
    ++info.verified;
  }
  return true;
}

}  // namespace dhkin
