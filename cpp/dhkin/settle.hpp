// Step 3 of the pipeline for one candidate: wrap it, refine it on the exact chain (Newton, then
// continuation where that fails) or polish an exact table's candidate, and measure its errors.
#pragma once

#include "dhkin/continuation.hpp"
#include "dhkin/newton.hpp"
#include "dhkin/plan.hpp"

namespace dhkin {

inline bool any(const JointMask& mask) {
  for (bool m : mask) {
    if (m) return true;
  }
  return false;
}

// q (verified, with errors `error`) polished by Newton with every joint free while it still
// improves (kPolishBudget chain evaluations at most), kept only where the errors shrink; whether
// they did.
inline bool polish_free(const Chain& chain, const Frame& target, double tolerance, Joints& q,
                   PoseError& error) {
  Joints polished = q;
  const PoseError polished_error = refine(chain, target, polished, JointMask{}, tolerance,
                                          {kPolishBudget, newton::kGrowth, 0.0});
  if (!(std::max(polished_error.position, polished_error.rotation) <
        std::max(error.position, error.rotation))) {
    return false;
  }
  q = polished;
  error = polished_error;
  return true;
}

// Wrap a candidate's revolute values, refine it on the exact chain if the plan says so (joints
// marked `fixed` keep their value; a candidate that is an exact solution of the ideal model, not
// `clamped`, is followed by continuation where Newton fails), or polish it by Newton where an
// exact table's candidate does not verify (when `polish`); return its errors. With `release`,
// a refined candidate whose fixed joints keep it from verifying is refined again with them free
// (`fixed` is then cleared); without, it stays a member of the singular family or fails.
inline PoseError settle(const Plan& plan, const Frame& target, Joints& values, JointMask& fixed,
                        bool clamped, bool long_shot, double tolerance, bool polish = true,
                        bool release = true) {
  const Chain& chain = plan.chain;
  plan.wrap_revolute(values);
  if (plan.refine) {
    const Joints start = values;
    const int budget = long_shot ? kLongShotBudget : newton::kBudget;
    // a long shot whose Newton stalls short of a root has reached the least error the exact chain
    // has near it: not a root (newton::Settings::stop_on_stall)
    PoseError error =
        refine(chain, target, values, fixed, tolerance, {budget, newton::kGrowth, 0.0, long_shot});
    if (release && any(fixed) && !error.within(tolerance)) {
      // the exact chain is not singular here (its singular set is shifted, or a calibration
      // leaves none): the seed's choice of the free joint is not exact, so release it from where
      // it got to (the caller sees `fixed` cleared)
      fixed = JointMask{};
      // a monotone descent first: it stays in the basin of the root nearest the seed's member,
      // where Newton's first step can jump along the near-singular direction to a far root
      const Joints held = values;
      error = refine(chain, target, values, fixed, tolerance, {budget, newton::kMonotone, 0.0});
      if (!error.within(tolerance)) {
        values = held;
        error = refine(chain, target, values, fixed, tolerance, {budget, newton::kGrowth, 0.0});
      }
    }
    const double goal = newton::kRefineFraction * tolerance;
    // verified before Newton stopped improving (a monotone descent's budget spent, or the end of
    // a continuation, which stops at the tolerance): polished while it still improves. A seed's
    // member (free joint held) is polished with every joint free: the exact chain's root near
    // the member where the pose fixes it; on an exact singular family the held point is already
    // exact and no step gains. `fixed` stays set: the seed chose this member
    const auto polish_verified = [&](Joints& at, PoseError& at_error) {
      const bool unpolished = at_error.position > goal || at_error.rotation > goal;
      if (at_error.within(tolerance) && (unpolished || any(fixed))) {
        polish_free(chain, target, tolerance, at, at_error);
      }
    };
    polish_verified(values, error);
    if (!clamped && !error.within(tolerance)) {  // follow the branch from the ideal model
      values = start;
      refine_along(plan.ideal, chain, plan.path, target, values, fixed, tolerance);
      PoseError followed = check(chain, values.data(), target);
      polish_verified(values, followed);
    } else if (clamped && !error.within(tolerance)) {
      // a target a hair beyond a fold: its least-squares point may verify
      refine(chain, target, values, fixed, tolerance, {kPolishBudget, newton::kMonotone, 0.0});
    }
    plan.wrap_revolute(values);
    return check(chain, values.data(), target);
  }
  PoseError error = check(chain, values.data(), target);
  if (!error.within(tolerance) && polish) {
    // a clamped or near-singular candidate of an exact table: the closed form's point is not the
    // best one the chain reaches; Newton's is, and verification decides
    refine(chain, target, values, fixed, tolerance, {kPolishBudget, newton::kGrowth, 0.0});
    error = check(chain, values.data(), target);
    if (clamped && !error.within(tolerance)) {
      // clamped onto a fold: J is singular there. A target a hair beyond it: Newton oscillates
      // along the fold's weak direction, a monotone descent reaches the least-squares point,
      // which may verify; a target a hair inside it: the roots lie a hair off the fold
      refine(chain, target, values, fixed, tolerance, {kPolishBudget, newton::kMonotone, 0.0});
      error = check(chain, values.data(), target);
      if (!error.within(tolerance)) {
        off_fold(chain, target, values, fixed, tolerance, kPolishBudget);
      }
    }
    plan.wrap_revolute(values);
    error = check(chain, values.data(), target);
  }
  return error;
}

// Every verified slot of a refined table polished while Newton still improves it: a slot's root
// can come from a search that stops at the tolerance (a root placed from a valley, a corrected
// target, a merge), not only from settle(). A slot whose errors are within the refinement goal
// (kRefineFraction x tolerance) is left as it is.
inline void polish_slots(const Plan& plan, const Frame& target, double tolerance,
                         Branches& branches) {
  const double goal = newton::kRefineFraction * tolerance;
  for (int b = 0; b < kBranches; ++b) {
    PoseError error = branches.errors[b];
    if (!branches.ok[b] || (error.position <= goal && error.rotation <= goal)) continue;
    Joints q = branches.q[b];
    if (polish_free(plan.chain, target, tolerance, q, error)) {
      plan.wrap_revolute(q);
      branches.q[b] = q;
      branches.errors[b] = check(plan.chain, q.data(), target);
    }
  }
}

// settle() of `start` copied into `candidate` with every joint free.
inline PoseError settle_free(const Plan& plan, const Frame& target, const Joints& start,
                             Joints& candidate, JointMask& fixed, bool clamped, bool long_shot,
                             double tolerance) {
  candidate = start;
  fixed = JointMask{};
  return settle(plan, target, candidate, fixed, clamped, long_shot, tolerance, true);
}

}  // namespace dhkin
