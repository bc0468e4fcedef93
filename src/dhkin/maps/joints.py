"""Joint-space slices: ``|det J|`` over a grid of two joints with the others held, and the cells its
factors change sign in (the singular loci).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from dhkin.dh import DHTable, joint_vector
from dhkin.errors import InputError
from dhkin.maps.branches import DEFAULT_JOINT_RESOLUTION, Array, Mask, _check_resolution
from dhkin.singularity import singularity_model

if TYPE_CHECKING:
    from dhkin.arm import Arm


@dataclass(frozen=True)
class JointSlice:
    """``|det J|`` over two joints (1-based ``joints``), the others at ``q_fixed``.

    Grids have shape (len(v), len(u)); ``u`` holds joint ``joints[0]``'s values, ``v`` joint
    ``joints[1]``'s (rad, or m for a prismatic joint). ``signed[kind]`` is the kind's signed
    factor, ``loci[kind]`` the cells its zero set passes through.
    """

    robot: str
    joints: tuple[int, int]
    q_fixed: Array
    u: Array
    v: Array
    manipulability: Array
    signed: dict[str, Array]
    loci: dict[str, Mask]


def default_fixed_q(robot: Arm) -> Array:
    """Joint values held fixed in the joint slices: 0 (clipped to the limits), except joint 2 at
    30 deg (away from the upright pose, where the stretched arm puts the wrist centre on axis 1)
    and joint 5 at theta5 = 90 deg (farthest from the wrist singularity), each when within its
    limits."""
    q = np.clip(np.zeros(robot.dof), robot.lower, robot.upper)
    shoulder = robot.table.joints[1]
    if shoulder.is_revolute and shoulder.lower <= math.pi / 6 <= shoulder.upper:
        q[1] = math.pi / 6
    wrist = robot.table.joints[4]
    if wrist.is_revolute:
        value = (math.pi / 2 - wrist.offset) / wrist.direction
        if wrist.lower <= value <= wrist.upper:
            q[4] = value
    return q


def joint_slice(robot: Arm, joints: tuple[int, int] = (2, 3), q_fixed: ArrayLike | None = None,
                resolution: int = DEFAULT_JOINT_RESOLUTION) -> JointSlice:
    """``|det J|`` and singular loci on a grid of two joints over their limits (one turn, centred
    on 0, for a joint whose limits span more), the others at ``q_fixed`` (default:
    :func:`default_fixed_q`)."""
    _check_resolution(resolution)
    model = singularity_model(robot)
    if len(joints) != 2 or len(set(joints)) != 2 or not all(
            isinstance(j, (int, np.integer)) and 1 <= j <= robot.dof for j in joints):
        raise InputError(f"joints: expected two different joint numbers 1..{robot.dof}, "
                         f"got {joints!r}", field="joints")
    fixed = (default_fixed_q(robot) if q_fixed is None
             else joint_vector(q_fixed, robot.dof, "q_fixed"))
    first, second = joints[0] - 1, joints[1] - 1
    u = np.linspace(*_slice_range(robot.table, first), resolution)
    v = np.linspace(*_slice_range(robot.table, second), resolution)
    uu, vv = np.meshgrid(u, v)
    Q = np.repeat(fixed[None], uu.size, axis=0)
    Q[:, first] = uu.ravel()
    Q[:, second] = vv.ravel()
    factors = model.factors(Q)
    grid = uu.shape
    signed = {kind: factors.signed(kind).reshape(grid) for kind in model.kinds}
    loci = {kind: _sign_change_cells(values) for kind, values in signed.items()}
    return JointSlice(robot=robot.name, joints=(int(joints[0]), int(joints[1])), q_fixed=fixed,
                      u=u, v=v, manipulability=np.abs(factors.determinant).reshape(grid),
                      signed=signed, loci=loci)


def _slice_range(table: DHTable, joint: int) -> tuple[float, float]:
    """A joint's limits, or one turn [-pi, pi] centred on 0 when they span more than a turn (the
    kinematics repeat every turn)."""
    info = table.joints[joint]
    if info.is_revolute and info.upper - info.lower > 2 * math.pi:
        return -math.pi, math.pi
    return info.lower, info.upper


def _sign_change_cells(values: Array) -> Mask:
    """Cells at a zero of ``values`` or, of two neighbours of opposite sign, the smaller one."""
    marked = values == 0
    for axis in (0, 1):
        a = np.moveaxis(values, axis, 0)
        out = np.moveaxis(marked, axis, 0)
        change = np.sign(a[:-1]) * np.sign(a[1:]) < 0
        first_smaller = np.abs(a[:-1]) <= np.abs(a[1:])
        out[:-1] |= change & first_smaller
        out[1:] |= change & ~first_smaller
    return marked
