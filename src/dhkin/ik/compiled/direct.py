"""The direct path: the pipeline's answer for a pose that needs none of its repairs, in a fraction
of its code.

Most poses of an exact-family table (no refinement) are regular: no candidate of the closed form
lies within the seed band of a singularity (no ``near`` bit of a free joint), every candidate
verifies as computed, and no two branches give one solution. For such a pose steps 1-3 of
:func:`.pipeline.solve_branches` reduce to: check and project the pose, solve the family, wrap
and verify each candidate, set the flags. :func:`direct_branches` does exactly that, with the
same calls in the same order, so its answer is the pipeline's bit for bit; for any other pose it
returns False and the caller runs the pipeline (tests compare the two on every pose class).

Why a second entry point: it is faster (no work arrays for seeded candidates, extras or twins are
set up; 35-45 % of the batch time on the built-in exact tables), and it is small. numba compiles a
kernel with everything it calls; the pipeline calls the refinement, continuation and
singular-family searches, ~90 kernels and ~45 s of compilation on a fresh install, the direct
path ~10 kernels. The solver (:mod:`dhkin.ik.solver`) tries the direct path first and compiles
the pipeline when a pose first needs it.
"""

from __future__ import annotations

import math

import numpy as np
from numba.core import types
from numba.core.errors import TypingError
from numba.extending import overload
from numpy.typing import NDArray

from dhkin.ik.compiled import chain as exact
from dhkin.ik.compiled.bands import FREE, MERGE_ANGLE, SHOULDER
from dhkin.ik.compiled.copies import wrap
from dhkin.ik.compiled.expand import copy_totals, expand
from dhkin.ik.compiled.jit import jit_literal
from dhkin.ik.compiled.offset import solve_offset_wrist
from dhkin.ik.compiled.plan import (
    BRANCHES,
    INFO,
    OFFSET_WRIST,
    PLAN,
    POSE_WORK,
    SPHERICAL_WRIST,
    STANFORD,
    _same,
    _value_flags,
    begin_pose,
    plan_parts,
    pose_views,
    verification_tolerance,
    work_sizes,
)
from dhkin.ik.compiled.spherical import solve_spherical_wrist, solve_stanford

#: :func:`direct_one`'s count for a pose the direct path leaves to the pipeline.
DEFER = -2


#: The closed form of each family id.
_SOLVERS = {SPHERICAL_WRIST: solve_spherical_wrist, STANFORD: solve_stanford,
            OFFSET_WRIST: solve_offset_wrist}


def solve_family(kind: int, plan: NDArray[np.float64], g: NDArray[np.float64],
                 T: NDArray[np.float64], seed: NDArray[np.float64], clamp: float,
                 q: NDArray[np.float64], valid: NDArray[np.bool_], flags: NDArray[np.uint8],
                 near: NDArray[np.uint8], why: NDArray[np.float64],
                 scratch: NDArray[np.float64]) -> None:
    """The closed form of family ``kind`` without a seeded joint (:func:`.plan._family` with
    use_seed 0), in compiled code only, where ``kind`` must be a compile-time constant: the
    kernel then contains that family's solver alone."""
    raise NotImplementedError("solve_family runs in compiled code only")


@overload(solve_family)
def _solve_family(kind, plan, g, T, seed, clamp, q, valid, flags, near, why,
                  scratch):
    # numba requires the implementation's parameters to match these, annotations included
    if not isinstance(kind, types.IntegerLiteral) or kind.literal_value not in _SOLVERS:
        raise TypingError(f"solve_family: the family must be a constant among "
                          f"{sorted(_SOLVERS)}, got {kind}")
    solver = _SOLVERS[kind.literal_value]

    def implementation(kind, plan, g, T, seed, clamp, q, valid, flags, near, why,
                       scratch):
        solver(g, T, seed, 0, plan[PLAN.seed_angle], plan[PLAN.seed_length], clamp, q, valid,
               flags, near, why, scratch)

    return implementation


