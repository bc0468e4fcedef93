"""Check a robot's own IK against the oracle on random poses (used by `dhkin check`).

Joint vectors are sampled uniformly within the limits (fixed seed); their poses come from
Pinocchio on the generated URDF; every distinct returned solution (modulo 2pi) is checked with
Pinocchio, and every returned 2pi copy must be an exact shift of a checked one within the limits.
Completeness: the sampled joint vector is among the returned solutions (max joint difference
<= :data:`COMPLETENESS_TOLERANCE`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dhkin.ik.closed_form import TWO_PI, wrap_revolute
from dhkin.robot import Robot
from dhkin.transforms import pose_error

#: Joint-space distance (rad or m) under which a returned solution "is" the sampled vector. Away
#: from singularities the solvers reproduce q to ~1e-12; 1e-6 leaves room for |sin q5| ~ 1e-5.
COMPLETENESS_TOLERANCE = 1e-6


@dataclass(frozen=True)
class IKCheck:
    """Outcome of :func:`check_ik`."""

    robot: str
    family: str
    poses: int
    solutions: int
    distinct_checked: int
    max_position: float
    max_rotation: float
    complete: int
    bad_copies: int

    @property
    def completeness(self) -> float:
        return self.complete / self.poses if self.poses else 0.0

    def ok(self, tolerance: float = 1e-9) -> bool:
        return (self.max_position <= tolerance and self.max_rotation <= tolerance
                and self.complete == self.poses and self.bad_copies == 0)


def check_ik(robot: Robot, n: int = 10_000, seed: int = 0) -> IKCheck:
    """Sample n joint vectors, solve their poses, check every solution against Pinocchio."""
    rng = np.random.default_rng(seed)
    q_true = robot.table.random_q(n, rng)
    oracle = robot.reference()
    targets = oracle.fk(q_true)
    batch = robot.ik_batch_detailed(targets)
    pose_idx, slot = np.nonzero(batch.valid)
    solutions = batch.q[pose_idx, slot]

    # Distinct solutions modulo 2pi, per pose: checked with Pinocchio.
    principal = wrap_revolute(robot.table, solutions)
    keys = np.round(principal, 9)
    keyed = np.concatenate([pose_idx[:, None].astype(float), keys], axis=1)
    _, first, inverse = np.unique(keyed, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    position, rotation = pose_error(oracle.fk(principal[first]), targets[pose_idx[first]])

    # Every copy is its distinct representative shifted by whole turns, inside the limits.
    shift = (solutions - principal[first][inverse]) / TWO_PI
    whole_turns = np.abs(shift - np.round(shift)).max(axis=1) < 1e-9
    inside = robot.table.in_limits(solutions)
    bad_copies = int(np.count_nonzero(~(whole_turns & inside)))

    distance = np.abs(solutions - q_true[pose_idx]).max(axis=1)
    found = np.zeros(n, bool)
    found[pose_idx[distance <= COMPLETENESS_TOLERANCE]] = True
    return IKCheck(
        robot=robot.name, family=batch.family, poses=n, solutions=int(solutions.shape[0]),
        distinct_checked=int(first.size),
        max_position=float(position.max()) if position.size else 0.0,
        max_rotation=float(rotation.max()) if rotation.size else 0.0,
        complete=int(found.sum()), bad_copies=bad_copies,
    )

