// Singular families: the member nearest the seed of a one-parameter family of solutions (q1 or q2
// free), the nearest member within the joint limits, and whether a family is singular at the
// tolerance over half a turn.
#pragma once

#include <cmath>
#include <limits>

#include "dhkin/plan.hpp"
#include "dhkin/settle.hpp"

namespace dhkin {

namespace members {

// The nearest member of a one-parameter family (q1 or q2 free): a grid over the whole turn (this
// half-width, this step, rad) around the seed's value of the free joint: the other joints follow
// the free one, so the nearest member can be far from the seed's value of it; then golden-section
// search to kPrecision within a step of the best grid point (the distance has kinks: no
// derivatives).
constexpr double kHalfWidth = kPi;
constexpr double kStep = 0.05;
constexpr int kGrid = 63;  // ceil(kHalfWidth / kStep)
static_assert(kGrid * kStep >= kHalfWidth && (kGrid - 1) * kStep < kHalfWidth,
              "kGrid = ceil(kHalfWidth / kStep)");
constexpr double kPrecision = 1e-9;
// Moves (rad or m) of a free joint off the seed tried, nearest first, when the seed's member of a
// singular family lies outside the joint limits.
constexpr double kLimitSteps[] = {0.02, -0.02, 0.05, -0.05, 0.1, -0.1, 0.2, -0.2, 0.4, -0.4, 0.8, -0.8};

// Squared joint distance (revolute differences wrapped) from the seed of branch b's member with
// the free joint at t; infinity where the branch has no such member. `found` receives the
// family's candidates.
inline double member_distance(const Plan& plan, const Frame& T, const Joints& seed, int free,
                              double t, int bits, int b, double clamp, Candidates& found) {
  Joints moved = seed;
  moved[free] = t;
  // a member that also passes the wrist singularity takes the seed's wrist split there
  plan.solve_family(T, moved, bits | kWrist, clamp, found);
  if (!found.valid[b] || (found.near[b] & bits) != bits) return INFINITY;
  const double total = plan.seed_distance(found.q[b], seed);
  return std::isfinite(total) ? total : INFINITY;
}

}  // namespace members

// Where the pose leaves q1 (kShoulder) or q2 (kElbow) free: branch b's member of the family
// nearest the seed over all joints (the other joints follow the free one: near a second
// singularity they follow it fast), into `candidate` (left as it is when none is found); returns
// the member's flags (-1 when none).
inline int nearest_member(const Plan& plan, const Frame& T, const Joints& seed, int bits, int b,
                          double clamp, Joints& candidate) {
  using namespace members;
  const int free = (bits & kShoulder) ? plan.free_shoulder : plan.free_elbow;
  Candidates found;
  const auto distance = [&](double t) {
    return member_distance(plan, T, seed, free, t, bits, b, clamp, found);
  };
  double best_t = seed[free], best = INFINITY;
  for (int k = -kGrid; k <= kGrid; ++k) {
    const double t = seed[free] + k * kStep;
    const double value = distance(t);
    if (value < best) best_t = t, best = value;
  }
  if (best == INFINITY) return -1;
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  double low = best_t - kStep, high = best_t + kStep;
  double a = high - golden * (high - low), c = low + golden * (high - low);
  double value_a = distance(a), value_c = distance(c);
  while (high - low > kPrecision) {
    if (value_a <= value_c) {
      high = c, c = a, value_c = value_a;
      a = high - golden * (high - low);
      value_a = distance(a);
    } else {
      low = a, a = c, value_a = value_c;
      c = low + golden * (high - low);
      value_c = distance(c);
    }
  }
  if (distance(0.5 * (low + high)) > best) distance(best_t);
  candidate = found.q[b];
  return found.flags[b];
}

// Branch b's seeded candidate with the free joint(s) of `bits` moved off the seed by
// kLimitSteps, the first that verifies and lies within the limits, into `candidate`; returns its
// errors (infinite when none). `fixed` ends as the free joints of `bits`.
inline PoseError member_in_limits(const Plan& plan, const Frame& T, const Frame& T_at,
                                  const Joints& seed, int bits, int b, double clamp,
                                  double tolerance, Joints& candidate, JointMask& fixed) {
  Candidates found;
  fixed = plan.free_joints(bits);
  for (double step : members::kLimitSteps) {
    Joints moved = seed;
    for (int j = 0; j < kDof; ++j) {
      if (fixed[j]) moved[j] += step;
    }
    plan.solve_family(T, moved, bits, clamp, found);
    if (!found.valid[b] || (found.near[b] & bits) != bits) continue;
    candidate = found.q[b];
    fixed = plan.free_joints(bits);
    const PoseError error = settle(plan, T_at, candidate, fixed, (found.near[b] & kClamped) != 0,
                                   false, tolerance, true);
    if (error.within(tolerance) && plan.in_limits(candidate, tolerance / plan.lever)) {
      return error;
    }
    fixed = plan.free_joints(bits);
  }
  return {INFINITY, INFINITY};
}

// Whether the pose leaves the wrist free at the tolerance: branch b's seeded member half a turn
// along the family from `solution` (the seed moved by pi on joints 4 and 6) verifies.
inline bool family_free(const Plan& plan, const Frame& T, const Frame& T_at,
                        const Joints& solution, int b, double clamp, double tolerance) {
  Joints moved = solution;
  moved[3] += kPi;
  moved[5] += kPi;
  Candidates found;
  plan.solve_family(T, moved, kWrist, clamp, found);
  if (!found.valid[b] || (found.near[b] & kWrist) == 0) return false;
  return check(plan.chain, found.q[b].data(), T_at).within(tolerance);
}

}  // namespace dhkin
