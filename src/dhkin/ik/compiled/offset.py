"""Closed-form solver of the offset-wrist family (UR3/UR5/UR10, UR e-series, AUBO i-series).

The geometry (layout :data:`GEOMETRY`) and the method are described in
:mod:`dhkin.ik.offset_wrist`: product of exponentials in DH frame 0; q1 from the wrist point's
offset along the common direction n of axes 2-4 (two shoulder branches); q5 from
n(q1) . z6 = cos(q5 - psi) (two wrist branches); q6 from the rest of the orientation; q2, q3, q4
from the planar motion G that remains (two elbow branches). Branch index
``4 * shoulder + 2 * elbow + wrist``.

Outputs as in :mod:`.spherical`: ``q`` (8, 6), ``valid``, ``flags``, ``near`` (free joints within
the seed band: q6 at the wrist singularity, q1 with the wrist point on axis 1 (no lateral
offset), q2 with axis 4 on axis 2), ``why`` (6,): the wrist point's distance from axis 1, the
least it needs (|c|), and the arm span (axis 4 from axis 2) of the four shoulder/wrist branches.
Near the wrist singularity q6 barely moves the flange's orientation but moves axis 4 on a circle
about the wrist point: where that puts axis 4 out of the arm's reach, q6 is turned the least
that brings it onto the reach boundary (:func:`_kept_in_reach`); the pipeline verifies the
result like every solution. Roots near a reach boundary of a refined table: as in
:mod:`.spherical` (``spread``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.bands import CLAMPED, ELBOW, FLAG_BAND, MERGE_ANGLE, SHOULDER, WRIST
from dhkin.ik.compiled.copies import wrap
from dhkin.ik.compiled.elementary import atan2, sincos
from dhkin.ik.compiled.jit import jit, jit_literal
from dhkin.ik.compiled.layout import layout

GEOMETRY = layout("OffsetGeometry", [
    ("directions", 18),      # joint axis directions (6, 3), times each joint's direction
    ("points", 18),          # a point on each axis (6, 3)
    ("n", 3),                # common direction of axes 2-4
    ("side", 3),             # axis 1 x n
    ("plane_x", 3), ("plane_y", 3),  # angles about n are measured from plane_x towards plane_y
    ("wrist_in_flange", 3),  # the wrist point (axes 5 and 6 meet) in DH frame 6
    ("wrist_point", 3),      # the same at q = 0 in DH frame 0
    ("home_rotation", 9),    # DH frame 6 at q = 0: rotation (row-major)
    ("home_inverse", 12),    # its inverse transform, top 3 rows (row-major)
    ("upper_arm", 3), ("forearm", 3), ("axis3_x_forearm", 3),
    ("lateral", 1),          # c: the wrist point's offset along n from axis 1
    ("left_sign", 1), ("lateral_sign", 1), ("up_sign", 1),
    ("psi", 1),              # n(q1) . z6 = cos(q5 - psi)
    ("sign3", 1), ("sign4", 1),
    ("upper_length", 1), ("forearm_length", 1),
    ("elbow_alpha", 1), ("elbow_base", 1), ("elbow_turn", 1),
    ("scale", 1),
    ("spread", 1),           # m: least distance from a reach boundary roots are computed at
])


@jit
def _vec(g: NDArray[np.float64], at: int) -> tuple[float, float, float]:
    return g[at], g[at + 1], g[at + 2]


@jit
def _dot3(a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> float:
    return a0 * b0 + a1 * b1 + a2 * b2


@jit
def _rotate(g: NDArray[np.float64], axis: int, c: float, s: float, v0: float, v1: float,
            v2: float) -> tuple[float, float, float]:
    """Rotation by the angle with cosine c, sine s about the unit vector g[axis:axis + 3]."""
    k0, k1, k2 = g[axis], g[axis + 1], g[axis + 2]
    along = (1.0 - c) * (k0 * v0 + k1 * v1 + k2 * v2)
    return (c * v0 + s * (k1 * v2 - k2 * v1) + along * k0,
            c * v1 + s * (k2 * v0 - k0 * v2) + along * k1,
            c * v2 + s * (k0 * v1 - k1 * v0) + along * k2)


@jit_literal
def _axis_rotate(g: NDArray[np.float64], joint: int, angle: float, v0: float, v1: float,
                 v2: float) -> tuple[float, float, float]:
    """Rotation by angle about joint axis ``joint`` (0-based) applied to the direction v."""
    s, c = sincos(angle)
    return _rotate(g, GEOMETRY.directions + 3 * joint, c, s, v0, v1, v2)


@jit_literal
def _screw_apply(g: NDArray[np.float64], joint: int, c: float, s: float, v0: float, v1: float,
                 v2: float, point: bool) -> tuple[float, float, float]:
    """The rigid motion turning about the line of joint axis ``joint`` by the angle with cosine
    c and sine s, applied to v: a point, or a direction."""
    a = GEOMETRY.directions + 3 * joint
    if not point:
        return _rotate(g, a, c, s, v0, v1, v2)
    p0, p1, p2 = _vec(g, GEOMETRY.points + 3 * joint)
    r0, r1, r2 = _rotate(g, a, c, s, v0 - p0, v1 - p1, v2 - p2)
    return r0 + p0, r1 + p1, r2 + p2


@jit_literal
def _motion_apply(g: NDArray[np.float64], T_home: NDArray[np.float64],
                  turns: tuple[float, float, float, float, float, float], v0: float, v1: float,
                  v2: float, point: bool) -> tuple[float, float, float]:
    """G v for the motion G = E1(-q1) T M^-1 E6(-q6) E5(-q5) of joints 2-4, with turns = cos,
    sin of -q5, -q6, -q1; T_home = T M^-1 (3, 4)."""
    c5, s5, c6, s6, c1, s1 = turns
    x0, x1, x2 = _screw_apply(g, 4, c5, s5, v0, v1, v2, point)
    x0, x1, x2 = _screw_apply(g, 5, c6, s6, x0, x1, x2, point)
    y0 = T_home[0, 0] * x0 + T_home[0, 1] * x1 + T_home[0, 2] * x2
    y1 = T_home[1, 0] * x0 + T_home[1, 1] * x1 + T_home[1, 2] * x2
    y2 = T_home[2, 0] * x0 + T_home[2, 1] * x1 + T_home[2, 2] * x2
    if point:
        y0, y1, y2 = y0 + T_home[0, 3], y1 + T_home[1, 3], y2 + T_home[2, 3]
    return _screw_apply(g, 0, c1, s1, y0, y1, y2, point)


@jit
def _in_plane(g: NDArray[np.float64], v0: float, v1: float,
              v2: float) -> tuple[float, float, float]:
    """Component of v normal to n."""
    n0, n1, n2 = _vec(g, GEOMETRY.n)
    along = v0 * n0 + v1 * n1 + v2 * n2
    return v0 - along * n0, v1 - along * n1, v2 - along * n2


@jit
def _arm_point(g: NDArray[np.float64], T_home: NDArray[np.float64],
               turns: tuple[float, float, float, float, float, float]
               ) -> tuple[float, float, float]:
    """The arm's target: axis 4's point under G, from axis 2's point, normal to n."""
    p1 = _vec(g, GEOMETRY.points + 3)
    p3 = _vec(g, GEOMETRY.points + 9)
    a0, a1, a2 = _motion_apply(g, T_home, turns, p3[0], p3[1], p3[2], True)
    return _in_plane(g, a0 - p1[0], a1 - p1[1], a2 - p1[2])


