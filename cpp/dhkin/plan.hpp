// The constants of one robot's closed-form solver (its plan), and the small helpers every step of
// the pipeline uses.
//
// dhkin.ik.plan builds a plan from a table's family fit: the family's geometry of the ideal model,
// the exact chain (corrections included) and the ideal model's chain, the path of models between
// them (for continuation), the joint limits and the bands.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "dhkin/bands.hpp"
#include "dhkin/chain.hpp"
#include "dhkin/copies.hpp"
#include "dhkin/exact_roots.hpp"
#include "dhkin/family.hpp"
#include "dhkin/offset.hpp"
#include "dhkin/spherical.hpp"

namespace dhkin {

// Family ids (dhkin.ik.plan's FAMILY_IDS).
enum class Family : int { spherical_wrist = 1, stanford = 2, offset_wrist = 3 };

// One constant frame's step on the path from the ideal model to the exact chain:
// P(exact) = P(ideal) [Rot(rotation), translation].
struct ModelStep {
  Vec3 rotation;     // rotation vector
  Vec3 translation;
};

// A 2pi shift changes FK by rounding only: sin/cos of q + 2pi k carry an error of ~|q + 2pi k|
// ulp, ~1.4e-15 rad per joint for |q| <= 4pi, so at most ~2e-14 (m per m of arm, rad) for six
// joints. Copies of a branch whose error is within this margin of the tolerance (500 times that
// bound) are verified themselves.
constexpr double kCopyMargin = 1e-11;
// Two double-precision evaluations of one chain's FK (ours, Pinocchio's on the URDF) differ by
// rounding: at most 1.4e-15 (m per m of arm, rad) on the built-in tables. Solutions are verified
// at the tolerance less kFkRounding x lever (64 ulp per metre, ~10x that bound; at most half the
// tolerance), so that a solution verified on our FK is also within the tolerance on the oracle's.
constexpr double kFkRounding = 64.0 * 2.220446049250313e-16;
// Chain evaluations allowed to the refinement of a long shot: on a refined table, a branch that
// the ideal model cannot reach even within the clamp band is still tried from its clamped
// candidate (near a wrist singularity the exact chain can reach where the ideal model is
// centimetres out), with this bounded effort (a converging refinement takes 4-10).
constexpr int kLongShotBudget = 24;
// Chain evaluations allowed to polish a candidate of an exact table that failed verification (a
// pose a hair outside the reach, or rounding at a singularity): Newton from it, verified.
constexpr int kPolishBudget = 12;

struct Plan {
  Family family = Family::spherical_wrist;
  bool refine = false;        // the exact chain differs from the ideal model
  double seed_angle = 0.0;    // wrist band: |sin| at or below which the seed's q4 / q6 is tried
  double seed_length = 0.0;   // m: distance at or below which the seed's q1 / q2 is tried
  double deviation = 0.0;     // m: how far the exact chain's poses are from the ideal model's
  double lever = 1.0;         // m: max(1, table scale): how far a point moves per radian
  // rad: the family band's angle on a refined table (0 on an exact one): the exact chain's
  // constants lie within it of the ideal model's, so a root refined from an ideal candidate that
  // moved farther than this sits where the two models' roots need not correspond one to one
  double band_angle = 0.0;
  int free_wrist = 3, free_elbow = 1, free_shoulder = 0;  // the free joint of each singularity
  SphericalGeometry spherical;  // the spherical-wrist and Stanford families
  OffsetGeometry offset;        // the offset-wrist family
  Chain chain;                  // the exact chain
  Chain ideal;                  // the ideal model's chain
  std::vector<ModelStep> path;  // one step per constant frame (dof + 1)
  std::array<JointLimit, kDof> limits{};
  // a refined table's exact chain solved without the families' branches (extra_roots.hpp), or
  // none (exact tables, a prismatic joint); owned by the solver that holds the plan
  const ExactRoots* exact_roots = nullptr;

