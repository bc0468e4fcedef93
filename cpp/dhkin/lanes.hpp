// The exact chain's pose errors of the eight branch candidates of one pose at once, one branch
// per lane: chain.hpp's fk and pose_error on the lane type (simd.hpp), so each lane has the bits
// of the scalar check() (tests compare them).
#pragma once

#include <array>

#include "dhkin/chain.hpp"
#include "dhkin/family.hpp"
#include "dhkin/simd.hpp"

namespace dhkin {

static_assert(kLanes == kBranches, "one lane per branch");

// The errors of T(q[b]) against `target` for the eight joint vectors q.
inline std::array<PoseError, kBranches> check_lanes(const Chain& chain,
                                                    const std::array<Joints, kBranches>& q,
                                                    const Frame& target) {
  Lanes values[kDof];
  for (int j = 0; j < kDof; ++j) values[j] = Lanes::gather(&q[0][j], kDof);
  const PoseErrorT<Lanes> errors = check(chain, values, target);
  std::array<PoseError, kBranches> out;
  for (int b = 0; b < kBranches; ++b) out[b] = lane(errors, b);
  return out;
}

}  // namespace dhkin
