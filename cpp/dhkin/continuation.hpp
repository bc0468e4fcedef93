// Beyond Newton on the exact chain: continuation along a path of models from the ideal one to the
// exact chain, and the searches off a fold (the twin root a refinement lost, the roots a hair
// inside a fold).
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <iterator>

#include "dhkin/newton.hpp"
#include "dhkin/plan.hpp"
#include "dhkin/refine_lanes_exact.hpp"

// Compiled once, in cpp/eigen_instances.cpp (docs/architecture.md, "Build time").
extern template Eigen::JacobiSVD<Eigen::Matrix<double, 6, dhkin::kDof>>&
Eigen::JacobiSVD<Eigen::Matrix<double, 6, dhkin::kDof>>::compute(
    const Eigen::Matrix<double, 6, dhkin::kDof>&, unsigned int);

namespace dhkin {

namespace continuation {

// Continuation from the ideal model to the exact chain: the first try takes the path in this many
// equal steps; a step whose Newton solve fails is halved, down to 1 / (kSteps * 2^kDepth).
constexpr int kSteps = 4;
constexpr int kDepth = 5;
// Steps (rad, along the unit weakest direction) tried from a solution to find a twin root that
// the refinement lost to it (two starts that converged to one solution near a fold).
constexpr double kTwinSteps[] = {0.02, 0.05, 0.1, 0.2, 0.4, 0.7};
// Steps (along the unit weakest direction) tried from a candidate clamped onto a fold, where J is
// singular and Newton cannot leave: the roots a hair inside lie ~sqrt(violation) away.
constexpr double kOffFoldSteps[] = {1e-6, 1e-5, 1e-4, 1e-3, 1e-2};

// The chain at t in [0, 1] on the path from `ideal` to the exact chain: each constant frame
// P_j(t) = P_j(ideal) [Rot(t w_j), t v_j]; motions as in `ideal`.
inline Chain interpolate(const Chain& ideal, const std::vector<ModelStep>& path, double t) {
  Chain out = ideal;
  const int n = ideal.dof();
  for (int j = 0; j <= n; ++j) {
    Frame step = rotation_vector(t * path[j].rotation);
    step.p[0] = t * path[j].translation.x;
    step.p[1] = t * path[j].translation.y;
    step.p[2] = t * path[j].translation.z;
    Frame& frame = j < n ? out.joints[j].before : out.tail;
    frame = frame * step;
  }
  return out;
}

// The unit-infinity-norm right singular vector of J's smallest singular value at q (joints
// marked `fixed` left out of J).
inline Joints weakest_direction(const Chain& chain, const Joints& q, const JointMask& fixed) {
  std::array<Frame, kDof + 1> frames;
  double J[6 * kDof];
  fk_frames(chain, q.data(), frames.data());
  jacobian(chain, frames.data(), J);
  Eigen::Matrix<double, 6, kDof> matrix;
  for (int r = 0; r < 6; ++r) {
    for (int j = 0; j < kDof; ++j) matrix(r, j) = fixed[j] ? 0.0 : J[r * kDof + j];
  }
  const Eigen::JacobiSVD<Eigen::Matrix<double, 6, kDof>> svd(matrix, Eigen::ComputeFullV);
  const auto weakest = svd.matrixV().col(kDof - 1);
  const double largest = weakest.cwiseAbs().maxCoeff();
  Joints out;
  for (int j = 0; j < kDof; ++j) out[j] = weakest(j) / largest;
  return out;
}

// Whether a and b differ by more than `distinct` on some joint (mod 2pi).
inline bool apart(const Joints& a, const Joints& b, double distinct) {
  double largest = 0.0;
  for (int j = 0; j < kDof; ++j) largest = std::max(largest, std::abs(wrapped_difference(a[j] - b[j])));
  return largest > distinct;
}

}  // namespace continuation

// refine() by continuation: a solution q of the ideal model (in place) followed along the path of
// models from `ideal` (t = 0) to `exact` (t = 1), solving each step with refine() from the
// previous step's solution; a failed step is halved. Returns the exact chain's errors at the
// final q.
inline PoseError refine_along(const Chain& ideal, const Chain& exact,
                              const std::vector<ModelStep>& path, const Frame& target, Joints& q,
                              const JointMask& fixed, double tolerance) {
  using namespace continuation;
  Joints start = q;
  double t = 0.0, dt = 1.0 / kSteps;
  const double smallest = dt / std::pow(2.0, kDepth);
  PoseError error{INFINITY, INFINITY};
  while (t < 1.0) {
    const double next = std::min(1.0, t + dt);
    Joints trial = start;
    if (next >= 1.0) {
      error = refine(exact, target, trial, fixed, tolerance);
    } else {
      error = refine(interpolate(ideal, path, next), target, trial, fixed, tolerance);
    }
    if (error.within(tolerance)) {
      t = next;
      start = trial;
      dt = std::min(2.0 * dt, 1.0 / kSteps);
    } else {
      dt *= 0.5;
      if (dt < smallest) break;
    }
  }
  q = start;
  if (t < 1.0) return check(exact, q.data(), target);
  return error;
}

// Newton from q (in place) displaced along J's weakest direction by kOffFoldSteps, each way,
// until one verifies; q keeps the best result; returns its errors.
inline PoseError off_fold(const Chain& chain, const Frame& target, Joints& q,
                          const JointMask& fixed, double tolerance, int budget) {
  using namespace continuation;
  const Joints weakest = weakest_direction(chain, q, fixed);
  const Joints best = q;
  PoseError best_error = check(chain, q.data(), target);
  for (double size : kOffFoldSteps) {
    for (double sign : {1.0, -1.0}) {
      Joints trial;
      for (int j = 0; j < kDof; ++j) trial[j] = best[j] + sign * size * weakest[j];
      refine(chain, target, trial, fixed, tolerance, {budget, newton::kGrowth, 0.0});
      const PoseError error = check(chain, trial.data(), target);
      if (error.largest() < best_error.largest()) {
        best_error = error;
        q = trial;
      }
      if (error.within(tolerance)) return error;
    }
  }
  return best_error;
}

// The twin search's starts from one solution q, each refined as find_twin refines it: they
// depend on q, the chain and the target alone, so a second search from the same q (one pose's
// root merged with several branches) reads them here instead of refining them again.
struct TwinSearch {
  static constexpr int kStarts = 2 * static_cast<int>(std::size(continuation::kTwinSteps));
  Joints from{};       // the solution searched from (none yet while `refined` is 0)
  Joints weakest{};    // J's weakest direction at `from`
  int refined = 0;     // starts refined so far, in search order (kLanes at a time)
  std::array<Joints, kStarts> root{};
  std::array<PoseError, kStarts> error{};
};

// Start k of the twin search from q: q + sign * size * weakest, kTwinSteps[k / 2] each way.
inline Joints twin_start(const Joints& q, const Joints& weakest, int k) {
  const double size = continuation::kTwinSteps[k / 2];
  const double sign = k % 2 == 0 ? 1.0 : -1.0;
  Joints trial;
  for (int j = 0; j < kDof; ++j) trial[j] = q[j] + sign * size * weakest[j];
  return trial;
}

// Refines the twin search's starts from `first` on, up to kLanes of them, in lanes at once (a
// plan's chain: kDof joints): refine_lanes_exact gives each the bits refine() gives it alone, so
// the cached roots and errors are those the search would have refined one by one.
inline void refine_twin_starts(const Chain& chain, const Frame& target, double tolerance,
                               int first, TwinSearch& search) {
  const int count = std::min(kLanes, TwinSearch::kStarts - first);
  JointsT<Lanes> starts;
  Mask active = uniform(false);
  for (int l = 0; l < kLanes; ++l) {
    // unused lanes repeat the first start (a finite one: their arithmetic still runs)
    const Joints trial = twin_start(search.from, search.weakest, first + (l < count ? l : 0));
    for (int j = 0; j < kDof; ++j) set_lane(starts[j], l, trial[j]);
    set_lane(active, l, l < count);
  }
  refine_lanes_exact(chain, ChainShape(chain), target, starts, JointMask{}, tolerance, {}, active);
  for (int l = 0; l < count; ++l) {
    Joints& root = search.root[first + l];
    for (int j = 0; j < kDof; ++j) root[j] = lane(starts[j], l);
    search.error[first + l] = check(chain, root.data(), target);
  }
  search.refined = first + count;
}

// A solution near the solution q on the far side of the fold it sits by, other than q and the ok
// rows of `known`: Newton from q displaced along J's weakest direction, kTwinSteps each way. `out`
// receives the first verified one that differs from all of them by more than `distinct` on some
// joint (mod 2pi); false when none does. `search` keeps the refined starts of the last q searched
// from (the same chain and target on every call).
inline bool find_twin(const Chain& chain, const Frame& target, const Joints& q, double tolerance,
                      double distinct, const Branches& known, Joints& out, TwinSearch& search) {
  using namespace continuation;
  if (search.refined == 0 || std::memcmp(search.from.data(), q.data(), sizeof q) != 0) {
    search.from = q;
    search.weakest = weakest_direction(chain, q, JointMask{});
    search.refined = 0;
  }
  for (int start = 0; start < TwinSearch::kStarts; ++start) {
    if (start == search.refined) refine_twin_starts(chain, target, tolerance, start, search);
    out = search.root[start];
    const PoseError& error = search.error[start];
    if (error.within(tolerance) && apart(out, q, distinct)) {
      bool fresh = true;
      for (int b = 0; b < kBranches; ++b) {
        if (known.ok[b] && !apart(out, known.q[b], distinct)) fresh = false;
      }
      if (fresh) return true;
    }
  }
  return false;
}

}  // namespace dhkin
