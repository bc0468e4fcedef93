"""A refined table's roots beyond the ideal model's branches: duplicates merged or split into twins,
corrected-target retries of lost branches, extra roots placed, and the root in the seed's basin.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled import chain as exact
from dhkin.ik.compiled import continuation
from dhkin.ik.compiled.bands import CLAMPED, MERGE_ANGLE
from dhkin.ik.compiled.copies import wrap
from dhkin.ik.compiled.jit import jit
from dhkin.ik.compiled.plan import (
    PLAN,
    _family,
    _finite,
    _known,
    _seed_distance,
    family_outputs,
    model_path,
)


@jit
def _seed_root(plan: NDArray[np.float64], chain: NDArray[np.float64], T: NDArray[np.float64],
               seed: NDArray[np.float64], tolerance: float, q: NDArray[np.float64],
               ok: NDArray[np.bool_], errors: NDArray[np.float64]) -> None:
    """A refined table's seed within one maximal Newton step of the pose (rotation error at
    most MAX_JOINT_STEP, position error at most that times the lever) is a start as good as
    the ideal model's closed form, which is up to the family band off the exact chain: a
    monotone, damped descent from it (SEED_DAMPING) finds the root in its basin. Near a
    singularity the exact chain can have roots the ideal model has not (a wrist 0.175 mm from
    spherical: one at q5 ~ 0 beside the two at q5 ~ +-0.03); such a root, when it is nearer
    the seed than the solution of the branch it lies nearest, takes that branch's slot (its
    solution moves to the nearest empty slot, if any)."""
    B, n = q.shape
    state = np.empty(12)
    position, rotation = exact.check(chain, seed, T, state)
    if rotation > exact.MAX_JOINT_STEP or position > exact.MAX_JOINT_STEP * plan[PLAN.lever]:
        return
    root = seed.copy()
    fixed = np.zeros(n, np.bool_)
    position, rotation = exact.refine(chain, T, root, fixed, tolerance,
                                      4 * exact.MAX_STEPS, 1.0,
                                      exact.SEED_DAMPING)
    if not exact.within(position, rotation, tolerance):
        return
    for j in range(n):
        if chain[j, exact.JOINT.revolute] != 0.0:
            root[j] = wrap(root[j])
    if _known(chain, q, ok, root):
        return
    slot, nearest = -1, math.inf
    for b in range(B):
        if ok[b]:
            distance = _seed_distance(chain, q[b], root)
            if distance < nearest:
                slot, nearest = b, distance
    if slot < 0:
        slot = 0
    elif _seed_distance(chain, root, seed) >= _seed_distance(chain, q[slot], seed):
        return
    else:
        for k in range(1, B):  # the displaced solution to the nearest empty slot
            if not ok[slot ^ k]:
                for j in range(n):
                    q[slot ^ k, j] = q[slot, j]
                ok[slot ^ k] = True
                errors[slot ^ k, 0], errors[slot ^ k, 1] = errors[slot, 0], errors[slot, 1]
                break
    for j in range(n):
        q[slot, j] = root[j]
    ok[slot] = True
    errors[slot, 0], errors[slot, 1] = position, rotation


@jit
def _place_extras(chain: NDArray[np.float64], T: NDArray[np.float64],
                  extra: NDArray[np.float64], extra_ok: NDArray[np.bool_],
                  extra_flags: NDArray[np.uint8], q: NDArray[np.float64],
                  ok: NDArray[np.bool_], flags: NDArray[np.uint8],
                  errors: NDArray[np.float64], reach: int) -> None:
    """Each verified extra root (extra_ok) that no slot holds yet goes to the first empty slot
    among b ^ 0, b ^ 1, ..., b ^ (reach - 1) (own, wrist twin, elbow pair, shoulder partners)."""
    B, n = q.shape
    state = np.empty(12)
    for b in range(B):
        if not extra_ok[b] or _known(chain, q, ok, extra[b]):
            continue
        for k in range(reach):
            slot = b ^ k
            if not ok[slot]:
                for j in range(n):
                    q[slot, j] = extra[b, j]
                ok[slot] = True
                flags[slot] = extra_flags[b]
                errors[slot, 0], errors[slot, 1] = exact.check(chain, q[slot], T, state)
                break


@jit
def _merge_duplicates(chain: NDArray[np.float64], T: NDArray[np.float64],
                      seed: NDArray[np.float64], q: NDArray[np.float64], ok: NDArray[np.bool_],
                      errors: NDArray[np.float64], tolerance: float,
                      member: NDArray[np.bool_]) -> None:
    """Branches that answered with one solution (a refined table's two starts converging to one
    root; polished clamps of an exact table at a fold; members of one singular family): the
    second looks for the twin root it lost (:func:`.chain.find_twin`) and keeps it when that is
    a new solution; else it is merged into the first, which keeps whichever of the two lies
    nearer the seed (both verified: at a fold the pose fixes the joints only to ~sqrt(tolerance),
    and the answer is the one nearest the seed). No twin search for a ``member`` of a singular
    family (it held the seed's free joint): every neighbour of it on the family would pass for
    a twin."""
    B, n = q.shape
    twin = np.empty(n)
    state = np.empty(12)
    for a in range(B):
        if not ok[a]:
            continue
        for b in range(a + 1, B):
            if not ok[b]:
                continue
            same = True
            for j in range(n):
                difference = q[a, j] - q[b, j]
                if chain[j, exact.JOINT.revolute] != 0.0:
                    difference = wrap(difference)
                same = same and abs(difference) <= 2.0 * MERGE_ANGLE
            if same:
                ok[b] = False
                if not (member[a] or member[b]) and continuation.find_twin(
                        chain, T, q[a], tolerance, 2.0 * MERGE_ANGLE, q, ok, twin):
                    ok[b] = True
                    for j in range(n):
                        q[b, j] = wrap(twin[j]) if chain[j, exact.JOINT.revolute] else twin[j]
                    errors[b, 0], errors[b, 1] = exact.check(chain, q[b], T, state)
                    continue
                ok[b] = False
                if _seed_distance(chain, q[b], seed) < _seed_distance(chain, q[a], seed):
                    for j in range(n):
                        q[a, j] = q[b, j]
                    errors[a, 0], errors[a, 1] = errors[b, 0], errors[b, 1]


#: Corrected-target retries of a lost branch (each one family solve and one refinement).
CORRECTIONS = 2


@jit
def _retry_corrected(plan: NDArray[np.float64], g: NDArray[np.float64],
                     chain: NDArray[np.float64], T: NDArray[np.float64],
                     T_at: NDArray[np.float64], seed: NDArray[np.float64], clamp: float,
                     tolerance: float,
                     regular: NDArray[np.float64], valid: NDArray[np.bool_],
                     near: NDArray[np.uint8], q: NDArray[np.float64], ok: NDArray[np.bool_],
                     errors: NDArray[np.float64], flags: NDArray[np.uint8],
                     scratch: NDArray[np.float64]) -> None:
    """A refined table's branch that did not settle, or that settled on another branch's
    solution, is tried again from the ideal model's closed form for the *corrected* target
    T' = FK_ideal(q_c) FK_exact(q_c)^-1 T, q_c its candidate: to first order the ideal model
    then sees the pose where the exact chain does (near a fold of the arm, where the ideal
    model's roots merge or vanish while the exact chain's do not, this moves the start to the
    right side of the fold). Up to CORRECTIONS times, each candidate refined and verified."""
    B, n = q.shape
    ideal, _ = model_path(plan)
    corrected = np.empty((3, 4))
    candidates, c_valid, c_flags, c_near, c_why = family_outputs(n)
    fixed = np.zeros(n, np.bool_)
    state = np.empty(12)
    for b in range(B):
        if ok[b] or not _finite(regular[b]) or not (valid[b] or (near[b] & CLAMPED) != 0):
            continue
        start = regular[b].copy()
        for _ in range(CORRECTIONS):
            _corrected_target(ideal, chain, start, T, corrected)
            _family(plan, g, corrected, seed, 0, clamp, candidates, c_valid, c_flags,
                    c_near, c_why, scratch)
            if not _finite(candidates[b]):
                break
            for j in range(n):
                start[j] = candidates[b, j]
            trial = start.copy()
            exact.refine(chain, T_at, trial, fixed, tolerance, 4 * exact.MAX_STEPS,
                         exact.GROWTH, 0.0)
            position, rotation = exact.check(chain, trial, T_at, state)
            if exact.within(position, rotation, tolerance):
                if not _known(chain, q, ok, trial):
                    for j in range(n):
                        q[b, j] = wrap(trial[j]) if chain[j, exact.JOINT.revolute] else trial[j]
                    ok[b] = True
                    errors[b, 0], errors[b, 1] = exact.check(chain, q[b], T_at, state)
                    flags[b] = c_flags[b]
                break


@jit
def _corrected_target(ideal: NDArray[np.float64], chain: NDArray[np.float64],
                      q: NDArray[np.float64], T: NDArray[np.float64],
                      out: NDArray[np.float64]) -> None:
    """out (3, 4) = FK_ideal(q) FK_exact(q)^-1 T (rigid 3 x 4 frames)."""
    model = np.empty(12)
    real = np.empty(12)
    exact.fk(ideal, q, model)
    exact.fk(chain, q, real)
    A, E = np.eye(4), np.eye(4)
    for r in range(3):
        for c in range(4):
            A[r, c] = model[4 * r + c]
            E[r, c] = real[4 * r + c]
    target = np.eye(4)
    target[:3, :] = T
    inverse = np.eye(4)
    inverse[:3, :3] = E[:3, :3].T
    for r in range(3):
        inverse[r, 3] = -(E[0, r] * E[0, 3] + E[1, r] * E[1, 3] + E[2, r] * E[2, 3])
    result = A @ inverse @ target
    for r in range(3):
        for c in range(4):
            out[r, c] = result[r, c]
