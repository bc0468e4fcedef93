"""The answer of the general 6R solver (:mod:`dhkin.ik.general6r`) from its verified roots:
the seed's member where a joint is free, the in-limit 2pi copies, values onto the limits.

Joint values are URDF joint values (rad); ``chain`` is the exact chain to the point verified
(:func:`dhkin.ik.plan.chain_array` layout) and ``tip_target`` its target (base_link frame).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.general6r_arrangement import wrap
from dhkin.ik.inputs import TWO_PI
from dhkin.ik.result import FLAG_NAMES, IKBatch, IKSolutions


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
                 tolerance: float, lever: float,
                 limits: tuple[NDArray[np.float64], NDArray[np.float64], float] | None = None
                 ) -> NDArray[np.bool_]:
    """The seed's choice where a joint is free, in place, as the families' seeded candidate
    (the member of the solution family nearest the seed, docs/ik_core.md): each singular root
    moves along the solutions towards the seed (:func:`dhkin.ik.compiled.general6r_members.walk`),
    and is replaced by the point damped Newton reaches from the seed where that point is
    singular, nearer the seed, and tied to the root by a segment of solutions
    (:func:`~dhkin.ik.compiled.general6r_members.on_segment`: a free pair of coincident axes,
    where the weak directions of a cloud of near-solutions make walking stall). The seed is
    never a root of its own: the roots stay those the elimination found. ``limits`` (lower,
    upper, slack; widened to the singular band, the width of a singular root's cloud): a
    root whose member has no 2pi copy within them, where the root itself has, stays where it
    was (a near-singular root on a joint limit). Returns which roots to
    keep: a root that moved onto an earlier one (their midpoint verifies, the merging rule)
    is one root with it."""
    from dhkin.ik.compiled.chain import MAX_JOINT_STEP, check
    from dhkin.ik.compiled.general6r_members import on_segment, seed_projection, walk

    band = singular_band(tolerance)
    target = np.ascontiguousarray(tip_target[:3])
    seed = np.ascontiguousarray(seed, dtype=np.float64)
    projected, projected_error = np.empty(6), np.empty(2)
    reached = seed_projection(chain, target, seed, tolerance, lever, band, projected,
                              projected_error)
    distance_projected = float(np.sum(wrap(projected - seed) ** 2))
    for index in np.flatnonzero(singular):
        found, found_error = roots[index].copy(), errors[index].copy()
        q = np.ascontiguousarray(roots[index])
        walk(chain, target, q, seed, tolerance, lever, band, errors[index])
        if (reached and distance_projected < float(np.sum(wrap(q - seed) ** 2))
                and on_segment(chain, target, q, projected, tolerance, lever, band)):
            q = np.ascontiguousarray(wrap(projected))
            errors[index] = projected_error
            # damped Newton stops near, not at, the member nearest the seed: walk the rest
            walk(chain, target, q, seed, tolerance, lever, band, errors[index])
        margin = max(limits[2], band) if limits is not None else 0.0
        if (limits is not None and not has_copy(limits[0], limits[1], q, margin)
                and has_copy(limits[0], limits[1], found, margin)):
            q, errors[index] = found, found_error
        roots[index] = q
    keep = np.ones(roots.shape[0], np.bool_)
    state = np.empty(12)
    for index in np.flatnonzero(singular):
        for other in range(index):
            if not keep[other]:
                continue
            step = wrap(roots[index] - roots[other])
            if np.max(np.abs(step)) > MAX_JOINT_STEP:
                continue
            position, rotation = check(chain, np.ascontiguousarray(roots[other] + 0.5 * step),
                                       target, state)
            if position <= tolerance and rotation <= tolerance:
                keep[index] = False
                break
    return keep


def distinct_rows(q: NDArray[np.float64], singular: list[bool], chain: NDArray[np.float64],
                  tip_target: NDArray[np.float64], tolerance: float) -> NDArray[np.bool_]:
    """Which rows (k, 6) to keep: a singular row that is one root with an earlier row (within
    MAX_JOINT_STEP, wrapped, and their midpoint verifies at ``tolerance``) is dropped."""
    from dhkin.ik.compiled.chain import MAX_JOINT_STEP, check

    target = np.ascontiguousarray(tip_target[:3])
    state = np.empty(12)
    keep = np.ones(q.shape[0], np.bool_)
    for index in range(q.shape[0]):
        if not singular[index]:
            continue
        for other in range(index):
            step = wrap(q[index] - q[other])
            if not keep[other] or np.max(np.abs(step)) > MAX_JOINT_STEP:
                continue
            position, rotation = check(chain, np.ascontiguousarray(q[other] + 0.5 * step),
                                       target, state)
            if position <= tolerance and rotation <= tolerance:
                keep[index] = False
                break
    return keep


def has_copy(lower: NDArray[np.float64], upper: NDArray[np.float64], q: NDArray[np.float64],
             slack: float) -> bool:
    """Whether every joint of q has a 2pi copy within the limits widened by ``slack``."""
    low, high = lower - slack, upper + slack
    first = np.ceil((low - q) / TWO_PI)
    return bool(np.all(q + TWO_PI * first <= high))


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
                tip_target: NDArray[np.float64], verify: float, lever: float
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], list[frozenset[str]]]:
    """As in the families (docs/ik_core.md, "limits"): a value within tolerance / lever
    outside a joint limit counts as on it: it is set onto the limit, the other joints are
    refined with it held there (monotone Newton steps: a root on the limit up to rounding is
    exact again), and the row is verified again (dropped if it no longer verifies)."""
    clipped = np.clip(q, lower, upper)
    moved = np.flatnonzero(np.any(clipped != q, axis=1))
    if moved.size == 0:
        return q, residuals, flags
    from dhkin.ik.compiled.chain import check, refine
    from dhkin.ik.compiled.general6r_roots import BUDGET, refine_tolerance

    target = np.ascontiguousarray(tip_target[:3])
    state = np.empty(12)
    keep = np.ones(q.shape[0], np.bool_)
    residuals = residuals.copy()
    for row in moved:
        values = np.ascontiguousarray(clipped[row])
        held = np.ascontiguousarray(clipped[row] != q[row])
        refine(chain, target, values, held, refine_tolerance(verify, lever), BUDGET, 1.0, 0.0)
        clipped[row] = np.clip(values, lower, upper)
        position, rotation = check(chain, np.ascontiguousarray(clipped[row]), target, state)
        keep[row] = position <= verify and rotation <= verify
        residuals[row] = position, rotation
    return (clipped[keep], residuals[keep],
            [f for f, k in zip(flags, keep, strict=True) if k])


def pack(results: list[IKSolutions], branch_labels: tuple[Mapping[str, str], ...],
         family: str) -> IKBatch:
    """Single answers (one per pose) as a batch padded to the largest count; ``branch`` is 0
    for every solution (the general solver's one label set)."""
    n_poses = len(results)
    width = max([len(r) for r in results], default=0)
    q = np.zeros((n_poses, width, 6))
    valid = np.zeros((n_poses, width), np.bool_)
    flags = np.zeros((n_poses, width), np.uint8)
    branch = np.full((n_poses, width), -1, np.int16)
    residuals = np.zeros((n_poses, width, 2))
    bits = {name: bit for bit, name in FLAG_NAMES.items()}
    for index, result in enumerate(results):
        count = len(result)
        q[index, :count] = result.q
        valid[index, :count] = True
        branch[index, :count] = 0
        residuals[index, :count] = result.residuals
        for slot, names in enumerate(result.flags):
            flags[index, slot] = sum(bits[name] for name in names)
    return IKBatch(q=q, valid=valid, flags=flags, branch=branch,
                   branch_labels=branch_labels, family=family,
                   residuals=residuals,
                   projection=np.array([r.projection for r in results]),
                   dropped=np.array([r.dropped for r in results], np.int64))

