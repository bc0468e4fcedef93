// The exact chain of a DH table (corrections included): forward kinematics, pose errors and the
// Jacobian.
//
// Any serial chain of a DH table is written as
//
//     T(q) = P_1 Z_1(v_1) P_2 Z_2(v_2) ... P_n Z_n(v_n) P_tail,    v_j = direction_j q_j + offset_j
//
// with P_j constant rigid transforms and Z_j = Rz(v_j) (revolute) or Tz(v_j) (prismatic): joint j
// moves about / along the z axis of the frame P_1 Z_1 ... P_j. T is DH frame 0 -> DH frame n
// (the IK turns its targets into that frame). dhkin.ik.plan.chain_parts builds the P_j from a
// table in either DH convention.
#pragma once

#include <array>
#include <cmath>
#include <new>
#include <vector>

#include "dhkin/angles.hpp"
#include "dhkin/frame.hpp"

namespace dhkin {

// Joints of the closed-form families (and of every arm the IK core solves).
constexpr int kDof = 6;
using Joints = std::array<double, kDof>;
// One flag per joint (e.g. the joints a refinement keeps fixed).
using JointMask = std::array<bool, kDof>;

// Most joints of any chain (dhkin.dh.MAX_JOINTS).
constexpr int kMaxJoints = 32;

struct ChainJoint {
  Frame before;            // P_j: the constant frame before the joint's motion
  bool revolute = true;    // Rz (revolute) or Tz (prismatic)
  double direction = 1.0;  // v_j = direction q_j + offset
  double offset = 0.0;

  // The DH variable (theta or d) at joint value q.
  template <class V>
  V motion(V q) const { return direction * q + offset; }
};

struct Chain {
  std::vector<ChainJoint> joints;
  Frame tail;  // P_tail

  int dof() const { return static_cast<int>(joints.size()); }
};

// f = f * Z(v): the joint's motion.
template <class V>
DHKIN_INLINE void apply_motion(FrameT<V>& f, const ChainJoint& joint, V q) {
  const V v = joint.motion(q);
  if (joint.revolute) {
    const SinCosT<V> t = sincos(v);
    turn_about_z(f, t.c, t.s);
  } else {
    slide_along_z(f, v);
  }
}

// Where a constant frame P has zeros. A DH table's frames turn about x (P.R = Rx(alpha): row 0
// and column 0 are those of the identity), often by a right angle (whose cosine 6e-17 stays a
// factor), and move along one or two axes.
struct ConstantShape {
  enum Kind { kGeneral, kIdentity, kTurnX };
  Kind kind = kGeneral;
  double turn[2][2] = {{1.0, 0.0}, {0.0, 1.0}};  // P.R[1..2][1..2] of a turn about x
  int moves = 0;                                 // nonzero entries of P.p
  int axis[3] = {0, 0, 0};                       // their indices, in order
  double move[3] = {0.0, 0.0, 0.0};              // and values

  ConstantShape() = default;
  explicit ConstantShape(const Frame& P) {
    for (int k = 0; k < 3; ++k) {
      if (P.p[k] != 0.0) axis[moves] = k, move[moves++] = P.p[k];
    }
    const bool about_x = P.R[0][0] == 1.0 && P.R[0][1] == 0.0 && P.R[0][2] == 0.0 &&
                         P.R[1][0] == 0.0 && P.R[2][0] == 0.0;
    if (!about_x) return;
    for (int r = 0; r < 2; ++r) {
      for (int c = 0; c < 2; ++c) turn[r][c] = P.R[r + 1][c + 1];
    }
    const bool identity = P.R[1][1] == 1.0 && P.R[1][2] == 0.0 && P.R[2][1] == 0.0 &&
                          P.R[2][2] == 1.0;
    kind = identity ? kIdentity : kTurnX;
  }
};

// state = state * P for the constant frame P of this shape: operator* of frame.hpp without the
// terms whose factor of P is zero. The same sums in the same order, so the same values short of
// the sign of a zero.
template <class V>
DHKIN_INLINE void times_constant(FrameT<V>& state, const Frame& P, const ConstantShape& shape) {
  if (shape.kind == ConstantShape::kGeneral) {
    state = state * P;
    return;
  }
  for (int r = 0; r < 3; ++r) {
    V* row = state.R[r];
    if (shape.moves == 1) {
      state.p[r] = row[shape.axis[0]] * shape.move[0] + state.p[r];
    } else if (shape.moves > 1) {
      V sum = row[shape.axis[0]] * shape.move[0];
      for (int t = 1; t < shape.moves; ++t) sum = sum + row[shape.axis[t]] * shape.move[t];
      state.p[r] = sum + state.p[r];
    }
    if (shape.kind == ConstantShape::kTurnX) {
      const V a1 = row[1], a2 = row[2];
      row[1] = a1 * shape.turn[0][0] + a2 * shape.turn[1][0];
      row[2] = a1 * shape.turn[0][1] + a2 * shape.turn[1][1];
    }
  }
}

// The shapes of the constant frames of a chain of at most kDof joints.
struct ChainShape {
  ConstantShape before[kDof];
  ConstantShape tail;

