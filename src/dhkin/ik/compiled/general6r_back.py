"""Back-substitution of the general 6R elimination, compiled: from the eliminated joint and its
two neighbours (an eigenvalue and its monomial vector) the other three joints (the math is in
:mod:`dhkin.ik.general6r_elimination` and docs/general6r.md).

The right side of the elimination holds two joints, a and b; its 14 quantities are linear in
y = (cos, sin, 1) of a times (cos, sin, 1) of b, less the constant product (8 values, index
3 i + j): Q y = P x - r. Where Q has full rank, y is its least-squares solution. Where it has
not (a free joint: axis 6 on axis 1 makes the right side depend on a - b alone when a and b are
joints 1 and 6), the least-squares y of least norm is no product of angles at all; the angles
are then fitted to the equations directly (:func:`right_joints`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.general6r_null import ratio_angle
from dhkin.ik.compiled.jit import jit

#: Rounds of alternation in :func:`right_joints` (each fits one angle with the other held): a
#: right side that depends on a - b alone is fitted exactly in the first; four let a start a
#: quarter turn off settle.
ALTERNATIONS = 4


@jit
def dh(theta: float, d: float, a: float, alpha: float, out: NDArray[np.float64]) -> None:
    """Rz(theta) Tz(d) Tx(a) Rx(alpha) into out (4, 4)."""
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = ct, -st * ca, st * sa, a * ct
    out[1, 0], out[1, 1], out[1, 2], out[1, 3] = st, ct * ca, -ct * sa, a * st
    out[2, 0], out[2, 1], out[2, 2], out[2, 3] = 0.0, sa, ca, d
    out[3, 0], out[3, 1], out[3, 2], out[3, 3] = 0.0, 0.0, 0.0, 1.0


@jit
def rigid_inverse(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of a rigid transform (4, 4)."""
    out = np.eye(4)
    for r in range(3):
        for c in range(3):
            out[r, c] = T[c, r]
        out[r, 3] = -(T[0, r] * T[0, 3] + T[1, r] * T[1, 3] + T[2, r] * T[2, 3])
    return out


@jit
def _products(a: float, b: float, y: NDArray[np.float64]) -> None:
    """y (8,) = (cos, sin, 1) of a times (cos, sin, 1) of b, index 3 i + j, less the last."""
    first = (math.cos(a), math.sin(a), 1.0)
    second = (math.cos(b), math.sin(b), 1.0)
    for i in range(3):
        for j in range(3):
            if 3 * i + j < 8:
                y[3 * i + j] = first[i] * second[j]


@jit
def _fit(Q: NDArray[np.float64], rhs: NDArray[np.float64], held: float,
         free_first: bool) -> float:
    """The angle of the free joint (a when ``free_first``, else b) that best fits Q y = rhs
    with the other joint at ``held``: y is linear in its (cos, sin), two unknowns by least
    squares, the angle from their direction."""
    cos_part = np.zeros(8)
    sin_part = np.zeros(8)
    constant = np.zeros(8)
    other = (math.cos(held), math.sin(held), 1.0)
    for t in range(3):
        if free_first:  # y[3 i + t] = (cos a, sin a, 1)[i] * other[t]
            cos_part[t] = other[t]
            sin_part[3 + t] = other[t]
            if 6 + t < 8:
                constant[6 + t] = other[t]
        else:  # y[3 t + j] = other[t] * (cos b, sin b, 1)[j]
            cos_part[3 * t] = other[t]
            sin_part[3 * t + 1] = other[t]
            if 3 * t + 2 < 8:
                constant[3 * t + 2] = other[t]
    u, v = Q @ cos_part, Q @ sin_part
    target = rhs - Q @ constant
    uu, uv, vv = u @ u, u @ v, v @ v
    ut, vt = u @ target, v @ target
    det = uu * vv - uv * uv
    if not abs(det) > 0.0:
        return math.atan2(vt, ut)
    return math.atan2(uu * vt - uv * ut, vv * ut - uv * vt)


