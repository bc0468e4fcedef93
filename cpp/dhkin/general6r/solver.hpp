// The general 6R solver's single call and batch: a pose (base_link -> tool0 or a TCP, 4 x 4
// row-major, metres) checked and projected, answered "out of reach" before any elimination where
// DH frame 6 lies beyond the chain's links, its starts (candidates.hpp), roots (roots.hpp) and
// answer (answer.hpp). Every pose is solved alone: a batch's answer does not depend on how it is
// split among threads.
#pragma once

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "dhkin/general6r/answer.hpp"
#include "dhkin/general6r/candidates.hpp"
#include "dhkin/general6r/crossings.hpp"
#include "dhkin/general6r/roots.hpp"
#include "dhkin/general6r/valley.hpp"
#include "dhkin/pose.hpp"
#include "dhkin/row_batch.hpp"

namespace dhkin::general6r {

// The point solutions are verified at: the exact chain to it, (tool tcp)^-1 (DH frame 6 -> that
// point, inverted), and the lever of the verification tolerance (m).
struct Tip {
  Chain chain;
  Frame tool_inverse;
  double lever = 1.0;
  double tool_length = 0.0;  // |translation of tool tcp| (m)
};

// A six-revolute table's solver: its elimination, moved poses, exact chain and limits.
struct Solver {
  Elimination elimination;
  // The table's other regular arrangements (each eliminates another joint), solved as well at
  // a pose with a singular root (settled_roots).
  std::vector<Elimination> others;
  Moves moves;
  Chain dh_chain;       // DH frame 0 -> DH frame 6, corrections included
  Frame tool;           // DH frame 6 -> tool0
  Frame base_inverse;   // base_link -> DH frame 0
  Limits limits;
  double lever = 1.0;   // the chain's lever: its longest link (at least 1 m)
  double links = 0.0;   // the sum of the chain's link lengths (m)

  // The tip at tool0, or at tool0 tcp (tcp: tool0 -> TCP).
  Tip tip(const Frame* tcp = nullptr) const {
    const double tip_lever = lever + norm(tool.translation());
    const Frame end = tcp ? tool * *tcp : tool;
    Tip out;
    out.chain = dh_chain;
    out.chain.tail = dh_chain.tail * end;
    out.tool_inverse = inverse(end);
    out.tool_length = norm(end.translation());
    out.lever = tcp ? std::max(tip_lever, lever + out.tool_length) : tip_lever;
    return out;
  }

  // The tip at DH frame 6 itself (roots of DH-frame-6 targets).
  Tip dh_tip() const {
    Tip out;
    out.chain = dh_chain;
    out.lever = lever;
    return out;
  }