  // Each shape built in place: a copy of one just written field by field loads it back in wider
  // pieces than it was stored, which waits until those stores retire (perf: ~10 % of a single
  // call's FK check).
  explicit ChainShape(const Chain& chain) : tail(chain.tail) {
    for (int j = 0; j < chain.dof() && j < kDof; ++j) {
      new (&before[j]) ConstantShape(chain.joints[j].before);
    }
  }
};

// The joints' motions at q: each revolute joint's sine and cosine, each DH variable.
template <class V>
struct JointMotions {
  SinCosT<V> turn[kDof];
  V variable[kDof];
};

// Joint j's motion at value q.
template <class V>
DHKIN_INLINE void joint_motion(const Chain& chain, int j, V q, JointMotions<V>& out) {
  const ChainJoint& joint = chain.joints[j];
  out.variable[j] = joint.motion(q);
  if (joint.revolute) out.turn[j] = sincos(out.variable[j]);
}

template <class V>
DHKIN_INLINE void joint_motions(const Chain& chain, const V* q, JointMotions<V>& out) {
  for (int j = 0; j < chain.dof(); ++j) joint_motion(chain, j, q[j], out);
}

// Joint j's step of chain_frame: state (the frame after j joints, P_1 Z_1 ... Z_j) becomes the
// frame after j + 1 joints.
template <class V>
DHKIN_INLINE void chain_step(const Chain& chain, const ChainShape& shape,
                             const JointMotions<V>& motions, int j, FrameT<V>& state) {
  if (j > 0) times_constant(state, chain.joints[j].before, shape.before[j]);
  if (chain.joints[j].revolute) {
    turn_about_z(state, motions.turn[j].c, motions.turn[j].s);
  } else {
    slide_along_z(state, motions.variable[j]);
  }
}

// T(q) of a chain of at most kDof joints from its motions at q.
template <class V>
DHKIN_INLINE FrameT<V> chain_frame(const Chain& chain, const ChainShape& shape,
                                   const JointMotions<V>& motions) {
  FrameT<V> state = broadcast<V>(chain.joints[0].before);
  for (int j = 0; j < chain.dof(); ++j) chain_step(chain, shape, motions, j, state);
  times_constant(state, chain.tail, shape.tail);
  return state;
}

// T(q), DH frame 0 -> DH frame n; q has chain.dof() values (per lane: kLanes joint vectors).
template <class V>
inline FrameT<V> fk(const Chain& chain, const V* q) {
  if (chain.dof() <= kDof) {
    JointMotions<V> motions;
    joint_motions(chain, q, motions);
    return chain_frame(chain, ChainShape(chain), motions);
  }
  FrameT<V> state = broadcast<V>(chain.joints[0].before);
  apply_motion(state, chain.joints[0], q[0]);
  for (int j = 1; j < chain.dof(); ++j) {
    times_constant(state, chain.joints[j].before, ConstantShape(chain.joints[j].before));
    apply_motion(state, chain.joints[j], q[j]);
  }
  times_constant(state, chain.tail, ConstantShape(chain.tail));
  return state;
}

// The frame each joint moves about (before its motion), frames[j] for j < n, and T(q) in
// frames[n]. frames must hold dof() + 1 frames.
inline void fk_frames(const Chain& chain, const double* q, Frame* frames) {
  const int n = chain.dof();
  Frame state;
  for (int j = 0; j < n; ++j) {
    state = j == 0 ? chain.joints[0].before : state * chain.joints[j].before;
    frames[j] = state;
    apply_motion(state, chain.joints[j], q[j]);
  }
  frames[n] = state * chain.tail;
}

// fk_frames of a chain of at most kDof joints, its constant frames' products skipping their zero
// terms (times_constant): the same values short of the sign of a zero. For loops that evaluate
// one chain many times (refine), which build its shape once.
inline void fk_frames(const Chain& chain, const ChainShape& shape, const double* q,
                      Frame* frames) {
  const int n = chain.dof();
  Frame state = chain.joints[0].before;
  for (int j = 0; j < n; ++j) {
    if (j > 0) times_constant(state, chain.joints[j].before, shape.before[j]);
    frames[j] = state;
    apply_motion(state, chain.joints[j], q[j]);
  }
  times_constant(state, chain.tail, shape.tail);
  frames[n] = state;
}

// Position (m) and rotation (rad) error of a frame against a target (per lane).
template <class V>
struct PoseErrorT {
  V position{};
  V rotation{};

