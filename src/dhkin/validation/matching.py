"""Joint-space matching for the validation, vectorised over a pose's solutions and branches:
joint differences modulo 2pi, the nearest returned solution of each branch, residuals reused for
joint vectors already checked, and the configuration label of each sampled joint vector.

Conventions as in :mod:`dhkin.validation.run`: joint vectors in chain order (rad, m for prismatic
joints); a distance is the largest joint difference, revolute joints wrapped to (-pi, pi].
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.errors import FamilyError
from dhkin.transforms import pose_error
from dhkin.validation.references import TargetModel
from dhkin.validation.samples import WRIST_JOINT

#: ``|sin q5|`` at or below which a sample is on the wrist singularity for the missing check.
WRIST_SINGULAR = 1e-6

#: Joints (0-based) compared at the wrist singularity for an IK that takes no seed.
SINGULAR_FAMILY_FIXED_JOINTS = (0, 4)


#: id(joints tuple) -> (that tuple, kept so that its id is not reused; its revolute mask).
_MASKS: dict[int, tuple[tuple[Any, ...], NDArray[np.bool_]]] = {}


def revolute_mask(robot: Arm) -> NDArray[np.bool_]:
    """Which joints are revolute (read-only; computed once per table's joints)."""
    joints = robot.table.joints
    known = _MASKS.get(id(joints))
    if known is None or known[0] is not joints:
        mask = np.array([j.is_revolute for j in joints], dtype=bool)
        mask.flags.writeable = False
        if len(_MASKS) >= 256:  # a long session of many tables: start again
            _MASKS.clear()
        known = _MASKS[id(joints)] = (joints, mask)
    return known[1]


def wrap(robot: Arm, difference: NDArray[np.float64]) -> NDArray[np.float64]:
    """Joint differences (..., dof) with revolute joints wrapped to (-pi, pi] (prismatic ones as
    they are)."""
    return np.where(revolute_mask(robot), np.pi - np.mod(np.pi - difference, 2.0 * np.pi),
                    difference)


def wrist_singular(robot: Arm, q: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether each joint vector (..., dof) is on the wrist singularity (``|sin q5|`` at most
    :data:`WRIST_SINGULAR`; never for an arm without a revolute fifth joint)."""
    q = np.asarray(q, dtype=float)
    if robot.dof <= WRIST_JOINT or not robot.table.joints[WRIST_JOINT].is_revolute:
        return np.zeros(q.shape[:-1], dtype=bool)
    return np.asarray(np.abs(np.sin(q[..., WRIST_JOINT])) <= WRIST_SINGULAR)


def nearest_distances(robot: Arm, Q: NDArray[np.float64], rows: NDArray[np.float64],
                      fixed_only: NDArray[np.bool_]) -> NDArray[np.float64]:
    """For each row of ``rows`` (k, dof): the distance to the nearest row of ``Q`` (m, dof),
    over every joint, or over :data:`SINGULAR_FAMILY_FIXED_JOINTS` only where ``fixed_only``."""
    distance = np.abs(wrap(robot, Q[None, :, :] - rows[:, None, :]))  # (k, m, dof)
    nearest = distance.max(axis=2).min(axis=1)
    if np.any(fixed_only):
        fixed = distance[:, :, list(SINGULAR_FAMILY_FIXED_JOINTS)].max(axis=2).min(axis=1)
        nearest = np.where(fixed_only, fixed, nearest)
    return nearest


def residuals(model: TargetModel, T: NDArray[np.float64], rows: NDArray[np.float64],
              Q: NDArray[np.float64], position: NDArray[np.float64],
              rotation: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Position and rotation errors of ``rows`` on the reference: those of the row of ``Q`` equal
    to it, bit for bit, where there is one (``position``, ``rotation``: Q's errors, already
    computed by Pinocchio), Pinocchio's FK for the others."""
    same = (np.all(rows[:, None, :] == Q[None, :, :], axis=2) if len(Q)
            else np.zeros((len(rows), 0), dtype=bool))
    known = same.any(axis=1)
    row_position, row_rotation = np.empty(len(rows)), np.empty(len(rows))
    first = same.argmax(axis=1)[known]
    row_position[known], row_rotation[known] = position[first], rotation[first]
    if not known.all():
        fresh = rows[~known]
        row_position[~known], row_rotation[~known] = pose_error(
            model.fk(fresh), np.broadcast_to(T, (len(fresh), 4, 4)))
    return row_position, row_rotation


def configuration_labels(robot: Arm, targets: NDArray[np.float64],
                         q: NDArray[np.float64]) -> list[str]:
    """Configuration of each sampled q according to dhkin's closed-form solver: the label of its
    nearest valid branch ('' without a closed form, 'unlabelled' without a valid branch). The
    general 6R solver's roots have no labels: it is not called for them."""
    if robot.ik_family == "general6r":
        return [""] * q.shape[0]
    try:
        batch = robot.ik_batch_detailed(targets)
    except FamilyError:
        return [""] * q.shape[0]
    if batch.q.shape[1] == 0:
        return ["unlabelled"] * q.shape[0]
    distance = np.abs(wrap(robot, batch.q - q[:, None, :])).max(axis=2)
    distance = np.where(batch.valid, distance, np.inf)
    best = np.argmin(distance, axis=1)
    labels = []
    for k in range(q.shape[0]):
        if not batch.valid[k].any():
            labels.append("unlabelled")
            continue
        label = batch.branch_labels[batch.branch[k, best[k]]]
        labels.append(" ".join(f"{key}={value}" for key, value in label.items()))
    return labels
