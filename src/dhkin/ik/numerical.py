"""Numerical inverse kinematics on Pinocchio, for any URDF chain or DH table.

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
* ``"newton"``: the textbook iteration of seed 003 with the Moore-Penrose pseudo-inverse,
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
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal, Protocol, TypeAlias

import eigenpy
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from dhkin.builtin import resolve_table_path
from dhkin.dh import DHTable, load_table
from dhkin.errors import InputError, URDFError
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


Mode: TypeAlias = Literal["pose", "position"]
Method: TypeAlias = Literal["lm", "dls", "newton"]
Preference: TypeAlias = Literal["auto", "seed", "mid_range"] | None
#: (error vector, position residual m, rotation residual rad or NaN) at one q.
_Error: TypeAlias = tuple[NDArray[np.float64], float, float]

TWO_PI = 2.0 * math.pi
_PRISMATIC_NAME = re.compile(r"^JointModel(P[XYZ]|Prismatic)")
#: Default convergence tolerance of a solution: position (m) and rotation (rad) residuals.
DEFAULT_TOLERANCE = 1e-10
#: Smallest damping added to J J^T: keeps the system solvable when J loses rank, and is far too
#: small to slow the quadratic convergence of the last Newton steps (sigma_min^2 >> 1e-12).
LAMBDA_FLOOR = 1e-12
#: Two solutions are the same when no joint differs by more than this (rad or m), revolute
#: differences taken modulo 2 pi (2 pi-shifted copies are one solution here).
DISTINCT_TOLERANCE = 1e-4
#: A null-space motion smaller than this (rad) counts as finished.
NULLSPACE_TOLERANCE = 1e-6
#: Limits wider than this (rad or m) are treated as no limit (URDF joints without a real bound).
UNLIMITED = 1e6

_MU_INITIAL = 1e-2
_MU_MIN = 1e-9
_MU_MAX = 1e8
_MU_DOWN = 3.0
_MU_UP = 10.0
#: Relative cut-off of small singular values in the Moore-Penrose pseudo-inverse.
_PINV_RCOND = 1e-10
#: Null-space sliding: residuals (m or rad) below which a step may move in the null space
#: (and above which the step cap halves), below which the cap doubles, and above which the
#: slide goes back to its last exact point.
_SLIDE_NEAR = 1e-2
_SLIDE_CLOSE = 2e-3
_SLIDE_LOST = 1e-1
#: Sliding ends after this many iterations in a row in which a task error that the null-space
#: motion does not explain fails to halve.
_SLIDE_PATIENCE = 8
#: A joint this close (rad or m) to a limit counts as on it for the null-space motion.
_AT_LIMIT = 1e-6
#: Largest null-space motion of one sliding step (rad or m per joint).
_SLIDE_STEP = 0.3
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


@dataclass
class _Task:
    """One prepared target: what the descent evaluates, in the model's world frame."""

    mode: Mode
    rows: int                                   # task rows: 6 pose, 3 position, 2 planar
    world_target: pin.SE3                       # pose: world -> target frame
    target_inverse: pin.SE3                     # pose: its inverse
    world_point: NDArray[np.float64]            # position: target point in the world
    base_rotation_t: NDArray[np.float64] | None  # position: world -> base axes (None: same)
    tcp: pin.SE3 | None                         # tip -> TCP (None: the tip itself)
    preferred: NDArray[np.float64] | None = None  # null-space target, when redundant
    weights: NDArray[np.float64] | None = None    # null-space weights per joint


