// The general 6R solver's roots along the valley of a nearly singular root (docs/general6r.md,
// "Near a curve of solutions").
//
// A pose a hair from one with a curve of solutions (the folded M-430iA/2P: links 2 and 3 equally
// long, q3 = 180 deg, q2 free) keeps, of that curve, a few isolated roots whose Jacobian is
// nearly singular (sigma ~ the distance from the curve's pose), and a matrix polynomial that is
// nearly singular too: its eigenvalues there are noise, and the elimination returns some of
// those roots, not all (at q3 = -179.97 deg, 2 of 8). Every one of them lies on the curve that
// the pose's equations minus their weakest combination (five equations in six joints, the
// combination re-taken at each point reached: it turns along a wrist's broken curve) define
// through a root: traced by predictor-corrector continuation from each root the elimination
// gave, the weakest combination changes sign at each of the others.
//
// Joint values are URDF joint values (rad); `chain` is the exact chain to the point verified;
// `target` its pose in DH frame 0 (metres). Errors are scaled as the Jacobian: metres over the
// lever, rad.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "dhkin/general6r/members.hpp"
#include "dhkin/general6r/roots.hpp"

// Compiled once, in cpp/eigen_instances.cpp (docs/architecture.md, "Build time").
extern template void Eigen::PartialPivLU<Eigen::Matrix<double, dhkin::kDof, dhkin::kDof>>::compute();

