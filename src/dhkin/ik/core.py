"""The Python face of the compiled core (``dhkin._core``, C++ in ``cpp/dhkin/``): its constants, the
family ids, and how a family's geometry is handed to it.

The core holds the per-pose work of the closed-form IK: the exact chain (FK, Jacobian, Newton
refinement), the spherical-wrist, Stanford and offset-wrist closed forms, the verification of
every branch and the 2pi copies within the limits (docs/architecture.md). It is built by
``pip install .`` (scikit-build-core, nanobind); nothing is compiled at run time.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin import _core

#: Singularity bits (the same as dhkin.ik.result's WRIST, ELBOW, SHOULDER).
WRIST, ELBOW, SHOULDER = 1, 2, 4

#: A solution is flagged at a singularity within this band of it (|sin| of the wrist or elbow
#: angle, the wrist centre's distance from axis 1 over the table's scale): a report only; what is
#: returned is decided by the verification tolerance (cpp/dhkin/bands.hpp).
FLAG_BAND: float = _core.FLAG_BAND
#: Two roots of one equation closer than twice this angle are one solution (cpp/dhkin/bands.hpp).
MERGE_ANGLE: float = _core.MERGE_ANGLE
#: Solutions are verified at the tolerance less this many metres per metre of lever: the
#: rounding between two double-precision FKs of one chain (ours, Pinocchio's), with a tenfold
#: margin (cpp/dhkin/plan.hpp).
FK_ROUNDING: float = _core.FK_ROUNDING
#: Largest |R R^T - I| entry of an accepted rotation block (cpp/dhkin/pose.hpp).
ORTHONORMALITY_GATE: float = _core.ORTHONORMALITY_GATE
#: Largest deviation of a pose's bottom row from [0, 0, 0, 1] (cpp/dhkin/pose.hpp).
BOTTOM_ROW_TOLERANCE: float = _core.BOTTOM_ROW_TOLERANCE

#: Why the core rejected a pose or seed (cpp/dhkin/pose.hpp, ``PoseStatus``).
STATUS_NOT_FINITE, STATUS_BOTTOM_ROW, STATUS_NOT_ROTATION, STATUS_BAD_SEED = 1, 2, 3, 4

#: Family ids of the compiled core (cpp/dhkin/plan.hpp, ``Family``).
SPHERICAL_WRIST, STANFORD, OFFSET_WRIST = 1, 2, 3

#: Branches of every family (index 4 * shoulder + 2 * elbow + wrist).
BRANCHES: int = _core.BRANCHES
#: Numbers an empty answer is explained with (each family's ``explain``).
WHY_SIZE: int = _core.WHY_SIZE
#: Most roots a refined table's pose has beyond its branch slots (a six-revolute pose has at
#: most 16 isolated roots; cpp/dhkin/extra_roots.hpp).
EXTRA_ROOTS: int = _core.EXTRA_ROOTS


def geometry_fields(values: dict[str, ArrayLike]) -> dict[str, NDArray[np.float64]]:
    """A family's geometry as the core reads it: each named value a flat float64 array
    (matrices row-major); the core refuses a missing or unknown name."""
    return {name: np.ascontiguousarray(value, dtype=np.float64).ravel()
            for name, value in values.items()}


def pose_status(T: ArrayLike) -> int:
    """0 for a usable pose (4, 4), else a STATUS_* (not finite, bottom row, not a rotation)."""
    return int(_core.pose_status(np.ascontiguousarray(T, dtype=np.float64)))


def project(T: ArrayLike) -> tuple[NDArray[np.float64], float]:
    """(T with its rotation block replaced by the nearest rotation, Frobenius norm of the
    change); T must have status 0."""
    frame, moved = _core.project(np.ascontiguousarray(T, dtype=np.float64))
    return frame, float(moved)
