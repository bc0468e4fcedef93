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

#include "dhkin/chain.hpp"

namespace dhkin {

constexpr int kBranches = 8;
// Numbers an empty answer is explained with (see each family's `explain` in Python).
constexpr int kWhySize = 6;

struct Candidates {
  std::array<Joints, kBranches> q{};
  std::array<bool, kBranches> valid{};
  std::array<std::uint8_t, kBranches> flags{};
  std::array<std::uint8_t, kBranches> near{};
  std::array<double, kWhySize> why{};

  // Candidates with any non-finite joint value are not valid.
  void drop_non_finite() {
    for (int b = 0; b < kBranches; ++b) {
      for (int j = 0; j < kDof; ++j) {
        if (!std::isfinite(q[b][j])) valid[b] = false;
      }
    }
  }
};

// How a family's closed form is asked: `use_seed` (singularity bits) selects which free joints
// come from the seed; within `seed_angle` (|sin| of the wrist angle) and `seed_length` (m) of a
// singularity a joint counts as free; reach conditions violated by at most `clamp` (m) are
// clamped onto their boundary. With `only_branch` >= 0 the seeded family member of that branch
// alone is given, the one at the seed's free joint itself, not the nearest one (the others' seeded
// candidates are left invalid): the valley scan walks one branch's family by its free joint.
struct FamilyRequest {
  const Joints* seed;
  int use_seed;
  double seed_angle;
  double seed_length;
  double clamp;
  int only_branch = -1;
};

inline bool finite(const Joints& q) {
  for (double v : q) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

}  // namespace dhkin
