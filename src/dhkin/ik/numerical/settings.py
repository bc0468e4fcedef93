"""Numerical IK: its constants, settings, result types and input checks (see
:mod:`dhkin.ik.numerical.solver`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Literal, TypeAlias

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from dhkin import _core
from dhkin.errors import InputError
from dhkin.ik.result import IKSolutions
from dhkin.tolerances import DEFAULT_TOLERANCE

Mode: TypeAlias = Literal["pose", "position"]


Method: TypeAlias = Literal["lm", "dls", "newton"]


Preference: TypeAlias = Literal["auto", "seed", "mid_range"] | None


TWO_PI = 2.0 * math.pi


_PRISMATIC_NAME = re.compile(r"^JointModel(P[XYZ]|Prismatic)")




#: Smallest damping added to J J^T: keeps the system solvable when J loses rank, and is far too
#: small to slow the quadratic convergence of the last Newton steps (sigma_min^2 >> 1e-12). The
#: compiled descent's kLambdaFloor (cpp/dhkin/numerical/descent.hpp), where the descent's other
#: constants (the LM damping rules, the slide's thresholds) live.
LAMBDA_FLOOR: float = _core.NUMERICAL_LAMBDA_FLOOR


#: Two solutions are the same when no joint differs by more than this (rad or m), revolute
#: differences taken modulo 2 pi (2 pi-shifted copies are one solution here).
DISTINCT_TOLERANCE = 1e-4


#: A null-space motion smaller than this (rad) counts as finished.
NULLSPACE_TOLERANCE = 1e-6


#: Limits wider than this (rad or m) are treated as no limit (URDF joints without a real bound).
UNLIMITED = 1e6


#: Int seeds whose random starts are kept per solver.
_MAX_BANKS = 8


#: Seed of the table of warm starts (fixed: solves are reproducible).
_WARM_START_SEED = 20240607


#: Rotation weight of the warm-start distance, as a fraction of the arm's reach (m per rad).
_WARM_START_ROTATION_WEIGHT = 0.3


@dataclass(frozen=True)
class Descent:
    """The outcome of one local descent from one start (a solution only if ``converged``).

    ``q`` is where the descent ended (the best point it reached for ``"lm"``; the last iterate for
    ``"newton"`` and ``"dls"``), always within the joint limits; ``position_error`` (m) and
    ``rotation_error`` (rad, NaN in position mode) are its residuals; ``iterations`` counts the
    evaluations of kinematics and Jacobian after the start's; ``nullspace_motion`` is the size
    (rad) of the last null-space step (0 when the task has no redundancy or it was off).
    """

    q: NDArray[np.float64]
    start: NDArray[np.float64]
    position_error: float
    rotation_error: float
    iterations: int
    converged: bool
    nullspace_motion: float = 0.0

    @property
    def residual(self) -> float:
        """The larger of the two residuals (position only in position mode)."""
        if math.isnan(self.rotation_error):
            return self.position_error
        return max(self.position_error, self.rotation_error)


@dataclass(frozen=True)
class NumericalReport:
    """A numerical solve in detail: the solutions and every descent that was run for them."""

    solutions: IKSolutions
    descents: tuple[Descent, ...]

    @property
    def iterations(self) -> int:
        """Total iterations over all starts."""
        return sum(d.iterations for d in self.descents)

    @property
    def starts(self) -> int:
        return len(self.descents)

    @property
    def best(self) -> Descent | None:
        """The descent that got closest to the target (None before any start)."""
        if not self.descents:
            return None
        return min(self.descents, key=lambda d: d.residual)


@dataclass(frozen=True)
class SolverSettings:
    """Knobs of the solver (defaults suit arms of about a metre, targets in m and rad).

    * ``method``: ``"lm"``, ``"dls"`` or ``"newton"`` (module docstring); ``damping``: the
      fixed damping of ``"dls"`` (lambda = damping^2).
    * ``tolerance``: a solution's position (m) and rotation (rad) residuals are <= this.
    * ``max_iterations``: per start, phase 1 (reaching the task).
    * ``stall_window``, ``stall_ratio``: a start is abandoned when its cost has not fallen
      below ``stall_ratio`` times its value ``stall_window`` iterations earlier.
    * ``nullspace_gain`` (0..1), ``nullspace_tolerance`` (rad), ``slide_iterations``: phase 2
      (redundant tasks), see :meth:`NumericalIK._slide`.
    * ``distinct_tolerance``: two solutions are one when no joint differs by more (modulo 2 pi
      for revolute joints).
    * ``warm_starts``: size of the table the first seed-free start is picked from (0: random).
    """

    method: Method = "lm"
    tolerance: float = DEFAULT_TOLERANCE
    max_iterations: int = 100
    damping: float = 1e-2
    nullspace_gain: float = 0.5
    nullspace_tolerance: float = NULLSPACE_TOLERANCE
    slide_iterations: int = 200
    distinct_tolerance: float = DISTINCT_TOLERANCE
    stall_window: int = 10
    stall_ratio: float = 0.5
    warm_starts: int = 256

    def checked(self) -> SolverSettings:
        """Self, after checking every value (IKInputError naming the bad one)."""
        if self.method not in ("lm", "dls", "newton"):
            raise InputError(field="method", value=self.method,
                             expected="'lm', 'dls' or 'newton'")
        _positive("tolerance", self.tolerance)
        _positive("damping", self.damping, allow_zero=self.method != "dls")
        _positive("nullspace_gain", self.nullspace_gain, allow_zero=True)
        if self.nullspace_gain > 1.0:
            raise InputError(f"nullspace_gain: expected a value in [0, 1], "
                             f"got {self.nullspace_gain!r}", field="nullspace_gain")
        _positive("nullspace_tolerance", self.nullspace_tolerance)
        _positive("distinct_tolerance", self.distinct_tolerance)
        _count("max_iterations", self.max_iterations, minimum=1)
        _count("slide_iterations", self.slide_iterations, minimum=1)
        _count("stall_window", self.stall_window, minimum=1)
        _positive("stall_ratio", self.stall_ratio)
        _count("warm_starts", self.warm_starts, minimum=0)
        return self


def _positive(name: str, value: float, allow_zero: bool = False) -> None:
    ok = isinstance(value, int | float | np.floating) and math.isfinite(value) and (
        value >= 0 if allow_zero else value > 0)
    if not ok:
        bound = ">= 0" if allow_zero else "> 0"
        raise InputError(f"{name}: expected a finite number {bound}, got {value!r}", field=name)


def _norm(vector: NDArray[np.float64]) -> float:
    """Euclidean norm of a short vector (cheaper than np.linalg.norm for 2-6 entries)."""
    return math.sqrt(float(vector @ vector))


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def _is_revolute(joint: pin.JointModel) -> bool:
    """Angle-valued joints (revolute, continuous): 2 pi shifts apply. Prismatic ones: no."""
    return _PRISMATIC_NAME.match(joint.shortname()) is None


def _as_array(name: str, value: ArrayLike) -> NDArray[np.float64]:
    try:
        return np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected numbers, got {value!r}", field=name) from exc


def _check_pose(name: str, T: NDArray[np.float64]) -> None:
    """IKInputError unless T is a finite homogeneous transform with a proper rotation."""
    if not np.isfinite(T).all():
        raise InputError(f"{name}: expected finite numbers, got NaN or inf", field=name)
    R = T[:3, :3]
    orthogonality = float(np.abs(R @ R.T - _IDENTITY3).max())
    (a, b, c), (d, e, f), (g, h, i) = R.tolist()
    determinant = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if orthogonality > 1e-6 or determinant < 0:
        raise InputError(f"{name}: rotation block is not a rotation matrix "
                         f"(|R R^T - I| = {orthogonality:.2e}, det {determinant:.3g}; "
                         f"expected <= 1e-6 and det +1)", field=name)
    if T[3].tolist() != [0.0, 0.0, 0.0, 1.0]:
        raise InputError(f"{name}: expected last row (0, 0, 0, 1), got {T[3]}", field=name)


_IDENTITY3 = np.eye(3)


def _count(name: str, value: int, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise InputError(f"{name}: expected an integer >= {minimum}, got {value!r}", field=name)
    return int(value)