@jit_literal
def direct_branches(kind: int, plan: NDArray[np.float64], frames: NDArray[np.float64],
                    T: NDArray[np.float64], seed: NDArray[np.float64], tolerance: float,
                    q: NDArray[np.float64], ok: NDArray[np.bool_], flags: NDArray[np.uint8],
                    errors: NDArray[np.float64], why: NDArray[np.float64],
                    info: NDArray[np.float64], fwork: NDArray[np.float64],
                    bwork: NDArray[np.bool_], uwork: NDArray[np.uint8]) -> bool:
    """Steps 1-3 of :func:`.pipeline.solve_branches` for a regular pose (see the module
    docstring), with its arguments and outputs; returns False, outputs undefined, for a pose
    that needs the pipeline. A rejected pose or seed is answered here (info[INFO.status])."""
    if plan[PLAN.refine] != 0.0:
        return False
    n = seed.shape[0]
    B = BRANCHES
    tolerance = verification_tolerance(plan, tolerance)
    usable, plan = begin_pose(plan, frames, T, seed, ok, flags, why, info, fwork)
    if not usable:
        return True  # rejected: info[INFO.status] says why, as the pipeline's would
    _, T_dh, T_at, _, state, scratch = pose_views(fwork)
    candidate = fwork[POSE_WORK:POSE_WORK + n]
    valid = bwork[:B]
    near = uwork[:B]
    g, chain, _ = plan_parts(plan)
    clamp = tolerance * (1.0 + plan[PLAN.lever]) + plan[PLAN.deviation]
    solve_family(kind, plan, g, T_dh, seed, clamp, q, valid, flags, near, why, scratch)
    for b in range(B):
        if near[b] & FREE:
            return False  # a seeded candidate to try: the pipeline's step 2
    for b in range(B):
        if not valid[b]:
            continue
        for j in range(n):
            value = q[b, j]
            candidate[j] = wrap(value) if chain[j, exact.JOINT.revolute] != 0.0 else value
        position, rotation = exact.check(chain, candidate, T_at, state)
        if not exact.within(position, rotation, tolerance):
            return False  # to be polished: the pipeline's step 3
        for j in range(n):
            q[b, j] = candidate[j]
        ok[b] = True
        errors[b, 0], errors[b, 1] = position, rotation
        info[INFO.candidates] += 1
    for a in range(B):
        for b in range(a + 1, B):
            if ok[a] and ok[b] and _same(chain, q[a], q[b], 2.0 * MERGE_ANGLE):
                return False  # one solution from two branches: the pipeline merges them
    for b in range(B):
        if ok[b]:
            flags[b] = (flags[b] & SHOULDER) | _value_flags(plan, g, q[b])
            info[INFO.verified] += 1
    info[INFO.best_position], info[INFO.best_rotation] = math.inf, math.inf
    return True


@jit_literal
def direct_one(kind: int, plan: NDArray[np.float64], frames: NDArray[np.float64],
               T: NDArray[np.float64], seed: NDArray[np.float64], tolerance: float, copies: bool,
               out_q: NDArray[np.float64], out_branch: NDArray[np.int16],
               out_flags: NDArray[np.uint8], out_errors: NDArray[np.float64],
               why: NDArray[np.float64], info: NDArray[np.float64], fwork: NDArray[np.float64],
               bwork: NDArray[np.bool_], uwork: NDArray[np.uint8],
               iwork: NDArray[np.int64]) -> int:
    """:func:`.pipeline.solve_one` for a regular pose (same arguments and result); DEFER for a
    pose that needs the pipeline."""
    n = seed.shape[0]
    B = BRANCHES
    q = np.empty((B, n))
    ok = np.empty(B, np.bool_)
    flags = np.empty(B, np.uint8)
    errors = np.empty((B, 2))
    if not direct_branches(kind, plan, frames, T, seed, tolerance, q, ok, flags, errors, why, info,
                           fwork, bwork, uwork):
        return DEFER
    if info[INFO.status] != 0:
        return 0
    return expand(plan, frames, T, seed, tolerance, copies, q, ok, flags, errors, out_q,
                  out_branch, out_flags, out_errors, fwork, iwork)


@jit_literal
def direct_batch(kind: int, plan: NDArray[np.float64], frames: NDArray[np.float64],
                 targets: NDArray[np.float64], seeds: NDArray[np.float64], tolerance: float,
                 copies: bool, q: NDArray[np.float64], ok: NDArray[np.bool_],
                 flags: NDArray[np.uint8], errors: NDArray[np.float64],
                 totals: NDArray[np.int64], why: NDArray[np.float64],
                 info: NDArray[np.float64], done: NDArray[np.bool_]) -> int:
    """:func:`.pipeline.solve_batch` for the regular poses of N: done[i] whether pose i was
    answered (its outputs as solve_batch's); returns how many were not."""
    n = seeds.shape[1]
    f_size, b_size, u_size, _ = work_sizes(n)
    fwork = np.empty(f_size)
    bwork = np.empty(b_size, np.bool_)
    uwork = np.empty(u_size, np.uint8)
    deferred = 0
    for i in range(targets.shape[0]):
        seed = seeds[i] if seeds.shape[0] > 1 else seeds[0]
        done[i] = direct_branches(kind, plan, frames, targets[i], seed, tolerance, q[i], ok[i],
                                  flags[i], errors[i], why[i], info[i], fwork, bwork, uwork)
        if done[i]:
            copy_totals(plan, q[i], ok[i], tolerance, copies, totals[i])
        else:
            deferred += 1
    return deferred
