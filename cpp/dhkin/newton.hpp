// Newton's method on the exact chain: damped Gauss-Newton steps solved by Householder QR of the
// Jacobian itself (not J^T J, so that a chain a hair from singular, sigma_min ~ 1e-8, keeps its
// accuracy), joint steps bounded, the best iterate kept.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "dhkin/chain.hpp"

namespace dhkin {

namespace newton {

// Refinement has converged once both errors are below this fraction of the verification
// tolerance (a thousandfold margin); it then goes on polishing while Newton still improves.
constexpr double kRefineFraction = 1e-3;
// Polishing stops at the first step that does not shrink the squared error by this factor (the
// error by sqrt 2): Newton's convergence is quadratic, and linear at worst near a singular root,
// where it still gains more than that per step; a step that gains less has reached the rounding
// of the arithmetic, where further steps only wander.
constexpr double kPolishGain = 2.0;
// At most this many Newton steps per refinement. The closed form starts within the model
// deviation (millimetres on a calibrated arm); converging refinements take 3-8 steps, more when
// the pose is near a singularity of the exact chain.
constexpr int kMaxSteps = 30;
// Chain evaluations allowed by default (each rejected step costs one).
constexpr int kBudget = 4 * kMaxSteps;
// Largest change of one joint per step (rad or m): near a singularity a full Gauss-Newton step
// can jump to another branch.
constexpr double kMaxJointStep = 0.3;
// A step is taken when it leaves the error below this multiple of the current one. Newton's
// iterates may first grow before they converge (from a start millimetres away, and near a
// singular root, where the first full step overshoots by orders of magnitude and convergence is
// linear). Joint steps are bounded and the best iterate is returned, so only a step that makes
// the error a million times larger is damped.
constexpr double kGrowth = 1e6;
// A monotone descent (Levenberg-Marquardt): a step is taken only when the error does not grow.
constexpr double kMonotone = 1.0;
// Damping after a rejected step: this fraction of the diagonal of J^T J first, growing a
// hundredfold per rejection; a taken step divides it by ten.
constexpr double kDampingStart = 1e-9;
// Damping to start from when the start is a seed, not a closed-form candidate (Marquardt's
// start for a guess that may be far from a root: a hundredth of the diagonal of J^T J).
constexpr double kSeedDamping = 1e-2;
// Largest damping before giving up (the step is then shorter than rounding).
constexpr double kDampingLimit = 1e12;

// The step minimising |J step - e|^2 + damping * sum_j (|J_j| step_j)^2 over the free joints
// (fixed ones get step 0), by Householder QR of the stacked system [J; sqrt(damping) diag(|J_j|)].
// J is 6 x kDof row-major. Per lane for V = Lanes (refine_lanes_exact.hpp: each lane its own
// damping, the same operations in the same order as for a double). Returns where the free
// columns are of full rank; elsewhere `step` is not meaningful.
template <class V>
DHKIN_INLINE MaskOf<V> least_squares(const V* J, const V* e, const JointMask& fixed, V damping,
                                     V* step) {
  constexpr int rows = 6 + kDof;
  V A[rows][kDof];
  V b[rows];
  for (int j = 0; j < kDof; ++j) step[j] = V(0.0);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < kDof; ++c) A[r][c] = V(0.0);
    b[r] = r < 6 ? e[r] : V(0.0);
  }
  int m = 0;  // free columns
  for (int j = 0; j < kDof; ++j) {
    if (fixed[j]) continue;
    V column(0.0);
    for (int r = 0; r < 6; ++r) {
      A[r][m] = J[r * kDof + j];
      column += J[r * kDof + j] * J[r * kDof + j];
    }
    A[6 + m][m] = sqrt(damping * column);
    ++m;
  }
  MaskOf<V> solved = every_lane<V>(true);
  for (int k = 0; k < m; ++k) {  // Householder reflection of column k below the diagonal
    // Column k is zero below row 6 + k: a damping row 6 + c holds only its diagonal entry until
    // reflection c (c >= k) reaches it, and a fixed joint's damping row stays zero. The sums over
    // rows k .. 6 + k are those over every row below k with their zero terms dropped (the same
    // values, short of the sign of a zero), and the reflection leaves the rows below unchanged.
    const int end = 7 + k;
    V length(0.0);
    for (int r = k; r < end; ++r) length += A[r][k] * A[r][k];
    length = sqrt(length);
    solved = solved && !(length == 0.0);
    const V alpha = select(A[k][k] >= 0.0, -length, length);
    A[k][k] -= alpha;
    V v_norm(0.0);
    for (int r = k; r < end; ++r) v_norm += A[r][k] * A[r][k];
    const MaskOf<V> reflect = v_norm > 0.0;
    if (any(reflect)) {
      for (int c = k + 1; c < m; ++c) {
        V d(0.0);
        for (int r = k; r < end; ++r) d += A[r][k] * A[r][c];
        const V factor = 2.0 * d / v_norm;
        for (int r = k; r < end; ++r) A[r][c] = select(reflect, A[r][c] - factor * A[r][k], A[r][c]);
      }
      V d(0.0);
      for (int r = k; r < end; ++r) d += A[r][k] * b[r];
      const V factor = 2.0 * d / v_norm;
      for (int r = k; r < end; ++r) b[r] = select(reflect, b[r] - factor * A[r][k], b[r]);
    }
    A[k][k] = alpha;  // R's diagonal
  }
  V largest(0.0);
  for (int k = 0; k < m; ++k) largest = max(largest, abs(A[k][k]));
  V solution[kDof];
  for (int k = m - 1; k >= 0; --k) {
    solved = solved && abs(A[k][k]) > 1e-15 * largest;  // the rank test
    V total = b[k];
    for (int c = k + 1; c < m; ++c) total -= A[k][c] * solution[c];
    solution[k] = total / A[k][k];
  }
  m = 0;
  for (int j = 0; j < kDof; ++j) {
    if (!fixed[j]) step[j] = solution[m++];
  }
  return solved;
}

