// The general 6R solver's answer from its verified roots: the seed's member where a joint is
// free, the in-limit 2pi copies, values onto the limits (docs/general6r.md, step 7).
//
// Joint values are URDF joint values (rad); `chain` is the exact chain to the point verified and
// `target` its pose in DH frame 0 (metres). `tolerance` is the verification tolerance;
// `slack` = the caller's tolerance / lever: a value that far outside a limit counts as on it.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "dhkin/copies.hpp"
#include "dhkin/general6r/members.hpp"
#include "dhkin/general6r/roots.hpp"

namespace dhkin::general6r {

using Limits = std::array<JointLimit, kDof>;

// A row of the answer: joint values, residuals, and whether it is singular.
struct Solution {
  Joints q{};
  PoseError error;
  bool singular = false;
  bool crossing = false;  // a crossing's row (Root::crossing)
};

// Rows (anything with a `q` and a `crossing` flag) kept in their order, but a row that
// `singular` marks is dropped where it is one root with a row kept before it (one_root: their
// midpoint verifies). A crossing's row is neither dropped nor takes another's place: the
// isolated near-solutions beside the crossing are tied to it alone (crossings.hpp).
template <class Row, class Singular>
void keep_distinct(const Chain& chain, const Frame& target, double tolerance,
                   std::vector<Row>& rows, Singular singular) {
  std::vector<Row> kept;
  for (const Row& row : rows) {
    bool merged = false;
    if (singular(row) && !row.crossing) {
      for (const Row& other : kept) {
        if (other.crossing) continue;
        if (one_root(chain, target, row.q, other.q, tolerance)) {
          merged = true;
          break;
        }
      }
    }
    if (!merged) kept.push_back(row);
  }
  rows.swap(kept);
}

// Whether every joint of q has a 2pi copy within the limits widened by `slack`.
inline bool has_copy(const Limits& limits, const Joints& q, double slack) {
  for (int j = 0; j < kDof; ++j) {
    const double first = std::ceil((limits[j].lower - slack - q[j]) / kTwoPi);
    if (!(q[j] + kTwoPi * first <= limits[j].upper + slack)) return false;
  }
  return true;
}

// The point of the limits' box nearest q: per joint, its 2pi copy nearest [lower, upper],
// clipped into it; `outside` (rad) how far q's copies lie from the box at most.
inline Joints box_point(const Limits& limits, const Joints& q, double& outside) {
  Joints out;
  outside = 0.0;
  for (int j = 0; j < kDof; ++j) {
    const double centre = 0.5 * (limits[j].lower + limits[j].upper);
    double value = q[j];
    if (std::isfinite(centre)) value += kTwoPi * std::nearbyint((centre - q[j]) / kTwoPi);
    const double inside = std::min(std::max(value, limits[j].lower), limits[j].upper);
    outside = std::max(outside, std::abs(value - inside));
    out[j] = inside;
  }
  return out;
}

// Whether the excess of `moved` beyond the box still falls onwards from `from`: the weak
// directions' share of the offset to the box's nearest point points away from `from`. A pass
// that went into the box and out again ends where the excess falls back towards `from`.
inline bool still_entering(const Chain& chain, const Limits& limits, const Joints& from,
                           const Joints& moved, double lever, double band) {
  const RightSvd svd = right_svd(scaled_jacobian(chain, moved, lever));
  double outside = 0.0;
  const Joints nearest = box_point(limits, moved, outside);
  Vector6d offset, travelled, step = Vector6d::Zero();
  for (int j = 0; j < kDof; ++j) {
    offset(j) = wrap(nearest[j] - moved[j]);
    travelled(j) = wrap(moved[j] - from[j]);
  }
  for (int w = 0; w < kDof; ++w) {
    if (svd.values(w) <= band) step += svd.V.col(w).dot(offset) * svd.V.col(w);
  }
  return step.dot(travelled) > 0.0;
}

// The goal of a pass of walk_into_limits that crosses into the box in one pass where the curve
// is straight (Newton along the curve): q moved along the Jacobian's one weak direction (singular
// value within `band`: the curve's tangent t) by the step that brings the one joint j beyond the
// box to half the margin outside its limit, (excess / t_j) t (the pass then ends within the
// margin where the curve's bend over the step moves joint j by less than half the margin either
// way; a pass that ends inside the box, or through it and out again, is not kept: see
// walk_into_limits). The plain goal, the box's point nearest q, moves a member along a curve that
// meets the box at a small angle only t_j^2 of the way per pass (von Neumann's rate): tm5_900 at
// q = (0, 90, 155, 90, 180, 0) deg (q3 on its limit, q5 = 180 deg), t_3 = 0.026, 7400 passes per
// root from 0.07 rad beyond, 10 s a pose. False where more than one direction is weak (a crossing
// of curves) or more than one joint lies beyond the box: the plain passes there, as before (a
// least-squares step on a folded M-430iA/2P, q1 and q5 beyond their limits at a crossing of two
// curves, carried a member onto the q1 limit, a second row of a set answered once). The step is
// cut to kMaxJointStep per joint (Newton's trusted step): a curve that dips into the box and out
// again within one pass would be crossed twice.
inline bool crossing_goal(const Chain& chain, const Limits& limits, const Joints& q,
                          double margin, double lever, double band, Joints& goal) {
  const RightSvd svd = right_svd(scaled_jacobian(chain, q, lever));
  if (!(svd.values(kDof - 1) <= band) || svd.values(kDof - 2) <= band) return false;
  double outside = 0.0;
  const Joints nearest = box_point(limits, q, outside);
  int beyond_joint = -1;
  double beyond = 0.0;  // signed, outwards
  for (int j = 0; j < kDof; ++j) {
    const double offset = wrap(q[j] - nearest[j]);
    if (std::abs(offset) <= 0.5 * margin) continue;  // within the box up to the rounding, or near
    if (beyond_joint >= 0) return false;
    beyond_joint = j, beyond = offset;
  }
  if (beyond_joint < 0) return false;
  const Vector6d tangent = svd.V.col(kDof - 1);
  const double along = (std::copysign(0.5 * margin, beyond) - beyond) / tangent(beyond_joint);
  const Vector6d step = along * tangent;
  const double longest = step.cwiseAbs().maxCoeff();
  if (!(longest > 0.0) || !std::isfinite(longest)) return false;
  const double scale = std::min(1.0, newton::kMaxJointStep / longest);
  for (int j = 0; j < kDof; ++j) goal[j] = q[j] + scale * step(j);
  return true;
}

// A member q (in place) with no 2pi copy within the limits widened by `margin`, walked towards
// them: alternately to the box's point nearest it and back onto the solutions (von Neumann's
// alternating projections, which reach a point of both where the curve of solutions crosses
// into the box), while each pass brings it nearer the box by more than the tolerance. A folded
// M-430iA/2P (q3 = 180 deg, links 2 and 3 equally long: q2 free) has members nearest q = 0 at
// q5 = 180 deg or q2 = -180 deg, beyond its limits, and members within them. Here a member also
// walks a valley's verifying floor (walk's `floors`: a target a hair off such a pose): the root
// has no copy within the limits, so no in-limit root is given up for the floor's member. Each
// pass first tries the crossing's goal (crossing_goal: a curve meeting the box at a small angle
// takes the plain goal thousands of passes), kept where it ends nearer the box, still outside
// it and still entering it (still_entering; past the crossing a member would reach a crossing
// other than the plain passes' first one); else the plain goal.
inline void walk_into_limits(const Chain& chain, const Frame& target, const Limits& limits,
                             double margin, double tolerance, double lever, double band,
                             Joints& q, PoseError& error) {
  double outside = 0.0;
  Joints goal = box_point(limits, q, outside);
  while (!has_copy(limits, q, margin)) {
    Joints crossing;
    if (crossing_goal(chain, limits, q, margin, lever, band, crossing)) {
      Joints moved = q;
      PoseError moved_error = error;
      const Projection projection = project(chain, target, crossing, tolerance, lever, band);
      nearest_member(chain, target, crossing, projection, tolerance, lever, band, moved,
                     moved_error, true);
      double moved_outside = 0.0;
      const Joints next_goal = box_point(limits, moved, moved_outside);
      if (moved_outside < outside - tolerance && moved_outside > 0.0 &&
          still_entering(chain, limits, q, moved, lever, band)) {
        q = moved, error = moved_error, goal = next_goal, outside = moved_outside;
        continue;
      }
    }
    Joints moved = q;
    PoseError moved_error = error;
    const Projection projection = project(chain, target, goal, tolerance, lever, band);
    nearest_member(chain, target, goal, projection, tolerance, lever, band, moved, moved_error,
                   true);
    double moved_outside = 0.0;
    const Joints next_goal = box_point(limits, moved, moved_outside);
    if (!(moved_outside < outside - tolerance)) return;
    q = moved, error = moved_error, goal = next_goal, outside = moved_outside;
  }
}

// The seed's choice where a joint is free, in place, as the families' seeded candidate (the
// member of the solution family nearest the seed): each singular root (sigma within `band`)
// becomes its member nearest the seed (nearest_member). The seed is never a root of its own. A
// member with no 2pi copy within the limits (widened to the band) is walked into them
// (walk_into_limits); one that still has none, where the root itself has, stays where the root
// was. A root that is no point of a curve (sigma above the tolerance) but walked onto one, with
// no segment of solutions between, stays where it was, the curve's member added after the roots.
// A root that moved onto
// an earlier one (the merging rule) is dropped.
inline void seed_members(const Chain& chain, const Frame& target, const Joints& seed,
                         const Limits& limits, double slack, double tolerance, double lever,
                         double band, std::vector<Root>& roots) {
  const Projection projection = project(chain, target, seed, tolerance, lever, band);
  const double margin = std::max(slack, band);
  std::vector<Root> members;  // curves' members reached from isolated roots beside them
  for (Root& root : roots) {
    if (!(root.sigma <= band) || root.crossing) continue;
    Joints q = root.q;
    PoseError error = root.error;
    nearest_member(chain, target, seed, projection, tolerance, lever, band, q, error);
    if (!has_copy(limits, q, margin)) {
      walk_into_limits(chain, target, limits, margin, tolerance, lever, band, q, error);
    }
    if (!has_copy(limits, q, margin) && has_copy(limits, root.q, margin)) continue;
    // An isolated root beside a curve of solutions: a root whose smallest singular value is
    // above the tolerance is no point of a curve (along a curve every point verifies, so the
    // Jacobian's weakest direction moves the pose by less than the tolerance per radian: sigma
    // within it, ~1e-17 on a true curve). Where two curves of the table cross and the target is
    // a hair off (a rounded description), isolated roots remain near the crossing (HC10 q =
    // (90, 180, 180, 180, 180, 90) deg: sigma 9.2e-7, 2e-5 rad off the q1 + q4 curve), and the
    // walk carried such a root onto the curve, where its member merged with the curve's own:
    // the root was lost. Where no segment of solutions ties the member to the root (on_segment:
    // an elimination root in a curve's cloud, ~1e-7 rad off a line of the CRX-10iA, is tied to
    // its member), it stays a row of its own, and the curve's member reached is added.
    if (root.sigma > tolerance) {
      const double member_sigma = smallest_singular(chain, q, lever, tolerance);
      if (member_sigma <= tolerance &&
          !on_segment(chain, target, root.q, q, tolerance, lever, band)) {
        members.push_back({q, error, member_sigma});
        continue;
      }
    }
    root.q = q;
    root.error = error;
  }
  roots.insert(roots.end(), members.begin(), members.end());
  keep_distinct(chain, target, tolerance, roots,
                [band](const Root& root) { return root.sigma <= band; });
}

// A row whose values were set onto limits (`held` marks them): the other joints refined with
// those held (monotone Newton: a root on the limit up to rounding is exact again; a member of a
// curve of solutions, sigma_min within the tolerance, only across the curve by settle_across,
// so that it stays where the seed put it), the values clipped to the limits, verified again;
// false where it no longer verifies (`row` then holds the clipped values as they were where
// that verifies).
inline bool settle_on_limits(const Chain& chain, const Frame& target, const Limits& limits,
                             const JointMask& held, double tolerance, double lever,
                             Solution& row, bool restore) {
  const Joints clipped = row.q;
  if (row.singular && smallest_singular(chain, row.q, lever, tolerance) <= tolerance) {
    settle_across(chain, target, row.q, lever, tolerance, held);
  } else {
    refine(chain, target, row.q, held, refine_tolerance(tolerance, lever),
           {kBudget, newton::kMonotone, 0.0});
  }
  for (int j = 0; j < kDof; ++j) {
    row.q[j] = std::min(std::max(row.q[j], limits[j].lower), limits[j].upper);
  }
  row.error = check(chain, row.q.data(), target);
  if (!row.error.within(tolerance) && restore) {
    // the held joints leave Newton no way back (a singular root): as it was
    row.q = clipped;
    row.error = check(chain, row.q.data(), target);
  }
  return row.error.within(tolerance);
}

// The 2pi copy of `value` nearest `reference`, moved by whole turns into [low, high] where it
// lies outside (the caller checks that it lies within: an interval shorter than a turn may hold
// no copy).
inline double copy_into(double value, double reference, double low, double high) {
  double copy = value + kTwoPi * std::nearbyint((reference - value) / kTwoPi);
  if (copy < low) copy += kTwoPi * std::ceil((low - copy) / kTwoPi);
  if (copy > high) copy -= kTwoPi * std::ceil((copy - high) / kTwoPi);
  return copy;
}

// Per joint the 2pi copy of q nearest `reference` within the limits themselves, into `out`;
// false where a joint has none.
inline bool copy_within(const Limits& limits, const Joints& q, const Joints& reference,
                        Joints& out) {
  for (int j = 0; j < kDof; ++j) {
    const double value = copy_into(q[j], reference[j], limits[j].lower, limits[j].upper);
    if (!(value >= limits[j].lower && value <= limits[j].upper)) return false;
    out[j] = value;
  }
  return true;
}

// Per root, per joint its 2pi copy nearest `reference` within the limits widened by `slack` (a
// singular root's by the band: it lies anywhere in a cloud of near-solutions that wide), set onto
// the limit where outside it and verified again; roots without such a copy, or that no longer
// verify, are left out.
inline void nearest_copies(const Chain& chain, const Frame& target, const std::vector<Root>& roots,
                           const Joints& reference, const Limits& limits, double slack,
                           double tolerance, double lever, double band,
                           std::vector<Solution>& out) {
  for (const Root& root : roots) {
    const bool singular = root.sigma <= band;
    const double margin = singular ? std::max(slack, band) : slack;
    Solution row{root.q, root.error, singular, root.crossing};
    JointMask held{};
    bool inside = true, moved = false;
    for (int j = 0; j < kDof && inside; ++j) {
      const double low = limits[j].lower - margin, high = limits[j].upper + margin;
      double value = copy_into(root.q[j], reference[j], low, high);
      if (value < low || value > high) inside = false;
      if (value < limits[j].lower) value = limits[j].lower, moved = held[j] = true;
      if (value > limits[j].upper) value = limits[j].upper, moved = held[j] = true;
      row.q[j] = value;
    }
    if (!inside) continue;
    if (!moved) {
      out.push_back(row);
      continue;
    }
    const Joints set = row.q;  // the copy, its values set onto the limits
    const bool settled = settle_on_limits(chain, target, limits, held, tolerance, lever, row, true);
    // Set onto a limit it no longer verifies (a singular root's held joints can leave Newton no
    // way back), or, a singular row, it settled farther than the margin from where its values
    // were set: it has left the seed's member. Its values moved by at most the margin, but with
    // a joint held the Jacobian of a point of a curve has weak directions of its own (the HC10
    // pointing down, q2 = q3 = 180 deg: sigma 1.3e-8 with q2 held, against 1.9e-3 for the
    // curve's nearest transverse direction without), and settle_across's steps along them
    // (residual / sigma) carried the member 0.6-0.8 rad along the q1 + q4 curve, exact but far
    // from the seed (`dhkin validate motoman_hc10`, four discontinuous samples). Then its copy
    // strictly within the limits, where it has one, verifies as the root does (the member 1.7e-8
    // rad inside the q2 limit there; the HC10's straight-up arm at q1 = q4 = 180 deg, the root
    // 4e-8 beyond); where it has none, the settled row (a verified member) rather than none.
    if (!settled || (singular && joint_distance(row.q, set) > margin)) {
      Solution inner = row;
      if (copy_within(limits, root.q, reference, inner.q)) {
        inner.error = check(chain, inner.q.data(), target);
        if (inner.error.within(tolerance)) {
          out.push_back(inner);
          continue;
        }
      }
      if (!settled) continue;
    }
    out.push_back(row);
  }
  // singular members set onto a limit may meet: one root
  keep_distinct(chain, target, tolerance, out, [](const Solution& row) { return row.singular; });
}

// Every 2pi copy of each root within the limits widened by `slack` (joint 1 slowest), a value
// outside a limit set onto it, the row refined with it held and verified again (left out where
// it no longer verifies). Joints whose limits are not finite take the copy nearest `reference`.
inline void every_copy(const Chain& chain, const Frame& target, const std::vector<Root>& roots,
                       const Joints& reference, const Limits& limits, double slack,
                       double tolerance, double lever, double band, std::vector<Solution>& out) {
  for (const Root& root : roots) {
    std::array<long, kDof> first{}, count{};
    long total = 1;
    for (int j = 0; j < kDof; ++j) {
      const double low = limits[j].lower - slack, high = limits[j].upper + slack;
      if (!(std::isfinite(low) && std::isfinite(high))) {
        first[j] = static_cast<long>(std::nearbyint((reference[j] - root.q[j]) / kTwoPi));
        count[j] = 1;
      } else {
        first[j] = static_cast<long>(std::ceil((low - root.q[j]) / kTwoPi));
        count[j] = std::max(0L, static_cast<long>(std::floor((high - root.q[j]) / kTwoPi)) -
                                    first[j] + 1);
      }
      total *= count[j];
    }
    for (long index = 0; index < total; ++index) {
      Solution row{root.q, root.error, root.sigma <= band, root.crossing};
      JointMask held{};
      long rest = index;
      for (int j = kDof - 1; j >= 0; --j) {
        const double value = root.q[j] + kTwoPi * static_cast<double>(first[j] + rest % count[j]);
        rest /= count[j];
        row.q[j] = std::min(std::max(value, limits[j].lower), limits[j].upper);
        held[j] = row.q[j] != value;
      }
      bool moved = false;
      for (bool h : held) moved = moved || h;
      if (moved && !settle_on_limits(chain, target, limits, held, tolerance, lever, row, false)) {
        continue;
      }
      out.push_back(row);
    }
  }
}

}  // namespace dhkin::general6r
