"""Offset-wrist IK of poses computed on the vendors' URDFs, checked on those URDFs.

Poses come from Pinocchio on ../shared/reference/ur5.urdf (base_link -> tool0) and
aubo_i10.urdf (base_link -> wrist3_Link, which is the AUBO table's tool0); the IK works from our
DH tables; every distinct principal solution is put back through the vendor's URDF. The vendor UR
files round pi/2 to 1.570796327 (~6e-10 rad, 3e-10 m from the exact DH), hence 1e-9 here. The
original joint vector is among the solutions to 1e-6 rad, or to 1e-9 / sigma_min of the Jacobian
near a singularity (the vendor-vs-DH difference, seen through the conditioning).
"""

from __future__ import annotations

import numpy as np
import pytest

from dhkin.reference import Reference
from dhkin.transforms import pose_error

from .conftest import REFERENCE_URDFS

VENDOR_TOL = 1e-9
N_POSES = 3000
CHUNK = 500
VENDORS = [("ur5", "ur5.urdf", "tool0", 55), ("aubo_i10", "aubo_i10.urdf", "wrist3_Link", 10)]


def wrap(q: np.ndarray) -> np.ndarray:
    return np.pi - np.mod(np.pi - q, 2.0 * np.pi)


@pytest.mark.parametrize("name, file, tip, seed", VENDORS)
def test_vendor_poses_are_reproduced_on_the_vendor_urdf(name, file, tip, seed, load_robot):
    robot = load_robot(name)
    path = REFERENCE_URDFS / file
    vendor = Reference(path.read_text(encoding="utf-8"), tip=tip, base="base_link",
                       source=str(path))
    assert vendor.dof == 6
    q0 = robot.table.random_q(N_POSES, np.random.default_rng(seed))
    T = vendor.fk(q0)
    worst_vendor = worst_ours = worst_joint = 0.0
    for start in range(0, N_POSES, CHUNK):
        part = slice(start, start + CHUNK)
        batch = robot.ik_batch_detailed(T[part])
        pose, slot = np.nonzero(batch.valid)
        key = pose * len(batch.branch_labels) + batch.branch[pose, slot]
        _, first = np.unique(key, return_index=True)
        principal = wrap(batch.q[pose, slot][first])
        targets = T[part][pose[first]]
        position, rotation = pose_error(vendor.fk(principal), targets)
        worst_vendor = max(worst_vendor, position.max(), rotation.max())
        position, rotation = pose_error(robot.reference().fk(principal), targets)
        worst_ours = max(worst_ours, position.max(), rotation.max())
        distance = np.where(batch.valid, np.abs(batch.q - q0[part][:, None]).max(2),
                            np.inf).min(1)
        # The original is a solution of the vendor's kinematics, not exactly of ours: where the
        # Jacobian is nearly singular the 6e-10 between them moves the joints by ~6e-10 / sigma.
        for k in np.flatnonzero(distance > 1e-6):
            sigma = robot.reference().manipulability(q0[part][k]).sigma_min
            assert distance[k] <= VENDOR_TOL / sigma, (q0[part][k], distance[k], sigma)
        worst_joint = max(worst_joint, distance.max())
    print(f"\n{name} vs {file}: {N_POSES} poses, max residual on the vendor URDF "
          f"{worst_vendor:.2e}, on ours {worst_ours:.2e}, joint distance to the original "
          f"{worst_joint:.2e} rad")
    assert worst_vendor <= VENDOR_TOL
    assert worst_ours <= VENDOR_TOL
    assert np.isfinite(worst_joint)
