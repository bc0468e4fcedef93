// The numerical IK's descent from one start (dhkin.ik.numerical): Levenberg-Marquardt, damped
// least squares or Newton steps within the joint limits until the task is met, then, for a
// redundant task, a slide along the solutions toward a preferred configuration.
//
// Frames and units. The chain (chain.hpp) maps joint values q (rad for revolute joints, m for
// prismatic ones, chain order base to tip) to T(q): the model's world frame -> the tip frame
// (dhkin.ik.numerical.task._Chain.parts builds it from the Pinocchio model). The task is in the
// world frame:
// * pose: e = log6(T_target^-1 T(q)), the twist [v; w] (m, rad) taking the target frame to the
//   tip frame, in the target frame (Pinocchio's LOCAL convention); its Jacobian is
//   Jlog6(T_target^-1 T(q)) J_local(q) (se3_log.hpp). Residuals: |p| of T_target^-1 T(q) (m) and
//   |w| (rad).
// * position: e = the first `rows` entries of R_base^T (p_tip + R_tip tcp - p_target), the TCP
//   point's offset from the target in the base axes (m). Residual |e|; the rotation residual is
//   NaN (orientation is not part of the task).
// The module docstring of dhkin/ik/numerical/solver.py states the steps, limits and stopping
// rules for users; the comments below state them in full. This file follows, line for line, the
// Python loop it replaced (src/dhkin/ik/numerical/descent.py before helper i25ad).
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "dhkin/chain.hpp"
#include "dhkin/numerical/pseudo_inverse.hpp"
#include "dhkin/numerical/se3_log.hpp"

namespace dhkin::numerical {

// Vectors and matrices of the descent, sized at run time within fixed bounds (no allocation):
// joint vectors of at most kMaxJoints entries, task vectors of at most 6 rows (TaskJacobian and
// PseudoInverse: pseudo_inverse.hpp).
using JointVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxJoints, 1>;
using JointFlags = Eigen::Matrix<bool, Eigen::Dynamic, 1, 0, kMaxJoints, 1>;
using TaskVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;
using JointSquare = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxJoints, kMaxJoints>;
using TaskSquare = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 6, 6>;

constexpr double kTwoPi = 2.0 * 3.14159265358979323846;

// Smallest damping added to J J^T (dhkin.ik.numerical.LAMBDA_FLOOR): keeps the system solvable
// when J loses rank, and is far too small to slow the quadratic convergence of the last Newton
// steps (sigma_min^2 >> 1e-12).
constexpr double kLambdaFloor = 1e-12;
// Levenberg-Marquardt: lambda = mu |e|^2 + kLambdaFloor, mu starting at kMuInitial; a refused
// step (the cost did not fall) multiplies mu by kMuUp, and mu beyond kMuMax (the step is then
// shorter than the rounding of q) ends the descent; a taken step divides it by kMuDown, down to
// kMuMin (Newton-Raphson in all but name).
constexpr double kMuInitial = 1e-2;
constexpr double kMuMin = 1e-9;
constexpr double kMuMax = 1e8;
constexpr double kMuDown = 3.0;
constexpr double kMuUp = 10.0;
// Relative cut-off of small singular values in the pseudo-inverse of the null-space motion.
constexpr double kPinvRcond = 1e-10;
// Relative cut-off of the Moore-Penrose step of method "newton" (numpy.linalg.pinv's default,
// which the Python loop used).
constexpr double kNewtonRcond = 1e-15;
// Slide: residuals (m or rad) below which a step may move in the null space (and above which
// the step cap halves), below which the cap doubles, and above which the slide goes back to its
// last exact point.
constexpr double kSlideNear = 1e-2;
constexpr double kSlideClose = 2e-3;
constexpr double kSlideLost = 1e-1;
// The slide ends after this many iterations in a row in which a task error that the null-space
// motion does not explain fails to halve.
constexpr int kSlidePatience = 8;
// A joint this close (rad or m) to a limit counts as on it for the null-space motion.
constexpr double kAtLimit = 1e-6;
// Largest null-space motion of one sliding step (rad or m per joint).
constexpr double kSlideStep = 0.3;

enum class Method { kLevenbergMarquardt, kDampedLeastSquares, kNewton };

// dhkin.ik.numerical.SolverSettings, the fields the descent reads.
struct Settings {
  Method method = Method::kLevenbergMarquardt;
  double tolerance = 1e-10;      // a solution's residuals (m and rad) are at most this
  int max_iterations = 100;      // steps of phase 1 (reaching the task)
  double damping = 1e-2;         // method "dls": lambda = damping^2
  double nullspace_gain = 0.5;   // phase 2: share of the pull toward the preference per step
  double nullspace_tolerance = 1e-6;  // phase 2 ends below this null-space motion (rad or m)
  int slide_iterations = 200;    // phase 2 steps at most
  int stall_window = 10;         // phase 1 gives up when the cost has not fallen below
  double stall_ratio = 0.5;      //   stall_ratio x its value stall_window steps earlier
};

// The joints: chain, limits (infinite where there is none) and which joints are angles (their
// values may be shifted by 2 pi to enter the limits).
struct Joints {
  Chain chain;
  JointVector lower, upper;
  JointFlags revolute;

