"""Singular families: the member nearest the seed of a one-parameter family of solutions (q1 or q2
free), the nearest member within the joint limits, and whether a family is singular at the
tolerance over half a turn.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled import chain as exact
from dhkin.ik.compiled.bands import CLAMPED, SHOULDER, WRIST
from dhkin.ik.compiled.copies import turn_range
from dhkin.ik.compiled.jit import jit
from dhkin.ik.compiled.plan import (
    PLAN,
    _family,
    _fix_free,
    _seed_distance,
    family_outputs,
    plan_parts,
)
from dhkin.ik.compiled.settle import _settle

#: The nearest member of a one-parameter family (q1 or q2 free): a grid over the whole turn
#: (this half-width, this step, rad) around the seed's value of the free joint: the other joints
#: follow the free one, so the nearest member can be far from the seed's value of it; then
#: golden-section search to
#: MEMBER_PRECISION within a step of the best grid point (the distance has kinks: no
#: derivatives).
MEMBER_HALF_WIDTH = math.pi


MEMBER_STEP = 0.05


MEMBER_GRID = math.ceil(MEMBER_HALF_WIDTH / MEMBER_STEP)


MEMBER_PRECISION = 1e-9


_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


@jit
def _member_distance(plan: NDArray[np.float64], g: NDArray[np.float64],
                     T: NDArray[np.float64], seed: NDArray[np.float64],
                     moved: NDArray[np.float64], free: int, t: float, bits: int, b: int,
                     clamp: float, q: NDArray[np.float64], valid: NDArray[np.bool_],
                     flags: NDArray[np.uint8], near: NDArray[np.uint8],
                     why: NDArray[np.float64], scratch: NDArray[np.float64]) -> float:
    """Squared joint distance (revolute differences wrapped) from the seed of branch b's member
    with the free joint at t; inf where the branch has no such member."""
    moved[free] = t
    # a member that also passes the wrist singularity takes the seed's wrist split there
    _family(plan, g, T, moved, bits | WRIST, clamp, q, valid, flags, near, why, scratch)
    if not valid[b] or (near[b] & bits) != bits:
        return math.inf
    _, chain, _ = plan_parts(plan)
    total = _seed_distance(chain, q[b], seed)
    return total if math.isfinite(total) else math.inf


@jit
def _nearest_member(plan: NDArray[np.float64], g: NDArray[np.float64], T: NDArray[np.float64],
                    seed: NDArray[np.float64], bits: int, b: int, clamp: float,
                    candidate: NDArray[np.float64], scratch: NDArray[np.float64]) -> int:
    """Where the pose leaves q1 (SHOULDER) or q2 (ELBOW) free: branch b's member of the family
    nearest the seed over all joints (the other joints follow the free one: near a second
    singularity they follow it fast), into ``candidate`` (left as it is when none is nearer);
    returns the member's flags (-1 when none)."""
    n = seed.shape[0]
    free = int(plan[PLAN.free_shoulder]) if bits & SHOULDER else int(plan[PLAN.free_elbow])
    q, valid, flags, near, why = family_outputs(n)
    moved = seed.copy()
    best_t, best = seed[free], math.inf
    for k in range(-MEMBER_GRID, MEMBER_GRID + 1):
        t = seed[free] + k * MEMBER_STEP
        value = _member_distance(plan, g, T, seed, moved, free, t, bits, b, clamp, q, valid,
                                 flags, near, why, scratch)
        if value < best:
            best_t, best = t, value
    if best == math.inf:
        return -1
    low, high = best_t - MEMBER_STEP, best_t + MEMBER_STEP
    a = high - _GOLDEN * (high - low)
    c = low + _GOLDEN * (high - low)
    value_a = _member_distance(plan, g, T, seed, moved, free, a, bits, b, clamp, q, valid,
                               flags, near, why, scratch)
    value_c = _member_distance(plan, g, T, seed, moved, free, c, bits, b, clamp, q, valid,
                               flags, near, why, scratch)
    while high - low > MEMBER_PRECISION:
        if value_a <= value_c:
            high, c, value_c = c, a, value_a
            a = high - _GOLDEN * (high - low)
            value_a = _member_distance(plan, g, T, seed, moved, free, a, bits, b, clamp, q,
                                       valid, flags, near, why, scratch)
        else:
            low, a, value_a = a, c, value_c
            c = low + _GOLDEN * (high - low)
            value_c = _member_distance(plan, g, T, seed, moved, free, c, bits, b, clamp, q,
                                       valid, flags, near, why, scratch)
    t = 0.5 * (low + high)
    if _member_distance(plan, g, T, seed, moved, free, t, bits, b, clamp, q, valid, flags,
                        near, why, scratch) > best:
        _member_distance(plan, g, T, seed, moved, free, best_t, bits, b, clamp, q, valid,
                         flags, near, why, scratch)
    for j in range(n):
        candidate[j] = q[b, j]
    return int(flags[b])


