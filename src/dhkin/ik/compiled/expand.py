"""Step 4 of the pipeline: the in-limit 2pi copies of each branch's solution (every copy, or the one
nearest the seed), re-verified where a limit or the tolerance margin asks.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled import chain as exact
from dhkin.ik.compiled.copies import nearest_turn, placed, turn_range
from dhkin.ik.compiled.jit import jit
from dhkin.ik.compiled.plan import (
    COPY_MARGIN,
    PLAN,
    plan_at_tcp,
    plan_parts,
    verification_tolerance,
)
from dhkin.ik.compiled.pose import at_point, project, tcp_point, to_dh


@jit
def copy_totals(plan: NDArray[np.float64], q: NDArray[np.float64], ok: NDArray[np.bool_],
                tolerance: float, copies: bool, totals: NDArray[np.int64]) -> None:
    """Per branch (B,): how many solutions step 4 can give (every in-limit copy, or 1 when
    ``copies`` is False and the branch has an in-limit copy; 0 for a branch that is not ok)."""
    _, chain, limits = plan_parts(plan)
    slack = tolerance / plan[PLAN.lever]
    for b in range(q.shape[0]):
        total = 1 if ok[b] else 0
        for j in range(q.shape[1]):
            if total == 0:
                break
            _, count = turn_range(limits[j, 0], limits[j, 1],
                                  chain[j, exact.JOINT.revolute] != 0.0, q[b, j], slack)
            total = total * count if copies else min(total, count)
        totals[b] = total


@jit
def expand(plan: NDArray[np.float64], frames: NDArray[np.float64], T: NDArray[np.float64],
           seed: NDArray[np.float64], tolerance: float, copies: bool, q: NDArray[np.float64],
           ok: NDArray[np.bool_], flags: NDArray[np.uint8], errors: NDArray[np.float64],
           out_q: NDArray[np.float64], out_branch: NDArray[np.int16],
           out_flags: NDArray[np.uint8], out_errors: NDArray[np.float64],
           fwork: NDArray[np.float64], iwork: NDArray[np.int64]) -> int:
    """Step 4 for one pose: the solutions in order of branch, then of copy (mixed radix over the
    joints' copies, last joint fastest); with ``copies`` False one per branch, the copy nearest
    the seed. Returns the count, or -1 when out_q has too few rows."""
    n = q.shape[1]
    slack = tolerance / plan[PLAN.lever]
    tolerance = verification_tolerance(plan, tolerance)
    value = fwork[:n]
    state = fwork[n:n + 12]
    T_dh = fwork[n + 12:n + 24].reshape(3, 4)
    projected = fwork[n + 24:n + 36].reshape(3, 4)
    T_at = fwork[n + 36:n + 48].reshape(3, 4)
    point = fwork[n + 48:n + 51]
    _, chain, limits = plan_parts(plan)
    at_chain = chain  # the chain ending at the TCP (plan_at_tcp), made when first needed
    have_target = False
    first, counts, digits = iwork[:n], iwork[n:2 * n], iwork[2 * n:3 * n]
    slot = 0
    for b in range(q.shape[0]):
        if not ok[b]:
            continue
        total = 1
        for j in range(n):
            revolute = chain[j, exact.JOINT.revolute] != 0.0
            if copies:
                first[j], counts[j] = turn_range(limits[j, 0], limits[j, 1], revolute, q[b, j],
                                                 slack)
            else:
                turn, exists = nearest_turn(limits[j, 0], limits[j, 1], revolute, q[b, j],
                                            slack, seed[j])
                first[j], counts[j] = turn, 1 if exists else 0
            total *= counts[j]
            digits[j] = 0
        recheck = max(errors[b, 0], errors[b, 1]) > tolerance - COPY_MARGIN
        for _ in range(total):
            clipped = False
            for j in range(n):
                revolute = chain[j, exact.JOINT.revolute] != 0.0
                shifted = q[b, j] + (2.0 * math.pi * (first[j] + digits[j]) if revolute else 0.0)
                value[j] = placed(limits[j, 0], limits[j, 1], revolute, q[b, j],
                                  first[j] + digits[j])
                clipped = clipped or value[j] != shifted
            position, rotation = errors[b, 0], errors[b, 1]
            keep = True
            if clipped or recheck:
                if not have_target:
                    project(T, projected)
                    to_dh(frames, projected, T_dh)
                    tcp_point(frames, point)
                    at_point(T_dh, point, T_at)
                    _, at_chain, _ = plan_parts(plan_at_tcp(plan, point))
                    have_target = True
                position, rotation = exact.check(at_chain, value, T_at, state)
                keep = exact.within(position, rotation, tolerance)
            if keep:
                if slot >= out_q.shape[0]:
                    return -1
                for j in range(n):
                    out_q[slot, j] = value[j]
                out_branch[slot] = b
                out_flags[slot] = flags[b]
                out_errors[slot, 0], out_errors[slot, 1] = position, rotation
                slot += 1
            for j in range(n - 1, -1, -1):  # next mixed-radix digit, last joint fastest
                digits[j] += 1
                if digits[j] < counts[j]:
                    break
                digits[j] = 0
    return slot
