// A refined table's roots beyond its eight branch slots.
//
// A refined table (corrections, rounded constants) answers one root per branch of the ideal
// model, each refined on the exact chain from the ideal model's candidate. Near the ideal model's
// singular sets the exact chain can have more isolated roots than the eight slots hold (two roots
// where the ideal model has one double root, or a family of solutions broken into several
// isolated roots), and the slots then miss some (docs/ik_core.md, "Roots the eight slots miss":
// 10-12 roots at q5 = 0 poses of a calibrated UR5e, none missed by the general 6R solver).
//
// Where that can happen, the pose is solved once more without the branches: by the exact chain's
// own roots (Plan::exact_roots, the general 6R solver), and every isolated root that no slot holds
// is added beyond the slots. It can happen where
//   * the pose left the refined direct path (a candidate within the seed band of a singular set,
//     a long shot the exact chain may reach, a candidate Newton did not settle as near a regular
//     root, two branches on one solution), or
//   * refinement moved some branch farther than the band angle from its ideal candidate: the
//     exact chain's constants lie within that band of the ideal model's, so a branch that moved
//     farther sits where the two models' roots need not correspond one to one.
// Both are decided by the pose alone, never by the seed, so the roots returned do not depend on
// the seed (the seed picks copies and the member of a singular family, as before).
//
// A root the exact roots flag singular (sigma within their singular band) is not added: it stands
// for a family of solutions, whose member the slots already hold (the seed's).
#pragma once

#include <array>
#include <cmath>
#include <vector>

#include "dhkin/direct.hpp"
#include "dhkin/exact_roots.hpp"
#include "dhkin/plan.hpp"

namespace dhkin {

// The ideal model's branch of joint values q: the branch whose candidate at the ideal model's own
// pose of q is q (the nearest, mod 2pi), and that candidate's shoulder flag (a property of the
// pose). `frames`: where the plan's chains end (at the TCP point when frames.at_tcp).
struct IdealBranch {
  int branch = 0;
  std::uint8_t shoulder = 0;
};

inline IdealBranch ideal_branch_of(const Plan& plan, const TargetFrames& frames, const Joints& q,
                                   double clamp) {
  Frame T_ideal = fk<double>(plan.ideal, q.data());
  if (frames.at_tcp) {  // the plan's ideal chain ends at the TCP point: back to DH frame n
    const Vec3& p = frames.tcp_point;
    T_ideal = moved_to(T_ideal, Vec3{-p.x, -p.y, -p.z});
  }
  Candidates found;
  plan.solve_family(T_ideal, q, 0, clamp, found);
  // where the ideal model is singular at its pose of q (q5 = 0 of a wrist), the free joint is
  // q's own: the seeded candidates (the family's member through q) stand for those branches
  int wanted = 0;
  for (int b = 0; b < kBranches; ++b) wanted |= found.near[b] & kFree;
  if (wanted != 0) {
    Candidates seeded;
    plan.solve_family(T_ideal, q, wanted, clamp, seeded);
    for (int b = 0; b < kBranches; ++b) {
      if (seeded.valid[b] && (seeded.near[b] & wanted) != 0) {
        found.q[b] = seeded.q[b];
        found.valid[b] = true;
        found.flags[b] = seeded.flags[b];
      }
    }
  }
  // a valid candidate first; among invalid ones (clamped at the reach) only when none is
  std::array<double, kBranches> rank;
  double nearest = INFINITY;
  for (int b = 0; b < kBranches; ++b) {
    double distance = 0.0;
    for (int j = 0; j < kDof; ++j) {
      const double d = plan.revolute(j) ? wrap(found.q[b][j] - q[j]) : found.q[b][j] - q[j];
      distance = std::max(distance, std::abs(d));
    }
    rank[b] = found.valid[b] ? distance : kTwoPi * 4.0 + distance;
    nearest = std::min(nearest, rank[b]);
  }
  // candidates within twice the merge angle of the nearest are one solution (the two wrist
  // branches of a singular wrist): the first branch stands for them, as in BranchSolutions
  IdealBranch out;
  for (int b = 0; b < kBranches; ++b) {
    if (rank[b] <= nearest + 2.0 * kMergeAngle) {
      out.branch = b;
      out.shoulder = found.flags[b] & kShoulder;
      break;
    }
  }
  return out;
}

// Adds to branches.extra every isolated root of the exact chain at the pose that no slot holds
// (the module comment): T_dh and T_at as in the pipeline, `tolerance` the verification tolerance.
inline void add_exact_roots(const Plan& plan, const TargetFrames& frames, const PoseTargets& targets,
                            double tolerance, double clamp, Branches& branches) {
  std::vector<ExactRoot> roots;
  plan.exact_roots->find(targets.T_dh, tolerance, roots);
  const double band = plan.exact_roots->singular_band(tolerance);
  ExtraRoots& extra = branches.extra;
  for (const ExactRoot& root : roots) {
    if (root.sigma <= band || branches.known(plan, root.q)) continue;
    const PoseError error = check(plan.chain, root.q.data(), targets.T_at);
    // (a full ExtraRoots cannot meet another root: the slots and the extras hold distinct
    // isolated roots, at most 16 in all)
    if (!error.within(tolerance) || extra.count == ExtraRoots::kCapacity) continue;
    const IdealBranch ideal = ideal_branch_of(plan, frames, root.q, clamp);
    const int k = extra.count++;
    extra.q[k] = root.q;
    extra.branch[k] = ideal.branch;
    extra.flags[k] = static_cast<std::uint8_t>(ideal.shoulder | plan.value_flags(root.q));
    extra.errors[k] = error;
  }
}

}  // namespace dhkin