  V largest() const { return select(position > rotation, position, rotation); }
  // Both errors at most `tolerance` (false for NaN).
  MaskOf<V> within(double tolerance) const {
    return position <= tolerance && rotation <= tolerance;
  }
};
using PoseError = PoseErrorT<double>;

// Lane l of errors of lanes.
inline PoseError lane(const PoseErrorT<Lanes>& e, int l) {
  return {lane(e.position, l), lane(e.rotation, l)};
}

// Below this ratio s / c (s >= 0, c > 0) atan2(s, c) is s / c bit for bit (see rotation_angle).
constexpr double kLinearAtan = 0x1p-27;

// atan2(s, c) for s >= 0 (NaN allowed), the same bits, with the quotient alone where every lane
// has s <= 2^-27 c (c finite and > 0): there atan2 (angles.hpp) reduces to t = s / c, table entry 0
// and u = (t - 0) / (1 + t 0) = t, and returns 0 + (u + u^3 P(u^2)) with |u^3 P| < |u| 2^-54 / 3,
// less than a quarter of u's spacing, so u + u^3 P rounds to u (subnormal u: the product
// vanishes). A verified branch's rotation error (<= 1e-9 rad) always takes this road.
template <class V>
DHKIN_INLINE V rotation_angle(V s, V c) {
  if (all(s <= kLinearAtan * c && c > 0.0 && c < INFINITY)) return s / c;
  return atan2(s, c);
}

// The error of `state` against `target`: |p - p_t| and the angle of R^T R_t, computed as
// atan2(s, c) with s = |vee(E - E^T)| / 2, c = (trace E - 1) / 2, E = R^T R_t.
template <class V, class W>
DHKIN_INLINE PoseErrorT<Product<V, W>> pose_error(const FrameT<V>& state, const FrameT<W>& target) {
  using T = Product<V, W>;
  T e[3][3];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      e[r][c] = state.R[0][r] * target.R[0][c] + state.R[1][r] * target.R[1][c] +
                state.R[2][r] * target.R[2][c];
    }
  }
  const T dx = state.p[0] - target.p[0], dy = state.p[1] - target.p[1],
          dz = state.p[2] - target.p[2];
  const T s = 0.5 * sqrt((e[2][1] - e[1][2]) * (e[2][1] - e[1][2]) +
                         (e[0][2] - e[2][0]) * (e[0][2] - e[2][0]) +
                         (e[1][0] - e[0][1]) * (e[1][0] - e[0][1]));
  const T c = 0.5 * (e[0][0] + e[1][1] + e[2][2] - 1.0);
  return {sqrt(dx * dx + dy * dy + dz * dz), rotation_angle(s, c)};
}