@jit
def right_joints(Q: NDArray[np.float64], rank: int, Qpinv: NDArray[np.float64],
                 rhs: NDArray[np.float64]) -> tuple[float, float]:
    """The right side's joints (a, b) from Q y = rhs (Q (14, 8) of rank ``rank``, Qpinv its
    pseudo-inverse): y's angles where Q has full rank; else the angles that fit best of
    alternating fits (:func:`_fit`, :data:`ALTERNATIONS` rounds) from either joint held at
    each quarter turn (a joint left free by the pose takes the value it was held at)."""
    y = Qpinv @ rhs
    if rank >= 8:
        return math.atan2(y[5], y[2]), math.atan2(y[7], y[6])
    best, best_a, best_b = math.inf, 0.0, 0.0
    fitted = np.empty(8)
    for hold_b in (True, False):
        for quarter in range(4):
            start = 0.5 * math.pi * quarter
            a, b = 0.0, 0.0
            if hold_b:
                b = start
                a = _fit(Q, rhs, b, True)
            else:
                a = start
                b = _fit(Q, rhs, a, False)
            for _ in range(ALTERNATIONS - 1):
                b = _fit(Q, rhs, a, False)
                a = _fit(Q, rhs, b, True)
            _products(a, b, fitted)
            residual = 0.0
            misfit = Q @ fitted - rhs
            for i in range(misfit.shape[0]):
                residual += misfit[i] * misfit[i]
            if residual < best:
                best, best_a, best_b = residual, a, b
    return best_a, best_b


@jit
def back_substitute(P: NDArray[np.float64], Q: NDArray[np.float64], rank: int,
                    Qpinv: NDArray[np.float64], r_vec: NDArray[np.float64],
                    rows: NDArray[np.float64], phi: NDArray[np.float64],
                    direction: NDArray[np.float64], offset: NDArray[np.float64], k: int,
                    reverse: bool, H: NDArray[np.float64], theta_k: float,
                    vector: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    """The joint values (URDF, 6) of the model angles theta_k (the eigenvalue) and those of
    the monomial vector (theta_k+1, theta_k+2), into out: the right side's two joints from
    the 14 equations (:func:`right_joints`), the dropped joint from the orientation."""
    theta = np.empty(6)
    x45 = np.empty(9)
    T1 = np.empty((4, 4))
    theta_1 = ratio_angle(vector, False)
    theta_2 = ratio_angle(vector, True)
    theta[k], theta[k + 1], theta[k + 2] = theta_k, theta_1, theta_2
    b0 = (math.cos(theta_k), math.sin(theta_k), 1.0)
    b1 = (math.cos(theta_1), math.sin(theta_1), 1.0)
    b2 = (math.cos(theta_2), math.sin(theta_2), 1.0)
    for i in range(3):
        for j in range(3):
            x45[3 * i + j] = b1[i] * b2[j]
    rhs = (P[0] * b0[0] + P[1] * b0[1] + P[2]) @ x45 - r_vec
    first, second = -1, -1
    for j in range(6):
        if j < k or j > k + 3:
            if first < 0:
                first = j
            else:
                second = j
    theta[first], theta[second] = right_joints(Q, rank, Qpinv, rhs)
    g = k + 3
    pre = np.eye(4)
    for j in range(g):
        dh(theta[j], rows[j, 0], rows[j, 1], rows[j, 2], T1)
        pre = pre @ T1
    post = np.eye(4)
    for j in range(g + 1, 6):
        dh(theta[j], rows[j, 0], rows[j, 1], rows[j, 2], T1)
        post = post @ T1
    A_g = rigid_inverse(pre) @ H @ rigid_inverse(post)
    theta[g] = math.atan2(A_g[1, 0], A_g[0, 0])
    for j in range(6):
        v = theta[j] - phi[j]
        if reverse:
            out[5 - j] = (-v - offset[5 - j]) / direction[5 - j]
        else:
            out[j] = (v - offset[j]) / direction[j]
