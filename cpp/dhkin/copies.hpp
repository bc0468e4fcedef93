// Joint values: the 2pi-shifted copies inside the joint limits.
//
// A revolute joint's value q and q + 2pi k reach the same pose; the limits decide which copies
// exist. A value that lies within `slack` outside a limit counts as on it: it is set onto the
// limit (and the solution is verified again by the caller). Prismatic joints have one value.
#pragma once

#include <algorithm>
#include <cmath>

#include "dhkin/angles.hpp"
#include "dhkin/simd.hpp"

namespace dhkin {

struct JointLimit {
  double lower = 0.0, upper = 0.0;
};

// The in-limit copies of one joint value: value + 2pi (first + k) for k < count.
struct TurnRange {
  long first = 0;
  long count = 0;
};

// The same per lane, as whole numbers in doubles (+0.0 for zero).
template <class V>
struct TurnRangeT {
  V first, count;
};

constexpr double kInverseTwoPi = 1.0 / kTwoPi;

// The copies of `value` inside [lower - slack, upper + slack]; a prismatic value has one copy
// (turn 0) when inside.
template <class V>
DHKIN_INLINE TurnRangeT<V> turn_range(const JointLimit& limit, bool revolute, V value, double slack) {
  if (revolute) {
    const V lo = ceil((limit.lower - slack - value) * kInverseTwoPi);
    const V hi = floor((limit.upper + slack - value) * kInverseTwoPi);
    return {lo + 0.0, max(hi - lo + 1.0, V(0.0)) + 0.0};
  }
  const auto inside = limit.lower - slack <= value && value <= limit.upper + slack;
  return {V(0.0), select(inside, V(1.0), V(0.0))};
}

inline TurnRange turn_range(const JointLimit& limit, bool revolute, double value, double slack) {
  const TurnRangeT<double> range = turn_range<double>(limit, revolute, value, slack);
  return {static_cast<long>(range.first), static_cast<long>(range.count)};
}

// The turn k of the in-limit copy value + 2pi k nearest to `aim` (the seed's value of this
// joint; rounded half to even, as Python's round), and whether the value has an in-limit copy
// (turn 0 where not).
template <class V>
struct NearestTurn {
  MaskOf<V> exists;
  V turn;
};

template <class V>
DHKIN_INLINE NearestTurn<V> nearest_turn(const JointLimit& limit, bool revolute, V value, double slack,
                                   V aim) {
  if (!revolute) return {turn_range<V>(limit, revolute, value, slack).count > 0.0, V(0.0)};
  const V wanted = nearbyint((aim - value) * kInverseTwoPi);
  // a whole number lies in [ceil(low), floor(high)] exactly when low <= it <= high
  const auto inside = (limit.lower - slack - value) * kInverseTwoPi <= wanted &&
                      wanted <= (limit.upper + slack - value) * kInverseTwoPi;
  if (all(inside)) return {inside, wanted + 0.0};
  const TurnRangeT<V> range = turn_range<V>(limit, revolute, value, slack);
  const auto exists = range.count > 0.0;
  const V turn = min(max(wanted, range.first), range.first + range.count - 1.0);
  return {exists, select(exists, turn + 0.0, V(0.0))};
}

inline bool nearest_turn(const JointLimit& limit, bool revolute, double value, double slack,
                         double aim, long& turn) {
  const NearestTurn<double> nearest = nearest_turn<double>(limit, revolute, value, slack, aim);
  turn = static_cast<long>(nearest.turn);
  return nearest.exists;
}

// value + 2pi turn (revolute), set onto the nearer limit when it lies outside.
template <class V>
DHKIN_INLINE V shifted(bool revolute, V value, V turn) {
  return revolute ? value + kTwoPi * turn : value;
}
template <class V>
DHKIN_INLINE V placed(const JointLimit& limit, bool revolute, V value, V turn) {
  return min(max(shifted(revolute, value, turn), V(limit.lower)), V(limit.upper));
}
inline double placed(const JointLimit& limit, bool revolute, double value, long turn) {
  return placed<double>(limit, revolute, value, static_cast<double>(turn));
}

}  // namespace dhkin