@jit
def _plane_angle(g: NDArray[np.float64], v0: float, v1: float, v2: float) -> float:
    """Angle about n of v from plane_x."""
    py, px = GEOMETRY.plane_y, GEOMETRY.plane_x
    return atan2(_dot3(v0, v1, v2, g[py], g[py + 1], g[py + 2]),
                 _dot3(v0, v1, v2, g[px], g[px + 1], g[px + 2]))


@jit
def _kept_in_reach(g: NDArray[np.float64], T_home: NDArray[np.float64],
                   turns: tuple[float, float, float, float, float, float],
                   arm: tuple[float, float, float], q5: float, q6: float,
                   clamp: float) -> float:
    """q6, turned the least that brings axis 4 onto the arm's reach boundary when it lies out
    of reach by more than ``clamp``; q6 itself otherwise (or when no turn reaches it)."""
    p1 = _vec(g, GEOMETRY.points + 3)
    arm0, arm1, arm2 = arm
    L2, L3 = g[GEOMETRY.upper_length], g[GEOMETRY.forearm_length]
    low, high = abs(L2 - L3), L2 + L3
    span = math.sqrt(arm0 * arm0 + arm1 * arm1 + arm2 * arm2)
    too_far = span > high + clamp
    too_near = span < low - clamp
    if not (too_far or too_near):
        return q6
    wp = _vec(g, GEOMETRY.wrist_point)
    c0, c1, c2 = _motion_apply(g, T_home, turns, wp[0], wp[1], wp[2], True)
    centre0, centre1, centre2 = _in_plane(g, c0 - p1[0], c1 - p1[1], c2 - p1[2])
    boundary = high if too_far else low
    d0, d1, d2 = arm0 - centre0, arm1 - centre1, arm2 - centre2
    radius = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    distance = math.sqrt(centre0 * centre0 + centre1 * centre1 + centre2 * centre2)
    denominator = 2.0 * distance * radius
    if not denominator > 0.0:
        return q6
    cos_needed = (boundary ** 2 - distance ** 2 - radius ** 2) / denominator
    if not abs(cos_needed) <= 1.0:
        # tangent reach (stretched or folded arm): rounding may put |cos| a hair above 1
        if abs(cos_needed) - 1.0 > clamp / max(distance, radius):
            return q6
        cos_needed = min(max(cos_needed, -1.0), 1.0)
    opening = math.acos(cos_needed)
    now = _plane_angle(g, d0, d1, d2) - _plane_angle(g, centre0, centre1, centre2)
    first, second = wrap(opening - now), wrap(-opening - now)
    turn = first if abs(first) <= abs(second) else second
    w6 = _vec(g, GEOMETRY.directions + 15)
    x0, x1, x2 = _axis_rotate(g, 4, q5, w6[0], w6[1], w6[2])
    axis6 = _motion_apply(g, T_home, turns, x0, x1, x2, False)
    along = _dot3(axis6[0], axis6[1], axis6[2], g[GEOMETRY.n], g[GEOMETRY.n + 1],
                  g[GEOMETRY.n + 2])
    # axis 6 is nearly +-n here: turning q6 by delta turns axis 4 about n by -sign * delta
    return q6 - (1.0 if along >= 0.0 else -1.0) * turn


