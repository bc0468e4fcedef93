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
from dhkin.ik.compiled.bands import CLAMPED, ELBOW, FLAG_BAND, FREE, MERGE_ANGLE, SHOULDER, WRIST
from dhkin.ik.compiled.copies import nearest_turn, placed, turn_range, wrap
from dhkin.ik.compiled.jit import jit
from dhkin.ik.compiled.layout import layout
from dhkin.ik.compiled.offset import GEOMETRY as OG
from dhkin.ik.compiled.offset import solve_offset_wrist
from dhkin.ik.compiled.pose import STATUS_BAD_SEED, at_point, project, status, tcp_point, to_dh
from dhkin.ik.compiled.spherical import GEOMETRY as SG
from dhkin.ik.compiled.spherical import solve_spherical_wrist, solve_stanford

# Family ids.
SPHERICAL_WRIST, STANFORD, OFFSET_WRIST = 1, 2, 3
#: Branches of every family.
BRANCHES = 8
#: A 2pi shift changes FK by rounding only: sin/cos of q + 2pi k carry an error of ~|q + 2pi k|
#: ulp, ~1.4e-15 rad per joint for |q| <= 4pi, so at most ~2e-14 (m per m of arm, rad) for six
#: joints. Copies of a branch whose error is within this margin of the tolerance (500 times that
#: bound) are verified themselves.
COPY_MARGIN = 1e-11
#: Two double-precision evaluations of one chain's FK (ours, Pinocchio's on the URDF) differ by
#: rounding: at most 1.4e-15 (m per m of arm, rad) on the built-in tables ("fk vs pin" of
#: ``dhkin check``). Solutions are verified here at the tolerance less FK_ROUNDING x lever (64 ulp
#: per metre, ~10x that bound; at most half the tolerance), so that a solution verified on our
#: FK is also within the tolerance on the oracle's.
FK_ROUNDING = 64.0 * 2.220446049250313e-16

#: Chain evaluations allowed to the refinement of a *long shot*: on a refined table, a branch
#: that the ideal model cannot reach even within the clamp band is still tried from its clamped
#: candidate (near a wrist singularity the exact chain can reach where the ideal model is
#: centimetres out), with this bounded effort (a converging refinement takes 4-10).
LONG_SHOT_BUDGET = 24

#: Chain evaluations allowed to polish a candidate of an exact table that failed verification
#: (a pose a hair outside the reach, or rounding at a singularity): Newton from it, verified.
POLISH_BUDGET = 12

#: The constants of one robot's solver (see :func:`dhkin.ik.solver.plan_array`).
PLAN = layout("Plan", [
    ("family", 1), ("dof", 1), ("refine", 1),
    ("seed_angle", 1),   # wrist band: |sin| at or below which the seed's q4 / q6 is tried
    ("seed_length", 1),  # m: distance at or below which the seed's q1 / q2 is tried
                         # (the flag band; on refined tables widened by the family band)
    ("deviation", 1),    # m: how far the exact chain's poses are from the ideal model's
    ("lever", 1),        # m: max(1, table scale)
    ("free_wrist", 1), ("free_elbow", 1), ("free_shoulder", 1),  # free joint of each bit
    ("geometry_at", 1), ("geometry_size", 1), ("chain_at", 1), ("limits_at", 1),
    ("ideal_at", 1),     # the ideal model's chain (same layout as the exact chain)
    ("path_at", 1),      # (n + 1, 6): rotation vector and translation of each constant frame
])
#: Per-pose facts returned beside the solutions.
INFO = layout("Info", [
    ("status", 1),       # 0, or a .pose STATUS_*
    ("projection", 1),   # Frobenius norm of the change of the input's rotation block
    ("candidates", 1),   # branches with a geometric solution
    ("verified", 1),     # branches whose solution verified (after merging)
    ("dropped", 1),      # branches with a candidate none of which verified
    ("best_position", 1), ("best_rotation", 1),  # smallest errors of the dropped candidates
])
#: Length of the ``why`` vector of each pose (numbers an empty answer is explained with).
WHY_SIZE = 6


