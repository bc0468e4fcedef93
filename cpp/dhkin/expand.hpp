// Step 4 of the pipeline: the in-limit 2pi copies of each branch's solution (every copy, or the
// one nearest the seed), verified again where a limit or the tolerance margin asks.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "dhkin/copies.hpp"
#include "dhkin/pipeline.hpp"
#include "dhkin/plan.hpp"

namespace dhkin {

// One solution of a pose: joint values, its branch, flags and errors.
struct Solution {
  Joints q{};
  int branch = -1;
  std::uint8_t flags = 0;
  PoseError error;
};

// Per branch: how many solutions step 4 can give (every in-limit copy, or 1 when `copies` is
// false and the branch has an in-limit copy; 0 for a branch that is not ok), the roots beyond the
// slots counted with their branch.
inline std::array<long, kBranches> copy_totals(const Plan& plan, const Branches& branches,
                                               double tolerance, bool copies) {
  const double slack = tolerance / plan.lever;
  const auto total_of = [&](const Joints& q) {
    long total = 1;
    for (int j = 0; j < kDof && total != 0; ++j) {
      const long count = turn_range(plan.limits[j], plan.revolute(j), q[j], slack).count;
      total = copies ? total * count : std::min(total, count);
    }
    return total;
  };
  std::array<long, kBranches> totals{};
  for (int b = 0; b < kBranches; ++b) totals[b] = branches.ok[b] ? total_of(branches.q[b]) : 0;
  // a root beyond the slots counts with its branch
  const ExtraRoots& extra = branches.extra;
  for (int k = 0; k < extra.count; ++k) totals[extra.branch[k]] += total_of(extra.q[k]);
  return totals;
}

// Step 4 for one pose: `emit(solution)` for each solution, in order of branch, then of copy
// (mixed radix over the joints' copies, last joint fastest), then the roots beyond the slots in
// their order; with `copies` false one per root, the copy nearest the seed (the eight branches at
// once, one per lane: the bits the scalar nearest_turn gives each). A copy set onto a limit, and
// every copy of a root whose error is within kCopyMargin of the tolerance, is verified again (and
// dropped when it fails). Returns the count, or -1 as soon as `emit` returns false (no room).
template <class Emit>
long expand(const Plan& plan, const TargetFrames& frames, const double* T, const Joints& seed,
            double tolerance, bool copies, const Branches& branches, Emit&& emit) {
  const double slack = tolerance / plan.lever;
  tolerance = plan.verification_tolerance(tolerance);
  bool have_target = false;
  Frame T_at;
  const auto verified = [&](Solution& solution) {  // a copy verified again
    if (!have_target) {
      double moved;
      T_at = moved_to(frames.to_dh(projected_frame(T, moved)), frames.tcp_point);
      have_target = true;
    }
    solution.error = check(plan.chain, solution.q.data(), T_at);
    return solution.error.within(tolerance);
  };
  long count = 0;
  if (!copies) {  // one copy per branch, the one nearest the seed: the eight branches in lanes
    Mask ok = every_lane<Lanes>(false);
    for (int b = 0; b < kBranches; ++b) set_lane(ok, b, branches.ok[b]);
    Mask exists = ok, clipped = every_lane<Lanes>(false);
    alignas(64) double nearest_q[kDof][kLanes];
    for (int j = 0; j < kDof; ++j) {
      const bool revolute = plan.revolute(j);
      const Lanes q = select(ok, Lanes::gather(&branches.q[0][j], kDof), Lanes(0.0));
      const NearestTurn<Lanes> nearest =
          nearest_turn(plan.limits[j], revolute, q, slack, Lanes(seed[j]));
      exists = exists && nearest.exists;
      const Lanes copy = placed(plan.limits[j], revolute, q, nearest.turn);
      clipped = clipped || copy != shifted(revolute, q, nearest.turn);
      copy.store(nearest_q[j]);
    }
    for (int b = 0; b < kBranches; ++b) {
      if (!lane(exists, b)) continue;
      Solution solution;
      for (int j = 0; j < kDof; ++j) solution.q[j] = nearest_q[j][b];
      solution.error = branches.errors[b];
      const bool recheck = branches.errors[b].largest() > tolerance - kCopyMargin;
      if ((lane(clipped, b) || recheck) && !verified(solution)) continue;
      solution.branch = b;
      solution.flags = branches.flags[b];
      if (!emit(solution)) return -1;
      ++count;
    }
    const ExtraRoots& extra = branches.extra;
    for (int k = 0; k < extra.count; ++k) {  // the roots beyond the slots, one at a time
      Solution solution;
      bool exists = true, clipped = false;
      for (int j = 0; j < kDof && exists; ++j) {
        const bool revolute = plan.revolute(j);
        const double value = extra.q[k][j];
        long turn = 0;
        exists = nearest_turn(plan.limits[j], revolute, value, slack, seed[j], turn);
        solution.q[j] = placed(plan.limits[j], revolute, value, turn);
        clipped = clipped || solution.q[j] != shifted<double>(revolute, value, turn);
      }
      if (!exists) continue;
      solution.error = extra.errors[k];
      const bool recheck = extra.errors[k].largest() > tolerance - kCopyMargin;
      if ((clipped || recheck) && !verified(solution)) continue;
      solution.branch = extra.branch[k];
      solution.flags = extra.flags[k];
      if (!emit(solution)) return -1;
      ++count;
    }
    return count;
  }
  // every in-limit copy of one root: false as soon as `emit` has no room
  const auto every_copy = [&](const Joints& q, const PoseError& error, int branch,
                              std::uint8_t flags) {
    std::array<long, kDof> first{}, counts{}, digits{};
    long total = 1;
    for (int j = 0; j < kDof; ++j) {  // every in-limit copy
      const TurnRange range = turn_range(plan.limits[j], plan.revolute(j), q[j], slack);
      first[j] = range.first, counts[j] = range.count;
      total *= counts[j];
      digits[j] = 0;
    }
    const bool recheck = error.largest() > tolerance - kCopyMargin;
    for (long k = 0; k < total; ++k) {
      Solution solution;
      bool clipped = false;
      for (int j = 0; j < kDof; ++j) {
        const bool revolute = plan.revolute(j);
        const long turn = first[j] + digits[j];
        const double shifted = revolute ? q[j] + kTwoPi * static_cast<double>(turn) : q[j];
        solution.q[j] = placed(plan.limits[j], revolute, q[j], turn);
        clipped = clipped || solution.q[j] != shifted;
      }
      solution.error = error;
      const bool keep = !(clipped || recheck) || verified(solution);
      if (keep) {
        solution.branch = branch;
        solution.flags = flags;
        if (!emit(solution)) return false;
        ++count;
      }
      for (int j = kDof - 1; j >= 0; --j) {  // next mixed-radix digit, last joint fastest
        if (++digits[j] < counts[j]) break;
        digits[j] = 0;
      }
    }
    return true;
  };
  for (int b = 0; b < kBranches; ++b) {
    if (branches.ok[b] && !every_copy(branches.q[b], branches.errors[b], b, branches.flags[b])) {
      return -1;
    }
  }
  const ExtraRoots& extra = branches.extra;
  for (int k = 0; k < extra.count; ++k) {
    if (!every_copy(extra.q[k], extra.errors[k], extra.branch[k], extra.flags[k])) return -1;
  }
  return count;
}

}  // namespace dhkin
