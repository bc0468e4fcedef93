// The direct path (direct.hpp) for kLanes poses of a batch at once, one pose per lane.
//
// The same steps as direct_branches, on the lane type: the poses' targets (one at a time), the
// family's closed form (plan.solve_family on lanes), each branch's candidate wrapped and checked
// by the exact chain's FK, the merge test and the flags. Every lane has the bits direct_branches
// gives its pose; a lane it declines (a candidate near a singularity, one that does not verify as
// computed, two branches with one solution) or rejects (the pose's status) is left to the caller,
// which runs that pose through the pipeline (tests/test_ik_batch.py compares them).
#pragma once

#include <array>
#include <cmath>
#include <new>

#include "dhkin/direct.hpp"
#include "dhkin/plan.hpp"
#include "dhkin/simd.hpp"

namespace dhkin {

// kLanes poses: their targets and seeds by lane (a block of fewer poses repeats its last).
struct PoseBlock {
  int count = 0;                            // poses in the block
  std::array<const double*, kLanes> T{};    // 4 x 4 row-major, base_link -> TCP
  std::array<const double*, kLanes> seed{};  // kDof values
};

// What the direct path gives a block: per lane, whether it answered and the pose's status and
// projection; per branch (lanes: poses), the verified solution, its errors and flags.
struct BlockAnswer {
  std::array<bool, kLanes> answered{};  // the direct path answered this pose (usable, regular)
  std::array<int, kLanes> status{};     // a PoseStatus (kUsable or why not)
  std::array<double, kLanes> projection{};
  std::array<JointsT<Lanes>, kBranches> q{};
  std::array<Mask, kBranches> ok{};
  std::array<LaneBits, kBranches> flags{};
  std::array<PoseErrorT<Lanes>, kBranches> errors{};
  std::array<Lanes, kWhySize> why{};
  JointsT<Lanes> seed{};
  FrameT<Lanes> T_at;  // the targets of the plan's chains (errors are measured there)
};

namespace block {

// pose_and_seed_status (direct.hpp) of kLanes poses at once, from their 16 entries (4 x 4
// row-major) and seeds by lane: pose_status's tests on the same values in the same order, so
// the same status in each lane.
DHKIN_INLINE LaneBits pose_and_seed_status(const Lanes (&T)[16], const JointsT<Lanes>& seed) {
  Mask finite = every_lane<Lanes>(true);
  for (int k = 0; k < 16; ++k) finite = finite && abs(T[k]) < INFINITY;
  const Lanes bottom = max(max(max(abs(T[12]), abs(T[13])), abs(T[14])), abs(T[15] - 1.0));
  Lanes worst(0.0);  // orthonormality()
  for (int a = 0; a < 3; ++a) {
    for (int b = a; b < 3; ++b) {
      const Lanes d = T[4 * a] * T[4 * b] + T[4 * a + 1] * T[4 * b + 1] +
                      T[4 * a + 2] * T[4 * b + 2];
      worst = max(worst, abs(d - (a == b ? 1.0 : 0.0)));
    }
  }
  const Lanes determinant = T[0] * (T[5] * T[10] - T[6] * T[9]) -
                            T[1] * (T[4] * T[10] - T[6] * T[8]) +
                            T[2] * (T[4] * T[9] - T[5] * T[8]);
  Mask seed_finite = every_lane<Lanes>(true);
  for (int j = 0; j < kDof; ++j) seed_finite = seed_finite && abs(seed[j]) < INFINITY;
  LaneBits status(kUsable);
  status = select(!seed_finite, LaneBits(kBadSeed), status);
  status = select(!(worst <= kOrthonormalityGate) || determinant <= 0.0, LaneBits(kNotRotation),
                  status);
  status = select(!(bottom <= kBottomRowTolerance), LaneBits(kBottomRow), status);
  return select(!finite, LaneBits(kNotFinite), status);
}

// Whether a and b hold the same bits in every lane.
DHKIN_INLINE bool same_bits(const Lanes& a, const Lanes& b) { return !any(bits_of(a) != bits_of(b)); }

// Bound on wrap's rounding (angles.hpp) of a difference of two values within [-pi, pi]: it
// takes off one whole turn whose head is exact, so its result is within ~1e-15 rad of a - b -+ 2pi;
// this bound is a thousand times that.
constexpr double kWrapRounding = 1e-12;

// Lanes where joint values a and b surely differ by more than `distance` (mod 2pi for a revolute
// joint), by a test without wrap: |a - b| beyond distance + kWrapRounding and, for revolute values
// within [-pi, pi], short of 2pi - distance - kWrapRounding. Plan::same finds these lanes apart
// too; the others it decides.
DHKIN_INLINE Mask surely_apart(const Lanes& a, const Lanes& b, bool revolute, double distance) {
  const Lanes d = abs(a - b);
  const Mask beyond = d > distance + kWrapRounding;
  if (!revolute) return beyond;
  return beyond && d < kTwoPi - distance - kWrapRounding && abs(a) <= kPi && abs(b) <= kPi;
}

}  // namespace block

// check() of each branch's candidate q[b] (lanes: poses) against `target`, for the branches
// `wanted` in some lane: every joint's sine and cosine first (independent work for the
// processor to overlap), then each branch's chain. Branches share joint values (the two wrist
// branches of a spherical wrist share q1-q3, the four branches of one shoulder q1): a joint value
// with the bits of an earlier branch's, in every lane, takes that branch's sine and cosine, and a
// branch whose first k joint values are an earlier branch's starts from that branch's frame after
// k joints; the frames advance joint by joint for all branches together. A joint variable with
// the bits of an angle whose sine and cosine the closed form computed (`known`, may be null), in
// every lane, takes those. The same operations on the same values as check() per branch, so the
// same bits.
inline void check_branches(const Chain& chain, const std::array<JointsT<Lanes>, kBranches>& q,
                           const std::array<bool, kBranches>& wanted, const FrameT<Lanes>& target,
                           const KnownTurnsT<Lanes>* known,
                           std::array<PoseErrorT<Lanes>, kBranches>& errors) {
  using block::same_bits;
  const ChainShape shape(chain);
  const int n = chain.dof();
  std::array<JointMotions<Lanes>, kBranches> motions;
  // Branches share joint values within a shoulder group, an elbow pair and a wrist pair (branch
  // index 4 shoulder + 2 elbow + wrist): the values of branch b are looked for among the wanted
  // earlier branches whose index differs from b's in one bit (any branch with the same bits
  // gives the same values; one not looked at is computed again).
  const auto neighbours = [&](int b, auto&& fn) {
    for (int m = 1; m < kBranches; m <<= 1) {
      const int a = b ^ m;
      if (a < b && wanted[a] && fn(a)) return;
    }
  };
  // per branch: the neighbour with the longest run of equal leading joint values (source, -1 for
  // none) and that run's length (shared), among those whose own frame starts within the run
  // (it then exists when the branch starts from it).
  int source[kBranches], shared[kBranches];
  for (int b = 0; b < kBranches; ++b) {
    source[b] = -1, shared[b] = 0;
    if (!wanted[b]) continue;
    neighbours(b, [&](int a) {
      int k = 0;
      while (k < n && same_bits(q[a][k], q[b][k])) ++k;
      if (k > shared[b] && shared[a] <= k) shared[b] = k, source[b] = a;
      return false;
    });
    for (int j = 0; j < n; ++j) {
      int from = -1;
      neighbours(b, [&](int a) {
        if (same_bits(q[a][j], q[b][j])) from = a;
        return from >= 0;
      });
      if (from < 0) {
        const ChainJoint& joint = chain.joints[j];
        const Lanes variable = joint.motion(q[b][j]);
        if (known != nullptr && joint.revolute && known->known[b][j] &&
            same_bits(variable, known->angle[b][j])) {  // joint_motion's outputs, as computed
          motions[b].variable[j] = variable;
          motions[b].turn[j] = known->turn[b][j];
        } else {
          joint_motion(chain, j, q[b][j], motions[b]);
        }
      } else {  // joint_motion's outputs: the variable, and the turn of a revolute joint
        motions[b].variable[j] = motions[from].variable[j];
        if (chain.joints[j].revolute) motions[b].turn[j] = motions[from].turn[j];
      }
    }
  }
  // joint by joint, every branch's frame (independent work for the processor to overlap): a
  // branch starts as a copy of its source's frame once that has `shared` joints (the source
  // started before: see above)
  alignas(64) unsigned char storage[kBranches][sizeof(FrameT<Lanes>)];
  FrameT<Lanes>* state[kBranches] = {};
  for (int j = 0; j <= n; ++j) {
    for (int b = 0; b < kBranches; ++b) {
      if (!wanted[b]) continue;
      if (source[b] < 0 && j == 0) {
        state[b] = new (storage[b]) FrameT<Lanes>(broadcast<Lanes>(chain.joints[0].before));
      } else if (source[b] >= 0 && j == shared[b]) {
        state[b] = new (storage[b]) FrameT<Lanes>(*state[source[b]]);
      }
    }
    if (j == n) break;
    for (int b = 0; b < kBranches; ++b) {
      if (state[b] != nullptr) chain_step(chain, shape, motions[b], j, *state[b]);
    }
  }
  for (int b = 0; b < kBranches; ++b) {
    if (!wanted[b]) continue;
    times_constant(*state[b], chain.tail, shape.tail);
    errors[b] = pose_error(*state[b], target);
  }
}

// Steps 1-3 of the direct path for a block of poses of an exact-family table (plan.refine
// false; the caller checks). `found` and `known`: room for the closed form's candidates and
// sines and cosines (the caller keeps them from block to block; every value read is written
// first, and a stale known pair is still a true one).
inline void direct_block(const Plan& plan, const TargetFrames& frames, const PoseBlock& poses,
                         double tolerance, BlockAnswer& out, CandidatesT<Lanes>& found,
                         KnownTurnsT<Lanes>& known) {
  tolerance = plan.verification_tolerance(tolerance);
  // the poses' 16 entries and the seeds by lane, then pose_and_seed_status in lanes
  alignas(64) double entries[16][kLanes];
  alignas(64) double seeds[kDof][kLanes];
  for (int l = 0; l < kLanes; ++l) {
    const int i = l < poses.count ? l : poses.count - 1;
    for (int k = 0; k < 16; ++k) entries[k][l] = poses.T[i][k];
    for (int j = 0; j < kDof; ++j) seeds[j][l] = poses.seed[i][j];
  }
  Lanes T[16];
  for (int k = 0; k < 16; ++k) T[k] = Lanes::load(entries[k]);
  JointsT<Lanes> seed;
  for (int j = 0; j < kDof; ++j) seed[j] = Lanes::load(seeds[j]);
  const LaneBits status = block::pose_and_seed_status(T, seed);
  Mask declined = status != kUsable;  // rejected: the caller reports it
  for (int l = 0; l < kLanes; ++l) out.status[l] = lane(status, l);
  // the identity and zero seeds where the pose is rejected
  FrameT<Lanes> raw;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) raw.R[r][c] = select(declined, Lanes(r == c ? 1.0 : 0.0), T[4 * r + c]);
    raw.p[r] = select(declined, Lanes(0.0), T[4 * r + 3]);
  }
  for (int j = 0; j < kDof; ++j) out.seed[j] = select(declined, Lanes(0.0), seed[j]);
  // the rotations projected, every lane at once (projected_pose's, lane by lane)
  Lanes moved;
  const FrameT<Lanes> projected = projected_frame<Lanes>(raw, !declined, moved);
  for (int l = 0; l < kLanes; ++l) out.projection[l] = lane(declined, l) ? 0.0 : lane(moved, l);
  FrameT<Lanes> T_dh;
  targets_of(frames, projected, T_dh, out.T_at);
  found.known = &known;  // the sines and cosines check_branches may take
  plan.solve_family(T_dh, out.seed, 0, plan.clamp(tolerance), found);
  out.why = found.why;
  for (int b = 0; b < kBranches; ++b) declined = declined || (found.near[b] & kFree) != 0;
  std::array<bool, kBranches> wanted{};
  for (int b = 0; b < kBranches; ++b) {
    out.ok[b] = found.valid[b] && !declined;
    wanted[b] = any(out.ok[b]);
    // revolute values wrapped; lanes without a candidate are checked on zeros (finite values;
    // their errors are not used)
    for (int j = 0; j < kDof; ++j) {
      Lanes value = found.q[b][j];
      if (plan.revolute(j)) value = wrap(value);
      if (wanted[b]) value = select(abs(value) < INFINITY, value, Lanes(0.0));
      out.q[b][j] = value;
    }
  }
  check_branches(plan.chain, out.q, wanted, out.T_at, &known, out.errors);
  for (int b = 0; b < kBranches; ++b) {
    declined = declined || (out.ok[b] && !out.errors[b].within(tolerance));
  }
  // one solution from two branches: the pipeline merges them (plan.same, for the lanes a cheaper
  // test does not find apart)
  // (the joints in any order: the test is their conjunction. First the joint the two branches'
  // highest differing index bit solves for, where they lie apart in nearly every lane: q1 for
  // the shoulder, q3 for the elbow, q5 for the wrist)
  const double merge_distance = 2.0 * kMergeAngle;
  for (int a = 0; a < kBranches; ++a) {
    for (int b = a + 1; b < kBranches; ++b) {
      Mask maybe = out.ok[a] && out.ok[b] && !declined;
      const int first = kSplitJoint[a ^ b];
      for (int k = 0; k < kDof && any(maybe); ++k) {
        const int j = joint_from(first, k);
        maybe = maybe && !block::surely_apart(out.q[a][j], out.q[b][j], plan.revolute(j),
                                              merge_distance);
      }
      if (any(maybe)) {
        declined = declined || (maybe && plan.same(out.q[a], out.q[b], merge_distance));
      }
    }
  }
  for (int b = 0; b < kBranches; ++b) {
    out.ok[b] = out.ok[b] && !declined;
    // the flags of the lanes with a solution (put_nearest reads no others)
    out.flags[b] = (found.flags[b] & kShoulder) | plan.value_flags(out.q[b], out.ok[b]);
  }
  for (int l = 0; l < kLanes; ++l) {
    out.answered[l] = !lane(declined, l);
  }
}

}  // namespace dhkin
