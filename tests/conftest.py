"""Shared fixtures: robots and their oracle (Pinocchio on the URDF generated through xacro)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dhkin

REPO = Path(__file__).resolve().parents[1]
#: The vendor reference URDFs shipped with the project (provenance and licences:
#: robots/vendor/README.md).
REFERENCE_URDFS = REPO / "robots" / "vendor"
DATA = Path(__file__).resolve().parent / "data"
#: The seed documents the tests read (provenance: tests/data/seeds/README.md).
SEED_DOCUMENTS = DATA / "seeds"


def oracle_errors(robot: dhkin.Robot, q: np.ndarray,
                  T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and rotation (rad) errors of Pinocchio FK(q) (M, n) against poses (M, 4, 4)."""
    from dhkin.transforms import pose_error

    return pose_error(robot.reference().fk(q), T)


@pytest.fixture(scope="session")
def load_robot():
    cache: dict[str, dhkin.Robot] = {}

    def _load(name: str) -> dhkin.Robot:
        if name not in cache:
            cache[name] = dhkin.load(name)
        return cache[name]

    return _load