  int dof() const { return chain.dof(); }
};

// One target, prepared in the world frame (dhkin.ik.numerical.task._Task).
struct Task {
  bool pose = true;           // pose task, else position
  int rows = 6;               // task rows: 6 pose, 3 position, 2 planar (x, y)
  Frame target_inverse;       // pose: target frame <- world
  Vec3 world_point;           // position: the target point in the world
  bool to_base = false;       // position: whether base_rotation_t applies
  Mat3 base_rotation_t;       // position: world axes -> base axes
  bool has_tcp = false;       // position: whether the TCP point is off the tip
  Vec3 tcp;                   // position: the TCP point in the tip frame
  bool slides = false;        // phase 2 wanted (a redundant task with a preference)
  JointVector preferred;      // phase 2: the preferred configuration
  JointVector weights;        // phase 2: per-joint weights of the pull toward it
};

// The outcome of one descent (dhkin.ik.numerical.Descent without its start).
struct Outcome {
  JointVector q;
  double position = 0.0;      // m
  double rotation = 0.0;      // rad; NaN in position mode
  int iterations = 0;         // kinematics evaluations after the start's
  bool converged = false;
  double nullspace_motion = 0.0;  // rad, the last null-space motion of phase 2
};

// The task error at q and its Jacobian at the last q evaluated.
class Evaluator {
 public:
  Evaluator(const Joints& joints, const Task& task)
      : joints_(joints), task_(task), frames_(joints.dof() + 1) {}

  // e (rows) at q; returns the (position, rotation) residuals.
  PoseError error_at(const JointVector& q, TaskVector& e) {
    fk_frames(joints_.chain, q.data(), frames_.data());
    const Frame& tip = frames_.back();
    e.resize(task_.rows);
    if (task_.pose) {
      const Frame error = task_.target_inverse * tip;
      error_R_ = rotation_of(error);
      error_p_ = Vector3(error.p[0], error.p[1], error.p[2]);
      e = log6(error_R_, error_p_);
      return {std::sqrt(error_p_.dot(error_p_)), std::sqrt(e.tail<3>().dot(e.tail<3>()))};
    }
    Vec3 point = tip.translation() - task_.world_point;
    if (task_.has_tcp) point = point + tip.rotate(task_.tcp);
    if (task_.to_base) point = task_.base_rotation_t * point;
    const double values[3] = {point.x, point.y, point.z};
    double squared = 0.0;
    for (int r = 0; r < task_.rows; ++r) e[r] = values[r], squared += values[r] * values[r];
    return {std::sqrt(squared), std::numeric_limits<double>::quiet_NaN()};
  }

  // J (rows x dof) of e at the q of the last error_at call.
  void jacobian(TaskJacobian& J) {
    const int n = joints_.dof();
    double world[6 * kMaxJoints];  // geometric Jacobian at the tip origin, world axes
    dhkin::jacobian(joints_.chain, frames_.data(), world);
    const Frame& tip = frames_.back();
    J.resize(task_.rows, n);
    if (task_.pose) {
      Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kMaxJoints> local(6, n);
      for (int j = 0; j < n; ++j) {  // J_local = [R^T v; R^T w]
        for (int r = 0; r < 3; ++r) {
          local(r, j) = tip.R[0][r] * world[0 * n + j] + tip.R[1][r] * world[1 * n + j] +
                        tip.R[2][r] * world[2 * n + j];
          local(3 + r, j) = tip.R[0][r] * world[3 * n + j] + tip.R[1][r] * world[4 * n + j] +
                            tip.R[2][r] * world[5 * n + j];
        }
      }
      J.noalias() = jlog6(error_R_, error_p_) * local;
      return;
    }
    const Vec3 lever = task_.has_tcp ? tip.rotate(task_.tcp) : Vec3{};
    for (int j = 0; j < n; ++j) {  // the TCP point's velocity: v + w x (R tcp)
      Vec3 v{world[0 * n + j], world[1 * n + j], world[2 * n + j]};
      if (task_.has_tcp) {
        v = v + cross(Vec3{world[3 * n + j], world[4 * n + j], world[5 * n + j]}, lever);
      }
      if (task_.to_base) v = task_.base_rotation_t * v;
      const double values[3] = {v.x, v.y, v.z};
      for (int r = 0; r < task_.rows; ++r) J(r, j) = values[r];
    }
  }

