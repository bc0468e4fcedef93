// A refined table's roots beyond the ideal model's branches: duplicates merged or split into
// twins, corrected-target retries of lost branches, extra roots placed, and the root in the
// seed's basin.
#pragma once

#include <cmath>

#include "dhkin/continuation.hpp"
#include "dhkin/newton.hpp"
#include "dhkin/plan.hpp"

namespace dhkin {

// Corrected-target retries of a lost branch (each one family solve and one refinement).
constexpr int kCorrections = 2;

// A refined table's seed within one maximal Newton step of the pose (rotation error at most
// kMaxJointStep, position error at most that times the lever) is a start as good as the ideal
// model's closed form, which is up to the family band off the exact chain: a monotone, damped
// descent from it (kSeedDamping) finds the root in its basin. Near a singularity the exact chain
// can have roots the ideal model has not; such a root, when it is nearer the seed than the
// solution of the branch it lies nearest, takes that branch's slot (its solution moves to the
// nearest empty slot, if any).
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

// Roots found beside a branch's own (one per branch slot at most).
struct Extras {
  std::array<Joints, kBranches> q{};
  std::array<bool, kBranches> ok{};
};

// Each verified extra root that no slot holds yet goes to the first empty slot among b ^ 0,
// b ^ 1, ..., b ^ (reach - 1) (own, wrist twin, elbow pair, shoulder partners).
inline void place_extras(const Plan& plan, const Frame& T, const Extras& extras,
                         const std::array<std::uint8_t, kBranches>& extra_flags,
                         Branches& branches, int reach) {
  for (int b = 0; b < kBranches; ++b) {
    if (!extras.ok[b] || branches.known(plan, extras.q[b])) continue;
    for (int k = 0; k < reach; ++k) {
      const int slot = b ^ k;
      if (!branches.ok[slot]) {
        branches.q[slot] = extras.q[b];
        branches.ok[slot] = true;
        branches.flags[slot] = extra_flags[b];
        branches.errors[slot] = check(plan.chain, branches.q[slot].data(), T);
        break;
      }
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
  for (int a = 0; a < kBranches; ++a) {
    if (!branches.ok[a]) continue;
    for (int b = a + 1; b < kBranches; ++b) {
      if (!branches.ok[b] || !plan.same(branches.q[a], branches.q[b], 2.0 * kMergeAngle)) {
        continue;
      }
      branches.ok[b] = false;
      Joints twin;
      if (!(member[a] || member[b]) &&
          find_twin(plan.chain, T, branches.q[a], tolerance, 2.0 * kMergeAngle, branches, twin)) {
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
    if (branches.ok[b] || !finite(regular.q[b]) ||
        !(regular.valid[b] || (regular.near[b] & kClamped) != 0)) {
      continue;
    }
    Joints start = regular.q[b];
    for (int attempt = 0; attempt < kCorrections; ++attempt) {
      const Frame corrected = corrected_target(plan.ideal, plan.chain, start, T_dh);
      plan.solve_family(corrected, seed, 0, clamp, candidates);
      if (!finite(candidates.q[b])) break;
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
