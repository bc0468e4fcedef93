"""The constants of one robot's solver (the plan), the per-pose info, and small helpers every step
of the pipeline uses (see :mod:`.pipeline` for the steps).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled import chain as exact
from dhkin.ik.compiled import continuation
from dhkin.ik.compiled.bands import ELBOW, FLAG_BAND, MERGE_ANGLE, SHOULDER, WRIST
from dhkin.ik.compiled.copies import wrap
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
def work_sizes(n: int) -> tuple[int, int, int, int]:
    """Lengths of the float, bool, uint8 and int64 work arrays of one pose (the pipeline's
    layout: :func:`.pipeline.solve_branches`)."""
    floats = POSE_WORK + BRANCHES * n + n + WHY_SIZE
    return floats, 3 * BRANCHES + n, 3 * BRANCHES, 3 * n


#: Length of the work floats :func:`pose_views` lays out (the pipeline's own follow them).
POSE_WORK = 67


@jit
def pose_views(fwork: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                     NDArray[np.float64], NDArray[np.float64],
                                                     NDArray[np.float64], NDArray[np.float64]]:
    """Views into a pose's float work array: the projected target (3, 4), the target in DH
    frame 0 -> n (3, 4), the target of the TCP point (3, 4; see plan_at_tcp), the TCP point
    (3,), an FK state (12,) and the family solver's scratch (16,)."""
    return (fwork[0:12].reshape(3, 4), fwork[12:24].reshape(3, 4), fwork[24:36].reshape(3, 4),
            fwork[36:39], fwork[39:51], fwork[51:POSE_WORK])


@jit
def begin_pose(plan: NDArray[np.float64], frames: NDArray[np.float64], T: NDArray[np.float64],
               seed: NDArray[np.float64], ok: NDArray[np.bool_], flags: NDArray[np.uint8],
               why: NDArray[np.float64], info: NDArray[np.float64],
               fwork: NDArray[np.float64]) -> tuple[bool, NDArray[np.float64]]:
    """Step 1 of one pose, shared by the pipeline and the direct path: the outputs reset (info
    zero, why NaN, no branch ok), the pose and the seed checked (a rejection goes to
    info[INFO.status]), the rotation projected (info[INFO.projection]) and the targets of
    :func:`pose_views` computed. Returns (whether the pose is usable, the plan at its TCP)."""
    for k in range(INFO.size):
        info[k] = 0.0
    for k in range(why.shape[0]):
        why[k] = math.nan
    for b in range(ok.shape[0]):
        ok[b] = False
        flags[b] = 0
    st = status(T)
    if st != 0:
        info[INFO.status] = st
        return False, plan
    for j in range(seed.shape[0]):
        if not math.isfinite(seed[j]):
            info[INFO.status] = STATUS_BAD_SEED
            return False, plan
    projected, T_dh, T_at, point, _, _ = pose_views(fwork)
    info[INFO.projection] = project(T, projected)
    to_dh(frames, projected, T_dh)
    tcp_point(frames, point)
    at_point(T_dh, point, T_at)
    return True, plan_at_tcp(plan, point)


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
    continuation.extend_tail(chain, point)
    continuation.extend_tail(ideal, point)
    continuation.extend_path(path, point)
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
def family_outputs(n: int) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.uint8],
                                    NDArray[np.uint8], NDArray[np.float64]]:
    """Fresh output arrays of one :func:`_family` call for n joints: q (B, n), valid, flags and
    near (B,), why (WHY_SIZE,)."""
    return (np.empty((BRANCHES, n)), np.empty(BRANCHES, np.bool_), np.empty(BRANCHES, np.uint8),
            np.empty(BRANCHES, np.uint8), np.empty(WHY_SIZE))


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
def _size(errors: NDArray[np.float64], b: int) -> float:
    return max(errors[b, 0], errors[b, 1])


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
