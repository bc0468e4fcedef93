// Singular families: the member nearest the seed of a one-parameter family of solutions (q1 or q2
// free), the nearest member within the joint limits, and whether a family is singular at the
// tolerance over half a turn.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "dhkin/golden.hpp"
#include "dhkin/plan.hpp"
#include "dhkin/settle.hpp"

namespace dhkin {

namespace members {

// The nearest member of a one-parameter family (q1 or q2 free): a grid over the whole turn (this
// half-width, this step, rad) around the seed's value of the free joint: the other joints follow
// the free one, so the nearest member can be far from the seed's value of it; then golden-section
// search to kPrecision within a step of the best grid point (the distance has kinks: no
// derivatives). Not Brent's search as on the offset wrist's q6 (brent.hpp): with q1 or q2 free
// and a second joint free too the distance here has isolated values the grid hits and a
// parabola's steps do not tie to (test_a_triply_singular_pose_answers_near_a_moved_seed).
constexpr double kHalfWidth = kPi;
constexpr double kStep = 0.05;
constexpr int kGrid = 63;  // ceil(kHalfWidth / kStep)
static_assert(kGrid * kStep >= kHalfWidth && (kGrid - 1) * kStep < kHalfWidth,
              "kGrid = ceil(kHalfWidth / kStep)");
constexpr double kPrecision = 1e-9;

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
  const double middle = golden_section(best_t - kStep, best_t + kStep, kPrecision, distance,
                                       [](double left, double right) { return left <= right; });
  if (distance(middle) > best) distance(best_t);
  candidate = found.q[b];
  return found.flags[b];
}

namespace members {

// How far the joint values q lie outside the limits: the largest distance of a joint's nearest
// 2pi copy beyond its range (0 inside).
inline double limit_violation(const Plan& plan, const Joints& q) {
  double worst = 0.0;
  for (int j = 0; j < kDof; ++j) {
    const JointLimit& limit = plan.limits[j];
    double value = q[j];
    if (plan.revolute(j)) {  // the copy nearest the middle of the range
      const double middle = 0.5 * (limit.lower + limit.upper);
      value += kTwoPi * std::nearbyint((middle - value) / kTwoPi);
      // a copy on the other side may lie nearer the range
      const double other = value + (value < middle ? kTwoPi : -kTwoPi);
      const double outside = std::max({limit.lower - value, value - limit.upper, 0.0});
      const double other_outside = std::max({limit.lower - other, other - limit.upper, 0.0});
      worst = std::max(worst, std::min(outside, other_outside));
    } else {
      worst = std::max(worst, std::max({limit.lower - value, value - limit.upper, 0.0}));
    }
  }
  return worst;
}

// The search for the member nearest the seed inside the limits resolves the free joint to this
// (rad or m): a member found there lies within ~1e-12 of the limits' edge, far inside the slack
// (tolerance / lever) within which a value counts as on its limit.
constexpr double kLimitPrecision = 1e-12;

}  // namespace members

// Where the seed's member of branch b's singular family (free joints of `bits`) lies outside the
// joint limits: the member nearest the seed inside them, into `candidate`; returns its errors
// (infinite when none). Searched over the seed's value t of the free joint (the members follow
// it) on the grid of nearest_member (the whole turn): the in-limit grid member nearest the seed,
// else the grid's least violation; then golden-section search within a grid step, to
// kLimitPrecision, on the distance to the seed among in-limit members (or on the violation, where
// the in-limit members are a single point, as when two joints sit exactly on their limits).
// `fixed` ends as the free joints of `bits`.
inline PoseError member_in_limits(const Plan& plan, const Frame& T, const Frame& T_at,
                                  const Joints& seed, int bits, int b, double clamp,
                                  double tolerance, Joints& candidate, JointMask& fixed) {
  using namespace members;
  const JointMask free = plan.free_joints(bits);
  int f = 0;
  while (f < kDof - 1 && !free[f]) ++f;
  const double slack = tolerance / plan.lever;
  Candidates found;
  struct Score {
    bool exists = false;
    double violation = INFINITY, distance = INFINITY;
  };
  const auto score = [&](double t) {
    Joints moved = seed;
    moved[f] = t;
    // searched over the wrist's free joint: the member at t itself (no nearest-member search)
    plan.solve_family(T, moved, bits, clamp, found, b, f == plan.free_wrist);
    Score out;
    if (!found.valid[b] || (found.near[b] & bits) != bits || !finite(found.q[b])) return out;
    out.exists = true;
    out.violation = limit_violation(plan, found.q[b]);
    out.distance = plan.seed_distance(found.q[b], seed);
    return out;
  };
  // a member is better when it is inside the limits and nearer the seed, or violates them less
  const auto better = [&](const Score& a, const Score& c) {
    if (!a.exists) return false;
    if (!c.exists) return true;
    const bool a_in = a.violation <= slack, c_in = c.violation <= slack;
    if (a_in != c_in) return a_in;
    return a_in ? a.distance < c.distance : a.violation < c.violation;
  };
  double best_t = seed[f];
  Score best;
  for (int k = -kGrid; k <= kGrid; ++k) {
    const double t = seed[f] + k * kStep;
    const Score here = score(t);
    if (better(here, best)) best_t = t, best = here;
  }
  if (!best.exists) return {INFINITY, INFINITY};
  double t = golden_section(best_t - kStep, best_t + kStep, kLimitPrecision, score,
                            [&](const Score& left, const Score& right) {
                              return !better(right, left);
                            });
  if (better(best, score(t))) t = best_t;
  if (!(score(t).violation <= slack)) return {INFINITY, INFINITY};
  candidate = found.q[b];
  fixed = free;
  const PoseError error = settle(plan, T_at, candidate, fixed, (found.near[b] & kClamped) != 0,
                                 false, tolerance, true);
  if (error.within(tolerance) && plan.in_limits(candidate, slack)) return error;
  fixed = free;
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
  plan.solve_family(T, moved, kWrist, clamp, found, b);
  if (!found.valid[b] || (found.near[b] & kWrist) == 0) return false;
  return check(plan.chain, found.q[b].data(), T_at).within(tolerance);
}

}  // namespace dhkin