// Per lane the best iterate of a Newton run in lanes (refine_lanes, refine_lanes_exact): its
// joint values, errors and squared error size, replaced lane by lane.
struct BestIterates {
  JointsT<Lanes> q;
  PoseErrorT<Lanes> error;
  Lanes size;

  // The iterate at (errors e, squared size) in the lanes m.
  void take(Mask m, const JointsT<Lanes>& at, const PoseErrorT<Lanes>& e, Lanes squared) {
    for (int a = 0; a < kDof; ++a) q[a] = select(m, at[a], q[a]);
    error.position = select(m, e.position, error.position);
    error.rotation = select(m, e.rotation, error.rotation);
    size = select(m, squared, size);
  }
};

struct Settings {
  int budget = kBudget;       // chain evaluations
  double growth = kGrowth;    // kGrowth: Newton; kMonotone: a monotone descent
  double damping_start = 0.0;
  // Stop at the first descent step (one that does not grow the error) that shrinks the squared
  // error less than kPolishGain-fold, converged or not. For a problem whose least error need not
  // be zero (a singular family's member with its free joint held, a long shot beyond the ideal
  // model's reach), where that least error, or the point reaching it, is all that is wanted: Gauss-Newton's steps gain only linearly there, at a
  // rate c^2 per step on the squared error (c: the residual times the curvature over the least
  // singular value squared), so such a step leaves the squared error within c^2 / (1 - c^2) of
  // itself above the least one. Near a root the steps gain quadratically (a double root's
  // fourfold) and go on; a step that grows the error (Newton's first steps from millimetres
  // away) goes on as without it.
  bool stop_on_stall = false;
};

}  // namespace newton

