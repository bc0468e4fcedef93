// A refined table's roots beyond the ideal model's branches: duplicates merged or split into
// twins, corrected-target retries of lost branches, the roots along a singular family, and
// extra roots placed.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "dhkin/continuation.hpp"
#include "dhkin/newton.hpp"
#include "dhkin/plan.hpp"
#include "dhkin/refine_lanes_exact.hpp"

namespace dhkin {

// Corrected-target retries of a lost branch (each one family solve and one refinement).
constexpr int kCorrections = 2;

// The one place where the seed still finds (known gap, docs/ik_core.md): on a refined table a
// root the valley scan misses (near a reach boundary and the wrist singularity at once, where the
// ideal model's family members are clamped onto the reach) is looked for from a seed within one
// maximal Newton step of the pose (rotation error at most kMaxJointStep, position error at most
// that times the lever): a monotone, damped descent from it (kSeedDamping) finds the root in its
// basin; when it is nearer the seed than the solution of the branch it lies nearest, it takes
// that branch's slot (its solution moves to the nearest empty slot, if any).
inline void seed_root(const Plan& plan, const Frame& T, const Joints& seed, double tolerance,
                      Branches& branches) {
  const Chain& chain = plan.chain;
  PoseError error = check(chain, seed.data(), T);
  if (error.rotation > newton::kMaxJointStep ||
      error.position > newton::kMaxJointStep * plan.lever) {
    return;
  }
  Joints root = seed;
  error = refine(chain, T, root, JointMask{}, tolerance,
                 {newton::kBudget, newton::kMonotone, newton::kSeedDamping});
  if (!error.within(tolerance)) return;
  plan.wrap_revolute(root);
  if (branches.known(plan, root)) return;
  int slot = -1;
  double nearest = INFINITY;
  for (int b = 0; b < kBranches; ++b) {
    if (branches.ok[b]) {
      const double distance = plan.seed_distance(branches.q[b], root);
      if (distance < nearest) slot = b, nearest = distance;
    }
  }
  if (slot < 0) {
    slot = 0;
  } else if (plan.seed_distance(root, seed) >= plan.seed_distance(branches.q[slot], seed)) {
    return;
  } else {
    for (int k = 1; k < kBranches; ++k) {  // the displaced solution to the nearest empty slot
      if (!branches.ok[slot ^ k]) {
        branches.q[slot ^ k] = branches.q[slot];
        branches.ok[slot ^ k] = true;
        branches.errors[slot ^ k] = branches.errors[slot];
        break;
      }
    }
  }
  branches.q[slot] = root;
  branches.ok[slot] = true;
  branches.errors[slot] = error;
}

// Roots found beside the branches' own, each with the branch it was found from.
struct Extras {
  static constexpr int kCapacity = 4 * kBranches;
  std::array<Joints, kCapacity> q{};
  std::array<int, kCapacity> branch{};
  int count = 0;