@jit
def verification_tolerance(plan: NDArray[np.float64], tolerance: float) -> float:
    """The tolerance the pipeline verifies at: ``tolerance`` less the FK rounding margin
    (:data:`FK_ROUNDING`)."""
    return max(tolerance - FK_ROUNDING * plan[PLAN.lever], 0.5 * tolerance)


@jit
def model_path(plan: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(ideal chain (n + 1, ROW), path (n + 1, 6)) views into a plan: the continuation from
    the ideal model to the exact chain (:func:`.chain.refine_along`)."""
    n = int(plan[PLAN.dof])
    i_at, p_at = int(plan[PLAN.ideal_at]), int(plan[PLAN.path_at])
    return (plan[i_at:i_at + (n + 1) * exact.ROW].reshape(n + 1, exact.ROW),
            plan[p_at:p_at + 6 * (n + 1)].reshape(n + 1, 6))


@jit
def plan_parts(plan: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                   NDArray[np.float64]]:
    """(geometry, chain (n + 1, ROW), limits (n, 2)) views into a plan."""
    n = int(plan[PLAN.dof])
    g_at, g_size = int(plan[PLAN.geometry_at]), int(plan[PLAN.geometry_size])
    c_at, l_at = int(plan[PLAN.chain_at]), int(plan[PLAN.limits_at])
    chain = plan[c_at:c_at + (n + 1) * exact.ROW].reshape(n + 1, exact.ROW)
    return plan[g_at:g_at + g_size], chain, plan[l_at:l_at + 2 * n].reshape(n, 2)


@jit
def plan_at_tcp(plan: NDArray[np.float64], point: NDArray[np.float64]) -> NDArray[np.float64]:
    """The plan whose exact and ideal chains (and the path between them) end at ``point``, the
    TCP's origin in DH frame n (:func:`.pose.tcp_point`): errors are then the TCP's, which
    differ from DH frame n's by up to the rotation error times |point|. The plan itself when
    the point is DH frame n's origin."""
    if point[0] == 0.0 and point[1] == 0.0 and point[2] == 0.0:
        return plan
    out = plan.copy()
    _, chain, _ = plan_parts(out)
    ideal, path = model_path(out)
    exact.extend_tail(chain, point)
    exact.extend_tail(ideal, point)
    exact.extend_path(path, point)
    return out


@jit
def _family(plan: NDArray[np.float64], g: NDArray[np.float64], T: NDArray[np.float64],
            seed: NDArray[np.float64], use_seed: int, clamp: float, q: NDArray[np.float64],
            valid: NDArray[np.bool_], flags: NDArray[np.uint8], near: NDArray[np.uint8],
            why: NDArray[np.float64], scratch: NDArray[np.float64]) -> None:
    family = int(plan[PLAN.family])
    angle, length = plan[PLAN.seed_angle], plan[PLAN.seed_length]
    if family == SPHERICAL_WRIST:
        solve_spherical_wrist(g, T, seed, use_seed, angle, length, clamp, q, valid, flags, near,
                              why, scratch)
    elif family == STANFORD:
        solve_stanford(g, T, seed, use_seed, angle, length, clamp, q, valid, flags, near, why,
                       scratch)
    else:
        solve_offset_wrist(g, T, seed, use_seed, angle, length, clamp, q, valid, flags, near,
                           why, scratch)


@jit
def _settle(plan: NDArray[np.float64], chain: NDArray[np.float64], T: NDArray[np.float64],
            values: NDArray[np.float64], fixed: NDArray[np.bool_], clamped: bool,
            long_shot: bool, tolerance: float, state: NDArray[np.float64],
            polish: bool = True) -> tuple[float, float]:
    """Wrap a candidate's revolute values, refine it on the exact chain if the plan says so
    (joints marked ``fixed`` keep their value; a candidate that is an exact solution of the
    ideal model, not ``clamped``, is followed by continuation where Newton fails), or polish it
    by Newton where an exact table's candidate does not verify; return its (position, rotation)
    errors."""
    n = values.shape[0]
    for j in range(n):
        if chain[j, exact.JOINT.revolute] != 0.0:
            values[j] = wrap(values[j])
    if plan[PLAN.refine] != 0.0:
        start = values.copy()
        budget = LONG_SHOT_BUDGET if long_shot else 4 * exact.MAX_STEPS
        position, rotation = exact.refine(chain, T, values, fixed, tolerance, budget)
        if _any(fixed) and not exact.within(position, rotation, tolerance):
            # the exact chain is not singular here (its singular set is shifted, or a
            # calibration leaves none): the seed's choice of the free joint is not exact, so
            # release it from where it got to (the caller sees ``fixed`` cleared)
            for j in range(n):
                fixed[j] = False
            # a monotone descent first: it stays in the basin of the root nearest the seed's
            # member, where Newton's first step can jump along the near-singular direction to
            # a far root (an exact chain a hair from a spherical wrist has a root at q5 ~ 0
            # beside the two the ideal model gives)
            held = values.copy()
            position, rotation = exact.refine(chain, T, values, fixed, tolerance, budget, 1.0)
            if not exact.within(position, rotation, tolerance):
                for j in range(n):
                    values[j] = held[j]
                position, rotation = exact.refine(chain, T, values, fixed, tolerance, budget)
        if not clamped and not exact.within(position, rotation, tolerance):  # follow the branch
            ideal, path = model_path(plan)
            for j in range(n):
                values[j] = start[j]
            exact.refine_along(ideal, chain, path, T, values, fixed, tolerance,
                               np.empty_like(chain))
        elif clamped and not exact.within(position, rotation, tolerance):
            # a target a hair beyond a fold: its least-squares point may verify
            exact.refine(chain, T, values, fixed, tolerance, POLISH_BUDGET, 1.0)
        for j in range(n):
            if chain[j, exact.JOINT.revolute] != 0.0:
                values[j] = wrap(values[j])
        return exact.check(chain, values, T, state)
    position, rotation = exact.check(chain, values, T, state)
    if not exact.within(position, rotation, tolerance) and polish:
        # a clamped or near-singular candidate of an exact table: the closed form's point is
        # not the best one the chain reaches; Newton's is, and verification decides (a seeded
        # candidate keeps its seeded joints; see solve_branches for when it is polished)
        exact.refine(chain, T, values, fixed, tolerance, POLISH_BUDGET)
        position, rotation = exact.check(chain, values, T, state)
        if clamped and not exact.within(position, rotation, tolerance):
            # clamped onto a fold: J is singular there. A target a hair beyond it: Newton
            # oscillates along the fold's weak direction, a monotone descent reaches the
            # least-squares point, which may verify; a target a hair inside it: the roots lie a
            # hair off the fold
            exact.refine(chain, T, values, fixed, tolerance, POLISH_BUDGET, 1.0)
            position, rotation = exact.check(chain, values, T, state)
            if not exact.within(position, rotation, tolerance):
                position, rotation = exact.off_fold(chain, T, values, fixed, tolerance,
                                                    POLISH_BUDGET)
        for j in range(n):
            if chain[j, exact.JOINT.revolute] != 0.0:
                values[j] = wrap(values[j])
        position, rotation = exact.check(chain, values, T, state)
    return position, rotation


@jit
def _settle_free(plan: NDArray[np.float64], chain: NDArray[np.float64], T: NDArray[np.float64],
                 start: NDArray[np.float64], candidate: NDArray[np.float64],
                 fixed: NDArray[np.bool_], clamped: bool, long_shot: bool, tolerance: float,
                 state: NDArray[np.float64]) -> tuple[float, float]:
    """:func:`_settle` of ``start`` copied into ``candidate`` with every joint free."""
    for j in range(start.shape[0]):
        candidate[j] = start[j]
        fixed[j] = False
    return _settle(plan, chain, T, candidate, fixed, clamped, long_shot, tolerance, state)


@jit
def _finite(values: NDArray[np.float64]) -> bool:
    return bool(np.all(np.isfinite(values)))


@jit
def _any(flags: NDArray[np.bool_]) -> bool:
    return bool(np.any(flags))


@jit
def _fix_free(plan: NDArray[np.float64], bits: int, fixed: NDArray[np.bool_]) -> None:
    """fixed[j] = True for the free joint of each singularity bit in ``bits``."""
    for j in range(fixed.shape[0]):
        fixed[j] = False
    if bits & WRIST:
        fixed[int(plan[PLAN.free_wrist])] = True
    if bits & ELBOW:
        fixed[int(plan[PLAN.free_elbow])] = True
    if bits & SHOULDER:
        fixed[int(plan[PLAN.free_shoulder])] = True


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
    for k in range(INFO.size):
        info[k] = 0.0
    for k in range(why.shape[0]):
        why[k] = math.nan
    for b in range(B):
        ok[b] = False
        flags[b] = 0
    st = status(T)
    if st != 0:
        info[INFO.status] = st
        return
    for j in range(n):
        if not math.isfinite(seed[j]):
            info[INFO.status] = STATUS_BAD_SEED
            return
    at = 0
    projected = fwork[at:at + 12].reshape(3, 4)
    at += 12
    T_dh = fwork[at:at + 12].reshape(3, 4)
    at += 12
    T_at = fwork[at:at + 12].reshape(3, 4)  # the target of the TCP point (see plan_at_tcp)
    at += 12
    point = fwork[at:at + 3]
    at += 3
    state = fwork[at:at + 12]
    at += 12
    scratch = fwork[at:at + 16]
    at += 16
    seeded_q = fwork[at:at + B * n].reshape(B, n)
    at += B * n
    candidate = fwork[at:at + n]
    at += n
    seeded_why = fwork[at:at + WHY_SIZE]
    valid, seeded_valid, fixed = bwork[:B], bwork[B:2 * B], bwork[2 * B:2 * B + n]
    near, seeded_flags, seeded_near = uwork[:B], uwork[B:2 * B], uwork[2 * B:3 * B]
    info[INFO.projection] = project(T, projected)
    to_dh(frames, projected, T_dh)
    tcp_point(frames, point)
    at_point(T_dh, point, T_at)
    plan = plan_at_tcp(plan, point)
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
                                         (seeded_near[b] & CLAMPED) != 0, False, tolerance,
                                         state, not raw_ok[b ^ 1])
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
                                              (near[b] & CLAMPED) != 0, False, tolerance, state)
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
                                                      (near[worse] & CLAMPED) != 0, False,
                                                      tolerance, state)
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
    q = np.empty((BRANCHES, n))
    valid = np.empty(BRANCHES, np.bool_)
    flags = np.empty(BRANCHES, np.uint8)
    near = np.empty(BRANCHES, np.uint8)
    why = np.empty(WHY_SIZE)
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
    q = np.empty((BRANCHES, n))
    valid = np.empty(BRANCHES, np.bool_)
    flags = np.empty(BRANCHES, np.uint8)
    near = np.empty(BRANCHES, np.uint8)
    why = np.empty(WHY_SIZE)
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
                                     (near[b] & CLAMPED) != 0, False, tolerance, state)
        if exact.within(position, rotation, tolerance) and _in_limits(
                chain, limits, candidate, tolerance / plan[PLAN.lever]):
            return position, rotation
        _fix_free(plan, bits, fixed)
    return math.inf, math.inf