// Newton's method on the exact chain from q, in place, towards `target` (DH frame 0 -> n);
// joints marked `fixed` keep their value (the seed's choice of a free joint at a singularity).
// q ends as the best iterate; returns its errors.
//
// Each step minimises |J dq - e|^2 + lambda sum_j (|J_j| dq_j)^2 over the free joints by QR
// (lambda = 0 is Gauss-Newton), shortened to kMaxJointStep per joint. A step is taken unless it
// makes |e| more than `growth` times larger; then lambda grows (kDampingStart, x100) and the step
// is solved again; `damping_start` damps the first steps. Converged when both errors are below
// kRefineFraction * tolerance; it then polishes until a step no longer shrinks the squared error
// kPolishGain-fold (the limit of the arithmetic: the tolerance decides what is returned, not how
// well it is solved). Stops there, after kMaxSteps, after `budget` evaluations of the chain, or
// when lambda passes kDampingLimit.
inline PoseError refine(const Chain& chain, const Frame& target, Joints& q, const JointMask& fixed,
                        double tolerance, const newton::Settings& settings = {}) {
  using namespace newton;
  std::array<Frame, kDof + 1> frames, trial_frames;
  double e[6], trial_e[6], J[6 * kDof], step[kDof];
  Joints trial, best = q;
  const double goal = kRefineFraction * tolerance;
  const ChainShape shape(chain);  // Joints: at most kDof joints
  fk_frames(chain, shape, q.data(), frames.data());
  PoseError error = error_twist(frames[kDof], target, e);
  double size = error.position * error.position + error.rotation * error.rotation;
  PoseError best_error = error;
  double best_size = size;
  // Directions along which even a maximal joint step moves the pose by less than the goal
  // (singular values below goal / kMaxJointStep, e.g. the free joint of an exactly singular
  // wrist) carry no information: this damping floor suppresses them, keeping the step the
  // minimum-norm one, while sigma ~ 1e-8 (a chain a hair from singular) stays fully active.
  const double floor = (goal / kMaxJointStep) * (goal / kMaxJointStep);
  double damping = std::max(floor, settings.damping_start);
  int evaluations = 1;
  PoseError trial_error;
  double trial_size = 0.0;
  bool polishing = false;  // converged: steps go on while each shrinks the error kPolishGain-fold
  for (int iteration = 0; iteration < kMaxSteps; ++iteration) {
    if (evaluations >= settings.budget || size == 0.0) break;
    if (error.position <= goal && error.rotation <= goal) polishing = true;
    jacobian(chain, frames.data(), J);
    bool taken = false;
    while (!taken) {
      if (least_squares(J, e, fixed, damping, step)) {
        double longest = 0.0;
        for (int a = 0; a < kDof; ++a) longest = std::max(longest, std::abs(step[a]));
        const double shrink = longest > kMaxJointStep ? kMaxJointStep / longest : 1.0;
        for (int a = 0; a < kDof; ++a) trial[a] = q[a] + shrink * step[a];
        fk_frames(chain, shape, trial.data(), trial_frames.data());
        ++evaluations;
        trial_error = error_twist(trial_frames[kDof], target, trial_e);
        trial_size = trial_error.position * trial_error.position +
                     trial_error.rotation * trial_error.rotation;
        taken = trial_size <= settings.growth * settings.growth * size;
      }
      if (!taken) {
        damping = std::max(100.0 * damping, kDampingStart + floor);
        if (damping > kDampingLimit || evaluations >= settings.budget) break;
      }
    }
    if (!taken) break;
    const bool stalled = trial_size <= size && !(trial_size * kPolishGain <= size);
    if ((polishing && !(trial_size * kPolishGain <= size)) || (settings.stop_on_stall && stalled)) {
      if (trial_size < best_size) best_error = trial_error, best_size = trial_size, best = trial;
      break;  // at the rounding of the arithmetic
    }
    q = trial;
    for (int r = 0; r < 6; ++r) e[r] = trial_e[r];
    frames = trial_frames;
    error = trial_error;
    size = trial_size;
    damping = damping > kDampingStart ? std::max(0.1 * damping, floor) : floor;
    if (size < best_size) {
      best_error = error;
      best_size = size;
      best = q;
    }
  }
  q = best;
  return best_error;
}

}  // namespace dhkin