#: Moves (rad or m) of a free joint off the seed tried, nearest first, when the seed's member of
#: a singular family lies outside the joint limits.
LIMIT_STEPS = (0.02, -0.02, 0.05, -0.05, 0.1, -0.1, 0.2, -0.2, 0.4, -0.4, 0.8, -0.8)


@jit
def _in_limits(chain: NDArray[np.float64], limits: NDArray[np.float64],
               values: NDArray[np.float64], slack: float) -> bool:
    """Whether some 2pi copy of every joint value lies within the limits (+- slack)."""
    for j in range(values.shape[0]):
        _, count = turn_range(limits[j, 0], limits[j, 1],
                              chain[j, exact.JOINT.revolute] != 0.0, values[j], slack)
        if count == 0:
            return False
    return True


@jit
def _member_in_limits(plan: NDArray[np.float64], g: NDArray[np.float64],
                      chain: NDArray[np.float64], limits: NDArray[np.float64],
                      T: NDArray[np.float64], T_at: NDArray[np.float64],
                      seed: NDArray[np.float64], bits: int, b: int,
                      clamp: float, tolerance: float, candidate: NDArray[np.float64],
                      scratch: NDArray[np.float64], fixed: NDArray[np.bool_],
                      state: NDArray[np.float64]) -> tuple[float, float]:
    """Branch b's seeded candidate with the free joint(s) of ``bits`` moved off the seed by
    LIMIT_STEPS, the first that verifies and lies within the limits, into ``candidate``;
    returns its errors (inf when none)."""
    n = seed.shape[0]
    q, valid, flags, near, why = family_outputs(n)
    moved = seed.copy()
    _fix_free(plan, bits, fixed)
    for step in LIMIT_STEPS:
        for j in range(n):
            moved[j] = seed[j] + (step if fixed[j] else 0.0)
        _family(plan, g, T, moved, bits, clamp, q, valid, flags, near, why, scratch)
        if not valid[b] or (near[b] & bits) != bits:
            continue
        for j in range(n):
            candidate[j] = q[b, j]
        _fix_free(plan, bits, fixed)
        position, rotation = _settle(plan, chain, T_at, candidate, fixed,
                                     (near[b] & CLAMPED) != 0, False, tolerance, state, True)
        if exact.within(position, rotation, tolerance) and _in_limits(
                chain, limits, candidate, tolerance / plan[PLAN.lever]):
            return position, rotation
        _fix_free(plan, bits, fixed)
    return math.inf, math.inf


@jit
def _family_free(plan: NDArray[np.float64], g: NDArray[np.float64],
                 chain: NDArray[np.float64], T: NDArray[np.float64], T_at: NDArray[np.float64],
                 solution: NDArray[np.float64], b: int, clamp: float, tolerance: float,
                 scratch: NDArray[np.float64], state: NDArray[np.float64]) -> bool:
    """Whether the pose leaves the wrist free at the tolerance: branch b's seeded member half a
    turn along the family from ``solution`` (the seed moved by pi on joints 4 and 6) verifies."""
    n = solution.shape[0]
    moved = solution.copy()
    moved[3] += math.pi
    moved[5] += math.pi
    q, valid, flags, near, why = family_outputs(n)
    _family(plan, g, T, moved, WRIST, clamp, q, valid, flags, near, why, scratch)
    if not valid[b] or (near[b] & WRIST) == 0:
        return False
    position, rotation = exact.check(chain, q[b], T_at, state)
    return exact.within(position, rotation, tolerance)
