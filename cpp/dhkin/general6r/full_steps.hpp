// Newton by full Gauss-Newton steps from an elimination start near a simple root
// (docs/general6r.md, "Speed, third pass"): the cheap way to the root for the starts that need
// no damping; the others go to refine() (newton.hpp) from the start itself, as before.
//
// An elimination start lies within ~1e-8 of its root (its eigenvalue and null vector; a
// cluster's split ~1e-5), where Newton converges quadratically: one or two full steps reach the
// arithmetic's rounding. refine() takes the same steps by a damped 12 x 6 least squares and
// polishes until a step gains less than twofold, which costs one evaluation more per root (the
// step that tries to gain below the rounding), and settle() then evaluated the chain twice more
// at the root (check() for the residual, smallest_singular() for the Jacobian). Here the frames
// of the last evaluation give both: the residual (the end frame is fk()'s own value, so
// pose_error of it is check()'s) and the Jacobian at the root.
//
// Joint values are URDF joint values (rad); `chain` is the exact chain to the point verified,
// targets that point's pose in DH frame 0 (metres).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "dhkin/chain.hpp"
#include "dhkin/family.hpp"
#include "dhkin/general6r/decomposed_types.hpp"  // Jacobian
#include "dhkin/general6r/square_lu.hpp"
#include "dhkin/newton.hpp"
#include "dhkin/simd.hpp"

namespace dhkin::general6r {

// Full steps allowed: from ~1e-5 (a cluster's split) quadratic convergence reaches the rounding
// in three; a start that needs more is not near a simple root, and refine() takes it over.
constexpr int kFullSteps = 4;
// The chain's FK rounds the end frame by a few ulps (per metre of the lever, per rad): an error
// within this many is at the rounding, where no step can shrink it twofold for certain (the step
// that tries costs an evaluation per root), so the steps stop there.
constexpr double kRoundingUlps = 4.0;

// Jacobian (6 x kDof, row-major): decomposed_types.hpp.

// The chain at one set of joint values (per lane for V = Lanes): the frames each joint moves
// about and the end frame (chain_frames: fk()'s and fk_frames' values), the error twist against
// the target and its size.
template <class V>
struct EvaluationT {
  std::array<FrameT<V>, kDof + 1> frames;
  V e[6];
  PoseErrorT<V> error;
  V size{};  // position^2 + rotation^2
};
using Evaluation = EvaluationT<double>;

template <class V>
DHKIN_INLINE void evaluate(const Chain& chain, const ChainShape& shape, const JointsT<V>& q,
                           const Frame& target, EvaluationT<V>& out) {
  JointMotions<V> motions;
  joint_motions(chain, q.data(), motions);
  chain_frames(chain, shape, motions, out.frames.data());
  out.error = error_twist(out.frames[kDof], target, out.e);
  out.size = out.error.position * out.error.position + out.error.rotation * out.error.rotation;
}

// 1 / |J^-1|_F of J (row-major 6 x 6 values, per lane), a lower bound of its smallest singular
// value (within sqrt(6) of it; 0 where J is singular or not finite).
template <class V>
DHKIN_INLINE V singular_bound_of(const V* J) {
  SquareLU<V> lu;
  lu_factor6(J, lu);
  const V inverse_size = inverse_norm6(lu);
  return select(inverse_size < INFINITY, 1.0 / inverse_size, V(0.0));
}

inline double singular_bound(const Jacobian& J) { return singular_bound_of(J.data()); }

// What full_steps() reached (per lane for V = Lanes).
template <class V>
struct FullStepsT {
  MaskOf<V> converged = every_lane<V>(false);
  PoseErrorT<V> error;  // check()'s error at the root
  V sigma_bound{};      // singular_bound of the scaled Jacobian at the root
};
using FullStepRoot = FullStepsT<double>;
using FullStepLanes = FullStepsT<Lanes>;

// Whether an error is at the rounding (kRoundingUlps, per metre of `lever`) and within
// newton::kRefineFraction of `goal`: where full_steps() stops.
template <class V>
DHKIN_INLINE MaskOf<V> at_rounding(const PoseErrorT<V>& e, double goal, double lever) {
  const double ulp = std::numeric_limits<double>::epsilon() * kRoundingUlps;
  const double converged = newton::kRefineFraction * goal;
  return e.position <= ulp * lever && e.rotation <= ulp && e.position <= converged &&
         e.rotation <= converged;
}

// now = trial in the lanes `taken` (every value where V = double and `taken`).
template <class V>
DHKIN_INLINE void take_lanes(MaskOf<V> taken, const EvaluationT<V>& trial, EvaluationT<V>& now) {
  for (int f = 0; f <= kDof; ++f) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        now.frames[f].R[r][c] = select(taken, trial.frames[f].R[r][c], now.frames[f].R[r][c]);
      }
      now.frames[f].p[r] = select(taken, trial.frames[f].p[r], now.frames[f].p[r]);
    }
  }
  for (int r = 0; r < 6; ++r) now.e[r] = select(taken, trial.e[r], now.e[r]);
  now.error.position = select(taken, trial.error.position, now.error.position);
  now.error.rotation = select(taken, trial.error.rotation, now.error.rotation);
  now.size = select(taken, trial.size, now.size);
}

