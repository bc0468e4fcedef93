"""How the general 6R solver eliminates (:mod:`dhkin.ik.general6r`): the arrangements, the
choice of one per table at build, and the numpy reference of the compiled candidates
(:func:`candidates`, checked against :mod:`dhkin.ik.compiled.general6r` by the tests).

Poses T_dh are DH frame 0 -> DH frame 6 of the exact chain, metres; angles in rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.errors import FamilyError
from dhkin.ik.general6r_elimination import Elimination
from dhkin.ik.general6r_model import Model, _inverse, dh_row
from dhkin.ik.inputs import TWO_PI


class EliminatingSolver(Protocol):
    """What the functions here read of a :class:`dhkin.ik.general6r.General6RSolver` (named
    by this protocol, so that this module does not import the solver's)."""

    table: DHTable
    arrangement: Arrangement
    elimination: Elimination
    offset: NDArray[np.float64]
    direction: NDArray[np.float64]

    def _eliminator(self, arrangement: Arrangement) -> tuple[Model, Elimination]: ...

#: A candidate angle is taken from an eigenvalue whose half-angle arc tangent's imaginary
#: part is at most this (rad). Rounding turns a double real root (a singular pose) into a
#: complex pair whose imaginary part is ~sqrt(rounding), ~1e-8; near a fold, two real roots
#: 0.1 rad apart in the chain can be a complex pair of the model. Spurious eigenvalues
#: (x3 = +-i) lie at infinite imaginary angle. Candidates are cheap (Newton decides), so the
#: band is wide.
IMAGINARY_BAND = 0.1



#: Singular values of the 12 x 12 matrix polynomial at a generic x3 below this fraction of
#: its norm mean the arrangement's polynomial is singular (its determinant vanishes for
#: every x3): rounding alone leaves ~1e-16 there, a regular one ~1e-5 or more.
SINGULAR_PENCIL = 1e-10



@dataclass(frozen=True)
class Arrangement:
    """One way of eliminating: the chain's direction (``reversed``: tip to base) and the
    eliminated joint ``k`` of the model (0-based)."""

    reversed: bool
    k: int



def candidates(solver: EliminatingSolver, T_dh: NDArray[np.float64],
               arrangement: Arrangement | None = None,
               elimination: Elimination | None = None) -> NDArray[np.float64]:
    """Joint values (m, 6) of every near-real eigenvalue for the target T_dh (DH frame 0 ->
    DH frame 6 of the exact chain), before refinement."""
    arrangement = arrangement or solver.arrangement
    el = elimination or solver.elimination
    model = el.model
    target = _inverse(T_dh) if arrangement.reversed else T_dh
    H = _inverse(model.D0) @ target @ _inverse(model.E)
    H[:3, 3] /= model.scale
    A, B, C, Q, r = el.pencil(H)
    n = 12
    left = np.zeros((24, 24))
    left[:n, n:] = np.eye(n)
    left[n:, :n] = -C
    left[n:, n:] = -B
    right = np.eye(24)
    right[n:, n:] = A
    (alpha, beta), vectors = scipy.linalg.eig(left, right, homogeneous_eigvals=True,
                                              check_finite=False)
    thetas = []
    for index in range(24):
        a, b = alpha[index], beta[index]
        if not (np.isfinite(a) and np.isfinite(b)):
            continue
        if abs(b) > abs(a) * 1e-300 and b != 0:
            x = a / b
            with np.errstate(divide="ignore", invalid="ignore"):  # x = +-i: spurious
                angle = 2.0 * np.arctan(x)
            if not np.isfinite(angle) or abs(angle.imag) > IMAGINARY_BAND:
                continue
            theta_k = el.shift + float(angle.real)
            vector = vectors[:n, index] if abs(x) <= 1.0 else vectors[n:, index]
        else:
            theta_k = el.shift + math.pi
            vector = vectors[n:, index]
        top = vector[int(np.argmax(np.abs(vector)))]
        m = (vector * (np.conj(top) / abs(top))).real.reshape(4, 3)
        theta_1 = ratio_angle(m, axis=0)
        theta_2 = ratio_angle(m, axis=1)
        thetas.append(back_substitute(el, H, theta_k, theta_1, theta_2, Q, r))
    if not thetas:
        return np.zeros((0, 6))
    theta = np.array(thetas)
    v = theta - model.phi
    if arrangement.reversed:
        v = -v[:, ::-1]
    return (v - solver.offset) / solver.direction

def back_substitute(el: Elimination, H: NDArray[np.float64], theta_k: float,
                     theta_1: float, theta_2: float, Q: NDArray[np.float64],
                     r: NDArray[np.float64]) -> NDArray[np.float64]:
    """All six model angles from the eliminated one and its two neighbours: the right
    side's two joints from the 14 equations (least squares: Q y = P x - r), the dropped
    joint from the orientation."""
    k = el.k
    basis = [np.array([math.cos(t), math.sin(t), 1.0]) for t in (theta_k, theta_1, theta_2)]
    P = el.P[0] * basis[0][0] + el.P[1] * basis[0][1] + el.P[2]
    y = np.linalg.lstsq(Q, P @ np.kron(basis[1], basis[2]) - r, rcond=None)[0]
    theta = np.zeros(6)
    theta[k], theta[k + 1], theta[k + 2] = theta_k, theta_1, theta_2
    a, b = el.right_joints
    theta[a] = math.atan2(y[5], y[2])
    theta[b] = math.atan2(y[7], y[6])
    g = el.dropped
    before = np.eye(4)
    for j in range(g):
        before = before @ dh_row(theta[j], *el.rows[j])
    after = np.eye(4)
    for j in range(g + 1, 6):
        after = after @ dh_row(theta[j], *el.rows[j])
    A_g = _inverse(before) @ H @ _inverse(after)
    theta[g] = math.atan2(A_g[1, 0], A_g[0, 0])
    return theta


def frames_at_zero(pre: NDArray[np.float64]) -> NDArray[np.float64]:
    """The frames (7, 4, 4) of a chain of 4x4 rows at q = 0: products of its first rows."""
    out = np.empty((7, 4, 4))
    current = np.eye(4)
    for j in range(7):
        current = current @ pre[j]
        out[j] = current
    return out


def wrap(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angles wrapped to (-pi, pi]."""
    return np.asarray(-((-q + math.pi) % TWO_PI - math.pi))


def ratio_angle(m: NDArray[np.float64], axis: int) -> float:
    """The angle whose half-angle tangent is the ratio of consecutive monomials along ``axis``
    of m (4, 3) ~ x4^i x5^j: 2 atan2(next, this) on the pair of largest size."""
    pairs = (m[:-1, :], m[1:, :]) if axis == 0 else (m[:, :-1], m[:, 1:])
    size = pairs[0] ** 2 + pairs[1] ** 2
    index = np.unravel_index(int(np.argmax(size)), size.shape)
    return 2.0 * math.atan2(float(pairs[1][index]), float(pairs[0][index]))


def choose_arrangement(solver: EliminatingSolver, poses: int = 12) -> Arrangement:
    """The arrangement whose matrix polynomial is regular and which recovers the most sample
    solutions (joint vectors drawn with a fixed seed; FK gives their poses) on the exact chain,
    ties broken by the polynomial's conditioning."""
    rng = np.random.default_rng(16)
    samples = rng.uniform(-math.pi, math.pi, size=(poses, 6))
    targets = [_inverse(solver.table.base) @ solver.table.fk(q) @ _inverse(solver.table.tool)
               for q in samples]
    best: tuple[float, float] | None = None
    choice: Arrangement | None = None
    for reversed_ in (False, True):
        for k in (1, 2, 0):
            arrangement = Arrangement(reversed_, k)
            _, el = solver._eliminator(arrangement)
            regular = regularity(solver, el, targets[0], arrangement)
            if regular < SINGULAR_PENCIL:
                continue
            recovered = 0
            for q, T_dh in zip(samples, targets, strict=True):
                cands = candidates(solver, T_dh, arrangement, el)
                if cands.shape[0] and np.min(np.max(np.abs(wrap(cands - q)), axis=1)) < 1e-6:
                    recovered += 1
            score = (recovered, regular)
            if best is None or score > best:
                best, choice = score, arrangement
    if choice is None:
        raise FamilyError(f"{solver.table.name}: every elimination's matrix polynomial is "
                          "singular")
    return choice


def regularity(solver: EliminatingSolver, el: Elimination, T_dh: NDArray[np.float64],
                arrangement: Arrangement) -> float:
    """Smallest singular value of M(x3) over its norm at two generic x3."""
    model = el.model
    target = _inverse(T_dh) if arrangement.reversed else T_dh
    H = _inverse(model.D0) @ target @ _inverse(model.E)
    H[:3, 3] /= model.scale
    A, B, C, _, _ = el.pencil(H)
    values = []
    for x in (0.7, -1.3):
        M = A * x * x + B * x + C
        s = np.linalg.svd(M, compute_uv=False)
        values.append(s[-1] / s[0])
    return float(min(values))
