"""Input poses: checks, projection onto the nearest rotation, conversion to DH frame 0 -> n.

A pose comes as it comes: computed (exact to rounding), printed with a few digits, or float32.
Its rotation block R is accepted when it is within :data:`ORTHONORMALITY_GATE` of a rotation
(largest entry of |R R^T - I|, and det R > 0) and replaced by the nearest rotation (the orthogonal
polar factor, which minimises the Frobenius distance); the solutions are exact for that projected
pose and :func:`target` returns how far the projection moved R (Frobenius norm of the change).
The bottom row must be [0, 0, 0, 1] to within :data:`BOTTOM_ROW_TOLERANCE`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.jit import jit

#: Largest |R R^T - I| entry of an accepted rotation block. Rounded sources stay far below it:
#: float32 poses ~2e-7, six printed decimals ~3e-6, four printed decimals ~3e-4; a block further
#: off is not a rounded rotation but a wrong matrix.
ORTHONORMALITY_GATE = 1e-3
#: Largest deviation of the bottom row from [0, 0, 0, 1]: rounding only (a product or inverse
#: of rigid transforms leaves it exact up to ~1e-16; 1e-12 allows ten thousand ulps).
BOTTOM_ROW_TOLERANCE = 1e-12
#: Newton steps of the polar decomposition (quadratic convergence: from 1e-3 off, three steps
#: reach rounding; the loop stops as soon as a step changes nothing beyond rounding).
POLAR_STEPS = 8

# Status of an input pose (0: usable).
STATUS_NOT_FINITE = 1
STATUS_BOTTOM_ROW = 2
STATUS_NOT_ROTATION = 3
STATUS_BAD_SEED = 4


@jit
def status(T: NDArray[np.float64]) -> int:
    """0 for a usable pose (4, 4), else STATUS_NOT_FINITE, STATUS_BOTTOM_ROW or
    STATUS_NOT_ROTATION (see the module docstring)."""
    for r in range(4):
        for c in range(4):
            if not abs(T[r, c]) < math.inf:
                return STATUS_NOT_FINITE
    bottom = max(abs(T[3, 0]), abs(T[3, 1]), abs(T[3, 2]), abs(T[3, 3] - 1.0))
    if not bottom <= BOTTOM_ROW_TOLERANCE:
        return STATUS_BOTTOM_ROW
    if not orthonormality(T) <= ORTHONORMALITY_GATE or _det(T) <= 0.0:
        return STATUS_NOT_ROTATION
    return 0


@jit
def orthonormality(T: NDArray[np.float64]) -> float:
    """Largest entry of |R R^T - I| of the rotation block of T (3 or 4 rows, >= 3 columns)."""
    worst = 0.0
    for a in range(3):
        for b in range(a, 3):
            dot = T[a, 0] * T[b, 0] + T[a, 1] * T[b, 1] + T[a, 2] * T[b, 2]
            worst = max(worst, abs(dot - (1.0 if a == b else 0.0)))
    return worst


@jit
def _det(T: NDArray[np.float64]) -> float:
    return (T[0, 0] * (T[1, 1] * T[2, 2] - T[1, 2] * T[2, 1])
            - T[0, 1] * (T[1, 0] * T[2, 2] - T[1, 2] * T[2, 0])
            + T[0, 2] * (T[1, 0] * T[2, 1] - T[1, 1] * T[2, 0]))


@jit
def project(T: NDArray[np.float64], out: NDArray[np.float64]) -> float:
    """out (3, 4) = T (>= 3 rows) with its rotation block replaced by the nearest rotation
    (Newton's iteration X <- (X + X^-T) / 2 for the polar factor); returns the Frobenius norm
    of the change of the rotation block. T must have passed :func:`status`."""
    for r in range(3):
        for c in range(4):
            out[r, c] = T[r, c]
    for _ in range(POLAR_STEPS):
        a, b, c = out[0, 0], out[0, 1], out[0, 2]
        d, e, f = out[1, 0], out[1, 1], out[1, 2]
        g, h, i = out[2, 0], out[2, 1], out[2, 2]
        det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
        # X^-T = cofactor(X) / det
        cof = ((e * i - f * h, f * g - d * i, d * h - e * g),
               (c * h - b * i, a * i - c * g, b * g - a * h),
               (b * f - c * e, c * d - a * f, a * e - b * d))
        change = 0.0
        for r in range(3):
            for k in range(3):
                new = 0.5 * (out[r, k] + cof[r][k] / det)
                change = max(change, abs(new - out[r, k]))
                out[r, k] = new
        if change <= 4e-16:
            break
    moved = 0.0
    for r in range(3):
        for c in range(3):
            moved += (out[r, c] - T[r, c]) ** 2
    return math.sqrt(moved)


@jit
def tcp_point(frames: NDArray[np.float64], out: NDArray[np.float64]) -> bool:
    """out (3,) = the TCP's origin in DH frame n (the translation of tool @ tcp, from
    frames[1] = (tool @ tcp)^-1); whether it is not the origin."""
    F = frames[1]
    for r in range(3):
        out[r] = -(F[0, r] * F[0, 3] + F[1, r] * F[1, 3] + F[2, r] * F[2, 3])
    return out[0] != 0.0 or out[1] != 0.0 or out[2] != 0.0


@jit
def at_point(T: NDArray[np.float64], point: NDArray[np.float64],
             out: NDArray[np.float64]) -> None:
    """out (3, 4) = T (3, 4) followed by the translation ``point`` (in T's frame)."""
    for r in range(3):
        for c in range(3):
            out[r, c] = T[r, c]
        out[r, 3] = T[r, 3] + T[r, 0] * point[0] + T[r, 1] * point[1] + T[r, 2] * point[2]


@jit
def to_dh(frames: NDArray[np.float64], T: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    """out (3, 4) = top rows of frames[0] @ T @ frames[1] for a rigid T (3 rows suffice):
    base_link -> TCP becomes DH frame 0 -> DH frame n (frames: base^-1, (tool @ tcp)^-1)."""
    B, F = frames[0], frames[1]
    for r in range(3):
        m0 = B[r, 0] * T[0, 0] + B[r, 1] * T[1, 0] + B[r, 2] * T[2, 0]
        m1 = B[r, 0] * T[0, 1] + B[r, 1] * T[1, 1] + B[r, 2] * T[2, 1]
        m2 = B[r, 0] * T[0, 2] + B[r, 1] * T[1, 2] + B[r, 2] * T[2, 2]
        m3 = B[r, 0] * T[0, 3] + B[r, 1] * T[1, 3] + B[r, 2] * T[2, 3] + B[r, 3]
        for c in range(4):
            out[r, c] = m0 * F[0, c] + m1 * F[1, c] + m2 * F[2, c]
        out[r, 3] += m3
