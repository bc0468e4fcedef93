"""The user-facing robot: ``dhkin.load(name_or_path)`` and the :class:`Robot` it returns."""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin import memory
from dhkin.builtin import builtin_dir, builtin_names, resolve_table_path
from dhkin.dh import DHTable
from dhkin.errors import FamilyError, InputError
from dhkin.ik.result import IKBatch, IKSolutions
from dhkin.ik.solver import DEFAULT_CHUNK, DEFAULT_TOLERANCE, ClosedFormSolver
from dhkin.reference import Reference
from dhkin.table_file import load_table
from dhkin.urdf import GeneratedFiles, generate

if TYPE_CHECKING:
    from dhkin.ik.general6r import General6RSolver
    from dhkin.ik.numerical import NumericalIK
    from dhkin.singularity import SingularityReport, Thresholds

def batch_bytes_per_solution(dof: int) -> int:
    """Bytes of one solution of a batch result: q (8 per joint), the residuals (16), valid,
    flags (1 each) and branch (2)."""
    return 8 * dof + 20


#: Re-exported: the built-in robots (dhkin.builtin).
__all__ = ["Robot", "builtin_dir", "builtin_names", "load", "resolve_table_path"]


def load(name_or_path: str | Path) -> Robot:
    """Load a built-in robot by name (see ``dhkin robots``) or a DH table file by path."""
    return Robot(load_table(resolve_table_path(name_or_path)))


