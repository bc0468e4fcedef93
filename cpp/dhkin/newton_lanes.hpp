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
#include <utility>

#include "dhkin/chain.hpp"
#include "dhkin/family.hpp"
#include "dhkin/newton.hpp"
#include "dhkin/simd.hpp"

namespace dhkin {

namespace newton {

// A lane's Gauss-Newton system counts as singular where a diagonal entry of R is at most this
// fraction of the largest: least_squares' rank test (the scalar code then damps the step).
constexpr double kRankFraction = 1e-15;

// The Householder QR factorisation of a square Jacobian (6 x kDof) per lane: R above the
// diagonal, R's diagonal in `diagonal`, the reflection vectors on and below it, each with its
// squared length.
struct SquareQR {
  Lanes A[6][kDof];
  Lanes diagonal[kDof];
  Lanes v_norm[kDof];
  Mask full_rank;  // R passes the rank test
};

// Factorises J (row-major) per lane.
DHKIN_INLINE void factor_square(const Lanes* J, SquareQR& qr) {
  static_assert(kDof == 6, "a square system");
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < kDof; ++c) qr.A[r][c] = J[r * kDof + c];
  }
  for (int k = 0; k < kDof; ++k) {  // Householder reflection of column k below the diagonal
    Lanes squared = qr.A[k][k] * qr.A[k][k];
    for (int r = k + 1; r < 6; ++r) squared += qr.A[r][k] * qr.A[r][k];
    const Lanes length = sqrt(squared);
    const Lanes alpha = select(qr.A[k][k] >= 0.0, -length, length);
    qr.A[k][k] -= alpha;
    Lanes v_norm = qr.A[k][k] * qr.A[k][k];
    for (int r = k + 1; r < 6; ++r) v_norm += qr.A[r][k] * qr.A[r][k];
    qr.v_norm[k] = v_norm;
    for (int c = k + 1; c < kDof; ++c) {
      Lanes d = qr.A[k][k] * qr.A[k][c];
      for (int r = k + 1; r < 6; ++r) d += qr.A[r][k] * qr.A[r][c];
      const Lanes factor = 2.0 * d / v_norm;
      for (int r = k; r < 6; ++r) qr.A[r][c] -= factor * qr.A[r][k];
    }
    qr.diagonal[k] = alpha;
  }
  Lanes largest = abs(qr.diagonal[0]);
  for (int k = 1; k < kDof; ++k) largest = max(largest, abs(qr.diagonal[k]));
  qr.full_rank = uniform(true);
  for (int k = 0; k < kDof; ++k) {
    qr.full_rank = qr.full_rank && abs(qr.diagonal[k]) > kRankFraction * largest;
  }
}

// Solves J step = e per lane from J's factorisation (meaningless where it is not full rank).
DHKIN_INLINE void solve_square(const SquareQR& qr, const Lanes* e, Lanes* step) {
  Lanes b[6];
  for (int r = 0; r < 6; ++r) b[r] = e[r];
  for (int k = 0; k < kDof; ++k) {
    Lanes d = qr.A[k][k] * b[k];
    for (int r = k + 1; r < 6; ++r) d += qr.A[r][k] * b[r];
    const Lanes factor = 2.0 * d / qr.v_norm[k];
    for (int r = k; r < 6; ++r) b[r] -= factor * qr.A[r][k];
  }
  for (int k = kDof - 1; k >= 0; --k) {
    Lanes total = b[k];
    for (int c = k + 1; c < kDof; ++c) total -= qr.A[k][c] * step[c];
    step[k] = total / qr.diagonal[k];
  }
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
// newton::kMaxSteps steps, ends unsettled. Once every running lane is polishing (both errors
// below kRefineFraction * tolerance), the Jacobian of the last iterate that was not is kept: the
// step from an error epsilon with a Jacobian computed delta away errs by ~delta epsilon, which at
// epsilon <= 1e-12 is below rounding, as Newton's epsilon^2 is.
inline LaneRefinement refine_lanes(const Chain& chain, const ChainShape& shape,
                                   const Frame& target, JointsT<Lanes>& q, Mask active,
                                   double tolerance) {
  using namespace newton;
  const double goal = kRefineFraction * tolerance;
  // the current iterate and the trial, swapped when the trial is taken; a lane that stops never
  // steps again, so only its best iterate is kept lane by lane
  struct Iterate {
    FrameT<Lanes> frames[kDof + 1];
    Lanes e[6];
    PoseErrorT<Lanes> error;
    Lanes size;
  };
  Iterate buffers[2];
  Iterate* now = &buffers[0];
  Iterate* trial_at = &buffers[1];
  JointMotions<Lanes> motions;
  Lanes J[6 * kDof], step[kDof];
  SquareQR qr;
  const auto evaluate = [&](const JointsT<Lanes>& at, Iterate& out) {
    joint_motions(chain, at.data(), motions);
    chain_frames(chain, shape, motions, out.frames);
    out.error = error_twist(out.frames[kDof], target, out.e);
    out.size = out.error.position * out.error.position + out.error.rotation * out.error.rotation;
  };
  evaluate(q, *now);
  BestIterates best{q, now->error, now->size};
  Mask polishing = uniform(false), settled = uniform(false), running = active;
  bool factored = false;
  for (int iteration = 0; iteration < kMaxSteps && any(running); ++iteration) {
    // an exact root: nothing to improve
    settled = settled || (running && now->size == 0.0);
    running = running && !(now->size == 0.0);
    polishing = polishing || (now->error.position <= goal && now->error.rotation <= goal);
    if (!factored || any(running && !polishing)) {
      jacobian(chain, now->frames, J);
      factor_square(J, qr);
      factored = true;
    }
    solve_square(qr, now->e, step);
    Lanes longest = abs(step[0]);
    for (int a = 1; a < kDof; ++a) longest = max(longest, abs(step[a]));
    const Lanes shrink = select(longest > kMaxJointStep, kMaxJointStep / longest, Lanes(1.0));
    JointsT<Lanes> trial;
    for (int a = 0; a < kDof; ++a) trial[a] = q[a] + shrink * step[a];
    evaluate(trial, *trial_at);
    const Lanes trial_size = trial_at->size;
    const Mask taken = qr.full_rank && trial_size <= (kGrowth * kGrowth) * now->size;
    // at the rounding of the arithmetic: the lane stops, keeping the trial if it is the best
    const Mask stop = running && taken && polishing && !(trial_size * kPolishGain <= now->size);
    best.take(stop && trial_size < best.size, trial, trial_at->error, trial_size);
    settled = settled || stop;
    running = running && taken && !stop;  // a rejected step ends the lane unsettled
    if (!any(running)) break;
    q = trial;
    std::swap(now, trial_at);
    best.take(running && now->size < best.size, q, now->error, now->size);
  }
  for (int a = 0; a < kDof; ++a) q[a] = select(active, best.q[a], q[a]);
  return {best.error, settled && active};
}

}  // namespace dhkin
