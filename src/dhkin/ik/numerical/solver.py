"""Numerical inverse kinematics on a Pinocchio model, for any URDF chain or DH table.

The solver drives the actuated joints of one chain (a :class:`~dhkin.reference.Reference`: base ->
tip) so that the tip reaches a target. It is what :meth:`dhkin.Robot.ik` falls back on when a
table fits no closed-form family, and it works as well for a URDF file plus a tip frame (a 7-axis
arm, an odd 6-axis geometry, a planar arm).

Conventions
-----------
* Joint vectors ``q`` are chain-order URDF joint values (rad for revolute and continuous joints,
  m for prismatic ones), base to tip, as :meth:`Reference.fk` takes them.
* Targets are given in the chain's base frame (the root link unless the reference names a
  ``base``): a pose is a (4, 4) transform base -> tip (metres); a position is a point (3,) of the
  tip's origin in the base frame, or (2,) for its x and y only (a planar task: z is left free,
  which is the natural task of a planar arm).
* ``mode="pose"`` error: ``e = log6(T_target^-1 T(q))``, the twist [v; w] (m, rad) that takes
  the target frame to the current tip frame, expressed in the target frame (Pinocchio LOCAL
  convention at the target). Its Jacobian is ``Jlog6(T_target^-1 T(q)) @ J_LOCAL(q)``, the exact
  derivative, so the Newton steps converge quadratically.
* ``mode="position"`` error: ``e = p(q) - p_target`` in the base frame's axes; Jacobian: the
  linear rows of the tip Jacobian in LOCAL_WORLD_ALIGNED, rotated into the base axes.
* Residuals are what a user checks: position error ``|p(q) - p_target|`` (m) and rotation angle
  of ``R(q)^T R_target`` (rad). A solution is returned only when both are ``<= tolerance``,
  re-measured by Pinocchio forward kinematics after the descent. In position mode the rotation
  residual is NaN (orientation is not part of the task).

Steps (``method``), with ``J`` the task Jacobian and ``e`` the error:

* ``"lm"`` (default): Levenberg-Marquardt. ``dq = -J^T (J J^T + lambda I)^-1 e`` (or the
  equivalent n x n form when the task has more rows than the chain has joints) with
  ``lambda = mu |e|^2 + LAMBDA_FLOOR``; a step that does not lower ``|e|`` is refused and ``mu``
  grows tenfold, an accepted one divides it by three. Far from a solution and near singularities
  this is damped least squares; close to a solution it is Newton-Raphson.
* ``"dls"``: damped least squares with a fixed damping, ``lambda = damping^2``, every step taken.
* ``"newton"``: the textbook iteration with the Moore-Penrose pseudo-inverse,
  ``dq = -J^+ e``: Newton-Raphson for a square Jacobian, least squares for an under-actuated task
  (more task rows than joints), the minimum-norm step for a redundant arm. Every step taken.

Joint limits: after every step the joint values are put back into the limits: a revolute joint
outside its range is first shifted by a multiple of 2 pi when that lands inside (same pose), else
clipped; a joint a step would push through a limit is held on it and the step is recomputed
without its column (one active-set round). Continuous joints (no limits) are never clipped. A
returned ``q`` is always within the limits.

Starts: the seed first if given; without one, the sample of a fixed table of configurations whose
tip pose is nearest to the target; then random configurations within the limits (reproducible:
default ``rng`` seed 0). A start that stalls (cost not halved in 10 iterations) is abandoned.

Redundancy: when the chain has more joints than the task's generic Jacobian rank (a 7-axis arm on
a pose, a 6-axis arm on a point, a planar 3R arm on a point), a solution, once reached, slides
along the set of solutions toward a preferred configuration (the seed, or the middle of the joint
ranges): null-space steps ``(I - J^+ J) gain (q_preferred - q)`` with Newton corrections of the
task, until that motion dies out. The answer is exact, never farther from the preference than
where it was reached, and (joints off their limits) a stationary point of the distance to it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from dhkin.description import read_urdf_file
from dhkin.dh import DHTable
from dhkin.errors import InputError, URDFError
from dhkin.ik.numerical.descent import DescentMethods
from dhkin.ik.numerical.settings import (
    _MAX_BANKS,
    _WARM_START_SEED,
    UNLIMITED,
    Descent,
    Method,
    Mode,
    NumericalReport,
    Preference,
    SolverSettings,
    _as_array,
    _check_pose,
    _count,
    _is_revolute,
)
from dhkin.ik.numerical.task import _Chain, _StartBank, _Task, _WarmStarts
from dhkin.ik.result import Configuration, IKSolutions
from dhkin.reference import Reference
from dhkin.urdf import generate


class RobotLike(Protocol):
    """What :meth:`NumericalIK.from_robot` and :func:`numerical_ik` need of a robot (a
    :class:`dhkin.robot.Robot` is one; this module does not import the facade above it)."""

    @property
    def lower(self) -> NDArray[np.float64]: ...

    @property
    def upper(self) -> NDArray[np.float64]: ...

    def reference(self, tip: str = "tool0") -> Reference: ...

    def numerical_solver(self, tip: str = "tool0") -> NumericalIK: ...


class NumericalIK(DescentMethods):
    """Numerical IK of one chain of a Pinocchio model (see the module docstring for conventions).

    Build it from a :class:`Reference` (``NumericalIK(reference)``), a robot
    (:meth:`from_robot`) or a URDF file (:meth:`from_urdf`). ``lower``/``upper`` (dof,) override
    the URDF limits (chain order); continuous joints have none. Not thread-safe: one instance
    owns one Pinocchio ``Data``.
    """

    def __init__(self, reference: Reference, lower: ArrayLike | None = None,
                 upper: ArrayLike | None = None, settings: SolverSettings | None = None) -> None:
        self.reference = reference
        self.settings = (settings or SolverSettings()).checked()
        self._chain = _Chain.of(reference)
        self.dof = self._chain.dof
        if self.dof == 0:
            raise URDFError(f"{reference.source}: no actuated joint between the base and "
                            f"{reference.tip!r}")
        self.joint_names = list(reference.joint_names)
        self.lower, self.upper = self._limits(lower, upper)
        joints = [reference.model.joints[j] for j in reference.chain]
        self._revolute_list = [_is_revolute(jm) for jm in joints]
        self._revolute = np.array(self._revolute_list)
        self._limited = np.isfinite(self.lower) | np.isfinite(self.upper)
        self._random_low = np.where(np.isfinite(self.lower), self.lower, -math.pi)
        self._random_high = np.where(np.isfinite(self.upper), self.upper, math.pi)
        self.mid_range = np.where(self._limited, 0.5 * (self._random_low + self._random_high),
                                  0.0)
        self._core_chain = self._chain.compiled(reference, self.lower, self.upper)
        self._ranks: dict[int, int] = {}
        self._banks: dict[int, _StartBank] = {}
        self._warm_tables: dict[int, _WarmStarts] = {}

    # ----------------------------------------------------------------------------- building
    @classmethod
    def from_robot(cls, robot: RobotLike, tip: str = "tool0",
                   settings: SolverSettings | None = None) -> NumericalIK:
        """Solver of a DH-table robot on its generated URDF, base_link -> ``tip``, table limits."""
        return cls(robot.reference(tip), robot.lower, robot.upper, settings)

    @classmethod
    def from_table(cls, table: DHTable, tip: str = "tool0",
                   settings: SolverSettings | None = None) -> NumericalIK:
        """Solver of a DH table on its generated URDF (through xacro), base_link -> ``tip``,
        within the table's limits."""
        reference = Reference(generate(table).urdf, tip=tip, source=f"{table.name}.urdf")
        return cls(reference, table.lower, table.upper, settings)

    @classmethod
    def from_urdf(cls, path: str | Path, tip: str, base: str | None = None,
                  settings: SolverSettings | None = None) -> NumericalIK:
        """Solver of the chain ``base`` (default: the root) -> ``tip`` of a URDF file."""
        urdf_path = Path(path)  # read_urdf_file: URDFError naming a missing or unreadable file
        reference = Reference(read_urdf_file(urdf_path), tip=tip, base=base, source=str(urdf_path))
        return cls(reference, settings=settings)

    def _limits(self, lower: ArrayLike | None,
                upper: ArrayLike | None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        model = self.reference.model
        joints = [model.joints[j] for j in self.reference.chain]
        urdf_lower = np.array([-math.inf if jm.nq == 2 else model.lowerPositionLimit[jm.idx_q]
                               for jm in joints])
        urdf_upper = np.array([math.inf if jm.nq == 2 else model.upperPositionLimit[jm.idx_q]
                               for jm in joints])
        low = urdf_lower if lower is None else self._joint_vector("lower", lower, finite=False)
        high = urdf_upper if upper is None else self._joint_vector("upper", upper, finite=False)
        low = np.where(low < -UNLIMITED, -math.inf, low)
        high = np.where(high > UNLIMITED, math.inf, high)
        if np.any(np.isnan(low) | np.isnan(high)) or np.any(low > high):
            raise InputError(f"joint limits of {self.joint_names}: expected "
                             f"lower <= upper, got lower={low}, upper={high}")
        return low, high

    # ------------------------------------------------------------------------------ solving
    def solve(self, target: ArrayLike, q_seed: ArrayLike | None = None, *,
              mode: Mode | None = None, max_solutions: int = 1, restarts: int = 50,
              rng: int | np.random.Generator | None = 0, tolerance: float | None = None,
              method: Method | None = None, max_iterations: int | None = None,
              nullspace: Preference | ArrayLike = "auto", tcp: ArrayLike | None = None,
              ) -> IKSolutions:
        """Up to ``max_solutions`` distinct solutions for ``target``; see :meth:`solve_detailed`."""
        return self.solve_detailed(
            target, q_seed, mode=mode, max_solutions=max_solutions, restarts=restarts, rng=rng,
            tolerance=tolerance, method=method, max_iterations=max_iterations,
            nullspace=nullspace, tcp=tcp).solutions

    def solve_detailed(self, target: ArrayLike, q_seed: ArrayLike | None = None, *,
                       mode: Mode | None = None, max_solutions: int = 1, restarts: int = 50,
                       rng: int | np.random.Generator | None = 0,
                       tolerance: float | None = None, method: Method | None = None,
                       max_iterations: int | None = None,
                       nullspace: Preference | ArrayLike = "auto",
                       tcp: ArrayLike | None = None) -> NumericalReport:
        """Solve from several starts: the seed first (if given), then random ones.

        * ``target``: a pose (4, 4), or a point (3,) / (x, y) (2,); see the module docstring.
        * ``mode``: ``"pose"`` or ``"position"``; inferred from the target's shape when None. A
          pose with ``mode="position"`` asks for its translation only.
        * ``q_seed``: (dof,) first start (put into the limits first) and null-space preference.
        * ``max_solutions``: stop after this many distinct solutions (differing by more than
          ``settings.distinct_tolerance`` in some joint, modulo 2 pi for revolute joints).
        * ``restarts``: random starts after the first (uniform within the limits; [-pi, pi] for
          unlimited joints), drawn from ``rng`` (an int seed or a Generator; default seed 0, so
          results are reproducible). Without a seed the first start is random too.
        * ``tolerance``: residual bound (m and rad) of a solution; default 1e-10.
        * ``method``, ``max_iterations`` (per start): override the settings.
        * ``nullspace``: for redundant tasks, the preferred configuration: ``"auto"`` (the seed
          if given, else the middle of the joint ranges), ``"seed"``, ``"mid_range"``, a joint
          vector (dof,), or None (no null-space motion).
        * ``tcp``: tip -> TCP transform (4, 4): the target is then the TCP's pose or point.

        Solutions are sorted by distance to the seed (when given), else in the order found. An
        empty result's ``reason`` gives the best residual reached, its iterations and the number
        of starts; the descents are all in the report.
        """
        settings = self._settings(tolerance, method, max_iterations)
        task = self._task(target, mode, tcp)
        seed = None if q_seed is None else self.project(self._joint_vector("q_seed", q_seed))
        max_solutions = _count("max_solutions", max_solutions, minimum=1)
        restarts = _count("restarts", restarts, minimum=0)
        if not (rng is None or isinstance(rng, np.random.Generator)
                or (isinstance(rng, int | np.integer) and not isinstance(rng, bool))):
            raise InputError(f"rng: expected an int seed, a numpy Generator or None, "
                             f"got {rng!r}", field="rng")
        task.preferred, task.weights = self._preference(task, nullspace, seed)
        starts = self._starts(seed, restarts + 1, rng, task, settings)

        found: list[NDArray[np.float64]] = []
        found_residuals: list[tuple[float, float]] = []
        descents: list[Descent] = []
        for start in starts:
            descent = self._checked(task, self._descend(task, start, settings), settings)
            descents.append(descent)
            if descent.converged and not self._known(descent.q, found, settings):
                found.append(descent.q)
                found_residuals.append((descent.position_error, descent.rotation_error))
                if len(found) >= max_solutions:
                    break
        solutions = self._solutions(task, found, found_residuals, seed, descents, settings)
        return NumericalReport(solutions, tuple(descents))

    def _starts(self, seed: NDArray[np.float64] | None, count: int,
                rng: int | np.random.Generator | None, task: _Task,
                settings: SolverSettings) -> Iterator[NDArray[np.float64]]:
        """The seed, then random starts, ``count`` in all, lazily.

        Without a seed, the first start is the sample of a fixed table of configurations
        (``settings.warm_starts`` of them, drawn once per solver) whose tip is nearest to the
        target: it is as random as any other start, but usually a few iterations closer.
        Random starts for an int ``rng`` come from a per-seed bank that grows on demand, so that
        a call costs no generator construction and gives the same starts every time.
        """
        if seed is not None:
            yield seed
            count -= 1
        elif settings.warm_starts > 0 and count > 0:
            yield self._warm_start_table(settings.warm_starts).nearest(task)
            count -= 1
        if isinstance(rng, int | np.integer) and not isinstance(rng, bool):
            bank = self._start_bank(int(rng))
            for index in range(count):
                if index >= len(bank.starts):
                    bank.grow(max(16, len(bank.starts)))
                yield bank.starts[index]
            return
        # rng was checked in solve(): a Generator here, or None
        generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng()
        for _ in range(count):
            yield generator.uniform(self._random_low, self._random_high)

    def _warm_start_table(self, size: int) -> _WarmStarts:
        table = self._warm_tables.get(size)
        if table is None:
            samples = np.random.default_rng(_WARM_START_SEED).uniform(
                self._random_low, self._random_high, size=(size, self.dof))
            placements = [self._chain.tip_placement(q) for q in samples]
            table = _WarmStarts(samples, np.array([m.translation for m in placements]),
                                np.array([m.rotation for m in placements]))
            self._warm_tables[size] = table
        return table

    def _start_bank(self, seed: int) -> _StartBank:
        bank = self._banks.get(seed)
        if bank is None:
            bank = _StartBank(np.random.default_rng(seed), self._random_low, self._random_high)
            if len(self._banks) < _MAX_BANKS:
                self._banks[seed] = bank
        return bank

    def solve_batch(self, targets: ArrayLike, q_seed: ArrayLike | None = None,
                    max_solutions: int = 1, **options: object
                    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """:meth:`solve` for N targets, shaped like ``Robot.ik_batch``.

        ``targets``: poses (N, 4, 4) or points (N, 3) / (N, 2); ``q_seed``: (dof,) for all or
        (N, dof). Returns solutions (N, max_solutions, dof) and a validity mask
        (N, max_solutions); rows with fewer solutions are padded with zeros, marked invalid.
        ``options`` are the keyword options of :meth:`solve`.
        """
        batch = _as_array("targets", targets)
        if batch.ndim not in (2, 3) or batch.shape[0] == 0:
            raise InputError(f"targets: expected (N, 4, 4) poses or (N, 3) / (N, 2) points, "
                             f"got shape {batch.shape}", field="targets")
        count = batch.shape[0]
        seeds: list[NDArray[np.float64] | None] = [None] * count
        if q_seed is not None:
            seed_array = _as_array("q_seed", q_seed)
            if seed_array.shape == (self.dof,):
                seeds = [seed_array] * count
            elif seed_array.shape == (count, self.dof):
                seeds = list(seed_array)
            else:
                raise InputError(f"q_seed: expected shape ({self.dof},) or ({count}, "
                                 f"{self.dof}), got {seed_array.shape}", field="q_seed")
        Q = np.zeros((count, max_solutions, self.dof))
        valid = np.zeros((count, max_solutions), dtype=bool)
        for index, (target, seed) in enumerate(zip(batch, seeds, strict=True)):
            solutions = self.solve(target, seed, max_solutions=max_solutions,
                                   **options)  # type: ignore[arg-type]
            Q[index, :len(solutions)] = solutions.q
            valid[index, :len(solutions)] = True
        return Q, valid

    def descend(self, target: ArrayLike, q_start: ArrayLike, *, mode: Mode | None = None,
                tolerance: float | None = None, method: Method | None = None,
                max_iterations: int | None = None, damping: float | None = None,
                nullspace: Preference | ArrayLike = None,
                tcp: ArrayLike | None = None) -> Descent:
        """One local descent from ``q_start`` (no restarts): the building block of :meth:`solve`.

        Useful to follow the textbook iteration (``method="newton"``, a few ``max_iterations``)
        or, for a task the arm cannot meet exactly, to get its least-squares configuration: unlike
        :meth:`solve`, a descent here is not cut short when it stalls, it runs until it
        converges, spends ``max_iterations`` or no LM step lowers the error any more. The
        returned :class:`Descent` is a solution only when ``converged`` is True. ``damping`` is
        the fixed damping of ``"dls"``; ``nullspace`` as in :meth:`solve` (default: off).
        """
        settings = self._settings(tolerance, method, max_iterations)
        if damping is not None:
            settings = replace(settings, damping=damping).checked()
        settings = replace(settings, stall_window=settings.max_iterations + 1)
        task = self._task(target, mode, tcp)
        start = self.project(self._joint_vector("q_start", q_start))
        task.preferred, task.weights = self._preference(task, nullspace, start)
        return self._checked(task, self._descend(task, start, settings), settings)

    def residuals(self, q: ArrayLike, target: ArrayLike, mode: Mode | None = None,
                  tcp: ArrayLike | None = None) -> tuple[float, float]:
        """(position m, rotation rad) residuals of ``q`` on ``target`` by Pinocchio FK.

        The rotation residual is NaN in position mode.
        """
        task = self._task(target, mode, tcp)
        return self._measure(task, self._joint_vector("q", q))

    def is_redundant(self, mode: Mode, rows: int | None = None) -> bool:
        """Whether the chain has more joints than the generic rank of the task's Jacobian."""
        task_rows = rows if rows is not None else (6 if mode == "pose" else 3)
        return self.dof > self._generic_rank(task_rows)

    # --------------------------------------------------------------------------- internals
    def _settings(self, tolerance: float | None, method: Method | None,
                  max_iterations: int | None) -> SolverSettings:
        changes: dict[str, Any] = {}
        if tolerance is not None:
            changes["tolerance"] = tolerance
        if method is not None:
            changes["method"] = method
        if max_iterations is not None:
            changes["max_iterations"] = max_iterations
        return replace(self.settings, **changes).checked() if changes else self.settings

    def _joint_vector(self, name: str, value: ArrayLike, finite: bool = True
                      ) -> NDArray[np.float64]:
        try:
            vector = np.array(value, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InputError(field=name, value=value, expected=f"{self.dof} numbers") from exc
        if vector.shape != (self.dof,):
            raise InputError(f"{name}: expected shape ({self.dof},) for the joints "
                             f"{self.joint_names}, got {vector.shape}", field=name)
        if finite and not np.all(np.isfinite(vector)):
            raise InputError(f"{name}: expected finite joint values, got {vector}", field=name)
        return vector

    def _task(self, target: ArrayLike, mode: Mode | None, tcp: ArrayLike | None) -> _Task:
        values = _as_array("target", target)
        if mode not in (None, "pose", "position"):
            raise InputError(field="mode", value=mode, expected="'pose', 'position' or None")
        if values.shape == (4, 4):
            _check_pose("target", values)
        elif values.shape not in ((3,), (2,)):
            raise InputError(f"target: expected a pose (4, 4), a point (3,) or an (x, y) "
                             f"point (2,), got shape {values.shape}", field="target")
        elif not np.all(np.isfinite(values)):
            raise InputError(f"target: expected finite numbers, got {values}", field="target")
        if mode is None:
            mode = "pose" if values.shape == (4, 4) else "position"
        if mode == "pose" and values.shape != (4, 4):
            raise InputError(f"target: mode='pose' needs a (4, 4) pose, got shape "
                             f"{values.shape}; use mode='position' for a point", field="target")
        tcp_placement = None
        if tcp is not None:
            tcp_matrix = _as_array("tcp", tcp)
            if tcp_matrix.shape != (4, 4):
                raise InputError(f"tcp: expected a (4, 4) transform tip -> TCP, got shape "
                                 f"{tcp_matrix.shape}", field="tcp")
            _check_pose("tcp", tcp_matrix)
            tcp_placement = pin.SE3(tcp_matrix[:3, :3].copy(), tcp_matrix[:3, 3].copy())
        base = self._chain.world_from_base
        if mode == "pose":
            world_target = pin.SE3(values)
            if not base.isIdentity():
                world_target = base * world_target
            if tcp_placement is not None:
                world_target = world_target * tcp_placement.inverse()
            return _Task("pose", 6, world_target, world_target.inverse(), np.zeros(3), None,
                         None)
        point = values[:3, 3] if values.shape == (4, 4) else values
        rows = point.size
        point3 = np.zeros(3)
        point3[:rows] = point
        world_point = base.act(point3)
        base_rotation_t = None if base.isIdentity() else base.rotation.T.copy()
        return _Task("position", rows, pin.SE3.Identity(), pin.SE3.Identity(), world_point,
                     base_rotation_t, tcp_placement)

    def _preference(self, task: _Task, nullspace: Preference | ArrayLike,
                    seed: NDArray[np.float64] | None
                    ) -> tuple[NDArray[np.float64] | None, NDArray[np.float64] | None]:
        if nullspace is None:
            return None, None
        if isinstance(nullspace, str):
            if nullspace not in ("auto", "seed", "mid_range"):
                raise InputError(f"nullspace: expected 'auto', 'seed', 'mid_range', a joint "
                                 f"vector or None, got {nullspace!r}", field="nullspace")
            if nullspace == "seed" and seed is None:
                raise InputError("nullspace='seed' needs a q_seed")
            use_seed = nullspace == "seed" or (nullspace == "auto" and seed is not None)
            preferred = seed if use_seed else self.mid_range
            weights = np.ones(self.dof) if use_seed else self._limited.astype(float)
        else:
            preferred = self._joint_vector("nullspace", nullspace)
            weights = np.ones(self.dof)
        if not self.is_redundant(task.mode, task.rows):
            return None, None
        return preferred, weights

    def _generic_rank(self, rows: int) -> int:
        """Rank of the task Jacobian (6: pose; 3: point; 2: (x, y) in the base axes) at random
        configurations (max over a few draws)."""
        if rows not in self._ranks:
            generator = np.random.default_rng(12345)
            rank = 0
            for _ in range(4):
                q = generator.uniform(self._random_low, self._random_high)
                self._chain.update(q)
                J = self._chain.tip_jacobian(pin.LOCAL_WORLD_ALIGNED)
                base_axes = self._chain.world_from_base.rotation
                block = J if rows == 6 else (base_axes.T @ J[:3])[:rows]
                sigma = np.linalg.svd(block, compute_uv=False)
                rank = max(rank, int(np.sum(sigma > 1e-9 * max(sigma[0], 1e-300))))
            self._ranks[rows] = rank
        return self._ranks[rows]

    def _solutions(self, task: _Task, found: list[NDArray[np.float64]],
                   found_residuals: list[tuple[float, float]],
                   seed: NDArray[np.float64] | None, descents: Sequence[Descent],
                   settings: SolverSettings) -> IKSolutions:
        iterations = sum(d.iterations for d in descents)
        if not found:
            best = min(descents, key=lambda d: d.residual)
            rotation_text = ("" if math.isnan(best.rotation_error)
                             else f", rotation {best.rotation_error:.3g} rad")
            reason = (f"numerical IK did not converge from {len(descents)} starts "
                      f"({iterations} iterations in all): the closest descent reached position "
                      f"{best.position_error:.3g} m{rotation_text} after {best.iterations} "
                      f"iterations; tolerance {settings.tolerance:g}")
            return IKSolutions(q=np.zeros((0, self.dof)), reason=reason, family="numerical",
                               numerical=True)
        Q = np.array(found)
        residuals = np.array(found_residuals)
        if seed is not None and len(found) > 1:
            order = np.argsort(np.linalg.norm(Q - seed, axis=1), kind="stable")
            Q, residuals = Q[order], residuals[order]
        labels = {"solver": "numerical", "mode": task.mode}
        configurations = tuple(Configuration(labels=labels, turns=self._turns(q)) for q in Q)
        reason = (f"{len(Q)} distinct solution(s) from {len(descents)} starts "
                  f"({iterations} iterations in all)")
        return IKSolutions(q=Q, configurations=configurations,
                           flags=(frozenset(),) * len(Q), residuals=residuals,
                           reason=reason, family="numerical", numerical=True)
