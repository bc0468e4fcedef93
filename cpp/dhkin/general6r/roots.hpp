// The general 6R solver's roots: Newton on the exact chain from every start, verification,
// merging of starts that reach one root, the Jacobian's smallest singular value (the "singular"
// flag), fold partners, and a moved pose's roots brought back (docs/general6r.md, step 6).
//
// Joint values are URDF joint values (rad); `chain` is the exact chain to the point verified
// (tool0 or the TCP); targets are that point's pose in DH frame 0 (metres).
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "dhkin/angles.hpp"
#include "dhkin/chain.hpp"
#include "dhkin/general6r/candidates.hpp"
#include "dhkin/general6r/full_steps.hpp"
#include "dhkin/newton.hpp"
#include "dhkin/plan.hpp"
#include "dhkin/right_svd.hpp"
#include "dhkin/simd.hpp"

// Compiled once, in cpp/eigen_instances.cpp (docs/architecture.md, "Build time").
extern template Eigen::JacobiSVD<dhkin::general6r::Jacobian>&
Eigen::JacobiSVD<dhkin::general6r::Jacobian>::compute(const dhkin::general6r::Jacobian&, unsigned int);

namespace dhkin::general6r {

// Refinement budget (chain evaluations) per start.
constexpr int kBudget = 120;
// Refinement budget of a start from a near-real complex pair of eigenvalues: a real root of the
// chain that the model's rounding or its fold made complex lies within the imaginary band of the
// start and converges in a few Newton steps (at a double root linearly, halving per step: from
// 1e-8 to 1e-12 within ~15); a truly complex one never converges, and the full budget spent on
// it was most of the refinement's time (0.8 such per pose on the CRX-10iA and xArm6). A moved
// pose's paired start has it (back_from_moved); the pose's own take refine_paired's steps.
constexpr int kPairBudget = 40;
// A paired start's first kCrawlSteps steps run as any start's; from then on it stops at its
// first descent step that shrinks the squared error less than kPolishGain-fold
// (newton::Settings::stop_on_stall). A start with no real root near it cycles (its error
// rising and falling for all kMaxSteps: 0.43 such starts a CRX-10iA pose, ~21 us each); one
// that reaches a root may first crawl towards it by steps cut to kMaxJointStep, each gaining
// little (the M-430iA/2P's near-fold roots: ~8 such steps, then quadratic), and a joint has at
// most pi rad to cover: ceil(pi / kMaxJointStep) = 11 steps. Past those, a converging start
// gains more per step (quadratically, or fourfold at a double root, whose error halves) but for a
// few (70 of 4,091 on 10^4 random CRX-10iA poses), each of a root that its own real eigenvalue's
// start finds (docs/general6r.md, "Speed, sixth pass": no root lost).
constexpr int kCrawlSteps = 11;
static_assert(kCrawlSteps * newton::kMaxJointStep >= kPi, "a crawl covers pi");
static_assert((kCrawlSteps - 1) * newton::kMaxJointStep < kPi, "the fewest such steps");

// refine() of a paired start, in place (kCrawlSteps steps, then until a descent step stalls;
// kMaxSteps in all, as one refine() would take). A root reached within the first steps but not
// yet polished to the rounding (at_rounding, `lever`) polishes on in the second refine(), whose
// stall rule is then refine()'s own polishing rule.
inline void refine_paired(const Chain& chain, const Frame& target, Joints& q, double goal,
                          double lever) {
  const PoseError first =
      refine(chain, target, q, JointMask{}, goal, {kCrawlSteps + 1, newton::kGrowth, 0.0});
  if (at_rounding(first, goal, lever)) return;
  refine(chain, target, q, JointMask{}, goal,
         {newton::kMaxSteps - kCrawlSteps + 1, newton::kGrowth, 0.0, true});
}

// Roots whose smallest singular value (scaled Jacobian) is at most this get their fold partner
// probed (fold_partner). Near a fold two roots lie d ~ 2 sigma / kappa apart along the weak
// direction (kappa ~1 rad^-1 on arms of order-one lengths); where that direction has no component
// along the eliminated joint, their eliminated joints differ only by ~d^2, and the eigenvalues
// (accurate to ~1e-6 at a CRX-10iA pose near q5 = 0) can no longer tell them apart: a pair 8e-3
// rad apart (sigma 1.5e-4) shared an eigenvalue to 1.7e-7. Above 1e-2, d^2 > 1e-4.
constexpr double kProbeSigma = 1e-2;
// Step (rad) of the central difference of the Jacobian along the weak direction in fold_partner
// (second-derivative error ~h^2, rounding ~eps / h).
constexpr double kProbeStep = 1e-5;
// Halvings of the motion along the path from a moved pose back to the pose before the last step
// to the pose itself: 2^-30 of a motion of 1e-3 is ~1e-12, below any tolerance.
constexpr int kTrackSteps = 30;
// Chain evaluations per step of that path (Newton from the previous step's root: a few steps).
constexpr int kStepBudget = 40;

// The tolerance Newton is given (it stops at kRefineFraction of it) so that a root's residual is
// at most kRefineFraction of `tolerance` on the oracle's FK as well: less the FK rounding margin
// (kFkRounding per metre of `lever`) at that scale.
inline double refine_tolerance(double tolerance, double lever) {
  return std::max(tolerance - kFkRounding * lever / newton::kRefineFraction, 0.5 * tolerance);
}

// The exact chain's Jacobian at q, its linear rows divided by `lever` (m per rad of a point of
// the arm; rad and m / lever then weigh alike).
inline Jacobian scaled_jacobian(const Chain& chain, const Joints& q, double lever) {
  std::array<Frame, kDof + 1> frames;
  fk_frames(chain, q.data(), frames.data());
  Jacobian J;
  jacobian(chain, frames.data(), J.data());
  J.topRows<3>() /= lever;
  return J;
}

// The smallest singular value of the scaled Jacobian at q where it is at most `band`; above it
// a lower bound may come back instead: 1 / |J^-1|_F <= sigma_min (|J^-1|_F >= |J^-1|_2 =
// 1 / sigma_min; within a factor sqrt(6) of it), and the SVD runs only where that bound is at
// most `band`. (The bound |det J| / |J|_F^5 used before is loose by the product of the other
// singular values over |J|_F^5: it fell below the band at most regular roots, and their SVDs
// were a tenth of the CRX-10iA's time.)
inline double smallest_singular(const Chain& chain, const Joints& q, double lever, double band) {
  const Jacobian J = scaled_jacobian(chain, q, lever);
  const double bound = singular_bound(J);
  if (bound > band) return bound;
  return right_svd(J).values(kDof - 1);
}

// smallest_singular at a root, or full_steps()' bound where that was above the band (taken at
// the unwrapped values, which differ from q by rounding: above the band the bound is the flag's
// answer either way).
inline double root_singular(const Chain& chain, const Joints& q, double lever, double band,
                            double sigma_bound) {
  return sigma_bound > band ? sigma_bound : smallest_singular(chain, q, lever, band);
}

// Joint values wrapped to (-pi, pi].
inline Joints wrapped(const Joints& q) {
  Joints out;
  for (int j = 0; j < kDof; ++j) out[j] = wrap(q[j]);
  return out;
}

// Whether a and b are one root: within kMaxJointStep of each other (wrapped) and their midpoint
// verifies at `tolerance`.
inline bool one_root(const Chain& chain, const Frame& target, const Joints& a, const Joints& b,
                     double tolerance) {
  Joints middle;
  for (int j = 0; j < kDof; ++j) {
    const double step = wrap(a[j] - b[j]);
    if (std::abs(step) > newton::kMaxJointStep) return false;
    middle[j] = b[j] + 0.5 * step;
  }
  return check(chain, middle.data(), target).within(tolerance);
}

// A verified root whose residual is still above kRefineFraction of `goal` (Newton's budget ran
// out on the way: slow convergence near a fold) refined further by monotone steps, in place.
inline PoseError polish(const Chain& chain, const Frame& target, Joints& q, double goal,
                        PoseError error) {
  if (error.largest() <= newton::kRefineFraction * goal) return error;
  Joints trial = q;
  refine(chain, target, trial, JointMask{}, goal, {kBudget, newton::kMonotone, 0.0});
  const PoseError better = check(chain, trial.data(), target);
  if (better.largest() >= error.largest()) return error;
  q = trial;
  return better;
}

// q (in place), a start near a root of the moved pose P(1) target, followed along the path
// s = 1, 1/2, ..., 2^-kTrackSteps, 0 by Newton at each step; whether every step's root verified
// at `tolerance` (q is then a root of target). The roots move continuously with s.
inline bool track(const Chain& chain, const Frame& target, Joints& q, const Moves& moves,
                  double goal, double tolerance) {
  for (int step = 0; step <= kTrackSteps + 1; ++step) {
    const double s = step > kTrackSteps ? 0.0 : std::ldexp(1.0, -step);
    const Frame moved = moves.motion(s) * target;
    refine(chain, moved, q, JointMask{}, goal, {kStepBudget, newton::kGrowth, 0.0});
    if (!check(chain, q.data(), moved).within(tolerance)) return false;
  }
  return true;
}

// A start of the moved pose to a root of the pose itself (target), in place; its residuals
// there. Refined on the moved pose first (the elimination's start of a nearly singular pose can
// be off its own root), then Newton goes to the pose; where that fails, the moved root is
// followed back along the path (track). A start that is no root of the moved pose (a complex
// pair's) gets a short direct Newton.
inline PoseError back_from_moved(const Chain& chain, const Frame& target, Joints& q,
                                 const Moves& moves, double goal, double tolerance) {
  const newton::Settings short_newton{kPairBudget, newton::kGrowth, 0.0};
  const Joints start = q;
  const Frame moved = moves.motion(1.0) * target;
  refine(chain, moved, q, JointMask{}, goal, short_newton);
  if (!check(chain, q.data(), moved).within(tolerance)) {
    q = start;
    refine(chain, target, q, JointMask{}, goal, short_newton);
    return check(chain, q.data(), target);
  }
  const Joints root = q;
  refine(chain, target, q, JointMask{}, goal, short_newton);
  const PoseError error = check(chain, q.data(), target);
  if (error.within(tolerance)) return error;
  q = root;
  if (track(chain, target, q, moves, goal, tolerance)) return check(chain, q.data(), target);
  return {INFINITY, INFINITY};
}

// Where the fold partner of the root q lies along the Jacobian's weakest right singular vector
// v (sigma, left vector u; linear rows over `lever`): the pose error is ~ t sigma u + t^2 / 2
// kappa u with kappa = u . d2F[v, v] (a central difference of the Jacobian along v), zero again
// at t = -2 sigma / kappa; that t, and v into `direction`. Infinite where kappa vanishes.
inline double fold_step(const Chain& chain, const Joints& q, double lever,
                        Eigen::Matrix<double, kDof, 1>& direction) {
  const Jacobian J = scaled_jacobian(chain, q, lever);
  const Eigen::JacobiSVD<Jacobian> svd(J, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const double sigma = svd.singularValues()(kDof - 1);
  const auto u = svd.matrixU().col(kDof - 1);
  direction = svd.matrixV().col(kDof - 1);
  double curvature = 0.0;
  Joints near_q;
  for (const double sign : {1.0, -1.0}) {
    for (int j = 0; j < kDof; ++j) near_q[j] = q[j] + sign * kProbeStep * direction(j);
    const Jacobian near = scaled_jacobian(chain, near_q, lever);
    curvature += sign * u.dot(near * direction) / (2.0 * kProbeStep);
  }
  if (!(std::abs(curvature) > 0.0)) return INFINITY;
  return -2.0 * sigma / curvature;
}

// The fold partner of the root q (fold_step), refined by Newton into `out`; false where it lies
// beyond kMaxJointStep (no fold partner near).
inline bool fold_partner(const Chain& chain, const Frame& target, const Joints& q, double lever,
                         double goal, Joints& out) {
  Eigen::Matrix<double, kDof, 1> v;
  const double t = fold_step(chain, q, lever, v);
  if (!(std::abs(t) <= newton::kMaxJointStep)) return false;
  for (int j = 0; j < kDof; ++j) out[j] = q[j] + t * v(j);
  refine(chain, target, out, JointMask{}, goal, {kBudget, newton::kGrowth, 0.0});
  return true;
}

// A verified root: joint values wrapped to (-pi, pi], residuals, smallest singular value.
struct Root {
  Joints q{};
  PoseError error;
  double sigma = 0.0;
  // a crossing of a curve of solutions whose target lies off it (crossings.hpp): a root of its
  // own, neither walked towards the seed nor merged with the curve's members
  bool crossing = false;
};

// Newton's basin around a regular root (docs/general6r.md, "Speed, fifth pass"). Let F be the
// error twist (linear rows over `lever`) and J the scaled geometric Jacobian that the steps solve
// with. Along any unit joint direction u, d J / d u has columns
// sum_k u_k d(col_i) / dq_k, each term a unit axis crossed into col_i's parts: |.| <= 1 for the
// rotation rows and <= rho / lever for the linear ones, rho the largest distance of the end
// point from a joint's axis (at most the sum of the chain's translations); so |J(a) - J(b)|_2 <=
// |.|_F <= L |a - b| with L = 6 sqrt(1 + (rho / lever)^2) (times the joint directions' largest
// squared size). F's own derivative differs from -J by the rotation error's inverse left
// Jacobian minus I (at most the rotation angle, itself at most sqrt(6) |q - r|) times J's
// rotation rows (|.| <= sqrt(6)): within 6 |q - r| of J. Newton's step from q at distance d
// from a root r with sigma_min(J(r)) >= s then lands within (L + 6) d^2 / (2 (s - L d)) of r
// (the textbook estimate with the mismatch folded into the constant): for d <= s / (2 (L + 6)),
// at most d / 2, every step, converging quadratically. Such a start reaches r by full steps or
// by refine() (Gauss-Newton as well, its damping at the floor and its steps far below
// kMaxJointStep there), so settle() may count it as r at once. And no other root lies within
// 2 s / (L + 6) of r, so the basins of distinct roots do not overlap.
constexpr double kBasinFraction = 0.5;

// The Lipschitz constant L + 6 above of `chain`'s scaled Jacobian (linear rows over `lever`).
inline double newton_lipschitz(const Chain& chain, double lever) {
  double reach = norm(chain.tail.translation());
  double direction = 1.0;
  for (const ChainJoint& joint : chain.joints) {
    reach += norm(joint.before.translation());
    direction = std::max(direction, std::abs(joint.direction));
  }
  const double ratio = reach / lever;
  return (6.0 * std::sqrt(1.0 + ratio * ratio) + 6.0) * direction * direction;
}

// The root among `roots` in whose Newton basin (radius kBasinFraction sigma / lipschitz) q lies
// (wrapped distance), or -1. A joint farther than the radius rules a root out at once.
inline int basin_of(const Joints& q, const std::vector<Root>& roots, double lipschitz) {
  const double fraction = kBasinFraction / lipschitz;
  for (std::size_t index = 0; index < roots.size(); ++index) {
    const double radius = fraction * roots[index].sigma;
    double squared = 0.0;
    for (int j = 0; j < kDof && squared < radius * radius; ++j) {
      const double step = wrap(q[j] - roots[index].q[j]);
      squared += step * step;
    }
    if (squared < radius * radius) return static_cast<int>(index);
  }
  return -1;
}

// A real start's full steps, taken ahead (settle: full_steps_lanes, eight starts at a time).
struct QuickStart {
  FullStepRoot root;  // what full_steps() reached (converged or not)
  Joints q{};         // the root where converged
};

// A start of a real eigenvalue (simple, or a cluster's split; not a complex pair's, not an
// ill-conditioned or moved pose's): full_steps() first.
inline bool takes_full_steps(const Start& start) {
  return start.origin < kMoved && (start.origin & (kPaired | kIll)) == 0;
}

// full_steps() of every start that takes them (takes_full_steps), eight at a time in lanes, the
// last group however few (running one or two starts alone on the scalar path instead measured
// the same: docs/general6r.md, "Speed, eighth pass"). Each lane's values are full_steps()'
// (full_steps_lanes), so settle() uses them in place of its own call, in the same order, and
// nothing it decides changes. A cluster's start that settle() then finds in a known root's basin
// was run for nothing; the lanes cost it little.
inline std::vector<QuickStart> full_steps_ahead(const Chain& chain, const ChainShape& shape,
                                                const Frame& target,
                                                const std::vector<Start>& starts, double goal,
                                                double lever) {
  std::vector<QuickStart> out(starts.size());
  std::vector<int> real;
  for (std::size_t index = 0; index < starts.size(); ++index) {
    if (takes_full_steps(starts[index])) real.push_back(static_cast<int>(index));
  }
  for (std::size_t first = 0; first < real.size(); first += kLanes) {
    const int count = static_cast<int>(std::min<std::size_t>(kLanes, real.size() - first));
    JointsT<Lanes> q;
    Mask active = uniform(false);
    for (int l = 0; l < kLanes; ++l) {
      // an idle lane repeats the first start (finite values; its result is not used)
      const Joints& start = starts[real[first + (l < count ? l : 0)]].q;
      for (int j = 0; j < kDof; ++j) q[j].set(l, start[j]);
      set_lane(active, l, l < count);
    }
    const FullStepLanes lanes = full_steps_lanes(chain, shape, target, q, active, goal, lever);
    for (int l = 0; l < count; ++l) {
      QuickStart& quick = out[real[first + l]];
      quick.root.converged = lane(lanes.converged, l);
      if (!quick.root.converged) continue;
      quick.root.error = lane(lanes.error, l);
      quick.root.sigma_bound = lane(lanes.sigma_bound, l);
      for (int j = 0; j < kDof; ++j) quick.q[j] = q[j][l];
    }
  }
  return out;
}

// Refine every start on the exact chain, keep those that verify at `tolerance`, merge those
// that are one root. Only the elimination's starts are starts: the seed never is (it chooses
// among the roots, it does not find them). A start of a real eigenvalue takes full Newton steps
// first (full_steps, run ahead eight starts at a time: full_steps_ahead), refine() where they do
// not reach the rounding; paired starts go to
// refine_paired(). The roots reached from
// shared ones (a cluster of eigenvalues), and every root of a moved pose, have their fold partner
// probed where their singular value is at most kProbeSigma (a tilted-UR5 root 0.1 rad from its
// partner, both 5e-4 from singular near a singular root, was found no other way); those of the
// moved pose are brought back (back_from_moved). Roots already in `roots` stay, and starts that
// reach one of them add nothing. Returns the starts that did not verify; the roots' sigmas are
// smallest_singular with `band`.
inline int settle(const Chain& chain, const Frame& target, const std::vector<Start>& starts,
                  const Moves& moves, double tolerance, double lever, double band,
                  std::vector<Root>& roots) {
  const double goal = refine_tolerance(tolerance, lever);
  const ChainShape shape(chain);
  // on a moved (ill-conditioned) pose every root near a fold gets its partner probed: the roots
  // there cluster near a singular point, and the moved poses' can collide in pairs
  bool moved_pose = false;
  for (const Start& start : starts) moved_pose = moved_pose || start.origin >= kMoved;
  // roots already there (an earlier arrangement's) are not probed again
  std::vector<bool> probe(roots.size(), false);
  int failed = 0;
  const auto known = [&](const Joints& q) {
    for (std::size_t other = 0; other < roots.size(); ++other) {
      if (one_root(chain, target, q, roots[other].q, tolerance)) return static_cast<int>(other);
    }
    return -1;
  };
  const double lipschitz = newton_lipschitz(chain, lever);
  const std::vector<QuickStart> ahead = full_steps_ahead(chain, shape, target, starts, goal, lever);
  for (std::size_t index = 0; index < starts.size(); ++index) {
    const Start& start = starts[index];
    const bool wants_probe = (start.origin & kShared) != 0 || moved_pose;
    // a cluster's start in a known root's basin reaches that root (the cluster's other members
    // split into the same roots' vectors; simple and paired starts were measured to lie in a
    // known basin 0.03 times a pose, not worth the check)
    if (start.origin == kShared) {
      const int basin = basin_of(start.q, roots, lipschitz);
      if (basin >= 0) {
        probe[basin] = probe[basin] || wants_probe;
        continue;
      }
    }
    Joints q = start.q;
    PoseError error;
    double sigma_bound = 0.0;  // at q, where full_steps() found it
    if (start.origin >= kMoved) {
      error = back_from_moved(chain, target, q, moves, goal, tolerance);
    } else if (start.origin & (kPaired | kIll)) {
      refine_paired(chain, target, q, goal, lever);
      error = check(chain, q.data(), target);
    } else {
      const FullStepRoot& quick = ahead[index].root;  // full_steps() from the start
      if (quick.converged) {
        q = ahead[index].q;
        error = quick.error;
        sigma_bound = quick.sigma_bound;
      } else {
        refine(chain, target, q, JointMask{}, goal, {kBudget, newton::kGrowth, 0.0});
        error = check(chain, q.data(), target);
      }
    }
    if (!error.within(tolerance)) {
      ++failed;
      continue;
    }
    error = polish(chain, target, q, goal, error);
    finish(chain, shape, target, q, goal, lever, error, sigma_bound);
    q = wrapped(q);
    const int duplicate = known(q);
    if (duplicate >= 0) {
      probe[duplicate] = probe[duplicate] || wants_probe;
      continue;
    }
    roots.push_back({q, error, root_singular(chain, q, lever, band, sigma_bound)});
    probe.push_back(wants_probe);
  }
  // near a fold, the partner of each root with a small singular value (its eliminated joint may
  // equal this one's to the eigenvalues' accuracy)
  const std::size_t found = roots.size();
  for (std::size_t index = 0; index < found; ++index) {
    if (!probe[index]) continue;
    const Joints q = roots[index].q;
    if (smallest_singular(chain, q, lever, kProbeSigma) > kProbeSigma) continue;
    Joints partner;
    if (!fold_partner(chain, target, q, lever, goal, partner)) continue;
    PoseError error = check(chain, partner.data(), target);
    if (!error.within(tolerance)) continue;
    error = polish(chain, target, partner, goal, error);
    double sigma_bound = 0.0;
    finish(chain, shape, target, partner, goal, lever, error, sigma_bound);
    partner = wrapped(partner);
    if (known(partner) >= 0) continue;
    roots.push_back({partner, error, root_singular(chain, partner, lever, band, sigma_bound)});
  }
  return failed;
}

}  // namespace dhkin::general6r
