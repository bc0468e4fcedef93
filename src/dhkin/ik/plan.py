"""The constants the compiled core gets for one robot (its *plan*): the family's geometry, the exact
chain, the limits, the ideal model and the continuation path between the two.

The plan is a dict of named values (``dhkin._core.ClosedForm`` reads each by name into its C++
struct, ``cpp/dhkin/plan.hpp``); chains are given by their parts (:func:`chain_parts`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.ik.core import FLAG_BAND
from dhkin.ik.family import BAND, FamilyFit
from dhkin.transforms import invert, rot_x, rot_z, translation

#: On a refined table, roots near a reach boundary are computed as if the target were at least
#: this fraction of the model deviation (m) inside it (cpp/dhkin/spherical.hpp): enough to give
#: each of two roots that the ideal model merges a start on its own side, small enough not to
#: move starts near a sensitive boundary far from the exact roots (measured on the calibrated
#: UR5e, 2000 vendor poses: 0.2 and 0.02 lose 2-3 poses, 2.0 loses 10, none loses 29).
SPREAD_FRACTION = 0.2


def chain_parts(table: DHTable) -> dict[str, NDArray[Any]]:
    """The exact chain of ``table`` (corrections included) as ``T(q) = P_1 Z_1(v_1) ... P_n
    Z_n(v_n) P_tail`` (cpp/dhkin/chain.hpp): per joint the constant frame P_j before its motion
    (``before``, (n, 4, 4)), whether it turns (``revolute``), its ``direction`` and ``offset``
    (v_j = direction q_j + offset); ``tail`` the frame after the last motion. DH frame 0 -> n."""
    n = table.dof
    before = np.zeros((n, 4, 4))
    after = np.eye(4)  # constant part since the previous joint's motion
    for j, joint in enumerate(table.joints):
        twist = rot_x(joint.alpha) @ translation(joint.a, 0, 0)
        if table.convention == "standard":
            before[j] = after if joint.is_revolute else after @ rot_z(joint.theta)
            rest = translation(joint.a, 0, 0) @ rot_x(joint.alpha)
            after = (translation(0, 0, joint.d) @ rest if joint.is_revolute else rest)
        else:
            before[j] = after @ twist if joint.is_revolute else after @ twist @ rot_z(joint.theta)
            after = translation(0, 0, joint.d) if joint.is_revolute else np.eye(4)
        after = after @ joint.correction_matrix
    return {"before": before,
            "revolute": np.array([j.is_revolute for j in table.joints], dtype=bool),
            "direction": np.array([float(j.direction) for j in table.joints]),
            "offset": np.array([float(j.offset) for j in table.joints]),
            "tail": after}


def plan_fields(table: DHTable, fit: FamilyFit) -> dict[str, Any]:
    """The plan of the compiled core (``dhkin._core.ClosedForm``): family, bands, geometry,
    exact and ideal chains, the continuation path between them and the joint limits."""
    geometry = dict(fit.solved.geometry)
    scale = fit.solved.scale
    lever = max(1.0, scale)
    position, rotation = fit.model_deviation
    deviation = position + lever * rotation  # how far a point of the arm may move, m
    geometry["spread"] = np.array([SPREAD_FRACTION * deviation])
    exact = chain_parts(table)
    ideal = chain_parts(fit.ideal)
    return {
        "family": fit.solved.kernel,
        "refine": bool(fit.refine),
        # A refined table's exact singular set lies anywhere within the family band of the ideal
        # model's (the band bounds the structural deviation): the seed band covers it
        "seed_angle": FLAG_BAND + (BAND.angle if fit.refine else 0.0),
        "seed_length": FLAG_BAND * scale + (BAND.length if fit.refine else 0.0),
        "deviation": 2.0 * deviation,
        # beyond it a refined branch's root and the ideal model's need not correspond one to one
        # (cpp/dhkin/extra_roots.hpp)
        "band_angle": BAND.angle if fit.refine else 0.0,
        "lever": lever,
        "free_joints": tuple(int(j) for j in fit.solved.free_joints),
        "geometry": geometry,
        "chain": exact,
        "ideal": ideal,
        "path": model_path(ideal, exact),
        "limits": np.stack([table.lower, table.upper], axis=1),
    }


def _frames(parts: dict[str, NDArray[Any]]) -> list[NDArray[np.float64]]:
    return [*parts["before"], parts["tail"]]


def model_path(ideal: dict[str, NDArray[Any]], exact: dict[str, NDArray[Any]]
               ) -> NDArray[np.float64]:
    """(n + 1, 6): per constant frame of the chains (:func:`chain_parts`), the rotation vector
    and translation of P(ideal)^-1 P(exact) (the continuation path from the ideal model to the
    exact chain)."""
    frames0, frames1 = _frames(ideal), _frames(exact)
    path = np.zeros((len(frames0), 6))
    for j, (P0, P1) in enumerate(zip(frames0, frames1, strict=True)):
        step = invert(P0) @ P1
        R = step[:3, :3]
        axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        angle = float(np.arctan2(0.5 * np.linalg.norm(axis), 0.5 * (np.trace(R) - 1.0)))
        norm = float(np.linalg.norm(axis))
        path[j, :3] = axis * (angle / norm) if norm > 0 else 0.0
        path[j, 3:] = step[:3, 3]
    return path
