"""The seed's member of a curve of solutions, compiled: the general 6R solver's singular roots
moved towards the seed along the solutions (docs/general6r.md, "The seed"), never a root of the
seed's own.

Joint values are URDF joint values (rad); ``chain`` is the exact chain to the point verified
(:func:`dhkin.ik.plan.chain_array` layout); targets are that point's pose in DH frame 0 (3 or 4
rows, metres).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.chain import (
    MAX_JOINT_STEP,
    MAX_STEPS,
    SEED_DAMPING,
    _jacobian,
    check,
    fk_frames,
    refine,
)
from dhkin.ik.compiled.general6r_roots import (
    GROWTH,
    _wrap,
    refine_tolerance,
    smallest_singular,
)
from dhkin.ik.compiled.jit import jit

#: Trial steps of :func:`walk` (a failed step is retried a quarter as long): on a curved
#: solution set the midpoint of a chord of length L lies ~kappa L^2 / 8 off it, so long steps
#: fail where short ones pass (a CRX-10iA pose at q5 = 0 whose members 1.6 rad apart needed
#: steps of ~0.05 rad); 100 trials walk ~3 rad at that length, beyond any seed within the
#: continuity distance of a member.
WALK_STEPS = 100

#: A step of :func:`walk` from a point on a curve of solutions (the Jacobian's smallest
#: singular value at most the tolerance: a step of up to a radian along the weakest direction
#: moves the pose less than the tolerance at first order, and a point of a true curve shows
#: ~1e-15) stays on that curve when the chord's midpoint, refined by Newton, lands within
#: CHORD_BEND of the chord's length of it: on a curve of radius r a chord of length L bends
#: L^2 / (8 r) from it, within a quarter of L for every chord up to the curve's diameter; a
#: jump between two distinct roots puts the refined midpoint on one of them, half the chord
#: from it (or nowhere). From an isolated root whose smallest singular value is above the
#: tolerance (near a fold: 3e-8 on the IRB 1200's split elbow roots, whose near-solutions
#: join them in a valley within the tolerance) the chord's midpoint itself must verify.
CHORD_BEND = 0.25


@jit
def walk(chain: NDArray[np.float64], T: NDArray[np.float64], q: NDArray[np.float64],
         seed: NDArray[np.float64], tolerance: float, lever: float, band: float,
         error: NDArray[np.float64]) -> None:
    """A singular root q (in place) moved along the solutions towards ``seed``: the member of a
    curve of solutions nearest the seed where a joint is free (docs/general6r.md). Each step
    goes along the Jacobian's weak directions (singular values of the Jacobian, linear rows
    over ``lever``, within ``band``) by the seed's offset projected onto them, at most
    MAX_JOINT_STEP per joint, is refined by Newton on the exact chain (target T, 3 or 4 rows)
    and kept while it verifies at ``tolerance``, comes nearer the seed and stays on the same
    root (:data:`CHORD_BEND`: on a curve of solutions the step's refined midpoint lies near
    its chord; elsewhere the midpoint itself verifies, the merging rule: near a fold Newton
    could land on a distinct root nearer the seed); a failed step is retried a quarter as long,
    down to ``band`` (:data:`WALK_STEPS` trials), and the walk ends where the seed's offset
    along the weak directions is within ``tolerance`` (rad). Where the pose is only
    near-singular Newton returns to the root, or lands on another one (near a fold), and q
    does not move.
    error: the residuals (position, rotation) of the final q, where it moved."""
    target = np.ascontiguousarray(T[:3])
    fixed = np.zeros(6, np.bool_)
    state = np.empty(12)
    frames = np.empty((7, 12))
    J = np.empty((6, 6))
    step = np.empty(6)
    offset = np.empty(6)
    trial = np.empty(6)
    middle = np.empty(6)
    distance = 0.0
    for j in range(6):
        distance += _wrap(q[j] - seed[j]) ** 2
    length = MAX_JOINT_STEP
    _walk(chain, target, q, seed, tolerance, lever, band, error, distance, length, fixed,
          state, frames, J, step, offset, trial, middle, np.empty(6))
    # polish: monotone Newton steps from the member reached (Newton converges slowly at a
    # singular root; these bring its residual to REFINE_FRACTION of the tolerance)
    for j in range(6):
        trial[j] = q[j]
    refine(chain, target, trial, fixed, refine_tolerance(tolerance, lever), 4 * MAX_STEPS,
           1.0, 0.0)
    position, rotation = check(chain, trial, target, state)
    if position <= tolerance and rotation <= tolerance and max(position, rotation) < max(
            error[0], error[1]):
        for j in range(6):
            q[j] = _wrap(trial[j])
        error[0], error[1] = position, rotation


@jit
def _walk(chain: NDArray[np.float64], target: NDArray[np.float64], q: NDArray[np.float64],
          seed: NDArray[np.float64], tolerance: float, lever: float, band: float,
          error: NDArray[np.float64], distance: float, length: float,
          fixed: NDArray[np.bool_], state: NDArray[np.float64], frames: NDArray[np.float64],
          J: NDArray[np.float64], step: NDArray[np.float64], offset: NDArray[np.float64],
          trial: NDArray[np.float64], middle: NDArray[np.float64],
          midpoint: NDArray[np.float64]) -> None:
    """:func:`walk`'s steps (its work arrays passed in)."""
    for _ in range(WALK_STEPS):
        fk_frames(chain, q, frames)
        _jacobian(chain, frames, J)
        for r in range(3):
            for c in range(6):
                J[r, c] /= lever
        _, sigma, Vt = np.linalg.svd(J)
        for j in range(6):
            offset[j] = _wrap(seed[j] - q[j])
            step[j] = 0.0
        for w in range(6):
            if sigma[w] <= band:
                along = 0.0
                for j in range(6):
                    along += Vt[w, j] * offset[j]
                for j in range(6):
                    step[j] += along * Vt[w, j]
        longest = 0.0
        for j in range(6):
            longest = max(longest, abs(step[j]))
        if longest <= tolerance:
            return  # nearer than the tolerance (rad): no step it could verify
        scale = length / longest if longest > length else 1.0
        for j in range(6):
            trial[j] = q[j] + scale * step[j]
        refine(chain, target, trial, fixed, tolerance, 4 * MAX_STEPS, GROWTH, 0.0)
        position, rotation = check(chain, trial, target, state)
        trial_distance = 0.0
        chord = 0.0
        for j in range(6):
            trial_distance += _wrap(trial[j] - seed[j]) ** 2
            chord = max(chord, abs(_wrap(trial[j] - q[j])))
        kept = (position <= tolerance and rotation <= tolerance and trial_distance < distance
                and chord > 0.0)
        if kept and sigma[5] > tolerance:  # an isolated (near-)singular root's cloud
            for j in range(6):
                middle[j] = q[j] + 0.5 * _wrap(trial[j] - q[j])
            between_position, between_rotation = check(chain, middle, target, state)
            kept = between_position <= tolerance and between_rotation <= tolerance
        elif kept:  # on a curve of solutions
            for j in range(6):
                middle[j] = q[j] + 0.5 * _wrap(trial[j] - q[j])
                midpoint[j] = middle[j]
            refine(chain, target, middle, fixed, tolerance, 4 * MAX_STEPS, 1.0, 0.0)
            between_position, between_rotation = check(chain, middle, target, state)
            moved = 0.0
            for j in range(6):
                moved = max(moved, abs(_wrap(middle[j] - midpoint[j])))
            kept = (between_position <= tolerance and between_rotation <= tolerance
                    and moved <= CHORD_BEND * chord)
        if not kept:
            length = 0.25 * min(length, longest)
            if length <= band:
                return
            continue
        for j in range(6):
            q[j] = _wrap(trial[j])
        distance = trial_distance
        error[0], error[1] = position, rotation
        length = min(2.0 * length, MAX_JOINT_STEP)


