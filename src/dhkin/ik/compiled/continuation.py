"""Beyond Newton on the exact chain (:mod:`.chain`): continuation along a path of models from the
ideal one to the exact chain, chains extended to the TCP point, and the searches off a fold (the
twin root a refinement lost, the roots a hair inside a fold).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.chain import (
    GROWTH,
    MAX_STEPS,
    _jacobian,
    _times_constant,
    check,
    fk_frames,
    refine,
    within,
)
from dhkin.ik.compiled.elementary import sincos
from dhkin.ik.compiled.jit import jit

#: Continuation from the ideal model to the exact chain: the first try takes the path in this
#: many equal steps; a step whose Newton solve fails is halved, down to 1 / (STEPS * 2^DEPTH).
CONTINUATION_STEPS = 4


CONTINUATION_DEPTH = 5


@jit
def rodrigues(w0: float, w1: float, w2: float, R: NDArray[np.float64]) -> None:
    """R (3, 3) = the rotation by the rotation vector w."""
    angle = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    s, c = sincos(angle)
    if angle > 1e-12:
        k0, k1, k2 = w0 / angle, w1 / angle, w2 / angle
        a, b = s, 1.0 - c
    else:  # first order: exact to rounding at this size
        k0, k1, k2 = w0, w1, w2
        a, b = 1.0, 0.0
    R[0, 0] = 1.0 - b * (k1 * k1 + k2 * k2)
    R[1, 1] = 1.0 - b * (k0 * k0 + k2 * k2)
    R[2, 2] = 1.0 - b * (k0 * k0 + k1 * k1)
    R[0, 1] = -a * k2 + b * k0 * k1
    R[1, 0] = a * k2 + b * k0 * k1
    R[0, 2] = a * k1 + b * k0 * k2
    R[2, 0] = -a * k1 + b * k0 * k2
    R[1, 2] = -a * k0 + b * k1 * k2
    R[2, 1] = a * k0 + b * k1 * k2


@jit
def extend_tail(chain: NDArray[np.float64], point: NDArray[np.float64]) -> None:
    """In place: the chain's tail frame P_tail followed by the translation ``point`` (in DH
    frame n), so that the chain's FK ends at that point (its errors are measured there)."""
    n = chain.shape[0] - 1
    for r in range(3):
        chain[n, 4 * r + 3] += (chain[n, 4 * r] * point[0] + chain[n, 4 * r + 1] * point[1]
                                + chain[n, 4 * r + 2] * point[2])


@jit
def extend_path(path: NDArray[np.float64], point: NDArray[np.float64]) -> None:
    """In place: the continuation path (:func:`interpolate`) between two chains whose tails
    were both extended by ``point``: row n's step [Rot(w), v] becomes
    Tr(-point) [Rot(w), v] Tr(point) = [Rot(w), v + Rot(w) point - point]."""
    n = path.shape[0] - 1
    R = np.empty((3, 3))
    rodrigues(path[n, 0], path[n, 1], path[n, 2], R)
    for r in range(3):
        path[n, 3 + r] += R[r, 0] * point[0] + R[r, 1] * point[1] + R[r, 2] * point[2] - point[r]


@jit
def interpolate(ideal: NDArray[np.float64], path: NDArray[np.float64], t: float,
                out: NDArray[np.float64]) -> None:
    """out = the chain at t in [0, 1] on the path from ``ideal`` to the exact chain: each
    constant frame P_j(t) = P_j(ideal) [Rot(t w_j), t v_j] with path[j] = (w_j, v_j) the
    rotation vector and translation of P_j(ideal)^-1 P_j(exact); motions as in ``ideal``."""
    R = np.empty((3, 3))
    for j in range(ideal.shape[0]):
        for k in range(ideal.shape[1]):
            out[j, k] = ideal[j, k]
        rodrigues(t * path[j, 0], t * path[j, 1], t * path[j, 2], R)
        step = np.empty(12)
        for r in range(3):
            for c in range(3):
                step[4 * r + c] = R[r, c]
            step[4 * r + 3] = t * path[j, 3 + r]
        _times_constant(out[j, 0:12], step)


@jit
def refine_along(ideal: NDArray[np.float64], exact: NDArray[np.float64],
                 path: NDArray[np.float64], T: NDArray[np.float64], q: NDArray[np.float64],
                 fixed: NDArray[np.bool_], tolerance: float,
                 work: NDArray[np.float64]) -> tuple[float, float]:
    """:func:`refine` by continuation: a solution q of the ideal model (in place) followed along
    the path of models from ``ideal`` (t = 0) to ``exact`` (t = 1), solving each step with
    :func:`refine` from the previous step's solution; a failed step is halved (CONTINUATION_*).
    Returns the exact chain's (position, rotation) errors at the final q. work: chain-shaped."""
    n = q.shape[0]
    start = q.copy()
    t, dt = 0.0, 1.0 / CONTINUATION_STEPS
    smallest = dt / 2.0 ** CONTINUATION_DEPTH
    position, rotation = math.inf, math.inf
    while t < 1.0:
        target = min(1.0, t + dt)
        model = exact if target >= 1.0 else work
        if target < 1.0:
            interpolate(ideal, path, target, work)
        trial = start.copy()
        position, rotation = refine(model, T, trial, fixed, tolerance, 4 * MAX_STEPS,
                                    GROWTH, 0.0)
        if within(position, rotation, tolerance):
            t = target
            for j in range(n):
                start[j] = trial[j]
            dt = min(2.0 * dt, 1.0 / CONTINUATION_STEPS)
        else:
            dt *= 0.5
            if dt < smallest:
                break
    for j in range(n):
        q[j] = start[j]
    if t < 1.0:
        state = np.empty(12)
        return check(exact, q, T, state)
    return position, rotation


