"""Closed-form solvers of the spherical-wrist family (R-R-R arm) and of the Stanford family
(R-R-P arm), which share the shoulder (axis 1) and the spherical wrist (axes 4, 5, 6).

The geometry (layout :data:`GEOMETRY`) comes from :mod:`dhkin.ik.spherical_wrist` and
:mod:`dhkin.ik.stanford`, which also document the method: everything in DH frame 0, the wrist
centre from the target, q1 from the wrist centre's position across axis 1 (two shoulder
branches), q2 and q3 from a planar problem (law of cosines, or the slide), q4..q6 from the
remaining rotation as a ZYZ Euler problem (two wrist branches). Branch index
``4 * shoulder + 2 * elbow + wrist``.

Each call solves one target (3, 4) for the 8 branches into ``q`` (8, 6), ``valid``, ``flags``
(singularity bits within the flag band) and ``near`` (bits of the singularities where a joint is
free and within the seed band: the wrist (q4 free), the wrist centre on axis 1 (q1 free), on
axis 2 (q2 free)). ``use_seed`` (bits) selects which free joints come from the seed: in that
mode the solver writes the seed's choice instead of the computed one, and the pipeline keeps it
wherever it verifies. Reach conditions violated by at most ``clamp`` (m) are clamped onto the
boundary (the pipeline verifies the result); two roots within :data:`.bands.MERGE_ANGLE` of each
other are one solution (the twin branch is invalid). On a refined table (``spread`` > 0, the
model deviation in metres) roots are computed as if the target were at least ``spread`` inside
every reach boundary: where the ideal model's two roots merge or vanish, the exact chain's may
still be distinct, and the refinement finds each from its own side. ``why`` (6,) receives the
numbers an empty answer is explained with: wrist centre distance from axis 1, the least it
needs, and its distance from axis 2 on the front and back branches.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.bands import CLAMPED, ELBOW, FLAG_BAND, MERGE_ANGLE, SHOULDER, WRIST
from dhkin.ik.compiled.copies import wrap
from dhkin.ik.compiled.elementary import atan2, sincos
from dhkin.ik.compiled.jit import jit
from dhkin.ik.compiled.layout import layout

GEOMETRY = layout("SphericalGeometry", [
    ("centre_in_flange", 3),  # wrist centre in DH frame n
    ("origin", 3),            # shoulder origin: foot on axis 1 of the common normal to axis 2
    ("forward", 3), ("lateral", 3), ("up", 3),  # shoulder frame (up = axis 1)
    ("shoulder_offset", 1),   # a1: axis 2 from axis 1 along forward
    ("lateral_offset", 1),    # b: wrist centre along lateral
    ("signs", 3),             # turn_i = sign_i * q_i for joints 1-3
    ("wrist_frame", 9),       # F (row-major): z along axis 4, y along axis 5
    ("target_to_wrist", 9),   # M_R^T F Ry(tilt) (row-major)
    ("tilt", 1),              # axis 6's tilt from axis 4 at q5 = 0
    ("wrist_directions", 3),  # directions of joints 4, 5, 6
    ("scale", 1),             # table length scale (m)
    ("upper_arm", 2),         # spherical: axis 3 from axis 2 in the arm plane (height, reach)
    ("forearm", 2),           # spherical: wrist centre from axis 3
    ("upper_length", 1), ("forearm_length", 1), ("bend_at_zero", 1),
    ("wrist_at_zero", 2),     # Stanford: wrist centre at q = 0 from axis 2 (height, reach)
    ("slide", 2),             # Stanford: unit slide direction in the arm plane
    ("slide_along", 1), ("slide_offset", 1),  # A.V and |e|
    ("spread", 1),            # m: least distance from a reach boundary roots are computed at
])


@jit
def _rotate(g: NDArray[np.float64], axis: int, c: float, s: float, v0: float, v1: float,
            v2: float) -> tuple[float, float, float]:
    """Rotation by the angle with cosine c, sine s about the unit vector g[axis:axis + 3]."""
    k0, k1, k2 = g[axis], g[axis + 1], g[axis + 2]
    along = (1.0 - c) * (k0 * v0 + k1 * v1 + k2 * v2)
    return (c * v0 + s * (k1 * v2 - k2 * v1) + along * k0,
            c * v1 + s * (k2 * v0 - k0 * v2) + along * k1,
            c * v2 + s * (k0 * v1 - k1 * v0) + along * k2)


@jit
def _shoulder(g: NDArray[np.float64], T: NDArray[np.float64], seed_q1: float, use_seed: int,
              seed_length: float, clamp: float,
              why: NDArray[np.float64]) -> tuple[int, int, bool, bool, float, float, float,
                                                 float, float]:
    """Both q1 branches: (flag, near, front valid, back valid, front turn, back turn, height,
    front reach, back reach); reach and height: the wrist centre's arm-plane target from axis 2.
    ``near`` has CLAMPED when the wrist centre was moved onto the reach across axis 1.

    Turning about axis 1 by phi maps the arm-plane point (X, b) to the wrist centre's
    coordinates (x, y) across axis 1: X = +-sqrt(r^2 - b^2), phi = atan2(y, x) - atan2(b, X).
    """
    c = GEOMETRY.centre_in_flange
    o = GEOMETRY.origin
    d0 = T[0, 3] + T[0, 0] * g[c] + T[0, 1] * g[c + 1] + T[0, 2] * g[c + 2] - g[o]
    d1 = T[1, 3] + T[1, 0] * g[c] + T[1, 1] * g[c + 1] + T[1, 2] * g[c + 2] - g[o + 1]
    d2 = T[2, 3] + T[2, 0] * g[c] + T[2, 1] * g[c + 1] + T[2, 2] * g[c + 2] - g[o + 2]
    f, lat, up = GEOMETRY.forward, GEOMETRY.lateral, GEOMETRY.up
    x = d0 * g[f] + d1 * g[f + 1] + d2 * g[f + 2]
    y = d0 * g[lat] + d1 * g[lat + 1] + d2 * g[lat + 2]
    height = d0 * g[up] + d1 * g[up + 1] + d2 * g[up + 2]
    b = g[GEOMETRY.lateral_offset]
    radius = math.sqrt(x * x + y * y)
    why[0], why[1] = radius, abs(b)
    gap = radius - abs(b)
    reachable = gap >= -clamp
    root = math.sqrt(max(gap, g[GEOMETRY.spread]) * (radius + abs(b)))
    merged = b != 0.0 and atan2(root, abs(b)) <= MERGE_ANGLE
    if merged:
        root = 0.0
    near = SHOULDER if b == 0.0 and radius <= seed_length else 0
    seeded = near != 0 and (use_seed & SHOULDER) != 0
    if gap < 0.0:
        near |= CLAMPED
    if seeded:
        front_turn = g[GEOMETRY.signs] * seed_q1
        back_turn = front_turn + math.pi
    else:
        heading = atan2(y, x)
        front_turn = heading - atan2(b, root)
        back_turn = heading - atan2(b, -root)
    flag = SHOULDER if merged or root <= FLAG_BAND * g[GEOMETRY.scale] else 0
    offset = g[GEOMETRY.shoulder_offset]
    return (flag, near, reachable, reachable and not merged, front_turn, back_turn, height,
            root - offset, -root - offset)


@jit
def _target_columns(g: NDArray[np.float64], T: NDArray[np.float64], turn1: float,
                    out: NDArray[np.float64]) -> None:
    """Columns 0 and 2 of K1 = R1^T R_target M_R^T F Ry(tilt) into out[0:3], out[3:6] (R1:
    the turn by turn1 about ``up``)."""
    m = GEOMETRY.target_to_wrist
    s1, c1 = sincos(turn1)
    for column in range(2):
        c = 2 * column
        k0 = T[0, 0] * g[m + c] + T[0, 1] * g[m + 3 + c] + T[0, 2] * g[m + 6 + c]
        k1 = T[1, 0] * g[m + c] + T[1, 1] * g[m + 3 + c] + T[1, 2] * g[m + 6 + c]
        k2 = T[2, 0] * g[m + c] + T[2, 1] * g[m + 3 + c] + T[2, 2] * g[m + 6 + c]
        r0, r1, r2 = _rotate(g, GEOMETRY.up, c1, -s1, k0, k1, k2)
        out[3 * column], out[3 * column + 1], out[3 * column + 2] = r0, r1, r2


@jit
def _wrist(g: NDArray[np.float64], columns: NDArray[np.float64], turn23: float,
           seed_q4: float, seed_q6: float, use_seed: int, seed_angle: float,
           out: NDArray[np.float64]) -> tuple[int, int]:
    """q4, q5, q6 of both wrist branches into out[0:3], out[3:6] for an arm turned by turn23
    about ``lateral``: H = F^T R23^T K1 = Rz(t4) Ry(t5 + tilt) Rz(t6). Returns (flag, near).

    Regular: t4 = atan2(h12, h02), then the flip (t4 + pi, -theta, t6 + pi). Seeded (near the
    singularity, ``use_seed`` has WRIST): the pose fixes only c = t4 + t6 (t4 - t6 where theta
    is near pi; exactly so at theta = 0 or pi); the member of that family nearest the seed in
    joint space splits the seed's miss r = c - (c of the seed), wrapped, evenly between the
    two joints: t4 = seed's t4 + r / 2 (in both
    branches), theta = +- the computed angle, and t6 from the remainder Ry(-theta) Rz(-t4) H,
    so that the pose error is what the choice costs (|sin theta| times its distance from the
    computed t4).
    """
    s23, c23 = sincos(turn23)
    F = GEOMETRY.wrist_frame
    lat = GEOMETRY.lateral
    a0, a1, a2 = _rotate(g, lat, c23, -s23, columns[0], columns[1], columns[2])
    b0, b1, b2 = _rotate(g, lat, c23, -s23, columns[3], columns[4], columns[5])
    h00 = g[F] * a0 + g[F + 3] * a1 + g[F + 6] * a2
    h10 = g[F + 1] * a0 + g[F + 4] * a1 + g[F + 7] * a2
    h20 = g[F + 2] * a0 + g[F + 5] * a1 + g[F + 8] * a2
    h02 = g[F] * b0 + g[F + 3] * b1 + g[F + 6] * b2
    h12 = g[F + 1] * b0 + g[F + 4] * b1 + g[F + 7] * b2
    h22 = g[F + 2] * b0 + g[F + 5] * b1 + g[F + 8] * b2
    d4 = g[GEOMETRY.wrist_directions]
    d5 = g[GEOMETRY.wrist_directions + 1]
    d6 = g[GEOMETRY.wrist_directions + 2]
    tilt = g[GEOMETRY.tilt]
    sine = math.sqrt(h02 * h02 + h12 * h12)
    flag = WRIST if sine <= FLAG_BAND else 0
    near = WRIST if sine <= seed_angle else 0
    theta = atan2(sine, h22)
    seeded = near != 0 and (use_seed & WRIST) != 0
    alpha = atan2(h12, h02)
    if seeded:  # theta near 0 fixes t4 + t6; near pi, t4 - t6 (Ry(pi) Rz(t6) = Rz(-t6) Ry(pi))
        sa, ca = sincos(alpha)
        st, ct = sincos(theta)
        gamma = atan2(-sa * h00 + ca * h10, ct * (ca * h00 + sa * h10) - st * h20)
        turn = 1.0 if h22 >= 0.0 else -1.0
        alpha = d4 * seed_q4 + 0.5 * wrap(alpha + turn * gamma
                                          - d4 * seed_q4 - turn * d6 * seed_q6)
    for w in range(2):
        t4 = alpha + (math.pi if w == 1 and not seeded else 0.0)
        t5 = theta if w == 0 else -theta
        sa, ca = sincos(t4)
        st, ct = sincos(t5)
        # Ry(-t5) Rz(-t4) H = Rz(t6): t6 from its first column
        t6 = atan2(-sa * h00 + ca * h10, ct * (ca * h00 + sa * h10) - st * h20)
        out[3 * w] = d4 * t4
        out[3 * w + 1] = d5 * (t5 - tilt)
        out[3 * w + 2] = d6 * t6
    return flag, near


@jit
def _store(q: NDArray[np.float64], valid: NDArray[np.bool_], flags: NDArray[np.uint8],
           near: NDArray[np.uint8], b: int, q123: tuple[float, float, float],
           wrist_q: NDArray[np.float64], w: int, ok: bool, flag: int, near_bits: int) -> None:
    q[b, 0], q[b, 1], q[b, 2] = q123
    q[b, 3], q[b, 4], q[b, 5] = wrist_q[3 * w], wrist_q[3 * w + 1], wrist_q[3 * w + 2]
    valid[b] = ok
    flags[b] = flag
    near[b] = near_bits


@jit
def _turn_to(target_re: float, target_im: float, point_re: float, point_im: float) -> float:
    """angle(target * conj(point)): the turn taking arm-plane ``point`` towards ``target``."""
    return atan2(target_im * point_re - target_re * point_im,
                 target_re * point_re + target_im * point_im)


@jit
def solve_spherical_wrist(g: NDArray[np.float64], T: NDArray[np.float64],
                          seed: NDArray[np.float64], use_seed: int, seed_angle: float,
                          seed_length: float, clamp: float, q: NDArray[np.float64],
                          valid: NDArray[np.bool_], flags: NDArray[np.uint8],
                          near: NDArray[np.uint8], why: NDArray[np.float64],
                          scratch: NDArray[np.float64]) -> None:
    """The 8 branches of the spherical-wrist family for target T (3, 4) (module docstring).
    Elbow: with psi the angle from upper arm to forearm, |target|^2 = L2^2 + L3^2 +
    2 L2 L3 cos(psi); t3 = psi - psi_0, t2 = arg(target) - arg(upper + exp(i t3) fore)."""
    shoulder_flag, shoulder_near, front_valid, back_valid, front_turn, back_turn, height, \
        front_reach, back_reach = _shoulder(g, T, seed[0], use_seed, seed_length, clamp, why)
    columns, wrist_q = scratch[:6], scratch[6:12]
    u_re, u_im = g[GEOMETRY.upper_arm], g[GEOMETRY.upper_arm + 1]
    f_re, f_im = g[GEOMETRY.forearm], g[GEOMETRY.forearm + 1]
    upper, fore = g[GEOMETRY.upper_length], g[GEOMETRY.forearm_length]
    s1, s2, s3 = g[GEOMETRY.signs], g[GEOMETRY.signs + 1], g[GEOMETRY.signs + 2]
    for s in range(2):
        turn1 = front_turn if s == 0 else back_turn
        t_re, t_im = height, front_reach if s == 0 else back_reach
        _target_columns(g, T, turn1, columns)
        distance = math.sqrt(t_re * t_re + t_im * t_im)
        why[2 + s] = distance
        outer = (upper + fore) - distance
        inner = distance - abs(upper - fore)
        reachable = outer >= -clamp and inner >= -clamp
        clamped = CLAMPED if outer < 0.0 or inner < 0.0 else 0
        # (2 L2 L3 sin psi)^2 as a product of factors: accurate near both boundaries
        spread = g[GEOMETRY.spread]
        sine_scaled = math.sqrt(max(outer, spread) * (upper + fore + distance)
                                * max(inner, spread)
                                * (distance + abs(upper - fore)))
        cosine_scaled = distance ** 2 - upper ** 2 - fore ** 2
        merged = atan2(sine_scaled, abs(cosine_scaled)) <= MERGE_ANGLE
        if merged:
            sine_scaled = 0.0
        elbow_flag = ELBOW if merged or sine_scaled <= FLAG_BAND * 2 * upper * fore else 0
        elbow_near = ELBOW if distance <= seed_length else 0
        for e in range(2):
            psi = atan2(sine_scaled if e == 0 else -sine_scaled, cosine_scaled)
            turn3 = psi - g[GEOMETRY.bend_at_zero]
            s3t, c3t = sincos(turn3)
            w_re = u_re + (c3t * f_re - s3t * f_im)
            w_im = u_im + (c3t * f_im + s3t * f_re)
            if elbow_near != 0 and (use_seed & ELBOW) != 0:
                turn2 = s2 * seed[1]
            else:
                turn2 = _turn_to(t_re, t_im, w_re, w_im)
            arm_valid = ((front_valid if s == 0 else back_valid) and reachable
                         and (e == 0 or not merged))
            wrist_flag, wrist_near = _wrist(g, columns, turn2 + turn3, seed[3], seed[5],
                                            use_seed, seed_angle, wrist_q)
            for w in range(2):
                _store(q, valid, flags, near, 4 * s + 2 * e + w,
                       (s1 * turn1, s2 * turn2, s3 * turn3), wrist_q, w, arm_valid,
                       shoulder_flag | elbow_flag | wrist_flag,
                       shoulder_near | elbow_near | wrist_near | clamped)


@jit
def solve_stanford(g: NDArray[np.float64], T: NDArray[np.float64], seed: NDArray[np.float64],
                   use_seed: int, seed_angle: float, seed_length: float, clamp: float,
                   q: NDArray[np.float64], valid: NDArray[np.bool_], flags: NDArray[np.uint8],
                   near: NDArray[np.uint8], why: NDArray[np.float64],
                   scratch: NDArray[np.float64]) -> None:
    """The 8 branches of the Stanford family (elbow = the slide of joint 3): in the arm plane
    the wrist centre is A + t V turned about axis 2, so |A + t V| = |target| gives
    t = -A.V +- sqrt(|target|^2 - e^2), e the slide line's distance from axis 2."""
    shoulder_flag, shoulder_near, front_valid, back_valid, front_turn, back_turn, height, \
        front_reach, back_reach = _shoulder(g, T, seed[0], use_seed, seed_length, clamp, why)
    columns, wrist_q = scratch[:6], scratch[6:12]
    a_re, a_im = g[GEOMETRY.wrist_at_zero], g[GEOMETRY.wrist_at_zero + 1]
    v_re, v_im = g[GEOMETRY.slide], g[GEOMETRY.slide + 1]
    along, offset = g[GEOMETRY.slide_along], g[GEOMETRY.slide_offset]
    s1, s2, s3 = g[GEOMETRY.signs], g[GEOMETRY.signs + 1], g[GEOMETRY.signs + 2]
    for s in range(2):
        turn1 = front_turn if s == 0 else back_turn
        t_re, t_im = height, front_reach if s == 0 else back_reach
        _target_columns(g, T, turn1, columns)
        distance = math.sqrt(t_re * t_re + t_im * t_im)
        why[2 + s] = distance
        gap = distance - offset
        reachable = gap >= -clamp
        clamped = CLAMPED if gap < 0.0 else 0
        root = math.sqrt(max(gap, g[GEOMETRY.spread]) * (distance + offset))
        merged = atan2(root, offset) <= MERGE_ANGLE
        if merged:
            root = 0.0
        slide_flag = ELBOW if merged or root <= FLAG_BAND * g[GEOMETRY.scale] else 0
        for e in range(2):
            t = -along + (root if e == 0 else -root)
            w_re = a_re + t * v_re
            w_im = a_im + t * v_im
            free = math.sqrt(w_re * w_re + w_im * w_im) <= seed_length
            slide_near = ELBOW if free else 0
            if free and (use_seed & ELBOW) != 0:
                turn2 = s2 * seed[1]
            else:
                turn2 = _turn_to(t_re, t_im, w_re, w_im)
            arm_valid = ((front_valid if s == 0 else back_valid) and reachable
                         and (e == 0 or not merged))
            wrist_flag, wrist_near = _wrist(g, columns, turn2, seed[3], seed[5], use_seed,
                                            seed_angle, wrist_q)
            for w in range(2):
                _store(q, valid, flags, near, 4 * s + 2 * e + w, (s1 * turn1, s2 * turn2, s3 * t),
                       wrist_q, w, arm_valid, shoulder_flag | slide_flag | wrist_flag,
                       shoulder_near | slide_near | wrist_near | clamped)
