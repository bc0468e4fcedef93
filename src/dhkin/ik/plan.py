"""The constants the compiled pipeline gets for one robot (its *plan*): the family's geometry, the
exact chain, the limits, the ideal model and the continuation path between the two (layouts in
:mod:`dhkin.ik.compiled.plan`).
"""

from __future__ import annotations

from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.ik.family import BAND, FamilyFit
from dhkin.transforms import invert, rot_x, rot_z, translation

#: On a refined table, roots near a reach boundary are computed as if the target were at least
#: this fraction of the model deviation (m) inside it (dhkin.ik.compiled.spherical): enough to
#: give each of two roots that the ideal model merges a start on its own side, small enough not
#: to move starts near a sensitive boundary far from the exact roots (measured on the calibrated
#: UR5e, 2000 vendor poses: 0.2 and 0.02 lose 2-3 poses, 2.0 loses 10, none loses 29).
SPREAD_FRACTION = 0.2


def _kernels() -> ModuleType:
    """dhkin.ik.compiled.pipeline, imported on first use (importing numba takes ~0.5 s)."""
    from dhkin.ik.compiled import pipeline

    return pipeline


def chain_array(table: DHTable) -> NDArray[np.float64]:
    """The exact chain of ``table`` (corrections included) as the compiled ``chain`` layout
    (n + 1, ROW): per joint the constant frame before its motion, its kind, direction and offset;
    the last row the frame after the last motion (see dhkin.ik.compiled.chain)."""
    from dhkin.ik.compiled.chain import JOINT, ROW

    n = table.dof
    chain = np.zeros((n + 1, ROW))
    after = np.eye(4)  # constant part since the previous joint's motion
    for j, joint in enumerate(table.joints):
        twist = rot_x(joint.alpha) @ translation(joint.a, 0, 0)
        if table.convention == "standard":
            before = after if joint.is_revolute else after @ rot_z(joint.theta)
            rest = translation(joint.a, 0, 0) @ rot_x(joint.alpha)
            after = (translation(0, 0, joint.d) @ rest if joint.is_revolute else rest)
        else:
            before = after @ twist if joint.is_revolute else after @ twist @ rot_z(joint.theta)
            after = translation(0, 0, joint.d) if joint.is_revolute else np.eye(4)
        after = after @ joint.correction_matrix
        chain[j, JOINT.pre:JOINT.pre + 12] = before[:3].ravel()
        chain[j, JOINT.revolute] = 1.0 if joint.is_revolute else 0.0
        chain[j, JOINT.direction] = joint.direction
        chain[j, JOINT.offset] = joint.offset
    chain[n, :12] = after[:3].ravel()
    return chain


def plan_array(table: DHTable, fit: FamilyFit) -> NDArray[np.float64]:
    """The ``plan`` of the compiled pipeline (layout PLAN, then geometry, chain and limits)."""
    from dhkin.ik.compiled.bands import FLAG_BAND

    kernels = _kernels()
    PLAN = kernels.PLAN
    geometry = fit.solved.geometry.copy()
    chain = chain_array(table)
    limits = np.stack([table.lower, table.upper], axis=1)
    scale = fit.solved.scale
    lever = max(1.0, scale)
    position, rotation = fit.model_deviation
    deviation = position + lever * rotation  # how far a point of the arm may move, m
    geometry[_spread_index(fit.solved.kernel)] = SPREAD_FRACTION * deviation
    head = np.zeros(PLAN.size)
    head[PLAN.family] = fit.solved.kernel
    head[PLAN.dof] = table.dof
    head[PLAN.refine] = 1.0 if fit.refine else 0.0
    # A refined table's exact singular set lies anywhere within the family band of the ideal
    # model's (the band bounds the structural deviation): the seed band covers it
    head[PLAN.seed_angle] = FLAG_BAND + (BAND.angle if fit.refine else 0.0)
    head[PLAN.seed_length] = FLAG_BAND * scale + (BAND.length if fit.refine else 0.0)
    head[PLAN.deviation] = 2.0 * deviation
    head[PLAN.lever] = lever
    head[PLAN.free_wrist], head[PLAN.free_elbow], head[PLAN.free_shoulder] = \
        fit.solved.free_joints
    ideal = chain_array(fit.ideal)
    path = model_path(ideal, chain)
    parts = [geometry, chain.ravel(), limits.ravel(), ideal.ravel(), path.ravel()]
    offsets = np.cumsum([PLAN.size] + [part.size for part in parts])
    head[PLAN.geometry_at] = offsets[0]
    head[PLAN.geometry_size] = geometry.size
    head[PLAN.chain_at], head[PLAN.limits_at] = offsets[1], offsets[2]
    head[PLAN.ideal_at], head[PLAN.path_at] = offsets[3], offsets[4]
    return np.ascontiguousarray(np.concatenate([head, *parts]))


def model_path(ideal: NDArray[np.float64], exact: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n + 1, 6): per constant frame of the chains, the rotation vector and translation of
    P(ideal)^-1 P(exact) (the continuation path of dhkin.ik.compiled.chain.interpolate)."""
    path = np.zeros((ideal.shape[0], 6))
    for j in range(ideal.shape[0]):
        P0, P1 = np.eye(4), np.eye(4)
        P0[:3] = ideal[j, :12].reshape(3, 4)
        P1[:3] = exact[j, :12].reshape(3, 4)
        step = invert(P0) @ P1
        R = step[:3, :3]
        angle = float(np.arctan2(0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0],
                                                       R[1, 0] - R[0, 1]]),
                                 0.5 * (np.trace(R) - 1.0)))
        axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        norm = float(np.linalg.norm(axis))
        path[j, :3] = axis * (angle / norm) if norm > 0 else 0.0
        path[j, 3:] = step[:3, 3]
    return path


def _spread_index(kernel: int) -> int:
    """Where a family's geometry vector keeps ``spread``."""
    from dhkin.ik.compiled import offset, spherical

    return offset.GEOMETRY.spread if kernel == _kernels().OFFSET_WRIST \
        else spherical.GEOMETRY.spread