  bool revolute(int j) const { return chain.joints[j].revolute; }

  // The plan whose exact and ideal chains (and the path between them) end at `point`, the TCP's
  // origin in DH frame n: errors are then the TCP's.
  Plan at_point(const Vec3& point) const {
    Plan out = *this;
    out.chain = extended_to(chain, point);
    out.ideal = extended_to(ideal, point);
    // Tr(-point) [Rot(w), v] Tr(point) = [Rot(w), v + Rot(w) point - point]
    ModelStep& last = out.path.back();
    const Vec3 turned = rotation_vector(last.rotation).rotate(point);
    last.translation = last.translation + turned - point;
    return out;
  }

  // The tolerance the pipeline verifies at: `tolerance` less the FK rounding margin.
  double verification_tolerance(double tolerance) const {
    return std::max(tolerance - kFkRounding * lever, 0.5 * tolerance);
  }

  // The reach band: reach conditions violated by at most this (m) are clamped, not rejected.
  double clamp(double tolerance) const { return tolerance * (1.0 + lever) + deviation; }

  // The family's closed form for target T (DH frame 0 -> n); per lane for V = Lanes.
  // `only_branch` and `at_seed`: which seeded member is searched, and how (FamilyRequest).
  template <class V>
  void solve_family(const FrameT<V>& T, const JointsT<V>& seed, int use_seed, double clamp,
                    CandidatesT<V>& out, int only_branch = -1, bool at_seed = false) const {
    const FamilyRequestT<V> request{&seed,       use_seed,    seed_angle, seed_length,
                                    clamp,       only_branch, at_seed};
    switch (family) {
      case Family::spherical_wrist: solve_spherical_wrist(spherical, T, request, out); break;
      case Family::stanford: solve_stanford(spherical, T, request, out); break;
      case Family::offset_wrist: solve_offset_wrist(offset, T, request, out); break;
    }
  }

  // The free joints of the singularity bits.
  JointMask free_joints(int bits) const {
    JointMask fixed{};
    if (bits & kWrist) fixed[free_wrist] = true;
    if (bits & kElbow) fixed[free_elbow] = true;
    if (bits & kShoulder) fixed[free_shoulder] = true;
    return fixed;
  }

  // |sin| of the wrist angle at joint values q (0 at the wrist singularity of the ideal model).
  double wrist_sine(const Joints& q) const {
    if (family == Family::offset_wrist) return std::abs(sincos(q[4] - offset.psi).s);
    const SphericalGeometry& g = spherical;
    return std::abs(sincos(g.wrist_directions[1] * q[4] + g.tilt).s);
  }

  // The kWrist and kElbow flags of joint values q: each singularity's measure (|sin| of the wrist
  // angle, of the elbow angle; the slide's distance from its merge over the scale) at most
  // kFlagBand, from q itself (family geometry of the ideal model). Only the lanes `wanted` are
  // measured (the others get no flags): the batch's lanes without a solution hold zeros or NaN,
  // which sent small_sine to its sine polynomial or to the C library's sine.
  template <class V>
  BitsOf<V> value_flags(const JointsT<V>& q, MaskOf<V> wanted = every_lane<V>(true)) const {
    if (family == Family::offset_wrist) {
      return bits_if(small_sine(q[4] - offset.psi, kFlagBand, wanted), kWrist) |
             bits_if(small_sine(q[2] - offset.elbow_base, kFlagBand, wanted), kElbow);
    }
    const SphericalGeometry& g = spherical;
    const BitsOf<V> wrist =
        bits_if(small_sine(g.wrist_directions[1] * q[4] + g.tilt, kFlagBand, wanted), kWrist);
    if (family == Family::spherical_wrist) {
      return wrist |
             bits_if(small_sine(g.signs[2] * q[2] + g.bend_at_zero, kFlagBand, wanted), kElbow);
    }
    return wrist | bits_if(wanted && abs(g.signs[2] * q[2] + g.slide_along) <= kFlagBand * g.scale,
                           kElbow);
  }

