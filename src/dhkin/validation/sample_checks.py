"""The checks of one sample of a validation (see :mod:`dhkin.validation.run` for what each
outcome means): verifying what an IK call returned on the reference, matching the sampled joint
vector and the branches, and the continuity call with a perturbed seed. Used pose by pose by
:mod:`dhkin.validation.run`, and by :mod:`dhkin.validation.batched` for every sample its
vectorised screen does not clear.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.errors import DhkinError
from dhkin.transforms import pose_error
from dhkin.validation.calls import CallResult
from dhkin.validation.matching import (
    SINGULAR_FAMILY_FIXED_JOINTS,
    nearest_distances,
    residuals,
    wrap,
    wrist_singular,
)
from dhkin.validation.multistart import missing_roots
from dhkin.validation.references import TargetModel
from dhkin.validation.samples import CONTINUITY_DISTANCE, SEED_PERTURBATION
from dhkin.validation.tally import Tally

#: Pose rounding (m and rad) of a target computed in floating point, a few ulps of a 1 m arm:
#: the joint difference a pose cannot resolve is about POSE_ROUNDING / sigma_min(J).
POSE_ROUNDING = 1e-14


def compared_joints(robot: Arm, q_sampled: NDArray[np.float64],
                     seeded: bool) -> NDArray[np.int64]:
    """Joints the missing check compares (all, except at the wrist singularity without seed)."""
    if wrist_singular(robot, q_sampled) and not seeded:
        return np.array(SINGULAR_FAMILY_FIXED_JOINTS)
    return np.arange(robot.dof)


@dataclass(frozen=True)
class Checked:
    """Outcome of one sample before it is turned into a (JSON-ready) SampleResult."""

    outcome: str
    detail: str
    position: NDArray[np.float64]
    rotation: NDArray[np.float64]


def resolvable(robot: Arm, q: NDArray[np.float64], joint_tolerance: float,
                noise: float = POSE_ROUNDING) -> float:
    """Joint distance under which two solutions of one pose count as the same at q:
    joint_tolerance + noise / sigma_min of Pinocchio's Jacobian (6 x n) at q, with ``noise``
    the pose's uncertainty: its rounding, or the reference's deviation from the table's model
    (a vendor description's target is a pose of the vendor's model, not exactly of ours)."""
    sigma = np.linalg.svd(robot.reference().jacobian(q), compute_uv=False)
    return joint_tolerance + noise / max(float(sigma.min()), 1e-300)


def matched(robot: Arm, model: TargetModel, Q: NDArray[np.float64], q: NDArray[np.float64],
             joints: NDArray[np.int64], joint_tolerance: float,
             residual: float = 0.0) -> tuple[bool, float]:
    """Whether some row of Q is q (mod 2pi on ``joints``, widened by :func:`resolvable` with
    the pose's uncertainty: the reference's deviation, or the residual of the solutions (two
    joint vectors within r of one pose can differ by ~r / sigma_min))."""
    closest = float(np.abs(wrap(robot, Q - q)[:, joints]).max(axis=1).min())
    noise = max(POSE_ROUNDING, model.deviation, residual)
    found = closest <= joint_tolerance or closest <= resolvable(robot, q, joint_tolerance, noise)
    return found, closest


def verify(robot: Arm, model: TargetModel, T: NDArray[np.float64],
            returned: list[NDArray[np.float64]], tolerance: float
            ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], str]:
    """Finite solutions, their residuals on the reference, and what is wrong with them ('')."""
    dof = robot.dof
    shaped = [s for s in returned if s.shape == (dof,)]
    Q = np.array(shaped, dtype=float).reshape(len(shaped), dof)
    Q = Q[np.all(np.isfinite(Q), axis=1)]
    position: NDArray[np.float64] = np.zeros(0)
    rotation: NDArray[np.float64] = np.zeros(0)
    if len(Q):
        position, rotation = pose_error(model.fk(Q), np.broadcast_to(T, (len(Q), 4, 4)))
    if len(Q) < len(returned):
        return Q, position, rotation, (f"{len(returned) - len(Q)} solution(s) not finite or "
                                       f"not {dof} values")
    if len(Q) and not np.all(robot.table.in_limits(Q)):
        return Q, position, rotation, "a solution lies outside the joint limits"
    allowed = tolerance + model.deviation
    if len(Q) and (position.max() > allowed or rotation.max() > allowed):
        return Q, position, rotation, (f"residual {position.max():.2e} m / "
                                       f"{rotation.max():.2e} rad (allowed {allowed:.2e}: the "
                                       f"tolerance + the reference's deviation from the table)")
    return Q, position, rotation, ""


def check_sample(robot: Arm, model: TargetModel, q_sampled: NDArray[np.float64],
                  T: NDArray[np.float64], call: CallResult, tolerance: float,
                  joint_tolerance: float, seeded: bool) -> tuple[Checked, NDArray[np.float64]]:
    """wrong / no_solution / missing / success of the first call, and its finite solutions."""
    returned = call.solutions
    if call.problem:  # it raised, exited, timed out, or returned no list of joint vectors
        empty = np.zeros(0)
        return Checked(call.outcome, call.problem, empty, empty), np.zeros((0, robot.dof))
    Q, position, rotation, problem = verify(robot, model, T, returned, tolerance)
    if problem:
        return Checked("wrong", problem, position, rotation), Q
    if not returned:
        return Checked("no_solution", "nothing returned for a reachable target", position,
                        rotation), Q
    residual = float(max(position.max(), rotation.max())) if len(Q) else 0.0
    found, closest = matched(robot, model, Q, q_sampled,
                              compared_joints(robot, q_sampled, seeded), joint_tolerance,
                              residual)
    if not found and robot.dof == 6 and all(j.is_revolute for j in robot.table.joints):
        # one root with a returned solution at the tolerance: the segment between them solves
        # the pose too (near a singularity the pose cannot tell them apart)
        found = not missing_roots(model, T, q_sampled[None], Q, tolerance, joint_tolerance)
    if not found:
        return Checked("missing", f"closest returned solution differs by {closest:.2e} "
                                   "(mod 2pi)", position, rotation), Q
    return Checked("success", "", position, rotation), Q


def missing_branches(robot: Arm, model: TargetModel, T: NDArray[np.float64],
                      q_sampled: NDArray[np.float64], checked: Checked, Q: NDArray[np.float64],
                      tolerance: float, joint_tolerance: float) -> list[tuple[str, float]]:
    """(configuration, closest distance) of each branch of T (closed form or general 6R) that
    Q lacks (``checked``: Q's residuals on the reference, reused for a branch equal to a row).

    The branches are ``robot.ik(T, q_seed=q_sampled, copies=False)``, those that verify on the
    reference. A branch on the wrist singularity is a one-parameter family: only joints 1 and 5
    are compared there. A branch is matched like the sampled q (:func:`matched`, with the
    sigma_min widening at the branch where the plain joint tolerance does not do).
    """
    try:
        branches = robot.ik(T, q_seed=q_sampled, copies=False)
    except DhkinError:
        return []
    if not len(branches):
        return []
    position, rotation = residuals(model, T, branches.q, Q, checked.position, checked.rotation)
    allowed = tolerance + model.deviation
    verified = np.flatnonzero((position <= allowed) & (rotation <= allowed))
    rows = branches.q[verified]
    closest = nearest_distances(robot, Q, rows, wrist_singular(robot, rows))
    noise = max(POSE_ROUNDING, model.deviation)
    missing = []
    for k, distance in zip(verified, closest, strict=True):
        if distance <= joint_tolerance or distance <= resolvable(
                robot, branches.q[k], joint_tolerance, noise):
            continue
        name = (str(branches.configurations[k]) if k < len(branches.configurations)
                else f"branch {k}")
        missing.append((name, float(distance)))
    return missing


def nearest_to_seed(robot: Arm, Q: NDArray[np.float64],
                     seed: NDArray[np.float64]) -> tuple[float, int]:
    """Largest joint distance (mod 2pi) of the solution nearest ``seed``, and its joint."""
    distance = np.abs(wrap(robot, Q - seed))
    best = int(np.argmin(distance.max(axis=1)))
    joint = int(np.argmax(distance[best]))
    return float(distance[best, joint]), joint



def check_continuity(robot: Arm, model: TargetModel, call: CallResult, T: NDArray[np.float64],
                      seed: NDArray[np.float64], tolerance: float, tally: Tally
                      ) -> tuple[str, str, list[NDArray[np.float64]]]:
    """The answer of the second call, with the perturbed seed: (outcome, detail, what came
    back); its residuals go to ``tally``."""
    returned = call.solutions
    if call.problem:
        outcome = "wrong" if call.outcome == "wrong" else "discontinuous"
        return outcome, f"with the perturbed seed: {call.problem}", returned
    Q, position, rotation, problem = verify(robot, model, T, returned, tolerance)
    tally.residuals(position, rotation)
    if problem:
        return "wrong", f"with the perturbed seed: {problem}", returned
    if not len(Q):
        return "discontinuous", "nothing returned for the perturbed seed", returned
    distance, joint = nearest_to_seed(robot, Q, seed)
    if distance > CONTINUITY_DISTANCE:
        return ("discontinuous", f"with the seed perturbed by +-{SEED_PERTURBATION} rad the "
                f"nearest solution is {distance:.3f} from it on joint {joint + 1} (allowed "
                f"{CONTINUITY_DISTANCE})", returned)
    return "success", "", returned
