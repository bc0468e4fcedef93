"""Numerical IK: the descent (damped least squares within the joint limits, sliding along a limit,
nullspace motion) and the checks of a reached point.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from dhkin.ik.numerical.settings import (
    _AT_LIMIT,
    _MU_DOWN,
    _MU_INITIAL,
    _MU_MAX,
    _MU_MIN,
    _MU_UP,
    _PINV_RCOND,
    _SLIDE_CLOSE,
    _SLIDE_LOST,
    _SLIDE_NEAR,
    _SLIDE_PATIENCE,
    _SLIDE_STEP,
    LAMBDA_FLOOR,
    TWO_PI,
    Descent,
    SolverSettings,
    _Error,
    _norm,
    _same,
    _skew,
    _task_step,
)
from dhkin.ik.numerical.task import _Chain, _Task


class DescentMethods:
    """The descent of :class:`~dhkin.ik.numerical.solver.NumericalIK` (a mixin of it): damped
    least-squares steps within the joint limits, sliding along a limit, nullspace motion, and the
    checks of a reached point (joint values in the chain's order). The attributes below are set
    by NumericalIK."""

    dof: int
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    _chain: _Chain
    _revolute: NDArray[np.bool_]
    _revolute_list: list[bool]

    def project(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """Joint values put into the limits: 2 pi shifts for revolute joints, else clipping."""
        return self._project(q)[0]

    def _project(self, q: NDArray[np.float64], wrap: bool = True
                 ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """:meth:`project`, and which joints had to be clipped (not merely shifted by 2 pi).
        With ``wrap`` False, joints are only clipped (no 2 pi shifts)."""
        above = q > self.upper
        outside = (q < self.lower) | above
        if not outside.any():
            return q, outside
        if not wrap:
            return np.clip(q, self.lower, self.upper), outside
        with np.errstate(invalid="ignore"):
            down = q - TWO_PI * np.ceil((q - self.upper) / TWO_PI)
            up = q + TWO_PI * np.ceil((self.lower - q) / TWO_PI)
        shifted = np.where(above, down, up)
        use_shift = outside & self._revolute & (shifted >= self.lower) & (shifted <= self.upper)
        projected = np.clip(np.where(use_shift, shifted, q), self.lower, self.upper)
        return projected, outside & ~use_shift

    def _evaluator(self, task: _Task) -> tuple[Callable[[NDArray[np.float64]], _Error],
                                               Callable[[], NDArray[np.float64]]]:
        """Two closures for the descent: ``error_at(q)`` -> (e, position, rotation) runs the
        kinematics at q; ``jacobian()`` -> J (rows x dof) of e at the q of the last
        ``error_at`` call (so a refused step costs no Jacobian)."""
        chain = self._chain
        model, data, tip_id = chain.model, chain.data, chain.tip_id
        placements = data.oMf
        configuration = chain.configuration
        tip_jacobian = chain.tip_jacobian
        compute, place = pin.computeJointJacobians, pin.updateFramePlacement
        if task.mode == "pose":
            target_inverse = task.target_inverse
            log6, Jlog6, LOCAL = pin.log6, pin.Jlog6, pin.LOCAL
            last: list[pin.SE3] = [target_inverse]

            def pose_error_at(q: NDArray[np.float64]) -> _Error:
                compute(model, data, configuration(q))
                place(model, data, tip_id)
                error_placement = target_inverse * placements[tip_id]
                last[0] = error_placement
                e = log6(error_placement).vector
                return e, _norm(error_placement.translation), _norm(e[3:])

            def pose_jacobian() -> NDArray[np.float64]:
                return Jlog6(last[0]) @ tip_jacobian(LOCAL)

            return pose_error_at, pose_jacobian

        rows, world_point, base_rotation_t = task.rows, task.world_point, task.base_rotation_t
        offset = None if task.tcp is None else task.tcp.translation.copy()
        offset_skew = None if offset is None else _skew(offset)

        def position_error_at(q: NDArray[np.float64]) -> _Error:
            compute(model, data, configuration(q))
            tip = place(model, data, tip_id)
            point = tip.translation - world_point
            if offset is not None:
                point = point + tip.rotation @ offset
            if base_rotation_t is not None:
                point = base_rotation_t @ point
            e = point[:rows]
            return e, _norm(e), math.nan

        def position_jacobian() -> NDArray[np.float64]:
            if offset_skew is None:
                J = tip_jacobian(pin.LOCAL_WORLD_ALIGNED)[:3]
            else:
                J_local = tip_jacobian(pin.LOCAL)
                J = placements[tip_id].rotation @ (J_local[:3] - offset_skew @ J_local[3:])
            if base_rotation_t is not None:
                J = base_rotation_t @ J
            return J[:rows]

        return position_error_at, position_jacobian

    def _descend(self, task: _Task, start: NDArray[np.float64],
                 settings: SolverSettings) -> Descent:
        """Reach the task from ``start``; then, for a redundant task, slide along the solutions
        toward the preferred configuration (:meth:`_slide`)."""
        descent = self._reach(task, start, settings)
        if descent.converged and task.preferred is not None and settings.nullspace_gain > 0:
            return self._slide(task, descent, settings)
        return descent

    def _reach(self, task: _Task, start: NDArray[np.float64],
               settings: SolverSettings) -> Descent:
        """Phase 1: LM, DLS or Newton steps until the task residuals are within tolerance.

        Stops when converged, after ``max_iterations``, when LM cannot find a descending step
        (mu > 1e8), or when the cost has not halved over ``stall_window`` iterations (a new
        start is then the better bet).
        """
        tolerance = settings.tolerance
        method = settings.method
        error_at, jacobian = self._evaluator(task)
        q = self.project(np.array(start, dtype=float))
        e, position, rotation = error_at(q)
        J = jacobian()
        cost = float(e @ e)
        mu = _MU_INITIAL
        iterations = 0
        costs = [cost]  # cost at the current point, per iteration
        window, stall_ratio = settings.stall_window, settings.stall_ratio
        while not (position <= tolerance and not rotation > tolerance):
            if iterations >= settings.max_iterations:
                break
            if iterations >= window and cost > stall_ratio * costs[iterations - window]:
                break
            if method == "lm":
                damping = mu * cost + LAMBDA_FLOOR
            elif method == "dls":
                damping = settings.damping * settings.damping
            else:
                damping = 0.0
            candidate = self._bounded_step(q, J, e, damping)
            iterations += 1
            e_new, position_new, rotation_new = error_at(candidate)
            cost_new = float(e_new @ e_new)
            if method == "lm" and not cost_new < cost:
                costs.append(cost)
                mu *= _MU_UP
                if mu > _MU_MAX:
                    break
                continue
            costs.append(cost_new)
            mu = max(mu / _MU_DOWN, _MU_MIN)
            q, e, position, rotation, cost = (candidate, e_new, position_new, rotation_new,
                                              cost_new)
            J = jacobian()
        converged = position <= tolerance and not rotation > tolerance
        return Descent(q, start, position, rotation, iterations, converged)

    def _bounded_step(self, q: NDArray[np.float64], J: NDArray[np.float64],
                      e: NDArray[np.float64], damping: float,
                      wrap: bool = True) -> NDArray[np.float64]:
        """q plus the task step, within the limits (2 pi shifts allowed when ``wrap``).

        A joint the step would push through a limit is put on the limit, its column leaves the
        Jacobian and the other joints take up its share of the error (one active-set round);
        whatever still leaves the limits is then clipped.
        """
        candidate, clipped = self._project(q + _task_step(J, e, damping), wrap)
        if not clipped.any():
            return candidate
        held = candidate - q
        held[~clipped] = 0.0
        free_J = J.copy()
        free_J[:, clipped] = 0.0
        step = _task_step(free_J, e + J @ held, damping)
        step[clipped] = held[clipped]
        return self._project(q + step, wrap)[0]

    def _slide(self, task: _Task, reached: Descent, settings: SolverSettings) -> Descent:
        """Phase 2 (redundant tasks): move from a solution along the solutions toward the
        preferred configuration.

        Each iteration, at q with task error e: if e is small (both residuals <= 1e-2), step
        by the null-space motion ``n = (I - J^+ J) gain W (q_preferred - q)`` (scaled down to
        a largest joint motion ``cap`` and to stop at the first limit it meets) and correct the
        task by a Newton step (:meth:`_bounded_step`, so joints on a limit stay there);
        otherwise correct the task only. ``cap`` starts at 0.3 rad, halves when a step leaves
        an error above 1e-2 and doubles (up to 0.3) when it leaves one below 2e-3; a residual
        above 0.1 sends the slide back to its last exact point. When the null-space motion turns
        back (it overshot the optimum along a curved set of solutions), its gain halves, and it
        grows back by 1.25 per step that does not. Ends at an exact point whose null-space
        motion is below ``nullspace_tolerance``, after 8 iterations in a row in which a task
        error larger than the null-space motion failed to halve (a limit keeps the task out of
        reach), or after ``slide_iterations``; returns the last exact point (the phase-1
        solution at worst).
        """
        assert task.preferred is not None and task.weights is not None
        tolerance = settings.tolerance
        error_at, jacobian = self._evaluator(task)
        q = reached.q
        e, position, rotation = error_at(q)
        J = jacobian()
        best = (q, position, rotation)
        motion = math.inf
        cap = _SLIDE_STEP
        gain = settings.nullspace_gain
        previous_motion: NDArray[np.float64] | None = None
        previous_residual, applied_motion, stalls = math.inf, 0.0, 0
        iterations = 0
        while iterations < settings.slide_iterations:
            residual = position if math.isnan(rotation) else max(position, rotation)
            stuck = (residual > tolerance and residual > 0.5 * previous_residual
                     and applied_motion <= residual)
            stalls = stalls + 1 if stuck else 0
            if stalls > _SLIDE_PATIENCE:
                break  # the task cannot be met again from here (a limit): keep the exact point
            previous_residual, applied_motion = residual, 0.0
            start_q = q
            if residual > _SLIDE_NEAR:
                cap *= 0.5
                if residual > _SLIDE_LOST:
                    start_q, e = best[0], np.zeros_like(e)
                    J = self._jacobian_at(task, start_q)
                step_from = start_q
            else:
                if residual <= _SLIDE_CLOSE:
                    cap = min(2.0 * cap, _SLIDE_STEP)
                pseudo_inverse = np.asarray(np.linalg.pinv(J, rcond=_PINV_RCOND), dtype=np.float64)
                pull = settings.nullspace_gain * task.weights * (task.preferred - q)
                null_step = self._null_motion(q, J, pseudo_inverse, pull)
                largest = float(np.abs(null_step).max())
                if residual <= tolerance:
                    best, motion = (q, position, rotation), largest
                    if largest <= settings.nullspace_tolerance:
                        break
                if previous_motion is not None and float(null_step @ previous_motion) < 0.0:
                    gain *= 0.5  # overshot the optimum along a curved self-motion: go slower
                else:
                    gain = min(1.25 * gain, settings.nullspace_gain)
                previous_motion = null_step
                scale = gain / settings.nullspace_gain
                null_step = null_step * min(scale, cap / max(largest, 1e-300),
                                            self._room(q, null_step))
                applied_motion = float(np.abs(null_step).max())
                step_from = self._project(q + null_step, wrap=False)[0]
            q = self._bounded_step(step_from, J, e, LAMBDA_FLOOR, wrap=False)
            iterations += 1
            e, position, rotation = error_at(q)
            J = jacobian()
        q_best, position_best, rotation_best = best
        return Descent(q_best, reached.start, position_best, rotation_best,
                       reached.iterations + iterations, True, motion)

    def _room(self, q: NDArray[np.float64], motion: NDArray[np.float64]) -> float:
        """Largest scale s <= 1 with q + s motion within the limits (0 if none fits)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(motion > 0, (self.upper - q) / motion,
                            np.where(motion < 0, (self.lower - q) / motion, np.inf))
        return float(max(0.0, min(1.0, room.min())))

    def _jacobian_at(self, task: _Task, q: NDArray[np.float64]) -> NDArray[np.float64]:
        error_at, jacobian = self._evaluator(task)
        error_at(q)
        return jacobian()

    def _null_motion(self, q: NDArray[np.float64], J: NDArray[np.float64],
                     pseudo_inverse: NDArray[np.float64],
                     pull: NDArray[np.float64]) -> NDArray[np.float64]:
        """``(I - J^+ J) pull``, with the joints that sit on a limit and would be pushed through
        it held still (their columns leave J): at a limit the optimum is a KKT point, where
        this motion vanishes."""
        null_step = pull - pseudo_inverse @ (J @ pull)
        blocked = (((q <= self.lower + _AT_LIMIT) & (null_step < 0.0))
                   | ((q >= self.upper - _AT_LIMIT) & (null_step > 0.0)))
        if not blocked.any():
            return null_step
        free_J = J.copy()
        free_J[:, blocked] = 0.0
        free_pull = np.where(blocked, 0.0, pull)
        free_inverse = np.linalg.pinv(free_J, rcond=_PINV_RCOND)
        return free_pull - free_inverse @ (free_J @ free_pull)

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
