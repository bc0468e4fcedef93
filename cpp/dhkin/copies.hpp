// Joint values: the 2pi-shifted copies inside the joint limits.
//
// A revolute joint's value q and q + 2pi k reach the same pose; the limits decide which copies
// exist. A value that lies within `slack` outside a limit counts as on it: it is set onto the
// limit (and the solution is verified again by the caller). Prismatic joints have one value.
#pragma once

#include <algorithm>
#include <cmath>

#include "dhkin/angles.hpp"

namespace dhkin {

struct JointLimit {
  double lower = 0.0, upper = 0.0;
};

// The in-limit copies of one joint value: value + 2pi (first + k) for k < count.
struct TurnRange {
  long first = 0;
  long count = 0;
};

constexpr double kInverseTwoPi = 1.0 / kTwoPi;

// The copies of `value` inside [lower - slack, upper + slack]; a prismatic value has one copy
// (turn 0) when inside.
inline TurnRange turn_range(const JointLimit& limit, bool revolute, double value, double slack) {
  if (revolute) {
    const long lo = static_cast<long>(std::ceil((limit.lower - slack - value) * kInverseTwoPi));
    const long hi = static_cast<long>(std::floor((limit.upper + slack - value) * kInverseTwoPi));
    return {lo, std::max(hi - lo + 1, 0L)};
  }
  const bool inside = limit.lower - slack <= value && value <= limit.upper + slack;
  return {0, inside ? 1 : 0};
}

// The turn k of the in-limit copy value + 2pi k nearest to `aim` (the seed's value of this
// joint); false when the value has no in-limit copy.
inline bool nearest_turn(const JointLimit& limit, bool revolute, double value, double slack,
                         double aim, long& turn) {
  const TurnRange range = turn_range(limit, revolute, value, slack);
  turn = 0;
  if (range.count == 0) return false;
  if (!revolute) return true;
  // rounded half to even, as Python's round
  const long wanted = static_cast<long>(std::nearbyint((aim - value) * kInverseTwoPi));
  turn = std::min(std::max(wanted, range.first), range.first + range.count - 1);
  return true;
}

// value + 2pi turn (revolute), set onto the nearer limit when it lies outside.
inline double placed(const JointLimit& limit, bool revolute, double value, long turn) {
  const double shifted = revolute ? value + kTwoPi * static_cast<double>(turn) : value;
  return std::min(std::max(shifted, limit.lower), limit.upper);
}

}  // namespace dhkin