@jit
def solve_offset_wrist(g: NDArray[np.float64], T: NDArray[np.float64],
                       seed: NDArray[np.float64], use_seed: int, seed_angle: float,
                       seed_length: float, clamp: float, q: NDArray[np.float64],
                       valid: NDArray[np.bool_], flags: NDArray[np.uint8],
                       near: NDArray[np.uint8], why: NDArray[np.float64],
                       work: NDArray[np.float64]) -> None:
    """The 8 branches of the offset-wrist family for target T (3, 4), DH frame 0 -> 6 (module
    docstring). work: (>= 16,) floats."""
    T_home = work[:12].reshape(3, 4)
    member = work[12:16]
    member_flag = np.zeros(1, np.int64)
    H = GEOMETRY.home_inverse  # T_home = T @ M^-1
    for r in range(3):
        for c in range(4):
            T_home[r, c] = (T[r, 0] * g[H + c] + T[r, 1] * g[H + 4 + c]
                            + T[r, 2] * g[H + 8 + c])
        T_home[r, 3] += T[r, 3]
    # q1: both roots of n(q1) . (wrist point - r1) = c
    wf = _vec(g, GEOMETRY.wrist_in_flange)
    w0 = T[0, 0] * wf[0] + T[0, 1] * wf[1] + T[0, 2] * wf[2] + T[0, 3]
    w1 = T[1, 0] * wf[0] + T[1, 1] * wf[1] + T[1, 2] * wf[2] + T[1, 3]
    w2 = T[2, 0] * wf[0] + T[2, 1] * wf[1] + T[2, 2] * wf[2] + T[2, 3]
    r1 = _vec(g, GEOMETRY.points)
    h0, h1, h2 = w0 - r1[0], w1 - r1[1], w2 - r1[2]
    n0, n1, n2 = _vec(g, GEOMETRY.n)
    sd = GEOMETRY.side
    along_n = _dot3(h0, h1, h2, n0, n1, n2)
    along_side = _dot3(h0, h1, h2, g[sd], g[sd + 1], g[sd + 2])
    distance = math.sqrt(along_n * along_n + along_side * along_side)
    c = g[GEOMETRY.lateral]
    why[0], why[1] = distance, abs(c)
    gap = distance - abs(c)
    shoulder_ok = gap >= -clamp
    root = math.sqrt(max(gap, g[GEOMETRY.spread]) * (distance + abs(c)))
    shoulder_merged = c != 0.0 and atan2(root, abs(c)) <= MERGE_ANGLE
    if shoulder_merged:
        root = 0.0
    shoulder_flag = SHOULDER if shoulder_merged or root <= FLAG_BAND * g[GEOMETRY.scale] else 0
    # Near the shoulder merge q1 is only as good as the pose over the root: a pose known to
    # ``clamp`` moves it by ~clamp / root (at most ~sqrt(2 clamp / |c|)), and q5 inherits that:
    # the wrist counts as near singular within this much more.
    q1_uncertainty = 0.0
    if c != 0.0:
        q1_uncertainty = min(clamp / max(root, 1e-300), math.sqrt(2.0 * clamp / abs(c)))
    shoulder_near = SHOULDER if c == 0.0 and distance <= seed_length else 0
    shoulder_seeded = shoulder_near != 0 and (use_seed & SHOULDER) != 0
    if gap < 0.0:
        shoulder_near |= CLAMPED
    phase = atan2(along_side, along_n)
    half = atan2(root, c)
    left_sign, lateral_sign = g[GEOMETRY.left_sign], g[GEOMETRY.lateral_sign]
    w6 = _vec(g, GEOMETRY.directions + 15)
    R = GEOMETRY.home_rotation
    for s in range(2):
        if shoulder_seeded:
            q1 = seed[0] + (0.0 if s == 0 else math.pi)
        else:
            q1 = phase + left_sign * half if s == 0 else phase - left_sign * half
        reach_side = lateral_sign if s == 0 else -lateral_sign
        q1_valid = shoulder_ok and (s == 0 or not shoulder_merged)
        # q5 from n(q1) . z6 = cos(q5 - psi), q6 from the rest
        m0, m1, m2 = _axis_rotate(g, 0, q1, n0, n1, n2)
        f0 = T[0, 0] * m0 + T[1, 0] * m1 + T[2, 0] * m2  # R_T^T n(q1)
        f1 = T[0, 1] * m0 + T[1, 1] * m1 + T[2, 1] * m2
        f2 = T[0, 2] * m0 + T[1, 2] * m1 + T[2, 2] * m2
        u0 = g[R] * f0 + g[R + 1] * f1 + g[R + 2] * f2  # u = M_R R_T^T n(q1)
        u1 = g[R + 3] * f0 + g[R + 4] * f1 + g[R + 5] * f2
        u2 = g[R + 6] * f0 + g[R + 7] * f1 + g[R + 8] * f2
        cosine = _dot3(u0, u1, u2, w6[0], w6[1], w6[2])
        x0 = w6[1] * u2 - w6[2] * u1
        x1 = w6[2] * u0 - w6[0] * u2
        x2 = w6[0] * u1 - w6[1] * u0
        sine = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)  # exact for tiny angles (no arccos)
        wrist_flag = WRIST if sine <= FLAG_BAND else 0
        wrist_near = WRIST if sine <= seed_angle + q1_uncertainty else 0
        wrist_seeded = wrist_near != 0 and (use_seed & WRIST) != 0
        q5_half = atan2(sine, cosine)
        a0, a1, a2 = u0 - cosine * w6[0], u1 - cosine * w6[1], u2 - cosine * w6[2]
        s1, c1 = sincos(-q1)
        for w in range(2):
            up = g[GEOMETRY.up_sign]
            q5 = g[GEOMETRY.psi] + (up * q5_half if w == 0 else -up * q5_half)
            s5, c5 = sincos(-q5)
            if wrist_seeded:
                q6 = seed[5]
            else:
                t0, t1, t2 = _rotate(g, GEOMETRY.directions + 12, c5, s5, n0, n1, n2)  # R5^T n
                along_b = _dot3(t0, t1, t2, w6[0], w6[1], w6[2])
                b0, b1, b2 = t0 - along_b * w6[0], t1 - along_b * w6[1], t2 - along_b * w6[2]
                q6 = atan2(_dot3(w6[0], w6[1], w6[2], a1 * b2 - a2 * b1, a2 * b0 - a0 * b2,
                                 a0 * b1 - a1 * b0), _dot3(a0, a1, a2, b0, b1, b2))
            s6, c6 = sincos(-q6)
            turns = (c5, s5, c6, s6, c1, s1)
            arm = _arm_point(g, T_home, turns)
            if wrist_near != 0:
                kept = _kept_in_reach(g, T_home, turns, arm, q5, q6, clamp)
                if kept != q6:
                    q6 = kept
                    s6, c6 = sincos(-q6)
                    turns = (c5, s5, c6, s6, c1, s1)
                    arm = _arm_point(g, T_home, turns)
            why[2 + 2 * s + w] = math.sqrt(arm[0] ** 2 + arm[1] ** 2 + arm[2] ** 2)
            # the two wrist roots coincide exactly: one solution
            wrist_valid = w == 0 or wrist_seeded or sine != 0.0
            _elbow_branches(g, T_home, turns, arm, reach_side, seed[1], use_seed, seed_length,
                            clamp, q1, q5, q6, shoulder_flag | wrist_flag,
                            shoulder_near | wrist_near, q1_valid and wrist_valid, s, w, q, valid,
                            flags, near)
            if wrist_seeded and q1_valid:
                for e in range(2):
                    b = 4 * s + 2 * e + w
                    if _nearest_member(g, T_home, c1, s1, q5, reach_side, seed, use_seed,
                                       seed_length, clamp, e, member, member_flag):
                        q[b, 1], q[b, 2], q[b, 3], q[b, 5] = member[0], member[1], member[2], \
                            member[3]
                        valid[b] = True
                        flags[b] = (flags[b] & ~ELBOW) | member_flag[0]
    for b in range(q.shape[0]):
        for j in range(6):
            if not math.isfinite(q[b, j]):
                valid[b] = False


