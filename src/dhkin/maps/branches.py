"""The planes and defaults of the maps, and IK over distinct branches: one solution per branch of
many poses, for the maps' best |det J| over the branches.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.errors import InputError

if TYPE_CHECKING:
    from dhkin.arm import Arm


Array = NDArray[np.float64]


Mask = NDArray[np.bool_]


PLANES: dict[str, tuple[int, int, int]] = {"xz": (0, 2, 1), "yz": (1, 2, 0), "xy": (0, 1, 2)}


AXIS_NAMES = "xyz"


#: Default tool0 orientation (URDF rpy, rad) of the workspace slice, per family, chosen so that
#: the x-z slice crosses wrist singular loci. Spherical wrist: tool0 z along +x, in the slice
#: (singular where the forearm, axis 4, is horizontal). Offset wrist: axis 4 stays parallel to
#: axis 2, i.e. horizontal and across the arm, so the wrist is singular only with a horizontal
#: tool axis across the arm: tool0 z horizontal at 45 deg to the slice (loci: vertical lines).
DEFAULT_RPY: dict[str, tuple[float, float, float]] = {
    "spherical_wrist": (0.0, math.pi / 2, 0.0),
    "stanford": (0.0, math.pi / 2, 0.0),
    "offset_wrist": (0.0, math.pi / 2, math.pi / 4),
}


DEFAULT_RESOLUTION = 161


DEFAULT_JOINT_RESOLUTION = 181


#: Poses per IK batch (memory: the batch holds every 2pi copy before it is reduced).
CHUNK = 2000


def principal_table(table: DHTable) -> DHTable:
    """The same table with every revolute joint limited to [-pi, pi]: IK then returns one copy
    per branch instead of every 2pi copy within the real limits."""
    joints = tuple(dataclasses.replace(j, lower=-math.pi, upper=math.pi) if j.is_revolute else j
                   for j in table.joints)
    return dataclasses.replace(table, joints=joints)


def has_copy_within_limits(table: DHTable, q: Array) -> Mask:
    """Whether some 2pi-shifted copy of each q (..., n) lies within the table's limits."""
    lower, upper = table.lower, table.upper
    revolute = np.array([j.is_revolute for j in table.joints])
    two_pi = 2.0 * math.pi
    first = np.ceil((lower - 1e-10 - q) / two_pi)
    last = np.floor((upper + 1e-10 - q) / two_pi)
    inside = np.where(revolute, first <= last, (q >= lower - 1e-10) & (q <= upper + 1e-10))
    return np.all(inside, axis=-1)


class BranchSolver:
    """IK of many poses, one solution per branch: q (N, B, n) and valid (N, B)."""

    def __init__(self, robot: Arm) -> None:
        from dhkin.ik.family import fit_family
        from dhkin.ik.solver import ClosedFormSolver

        self.table = robot.table
        principal = principal_table(robot.table)
        self.principal = ClosedFormSolver(principal, fit_family(principal))
        self.n_branches = len(self.principal.branch_labels)

    def solve(self, T: Array) -> tuple[Array, Mask]:
        n = len(T)
        q = np.zeros((n, self.n_branches, self.table.dof))
        valid = np.zeros((n, self.n_branches), bool)
        if n == 0:
            return q, valid
        batch = self.principal.solve_batch(T)
        pose, slot = np.nonzero(batch.valid)
        branch = batch.branch[pose, slot]
        # a refined table's roots beyond the slots follow its slots' roots (their branch may be
        # one a slot answers): the slot's root, continuous with the ideal model's, stands for it
        _, first = np.unique(pose * self.n_branches + branch, return_index=True)
        pose, slot, branch = pose[first], slot[first], branch[first]
        q[pose, branch] = batch.q[pose, slot]
        valid[pose, branch] = True
        valid &= has_copy_within_limits(self.table, q)
        return q, valid


def _chunks(n: int, size: int, progress: bool, label: str) -> Iterator[slice]:
    starts = range(0, n, size)
    if progress:
        from tqdm import tqdm

        starts = tqdm(starts, total=math.ceil(n / size), desc=label, unit="chunk",
                      file=sys.stderr, leave=False)
    for start in starts:
        yield slice(start, min(start + size, n))


def _check_resolution(resolution: int) -> None:
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) \
            or not 8 <= resolution <= 2000:
        raise InputError(f"resolution: expected an integer from 8 to 2000, "
                         f"got {resolution!r}", field="resolution")