#: Interior points (at k / 8 of the way) of a segment from a singular root to the seed's
#: Newton point that must lie on the solutions for the two to be one set of solutions
#: (:func:`on_segment`): a straight segment of solutions (a free pair of coincident axes,
#: q_i +- q_j fixed) passes at all, a chord across a curved set or between two distinct
#: roots fails near its middle.
SEGMENT_POINTS = 7


@jit
def seed_projection(chain: NDArray[np.float64], T: NDArray[np.float64],
                    seed: NDArray[np.float64], tolerance: float, lever: float, band: float,
                    out: NDArray[np.float64], error: NDArray[np.float64]) -> bool:
    """Damped Newton from ``seed`` onto the solutions (the families' seeded refinement), into
    out; whether it verifies at ``tolerance`` and is singular (sigma within ``band``): a
    candidate for the seed's member of a curve, which :func:`on_segment` must tie to a root
    the elimination found (it is never a root of its own)."""
    target = np.ascontiguousarray(T[:3])
    fixed = np.zeros(6, np.bool_)
    state = np.empty(12)
    for j in range(6):
        out[j] = seed[j]
    refine(chain, target, out, fixed, refine_tolerance(tolerance, lever), 4 * MAX_STEPS,
           GROWTH, SEED_DAMPING)
    position, rotation = check(chain, out, target, state)
    error[0], error[1] = position, rotation
    if not (position <= tolerance and rotation <= tolerance):
        return False
    return smallest_singular(chain, out, lever, band) <= band


@jit
def on_segment(chain: NDArray[np.float64], T: NDArray[np.float64], a: NDArray[np.float64],
               b: NDArray[np.float64], tolerance: float, lever: float, band: float) -> bool:
    """Whether the segment from a to b (joint differences wrapped) lies on the solutions: each
    of its :data:`SEGMENT_POINTS` interior points, refined by monotone Newton steps, verifies
    at ``tolerance`` within ``band`` (rad) of where it was. Within the band, not at the point
    itself: the elimination's singular root lies in the cloud of near-solutions around the
    set (~1e-7 rad off a line of solutions on the CRX-10iA), and a chord from it drifts off
    the line by as much times the angle travelled."""
    target = np.ascontiguousarray(T[:3])
    fixed = np.zeros(6, np.bool_)
    state = np.empty(12)
    point = np.empty(6)
    start = np.empty(6)
    goal = refine_tolerance(tolerance, lever)
    for k in range(1, SEGMENT_POINTS + 1):
        t = k / (SEGMENT_POINTS + 1.0)
        for j in range(6):
            start[j] = a[j] + t * _wrap(b[j] - a[j])
            point[j] = start[j]
        refine(chain, target, point, fixed, goal, 4 * MAX_STEPS, 1.0, 0.0)
        position, rotation = check(chain, point, target, state)
        if not (position <= tolerance and rotation <= tolerance):
            return False
        for j in range(6):
            if abs(point[j] - start[j]) > band:
                return False
    return True