namespace dhkin::general6r {

// Longest continuation step (rad, joint space; a step whose corrector fails is retried half as
// long, down to kValleyStep / 64). Two roots within one step would cancel each other's sign
// change; the roots along a valley lie 1.3 rad apart and more (the M-430iA/2P's 8 at
// q3 = -179.97 deg, 4 on each of two closed valleys 9 rad long), a fold's pair (2 sigma / kappa
// apart) is found by its fold partner (roots.hpp).
constexpr double kValleyStep = 0.1;
// Arc length (rad) after which a valley that has not closed on itself is given up: two turns
// (the M-430iA/2P's closed after 9 rad). A curve of solutions of the nearby pose is a closed
// curve of joint space; a valley that runs on is no trace of one.
constexpr double kValleyLength = 2.0 * kTwoPi;
// Corrector (Gauss-Newton) iterations per step.
constexpr int kCorrectorIterations = 8;

using Vector6 = Eigen::Matrix<double, 6, 1>;
using Relaxed = Eigen::Matrix<double, 5, kDof>;

// The scaled pose error (target - state, position over `lever`) and Jacobian at q.
inline Vector6 scaled_error(const Chain& chain, const Frame& target, const Joints& q,
                            double lever, Jacobian& J) {
  std::array<Frame, kDof + 1> frames;
  fk_frames(chain, q.data(), frames.data());
  double e[6];
  error_twist(frames[kDof], target, e);
  jacobian(chain, frames.data(), J.data());
  J.topRows<3>() /= lever;
  Vector6 out;
  out << e[0] / lever, e[1] / lever, e[2] / lever, e[3], e[4], e[5];
  return out;
}

// One valley's equations near a point: the curve {q : strong^T e(q) = 0} (`strong`: the five
// strongest left singular vectors of the Jacobian at the point, transposed; trace_valley re-takes
// them at each point it reaches), `weak` the sixth, along which e changes sign at each root on
// the curve.
struct Valley {
  Relaxed strong;
  Vector6 weak;
};

// q moved onto the valley (Gauss-Newton, minimum-norm steps) and its tangent (the null vector
// of strong J, oriented along `previous`); the weak combination of the error there. False where
// the corrector does not converge to `goal`.
inline bool onto_valley(const Chain& chain, const Frame& target, const Valley& valley,
                        double lever, double goal, const Vector6& previous, Joints& q,
                        Vector6& tangent, double& weak_error) {
  Jacobian J;
  for (int iteration = 0; iteration <= kCorrectorIterations; ++iteration) {
    const Vector6 e = scaled_error(chain, target, q, lever, J);
    // A completed by the previous tangent: its solution with right side (0, 1) is the new
    // tangent (A t = 0, t . previous = 1), and with (strong e, 0) the corrector's step, the one
    // across the curve (e = target - state and J = d state / dq: A dq = strong e)
    Eigen::Matrix<double, kDof, kDof> bordered;
    bordered.topRows<5>() = valley.strong * J;
    bordered.row(5) = previous.transpose();
    const Eigen::PartialPivLU<Eigen::Matrix<double, kDof, kDof>> lu(bordered);
    Vector6 right = Vector6::Zero();
    right.head<5>() = valley.strong * e;
    if (right.cwiseAbs().maxCoeff() <= goal) {
      tangent = lu.solve(Vector6::Unit(5));
      const double length = tangent.norm();
      if (!(length > 0.0) || !tangent.allFinite()) return false;
      tangent /= length;
      weak_error = valley.weak.dot(e);
      return true;
    }
    if (iteration == kCorrectorIterations) break;
    const Vector6 step = lu.solve(right);
    if (!step.allFinite()) return false;
    for (int j = 0; j < kDof; ++j) q[j] += step(j);
  }
  return false;
}

// A root near where the weak combination changed sign (between a and b, linearly interpolated),
// refined by Newton and verified at `tolerance`, appended to `roots` unless it is one of them;
// `met` (one flag per root) marks it.
inline void add_crossing(const Chain& chain, const Frame& target, const Joints& a, double weak_a,
                         const Joints& b, double weak_b, double tolerance, double lever,
                         double band, std::vector<Root>& roots, std::vector<bool>& met) {
  const double t = weak_a / (weak_a - weak_b);
  Joints q;
  for (int j = 0; j < kDof; ++j) q[j] = a[j] + t * (b[j] - a[j]);
  const double goal = refine_tolerance(tolerance, lever);
  refine(chain, target, q, JointMask{}, goal, {kBudget, newton::kGrowth, 0.0});
  PoseError error = check(chain, q.data(), target);
  if (!error.within(tolerance)) return;
  error = polish(chain, target, q, goal, error);
  q = wrapped(q);
  for (std::size_t index = 0; index < roots.size(); ++index) {
    if (one_root(chain, target, q, roots[index].q, tolerance)) {
      met[index] = true;
      return;
    }
  }
  roots.push_back({q, error, smallest_singular(chain, q, lever, band)});
  met.push_back(true);
}

// The valley through `root` (a root, or a point on the valley's floor) traced both ways (one way
// where it closes on itself), each sign change of its weak combination a root added to `roots`
// (add_crossing); the points it passes appended to `visited`.
inline void trace_valley(const Chain& chain, const Frame& target, const Joints& root,
                         double tolerance, double lever, double band, std::vector<Root>& roots,
                         std::vector<bool>& met, std::vector<Joints>& visited) {
  Jacobian J;
  scaled_error(chain, target, root, lever, J);
  const Eigen::JacobiSVD<Jacobian> svd(J, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Valley at_root;
  at_root.strong = svd.matrixU().leftCols<5>().transpose();
  at_root.weak = svd.matrixU().col(kDof - 1);
  const double goal = newton::kRefineFraction * tolerance;
  for (const double direction : {1.0, -1.0}) {
    Joints q = root;
    Valley valley = at_root;
    Vector6 tangent = direction * svd.matrixV().col(kDof - 1);
    double weak_error = 0.0, step = kValleyStep, travelled = 0.0;
    bool closed = false;
    while (travelled < kValleyLength) {
      Joints next = q;
      for (int j = 0; j < kDof; ++j) next[j] += step * tangent(j);
      Vector6 next_tangent;
      double next_weak = 0.0;
      if (!onto_valley(chain, target, valley, lever, goal, tangent, next, next_tangent,
                       next_weak)) {
        step *= 0.5;
        if (step < kValleyStep / 64.0) break;
        continue;
      }
      // a step along which the weak combination stays within the tolerance: a curve of
      // solutions at the tolerance, whose every point verifies (walk's part, members.hpp)
      if (travelled == 0.0 && std::abs(next_weak) <= tolerance) return;
      if ((weak_error < 0.0 && next_weak > 0.0) || (weak_error > 0.0 && next_weak < 0.0)) {
        add_crossing(chain, target, q, weak_error, next, next_weak, tolerance, lever, band,
                     roots, met);
      }
      q = next, tangent = next_tangent;
      // the valley's equations re-taken at the new point: along a wrist's broken curve (an arm
      // a hair from a family at q5 = 0) the weak direction turns (|w . w_root| 0.43 one rad
      // along, the Kinova Gen3 6-DoF), and five equations fixed at the root no longer describe
      // the floor (docs/general6r.md, "Near-family arms"); the weak direction keeps its
      // orientation, so that its combination changes sign only through a root
      const Vector6 here = scaled_error(chain, target, q, lever, J);
      const Eigen::JacobiSVD<Jacobian> turned(J, Eigen::ComputeFullU);
      Vector6 weak = turned.matrixU().col(kDof - 1);
      if (weak.dot(valley.weak) < 0.0) weak = -weak;
      valley.strong = turned.matrixU().leftCols<5>().transpose();
      valley.weak = weak;
      weak_error = weak.dot(here);
      visited.push_back(q);
      travelled += step;
      step = std::min(2.0 * step, kValleyStep);
      if (travelled > kValleyStep && joint_distance(q, root) < 0.5 * kValleyStep) {
        closed = true;
        break;
      }
    }
    if (closed) break;
  }
}

// Whether q lies within a continuation step (rad, every joint) of a point a valley passed.
inline bool on_traced_valley(const Joints& q, const std::vector<Joints>& visited) {
  for (const Joints& point : visited) {
    if (joint_distance(q, point) <= kValleyStep) return true;
  }
  return false;
}

// Whether the nearly singular point q (tolerance < sigma <= band) lies on a fold's valley rather
// than a remnant of a curve: a fold's partner lies within a step (2 sigma / kappa), and along a
// remnant's valley the weak error runs like a wave of the curve's length.
inline bool near_fold(const Chain& chain, const Joints& q, double lever) {
  Eigen::Matrix<double, kDof, 1> weak_direction;
  return std::abs(fold_step(chain, q, lever, weak_direction)) <= kValleyStep;
}

// Roots along the valleys of the nearly singular roots (tolerance < sigma <= band: not on a
// curve of solutions, whose every point verifies) that are no fold's (near_fold), appended to
// `roots`; a valley is traced once (a root found on a valley, or met on it, starts none of its
// own).
//
// Then the valleys that none of those roots lies on, from the elimination's starts (`starts`,
// joint values of the pose itself): near a pose with curves of solutions the eigenvalues are
// noise, and a start that settles on no root can still lie near a valley (the folded
// M-430iA/2P, q3 = -179.97 deg, its target rounded to 10 significant digits: two closed valleys
// of 4 roots each, the elimination's roots on one of them only; of its 14 starts, 6 lie on the
// other). Each start is moved onto its valley's floor (settle_across on the directions whose
// singular values exceed the band: across the valley, not along it); where it lands on a nearly
// singular point of no valley traced yet, that valley is traced from there.
inline void valley_roots(const Chain& chain, const Frame& target, double tolerance, double lever,
                         double band, const std::vector<Joints>& starts,
                         std::vector<Root>& roots) {
  std::vector<bool> met(roots.size(), false);
  std::vector<Joints> visited;
  bool traced = false;
  for (std::size_t index = 0; index < roots.size(); ++index) {
    if (met[index]) continue;
    if (!(roots[index].sigma <= band && roots[index].sigma > tolerance)) continue;
    if (near_fold(chain, roots[index].q, lever)) continue;
    met[index] = true;
    traced = true;
    const Joints start = roots[index].q;
    trace_valley(chain, target, start, tolerance, lever, band, roots, met, visited);
  }
  if (!traced) return;  // no remnant of a curve at this pose
  for (const Joints& start : starts) {
    Joints q = start;
    settle_across(chain, target, q, lever, band);
    if (!finite(q) || on_traced_valley(q, visited)) continue;
    const double sigma = smallest_singular(chain, q, lever, band);
    if (!(sigma <= band && sigma > tolerance) || near_fold(chain, q, lever)) continue;
    trace_valley(chain, target, q, tolerance, lever, band, roots, met, visited);
  }
}

}  // namespace dhkin::general6r