class Robot:
    """A robot defined by a DH table: own FK, generated URDF, Pinocchio reference.

    Frames: poses are base_link -> tool0 (4x4, metres); joint values q are URDF joint values
    (rad for revolute joints, m for prismatic ones), ordered base to tip.
    """

    def __init__(self, table: DHTable) -> None:
        self.table = table
        self._numerical_solvers: dict[str, NumericalIK] = {}

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, {self.table.convention} DH, {self.dof} joints)"

    @property
    def name(self) -> str:
        return self.table.name

    @property
    def dof(self) -> int:
        return self.table.dof

    @property
    def lower(self) -> NDArray[np.float64]:
        return self.table.lower

    @property
    def upper(self) -> NDArray[np.float64]:
        return self.table.upper

    def fk(self, q: ArrayLike) -> NDArray[np.float64]:
        """Own batched numpy FK, base_link -> tool0: (n,) -> (4, 4); (N, n) -> (N, 4, 4)."""
        return self.table.fk(q)

    def generated(self, prefix: str = "") -> GeneratedFiles:
        """The macro xacro, top-level xacro and URDF (through xacro) of this robot."""
        if prefix == "":
            return self._generated_unprefixed
        return generate(self.table, prefix=prefix)

    @cached_property
    def _generated_unprefixed(self) -> GeneratedFiles:
        return generate(self.table)

    def urdf(self, prefix: str = "") -> str:
        """URDF text produced by running xacro on the generated macro (``prefix`` on all names)."""
        return self.generated(prefix).urdf

    def reference(self, tip: str = "tool0") -> Reference:
        """Pinocchio model of the generated URDF, base_link -> ``tip``."""
        if tip == "tool0":
            return self._reference_tool0
        return Reference(self.urdf(), tip=tip, source=f"{self.name}.urdf")

    @cached_property
    def _reference_tool0(self) -> Reference:
        return Reference(self.urdf(), tip="tool0", source=f"{self.name}.urdf")

    @cached_property
    def ik_solver(self) -> ClosedFormSolver:
        """The closed-form solver of this robot's family (FamilyError if none fits within the
        band, naming what each family lacks; see dhkin.ik.family)."""
        solver = self._closed_form_solver
        if solver is None:
            from dhkin.ik.family import fit_family

            fit_family(self.table)  # raises the FamilyError
        assert solver is not None
        return solver

    @cached_property
    def _closed_form_solver(self) -> ClosedFormSolver | None:
        """The closed-form solver, or None when no family fits (cached: a cached_property does
        not cache the FamilyError of :attr:`ik_solver`)."""
        from dhkin.ik.family import fit_family

        try:
            return ClosedFormSolver(self.table, fit_family(self.table))
        except FamilyError:
            return None

    def numerical_solver(self, tip: str = "tool0") -> NumericalIK:
        """The numerical IK of this robot's generated URDF, base_link -> ``tip``, within the
        table's limits (built once per tip; :meth:`ik` falls back on it without a family)."""
        solver = self._numerical_solvers.get(tip)
        if solver is None:
            from dhkin.ik.numerical import NumericalIK

            solver = NumericalIK(self.reference(tip), self.lower, self.upper)
            self._numerical_solvers[tip] = solver
        return solver

    @property
    def has_closed_form(self) -> bool:
        """Whether a closed-form IK family fits this robot's table (within the band)."""
        return self._closed_form_solver is not None

    @cached_property
    def general_solver(self) -> General6RSolver | None:
        """The general 6R solver (dhkin.ik.general6r) when the table has six revolute joints
        and no closed-form family fits; None otherwise, or when it cannot be built for the
        table (every elimination's matrix polynomial singular: :meth:`ik` then falls back on
        the numerical IK)."""
        if self.has_closed_form or self.dof != 6 or not all(
                j.is_revolute for j in self.table.joints):
            return None
        from dhkin.ik.general6r import General6RSolver

        try:
            return General6RSolver(self.table)
        except FamilyError:
            return None

    @property
    def ik_family(self) -> str:
        """Which IK answers :meth:`ik`: the closed-form family's name, "general6r" (every
        solution of a six-revolute arm outside the families) or "numerical"."""
        if self._closed_form_solver is not None:
            return self._closed_form_solver.family
        return "general6r" if self.general_solver is not None else "numerical"

    @property
    def complete_ik(self) -> bool:
        """Whether :meth:`ik` returns every solution (a closed-form family or the general 6R
        solver), not the numerical IK's one per call."""
        return self.ik_family != "numerical"

    def ik(self, T: ArrayLike, q_seed: ArrayLike | None = None,
           tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
           copies: bool = False) -> IKSolutions:
        """The solutions for pose ``T`` (base_link -> tool0, 4x4 m) within the joint limits.

        One solution per branch: its in-limit 2pi copy nearest ``q_seed`` (nearest 0 without
        one); ``copies=True`` lists every in-limit copy. Each solution is verified by FK on the
        exact chain to ``tolerance`` (m and rad). At a singularity the free joint is taken from
        ``q_seed`` wherever that verifies, and the solution is flagged. With ``tcp`` (tool0 ->
        TCP, 4x4) the target ``T`` is the pose of that TCP instead of tool0. A rotation block
        off orthonormal by rounding is projected onto the nearest rotation
        (``result.projection`` says how far). An empty result's ``reason`` says why.

        When no closed-form family fits a chain of six revolute joints, the general 6R solver
        answers (family "general6r", :attr:`general_solver`): every solution, no branch labels.
        Otherwise (other joint counts, prismatic joints, or a table the general solver cannot
        be built for) the numerical solver answers (``result.numerical`` is True, family
        "numerical"): the solution from the seed's basin first, not necessarily every solution.
        """
        solver = self._closed_form_solver
        if solver is not None:  # ClosedFormSolver.solve_one, without its own call
            solved = solver.solve_common(T, q_seed, tolerance, tcp, copies)
            if type(solved) is IKSolutions:
                return solved
            return solver.solve_rest(solved, T, q_seed, tolerance, tcp, copies)
        general = self.general_solver
        if general is not None:
            return general.solve_one(T, q_seed, tolerance, tcp, copies)
        return self.numerical_solver().solve(T, q_seed, tolerance=tolerance, tcp=tcp)

    def ik_batch(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                 tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                 copies: bool = False, chunk_size: int = DEFAULT_CHUNK,
                 workers: int | None = None
                 ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """IK of N poses (N, 4, 4) -> solutions (N, m, n) and validity mask (N, m).

        The same solutions as :meth:`ik` pose by pose, in the same order; rows are padded to the
        largest count m (without copies m <= 8 on an exact table, and up to 8 + 16 on a refined
        one, whose exact chain can have roots beyond the eight branches near the ideal model's
        singular sets; with every copy a UR arm's +-360 deg joints give
        up to 256 or more per pose: see :meth:`ik_batch_chunks` for very large batches).
        ``workers`` threads share the poses (default: the CPUs this process may use; the
        result does not depend on it). Without a closed-form family the general 6R solver
        answers (its pose loop in the compiled core, shared among ``workers`` the same way), and
        where that does not apply the numerical solver (``copies``, ``chunk_size`` and
        ``workers`` do not apply).
        """
        if self._closed_form_solver is None and self.general_solver is None:
            return self.numerical_solver().solve_batch(T, q_seed, tolerance=tolerance, tcp=tcp)
        batch = self.ik_batch_detailed(T, q_seed, tolerance, tcp, copies, chunk_size, workers)
        return batch.q, batch.valid

    def batch_memory(self, n_poses: int) -> int:
        """Bytes :meth:`ik_batch` with ``copies=True`` may need for ``n_poses`` poses of the
        closed-form family (0 without one): the result at its widest, n_poses x the most
        solutions one pose can have x :func:`batch_bytes_per_solution`, twice (each chunk's
        result is made on its own and the chunks are joined at the end). The most solutions:
        the solver's ``max_solutions``, capped by what the limits allow, every branch times,
        per revolute joint, floor(span / 2 pi) + 1 copies (the most 2 pi copies of one angle a
        closed interval of that span holds)."""
        solver = self._closed_form_solver
        if solver is None:
            return 0
        spans = self.table.upper - self.table.lower
        revolute = np.array([joint.is_revolute for joint in self.table.joints])
        copies = np.where(revolute, np.floor(spans / (2.0 * np.pi)) + 1, 1)
        widest = min(solver.max_solutions, len(solver.branch_labels) * int(np.prod(copies)))
        return 2 * int(n_poses) * widest * batch_bytes_per_solution(self.dof)

    def _check_batch_memory(self, T: ArrayLike, copies: bool) -> None:
        """With every copy, size the batch before it is allocated: InputError naming the bytes
        (:meth:`batch_memory`) and :meth:`ik_batch_chunks` when they exceed
        :func:`dhkin.memory.available_memory`."""
        if copies is not True or self._closed_form_solver is None:
            return
        poses = int(np.prod(np.shape(T)[:-2])) if np.ndim(T) >= 2 else 1
        needed = self.batch_memory(poses)
        available = memory.available_memory()
        if available is not None and needed > available:
            raise InputError(
                f"T: ik_batch with copies=True of {poses} poses may need {needed / 1e9:.3g} GB "
                f"(robot.batch_memory), more than the {available / 1e9:.3g} GB available; "
                "expected fewer poses, or robot.ik_batch_chunks(T, copies=True), which yields "
                "the result chunk by chunk", field="T", value=poses,
                expected="a batch that fits in memory")

    def ik_batch_detailed(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                          tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                          copies: bool = False, chunk_size: int = DEFAULT_CHUNK,
                          workers: int | None = None) -> IKBatch:
        """Like :meth:`ik_batch`, with flags, branch indices, residuals and projections (the
        closed-form family, else the general 6R solver; FamilyError for neither). With
        ``copies=True`` a batch too large for the memory available is an InputError naming
        its size and :meth:`ik_batch_chunks`, before anything is allocated."""
        self._check_batch_memory(T, copies)
        general = self.general_solver
        if self._closed_form_solver is None and general is not None:
            return general.solve_batch(T, q_seed, tolerance, tcp, copies, chunk_size, workers)
        return self.ik_solver.solve_batch(T, q_seed, tolerance, tcp, copies, chunk_size,
                                          workers)

    def ik_batch_seeds(self, T: ArrayLike, q_seeds: Sequence[ArrayLike | None],
                       tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                       copies: bool = False, chunk_size: int = DEFAULT_CHUNK,
                       workers: int | None = None) -> list[IKBatch]:
        """:meth:`ik_batch_detailed` of the poses T once per seed set of ``q_seeds`` (each None,
        (6,) or (N, 6)), in order: answer s is ``ik_batch_detailed(T, q_seeds[s], ...)`` row for
        row. The general 6R solver finds each pose's roots once for every set (they do not
        depend on the seed, which chooses copies and curve members only): the answers of a pose
        under several seeds at about the cost of one. A closed-form family's roots depend on its
        seed (the seeded candidates of its singular sets): one batch per set."""
        if not q_seeds:
            raise InputError("q_seeds: expected at least one seed set", field="q_seeds")
        general = self.general_solver
        # a subclass that answers otherwise (its own ik_batch_detailed) is asked as it answers
        if general is None or type(self).ik_batch_detailed is not Robot.ik_batch_detailed:
            return [self.ik_batch_detailed(T, q_seed, tolerance, tcp, copies, chunk_size, workers)
                    for q_seed in q_seeds]
        self._check_batch_memory(T, copies)
        return general.solve_batch_seeds(T, q_seeds, tolerance, tcp, copies, chunk_size, workers)

    def ik_batch_chunks(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                        tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                        copies: bool = False, chunk_size: int | None = None
                        ) -> Iterator[tuple[int, IKBatch]]:
        """:meth:`ik_batch_detailed` chunk by chunk, for batches too large to hold at once:
        yields (index of the chunk's first pose, IKBatch of poses ``start:start + len``), each
        chunk padded to its own largest count (default chunks hold about 64 MiB of output)."""
        return self.ik_solver.solve_chunks(T, q_seed, tolerance, tcp, copies, chunk_size)

    def singularity(self, q: ArrayLike,
                    thresholds: Thresholds | Mapping[str, float] | None = None
                    ) -> SingularityReport:
        """Singularity report of q (URDF joint values, rad and m).

        ``kinds``: the singularities q is at or near (subset of "wrist", "elbow", "shoulder");
        ``distances`` (``|sin q5|``, metres); the analytic det J factored into shoulder x elbow x
        wrist terms; Pinocchio's ``sigma_min``, singular values, Yoshikawa measures and
        condition. ``thresholds`` default to dhkin.singularity.DEFAULT_THRESHOLDS, or override
        some kinds: {"wrist": 1e-3}. FamilyError outside the closed-form families. See
        docs/singularities.md.
        """
        from dhkin.singularity import singularity_report

        return singularity_report(self, q, thresholds)
