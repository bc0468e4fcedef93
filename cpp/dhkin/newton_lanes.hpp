// Newton's method on the exact chain for the eight branch candidates of one pose at once, one
// branch per lane: refine() (newton.hpp) on the lane type, for candidates that converge as Newton
// does near a regular root.
//
// Each lane takes refine()'s steps: the Gauss-Newton step J dq = e (a square 6 x 6 system here,
// solved by Householder QR of J itself), shortened to kMaxJointStep per joint; converged once
// both errors are below kRefineFraction * tolerance, then polished while a step shrinks the
// squared error kPolishGain-fold (the limit of the arithmetic); the best iterate kept. What
// refine() would do beyond that (damping a rejected step, the damping floor that suppresses
// directions no joint step can move, more steps than kMaxSteps) is not done here: a lane that
// would need it is not `settled`, and the caller gives its candidate to the scalar pipeline.
#pragma once

#include <cmath>

#include "dhkin/chain.hpp"
#include "dhkin/family.hpp"
#include "dhkin/newton.hpp"
#include "dhkin/simd.hpp"

namespace dhkin {

namespace newton {

// A lane's Gauss-Newton system counts as singular where a diagonal entry of R is at most this
// fraction of the largest: least_squares' rank test (the scalar code then damps the step).
constexpr double kRankFraction = 1e-15;

// Solves J step = e per lane (J 6 x kDof row-major, square) by Householder QR; false in the lanes
// where R fails the rank test (their `step` is then meaningless).
DHKIN_INLINE Mask solve_square(const Lanes* J, const Lanes* e, Lanes* step) {
  static_assert(kDof == 6, "a square system");
  Lanes A[6][kDof], b[6];
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < kDof; ++c) A[r][c] = J[r * kDof + c];
    b[r] = e[r];
  }
  for (int k = 0; k < kDof; ++k) {  // Householder reflection of column k below the diagonal
    Lanes squared = A[k][k] * A[k][k];
    for (int r = k + 1; r < 6; ++r) squared += A[r][k] * A[r][k];
    const Lanes length = sqrt(squared);
    const Lanes alpha = select(A[k][k] >= 0.0, -length, length);
    A[k][k] -= alpha;
    Lanes v_norm = A[k][k] * A[k][k];
    for (int r = k + 1; r < 6; ++r) v_norm += A[r][k] * A[r][k];
    for (int c = k + 1; c < kDof; ++c) {
      Lanes d = A[k][k] * A[k][c];
      for (int r = k + 1; r < 6; ++r) d += A[r][k] * A[r][c];
      const Lanes factor = 2.0 * d / v_norm;
      for (int r = k; r < 6; ++r) A[r][c] -= factor * A[r][k];
    }
    Lanes d = A[k][k] * b[k];
    for (int r = k + 1; r < 6; ++r) d += A[r][k] * b[r];
    const Lanes factor = 2.0 * d / v_norm;
    for (int r = k; r < 6; ++r) b[r] -= factor * A[r][k];
    A[k][k] = alpha;  // R's diagonal
  }
  Lanes largest = abs(A[0][0]);
  for (int k = 1; k < kDof; ++k) largest = max(largest, abs(A[k][k]));
  Mask full_rank = uniform(true);
  for (int k = kDof - 1; k >= 0; --k) {
    full_rank = full_rank && abs(A[k][k]) > kRankFraction * largest;
    Lanes total = b[k];
    for (int c = k + 1; c < kDof; ++c) total -= A[k][c] * step[c];
    step[k] = total / A[k][k];
  }
  return full_rank;
}

}  // namespace newton

// The outcome of refine_lanes: per lane the best iterate's errors (position m, rotation rad, as
// error_twist measures them), and whether the lane settled as refine() would: converged below
// kRefineFraction * tolerance and polished to the limit of the arithmetic.
struct LaneRefinement {
  PoseErrorT<Lanes> error;
  Mask settled;
};