@dataclass
class _Chain:
    """Pinocchio model of the chain, with the fast mapping chain q -> configuration."""

    model: pin.Model
    data: pin.Data
    tip_id: int
    world_from_base: pin.SE3
    dof: int
    direct: bool
    neutral: NDArray[np.float64]
    index_q: NDArray[np.intp]                 # nq = 1 joints: config index, chain position
    chain_q: NDArray[np.intp]
    index_cos: NDArray[np.intp]               # continuous joints: cos/sin slots, chain position
    chain_continuous: NDArray[np.intp]
    index_v: NDArray[np.intp]
    velocity_direct: bool

    @classmethod
    def of(cls, reference: Reference) -> _Chain:
        model = reference.model
        data = model.createData()
        joints = [model.joints[j] for j in reference.chain]
        continuous = [jm.nq == 2 for jm in joints]
        neutral = pin.neutral(model)
        world_from_base = pin.SE3.Identity()
        if reference.base is not None:
            pin.framesForwardKinematics(model, data, neutral)
            world_from_base = pin.SE3(data.oMf[reference.frame_id(reference.base)])
        index_v = np.array([jm.idx_v for jm in joints], dtype=np.intp)
        dof = len(joints)
        plain = [k for k, c in enumerate(continuous) if not c]
        turning = [k for k, c in enumerate(continuous) if c]
        return cls(
            model=model, data=data, tip_id=reference.frame_id(reference.tip),
            world_from_base=world_from_base, dof=dof,
            direct=(model.nq == dof and not turning
                    and [jm.idx_q for jm in joints] == list(range(dof))),
            neutral=neutral,
            index_q=np.array([joints[k].idx_q for k in plain], dtype=np.intp),
            chain_q=np.array(plain, dtype=np.intp),
            index_cos=np.array([joints[k].idx_q for k in turning], dtype=np.intp),
            chain_continuous=np.array(turning, dtype=np.intp),
            velocity_direct=(model.nv == dof and index_v.tolist() == list(range(dof))),
            index_v=index_v,
        )

    def configuration(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """Chain q (dof,) -> Pinocchio configuration (nq,), joints off the chain at neutral."""
        if self.direct:
            return q
        config = self.neutral.copy()
        config[self.index_q] = q[self.chain_q]
        if self.index_cos.size:
            angles = q[self.chain_continuous]
            config[self.index_cos] = np.cos(angles)
            config[self.index_cos + 1] = np.sin(angles)
        return config

    def update(self, q: NDArray[np.float64]) -> pin.SE3:
        """Kinematics and joint Jacobians at q; returns the tip placement (a live reference)."""
        pin.computeJointJacobians(self.model, self.data, self.configuration(q))
        pin.updateFramePlacement(self.model, self.data, self.tip_id)
        return self.data.oMf[self.tip_id]

    def tip_jacobian(self, frame: pin.ReferenceFrame) -> NDArray[np.float64]:
        """6 x dof Jacobian of the tip after :meth:`update`, chain-order columns."""
        J = pin.getFrameJacobian(self.model, self.data, self.tip_id, frame)
        return J if self.velocity_direct else J[:, self.index_v]

    def tip_placement(self, q: NDArray[np.float64]) -> pin.SE3:
        """World -> tip at q (a copy)."""
        pin.forwardKinematics(self.model, self.data, self.configuration(q))
        return pin.SE3(pin.updateFramePlacement(self.model, self.data, self.tip_id))


class NumericalIK:
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
        urdf_path = Path(path)
        if not urdf_path.is_file():
            raise URDFError(f"{urdf_path}: no such URDF file")
        reference = Reference(urdf_path.read_text(), tip=tip, base=base, source=str(urdf_path))
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


class _StartBank:
    """Random starts of one int seed, drawn once and kept (grows on demand)."""

    def __init__(self, generator: np.random.Generator, low: NDArray[np.float64],
                 high: NDArray[np.float64]) -> None:
        self._generator, self._low, self._high = generator, low, high
        self.starts: list[NDArray[np.float64]] = []
        self.grow(16)

    def grow(self, count: int) -> None:
        draws = self._generator.uniform(self._low, self._high, size=(count, self._low.size))
        self.starts.extend(draws)


class _WarmStarts:
    """A fixed table of configurations with their tip poses (world frame), to pick a start
    near a target: distance |p - p_target|^2 + L^2 (3 - trace(R^T R_target)), where
    3 - trace = 2 (1 - cos angle) ~ angle^2 and L = 0.3 x the largest tip distance seen."""

    def __init__(self, q: NDArray[np.float64], positions: NDArray[np.float64],
                 rotations: NDArray[np.float64]) -> None:
        self.q, self.positions = q, positions
        self.rotations = rotations.reshape(len(q), 9)
        reach = float(np.sqrt((positions * positions).sum(axis=1)).max())
        self.weight = (_WARM_START_ROTATION_WEIGHT * reach) ** 2

    def nearest(self, task: _Task) -> NDArray[np.float64]:
        if task.mode == "pose":
            target = task.world_target
            offset = self.positions - target.translation
            distance = (offset * offset).sum(axis=1)
            distance += self.weight * (3.0 - self.rotations @ target.rotation.reshape(9))
        else:
            offset = self.positions - task.world_point
            if task.base_rotation_t is not None:
                offset = offset @ task.base_rotation_t.T
            offset = offset[:, :task.rows]
            distance = (offset * offset).sum(axis=1)
        return self.q[int(np.argmin(distance))]


def _norm(vector: NDArray[np.float64]) -> float:
    """Euclidean norm of a short vector (cheaper than np.linalg.norm for 2-6 entries)."""
    return math.sqrt(float(vector @ vector))


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def _task_step(J: NDArray[np.float64], e: NDArray[np.float64],
               damping: float) -> NDArray[np.float64]:
    """Step -J^# e with J^# the damped pseudo-inverse (Moore-Penrose when damping = 0)."""
    rows, columns = J.shape
    if damping == 0.0:
        return -(np.linalg.pinv(J) @ e)
    if rows <= columns:
        A = J @ J.T
        A.flat[:: rows + 1] += damping
        return -(J.T @ eigenpy.LLT(A).solve(e).reshape(rows))
    A = J.T @ J
    A.flat[:: columns + 1] += damping
    return -eigenpy.LLT(A).solve(J.T @ e).reshape(columns)


def _skew(v: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


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


# ----------------------------------------------------------------------------- conveniences
def numerical_ik(robot_or_urdf: RobotLike | Reference | NumericalIK | str | Path, target: ArrayLike,
                 q_seed: ArrayLike | None = None, *, tip: str | None = None,
                 base: str | None = None, **options: object) -> IKSolutions:
    """Numerical IK in one call.

    ``robot_or_urdf``: a :class:`~dhkin.Robot`, a built-in robot name or ``.yaml`` table path, a
    ``.urdf`` file path (then ``tip`` is required, ``base`` optional), a :class:`Reference` or a
    :class:`NumericalIK`. ``options`` are those of :meth:`NumericalIK.solve`.
    """
    solver = _solver_of(robot_or_urdf, tip, base)
    return solver.solve(target, q_seed, **options)  # type: ignore[arg-type]


def _solver_of(source: RobotLike | Reference | NumericalIK | str | Path, tip: str | None,
               base: str | None) -> NumericalIK:
    if isinstance(source, NumericalIK):
        return source
    if isinstance(source, Reference):
        return NumericalIK(source)
    if not isinstance(source, str | Path):  # a robot: its cached solver
        return source.numerical_solver(tip or "tool0")
    path = Path(source)
    if path.suffix == ".urdf":
        if tip is None:
            raise InputError(f"{path}: a URDF needs the tip frame (tip=...)", field="tip",
                             expected="the tip frame of the URDF's chain")
        return NumericalIK.from_urdf(path, tip, base)
    return NumericalIK.from_table(load_table(resolve_table_path(source)), tip or "tool0")
