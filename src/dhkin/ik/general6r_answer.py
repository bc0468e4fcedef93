"""The answer of the general 6R solver (:mod:`dhkin.ik.general6r`) from its verified roots:
the seed's member where a joint is free, the in-limit 2pi copies, values onto the limits.

Joint values are URDF joint values (rad); ``chain`` is the exact chain to the point verified
(:func:`dhkin.ik.plan.chain_array` layout) and ``tip_target`` its target (base_link frame).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.general6r_arrangement import wrap
from dhkin.ik.inputs import TWO_PI

#: The seed's member of a curve of solutions (a joint free at a singular pose) is followed by
#: at most this many steps along the Jacobian's weak directions towards the seed, each refined
#: back onto the solutions by Newton and kept only when it verifies and is nearer the seed.
SEED_STEPS = 12


def singular_band(tolerance: float) -> float:
    """A root is flagged "singular" when the smallest singular value sigma of its Jacobian
    (linear rows divided by the lever, so that rad and m/lever weigh alike) is at most
    sqrt(tolerance): a step delta along the weakest direction moves the pose by about
    sigma delta + delta^2 / 2 (curvature ~1 per rad on the scaled chain), so with sigma <=
    sqrt(tolerance) every point within ~sqrt(tolerance) rad of the root along that direction
    verifies as well: at the tolerance the pose cannot be told from a singular one (a double
    root, or a curve of solutions where a joint is free). 3.2e-5 at the default 1e-9."""
    return math.sqrt(tolerance)


def seed_members(roots: NDArray[np.float64], errors: NDArray[np.float64],
             singular: NDArray[np.bool_], seed: NDArray[np.float64],
             chain: NDArray[np.float64], tip_target: NDArray[np.float64],
             tolerance: float, lever: float) -> None:
    """The seed's choice where a joint is free, in place: each singular root moves along
    the solutions towards the seed, as the families' seeded candidate does (the member of
    the solution family nearest the seed, docs/ik_core.md): steps along the Jacobian's
    weak directions (singular values within :func:`singular_band`) by the seed's offset
    projected onto them, at most MAX_JOINT_STEP per joint, each refined by Newton on the
    exact chain and kept while it verifies, comes nearer the seed and stays on the same
    root (the midpoint of the step verifies too: the rule by which candidates are merged)
    (at most :data:`SEED_STEPS`). Where the pose is only near-singular (no curve of
    solutions) Newton returns to the root, or lands on another root (near a fold: the
    midpoint does not verify), and nothing moves."""
    from dhkin.ik.compiled.chain import MAX_JOINT_STEP, _jacobian, check, fk_frames, refine

    target = np.ascontiguousarray(tip_target[:3])
    band = singular_band(tolerance)
    fixed = np.zeros(6, np.bool_)
    state = np.empty(12)
    frames = np.empty((7, 12))
    J = np.empty((6, 6))
    for index in np.flatnonzero(singular):
        q = roots[index].copy()
        distance = float(np.sum(wrap(q - seed) ** 2))
        for _ in range(SEED_STEPS):
            fk_frames(chain, q, frames)
            _jacobian(chain, frames, J)
            J[:3] /= lever
            _, sigma, Vt = np.linalg.svd(J)
            weak = Vt[sigma <= band]
            step = weak.T @ (weak @ wrap(seed - q))
            longest = float(np.max(np.abs(step)))
            if longest <= 0.0:
                break
            if longest > MAX_JOINT_STEP:
                step *= MAX_JOINT_STEP / longest
            trial = np.ascontiguousarray(q + step)
            refine(chain, target, trial, fixed, tolerance)
            position, rotation = check(chain, trial, target, state)
            trial_distance = float(np.sum(wrap(trial - seed) ** 2))
            if not (position <= tolerance and rotation <= tolerance
                    and trial_distance < distance):
                break
            # the step stays on this root (their midpoint verifies too, the merging rule):
            # near a fold Newton can land on a distinct root nearer the seed instead
            middle = np.ascontiguousarray(q + 0.5 * wrap(trial - q))
            between = check(chain, middle, target, state)
            if not (between[0] <= tolerance and between[1] <= tolerance):
                break
            q, distance = wrap(trial), trial_distance
            errors[index] = position, rotation
        roots[index] = q


def copies(lower: NDArray[np.float64], upper: NDArray[np.float64], q: NDArray[np.float64],
           reference: NDArray[np.float64], every: bool, slack: float
           ) -> list[NDArray[np.float64]]:
    """The 2pi copies of q within the limits widened by ``slack``: the one nearest
    ``reference`` (per joint), or all."""
    lower, upper = lower - slack, upper + slack
    options = []
    for j in range(6):
        first = math.ceil((lower[j] - q[j]) / TWO_PI)
        last = math.floor((upper[j] - q[j]) / TWO_PI)
        values = [q[j] + TWO_PI * n for n in range(first, last + 1)]
        if not values:
            return []
        if not every:
            values = [values[int(np.argmin(np.abs(np.array(values) - reference[j])))]]
        options.append(values)
    grid = np.array(np.meshgrid(*options, indexing="ij")).reshape(6, -1).T
    return list(grid)

def onto_limits(lower: NDArray[np.float64], upper: NDArray[np.float64],
                q: NDArray[np.float64], residuals: NDArray[np.float64],
                flags: list[frozenset[str]], chain: NDArray[np.float64],
                tip_target: NDArray[np.float64], verify: float
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], list[frozenset[str]]]:
    """As in the families (docs/ik_core.md, "limits"): a value within tolerance / lever
    outside a joint limit counts as on it: it is set onto the limit and verified again
    (dropped if it no longer verifies)."""
    clipped = np.clip(q, lower, upper)
    moved = np.flatnonzero(np.any(clipped != q, axis=1))
    if moved.size == 0:
        return q, residuals, flags
    from dhkin.ik.compiled.chain import check

    target = np.ascontiguousarray(tip_target[:3])
    state = np.empty(12)
    keep = np.ones(q.shape[0], np.bool_)
    residuals = residuals.copy()
    for row in moved:
        position, rotation = check(chain, np.ascontiguousarray(clipped[row]), target, state)
        keep[row] = position <= verify and rotation <= verify
        residuals[row] = position, rotation
    return (clipped[keep], residuals[keep],
            [f for f, k in zip(flags, keep, strict=True) if k])