  // Revolute values wrapped to (-pi, pi], prismatic ones kept.
  template <class V>
  void wrap_revolute(JointsT<V>& q) const {
    for (int j = 0; j < kDof; ++j) {
      if (revolute(j)) q[j] = wrap(q[j]);
    }
  }

  // Squared joint distance from the seed, revolute differences wrapped.
  double seed_distance(const Joints& q, const Joints& seed) const {
    double total = 0.0;
    for (int j = 0; j < kDof; ++j) {
      double d = q[j] - seed[j];
      if (revolute(j)) d = wrap(d);
      total += d * d;
    }
    return total;
  }

  // Whether a and b differ by at most `distance` on every joint (mod 2pi).
  template <class V>
  MaskOf<V> same(const JointsT<V>& a, const JointsT<V>& b, double distance) const {
    MaskOf<V> close = every_lane<V>(true);
    for (int j = 0; j < kDof && any(close); ++j) {
      V d = a[j] - b[j];
      if (revolute(j)) d = wrap(d);
      close = close && !(abs(d) > distance);
    }
    return close;
  }

  // Whether some 2pi copy of every joint value lies within the limits (+- slack).
  bool in_limits(const Joints& q, double slack) const {
    for (int j = 0; j < kDof; ++j) {
      if (turn_range(limits[j], revolute(j), q[j], slack).count == 0) return false;
    }
    return true;
  }
};

// Roots of a refined table's exact chain beyond the branch slots (extra_roots.hpp): near the
// ideal model's singular sets the exact chain can have more isolated roots than the eight slots
// hold. Each keeps the branch whose configuration the ideal model gives its joint values.
struct ExtraRoots {
  // A six-revolute pose has at most 16 isolated roots (the degree of its polynomial), so at most
  // 16 lie beyond the slots.
  static constexpr int kCapacity = 16;
  int count = 0;
  std::array<Joints, kCapacity> q;
  std::array<int, kCapacity> branch;
  std::array<std::uint8_t, kCapacity> flags;
  std::array<PoseError, kCapacity> errors;
};

// The verified principal solution of each branch of one pose (steps 1-3 of the pipeline), and
// on a refined table the roots beyond the slots.
struct Branches {
  std::array<Joints, kBranches> q{};
  std::array<bool, kBranches> ok{};
  std::array<std::uint8_t, kBranches> flags{};
  std::array<PoseError, kBranches> errors{};
  ExtraRoots extra;

  // Whether `candidate` equals an ok branch's solution or an extra root (2 kMergeAngle, mod 2pi).
  bool known(const Plan& plan, const Joints& candidate) const {
    for (int b = 0; b < kBranches; ++b) {
      if (ok[b] && plan.same(candidate, q[b], 2.0 * kMergeAngle)) return true;
    }
    for (int k = 0; k < extra.count; ++k) {
      if (plan.same(candidate, extra.q[k], 2.0 * kMergeAngle)) return true;
    }
    return false;
  }
};

// What happened to one pose, beside its solutions (dhkin.ik.solver reads these).
struct PoseInfo {
  int status = 0;            // 0, or a PoseStatus
  double projection = 0.0;   // Frobenius norm of the change of the input's rotation block
  int candidates = 0;        // branches with a geometric solution
  int verified = 0;          // branches whose solution verified (after merging)
  int dropped = 0;           // branches with a candidate none of which verified
  double best_position = INFINITY, best_rotation = INFINITY;  // closest dropped candidate
  // the refined direct path moved some branch farther than the band angle from its ideal
  // candidate (Plan::band_angle): the exact chain may have roots the slots do not hold
  bool beyond_band = false;
  std::array<double, kWhySize> why{};  // numbers an empty answer is explained with (NaN: unset)
};

}  // namespace dhkin