@jit
def _elbow(g: NDArray[np.float64], T_home: NDArray[np.float64],
           turns: tuple[float, float, float, float, float, float],
           arm: tuple[float, float, float], reach_side: float, seed_q2: float, use_seed: int,
           seed_length: float, clamp: float, e: int) -> tuple[float, float, float, bool, int,
                                                             int]:
    """q2, q3, q4 of elbow branch e for the motion G of joints 2-4 (turns: cos, sin of -q5,
    -q6, -q1; arm: :func:`_arm_point`), with its validity, flag and near bits. Law of cosines
    for q3, the planar rotation taking the bent arm onto the target for q2, the angle of G
    about n for q4."""
    t0, t1, t2 = arm
    span = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    L2, L3 = g[GEOMETRY.upper_length], g[GEOMETRY.forearm_length]
    low, high = abs(L2 - L3), L2 + L3
    outer = high - span
    inner = span - low
    reach_ok = outer >= -clamp and inner >= -clamp
    # (L2 L3)^2 - kappa^2 in factored form: accurate near both boundaries
    spread = g[GEOMETRY.spread]
    root = math.sqrt(max(outer, spread) * (high + span) * max(inner, spread) * (span + low)) / 2.0
    kappa = (span * span - L2 * L2 - L3 * L3) / 2.0
    merged = atan2(root, abs(kappa)) <= MERGE_ANGLE
    if merged:
        root = 0.0
    elbow_flag = ELBOW if merged or root <= FLAG_BAND * L2 * L3 else 0
    half = atan2(root, kappa)
    base = g[GEOMETRY.elbow_base]
    first, second = base + half, base - half
    sf, cf = sincos(first)
    turn = cf * g[GEOMETRY.elbow_turn] + g[GEOMETRY.sign3] * sf * g[GEOMETRY.elbow_alpha]
    if (1.0 if turn >= 0.0 else -1.0) != reach_side:
        first, second = second, first
    q3 = first if e == 0 else second
    s3, c3 = sincos(q3)
    n0, n1, n2 = _vec(g, GEOMETRY.n)
    v0, v1, v2 = _vec(g, GEOMETRY.upper_arm)
    u0, u1, u2 = _vec(g, GEOMETRY.forearm)
    k0, k1, k2 = _vec(g, GEOMETRY.axis3_x_forearm)
    px = _vec(g, GEOMETRY.plane_x)
    r0, r1, r2 = _motion_apply(g, T_home, turns, px[0], px[1], px[2], False)
    total = _plane_angle(g, r0, r1, r2)
    bent0, bent1, bent2 = v0 + c3 * u0 + s3 * k0, v1 + c3 * u1 + s3 * k1, v2 + c3 * u2 + s3 * k2
    elbow_near = ELBOW if math.sqrt(bent0 ** 2 + bent1 ** 2 + bent2 ** 2) <= seed_length else 0
    seeded = elbow_near != 0 and (use_seed & ELBOW) != 0
    if outer < 0.0 or inner < 0.0:
        elbow_near |= CLAMPED
    if seeded:
        q2 = seed_q2
    else:
        q2 = atan2(_dot3(n0, n1, n2, bent1 * t2 - bent2 * t1, bent2 * t0 - bent0 * t2,
                         bent0 * t1 - bent1 * t0), _dot3(bent0, bent1, bent2, t0, t1, t2))
    q4 = g[GEOMETRY.sign4] * (total - q2 - g[GEOMETRY.sign3] * q3)
    return q2, q3, q4, reach_ok and (e == 0 or not merged), elbow_flag, elbow_near


