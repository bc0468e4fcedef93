"""Numerical IK on a Pinocchio model: Levenberg-Marquardt with joint limits, restarts and nullspace
motion (:mod:`.solver` documents the conventions). Every public name is importable from
``dhkin.ik.numerical``.
"""

from __future__ import annotations

from dhkin.ik.numerical.entry import numerical_ik
from dhkin.ik.numerical.settings import (
    DEFAULT_TOLERANCE,
    DISTINCT_TOLERANCE,
    LAMBDA_FLOOR,
    NULLSPACE_TOLERANCE,
    TWO_PI,
    UNLIMITED,
    Descent,
    Method,
    Mode,
    NumericalReport,
    Preference,
    SolverSettings,
)
from dhkin.ik.numerical.solver import (
    NumericalIK,
    RobotLike,
)

__all__ = [
    "DEFAULT_TOLERANCE",
    "DISTINCT_TOLERANCE",
    "LAMBDA_FLOOR",
    "NULLSPACE_TOLERANCE",
    "TWO_PI",
    "UNLIMITED",
    "Descent",
    "Method",
    "Mode",
    "NumericalIK",
    "NumericalReport",
    "Preference",
    "RobotLike",
    "SolverSettings",
    "numerical_ik",
]