#: Steps (rad, along the unit weakest direction) tried from a solution to find a twin root that
#: the refinement lost to it (two starts that converged to one solution near a fold).
TWIN_STEPS = (0.02, 0.05, 0.1, 0.2, 0.4, 0.7)


#: Steps (along the unit weakest direction) tried from a candidate clamped onto a fold, where
#: J is singular and Newton cannot leave: the roots a hair inside lie ~sqrt(violation) away.
OFF_FOLD_STEPS = (1e-6, 1e-5, 1e-4, 1e-3, 1e-2)


@jit
def off_fold(chain: NDArray[np.float64], T: NDArray[np.float64], q: NDArray[np.float64],
             fixed: NDArray[np.bool_], tolerance: float, budget: int) -> tuple[float, float]:
    """Newton from q (in place) displaced along J's weakest direction by OFF_FOLD_STEPS, each
    way, until one verifies; q keeps the best result; returns its errors."""
    n = q.shape[0]
    frames = np.empty((n + 1, 12))
    J = np.empty((6, n))
    fk_frames(chain, q, frames)
    _jacobian(chain, frames, J)
    for j in range(n):
        if fixed[j]:
            for r in range(6):
                J[r, j] = 0.0
    _, _, vt = np.linalg.svd(J)
    weakest = vt[n - 1]
    largest = np.abs(weakest).max()
    state = np.empty(12)
    best = q.copy()
    best_position, best_rotation = check(chain, q, T, state)
    trial = np.empty(n)
    for size in OFF_FOLD_STEPS:
        for sign in (1.0, -1.0):
            for j in range(n):
                trial[j] = best[j] + sign * size * weakest[j] / largest
            refine(chain, T, trial, fixed, tolerance, budget, GROWTH, 0.0)
            position, rotation = check(chain, trial, T, state)
            if max(position, rotation) < max(best_position, best_rotation):
                best_position, best_rotation = position, rotation
                for j in range(n):
                    q[j] = trial[j]
            if within(position, rotation, tolerance):
                return position, rotation
    return best_position, best_rotation


@jit
def find_twin(chain: NDArray[np.float64], T: NDArray[np.float64], q: NDArray[np.float64],
              tolerance: float, distinct: float, known: NDArray[np.float64],
              known_ok: NDArray[np.bool_], out: NDArray[np.float64]) -> bool:
    """A solution near the solution q (n,) on the far side of the fold it sits by, other than
    q and the ``known`` rows (B, n) marked ``known_ok``: Newton from q displaced along the right
    singular vector of the smallest singular value of J(q), TWIN_STEPS each way. out receives
    the first verified one that differs from all of them by more than ``distinct`` on some joint
    (mod 2pi); False when none does."""
    n = q.shape[0]
    frames = np.empty((n + 1, 12))
    J = np.empty((6, n))
    fk_frames(chain, q, frames)
    _jacobian(chain, frames, J)
    _, _, vt = np.linalg.svd(J)
    weakest = vt[n - 1]
    largest = np.abs(weakest).max()
    fixed = np.zeros(n, np.bool_)
    state = np.empty(12)
    for size in TWIN_STEPS:
        for sign in (1.0, -1.0):
            for j in range(n):
                out[j] = q[j] + sign * size * weakest[j] / largest
            refine(chain, T, out, fixed, tolerance, 4 * MAX_STEPS, GROWTH, 0.0)
            position, rotation = check(chain, out, T, state)
            if within(position, rotation, tolerance) and _apart(out, q, distinct):
                new = True
                for b in range(known.shape[0]):
                    if known_ok[b] and not _apart(out, known[b], distinct):
                        new = False
                if new:
                    return True
    return False


@jit
def _apart(a: NDArray[np.float64], b: NDArray[np.float64], distinct: float) -> bool:
    """Whether a and b differ by more than ``distinct`` on some joint (mod 2pi)."""
    largest = 0.0
    for j in range(a.shape[0]):  # no generator: numba compiles none
        largest = max(largest, abs(_wrapped(a[j] - b[j])))
    return largest > distinct


@jit
def _wrapped(x: float) -> float:
    return x - 2.0 * math.pi * np.floor((x + math.pi) / (2.0 * math.pi))