@jit
def _elbow_branches(g: NDArray[np.float64], T_home: NDArray[np.float64],
                    turns: tuple[float, float, float, float, float, float],
                    arm: tuple[float, float, float], reach_side: float, seed_q2: float,
                    use_seed: int, seed_length: float, clamp: float, q1: float, q5: float,
                    q6: float, flag: int, near_bits: int, arm_valid: bool, s: int, w: int,
                    q: NDArray[np.float64], valid: NDArray[np.bool_], flags: NDArray[np.uint8],
                    near: NDArray[np.uint8]) -> None:
    """Both elbow branches (:func:`_elbow`), written with q1, q5, q6 into branches
    4 s + 2 e + w."""
    for e in range(2):
        q2, q3, q4, ok, elbow_flag, elbow_near = _elbow(g, T_home, turns, arm, reach_side,
                                                        seed_q2, use_seed, seed_length, clamp, e)
        b = 4 * s + 2 * e + w
        q[b, 0], q[b, 1], q[b, 2], q[b, 3], q[b, 4], q[b, 5] = q1, q2, q3, q4, q5, q6
        valid[b] = arm_valid and ok
        flags[b] = flag | elbow_flag
        near[b] = near_bits | elbow_near


@jit
def _member(g: NDArray[np.float64], T_home: NDArray[np.float64], c1: float, s1: float,
            q5: float, t: float, reach_side: float, seed: NDArray[np.float64], use_seed: int,
            seed_length: float, clamp: float, e: int,
            out_flag: NDArray[np.int64]) -> tuple[float, float, float, float, bool, float]:
    """Elbow branch e of the solution family at the wrist singularity with q6 = t (moved onto
    the arm's reach if needed): (q2, q3, q4, q6, valid, squared joint distance to the seed over
    joints 2-4 and 6, revolute differences wrapped); out_flag[0]: its ELBOW flag."""
    s5, c5 = sincos(-q5)
    s6, c6 = sincos(-t)
    turns = (c5, s5, c6, s6, c1, s1)
    arm = _arm_point(g, T_home, turns)
    kept = _kept_in_reach(g, T_home, turns, arm, q5, t, clamp)
    if kept != t:
        t = kept
        s6, c6 = sincos(-t)
        turns = (c5, s5, c6, s6, c1, s1)
        arm = _arm_point(g, T_home, turns)
    q2, q3, q4, ok, elbow_flag, _ = _elbow(g, T_home, turns, arm, reach_side, seed[1],
                                           use_seed, seed_length, clamp, e)
    distance = (wrap(q2 - seed[1]) ** 2 + wrap(q3 - seed[2]) ** 2 + wrap(q4 - seed[3]) ** 2
                + wrap(t - seed[5]) ** 2)
    out_flag[0] = elbow_flag
    return q2, q3, q4, t, ok and math.isfinite(distance), distance