  // Adds a root unless it is one of the extras already (2 kMergeAngle, mod 2pi).
  void add(const Plan& plan, int b, const Joints& root) {
    for (int k = 0; k < count; ++k) {
      if (plan.same(q[k], root, 2.0 * kMergeAngle)) return;
    }
    if (count < kCapacity) q[count] = root, branch[count] = b, ++count;
  }
};

// Each verified extra root that no slot holds yet goes to the first empty slot among b ^ 0,
// b ^ 1, ..., b ^ (reach - 1) (own, wrist twin, elbow pair, shoulder partners) of the branch b
// it was found from; with `slack` (the limit slack, tolerance / lever), an extra root inside the
// joint limits may also take a slot whose root has no copy inside them (that root would not be
// answered: near a singular set the exact chain can have more roots than the ideal model's eight
// branches, and those that the limits admit are kept; the slot's labels are then its own).
inline void place_extras(const Plan& plan, const Frame& T, const Extras& extras,
                         const std::array<std::uint8_t, kBranches>& extra_flags,
                         Branches& branches, int reach, double slack = -1.0) {
  for (int k = 0; k < extras.count; ++k) {
    const int b = extras.branch[k];
    if (branches.known(plan, extras.q[k])) continue;
    const bool admitted = slack >= 0.0 && plan.in_limits(extras.q[k], slack);
    for (int step = 0; step < reach; ++step) {
      const int slot = b ^ step;
      if (!branches.ok[slot] ||
          (admitted && !plan.in_limits(branches.q[slot], slack))) {
        branches.q[slot] = extras.q[k];
        branches.ok[slot] = true;
        branches.flags[slot] = extra_flags[b];
        branches.errors[slot] = check(plan.chain, branches.q[slot].data(), T);
        break;
      }
    }
  }
}

// Near a singular set the exact chain of a refined table can have more roots inside the limits
// than the eight branch slots (a calibrated UR5e at q5 = 0: nine or ten). Every root is found
// without the seed (valley_roots); where one still has no slot, the seed chooses which of the
// competing roots a slot shows: an extra root takes the slot of the root nearest it (its
// neighbour on the family) when it lies nearer the seed than that root.
inline void place_nearer_the_seed(const Plan& plan, const Frame& T, const Extras& extras,
                                  const Joints& seed, double slack, Branches& branches) {
  for (int k = 0; k < extras.count; ++k) {
    const Joints& root = extras.q[k];
    if (branches.known(plan, root) || !plan.in_limits(root, slack)) continue;
    int slot = -1;
    double nearest = INFINITY;
    for (int b = 0; b < kBranches; ++b) {
      if (!branches.ok[b]) continue;
      const double distance = plan.seed_distance(branches.q[b], root);
      if (distance < nearest) slot = b, nearest = distance;
    }
    if (slot >= 0 && plan.seed_distance(root, seed) < plan.seed_distance(branches.q[slot], seed)) {
      branches.q[slot] = root;
      branches.errors[slot] = check(plan.chain, root.data(), T);
    }
  }
}

// Points of a singular family scanned for the exact chain's roots along it: the free wrist joint
// of the seed given to the family over a whole turn in this many steps (the family's members
// then cover the turn once).
constexpr int kValleyGrid = 16;
// Steps of successive parabolic interpolation that take a local minimum of the scan to the root
// beside it, within a bracket that every step narrows (a trial point that is not lower bounds the
// minimum on its side): the squared residual is quadratic near a simple root, so each step gains
// about as many digits as it has (from a grid step of ~0.4 rad, four reach ~1e-6 rad and the
// descent below then converges at once). Near a double root (the calibrated UR5e's special poses,
// e.g. q = (-90, 90, -90, -90, 0, 0) deg: two roots 2.3e-4 rad apart on q6, sigma_min 7e-9) it
// is quartic and a step gains a constant factor; four steps, stopping at the first that was not
// lower, ended 4e-3 to 3e-2 rad off, where the released descent did not converge, so only the
// seed found those roots. Twelve within the bracket reach 2e-5 to 1e-4. (Stopping them once the
// middle's held member passed refinement's convergence test was tried: it saved little beyond
// the held members' own stop, and on kinova_gen3_6dof 4 more of 200 special-angle poses
// answered other solutions with a seed than without, scripts/check_seed_independence.py.)
constexpr int kValleySteps = 12;

namespace valley {

// A member of branch b's family with the seed's free wrist joint at t, refined on the exact chain
// with that joint held; its squared residual (infinite where the family has no member). Away
// from a root the held problem's least residual is not zero and Gauss-Newton gains only linearly
// towards it: refinement stops at the first descent step that gains less than kPolishGain
// (newton::Settings::stop_on_stall), which leaves the residual a small fraction above the least
// one. Near a root the steps gain quadratically and polish it as before.
struct Point {
  double t = 0.0, squared = INFINITY;
  Joints q{};
};

// How a held member is refined: kPolishBudget evaluations, Newton's steps, stopping at a stall.
inline newton::Settings held_settings() { return {kPolishBudget, newton::kGrowth, 0.0, true}; }

// The member of branch b's family with the seed's free wrist joint at t, wrapped, in point.q
// (point.t = t); false where the family has no member there (point.q is then left as it is).
inline bool family_member(const Plan& plan, const Frame& T_dh, const Joints& base, int b,
                          double t, double clamp, Candidates& found, Point& point) {
  point.t = t;
  Joints moved = base;
  moved[plan.free_wrist] = t;
  plan.solve_family(T_dh, moved, kWrist, clamp, found, b, true);
  if (!found.valid[b] || !finite(found.q[b])) return false;
  point.q = found.q[b];
  plan.wrap_revolute(point.q);
  return true;
}

// The point at t: its member refined with the free wrist joint held.
inline Point held_member(const Plan& plan, const Frame& T_dh, const Frame& T_at,
                         const Joints& base, int b, double t, double clamp, double tolerance,
                         Candidates& found) {
  Point point;
  if (!family_member(plan, T_dh, base, b, t, clamp, found, point)) return point;
  const double r = refine(plan.chain, T_at, point.q, plan.free_joints(kWrist), tolerance,
                          held_settings())
                       .largest();
  point.squared = r * r;
  return point;
}

// The refinement of held_member for the points whose member `exists`, kLanes at a time
// (refine_lanes_exact: the same bits as one by one).
template <std::size_t N>
inline void refine_held(const Plan& plan, const Frame& T_at, double tolerance,
                        const std::array<bool, N>& exists, std::array<Point, N>& points) {
  const Chain& chain = plan.chain;  // a plan's chain: kDof joints
  const JointMask held = plan.free_joints(kWrist);
  const ChainShape shape(chain);
  for (std::size_t first = 0; first < N; first += kLanes) {
    const int count = static_cast<int>(std::min<std::size_t>(kLanes, N - first));
    JointsT<Lanes> q;
    Mask active = uniform(false);
    for (int l = 0; l < count; ++l) {
      // a point without a member takes no part (its start {}, a finite one)
      for (int j = 0; j < kDof; ++j) set_lane(q[j], l, points[first + l].q[j]);
      set_lane(active, l, exists[first + l]);
    }
    if (!any(active)) continue;
    const PoseErrorT<Lanes> errors =
        refine_lanes_exact(chain, shape, T_at, q, held, tolerance, held_settings(), active);
    for (int l = 0; l < count; ++l) {
      if (!exists[first + l]) continue;
      Point& point = points[first + l];
      for (int j = 0; j < kDof; ++j) point.q[j] = lane(q[j], l);
      const double r = lane(errors, l).largest();
      point.squared = r * r;
    }
  }
}

}  // namespace valley

// On a refined table near the wrist singularity the exact chain is not singular: where the ideal
// model has a one-parameter family, the exact chain has isolated roots along it (the flip pair,
// and beside them others: a wrist 0.175 mm from spherical, a calibrated UR5e, have three or four
// per family near q5 = 0). They are found without the seed: the family's members over the whole
// turn (kValleyGrid), each refined on the exact chain with its free joint held (what remains is
// how far the exact chain is from reaching the pose there); each local minimum of that residual
// along the turn taken to the root beside it by parabolic interpolation on the squared residual
// (kValleySteps), then every joint released: a monotone descent and Newton's polish. Every
// verified root not yet known is an extra of branch b.
inline void valley_roots(const Plan& plan, const Frame& T_dh, const Frame& T_at,
                         const Joints& regular_q, int b, double clamp, double tolerance,
                         const Branches& known, Extras& extras) {
  using valley::Point;
  Candidates found;
  std::array<Point, kValleyGrid> grid;
  const double start = regular_q[plan.free_wrist], step = kTwoPi / kValleyGrid;
  std::array<bool, kValleyGrid> exists;
  for (int k = 0; k < kValleyGrid; ++k) {  // held members: closed forms, then refined in lanes
    exists[k] =
        valley::family_member(plan, T_dh, regular_q, b, start + k * step, clamp, found, grid[k]);
  }
  valley::refine_held(plan, T_at, tolerance, exists, grid);
  const JointMask none{};
  for (int k = 0; k < kValleyGrid; ++k) {
    Point left = grid[(k + kValleyGrid - 1) % kValleyGrid], middle = grid[k],
          right = grid[(k + 1) % kValleyGrid];
    if (!(middle.squared <= left.squared && middle.squared <= right.squared)) continue;
    left.t = middle.t - step, right.t = middle.t + step;  // the neighbours across the seam
    for (int s = 0; s < kValleySteps && std::isfinite(left.squared + right.squared); ++s) {
      // the vertex of the parabola through the three points, kept inside the bracket
      const double a = (middle.t - left.t) * (middle.squared - right.squared);
      const double c = (middle.t - right.t) * (middle.squared - left.squared);
      const double denominator = 2.0 * (a - c);
      if (!(std::abs(denominator) > 0.0)) break;
      double t = middle.t - ((middle.t - left.t) * a - (middle.t - right.t) * c) / denominator;
      t = std::min(std::max(t, left.t), right.t);
      const Point next = valley::held_member(plan, T_dh, T_at, regular_q, b, t, clamp,
                                             tolerance, found);
      if (!(next.t != middle.t) || !std::isfinite(next.squared)) break;
      if (next.squared < middle.squared) {  // the new middle; the old one bounds its side
        (next.t < middle.t ? right : left) = middle;
        middle = next;
      } else {  // not lower: it still bounds the minimum on its side
        (next.t < middle.t ? left : right) = next;
      }
    }
    Joints root = middle.q;
    if (!std::isfinite(middle.squared) ||
        !refine(plan.chain, T_at, root, none, tolerance,
                {newton::kBudget, newton::kMonotone, newton::kSeedDamping})
             .within(tolerance)) {
      continue;
    }
    refine(plan.chain, T_at, root, none, tolerance);  // polished
    plan.wrap_revolute(root);
    if (check(plan.chain, root.data(), T_at).within(tolerance) && !known.known(plan, root)) {
      extras.add(plan, b, root);
    }
  }
}

// Branches that answered with one solution (a refined table's two starts converging to one root;
// polished clamps of an exact table at a fold; members of one singular family): the second looks
// for the twin root it lost (find_twin) and keeps it when that is a new solution; else it is
// merged into the first, which keeps whichever of the two lies nearer the seed. No twin search for
// a `member` of a singular family (it held the seed's free joint): every neighbour of it on the
// family would pass for a twin.
inline void merge_duplicates(const Plan& plan, const Frame& T, const Joints& seed,
                             double tolerance, const std::array<bool, kBranches>& member,
                             Branches& branches) {
  TwinSearch search;
  for (int a = 0; a < kBranches; ++a) {
    if (!branches.ok[a]) continue;
    for (int b = a + 1; b < kBranches; ++b) {
      if (!branches.ok[b] || !plan.same(branches.q[a], branches.q[b], 2.0 * kMergeAngle)) {
        continue;
      }
      branches.ok[b] = false;
      Joints twin;
      if (!(member[a] || member[b]) &&
          find_twin(plan.chain, T, branches.q[a], tolerance, 2.0 * kMergeAngle, branches, twin,
                    search)) {
        branches.ok[b] = true;
        plan.wrap_revolute(twin);
        branches.q[b] = twin;
        branches.errors[b] = check(plan.chain, twin.data(), T);
        continue;
      }
      if (plan.seed_distance(branches.q[b], seed) < plan.seed_distance(branches.q[a], seed)) {
        branches.q[a] = branches.q[b];
        branches.errors[a] = branches.errors[b];
      }
    }
  }
}

// FK_ideal(q) FK_exact(q)^-1 T.
inline Frame corrected_target(const Chain& ideal, const Chain& exact, const Joints& q,
                              const Frame& T) {
  return fk(ideal, q.data()) * inverse(fk(exact, q.data())) * T;
}

// What the first closed form gave for one pose, before seeded candidates replaced any.
struct Regular {
  std::array<Joints, kBranches> q{};
  std::array<bool, kBranches> valid{};
  std::array<std::uint8_t, kBranches> flags{};
  std::array<std::uint8_t, kBranches> near{};
  // false for a long shot that the exact chain cannot reach (reach_bound.hpp): not chased
  std::array<bool, kBranches> chased{};
};

// A refined table's branch that did not settle, or that settled on another branch's solution, is
// tried again from the ideal model's closed form for the corrected target
// T' = FK_ideal(q_c) FK_exact(q_c)^-1 T, q_c its candidate: to first order the ideal model then
// sees the pose where the exact chain does (near a fold of the arm, where the ideal model's roots
// merge or vanish while the exact chain's do not, this moves the start to the right side of the
// fold). Up to kCorrections times, each candidate refined and verified.
inline void retry_corrected(const Plan& plan, const Frame& T_dh, const Frame& T_at,
                            const Joints& seed, double clamp, double tolerance,
                            const Regular& regular, Branches& branches) {
  Candidates candidates;
  for (int b = 0; b < kBranches; ++b) {
    if (branches.ok[b] || !regular.chased[b] || !finite(regular.q[b]) ||
        !(regular.valid[b] || (regular.near[b] & kClamped) != 0)) {
      continue;
    }
    Joints start = regular.q[b];
    for (int attempt = 0; attempt < kCorrections; ++attempt) {
      const Frame corrected = corrected_target(plan.ideal, plan.chain, start, T_dh);
      plan.solve_family(corrected, seed, 0, clamp, candidates);
      if (!finite(candidates.q[b])) break;
      // the ideal model has no root for the corrected target on this branch even within the
      // clamp band: no start to retry from (its clamped candidate would only repeat the long
      // shot's chase from another point beyond the reach)
      if (!candidates.valid[b]) break;
      start = candidates.q[b];
      Joints trial = start;
      refine(plan.chain, T_at, trial, JointMask{}, tolerance);
      if (check(plan.chain, trial.data(), T_at).within(tolerance)) {
        if (!branches.known(plan, trial)) {
          plan.wrap_revolute(trial);
          branches.q[b] = trial;
          branches.ok[b] = true;
          branches.errors[b] = check(plan.chain, trial.data(), T_at);
          branches.flags[b] = candidates.flags[b];
        }
        break;
      }
    }
  }
}

}  // namespace dhkin