  // How far DH frame 6 may lie from DH frame 0 (m) for a pose of `tip` within `tolerance`: the
  // chain's links, widened by the tolerance at the point and its rotation over the tool's length,
  // and FK rounding.
  double reach(double tolerance, const Tip& at) const {
    return links + tolerance * (1.0 + at.tool_length) +
           kFkRounding * (lever + norm(tool.translation()));
  }
};

// The verification tolerance: `tolerance` less the FK rounding margin (kFkRounding per metre of
// lever), so that a solution verified on our FK is within `tolerance` on the oracle's too.
inline double verification_tolerance(double tolerance, double lever) {
  return std::max(tolerance - kFkRounding * lever, 0.5 * tolerance);
}

// A root is flagged singular when its scaled Jacobian's smallest singular value is at most
// sqrt(tolerance): along the weakest direction every point within ~sqrt(tolerance) rad of it
// verifies as well, so at the tolerance the pose cannot be told from a singular one.
inline double singular_band(double verification) { return std::sqrt(verification); }

// DH frame 6's distance from DH frame 0 (m), by the largest coordinate first (no overflow at
// 1e300 m).
inline double reach_distance(const Frame& T_dh) {
  const double largest =
      std::max({std::abs(T_dh.p[0]), std::abs(T_dh.p[1]), std::abs(T_dh.p[2])});
  if (!(largest > 0.0) || !std::isfinite(largest)) return largest;
  const double x = T_dh.p[0] / largest, y = T_dh.p[1] / largest, z = T_dh.p[2] / largest;
  return largest * std::sqrt(x * x + y * y + z * z);
}

enum class Outcome : int {
  kSolved = 0,      // rows hold the solutions
  kRejected = 1,    // the pose is not usable (`status` says why)
  kOutOfReach = 2,  // `distance` beyond the links
  kNoRoot = 3,      // no root verified (`failed` starts did not)
  kNoCopy = 4,      // `verified` roots, none with an in-limit copy
};

struct Answer {
  Outcome outcome = Outcome::kSolved;
  int status = kUsable;
  double projection = 0.0;  // how far the pose's rotation block was moved onto a rotation
  double distance = 0.0;    // DH frame 6 from DH frame 0 (m), where out of reach
  int failed = 0;           // starts that did not verify
  int verified = 0;         // distinct roots
  std::vector<Solution> rows;
};

// Whether some root is singular (sigma within `band`).
inline bool any_singular(const std::vector<Root>& roots, double band) {
  for (const Root& root : roots) {
    if (root.sigma <= band) return true;
  }
  return false;
}

// The roots of T_dh (DH frame 0 -> DH frame 6) verified on `tip`'s chain against `tip_target`
// (DH frame 0 -> the tip) at the verification tolerance; returns the starts that failed.
//
// Where a root is singular, the eliminated joint's eigenvalue at it is a multiple one (a double
// root, or a curve of solutions: a defective eigenvalue of high order whose computed copies
// scatter by ~eps^(1 / order), up to 1e-2 rad), and a regular root whose eliminated joint
// takes the same value (as at special angles: the HC10's straight-up arm q2 = q3 = 0, a curve
// q1 + q4 fixed, and an isolated root with q2 = 0) falls into that scattered cluster and is
// lost. Every other regular arrangement eliminates another joint, where the two differ: their
// starts are settled too (with their own moved pose where their eigenproblem asks for it). And
// where the pose lies a hair from one with a curve of solutions, the roots left of that curve
// are found along the valleys of those found (valley.hpp), and where it lies a hair off a curve
// of solutions itself, the curve's crossings with a second singular set are roots of their own
// (crossings.hpp).
inline int settled_roots(const Solver& solver, const Tip& tip, const Frame& T_dh,
                         const Frame& tip_target, double verification, std::vector<Root>& roots) {
  const double band = singular_band(verification);
  std::vector<Start> starts;
  starts.reserve(64);
  all_candidates(solver.elimination, solver.moves, T_dh, starts);
  int failed = settle(tip.chain, tip_target, starts, solver.moves, verification, tip.lever, band,
                      roots);
  if (!any_singular(roots, band)) return failed;
  std::vector<Joints> start_values;  // the starts at the pose itself (not a moved pose's)
  const auto keep_values = [&start_values](const std::vector<Start>& some) {
    for (const Start& start : some) {
      if (start.origin < kMoved) start_values.push_back(start.q);
    }
  };
  keep_values(starts);
  for (const Elimination& other : solver.others) {
    starts.clear();
    all_candidates(other, solver.moves, T_dh, starts, false);
    failed += settle(tip.chain, tip_target, starts, solver.moves, verification, tip.lever, band,
                     roots);
    keep_values(starts);
  }
  valley_roots(tip.chain, tip_target, verification, tip.lever, band, start_values, roots);
  crossing_roots(tip.chain, tip_target, verification, tip.lever, band, roots);
  return failed;
}

// What the answers of a pose share whatever their seed: its usability, projection and distance,
// and its verified roots (before any seed moves a singular one along its curve).
struct PoseRoots {
  Answer answer;          // outcome, status, projection, distance, failed (no rows yet)
  Frame tip_target;       // the tip's target, DH frame 0 -> the tip
  double verification = 0.0;
  bool solved = false;    // roots were sought (the pose is usable and within reach)
  std::vector<Root> roots;
};

// The roots of the pose T (4 x 4 row-major) at `tolerance`: the part of solve() that does not
// depend on the seed.
inline PoseRoots pose_roots(const Solver& solver, const Tip& tip, const double* T,
                            double tolerance) {
  PoseRoots out;
  Answer& answer = out.answer;
  answer.status = pose_status(T);
  if (answer.status != kUsable) {
    answer.outcome = Outcome::kRejected;
    return out;
  }
  const Frame target = projected_frame(T, answer.projection);
  out.tip_target = solver.base_inverse * target;
  const Frame T_dh = out.tip_target * tip.tool_inverse;
  answer.distance = reach_distance(T_dh);
  if (!(answer.distance <= solver.reach(tolerance, tip))) {
    answer.outcome = Outcome::kOutOfReach;
    return out;
  }
  out.verification = verification_tolerance(tolerance, tip.lever);
  answer.failed = settled_roots(solver, tip, T_dh, out.tip_target, out.verification, out.roots);
  out.solved = true;
  return out;
}

// The answer of a pose from its roots (pose_roots, taken by value: the seed moves singular roots
// along their curves) for one seed: per root its in-limit 2pi copy nearest `seed` (zeros: no
// seed), or every copy with `copies`.
inline Answer answer_for_seed(const Solver& solver, const Tip& tip, PoseRoots pose,
                              const Joints& seed, double tolerance, bool copies) {
  Answer answer = pose.answer;
  if (!pose.solved) return answer;
  const double verification = pose.verification;
  const double band = singular_band(verification);
  const Frame& tip_target = pose.tip_target;
  std::vector<Root>& roots = pose.roots;
  const double slack = tolerance / tip.lever;
  if (any_singular(roots, band)) {
    seed_members(tip.chain, tip_target, seed, solver.limits, slack, verification, tip.lever,
                 band, roots);
  }
  answer.verified = static_cast<int>(roots.size());
  if (roots.empty()) {
    answer.outcome = Outcome::kNoRoot;
    return answer;
  }
  if (copies) {
    every_copy(tip.chain, tip_target, roots, seed, solver.limits, slack, verification,
               tip.lever, band, answer.rows);
  } else {
    nearest_copies(tip.chain, tip_target, roots, seed, solver.limits, slack, verification,
                   tip.lever, band, answer.rows);
  }
  if (answer.rows.empty()) answer.outcome = Outcome::kNoCopy;
  return answer;
}

// Every solution of the pose T (4 x 4 row-major) within the joint limits: per root its in-limit
// 2pi copy nearest `seed` (zeros: no seed), or every copy with `copies`. The roots do not depend
// on the seed: it only chooses each root's copy and, on a curve of solutions, its member.
inline Answer solve(const Solver& solver, const Tip& tip, const double* T, const Joints& seed,
                    double tolerance, bool copies) {
  return answer_for_seed(solver, tip, pose_roots(solver, tip, T, tolerance), seed, tolerance,
                         copies);
}

// A batch's answers, rows of all poses one after the other (dropped: starts that did not
// verify, per pose).
using BatchAnswers = RowBatch<Solution>;

// solve() of N poses (4 x 4 row-major, consecutive) for each of several seed sets (seeds[s]:
// kDof values per pose, `seed_stride` apart: 0 for one seed for all), each pose's roots found
// once and shared by its answers (they do not depend on the seed): answer s is, row for row,
// solve()'s with seed set s. Every set stops at the first pose not usable.
inline std::vector<BatchAnswers> solve_batch_seeds(const Solver& solver, const Tip& tip,
                                                   const double* T, std::size_t n,
                                                   const std::vector<const double*>& seeds,
                                                   std::size_t seed_stride, double tolerance,
                                                   bool copies) {
  std::vector<BatchAnswers> out(seeds.size());
  for (BatchAnswers& answers : out) answers.reserve(n, 8);
  for (std::size_t i = 0; i < n; ++i) {
    PoseRoots pose = pose_roots(solver, tip, T + 16 * i, tolerance);
    if (pose.answer.outcome == Outcome::kRejected) {
      for (BatchAnswers& answers : out) answers.reject(i, pose.answer.status);
      return out;
    }
    for (std::size_t s = 0; s < seeds.size(); ++s) {
      const Joints seed = seed_of(seeds[s], seed_stride, i);
      // each set but the last answers from a copy (the seed moves singular roots)
      const bool last = s + 1 == seeds.size();
      const Answer answer = answer_for_seed(solver, tip, last ? std::move(pose) : pose, seed,
                                            tolerance, copies);
      out[s].rows.insert(out[s].rows.end(), answer.rows.begin(), answer.rows.end());
      out[s].answered(static_cast<std::int64_t>(answer.rows.size()), answer.projection,
                      answer.failed);
    }
  }
  return out;
}

}  // namespace dhkin::general6r
