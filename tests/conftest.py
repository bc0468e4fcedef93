"""Shared fixtures: robots and their oracle (Pinocchio on the URDF generated through xacro)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dhkin
from dhkin.reference import Reference

REPO = Path(__file__).resolve().parents[1]
#: The vendor reference URDFs shipped with the project (provenance and licences:
#: robots/vendor/README.md).
REFERENCE_URDFS = REPO / "robots" / "vendor"
DATA = Path(__file__).resolve().parent / "data"
#: The seed documents the tests read (provenance: tests/data/seeds/README.md).
SEED_DOCUMENTS = DATA / "seeds"


def _per_robot_builtins() -> list[str]:
    from dhkin.vendors import PACKAGE_ARMS

    sample = set(PACKAGE_ARMS_SAMPLED)
    return [name for name in dhkin.builtin_names() if name not in PACKAGE_ARMS or name in sample]


#: The arms of the ROS-Industrial support packages (dhkin.vendors.PACKAGE_ARMS) that the
#: per-robot tests of code paths (FK, frames, Jacobians, conventions, URDF validators) run on:
#: one per maker and per IK family, and the odd ones: KUKA KR 10 R1100 sixx, FANUC M-900iB/700
#: (limits written 1.5707 and 3.1415: just inside pi/2 and pi), Yaskawa MotoMINI (a vendor
#: expansion equal to the table to 1e-15) and GP12 (tool0 is not OPW's flange), HC10 (general
#: 6R), LR Mate 200iC/5H (5 axes) and SIA10F (7 axes). All 54 are imported as the same kind of
#: table; each one's data is checked by the tests that run on every arm (committed files equal
#: their regeneration and import, tables valid and round-tripped, generated URDF equal to the
#: vendor expansion in Pinocchio with its limits, own FK equal to Pinocchio) and by
#: `dhkin check --all` (docs/check.md).
PACKAGE_ARMS_SAMPLED = ("kuka_kr10r1100sixx", "fanuc_m900ib700", "motoman_motomini",
                        "motoman_gp12", "motoman_hc10", "fanuc_lrmate200ic5h", "motoman_sia10f")
#: Every built-in robot but the package arms outside PACKAGE_ARMS_SAMPLED.
PER_ROBOT_BUILTINS = _per_robot_builtins()


def oracle_errors(robot: dhkin.Robot, q: np.ndarray,
                  T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and rotation (rad) errors of Pinocchio FK(q) (M, n) against poses (M, 4, 4)."""
    from dhkin.transforms import pose_error

    return pose_error(robot.reference().fk(q), T)


def oracle_sigma_min(reference: Reference, q: np.ndarray) -> np.ndarray:
    """``reference.manipulability(row).sigma_min`` of each row of q (M, dof), bit for bit (the
    same Jacobians, the same LAPACK SVD matrix by matrix), without three SVDs and a dataclass a
    row: the smallest singular value of Pinocchio's LOCAL_WORLD_ALIGNED Jacobian (0 for fewer
    than six joints)."""
    if reference.dof < 6:
        return np.zeros(len(q))
    return np.linalg.svd(reference.jacobians(q, reference="local_world_aligned"),
                         compute_uv=False)[:, -1]


@pytest.fixture(scope="session")
def load_robot():
    cache: dict[str, dhkin.Robot] = {}

    def _load(name: str) -> dhkin.Robot:
        if name not in cache:
            cache[name] = dhkin.load(name)
        return cache[name]

    return _load