 private:
  static Matrix3 rotation_of(const Frame& f) {
    Matrix3 R;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) R(r, c) = f.R[r][c];
    }
    return R;
  }

  const Joints& joints_;
  const Task& task_;
  std::vector<Frame> frames_;  // fk_frames at the last q: each joint's frame, then T(q)
  Matrix3 error_R_;            // pose: T_target^-1 T(q) at the last q
  Vector3 error_p_;
};

// Step -J^# e with J^# the damped pseudo-inverse (Moore-Penrose when damping = 0): the damped
// system J J^T + damping I (or J^T J + damping I when the task has more rows than joints) by
// Cholesky.
inline JointVector task_step(const TaskJacobian& J, const TaskVector& e, double damping) {
  if (damping == 0.0) return -(pseudo_inverse(J, kNewtonRcond) * e);
  const int rows = static_cast<int>(J.rows()), columns = static_cast<int>(J.cols());
  if (rows <= columns) {
    TaskSquare A = J * J.transpose();
    A.diagonal().array() += damping;
    const TaskVector x = A.llt().solve(e);
    return -(J.transpose() * x);
  }
  JointSquare A = J.transpose() * J;
  A.diagonal().array() += damping;
  return -A.llt().solve(J.transpose() * e);
}

// q within the limits: a revolute joint outside them shifted by a multiple of 2 pi when that
// lands inside (only with `wrap`), else clipped. `clipped` marks the joints that were clipped.
inline JointVector project(const Joints& joints, const JointVector& q, bool wrap,
                           JointFlags* clipped = nullptr) {
  const int n = joints.dof();
  JointVector out = q;
  if (clipped) clipped->setConstant(n, false);
  for (int j = 0; j < n; ++j) {
    const double low = joints.lower[j], high = joints.upper[j];
    const bool above = q[j] > high;
    if (!(q[j] < low || above)) continue;
    bool shifted_in = false;
    if (wrap && joints.revolute[j]) {
      const double shifted = above ? q[j] - kTwoPi * std::ceil((q[j] - high) / kTwoPi)
                                   : q[j] + kTwoPi * std::ceil((low - q[j]) / kTwoPi);
      if (shifted >= low && shifted <= high) out[j] = shifted, shifted_in = true;
    }
    if (!shifted_in) {
      out[j] = std::min(std::max(q[j], low), high);
      if (clipped) (*clipped)[j] = true;
    }
  }
  return out;
}

// The descent of one start: reach (phase 1), then slide (phase 2) when the task asks for it.
class Descent {
 public:
  Descent(const Joints& joints, const Task& task, const Settings& settings)
      : joints_(joints), task_(task), settings_(settings), evaluator_(joints, task) {}

  Outcome run(const JointVector& start) {
    Outcome reached = reach(start);
    if (reached.converged && task_.slides && settings_.nullspace_gain > 0.0) {
      return slide(reached);
    }
    return reached;
  }

  JointVector project(const JointVector& q, bool wrap, JointFlags* clipped = nullptr) const {
    return numerical::project(joints_, q, wrap, clipped);
  }

 private:
  static bool met(const PoseError& r, double tolerance) {
    return r.position <= tolerance && !(r.rotation > tolerance);
  }

