// The seed's member of a curve of solutions: the general 6R solver's singular roots moved
// towards the seed along the solutions (docs/general6r.md, "Singular roots"), never a root of
// the seed's own.
//
// Joint values are URDF joint values (rad); `chain` is the exact chain to the point verified;
// targets are that point's pose in DH frame 0 (metres).
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "dhkin/general6r/roots.hpp"
#include "dhkin/right_svd.hpp"

namespace dhkin::general6r {

// Trial steps of walk (a failed step is retried a quarter as long): on a curved solution set the
// midpoint of a chord of length L lies ~kappa L^2 / 8 off it, so long steps fail where short ones
// pass (a CRX-10iA pose at q5 = 0 whose members 1.6 rad apart needed steps of ~0.05 rad); 100
// trials walk ~3 rad at that length, beyond any seed within the continuity distance of a member.
constexpr int kWalkSteps = 100;
// Interior points (at k / 8 of the way) of a segment from a singular root to the seed's Newton
// point that must lie on the solutions for the two to be one set of solutions (on_segment): a
// straight segment of solutions (a free pair of coincident axes, q_i +- q_j fixed) passes at
// all, a chord across a curved set or between two distinct roots fails near its middle.
constexpr int kSegmentPoints = 7;
// A step of walk from a point on a curve of solutions (the Jacobian's smallest singular value at
// most the tolerance: a step of up to a radian along the weakest direction moves the pose less
// than the tolerance at first order, and a point of a true curve shows ~1e-15) stays on that
// curve when the chord's midpoint, refined by Newton, lands within kChordBend of the chord's
// length of it: on a curve of radius r a chord of length L bends L^2 / (8 r) from it, within a
// quarter of L for every chord up to the curve's diameter; a jump between two distinct roots
// puts the refined midpoint on one of them, half the chord from it (or nowhere). From an
// isolated root whose smallest singular value is above the tolerance (near a fold: 3e-8 on the
// IRB 1200's split elbow roots, whose near-solutions join them in a valley within the
// tolerance) the chord's midpoint itself must verify.
constexpr double kChordBend = 0.25;
// Newton's budget for a member (it converges slowly at a singular root).
constexpr int kMemberBudget = 4 * newton::kMaxSteps;

// The largest wrapped joint difference of a and b (rad).
inline double joint_distance(const Joints& a, const Joints& b) {
  double out = 0.0;
  for (int j = 0; j < kDof; ++j) out = std::max(out, std::abs(wrap(a[j] - b[j])));
  return out;
}

// The sum of squared wrapped joint differences.
inline double squared_distance(const Joints& a, const Joints& b) {
  double total = 0.0;
  for (int j = 0; j < kDof; ++j) total += wrap(a[j] - b[j]) * wrap(a[j] - b[j]);
  return total;
}

// Gauss-Newton across a curve of solutions, in place: each step solves J dq = e on the scaled
// Jacobian's directions whose singular values exceed `flat` (the tolerance: a step of a radian
// along a direction at or below it moves the pose less than the tolerance, as along a curve of
// solutions, sigma ~ 1e-15 on a true one), so that a point near the curve moves onto the
// solutions across it, not along it. Where the target lies a hair off a
// singular set (a description rounded to 11 significant digits puts an HC10 target 3e-11 off its
// table's curve) the curve becomes a valley whose floor misses the target by far less than the
// tolerance, and Newton's full steps (residual / sigma along the weak direction, sigma ~ 1e-12)
// slide a point along the floor towards one of its isolated roots, carrying a member far from
// the seed. Joints marked `held` keep their values (a member set onto a limit). Steps go on
// while each shrinks the squared error kPolishGain-fold (Newton's rate; less is the rounding of
// the arithmetic), at most kMemberBudget. The first SVD starts from `start` where given (the
// right singular vectors at a point nearby), each later one from the step before's. Returns the
// errors at q.
inline PoseError settle_across(const Chain& chain, const Frame& target, Joints& q, double lever,
                               double flat, const JointMask& held = {},
                               const std::optional<Matrix6>& start = std::nullopt) {
  std::array<Frame, kDof + 1> frames;
  double e[6], trial_e[6];
  fk_frames(chain, q.data(), frames.data());
  PoseError error = error_twist(frames[kDof], target, e);
  const auto scaled_size = [lever](const double* twist) {  // |e|^2, metres divided by lever
    double size = 0.0;
    for (int r = 0; r < 6; ++r) {
      const double component = r < 3 ? twist[r] / lever : twist[r];
      size += component * component;
    }
    return size;
  };
  double size = scaled_size(e);
  std::optional<Matrix6> previous_V = start;
  for (int step = 0; step < kMemberBudget && size > 0.0; ++step) {
    Jacobian J;
    jacobian(chain, frames.data(), J.data());
    J.topRows<3>() /= lever;
    for (int j = 0; j < kDof; ++j) {
      if (held[j]) J.col(j).setZero();  // the least-norm step leaves a zero column's joint alone
    }
    Eigen::Matrix<double, 6, 1> residual;
    for (int r = 0; r < 6; ++r) residual(r) = r < 3 ? e[r] / lever : e[r];
    const RightSvd svd = previous_V ? right_svd(J, *previous_V) : right_svd(J);
    previous_V = svd.V;
    Eigen::Matrix<double, kDof, 1> dq = Eigen::Matrix<double, kDof, 1>::Zero();
    for (int w = 0; w < kDof; ++w) {
      // u . r / sigma, with sigma u = J v
      const double sigma = svd.values(w);
      if (sigma > flat) dq += (svd.AV.col(w).dot(residual) / (sigma * sigma)) * svd.V.col(w);
    }
    Joints trial;
    for (int j = 0; j < kDof; ++j) trial[j] = q[j] + dq(j);
    std::array<Frame, kDof + 1> trial_frames;
    fk_frames(chain, trial.data(), trial_frames.data());
    const PoseError trial_error = error_twist(trial_frames[kDof], target, trial_e);
    const double trial_size = scaled_size(trial_e);
    if (!(trial_size * newton::kPolishGain <= size)) break;
    q = trial, frames = trial_frames, error = trial_error, size = trial_size;
    for (int r = 0; r < 6; ++r) e[r] = trial_e[r];
  }
  return error;
}

// A singular root q (in place) moved along the solutions towards `seed`: the member of a curve
// of solutions nearest the seed where a joint is free. Each step goes along the Jacobian's weak
// directions (singular values within `band`) by the seed's offset projected onto them, at most
// kMaxJointStep per joint, is refined by Newton and kept while it verifies at `tolerance`, comes
// nearer the seed and stays on the same root (the midpoint of the step verifies too: near a fold
// Newton could land on a distinct root nearer the seed); a failed step is retried a quarter as
// long, down to `band`, and the walk ends where the seed's offset along the weak directions is
// within `tolerance` (rad). On a curve of solutions a step stays on it when its refined midpoint
// lies near its chord (kChordBend); with `floors`, so does a step along a nearly singular
// root's valley whose floor verifies. Then polished by monotone Newton steps (across the curve
// or floor only). `error`: the residuals of the final q, where it moved.
inline void walk(const Chain& chain, const Frame& target, Joints& q, const Joints& seed,
                 double tolerance, double lever, double band, PoseError& error,
                 bool floors = false) {
  double distance = squared_distance(q, seed);
  double length = newton::kMaxJointStep;
  bool on_curve = false;  // q lies on a curve of solutions (sigma_min within the tolerance)
  bool on_floor = false;  // the last step kept walked a valley's verifying floor
  for (int trial_step = 0; trial_step < kWalkSteps; ++trial_step) {
    const Jacobian J = scaled_jacobian(chain, q, lever);
    const RightSvd svd = right_svd(J);
    on_curve = svd.values(kDof - 1) <= tolerance;
    Eigen::Matrix<double, kDof, 1> offset, step = Eigen::Matrix<double, kDof, 1>::Zero();
    for (int j = 0; j < kDof; ++j) offset(j) = wrap(seed[j] - q[j]);
    for (int w = 0; w < kDof; ++w) {
      if (svd.values(w) <= band) step += svd.V.col(w).dot(offset) * svd.V.col(w);
    }
    const double longest = step.cwiseAbs().maxCoeff();
    if (longest <= tolerance) break;  // nearer than the tolerance (rad): no step it could verify
    const double scale = longest > length ? length / longest : 1.0;
    Joints trial, middle;
    for (int j = 0; j < kDof; ++j) trial[j] = q[j] + scale * step(j);
    // across: the step is settled only across the weak directions (flat: singular values up to
    // it are left alone). On a curve, those within the tolerance. Off one (sigma within the band)
    // with `floors`, first those within the band: a target a hair off a pose with a curve of
    // solutions (a description rounded to 10 significant digits, 2.6e-10 m off a folded
    // M-430iA/2P's table) leaves a valley whose floor still verifies, and a step along it is a
    // member as on a curve (Newton would slide it back to the valley's isolated root); where the
    // floor does not verify (an isolated root's valley), Newton as before.
    bool floor_step = false;
    if (on_curve) {
      settle_across(chain, target, trial, lever, tolerance, JointMask{}, svd.V);
    } else {
      Joints floor = trial;
      if (floors) settle_across(chain, target, floor, lever, band, JointMask{}, svd.V);
      floor_step = floors && check(chain, floor.data(), target).within(tolerance);
      if (floor_step) {
        trial = floor;
      } else {
        refine(chain, target, trial, JointMask{}, tolerance,
               {kMemberBudget, newton::kGrowth, 0.0});
      }
    }
    const bool across = on_curve || floor_step;
    const double flat = floor_step ? band : tolerance;
    const PoseError trial_error = check(chain, trial.data(), target);
    const double trial_distance = squared_distance(trial, seed);
    double chord = 0.0;
    for (int j = 0; j < kDof; ++j) {
      middle[j] = q[j] + 0.5 * wrap(trial[j] - q[j]);
      chord = std::max(chord, std::abs(wrap(trial[j] - q[j])));
    }
    bool kept = trial_error.within(tolerance) && trial_distance < distance && chord > 0.0;
    if (kept && !across) {
      // an isolated (near-)singular root's cloud: the midpoint itself verifies
      kept = check(chain, middle.data(), target).within(tolerance);
    } else if (kept) {
      // on a curve of solutions (or a valley's verifying floor): the midpoint, moved across it,
      // verifies near the chord
      const Joints midpoint = middle;
      settle_across(chain, target, middle, lever, flat, JointMask{}, svd.V);
      const double moved = joint_distance(middle, midpoint);
      kept = check(chain, middle.data(), target).within(tolerance) && moved <= kChordBend * chord;
    }
    if (!kept) {
      length = 0.25 * std::min(length, longest);
      if (length <= band) break;
      continue;
    }
    q = wrapped(trial);
    distance = trial_distance;
    error = trial_error;
    on_floor = floor_step;
    length = std::min(2.0 * length, newton::kMaxJointStep);
  }
  // polish: monotone Newton steps from the member reached (Newton converges slowly at a singular
  // root; these bring its residual to kRefineFraction of the tolerance); on a curve only across
  // it (along it Newton would slide the member off the seed)
  Joints trial = q;
  if (on_curve || on_floor) {
    settle_across(chain, target, trial, lever, on_curve ? tolerance : band);
  } else {
    refine(chain, target, trial, JointMask{}, refine_tolerance(tolerance, lever),
           {kMemberBudget, newton::kMonotone, 0.0});
  }
  const PoseError polished = check(chain, trial.data(), target);
  if (polished.within(tolerance) && polished.largest() < error.largest()) {
    q = wrapped(trial);
    error = polished;
  }
}

// Damped Newton from `seed` onto the solutions (the families' seeded refinement), into `out`;
// whether it verifies at `tolerance` and is singular (sigma within `band`): a candidate for the
// seed's member of a curve, which on_segment must tie to a root the elimination found (it is
// never a root of its own).
inline bool seed_projection(const Chain& chain, const Frame& target, const Joints& seed,
                            double tolerance, double lever, double band, Joints& out,
                            PoseError& error) {
  out = seed;
  refine(chain, target, out, JointMask{}, refine_tolerance(tolerance, lever),
         {kMemberBudget, newton::kGrowth, newton::kSeedDamping});
  error = check(chain, out.data(), target);
  if (!error.within(tolerance)) return false;
  return smallest_singular(chain, out, lever, band) <= band;
}

// Whether the segment from a to b (joint differences wrapped) lies on the solutions: each of its
// kSegmentPoints interior points, refined by monotone Newton steps, verifies at `tolerance`
// within `band` (rad) of where it was. Within the band, not at the point itself: the
// elimination's singular root lies in the cloud of near-solutions around the set (~1e-7 rad off
// a line of solutions on the CRX-10iA), and a chord from it drifts off the line by as much times
// the angle travelled.
inline bool on_segment(const Chain& chain, const Frame& target, const Joints& a, const Joints& b,
                       double tolerance, double lever, double band) {
  const double goal = refine_tolerance(tolerance, lever);
  for (int k = 1; k <= kSegmentPoints; ++k) {
    const double t = k / (kSegmentPoints + 1.0);
    Joints start, point;
    for (int j = 0; j < kDof; ++j) start[j] = a[j] + t * wrap(b[j] - a[j]);
    point = start;
    refine(chain, target, point, JointMask{}, goal, {kMemberBudget, newton::kMonotone, 0.0});
    if (!check(chain, point.data(), target).within(tolerance)) return false;
    for (int j = 0; j < kDof; ++j) {
      if (std::abs(point[j] - start[j]) > band) return false;
    }
  }
  return true;
}

// Where damped Newton from a point lands on the solutions (seed_projection), computed once per
// point and shared by every root moved towards it.
struct Projection {
  bool reached = false;  // it verifies and is singular
  Joints q{};
  PoseError error;
};

inline Projection project(const Chain& chain, const Frame& target, const Joints& point,
                          double tolerance, double lever, double band) {
  Projection out;
  out.reached = seed_projection(chain, target, point, tolerance, lever, band, out.q, out.error);
  return out;
}

// The member of a singular root's solutions nearest `point` (the seed, or a point of the limits),
// in place: q walked towards it, and replaced by the point's projection where that lies nearer
// and a segment of solutions ties the two (on_segment: a free pair of coincident axes, where
// walking stalls in the cloud of near-solutions), then walked the rest (damped Newton stops
// near, not at, the member nearest the point). `point` is never a root of its own.
inline void nearest_member(const Chain& chain, const Frame& target, const Joints& point,
                           const Projection& projection, double tolerance, double lever,
                           double band, Joints& q, PoseError& error, bool floors = false) {
  walk(chain, target, q, point, tolerance, lever, band, error, floors);
  if (projection.reached &&
      squared_distance(projection.q, point) < squared_distance(q, point) &&
      on_segment(chain, target, q, projection.q, tolerance, lever, band)) {
    q = wrapped(projection.q);
    error = projection.error;
    walk(chain, target, q, point, tolerance, lever, band, error, floors);
  }
}

}  // namespace dhkin::general6r
