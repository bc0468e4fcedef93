// What a family's closed form gives for one target: eight branch candidates with their validity,
// singularity flags and `near` bits, and the numbers an empty answer is explained with.
//
// Branch index 4 * shoulder + 2 * elbow + wrist in every family. `near` has the bits of the
// singularities where a joint is free and within the seed band (the pipeline then tries a seeded
// candidate), and kClamped when the candidate was clamped onto a reach boundary.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

#include "dhkin/angles.hpp"
#include "dhkin/chain.hpp"
#include "dhkin/simd.hpp"

namespace dhkin {

constexpr int kBranches = 8;
// The joint where two branches whose indices differ by the bits d (1..7) part first: that of d's
// highest bit (4 shoulder: q1, 2 elbow: q3, 1 wrist: q5). Tests of "the same solution" look
// there first (their answer does not depend on the order of the joints).
constexpr int kSplitJoint[kBranches] = {0, 4, 2, 2, 0, 0, 0, 0};
// The k-th joint (k = 0..kDof-1) of the order that tests `first` first, then the others in order.
constexpr int joint_from(int first, int k) { return k == 0 ? first : (k <= first ? k - 1 : k); }
// Numbers an empty answer is explained with (see each family's `explain` in Python).
constexpr int kWhySize = 6;

// Joint values of one arm per lane.
template <class V>
using JointsT = std::array<V, kDof>;

// Sines and cosines a closed form computed of its candidates' joint values, for the check of the
// candidates (block.hpp) to take instead of computing them again: wherever known[b][j],
// turn[b][j] = sincos(angle[b][j]) bit for bit in every lane. The check takes a pair only where
// its own joint variable has the bits of `angle` in every lane (a value the closed form patched
// lane by lane afterwards, or wrapped, is computed again), so a stale pair is never wrong.
template <class V>
struct KnownTurnsT {
  std::array<std::array<V, kDof>, kBranches> angle;
  std::array<std::array<SinCosT<V>, kDof>, kBranches> turn;
  std::array<std::array<bool, kDof>, kBranches> known{};

  // sincos(sign * x) from t = sincos(x), for sign +-1 (negated: the bits of sincos(-x)).
  static SinCosT<V> signed_turn(double sign, const SinCosT<V>& t) {
    return sign > 0.0 ? t : negated(t);
  }
  // Branch b's joint j has value `value` = sign * x and t = sincos(x) (sign +-1).
  void put(int b, int j, double sign, V x, const SinCosT<V>& t) {
    if (sign != 1.0 && sign != -1.0) return;
    angle[b][j] = sign * x;
    turn[b][j] = signed_turn(sign, t);
    known[b][j] = true;
  }
};

// The candidates of one target (V = double) or of kLanes targets (V = Lanes, one per lane).
template <class V>
struct CandidatesT {
  std::array<JointsT<V>, kBranches> q{};
  std::array<MaskOf<V>, kBranches> valid{};
  std::array<BitsOf<V>, kBranches> flags{};
  std::array<BitsOf<V>, kBranches> near{};
  std::array<V, kWhySize> why{};
  // Where the closed form records the sines and cosines it computed (none when null).
  KnownTurnsT<V>* known = nullptr;

  // Candidates with any non-finite joint value are not valid.
  void drop_non_finite() {
    for (int b = 0; b < kBranches; ++b) {
      for (int j = 0; j < kDof; ++j) valid[b] = valid[b] && abs(q[b][j]) < INFINITY;
    }
  }
};
using Candidates = CandidatesT<double>;

// How a family's closed form is asked: `use_seed` (singularity bits) selects which free joints
// come from the seed; within `seed_angle` (|sin| of the wrist angle) and `seed_length` (m) of a
// singularity a joint counts as free; reach conditions violated by at most `clamp` (m) are
// clamped onto their boundary. With `only_branch` >= 0 the seeded family member of that branch
// alone is searched (the others' seeded candidates are left invalid); with `at_seed` it is the
// member at the seed's free joint itself, not the one nearest the seed (the valley scan and the
// limit search walk a family by its free joint).
template <class V>
struct FamilyRequestT {
  const JointsT<V>* seed;
  int use_seed;
  double seed_angle;
  double seed_length;
  double clamp;
  int only_branch = -1;
  bool at_seed = false;
};
using FamilyRequest = FamilyRequestT<double>;

// The request of lane l (its seed copied into `seed`).
template <class V>
inline FamilyRequest lane(const FamilyRequestT<V>& request, int l, Joints& seed) {
  for (int j = 0; j < kDof; ++j) seed[j] = lane((*request.seed)[j], l);
  return {&seed,         request.use_seed,    request.seed_angle, request.seed_length,
          request.clamp, request.only_branch, request.at_seed};
}

inline bool finite(const Joints& q) {
  for (double v : q) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

}  // namespace dhkin
