"""One pose, start to end: the closed-form IK pipeline (batches run the same function per pose).

For a target T (4, 4), base_link -> TCP:

1. check it (:func:`.pose.status`) and project its rotation onto the nearest rotation;
   ``T_dh = base^-1 T (tool tcp)^-1`` is DH frame 0 -> DH frame n;
2. the family's closed form on the *ideal* model (the table's nominal geometry within the band
   of its family, see :mod:`dhkin.ik.family`) gives 8 branch candidates. Where a joint is free
   at a singularity within the seed band (the ``near`` bits: wrist, wrist centre on axis 1 or
   2), the family runs a second time taking that joint from the seed;
3. each candidate is wrapped to (-pi, pi], refined on the exact chain when the table needs it
   (Newton, :func:`.chain.refine`; where that fails, by continuation along a path of models
   from the ideal one to the exact chain, :func:`.chain.refine_along`; a seeded candidate keeps
   its seeded joints fixed) and
   verified by FK on the exact chain: errors at most ``tolerance`` in metres and radians. Where
   the seeded candidate verifies it is the branch's answer (continuous in the seed), else the
   regular one; a branch neither of whose candidates verifies is dropped and counted. The two
   wrist branches of an arm branch that both answer with the seed's wrist are one solution (the
   one with the smaller error). On a refined table, branches that converged to the same
   solution (within 2 MERGE_ANGLE on every joint, mod 2pi) are one;
4. 2pi copies inside the joint limits (:mod:`.copies`): with ``copies`` every copy, else per
   branch the copy nearest the seed. A value within ``slack`` outside a limit is set onto it;
   such a copy, and every copy of a branch whose error is within :data:`COPY_MARGIN` of the
   tolerance, is verified again.

The solver tries :mod:`.direct` first: for a regular pose of an exact-family table (no seeded
candidate, every candidate verifies as computed, no two branches merge) it gives this pipeline's
answer bit for bit with a fraction of its code, and declines every other pose.

``clamp``: reach conditions violated by at most tolerance x (1 + lever) + twice the model
deviation (metres; no deviation for an exact-family table) are clamped onto their boundary,
polished by Newton (from just off the fold where J is singular on it) and verified, not
rejected: a point missing the reach by d can still give a pose within the tolerance, trading
position error for rotation through the wrist (about d / (1 + lever)), so a pose whose joint
values verify is never answered empty. ``slack`` = tolerance / lever, lever = max(1 m,
table scale): the largest move of one joint that keeps the pose within the tolerance.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled import chain as exact
from dhkin.ik.compiled.bands import CLAMPED, ELBOW, FLAG_BAND, FREE, SHOULDER, WRIST
from dhkin.ik.compiled.expand import copy_totals, expand
from dhkin.ik.compiled.jit import jit
from dhkin.ik.compiled.members import _family_free, _in_limits, _member_in_limits, _nearest_member
from dhkin.ik.compiled.plan import (
    BRANCHES,
    INFO,
    OFFSET_WRIST,
    PLAN,
    POSE_WORK,
    SPHERICAL_WRIST,
    STANFORD,
    WHY_SIZE,
    _any,
    _family,
    _finite,
    _fix_free,
    _known,
    _same,
    _size,
    _value_flags,
    begin_pose,
    plan_at_tcp,
    plan_parts,
    pose_views,
    verification_tolerance,
    work_sizes,
)
from dhkin.ik.compiled.roots import _merge_duplicates, _place_extras, _retry_corrected, _seed_root
from dhkin.ik.compiled.settle import _settle, _settle_free


@jit
def solve_branches(plan: NDArray[np.float64], frames: NDArray[np.float64],
                   T: NDArray[np.float64], seed: NDArray[np.float64], tolerance: float,
                   q: NDArray[np.float64], ok: NDArray[np.bool_], flags: NDArray[np.uint8],
                   errors: NDArray[np.float64], why: NDArray[np.float64],
                   info: NDArray[np.float64], fwork: NDArray[np.float64],
                   bwork: NDArray[np.bool_], uwork: NDArray[np.uint8]) -> None:
    """Steps 1-3 for one pose: q (B, n) the branches' verified principal solutions where ok (B,),
    their flags (B,) and errors (B, 2); why (WHY_SIZE,), info (INFO.size,). Work arrays:
    :func:`work_sizes`."""
    n = seed.shape[0]
    B = BRANCHES
    tolerance = verification_tolerance(plan, tolerance)
    usable, plan = begin_pose(plan, frames, T, seed, ok, flags, why, info, fwork)
    if not usable:
        return
    _, T_dh, T_at, _, state, scratch = pose_views(fwork)
    at = POSE_WORK
    seeded_q = fwork[at:at + B * n].reshape(B, n)
    at += B * n
    candidate = fwork[at:at + n]
    at += n
    seeded_why = fwork[at:at + WHY_SIZE]
    valid, seeded_valid, fixed = bwork[:B], bwork[B:2 * B], bwork[2 * B:2 * B + n]
    near, seeded_flags, seeded_near = uwork[:B], uwork[B:2 * B], uwork[2 * B:3 * B]
    g, chain, limits = plan_parts(plan)
    clamp = tolerance * (1.0 + plan[PLAN.lever]) + plan[PLAN.deviation]
    _family(plan, g, T_dh, seed, 0, clamp, q, valid, flags, near, why, scratch)
    wanted = 0
    for b in range(B):
        wanted |= near[b] & FREE
    if wanted != 0:
        _family(plan, g, T_dh, seed, wanted, clamp, seeded_q, seeded_valid, seeded_flags,
                seeded_near, seeded_why, scratch)
    regular = q.copy()
    regular_flags = flags.copy()
    best_position, best_rotation = math.inf, math.inf
    seeded_wrist = bwork[2 * B + n:3 * B + n]
    released = np.zeros(B, np.bool_)
    member = np.zeros(B, np.bool_)  # a seeded member that kept the seed's free joint
    unclamped = np.zeros(B, np.bool_)
    extra = np.empty((B, n))
    extra_ok = np.zeros(B, np.bool_)
    # which seeded candidates verify as computed (wrapped, neither refined nor polished)
    raw_ok = np.zeros(B, np.bool_)
    if wanted != 0 and plan[PLAN.refine] == 0.0:
        for b in range(B):
            if seeded_valid[b] and (seeded_near[b] & wanted) != 0 and _finite(seeded_q[b]):
                for j in range(n):
                    candidate[j] = seeded_q[b, j]
                position, rotation = exact.check(chain, candidate, T_at, state)
                raw_ok[b] = exact.within(position, rotation, tolerance)
    for b in range(B):
        seeded_wrist[b] = False
        tried = False
        bits = seeded_near[b] & wanted
        if bits != 0 and seeded_valid[b]:
            tried = True
            for j in range(n):
                candidate[j] = seeded_q[b, j]
            if bits & (SHOULDER | ELBOW):
                member_flags = _nearest_member(plan, g, T_dh, seed, bits, b, clamp, candidate,
                                               scratch)
                if member_flags >= 0:
                    seeded_flags[b] = member_flags
            _fix_free(plan, bits, fixed)
            # polished only when its wrist partner does not verify as computed either: where
            # the partner does, the pose has picked the partner's side of the singular family
            # and this candidate's miss is real (polishing would carry it onto the partner's
            # member and hide the distinct flip, which the regular candidate then gives)
            position, rotation = _settle(plan, chain, T_at, candidate, fixed,
                                         (seeded_near[b] & CLAMPED) != 0, False,
                                         tolerance, state, not raw_ok[b ^ 1])
            released[b] = not _any(fixed)
            if not released[b] and exact.within(position, rotation, tolerance) and not (
                    _in_limits(chain, limits, candidate, tolerance / plan[PLAN.lever])):
                # the seed's member of the family lies outside the joint limits: the nearest
                # member inside them (the free joint moved off the seed, nearest first)
                kept = candidate.copy()
                position, rotation = _member_in_limits(
                    plan, g, chain, limits, T_dh, T_at, seed, bits, b, clamp, tolerance, candidate,
                    scratch, fixed, state)
                if not exact.within(position, rotation, tolerance):
                    # none inside: the seed's member stands (the limits drop it later), not
                    # the regular candidates, which are other members of the same family
                    for j in range(n):
                        candidate[j] = kept[j]
                    position, rotation = exact.check(chain, candidate, T_at, state)
            if exact.within(position, rotation, tolerance):
                for j in range(n):
                    q[b, j] = candidate[j]
                ok[b] = True
                flags[b] = seeded_flags[b] | bits
                seeded_wrist[b] = (bits & WRIST) != 0
                member[b] = _any(fixed)
                errors[b, 0], errors[b, 1] = position, rotation
            else:
                best_position = min(best_position, position)
                best_rotation = min(best_rotation, rotation)
        long_shot = (not valid[b] and plan[PLAN.refine] != 0.0 and _finite(q[b])
                     and (near[b] & CLAMPED) != 0)
        if ok[b] and released[b] and valid[b] and plan[PLAN.refine] != 0.0:
            # the seeded candidate verified only with its free joint released: the exact chain
            # is not singular here, and the regular candidate may reach another root of the
            # pose (kept as an extra; the seeded root, the one nearest the seed, stays)
            position, rotation = _settle_free(plan, chain, T_at, regular[b], candidate, fixed,
                                              (near[b] & CLAMPED) != 0, False,
                                              tolerance, state)
            if exact.within(position, rotation, tolerance):
                for j in range(n):
                    extra[b, j] = candidate[j]
                extra_ok[b] = True
        if not ok[b] and (valid[b] or long_shot):
            tried = tried or valid[b]
            position, rotation = _settle_free(plan, chain, T_at, q[b], candidate, fixed,
                                              (near[b] & CLAMPED) != 0, long_shot, tolerance,
                                              state)
            if exact.within(position, rotation, tolerance):
                tried = True
                for j in range(n):
                    q[b, j] = candidate[j]
                ok[b] = True
                errors[b, 0], errors[b, 1] = position, rotation
            else:
                best_position = min(best_position, position)
                best_rotation = min(best_rotation, rotation)

        if tried:
            info[INFO.candidates] += 1
            unclamped[b] = (valid[b] and (near[b] & CLAMPED) == 0) or (
                bits != 0 and seeded_valid[b] and (seeded_near[b] & CLAMPED) == 0)
    # the two wrist branches of an arm branch that both took the seed's wrist and landed on the
    # same member of the family (they differ by 2 |q5| <= 2 FLAG_BAND): one solution (on a
    # refined table the seeded candidates were refined; duplicates merge below)
    for b in range(0, B, 2):
        if (plan[PLAN.refine] == 0.0 and ok[b] and ok[b + 1] and seeded_wrist[b]
                and seeded_wrist[b + 1] and _same(chain, q[b], q[b + 1], 4.0 * FLAG_BAND)):
            better = b if _size(errors, b) <= _size(errors, b + 1) else b + 1
            worse = b + b + 1 - better
            if _family_free(plan, g, chain, T_dh, T_at, q[better], better, clamp, tolerance,
                            scratch, state):
                ok[worse] = False  # one family at the tolerance: one solution
            else:
                # singular to within the seed band but not to within the tolerance over half a
                # turn of the family: the flip is a distinct solution, the regular candidate's
                ok[worse] = False
                if valid[worse]:
                    position, rotation = _settle_free(plan, chain, T_at, regular[worse],
                                                      candidate, fixed,
                                                      (near[worse] & CLAMPED) != 0,
                                                      False, tolerance, state)
                    if (exact.within(position, rotation, tolerance)
                            and not _known(chain, q, ok, candidate)):
                        for j in range(n):
                            q[worse, j] = candidate[j]
                        ok[worse] = True
                        flags[worse] = regular_flags[worse]
                        errors[worse, 0], errors[worse, 1] = position, rotation
    _merge_duplicates(chain, T_at, seed, q, ok, errors, tolerance, member)
    # a second root found by a branch goes to its own slot when a merge emptied that (its
    # seeded root was another branch's), else to its wrist twin's when that has none
    _place_extras(chain, T_at, extra, extra_ok, regular_flags, q, ok, flags, errors, 2)
    if plan[PLAN.refine] != 0.0:
        _retry_corrected(plan, g, chain, T_dh, T_at, seed, clamp, tolerance, regular, valid,
                         near, q, ok, errors, flags, scratch)
        # a root still without a slot takes the nearest empty one (elbow, then shoulder
        # partners): near a singularity the exact chain can have more roots for one ideal
        # branch than the ideal model has, while another branch's candidates found none
        _place_extras(chain, T_at, extra, extra_ok, regular_flags, q, ok, flags, errors, B)
        _seed_root(plan, chain, T_at, seed, tolerance, q, ok, errors)
    # flags describe the solution returned: wrist and elbow from its joint values, shoulder
    # from the pose (where the two q1 roots meet depends on the pose alone)
    for b in range(B):
        if ok[b]:
            flags[b] = (regular_flags[b] & SHOULDER) | _value_flags(plan, g, q[b])
    for b in range(B):
        if ok[b]:
            info[INFO.verified] += 1
        # dropped: a solution of the ideal model (not a clamped start) that did not settle, on
        # a wrist pair that answered nothing (one answer for a singular pair is by design)
        elif unclamped[b] and not ok[b ^ 1]:
            info[INFO.dropped] += 1
    info[INFO.best_position], info[INFO.best_rotation] = best_position, best_rotation


@jit
def solve_one(plan: NDArray[np.float64], frames: NDArray[np.float64], T: NDArray[np.float64],
              seed: NDArray[np.float64], tolerance: float, copies: bool,
              out_q: NDArray[np.float64], out_branch: NDArray[np.int16],
              out_flags: NDArray[np.uint8], out_errors: NDArray[np.float64],
              why: NDArray[np.float64], info: NDArray[np.float64], fwork: NDArray[np.float64],
              bwork: NDArray[np.bool_], uwork: NDArray[np.uint8],
              iwork: NDArray[np.int64]) -> int:
    """The whole pipeline for one pose: the solutions into out_* (M rows), why and info.
    Returns the count, or -1 when out_q has too few rows (or the pose was rejected: see
    info[INFO.status])."""
    n = seed.shape[0]
    B = BRANCHES
    q = np.empty((B, n))
    ok = np.empty(B, np.bool_)
    flags = np.empty(B, np.uint8)
    errors = np.empty((B, 2))
    solve_branches(plan, frames, T, seed, tolerance, q, ok, flags, errors, why, info, fwork,
                   bwork, uwork)
    if info[INFO.status] != 0:
        return 0
    return expand(plan, frames, T, seed, tolerance, copies, q, ok, flags, errors, out_q,
                  out_branch, out_flags, out_errors, fwork, iwork)


@jit
def solve_batch(plan: NDArray[np.float64], frames: NDArray[np.float64],
                targets: NDArray[np.float64], seeds: NDArray[np.float64], tolerance: float,
                copies: bool, q: NDArray[np.float64], ok: NDArray[np.bool_],
                flags: NDArray[np.uint8], errors: NDArray[np.float64],
                totals: NDArray[np.int64], why: NDArray[np.float64],
                info: NDArray[np.float64]) -> None:
    """Steps 1-3 for N poses (targets (N, 4, 4), seeds (N, n) or (1, n)): q (N, B, n), ok,
    flags, totals (N, B), errors (N, B, 2), why (N, WHY_SIZE), info (N, INFO.size)."""
    n = seeds.shape[1]
    f_size, b_size, u_size, _ = work_sizes(n)
    fwork = np.empty(f_size)
    bwork = np.empty(b_size, np.bool_)
    uwork = np.empty(u_size, np.uint8)
    for i in range(targets.shape[0]):
        seed = seeds[i] if seeds.shape[0] > 1 else seeds[0]
        solve_branches(plan, frames, targets[i], seed, tolerance, q[i], ok[i], flags[i],
                       errors[i], why[i], info[i], fwork, bwork, uwork)
        copy_totals(plan, q[i], ok[i], tolerance, copies, totals[i])


@jit
def expand_batch(plan: NDArray[np.float64], frames: NDArray[np.float64],
                 targets: NDArray[np.float64], seeds: NDArray[np.float64], tolerance: float,
                 copies: bool, q: NDArray[np.float64], ok: NDArray[np.bool_],
                 flags: NDArray[np.uint8], errors: NDArray[np.float64],
                 out_q: NDArray[np.float64], out_valid: NDArray[np.bool_],
                 out_branch: NDArray[np.int16], out_flags: NDArray[np.uint8],
                 out_errors: NDArray[np.float64]) -> None:
    """Step 4 for N poses into out_q (N, M, n), out_valid, out_branch, out_flags (N, M) and
    out_errors (N, M, 2); M >= every pose's total (:func:`copy_totals`)."""
    n = seeds.shape[1]
    f_size, _, _, i_size = work_sizes(n)
    fwork = np.empty(f_size)
    iwork = np.empty(i_size, np.int64)
    for i in range(targets.shape[0]):
        seed = seeds[i] if seeds.shape[0] > 1 else seeds[0]
        count = expand(plan, frames, targets[i], seed, tolerance, copies, q[i], ok[i], flags[i],
                       errors[i], out_q[i], out_branch[i], out_flags[i], out_errors[i], fwork,
                       iwork)
        for k in range(out_valid.shape[1]):
            out_valid[i, k] = k < count
            if k >= count:
                out_branch[i, k] = -1
                out_flags[i, k] = 0
                for j in range(n):
                    out_q[i, k, j] = 0.0


#: The pipeline's entry points and the plan's constants, for the solver (dhkin.ik.solver) and the
#: scripts: one module to import.
__all__ = ["BRANCHES", "INFO", "OFFSET_WRIST", "PLAN", "SPHERICAL_WRIST", "STANFORD", "WHY_SIZE",
           "_family", "_settle", "expand_batch", "plan_at_tcp", "plan_parts", "solve_batch",
           "solve_branches", "solve_one", "work_sizes"]