  // Phase 1: steps until the residuals are within tolerance, max_iterations are spent, LM finds
  // no descending step (mu > kMuMax), or the cost has not fallen below stall_ratio x its value
  // stall_window steps earlier (a new start is then the better bet).
  Outcome reach(const JointVector& start) {
    const Settings& s = settings_;
    JointVector q = project(start, true);
    TaskVector e, e_new;
    PoseError residual = evaluator_.error_at(q, e);
    TaskJacobian J;
    evaluator_.jacobian(J);
    double cost = e.dot(e);
    double mu = kMuInitial;
    int iterations = 0;
    std::vector<double> costs{cost};  // cost at the current point, per iteration
    const bool lm = s.method == Method::kLevenbergMarquardt;
    while (!met(residual, s.tolerance)) {
      if (iterations >= s.max_iterations) break;
      if (iterations >= s.stall_window && cost > s.stall_ratio * costs[iterations - s.stall_window]) {
        break;
      }
      const double damping = lm ? mu * cost + kLambdaFloor
                                : s.method == Method::kDampedLeastSquares ? s.damping * s.damping
                                                                           : 0.0;
      const JointVector candidate = bounded_step(q, J, e, damping, true);
      ++iterations;
      const PoseError residual_new = evaluator_.error_at(candidate, e_new);
      const double cost_new = e_new.dot(e_new);
      if (lm && !(cost_new < cost)) {
        costs.push_back(cost);
        mu *= kMuUp;
        if (mu > kMuMax) break;
        continue;
      }
      costs.push_back(cost_new);
      mu = std::max(mu / kMuDown, kMuMin);
      q = candidate, e = e_new, residual = residual_new, cost = cost_new;
      evaluator_.jacobian(J);
    }
    Outcome out;
    out.q = q, out.position = residual.position, out.rotation = residual.rotation;
    out.iterations = iterations, out.converged = met(residual, s.tolerance);
    return out;
  }

  // q plus the task step, within the limits (2 pi shifts allowed when `wrap`). A joint the step
  // would push through a limit is put on the limit, its column leaves the Jacobian and the other
  // joints take up its share of the error (one active-set round); whatever still leaves the
  // limits is then clipped.
  JointVector bounded_step(const JointVector& q, const TaskJacobian& J, const TaskVector& e,
                           double damping, bool wrap) const {
    JointFlags clipped;
    const JointVector candidate = project(q + task_step(J, e, damping), wrap, &clipped);
    if (!clipped.any()) return candidate;
    JointVector held = candidate - q;
    TaskJacobian free_J = J;
    for (int j = 0; j < joints_.dof(); ++j) {
      if (clipped[j]) {
        free_J.col(j).setZero();
      } else {
        held[j] = 0.0;
      }
    }
    const TaskVector shifted_e = e + J * held;
    JointVector step = task_step(free_J, shifted_e, damping);
    for (int j = 0; j < joints_.dof(); ++j) {
      if (clipped[j]) step[j] = held[j];
    }
    return project(q + step, wrap);
  }