// The error of T(q) against `target`.
template <class V, class W>
inline PoseErrorT<Product<V, W>> check(const Chain& chain, const V* q, const FrameT<W>& target) {
  return pose_error(fk(chain, q), target);
}

// The twist taking `state` to `target`, in DH frame 0: e[0..2] = p_t - p, e[3..5] = the rotation
// vector of R_t R^T. Returns the two errors (per lane for V = Lanes).
template <class V>
DHKIN_INLINE PoseErrorT<V> error_twist(const FrameT<V>& state, const Frame& target, V* e) {
  for (int r = 0; r < 3; ++r) e[r] = target.p[r] - state.p[r];
  // M = R_t R^T: its skew part carries sin(angle) * axis, its trace 1 + 2 cos(angle)
  V m[3][3];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      m[r][c] = target.R[r][0] * state.R[c][0] + target.R[r][1] * state.R[c][1] +
                target.R[r][2] * state.R[c][2];
    }
  }
  const V v0 = 0.5 * (m[2][1] - m[1][2]);
  const V v1 = 0.5 * (m[0][2] - m[2][0]);
  const V v2 = 0.5 * (m[1][0] - m[0][1]);
  const V s = sqrt(v0 * v0 + v1 * v1 + v2 * v2);
  const V angle = atan2(s, 0.5 * (m[0][0] + m[1][1] + m[2][2] - 1.0));
  const V scale = select(s > 0.0, angle / s, V(1.0));
  e[3] = v0 * scale, e[4] = v1 * scale, e[5] = v2 * scale;
  return {sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), angle};
}

// The geometric Jacobian (6 x n, row-major J[row * n + j]): linear and angular velocity of DH
// frame n's origin per unit joint value, in DH frame 0, from the frames each joint moves about
// (frames[j]) and T(q) (frames[n]), as fk_frames and chain_frames give them (per lane for
// V = Lanes).
template <class V>
DHKIN_INLINE void jacobian(const Chain& chain, const FrameT<V>* frames, V* J) {
  const int n = chain.dof();
  const FrameT<V>& end = frames[n];
  for (int j = 0; j < n; ++j) {
    const double d = chain.joints[j].direction;
    const Vec3T<V> z = frames[j].column(2);
    if (chain.joints[j].revolute) {
      const Vec3T<V> arm = end.translation() - frames[j].translation();
      const Vec3T<V> v = cross(z, arm);
      J[0 * n + j] = d * v.x, J[1 * n + j] = d * v.y, J[2 * n + j] = d * v.z;
      J[3 * n + j] = d * z.x, J[4 * n + j] = d * z.y, J[5 * n + j] = d * z.z;
    } else {
      J[0 * n + j] = d * z.x, J[1 * n + j] = d * z.y, J[2 * n + j] = d * z.z;
      J[3 * n + j] = V(0.0), J[4 * n + j] = V(0.0), J[5 * n + j] = V(0.0);
    }
  }
}

// fk_frames of a chain of kDof joints on the lane type, from its motions at q: the frame each
// joint moves about in frames[j], T(q) in frames[kDof]. The constant frames' products skip their
// zero terms (times_constant), so the values equal fk_frames' short of the sign of a zero.
template <class V>
DHKIN_INLINE void chain_frames(const Chain& chain, const ChainShape& shape,
                               const JointMotions<V>& motions, FrameT<V>* frames) {
  FrameT<V> state = broadcast<V>(chain.joints[0].before);
  for (int j = 0; j < kDof; ++j) {
    if (j > 0) times_constant(state, chain.joints[j].before, shape.before[j]);
    frames[j] = state;
    if (chain.joints[j].revolute) {
      turn_about_z(state, motions.turn[j].c, motions.turn[j].s);
    } else {
      slide_along_z(state, motions.variable[j]);
    }
  }
  times_constant(state, chain.tail, shape.tail);
  frames[kDof] = state;
}

// The chain whose tail ends at `point` (given in DH frame n): errors are then measured there.
inline Chain extended_to(const Chain& chain, const Vec3& point) {
  Chain out = chain;
  out.tail = moved_to(chain.tail, point);
  return out;
}

}  // namespace dhkin