#: Nearest-member search over q6: a grid of this half-width and step (rad) around the seed's
#: q6 (where q6 would leave axis 4 out of reach it is moved onto the reach boundary, so far
#: members are found at the grid's edge), then golden-section search to MEMBER_PRECISION within
#: a step of the best grid point. The distance is not smooth (square roots near a stretched or
#: folded elbow, the move onto the boundary): no derivatives are used.
MEMBER_HALF_WIDTH = math.pi
MEMBER_STEP = 0.05
MEMBER_PRECISION = 1e-9
_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)
#: Grid points on each side of the seed's q6 (the whole turn: q2-q4 follow q6, so the nearest
#: member can be far from the seed's q6).
MEMBER_GRID = math.ceil(MEMBER_HALF_WIDTH / MEMBER_STEP)


@jit
def _nearest_member(g: NDArray[np.float64], T_home: NDArray[np.float64], c1: float,
                    s1: float, q5: float, reach_side: float, seed: NDArray[np.float64],
                    use_seed: int, seed_length: float, clamp: float, e: int,
                    out: NDArray[np.float64], out_flag: NDArray[np.int64]) -> bool:
    """At the wrist singularity the pose leaves a one-parameter family (q6 free, q2, q3, q4
    following it): the member nearest the seed in joint space (squared distance over joints
    2-4 and 6), searched over q6 (see MEMBER_*). Writes q2, q3, q4, q6 into out[0:4]; False
    when no member of this elbow branch exists near the seed."""
    best_t, best = seed[5], math.inf
    steps = MEMBER_GRID
    for k in range(-steps, steps + 1):
        t = seed[5] + k * MEMBER_STEP
        _, _, _, _, ok, distance = _member(g, T_home, c1, s1, q5, t, reach_side, seed,
                                           use_seed, seed_length, clamp, e, out_flag)
        if ok and distance < best:
            best_t, best = t, distance
    if best == math.inf:
        return False
    low, high = best_t - MEMBER_STEP, best_t + MEMBER_STEP
    a = high - _GOLDEN * (high - low)
    b = low + _GOLDEN * (high - low)
    fa = _member(g, T_home, c1, s1, q5, a, reach_side, seed, use_seed, seed_length, clamp, e,
                 out_flag)
    fb = _member(g, T_home, c1, s1, q5, b, reach_side, seed, use_seed, seed_length, clamp, e,
                 out_flag)
    value_a = fa[5] if fa[4] else math.inf
    value_b = fb[5] if fb[4] else math.inf
    while high - low > MEMBER_PRECISION:
        if value_a <= value_b:
            high, b, value_b = b, a, value_a
            a = high - _GOLDEN * (high - low)
            fa = _member(g, T_home, c1, s1, q5, a, reach_side, seed, use_seed, seed_length,
                         clamp, e, out_flag)
            value_a = fa[5] if fa[4] else math.inf
        else:
            low, a, value_a = a, b, value_b
            b = low + _GOLDEN * (high - low)
            fb = _member(g, T_home, c1, s1, q5, b, reach_side, seed, use_seed, seed_length,
                         clamp, e, out_flag)
            value_b = fb[5] if fb[4] else math.inf
    t = 0.5 * (low + high)
    q2, q3, q4, t, ok, distance = _member(g, T_home, c1, s1, q5, t, reach_side, seed, use_seed,
                                          seed_length, clamp, e, out_flag)
    if not ok or distance > best:  # the grid point is better (a kink inside the bracket)
        q2, q3, q4, t, ok, distance = _member(g, T_home, c1, s1, q5, best_t, reach_side, seed,
                                              use_seed, seed_length, clamp, e, out_flag)
    out[0], out[1], out[2], out[3] = q2, q3, q4, t
    return True
