"""Numerical IK: the descent from one start, run by the compiled core
(``cpp/dhkin/numerical/descent.hpp``: damped least squares within the joint limits, sliding along
a limit, nullspace motion) on the chain of the Pinocchio model (:meth:`_Chain.parts`), and the
checks of a reached point (every answer re-measured by Pinocchio forward kinematics).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from functools import lru_cache

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from dhkin import _core
from dhkin.ik.numerical.settings import (
    TWO_PI,
    Descent,
    SolverSettings,
    _norm,
    _same,
)
from dhkin.ik.numerical.task import _Chain, _Task


class DescentMethods:
    """The descent of :class:`~dhkin.ik.numerical.solver.NumericalIK` (a mixin of it): one start
    taken to a solution by the compiled core, and the checks of a reached point (joint values in
    the chain's order). The attributes below are set by NumericalIK."""

    dof: int
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    _chain: _Chain
    _core_chain: _core.NumericalChain
    _revolute: NDArray[np.bool_]
    _revolute_list: list[bool]

    def project(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """Joint values put into the limits: 2 pi shifts for revolute joints, else clipping."""
        projected = np.empty(self.dof)
        self._core_chain.project(np.asarray(q, dtype=float), projected)
        return projected

    def _descend(self, task: _Task, start: NDArray[np.float64],
                 settings: SolverSettings) -> Descent:
        """Reach the task from ``start``; then, for a redundant task, slide along the solutions
        toward the preferred configuration (the compiled descent; the rules are those of
        :meth:`~dhkin.ik.numerical.solver.NumericalIK.solve` and ``descent.hpp``)."""
        q = np.empty(self.dof)
        position, rotation, iterations, converged, motion = self._core_chain.descend(
            task.core(), _compiled(settings), np.asarray(start, dtype=float), q)
        return Descent(q, start, position, rotation, iterations, converged, motion)

    def _measure(self, task: _Task, q: NDArray[np.float64]) -> tuple[float, float]:
        """(position, rotation) residuals of q by Pinocchio FK, in the base frame."""
        placement = self._chain.tip_placement(q)
        if task.tcp is not None:
            placement = placement * task.tcp
        if task.mode == "pose":
            error = task.target_inverse * placement
            return _norm(error.translation), _norm(pin.log3(error.rotation))
        difference = placement.translation - task.world_point
        if task.base_rotation_t is not None:
            difference = task.base_rotation_t @ difference
        return _norm(difference[:task.rows]), math.nan

    def _checked(self, task: _Task, descent: Descent, settings: SolverSettings) -> Descent:
        """A converged descent re-measured by FK and checked against the limits; demoted to
        not converged (with the measured residuals) if it is not exact after all."""
        if not descent.converged:
            return descent
        position, rotation = self._measure(task, descent.q)
        tolerance = settings.tolerance
        inside = bool(((descent.q >= self.lower) & (descent.q <= self.upper)).all())
        if position <= tolerance and not rotation > tolerance and inside:
            if position == descent.position_error and _same(rotation, descent.rotation_error):
                return descent
            return replace(descent, position_error=position, rotation_error=rotation)
        return replace(descent, position_error=position, rotation_error=rotation,
                       converged=False)

    def _turns(self, q: NDArray[np.float64]) -> tuple[int, ...]:
        """round(q / 2 pi) for revolute joints, 0 for prismatic ones."""
        return tuple(round(value / TWO_PI) if revolute else 0
                     for value, revolute in zip(q.tolist(), self._revolute_list, strict=True))

    def _known(self, q: NDArray[np.float64], found: Sequence[NDArray[np.float64]],
               settings: SolverSettings) -> bool:
        for other in found:
            difference = q - other
            wrapped = np.where(self._revolute,
                               np.mod(difference + math.pi, TWO_PI) - math.pi, difference)
            if np.abs(wrapped).max() <= settings.distinct_tolerance:
                return True
        return False


#: Settings kept compiled: the solver's own and a few per-call variants (tolerance, method,
#: max_iterations); bounded so that callers varying them cannot grow the cache without end.
_COMPILED_SETTINGS = 32


@lru_cache(maxsize=_COMPILED_SETTINGS)
def _compiled(settings: SolverSettings) -> _core.NumericalSettings:
    """The settings as the compiled descent takes them."""
    return _core.NumericalSettings(
        settings.method, settings.tolerance, settings.max_iterations, settings.damping,
        settings.nullspace_gain, settings.nullspace_tolerance, settings.slide_iterations,
        settings.stall_window, settings.stall_ratio)