// Full Gauss-Newton steps from q towards `target` (per lane of q in the lanes `active`, for V =
// Lanes), each solved by LU of the 6 x 6 Jacobian, while each is within newton::kMaxJointStep per
// joint and shrinks the squared error newton::kPolishGain-fold (refine()'s polishing rule), at
// most kFullSteps, until the error is at
// the rounding and within newton::kRefineFraction of `goal` (at_rounding: refine()'s
// convergence). Where they get there, q (in place) is the root, with its error and singular bound
// (linear rows of the Jacobian over `lever`). Where not (a start farther off, a singular root's
// linear convergence, a nearly singular Jacobian's error that stops shrinking above the
// rounding), q is left as it was: refine() takes it from the start, as it did before.
//
// One code for one start (V = double) and for up to kLanes starts at once (V = Lanes): each lane
// takes the operations of one start on its own values (the lane type's arithmetic is the
// double's, square_lu.hpp's LU the same for both), so a lane converges exactly where one start
// would, with the same root, error and singular bound, bit for bit. A lane stops at its own
// rounding, at a step beyond kMaxJointStep or one that does not gain kPolishGain-fold; the others
// step on.
template <class V>
inline FullStepsT<V> full_steps_of(const Chain& chain, const ChainShape& shape,
                                   const Frame& target, JointsT<V>& q, MaskOf<V> active,
                                   double goal, double lever) {
  FullStepsT<V> out;
  EvaluationT<V> now, trial;
  JointsT<V> current = q;
  evaluate(chain, shape, current, target, now);
  MaskOf<V> stopped = !active;  // failed (or not a start): never converges
  V J[6 * kDof];
  for (int step = 0; step < kFullSteps; ++step) {
    const MaskOf<V> running = !stopped && !at_rounding(now.error, goal, lever);
    if (!any(running)) break;
    jacobian(chain, now.frames.data(), J);
    SquareLU<V> lu;
    lu_factor6(J, lu);
    V dq[kDof];
    lu_solve6(lu, now.e, dq);
    MaskOf<V> within = every_lane<V>(true);
    for (int j = 0; j < kDof; ++j) within = within && abs(dq[j]) <= newton::kMaxJointStep;
    stopped = stopped || (running && !within);  // also NaN
    const MaskOf<V> stepping = running && within;
    if (!any(stepping)) break;  // every lane has stopped or is at its rounding
    JointsT<V> next;
    for (int j = 0; j < kDof; ++j) next[j] = select(stepping, current[j] + dq[j], current[j]);
    evaluate(chain, shape, next, target, trial);
    const MaskOf<V> gains = trial.size * newton::kPolishGain <= now.size;
    stopped = stopped || (stepping && !gains);
    const MaskOf<V> taken = stepping && gains;
    for (int j = 0; j < kDof; ++j) current[j] = select(taken, next[j], current[j]);
    take_lanes(taken, trial, now);
  }
  out.converged = !stopped && at_rounding(now.error, goal, lever);
  if (!any(out.converged)) return out;
  jacobian(chain, now.frames.data(), J);
  for (int i = 0; i < 3 * kDof; ++i) J[i] = J[i] / lever;
  out.error = pose_error(now.frames[kDof], target);
  out.sigma_bound = singular_bound_of(J);
  for (int j = 0; j < kDof; ++j) q[j] = select(out.converged, current[j], q[j]);
  return out;
}

// One start (full_steps_of). Where the steps do not get there, q is left as it was.
inline FullStepRoot full_steps(const Chain& chain, const ChainShape& shape, const Frame& target,
                               Joints& q, double goal, double lever) {
  return full_steps_of<double>(chain, shape, target, q, true, goal, lever);
}

// Up to kLanes starts, one per lane of q, in the lanes `active` (full_steps_of).
inline FullStepLanes full_steps_lanes(const Chain& chain, const ChainShape& shape,
                                      const Frame& target, JointsT<Lanes>& q, Mask active,
                                      double goal, double lever) {
  return full_steps_of<Lanes>(chain, shape, target, q, active, goal, lever);
}

// A verified root q (in place) whose error is above the rounding, finished by full_steps() where
// they get it there: refine() stops polishing at the first step that gains less than twofold,
// which a step still damped after rejections on the way can be (a tilted-UR5 root at q5 = 0,
// sigma_min 0.03, stopped at 5.7e-13 m; one full step from there reaches 3e-16). The error and,
// where the steps got there, the singular bound at q (else 0) are updated.
inline void finish(const Chain& chain, const ChainShape& shape, const Frame& target, Joints& q,
                   double goal, double lever, PoseError& error, double& sigma_bound) {
  if (at_rounding(error, goal, lever)) return;
  Joints trial = q;
  const FullStepRoot quick = full_steps(chain, shape, target, trial, goal, lever);
  if (!quick.converged || !(quick.error.largest() < error.largest())) return;
  q = trial;
  error = quick.error;
  sigma_bound = quick.sigma_bound;
}

}  // namespace dhkin::general6r
