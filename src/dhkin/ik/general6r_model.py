"""A six-revolute chain as a standard-DH model, and the elimination's constant coefficients.

Conventions. The exact chain of a table (:func:`dhkin.ik.plan.chain_parts`, corrections
included) is ``T_dh(q) = P_1 Z(v_1) P_2 Z(v_2) ... P_6 Z(v_6) P_tail`` (DH frame 0 -> DH
frame 6, metres), ``Z = Rz``, ``v_j = direction_j q_j + offset_j``. :func:`refit` writes it as

    T_dh(q) = D_0 A_1(theta_1) ... A_6(theta_6) E,   theta_j = v_j + phi_j,

with standard DH rows ``A_j = Rz(theta_j) Tz(d_j) Tx(a_j) Rx(alpha_j)`` (``A_6 = Rz(theta_6)``)
built from the joint axes themselves (lines in space at v = 0): D_j's z axis is joint j + 1's
axis, its x axis the common normal of axes j and j + 1. That model is exact (to rounding) for
any chain whose consecutive axes are not nearly parallel; axes within :data:`PARALLEL_BAND` of
parallel are modelled as parallel (their common normal lies far away: a model a hair off the
chain, which Newton's refinement on the exact chain absorbs, is better conditioned than an
exact one with kilometre offsets). ``model_deviation`` says how far the model is from the chain.

Lengths are scaled by the model's length scale (:attr:`Model.scale`) before the elimination, so
that its coefficients are of order one whatever the arm's size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Consecutive axes whose directions differ by less than this angle (rad) are modelled as
#: parallel. The exact common normal of axes at an angle s lies ~ (distance / s) away: at
#: s = 1e-3 rad and arm lengths ~1 m, offsets of ~1e3 m, whose cubes (the elimination's
#: p.p l terms) lose ~1e-7 relative to rounding, still a good start for Newton; below it the
#: parallel model is at most 1e-3 rad from the chain, also a good start (Newton converges from
#: the family band's 0.02 rad, docs/ik_core.md).
PARALLEL_BAND = 1e-3


@dataclass(frozen=True)
class Model:
    """A standard-DH model of a six-revolute chain (see the module docstring).

    ``phi``, ``d``, ``a``, ``alpha`` (6,): the rows (d, a in units of ``scale`` metres);
    ``D0``, ``E`` (4, 4): frame 0 of the exact chain -> model frame 0, model frame 6 -> the
    chain's frame 6 (metres); ``direction``, ``offset`` (6,): v_j = direction_j q_j + offset_j;
    ``reversed``: the model describes the chain tip to base (joint k of the model is joint
    6 - k of the table, q_table = -q_model ... see :class:`Layout`)."""

    phi: NDArray[np.float64]
    d: NDArray[np.float64]
    a: NDArray[np.float64]
    alpha: NDArray[np.float64]
    D0: NDArray[np.float64]
    E: NDArray[np.float64]
    scale: float
    deviation: float


def rz(angle: float) -> NDArray[np.float64]:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def dh_row(theta: float, d: float, a: float, alpha: float) -> NDArray[np.float64]:
    """Rz(theta) Tz(d) Tx(a) Rx(alpha), 4x4."""
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d], [0, 0, 0, 1.0]])


def _inverse(T: NDArray[np.float64]) -> NDArray[np.float64]:
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


def frames_of(pre: NDArray[np.float64]) -> NDArray[np.float64]:
    """F_j = P_1 ... P_j (j = 1..7, the last with P_tail) at v = 0: (7, 4, 4)."""
    out = np.empty((pre.shape[0], 4, 4))
    current = np.eye(4)
    for j in range(pre.shape[0]):
        current = current @ pre[j]
        out[j] = current
    return out


def refit(pre: NDArray[np.float64]) -> Model:
    """The standard-DH model of the chain ``pre`` (7, 4, 4): P_1..P_6, P_tail (see module)."""
    F = frames_of(pre)
    origins, axes = F[:6, :3, 3], F[:6, :3, 2]
    scale = max(1e-3, float(np.max(np.abs(np.diff(F[:, :3, 3], axis=0)))))
    # frames D_j (j = 0..5): z = axis j + 1 (1-based), x along the common normal of axes j
    # and j + 1, origin at the normal's foot on axis j + 1; D_0 at the first normal's foot
    D = np.empty((6, 4, 4))
    previous_x = _perpendicular(axes[0])
    previous_origin = origins[0]
    for j in range(5):
        u1, u2 = axes[j], axes[j + 1]
        o1, o2 = origins[j], origins[j + 1]
        n = np.cross(u1, u2)
        sin = float(np.linalg.norm(n))
        if sin > PARALLEL_BAND:
            w = o2 - o1
            b = float(u1 @ u2)
            t1 = (u1 @ w - b * (u2 @ w)) / (1 - b * b)
            t2 = (b * (u1 @ w) - u2 @ w) / (1 - b * b)
            f1, f2 = o1 + t1 * u1, o2 + t2 * u2
            normal = f2 - f1
            length = float(np.linalg.norm(normal))
            x = normal / length if length > 1e-12 * scale else n / sin
        else:  # (nearly) parallel: the normal through the previous frame's origin
            f1 = o1 + ((previous_origin - o1) @ u1) * u1
            f2 = o2 + ((f1 - o2) @ u2) * u2
            normal = f2 - f1
            normal -= (normal @ u2) * u2
            length = float(np.linalg.norm(normal))
            x = normal / length if length > 1e-12 * scale else previous_x
            x = x - (x @ u2) * u2
            x = x / np.linalg.norm(x)
        if j == 0:
            x0 = x - (x @ u1) * u1
            D[0] = _frame(f1, x0 / np.linalg.norm(x0), u1)
        D[j + 1] = _frame(f2, x, u2)
        previous_x, previous_origin = x, f2
    # rows from consecutive frames (exact where the frames are DH-consistent)
    phi, d, a, alpha = (np.zeros(6) for _ in range(4))
    model = D[0].copy()
    for j in range(5):
        rel = _inverse(D[j]) @ D[j + 1]
        theta = math.atan2(rel[1, 0], rel[0, 0])
        M = rz(-theta) @ rel
        phi[j], d[j], a[j] = theta, M[2, 3], M[0, 3]
        alpha[j] = math.atan2(M[2, 1], M[1, 1])
        model = model @ dh_row(phi[j], d[j], a[j], alpha[j])
    # A_6 = Rz(theta_6), phi_6 = 0: model frame 6 at v = 0 is model frame 5
    E = _inverse(model) @ F[6]
    # deviation: the model's frames against the chain's (axes' directions and points)
    deviation = 0.0
    frame = D[0]
    for j in range(5):
        frame = frame @ dh_row(phi[j], d[j], a[j], alpha[j])
        deviation = max(deviation, float(np.linalg.norm(np.cross(frame[:3, 2], axes[j + 1]))),
                        float(np.linalg.norm(np.cross(frame[:3, 3] - origins[j + 1],
                                                      axes[j + 1]))) / scale)
    return Model(phi=phi, d=d / scale, a=a / scale, alpha=alpha, D0=D[0], E=E, scale=scale,
                 deviation=deviation)


def _frame(origin: NDArray[np.float64], x: NDArray[np.float64],
           z: NDArray[np.float64]) -> NDArray[np.float64]:
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z, x), z, origin
    return T


def _perpendicular(u: NDArray[np.float64]) -> NDArray[np.float64]:
    other = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
    x = np.cross(u, other)
    return x / np.linalg.norm(x)
