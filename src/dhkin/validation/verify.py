"""The first check of every returned answer: finite joint vectors of the arm's length, within
the joint limits, exact on the reference description (see :mod:`dhkin.validation.run`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.transforms import pose_error
from dhkin.validation.references import TargetModel


def verify_solutions(robot: Arm, model: TargetModel, T: NDArray[np.float64],
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
