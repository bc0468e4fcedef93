"""The general 6R solver's roots, compiled: Newton on the exact chain from every candidate,
verification, merging of candidates that reach one root, the Jacobian's smallest singular
value (the "singular" flag) and the nearest in-limit 2pi copies (the math is documented in
:mod:`dhkin.ik.general6r`; the candidates come from :mod:`dhkin.ik.compiled.general6r`).

Joint values are URDF joint values (rad); ``chain`` is the exact chain in the layout of
:func:`dhkin.ik.plan.chain_array`; poses are 4 x 4 (or their first 3 rows), metres.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.chain import (
    MAX_JOINT_STEP,
    REFINE_FRACTION,
    _jacobian,
    check,
    fk_frames,
    refine,
)
from dhkin.ik.compiled.general6r_track import moved_target, track
from dhkin.ik.compiled.jit import jit
from dhkin.ik.core import FK_ROUNDING

#: Refinement budget (chain evaluations) per candidate, and the growth Newton may take.
BUDGET = 120
GROWTH = 1e6


#: Refinement budget of a candidate from a near-real complex pair of eigenvalues: a real root
#: of the chain that the model's rounding or its fold made complex lies within the imaginary
#: band (0.1 rad) of the start and converges in a few Newton steps (at a double root linearly,
#: halving per step: from 1e-8 to 1e-12 within ~15); a truly complex one never converges, and
#: the full budget spent on it was most of the refinement's time (0.8 such per pose on the
#: CRX-10iA and xArm6).
PAIR_BUDGET = 40


@jit
def _wrap(x: float) -> float:
    return -((-x + math.pi) % (2.0 * math.pi) - math.pi)


@jit
def smallest_singular(chain: NDArray[np.float64], q: NDArray[np.float64], lever: float,
                      band: float) -> float:
    """The smallest singular value of the exact chain's Jacobian at q, its linear rows divided
    by ``lever`` (m per rad of a point of the arm; rad and m/lever then weigh alike), where it
    is at most ``band``; above it a lower bound may come back instead: |det J| / |J|_F^5 <=
    sigma_min (the other five singular values are at most |J|_F), and the SVD (~20 times the
    cost) runs only where that bound is at most ``band``."""
    frames = np.empty((7, 12))
    fk_frames(chain, q, frames)
    J = np.empty((6, 6))
    _jacobian(chain, frames, J)
    size = 0.0
    for r in range(6):
        for c in range(6):
            if r < 3:
                J[r, c] /= lever
            size += J[r, c] * J[r, c]
    bound = abs(np.linalg.det(J)) / size ** 2.5 if size > 0.0 else 0.0
    if bound > band:
        return bound
    return float(np.linalg.svd(J)[1][5])


@jit
def settle(chain: NDArray[np.float64], T_dh: NDArray[np.float64], starts: NDArray[np.float64],
           origin: NDArray[np.int64], n_starts: int, moves: NDArray[np.float64],
           tolerance: float, lever: float, band: float, roots: NDArray[np.float64],
           errors: NDArray[np.float64], sigmas: NDArray[np.float64]) -> tuple[int, int]:
    """Refine every start on the exact chain, keep those that verify at ``tolerance``, merge
    those that are one root (close, and their midpoint verifies). Only the elimination's
    candidates are starts: the seed never is (it chooses among the roots, it does not find
    them). Starts whose ``origin`` has PAIRED (near-real complex pairs of eigenvalues) get
    PAIR_BUDGET; the roots reached from SHARED ones (a cluster of eigenvalues), and every root
    of a moved pose, have their fold partner probed where their singular value is at most
    PROBE_SIGMA (:func:`fold_partner`: a tilted-UR5 root 0.1 rad from its partner, both
    5e-4 from singular near a singular root, was found no other way); those of a moved pose
    (MOVED, ``moves`` the motions) are brought back by :func:`_back_from_moved`.
    Newton runs until the residual is REFINE_FRACTION of the tolerance on the oracle's FK too
    (:func:`refine_tolerance`). Returns (roots found, candidates that did not verify); sigmas:
    :func:`smallest_singular` of each root (``lever``, ``band``)."""
    target = np.ascontiguousarray(T_dh[:3])
    fixed = np.zeros(6, np.bool_)
    state = np.empty(12)
    q = np.empty(6)
    middle = np.empty(6)
    goal = refine_tolerance(tolerance, lever)
    probe = np.zeros(roots.shape[0], np.bool_)
    # on a moved (ill-conditioned) pose every root near a fold gets its partner probed: the
    # roots there cluster near a singular point, and the moved poses' can collide in pairs
    moved_pose = False
    for index in range(n_starts):
        moved_pose = moved_pose or origin[index] >= MOVED
    found, failed = 0, 0
    for index in range(n_starts):
        for j in range(6):
            q[j] = starts[index, j]
        moved = origin[index] // MOVED
        if moved:
            pose = 0
            while not (moved >> pose) & 1:
                pose += 1
            position, rotation = _back_from_moved(chain, target, q, moves[pose], goal,
                                                  tolerance)
        else:
            budget = PAIR_BUDGET if origin[index] & PAIRED else BUDGET
            refine(chain, target, q, fixed, goal, budget, GROWTH, 0.0)
            position, rotation = check(chain, q, target, state)
        if not (position <= tolerance and rotation <= tolerance):
            failed += 1
            continue
        position, rotation = _polish(chain, target, q, goal, position, rotation)
        for j in range(6):
            q[j] = _wrap(q[j])
        duplicate = _known(chain, target, q, roots, found, tolerance, middle, state)
        if duplicate >= 0:
            probe[duplicate] = probe[duplicate] or (origin[index] & SHARED) != 0 or moved_pose
            continue
        for j in range(6):
            roots[found, j] = q[j]
        errors[found, 0], errors[found, 1] = position, rotation
        sigmas[found] = smallest_singular(chain, q, lever, band)
        probe[found] = (origin[index] & SHARED) != 0 or moved_pose
        found += 1
    # near a fold, the partner of each root with a small singular value (its eliminated joint
    # may equal this one's to the eigenvalues' accuracy)
    partner = np.empty(6)
    known = found
    for index in range(known):
        if found >= roots.shape[0]:
            break
        if not probe[index]:
            continue
        if smallest_singular(chain, roots[index], lever, PROBE_SIGMA) > PROBE_SIGMA:
            continue
        if not fold_partner(chain, target, roots[index], lever, goal, partner):
            continue
        position, rotation = check(chain, partner, target, state)
        if not (position <= tolerance and rotation <= tolerance):
            continue
        position, rotation = _polish(chain, target, partner, goal, position, rotation)
        for j in range(6):
            q[j] = _wrap(partner[j])
        if _known(chain, target, q, roots, found, tolerance, middle, state) >= 0:
            continue
        for j in range(6):
            roots[found, j] = q[j]
        errors[found, 0], errors[found, 1] = position, rotation
        sigmas[found] = smallest_singular(chain, q, lever, band)
        found += 1
    return found, failed


@jit
def _polish(chain: NDArray[np.float64], target: NDArray[np.float64], q: NDArray[np.float64],
            goal: float, position: float, rotation: float) -> tuple[float, float]:
    """A verified root whose residual is still above REFINE_FRACTION of ``goal`` (Newton's
    budget ran out on the way: slow convergence near a fold) refined further, in place, by
    monotone steps; its residuals."""
    if max(position, rotation) <= REFINE_FRACTION * goal:
        return position, rotation
    fixed = np.zeros(6, np.bool_)
    state = np.empty(12)
    trial = q.copy()
    refine(chain, target, trial, fixed, goal, BUDGET, 1.0, 0.0)
    better_position, better_rotation = check(chain, trial, target, state)
    if max(better_position, better_rotation) >= max(position, rotation):
        return position, rotation
    for j in range(6):
        q[j] = trial[j]
    return better_position, better_rotation


@jit
def _back_from_moved(chain: NDArray[np.float64], target: NDArray[np.float64],
                     q: NDArray[np.float64], move: NDArray[np.float64], goal: float,
                     tolerance: float) -> tuple[float, float]:
    """A start of a moved pose (``move``, :mod:`dhkin.ik.general6r_moves`) to a root of the pose
    itself (target), in place; its residuals there. The start is refined on the moved pose
    first (the elimination's start of a nearly singular pose can be off its own root), then
    Newton goes to the pose; where that fails, the moved root is followed back along the path
    (:func:`~.general6r_track.track`). A start that is no root of the moved pose (a complex
    pair's) gets a short direct Newton. (Where Newton carries a root near a singular point to
    a neighbour of its own, the fold partners probed for every root of a moved pose find it.)"""
    fixed = np.zeros(6, np.bool_)
    state = np.empty(12)
    moved = np.empty((3, 4))
    start = q.copy()
    moved_target(move, 1.0, target, moved)
    refine(chain, moved, q, fixed, goal, PAIR_BUDGET, GROWTH, 0.0)
    position, rotation = check(chain, q, moved, state)
    if not (position <= tolerance and rotation <= tolerance):
        for j in range(6):
            q[j] = start[j]
        refine(chain, target, q, fixed, goal, PAIR_BUDGET, GROWTH, 0.0)
        return check(chain, q, target, state)
    root = q.copy()
    refine(chain, target, q, fixed, goal, PAIR_BUDGET, GROWTH, 0.0)
    position, rotation = check(chain, q, target, state)
    if position <= tolerance and rotation <= tolerance:
        return position, rotation
    for j in range(6):
        q[j] = root[j]
    if track(chain, target, q, move, goal, tolerance):
        return check(chain, q, target, state)
    return math.inf, math.inf


@jit
def _known(chain: NDArray[np.float64], target: NDArray[np.float64], q: NDArray[np.float64],
           roots: NDArray[np.float64], found: int, tolerance: float,
           middle: NDArray[np.float64], state: NDArray[np.float64]) -> int:
    """The index of the root among the first ``found`` that q is one root with (within
    MAX_JOINT_STEP, and their midpoint verifies at ``tolerance``), or -1."""
    for other in range(found):
        largest = 0.0
        for j in range(6):
            middle[j] = _wrap(q[j] - roots[other, j])
            largest = max(largest, abs(middle[j]))
        if largest > MAX_JOINT_STEP:
            continue
        for j in range(6):
            middle[j] = roots[other, j] + 0.5 * middle[j]
        position, rotation = check(chain, middle, target, state)
        if position <= tolerance and rotation <= tolerance:
            return other
    return -1


#: Bits of a start's origin (:func:`dhkin.ik.compiled.general6r.candidates`): a near-real
#: complex pair of eigenvalues, a cluster of eigenvalues, the first moved pose (MOVED << p:
#: moved pose p; :func:`dhkin.ik.compiled.general6r.all_candidates`).
PAIRED, SHARED, MOVED = 1, 2, 4


#: Roots whose smallest singular value (scaled Jacobian) is at most this get their fold
#: partner probed (:func:`fold_partner`). Near a fold two roots lie d ~ 2 sigma / kappa apart
#: along the weak direction (kappa: the curvature there, ~1 rad^-1 on arms of order-one
#: lengths); where that direction has no component along the eliminated joint, their
#: eliminated joints differ only to second order, ~d^2, and the eigenvalues (accurate to
#: ~1e-6 at a CRX-10iA pose near q5 = 0) can no longer tell them apart: a pair 8e-3 rad
#: apart (sigma 1.5e-4) shared an eigenvalue to 1.7e-7. Above 1e-2, d^2 > 1e-4.
PROBE_SIGMA = 1e-2


#: Step (rad) of the central difference of the Jacobian along the weak direction in
#: :func:`fold_partner` (second-derivative error ~h^2, rounding ~eps / h).
PROBE_STEP = 1e-5


@jit
def fold_partner(chain: NDArray[np.float64], target: NDArray[np.float64],
                 q: NDArray[np.float64], lever: float, goal: float,
                 out: NDArray[np.float64]) -> bool:
    """The fold partner of the root q, refined by Newton into out: along the Jacobian's
    weakest right singular vector v (sigma, left vector u; linear rows over ``lever``), the
    pose error is ~ t sigma u + t^2 / 2 kappa u with kappa = u . d2F[v, v] (a central
    difference of the Jacobian along v), zero again at t = -2 sigma / kappa. False where
    that lies beyond MAX_JOINT_STEP (no fold partner near) or kappa vanishes."""
    frames = np.empty((7, 12))
    J = np.empty((6, 6))
    fk_frames(chain, q, frames)
    _jacobian(chain, frames, J)
    for r in range(3):
        for c in range(6):
            J[r, c] /= lever
    U, S, Vt = np.linalg.svd(J)
    sigma = S[5]
    curvature = 0.0
    for sign in (1.0, -1.0):
        for j in range(6):
            out[j] = q[j] + sign * PROBE_STEP * Vt[5, j]
        fk_frames(chain, out, frames)
        _jacobian(chain, frames, J)
        for r in range(6):
            row = 0.0
            for c in range(6):
                row += J[r, c] * Vt[5, c]
            if r < 3:
                row /= lever
            curvature += sign * U[r, 5] * row / (2.0 * PROBE_STEP)
    if not abs(curvature) > 0.0:
        return False
    t = -2.0 * sigma / curvature
    if not abs(t) <= MAX_JOINT_STEP:
        return False
    for j in range(6):
        out[j] = q[j] + t * Vt[5, j]
    fixed = np.zeros(6, np.bool_)
    refine(chain, target, out, fixed, goal, BUDGET, GROWTH, 0.0)
    return True


@jit
def refine_tolerance(tolerance: float, lever: float) -> float:
    """The tolerance Newton is given (it stops at REFINE_FRACTION of it) so that a root's
    residual is at most REFINE_FRACTION of ``tolerance`` on the oracle's FK as well: less the
    FK rounding margin (FK_ROUNDING per metre of ``lever``) at that scale."""
    return max(tolerance - FK_ROUNDING * lever / REFINE_FRACTION, 0.5 * tolerance)


@jit
def nearest_copies(chain: NDArray[np.float64], T: NDArray[np.float64],
                   roots: NDArray[np.float64], errors: NDArray[np.float64], found: int,
                   reference: NDArray[np.float64], lower: NDArray[np.float64],
                   upper: NDArray[np.float64], slack: float, tolerance: float, lever: float,
                   singular: NDArray[np.bool_], band: float, out_q: NDArray[np.float64],
                   out_errors: NDArray[np.float64], kept: NDArray[np.int64]) -> int:
    """Per root, per joint its 2pi copy nearest ``reference`` within the limits widened by
    ``slack`` (a value that far outside a limit counts as on it, as in the families: set onto
    it, the other joints refined by monotone Newton steps with it held there (a root on the
    limit up to rounding is then exact again), and verified on ``chain`` against T (3 or 4
    rows) at ``tolerance``); roots without such a copy, or that no longer verify, are left
    out. A ``singular`` root lies anywhere in a cloud of near-solutions ~``band`` wide (its
    position there is Newton's, 1e-8 rad off the reference's on a CRX-10iA root on two
    limits): its slack is ``band``. Writes the kept rows in order into out_q, out_errors and
    their root indices into kept; returns their number."""
    two_pi = 2.0 * math.pi
    target = np.ascontiguousarray(T[:3])
    state = np.empty(12)
    q = np.empty(6)
    held = np.zeros(6, np.bool_)
    clipped = np.empty(6)
    count = 0
    for k in range(found):
        inside, moved = True, False
        margin = max(slack, band) if singular[k] else slack
        for j in range(6):
            held[j] = False
            value = roots[k, j] + two_pi * np.rint((reference[j] - roots[k, j]) / two_pi)
            if value < lower[j] - margin:
                value += two_pi * math.ceil((lower[j] - margin - value) / two_pi)
            if value > upper[j] + margin:
                value -= two_pi * math.ceil((value - upper[j] - margin) / two_pi)
            if value < lower[j] - margin or value > upper[j] + margin:
                inside = False
                break
            if value < lower[j]:
                value, moved, held[j] = lower[j], True, True
            elif value > upper[j]:
                value, moved, held[j] = upper[j], True, True
            q[j] = value
        if not inside:
            continue
        position, rotation = errors[k, 0], errors[k, 1]
        if moved:
            for j in range(6):
                clipped[j] = q[j]
            refine(chain, target, q, held, refine_tolerance(tolerance, lever), BUDGET, 1.0,
                   0.0)
            for j in range(6):
                q[j] = min(max(q[j], lower[j]), upper[j])
            position, rotation = check(chain, q, target, state)
            if not (position <= tolerance and rotation <= tolerance):
                # the held joints leave Newton no way back (a singular root): as it was
                for j in range(6):
                    q[j] = clipped[j]
                position, rotation = check(chain, q, target, state)
            if not (position <= tolerance and rotation <= tolerance):
                continue
        for j in range(6):
            out_q[count, j] = q[j]
        out_errors[count, 0], out_errors[count, 1] = position, rotation
        kept[count] = k
        count += 1
    return count
