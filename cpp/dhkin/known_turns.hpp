// The sines and cosines a family's closed form has computed at its candidates' joint values, by
// branch and joint, for the FK check of those candidates (block.hpp's check_branches).
//
// The check needs sincos(v) of each revolute joint's DH variable v = direction q + offset. The
// closed form has often computed sincos at an angle with the same bits as v (q1, q3 and q5 of
// most tables: direction 1, offset 0, and q already within (-pi, pi]) or as -v (q5 and q6 of the
// offset wrist, turned back by -q5 and -q6). Where it has, in every lane, the check takes those
// values: sincos is a function of its argument's bits, so they are the values it would compute,
// and -v gives (-sin, cos) with the bits sincos(v) has (angles.hpp, `negated`). The check stays
// a full FK of the returned joint values; only the repeated evaluation is saved.
#pragma once

#include "dhkin/angles.hpp"
#include "dhkin/family.hpp"
#include "dhkin/simd.hpp"

namespace dhkin {

template <class V>
struct KnownTurnsT {
  V angle[kBranches][kDof];         // the argument sincos was computed at
  SinCosT<V> turn[kBranches][kDof];  // sincos(angle)
  bool known[kBranches][kDof] = {};

  // Branch b's joint j: sincos was computed at `at`, giving t.
  DHKIN_INLINE void put(int b, int j, const V& at, const SinCosT<V>& t) {
    angle[b][j] = at, turn[b][j] = t, known[b][j] = true;
  }
};

// Whether a and b hold the same bits in every lane.
DHKIN_INLINE bool same_bits(const Lanes& a, const Lanes& b) { return !any(bits_of(a) != bits_of(b)); }

// sincos(v) of branch b's joint j from `known` when it was computed at v or at -v (every lane);
// false when it was not.
DHKIN_INLINE bool known_sincos(const KnownTurnsT<Lanes>& known, int b, int j, const Lanes& v,
                               SinCosT<Lanes>& out) {
  if (!known.known[b][j]) return false;
  if (same_bits(v, known.angle[b][j])) {
    out = known.turn[b][j];
    return true;
  }
  if (same_bits(v, -known.angle[b][j])) {
    out = negated(known.turn[b][j]);
    return true;
  }
  return false;
}

}  // namespace dhkin
