"""How the general 6R solver eliminates (:mod:`dhkin.ik.general6r`): the arrangements and the
choice of one per table at build (the candidates themselves are compiled:
``cpp/dhkin/general6r/candidates.hpp``).

Poses T_dh are DH frame 0 -> DH frame 6 of the exact chain, metres; angles in rad.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.errors import FamilyError
from dhkin.ik.general6r_elimination import Elimination
from dhkin.ik.general6r_model import Model, _inverse
from dhkin.ik.inputs import TWO_PI
from dhkin.tolerances import DEFAULT_TOLERANCE


class EliminatingSolver(Protocol):
    """What the functions here read of a :class:`dhkin.ik.general6r.General6RSolver` (named
    by this protocol, so that this module does not import the solver's)."""

    table: DHTable
    arrangement: Arrangement
    elimination: Elimination
    offset: NDArray[np.float64]
    direction: NDArray[np.float64]

    def _eliminator(self, arrangement: Arrangement) -> tuple[Model, Elimination]: ...

    def core_for(self, arrangement: Arrangement, elimination: Elimination,
                 others: Sequence[tuple[Arrangement, Elimination]] = ()) -> Any: ...

    def compiled_candidates(self, T_dh: NDArray[np.float64], core: Any = None
                            ) -> NDArray[np.float64]: ...

    lever: float

    @staticmethod
    def verification_tolerance(tolerance: float, lever: float) -> float: ...

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


#: Chain evaluations a start costs when its root is settled (cpp/dhkin/general6r/roots.hpp,
#: settle): one that verifies reaches the rounding within full_steps.hpp's kFullSteps (4) full
#: Newton steps from an eigenvalue's start; one that verifies nothing runs Newton's whole
#: newton.hpp kMaxSteps (30) before it is given up. Measured per start on the Kinova Gen3 6-DoF
#: (random poses, settle alone): ~3 us against ~39 us.
VERIFIED_START_EVALUATIONS = 4
FAILED_START_EVALUATIONS = 30


def rank_arrangements(solver: EliminatingSolver, poses: int = 12) -> list[Arrangement]:
    """The arrangements whose matrix polynomial is regular, best first: the one whose solver
    returns the most sample solutions (joint vectors drawn with a fixed seed; FK gives their
    poses) among its verified roots on the exact chain, ties broken by the fewest chain
    evaluations its starts cost (VERIFIED_START_EVALUATIONS a start that verifies,
    FAILED_START_EVALUATIONS one that does not), then by the polynomial's conditioning. The
    first solves every pose; the others, which eliminate other joints, solve the poses where a
    root is singular as well (``settled_roots``, cpp/dhkin/general6r/solver.hpp).

    A sample counts as returned when it is among the roots the arrangement's own solver verifies
    (its starts refined by Newton, as every pose is solved), not when a raw start lies within
    1e-6 rad of it: on an arm a hair from a family (the Kinova Gen3 6-DoF's near-spherical
    wrist) the starts are farther off in every arrangement and every arrangement returns every
    sample, so the raw count (1 of 12 samples against 0) chose the reversed k = 1 arrangement,
    whose 4.5 starts a pose that verify nothing each run Newton's whole budget: 2.7 times the
    forward one's time for the same roots (docs/general6r.md, "Near-family arms"). Starts count
    too: eigenvalues shared by several roots give a start per root and cost a split (on the
    CRX-10iA every eigenvalue of the reversed k = 1 arrangement is shared by two roots, none of
    the forward one's)."""
    rng = np.random.default_rng(16)
    samples = rng.uniform(-math.pi, math.pi, size=(poses, 6))
    targets = [_inverse(solver.table.base) @ solver.table.fk(q) @ _inverse(solver.table.tool)
               for q in samples]
    verification = solver.verification_tolerance(DEFAULT_TOLERANCE, solver.lever)
    scored: list[tuple[tuple[float, float, float], int, Arrangement]] = []
    for reversed_ in (False, True):
        for k in (1, 2, 0):
            arrangement = Arrangement(reversed_, k)
            _, el = solver._eliminator(arrangement)
            regular = regularity(solver, el, targets[0], arrangement)
            if regular < SINGULAR_PENCIL:
                continue
            recovered, failed, starts = 0, 0, 0
            core = solver.core_for(arrangement, el)
            for q, T_dh in zip(samples, targets, strict=True):
                T_dh = np.ascontiguousarray(T_dh, dtype=np.float64)
                starts += solver.compiled_candidates(T_dh, core).shape[0]
                roots, _, not_verified, _ = core.roots(T_dh, verification)
                roots = np.asarray(roots)
                failed += int(not_verified)
                if roots.shape[0] and np.min(np.max(np.abs(wrap(roots - q)), axis=1)) < 1e-6:
                    recovered += 1
            evaluations = ((starts - failed) * VERIFIED_START_EVALUATIONS
                           + failed * FAILED_START_EVALUATIONS)
            scored.append(((recovered, -evaluations, regular), -len(scored), arrangement))
    if not scored:
        raise FamilyError(f"{solver.table.name}: every elimination's matrix polynomial is "
                          "singular")
    # best score first; among equal scores the earlier tried (-len(scored) keeps their order)
    return [arrangement for _, _, arrangement in sorted(scored, key=lambda s: s[:2],
                                                          reverse=True)]


def choose_arrangement(solver: EliminatingSolver, poses: int = 12) -> Arrangement:
    """The best arrangement of :func:`rank_arrangements`."""
    return rank_arrangements(solver, poses)[0]


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
