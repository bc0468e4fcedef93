// One pose, steps 1-3: the closed-form IK pipeline (batches run the same function per pose).
//
// For a target T (4 x 4), base_link -> TCP:
//
// 1. check it (pose_status) and project its rotation onto the nearest rotation;
//    T_dh = base^-1 T (tool tcp)^-1 is DH frame 0 -> DH frame n;
// 2. the family's closed form on the ideal model gives 8 branch candidates. Where a joint is free
//    at a singularity within the seed band (the `near` bits: wrist, wrist centre on axis 1 or 2),
//    the family runs a second time taking that joint from the seed;
// 3. each candidate is wrapped to (-pi, pi], refined on the exact chain when the table needs it
//    (Newton; where that fails, continuation along a path of models from the ideal one to the
//    exact chain; a seeded candidate keeps its seeded joints fixed) and verified by FK on the exact
//    chain: errors at most `tolerance` in metres and radians. Where the seeded candidate verifies
//    it is the branch's answer (continuous in the seed), else the regular one; a branch neither of
//    whose candidates verifies is dropped and counted. The two wrist branches of an arm branch that
//    both answer with the seed's wrist are one solution. On a refined table, branches that
//    converged to the same solution are one.
//
// Step 4 (the 2pi copies) is expand.hpp. The direct path (direct_branches) is steps 1-3 for a
// regular pose of an exact-family table (no seeded candidate, every candidate verifies as
// computed, no two branches merge): the same answer with a fraction of the work; every other
// pose goes on to solve_branches. On a refined table solve_branches first tries the refined
// direct path (direct_refined_branches, refined_direct.hpp): a regular pose's eight candidates
// refined by Newton in lanes; a pose that needs any of the repairs below takes the pipeline.
// Where the exact chain of a refined table may have more roots than the eight slots hold, the
// roots beyond them are added after step 3 (add_roots_beyond_slots, extra_roots.hpp).
//
// `clamp`: reach conditions violated by at most tolerance x (1 + lever) + twice the model
// deviation are clamped onto their boundary, polished and verified, not rejected: a pose whose
// joint values verify is never answered empty. On a refined table a branch beyond the band (a
// long shot) is still chased from its clamped candidate, unless reach_bound.hpp shows that the
// exact chain cannot reach it.
#pragma once

#include <algorithm>
#include <cmath>

#include "dhkin/direct.hpp"
#include "dhkin/extra_roots.hpp"
#include "dhkin/members.hpp"
#include "dhkin/plan.hpp"
#include "dhkin/pose.hpp"
#include "dhkin/reach_bound.hpp"
#include "dhkin/refined_direct.hpp"
#include "dhkin/roots.hpp"
#include "dhkin/settle.hpp"