@jit
def _size(errors: NDArray[np.float64], b: int) -> float:
    return max(errors[b, 0], errors[b, 1])


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
    position, rotation = exact.refine(chain, T, root, fixed, tolerance, 4 * exact.MAX_STEPS, 1.0,
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
def _seed_distance(chain: NDArray[np.float64], values: NDArray[np.float64],
                   seed: NDArray[np.float64]) -> float:
    """Squared joint distance from the seed, revolute differences wrapped."""
    total = 0.0
    for j in range(seed.shape[0]):
        difference = values[j] - seed[j]
        if chain[j, exact.JOINT.revolute] != 0.0:
            difference = wrap(difference)
        total += difference * difference
    return total


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
                if not (member[a] or member[b]) and exact.find_twin(
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
    candidates = np.empty((B, n))
    c_valid = np.empty(B, np.bool_)
    c_flags = np.empty(B, np.uint8)
    c_near = np.empty(B, np.uint8)
    c_why = np.empty(WHY_SIZE)
    fixed = np.zeros(n, np.bool_)
    state = np.empty(12)
    for b in range(B):
        if ok[b] or not _finite(regular[b]) or not (valid[b] or (near[b] & CLAMPED) != 0):
            continue
        start = regular[b].copy()
        for _ in range(CORRECTIONS):
            _corrected_target(ideal, chain, start, T, corrected)
            _family(plan, g, corrected, seed, 0, clamp, candidates, c_valid, c_flags, c_near,
                    c_why, scratch)
            if not _finite(candidates[b]):
                break
            for j in range(n):
                start[j] = candidates[b, j]
            trial = start.copy()
            exact.refine(chain, T_at, trial, fixed, tolerance)
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


@jit
def _value_flags(plan: NDArray[np.float64], g: NDArray[np.float64],
                 q: NDArray[np.float64]) -> int:
    """The WRIST and ELBOW flags of joint values q: each singularity's measure (|sin| of the
    wrist angle, of the elbow angle; the slide's distance from its merge over the scale) at most
    FLAG_BAND, computed from q itself (family geometry of the ideal model)."""
    family = int(plan[PLAN.family])
    bits = 0
    if family == OFFSET_WRIST:
        if abs(math.sin(q[4] - g[OG.psi])) <= FLAG_BAND:
            bits |= WRIST
        if abs(math.sin(q[2] - g[OG.elbow_base])) <= FLAG_BAND:
            bits |= ELBOW
        return bits
    d5 = g[SG.wrist_directions + 1]
    if abs(math.sin(d5 * q[4] + g[SG.tilt])) <= FLAG_BAND:
        bits |= WRIST
    s3 = g[SG.signs + 2]
    if family == SPHERICAL_WRIST:
        if abs(math.sin(s3 * q[2] + g[SG.bend_at_zero])) <= FLAG_BAND:
            bits |= ELBOW
    elif abs(s3 * q[2] + g[SG.slide_along]) <= FLAG_BAND * g[SG.scale]:
        bits |= ELBOW
    return bits


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
    q = np.empty((BRANCHES, n))
    valid = np.empty(BRANCHES, np.bool_)
    flags = np.empty(BRANCHES, np.uint8)
    near = np.empty(BRANCHES, np.uint8)
    why = np.empty(WHY_SIZE)
    _family(plan, g, T, moved, WRIST, clamp, q, valid, flags, near, why, scratch)
    if not valid[b] or (near[b] & WRIST) == 0:
        return False
    position, rotation = exact.check(chain, q[b], T_at, state)
    return exact.within(position, rotation, tolerance)


@jit
def _same(chain: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64],
          distance: float) -> bool:
    """Whether a and b differ by at most ``distance`` on every joint (mod 2pi)."""
    for j in range(a.shape[0]):
        difference = a[j] - b[j]
        if chain[j, exact.JOINT.revolute] != 0.0:
            difference = wrap(difference)
        if abs(difference) > distance:
            return False
    return True


@jit
def _known(chain: NDArray[np.float64], q: NDArray[np.float64], ok: NDArray[np.bool_],
           candidate: NDArray[np.float64]) -> bool:
    """Whether ``candidate`` equals an ok branch's solution (2 MERGE_ANGLE, mod 2pi)."""
    for b in range(q.shape[0]):
        if not ok[b]:
            continue
        same = True
        for j in range(q.shape[1]):
            difference = candidate[j] - q[b, j]
            if chain[j, exact.JOINT.revolute] != 0.0:
                difference = wrap(difference)
            same = same and abs(difference) <= 2.0 * MERGE_ANGLE
        if same:
            return True
    return False


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


@jit
def work_sizes(n: int) -> tuple[int, int, int, int]:
    """Lengths of the float, bool, uint8 and int64 work arrays of one pose."""
    floats = 67 + BRANCHES * n + n + WHY_SIZE
    return floats, 3 * BRANCHES + n, 3 * BRANCHES, 3 * n


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