  // Phase 2 (redundant tasks): from a solution, move along the solutions toward the preferred
  // configuration. Each iteration, at q with task error e: if the residual is at most
  // kSlideNear, step by the null-space motion n = (I - J^+ J) gain W (q_preferred - q) (joints on
  // a limit that it would push through held, null_motion), scaled down to a largest joint motion
  // `cap` and to stop at the first limit it meets, and correct the task by a Newton step
  // (bounded_step, so joints on a limit stay there); otherwise correct the task only. `cap`
  // starts at kSlideStep, halves when a residual is above kSlideNear and doubles (up to
  // kSlideStep) when it is at most kSlideClose; a residual above kSlideLost sends the slide back
  // to its last exact point. When the null-space motion turns back (it overshot the optimum along
  // a curved set of solutions) its gain halves, and it grows back by 1.25 per step that does not.
  // Ends at an exact point whose null-space motion is at most nullspace_tolerance, after
  // kSlidePatience + 1 iterations in a row in which a task error larger than the null-space
  // motion failed to halve (a limit keeps the task out of reach), or after slide_iterations;
  // returns the last exact point (the phase-1 solution at worst).
  Outcome slide(const Outcome& reached) {
    const Settings& s = settings_;
    const double tolerance = s.tolerance;
    JointVector q = reached.q;
    TaskVector e;
    PoseError residual_now = evaluator_.error_at(q, e);
    TaskJacobian J;
    evaluator_.jacobian(J);
    JointVector best_q = q;
    PoseError best = residual_now;
    double motion = std::numeric_limits<double>::infinity();
    double cap = kSlideStep;
    double gain = s.nullspace_gain;
    JointVector previous_motion;
    bool has_previous = false;
    double previous_residual = std::numeric_limits<double>::infinity();
    double applied_motion = 0.0;
    int stalls = 0;
    int iterations = 0;
    while (iterations < s.slide_iterations) {
      const double residual = std::isnan(residual_now.rotation)
                                  ? residual_now.position
                                  : std::max(residual_now.position, residual_now.rotation);
      const bool stuck = residual > tolerance && residual > 0.5 * previous_residual &&
                         applied_motion <= residual;
      stalls = stuck ? stalls + 1 : 0;
      if (stalls > kSlidePatience) break;  // a limit keeps the task out of reach
      previous_residual = residual, applied_motion = 0.0;
      JointVector step_from;
      if (residual > kSlideNear) {
        cap *= 0.5;
        step_from = q;
        if (residual > kSlideLost) {  // lost: back to the last exact point, task error zero
          step_from = best_q;
          e.setZero();
          TaskVector ignored;
          evaluator_.error_at(best_q, ignored);
          evaluator_.jacobian(J);
        }
      } else {
        if (residual <= kSlideClose) cap = std::min(2.0 * cap, kSlideStep);
        const PseudoInverse inverse = pseudo_inverse(J, kPinvRcond);
        const JointVector pull =
            (s.nullspace_gain * task_.weights.array() * (task_.preferred - q).array()).matrix();
        JointVector null_step = null_motion(q, J, inverse, pull);
        const double largest = null_step.cwiseAbs().maxCoeff();
        if (residual <= tolerance) {
          best_q = q, best = residual_now, motion = largest;
          if (largest <= s.nullspace_tolerance) break;
        }
        if (has_previous && null_step.dot(previous_motion) < 0.0) {
          gain *= 0.5;  // overshot the optimum along a curved self-motion: go slower
        } else {
          gain = std::min(1.25 * gain, s.nullspace_gain);
        }
        previous_motion = null_step, has_previous = true;
        const double scale = gain / s.nullspace_gain;
        // the cap over the largest joint motion (no division by zero when the motion is zero)
        const double capped = cap / std::max(largest, std::numeric_limits<double>::min());
        null_step *= std::min({scale, capped, room(q, null_step)});
        applied_motion = null_step.cwiseAbs().maxCoeff();
        step_from = project(q + null_step, false);
      }
      q = bounded_step(step_from, J, e, kLambdaFloor, false);
      ++iterations;
      residual_now = evaluator_.error_at(q, e);
      evaluator_.jacobian(J);
    }
    Outcome out;
    out.q = best_q, out.position = best.position, out.rotation = best.rotation;
    out.iterations = reached.iterations + iterations, out.converged = true;
    out.nullspace_motion = motion;
    return out;
  }

  // Largest scale s <= 1 with q + s motion within the limits (0 if none fits).
  double room(const JointVector& q, const JointVector& motion) const {
    double smallest = std::numeric_limits<double>::infinity();
    for (int j = 0; j < joints_.dof(); ++j) {
      if (motion[j] > 0.0) {
        smallest = std::min(smallest, (joints_.upper[j] - q[j]) / motion[j]);
      } else if (motion[j] < 0.0) {
        smallest = std::min(smallest, (joints_.lower[j] - q[j]) / motion[j]);
      }
    }
    return std::max(0.0, std::min(1.0, smallest));
  }

  // (I - J^+ J) pull, with the joints that sit on a limit and would be pushed through it held
  // still (their columns leave J): at a limit the optimum is a KKT point, where this motion
  // vanishes.
  JointVector null_motion(const JointVector& q, const TaskJacobian& J,
                          const PseudoInverse& inverse, const JointVector& pull) const {
    const TaskVector task_pull = J * pull;
    JointVector null_step = pull - inverse * task_pull;
    JointFlags blocked(joints_.dof());
    for (int j = 0; j < joints_.dof(); ++j) {
      blocked[j] = (q[j] <= joints_.lower[j] + kAtLimit && null_step[j] < 0.0) ||
                   (q[j] >= joints_.upper[j] - kAtLimit && null_step[j] > 0.0);
    }
    if (!blocked.any()) return null_step;
    TaskJacobian free_J = J;
    JointVector free_pull = pull;
    for (int j = 0; j < joints_.dof(); ++j) {
      if (blocked[j]) free_J.col(j).setZero(), free_pull[j] = 0.0;
    }
    const PseudoInverse free_inverse = pseudo_inverse(free_J, kPinvRcond);
    const TaskVector free_task_pull = free_J * free_pull;
    return free_pull - free_inverse * free_task_pull;
  }

  const Joints& joints_;
  const Task& task_;
  const Settings& settings_;
  Evaluator evaluator_;
};

}  // namespace dhkin::numerical