namespace dhkin {

// Steps 1-3 for one pose (any pose) by the pipeline itself: the branches' verified principal
// solutions and the pose's info.
inline void pipeline_branches(const Plan& plan, const TargetFrames& frames, const double* T,
                              const Joints& seed, double tolerance, Branches& branches,
                              PoseInfo& info) {
  tolerance = plan.verification_tolerance(tolerance);
  PoseTargets targets;
  if (!begin_pose(frames, T, seed, info, branches, targets)) return;
  const Frame& T_dh = targets.T_dh;
  const Frame& T_at = targets.T_at;
  const double clamp = plan.clamp(tolerance);
  Regular regular;
  {
    Candidates found;
    plan.solve_family(T_dh, seed, 0, clamp, found);
    info.why = found.why;
    regular.q = found.q, regular.valid = found.valid, regular.flags = found.flags;
    regular.near = found.near;
    regular.chased.fill(true);
    if (plan.refine) {
      // long shots (reach_bound.hpp): one away from every singular set that the exact chain
      // cannot reach is not chased
      bool long_shots = false;
      for (int b = 0; b < kBranches; ++b) {
        long_shots = long_shots || (!found.valid[b] && (found.near[b] & kClamped) != 0 &&
                                    (found.near[b] & kFree) == 0 && finite(found.q[b]));
      }
      if (long_shots) {
        const std::array<bool, kBranches> in_reach =
            long_shots_in_reach(plan, T_dh, found.why, found.valid, tolerance);
        for (int b = 0; b < kBranches; ++b) {
          regular.chased[b] = found.valid[b] || (found.near[b] & kFree) != 0 || in_reach[b];
        }
      }
    }
  }
  branches.q = regular.q;
  branches.flags = regular.flags;
  int wanted = 0;
  for (int b = 0; b < kBranches; ++b) wanted |= regular.near[b] & kFree;
  Candidates seeded;
  if (wanted != 0) plan.solve_family(T_dh, seed, wanted, clamp, seeded);
  double best_position = INFINITY, best_rotation = INFINITY;
  std::array<bool, kBranches> seeded_wrist{}, released{}, member{}, unclamped{}, raw_ok{};
  std::array<std::uint8_t, kBranches> seeded_flags = seeded.flags;
  Extras extras;
  // which seeded candidates verify as computed (wrapped, neither refined nor polished)
  if (wanted != 0 && !plan.refine) {
    for (int b = 0; b < kBranches; ++b) {
      if (seeded.valid[b] && (seeded.near[b] & wanted) != 0 && finite(seeded.q[b])) {
        raw_ok[b] = check(plan.chain, seeded.q[b].data(), T_at).within(tolerance);
      }
    }
  }
  Joints candidate{};
  JointMask fixed{};
  for (int b = 0; b < kBranches; ++b) {
    bool tried = false;
    const int bits = seeded.near[b] & wanted;
    if (bits != 0 && seeded.valid[b]) {
      tried = true;
      candidate = seeded.q[b];
      if (bits & (kShoulder | kElbow)) {
        const int member_flags = nearest_member(plan, T_dh, seed, bits, b, clamp, candidate);
        if (member_flags >= 0) seeded_flags[b] = static_cast<std::uint8_t>(member_flags);
      }
      fixed = plan.free_joints(bits);
      // polished only when its wrist partner does not verify as computed either: where the
      // partner does, the pose has picked the partner's side of the singular family and this
      // candidate's miss is real (polishing would carry it onto the partner's member and hide the
      // distinct flip, which the regular candidate then gives)
      // released on a refined table where the seed's member does not verify: the exact chain is
      // not singular there, and the root in the seed's basin is kept (the seed finding a root:
      // the known gap of refined tables, beside the seed-independent valley scan below)
      PoseError error = settle(plan, T_at, candidate, fixed, (seeded.near[b] & kClamped) != 0,
                               false, tolerance, !raw_ok[b ^ 1]);
      released[b] = !any(fixed);
      if (!released[b] && error.within(tolerance) &&
          !plan.in_limits(candidate, tolerance / plan.lever)) {
        // the seed's member of the family lies outside the joint limits: the nearest member
        // inside them (the free joint moved off the seed, nearest first)
        const Joints kept = candidate;
        error = member_in_limits(plan, T_dh, T_at, seed, bits, b, clamp, tolerance, candidate,
                                 fixed);
        if (!error.within(tolerance)) {
          // none inside: the seed's member stands (the limits drop it later), not the regular
          // candidates, which are other members of the same family
          candidate = kept;
          error = check(plan.chain, candidate.data(), T_at);
        }
      }
      if (error.within(tolerance)) {
        branches.q[b] = candidate;
        branches.ok[b] = true;
        branches.flags[b] = seeded_flags[b] | bits;
        seeded_wrist[b] = (bits & kWrist) != 0;
        member[b] = any(fixed);
        branches.errors[b] = error;
      } else {
        best_position = std::min(best_position, error.position);
        best_rotation = std::min(best_rotation, error.rotation);
      }
    }
    const bool long_shot = !regular.valid[b] && regular.chased[b] && plan.refine &&
                           finite(branches.q[b]) && (regular.near[b] & kClamped) != 0;
    if (branches.ok[b] && released[b] && regular.valid[b] && plan.refine) {
      // the seeded candidate verified only with its free joint released: the regular candidate
      // may reach another root of the pose (an extra; the seeded root, nearest the seed, stays)
      const PoseError error = settle_free(plan, T_at, regular.q[b], candidate, fixed,
                                          (regular.near[b] & kClamped) != 0, false, tolerance);
      if (error.within(tolerance)) extras.add(plan, b, candidate);
    }
    if (!branches.ok[b] && (regular.valid[b] || long_shot)) {
      tried = tried || regular.valid[b];
      const Joints start = branches.q[b];
      const PoseError error = settle_free(plan, T_at, start, candidate, fixed,
                                          (regular.near[b] & kClamped) != 0, long_shot, tolerance);
      if (error.within(tolerance)) {
        tried = true;
        branches.q[b] = candidate;
        branches.ok[b] = true;
        branches.errors[b] = error;
      } else {
        best_position = std::min(best_position, error.position);
        best_rotation = std::min(best_rotation, error.rotation);
      }
    }
    if (tried) {
      ++info.candidates;
      unclamped[b] = (regular.valid[b] && (regular.near[b] & kClamped) == 0) ||
                     (bits != 0 && seeded.valid[b] && (seeded.near[b] & kClamped) == 0);
    }
  }
  // the two wrist branches of an arm branch that both took the seed's wrist. Whether they are one
  // solution is a property of the pose: the family is free at the tolerance when its member half
  // a turn from a member verifies (from the seed's member or from the branch's regular root).
  // Then the pair is one solution, in the first wrist branch's slot (the seed's member), whatever
  // the seed; else, where both landed on the same member (they differ by 2 |q5| <= 2 kFlagBand),
  // the flip is a distinct solution, the regular root of the second slot. (On a refined table the
  // seeded candidates were refined; duplicates merge below.)
  for (int b = 0; b < kBranches; b += 2) {
    if (plan.refine || !branches.ok[b] || !branches.ok[b + 1] || !seeded_wrist[b] ||
        !seeded_wrist[b + 1]) {
      continue;
    }
    // free: the member half a turn from a wrist branch's regular root (settled on the exact
    // chain) verifies. Tested from the regular roots, which the seed does not move, so that the
    // answer's branches do not depend on the seed; from the seed's members only where neither
    // regular root settles. (Either wrist branch's root: at a second singularity, e.g. a
    // stretched elbow, one half turn may have no member, the family leaving the reach on an
    // arc.)
    bool free = false;
    bool probed = false;
    for (int w = b; w <= b + 1 && !free; ++w) {
      if (regular.valid[w] &&
          settle_free(plan, T_at, regular.q[w], candidate, fixed,
                      (regular.near[w] & kClamped) != 0, false, tolerance)
              .within(tolerance)) {
        probed = true;
        free = family_free(plan, T_dh, T_at, candidate, w, clamp, tolerance);
      }
    }
    if (!probed) {
      free = family_free(plan, T_dh, T_at, branches.q[b], b, clamp, tolerance) ||
             family_free(plan, T_dh, T_at, branches.q[b + 1], b + 1, clamp, tolerance);
    }
    if (free) {  // one family at the tolerance: one solution (the members may differ where the
      branches.ok[b + 1] = false;  // seed's member was moved onto the reach)
      continue;
    }
    if (!plan.same(branches.q[b], branches.q[b + 1], 4.0 * kFlagBand)) continue;  // distinct
    branches.ok[b + 1] = false;
    // singular to within the seed band but not to within the tolerance over half a turn of the
    // family: the flip is a distinct solution, the regular candidate's
    if (regular.valid[b + 1]) {
      const PoseError error =
          settle_free(plan, T_at, regular.q[b + 1], candidate, fixed,
                      (regular.near[b + 1] & kClamped) != 0, false, tolerance);
      if (error.within(tolerance) && !branches.known(plan, candidate)) {
        branches.q[b + 1] = candidate;
        branches.ok[b + 1] = true;
        branches.flags[b + 1] = regular.flags[b + 1];
        branches.errors[b + 1] = error;
      }
    }
  }
  merge_duplicates(plan, T_at, seed, tolerance, member, branches);
  if (plan.refine) {
    // the exact chain's roots along the ideal model's wrist families, where its wrist singular
    // set may lie: within the seed band of the ideal model's, at the ideal candidate or at the
    // exact root refined from it (the ideal q5 can be far off near the shoulder singularity).
    // (Kept beside the exact roots of add_roots_beyond_slots: it also finds near-double roots
    // inside their singular band, which those leave to the slots)
    for (int b = 0; b < kBranches; ++b) {
      const bool in_band = plan.wrist_sine(regular.q[b]) <= plan.seed_angle ||
                           (branches.ok[b] && plan.wrist_sine(branches.q[b]) <= plan.seed_angle);
      if ((regular.near[b] & kWrist) != 0 && in_band && regular.valid[b] &&
          finite(regular.q[b])) {
        valley_roots(plan, T_dh, T_at, regular.q[b], b, clamp, tolerance, branches, extras);
      }
    }
  }
  // a root found along a family goes to its branch's own slot when a merge emptied that, else to
  // its wrist twin's when that has none
  place_extras(plan, T_at, extras, regular.flags, branches, 2);
  if (plan.refine) {
    retry_corrected(plan, T_dh, T_at, seed, clamp, tolerance, regular, branches);
    // a root still without a slot takes the nearest empty one (elbow, then shoulder partners):
    // near a singularity the exact chain can have more roots for one ideal branch than the ideal
    // model has, while another branch's candidates found none
    place_extras(plan, T_at, extras, regular.flags, branches, kBranches);
    place_extras(plan, T_at, extras, regular.flags, branches, kBranches, tolerance / plan.lever);
    place_nearer_the_seed(plan, T_at, extras, seed, tolerance / plan.lever, branches);
    seed_root(plan, T_at, seed, tolerance, branches);
    polish_slots(plan, T_at, tolerance, branches);
  }
  // flags describe the solution returned: wrist and elbow from its joint values, shoulder from
  // the pose (where the two q1 roots meet depends on the pose alone)
  for (int b = 0; b < kBranches; ++b) {
    if (branches.ok[b]) {
      branches.flags[b] = (regular.flags[b] & kShoulder) | plan.value_flags(branches.q[b]);
      ++info.verified;
    } else if (unclamped[b] && !branches.ok[b ^ 1]) {
      // dropped: a solution of the ideal model (not a clamped start) that did not settle, on a
      // wrist pair that answered nothing (one answer for a singular pair is by design)
      ++info.dropped;
    }
  }
  info.best_position = best_position, info.best_rotation = best_rotation;
}

// The roots beyond the slots of a pose of a refined table whose exact roots the plan holds
// (extra_roots.hpp), added to `branches`; nothing for any other table or a rejected pose.
inline void add_roots_beyond_slots(const Plan& plan, const TargetFrames& frames, const double* T,
                                   const Joints& seed, double tolerance, const PoseInfo& info,
                                   Branches& branches) {
  if (plan.exact_roots == nullptr || info.status != kUsable) return;
  PoseTargets targets;
  int status = kUsable;
  double projection = 0.0;
  pose_targets(frames, T, seed, status, projection, targets);
  const double verification = plan.verification_tolerance(tolerance);
  add_exact_roots(plan, frames, targets, verification, plan.clamp(verification), branches);
}

// Steps 1-3 for one pose (any pose): on a refined table the refined direct path, else the
// pipeline; then the roots beyond the slots where the pose may have some: it left the refined
// direct path, or a branch moved beyond the band there (extra_roots.hpp).
inline void solve_branches(const Plan& plan, const TargetFrames& frames, const double* T,
                           const Joints& seed, double tolerance, Branches& branches,
                           PoseInfo& info) {
  branches.extra.count = 0;
  const bool direct =
      plan.refine && direct_refined_branches(plan, frames, T, seed, tolerance, branches, info);
  if (!direct) pipeline_branches(plan, frames, T, seed, tolerance, branches, info);
  if (!direct || info.beyond_band) {
    add_roots_beyond_slots(plan, frames, T, seed, tolerance, info, branches);
  }
}

// Steps 1-3 for one pose: the direct path, else the pipeline.
inline void solve_pose(const Plan& plan, const TargetFrames& frames, const double* T,
                       const Joints& seed, double tolerance, Branches& branches, PoseInfo& info) {
  if (!direct_branches(plan, frames, T, seed, tolerance, branches, info)) {
    solve_branches(plan, frames, T, seed, tolerance, branches, info);
  }
}

}  // namespace dhkin