// Newton on the exact chain from q (in place) towards `target` (DH frame 0 -> n), in the lanes
// `active`; q ends as each lane's best iterate (inactive lanes are left as they are). Each
// lane's steps are refine()'s until it stops improving; a lane whose step fails the rank test or
// would be rejected (refine() would then damp it), or that has not settled after
// newton::kMaxSteps steps, ends unsettled.
inline LaneRefinement refine_lanes(const Chain& chain, const ChainShape& shape,
                                   const Frame& target, JointsT<Lanes>& q, Mask active,
                                   double tolerance) {
  using namespace newton;
  const double goal = kRefineFraction * tolerance;
  FrameT<Lanes> frames[kDof + 1], trial_frames[kDof + 1];
  JointMotions<Lanes> motions;
  Lanes e[6], trial_e[6], J[6 * kDof], step[kDof];
  joint_motions(chain, q.data(), motions);
  chain_frames(chain, shape, motions, frames);
  PoseErrorT<Lanes> error = error_twist(frames[kDof], target, e);
  Lanes size = error.position * error.position + error.rotation * error.rotation;
  JointsT<Lanes> best = q;
  PoseErrorT<Lanes> best_error = error;
  Lanes best_size = size;
  Mask polishing = uniform(false), settled = uniform(false), running = active;
  for (int iteration = 0; iteration < kMaxSteps && any(running); ++iteration) {
    // an exact root: nothing to improve
    settled = settled || (running && size == 0.0);
    running = running && !(size == 0.0);
    polishing = polishing || (error.position <= goal && error.rotation <= goal);
    jacobian(chain, frames, J);
    const Mask solved = solve_square(J, e, step);
    Lanes longest = abs(step[0]);
    for (int a = 1; a < kDof; ++a) longest = max(longest, abs(step[a]));
    const Lanes shrink = select(longest > kMaxJointStep, kMaxJointStep / longest, Lanes(1.0));
    JointsT<Lanes> trial;
    for (int a = 0; a < kDof; ++a) trial[a] = q[a] + shrink * step[a];
    joint_motions(chain, trial.data(), motions);
    chain_frames(chain, shape, motions, trial_frames);
    const PoseErrorT<Lanes> trial_error = error_twist(trial_frames[kDof], target, trial_e);
    const Lanes trial_size =
        trial_error.position * trial_error.position + trial_error.rotation * trial_error.rotation;
    const Mask taken = solved && trial_size <= (kGrowth * kGrowth) * size;
    // at the rounding of the arithmetic: the lane stops, keeping the trial if it is the best
    const Mask stop = running && taken && polishing && !(trial_size * kPolishGain <= size);
    const Mask kept = stop && trial_size < best_size;
    for (int a = 0; a < kDof; ++a) best[a] = select(kept, trial[a], best[a]);
    best_error.position = select(kept, trial_error.position, best_error.position);
    best_error.rotation = select(kept, trial_error.rotation, best_error.rotation);
    best_size = select(kept, trial_size, best_size);
    settled = settled || stop;
    const Mask step_on = running && taken && !stop;
    running = step_on;  // a rejected step ends the lane unsettled
    if (!any(step_on)) break;
    for (int a = 0; a < kDof; ++a) q[a] = select(step_on, trial[a], q[a]);
    for (int r = 0; r < 6; ++r) e[r] = select(step_on, trial_e[r], e[r]);
    for (int f = 0; f <= kDof; ++f) {
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
          frames[f].R[r][c] = select(step_on, trial_frames[f].R[r][c], frames[f].R[r][c]);
        }
        frames[f].p[r] = select(step_on, trial_frames[f].p[r], frames[f].p[r]);
      }
    }
    error.position = select(step_on, trial_error.position, error.position);
    error.rotation = select(step_on, trial_error.rotation, error.rotation);
    size = select(step_on, trial_size, size);
    const Mask better = step_on && size < best_size;
    for (int a = 0; a < kDof; ++a) best[a] = select(better, q[a], best[a]);
    best_error.position = select(better, error.position, best_error.position);
    best_error.rotation = select(better, error.rotation, best_error.rotation);
    best_size = select(better, size, best_size);
  }
  for (int a = 0; a < kDof; ++a) q[a] = select(active, best[a], q[a]);
  return {best_error, settled && active};
}

}  // namespace dhkin
