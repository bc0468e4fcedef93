"""The closed-form IK of one robot: inputs checked, the compiled core called, results built.

:class:`ClosedFormSolver` holds a table's family fit (:mod:`dhkin.ik.family`) and the core's
solver of its plan (:mod:`dhkin.ik.plan`; the pipeline's steps are documented in
``cpp/dhkin/pipeline.hpp`` and ``cpp/dhkin/expand.hpp``). A
:class:`~dhkin.robot.Robot` keeps one. Poses are base_link -> tool0 (or -> a TCP given as
``tcp``, tool0 -> TCP) in metres; joint values are URDF joint values (rad, m).

Results: :meth:`ClosedFormSolver.solve_one` gives :class:`~dhkin.ik.result.IKSolutions` (one
pose, with configurations, flags, residuals, the input's projection and, when empty, the true
reason); :meth:`solve_batch` gives :class:`~dhkin.ik.result.IKBatch`; :meth:`solve_chunks`
streams a large batch. By default each branch gives one solution, its in-limit 2pi copy nearest
the seed (nearest 0 without one); ``copies=True`` lists every in-limit copy.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin import _core
from dhkin.dh import DHTable
from dhkin.errors import InputError
from dhkin.ik.core import (
    BRANCHES,
    EXTRA_ROOTS,
    STATUS_BAD_SEED,
    WHY_SIZE,
    pose_status,
    project,
)
from dhkin.ik.family import FamilyFit
from dhkin.ik.inputs import (
    TWO_PI,
    _check_chunk,
    as_targets,
    check_flag,
    check_tolerance,
    pose_error_message,
)
from dhkin.ik.plan import plan_fields
from dhkin.ik.result import BranchSolutions, Configuration, IKBatch, IKSolutions
from dhkin.ik.workers import _in_slices, check_workers
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import invert

#: Poses per kernel call of :meth:`ClosedFormSolver.solve_batch`.
DEFAULT_CHUNK = 65536


_from_core = IKSolutions.from_core

#: solve_chunks' default chunks hold at most this much output (bytes).
STREAM_BYTES = 64 * 2**20


class _Configurations:
    """The (shared) Configuration of a branch and its turns: ``configurations(branch, turns)``.

    Holds no reference to its solver: the core keeps one (ClosedForm.bind_results), and a
    reference back would be a cycle the garbage collector cannot see through the core."""

    __slots__ = ("known", "labels")

    def __init__(self, labels: tuple[Mapping[str, str], ...]) -> None:
        self.labels = labels
        self.known: dict[tuple[int, tuple[int, ...]], Configuration] = {}

    def __call__(self, branch: int, turns: tuple[int, ...]) -> Configuration:
        key = (branch, turns)
        found = self.known.get(key)
        if found is None:
            if len(self.known) >= 65536:
                self.known.clear()
            found = Configuration(labels=self.labels[branch], turns=turns)
            self.known[key] = found
        return found


class INFO:
    """Columns of the per-pose info the core writes (cpp/dhkin/plan.hpp, ``PoseInfo``)."""

    status, projection, candidates, verified, dropped, best_position, best_rotation = range(7)
    size = 7


class ClosedFormSolver:
    """The closed-form IK of one table (see the module docstring); safe to call from several
    threads (the core releases the GIL and keeps no state between calls)."""

    def __init__(self, table: DHTable, fit: FamilyFit) -> None:
        self.table, self.fit = table, fit
        self.family = fit.family
        self.dof = table.dof
        self.branch_labels: tuple[Mapping[str, str], ...] = tuple(
            MappingProxyType(dict(labels)) for labels in fit.solved.branch_labels)
        self.n_branches = len(self.branch_labels)
        self.plan = plan_fields(table, fit)
        self._base_inverse = invert(table.base)
        self.frames = self.frames_for(None)
        self.core = _core.ClosedForm(self.plan, self.frames)
        #: Whether answers reach beyond the branch slots: a refined table of six revolute joints
        #: is completed by the general 6R solver's roots of its exact chain wherever the slots may
        #: not hold every root (cpp/dhkin/extra_roots.hpp); its batches come from the core as rows.
        self.completed = bool(fit.refine and table.dof == 6
                              and all(j.is_revolute for j in table.joints))
        if self.completed:
            from dhkin.ik.general6r import General6RSolver

            self.core.attach_exact_roots(General6RSolver(table).core)
        self._configure = _Configurations(self.branch_labels)
        self.core.bind_results(IKSolutions, self._configure, self.family)
        #: The common single call made whole in the core (bound once: Robot.ik calls it first):
        #: solve_common(T, q_seed, tolerance, tcp, copies) gives solve_one's IKSolutions when the
        #: pose has solutions, the core's Answer when it has none, else None (any other call:
        #: :meth:`solve_rest` then takes it).
        self.solve_common = self.core.solve_common
        self._zero_seed = np.zeros(self.dof)
        self._revolute = np.array([j.is_revolute for j in table.joints], dtype=float)
        spans = table.upper - table.lower
        revolute = np.array([j.is_revolute for j in table.joints])
        copies = np.where(revolute, np.floor(spans / TWO_PI) + 2, 1).astype(np.int64)
        #: Most roots one pose can have: a slot per branch, and on a completed table up to
        #: EXTRA_ROOTS beyond them.
        self.max_roots = self.n_branches + (EXTRA_ROOTS if self.completed else 0)
        #: Most solutions one pose can have with every copy: a revolute joint has at most
        #: 2 * MAX_JOINT_TURNS + 2 = 6 copies, since every DHTable keeps its limits within
        #: +-dhkin.dh.MAX_JOINT_TURNS turns (what bounds the buffers sized by this number).
        self.max_solutions = int(self.max_roots * np.prod(copies))

    def __repr__(self) -> str:
        mode = "refined on the exact chain" if self.fit.refine else "exact family"
        return f"ClosedFormSolver({self.table.name!r}, {self.family}, {mode})"

    # -- inputs -------------------------------------------------------------------------------

    def frames_for(self, tcp: ArrayLike | None) -> NDArray[np.float64]:
        """(2, 4, 4): base^-1 and (tool @ tcp)^-1 (T_dh = frames[0] @ T @ frames[1])."""
        tool = self.table.tool
        if tcp is not None:
            frame = np.asarray(tcp, dtype=float)
            if frame.shape != (4, 4) or not np.all(np.isfinite(frame)):
                raise InputError(f"tcp: expected a finite (4, 4) transform tool0 -> TCP, "
                                 f"got shape {frame.shape}", field="tcp")
            status = pose_status(frame)
            if status:
                raise InputError(pose_error_message("tcp", frame, status))
            projected, _ = project(frame)
            tool = tool @ projected
        return np.ascontiguousarray(np.stack([self._base_inverse, invert(tool)]))

    def _seeds(self, q_seed: ArrayLike | None, n_poses: int) -> NDArray[np.float64]:
        if q_seed is None:
            return self._zero_seed[None]
        try:
            seeds = np.ascontiguousarray(q_seed, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(f"q_seed: expected numbers of shape ({self.dof},) or "
                             f"({n_poses}, {self.dof}) ({exc})", field="q_seed") from exc
        if seeds.shape == (self.dof,):
            seeds = seeds[None]
        if seeds.shape not in ((1, self.dof), (n_poses, self.dof)):
            raise InputError(f"q_seed: expected shape ({self.dof},) or ({n_poses}, "
                             f"{self.dof}), got {np.shape(q_seed)}", field="q_seed")
        if not np.all(np.isfinite(seeds)):
            raise InputError(field="q_seed", value=seeds.tolist(), expected="finite values")
        return seeds

    def _clamp(self, tolerance: float) -> float:
        """The reach band of the core (cpp/dhkin/plan.hpp, ``Plan::clamp``)."""
        return tolerance * (1.0 + float(self.plan["lever"])) + float(self.plan["deviation"])

    # -- one pose -----------------------------------------------------------------------------

    def solve_one(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                  tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                  copies: bool = False) -> IKSolutions:
        """Every branch's solution of one pose (4, 4) (see the module docstring)."""
        solved = self.solve_common(T, q_seed, tolerance, tcp, copies)
        if type(solved) is IKSolutions:
            return solved
        return self.solve_rest(solved, T, q_seed, tolerance, tcp, copies)

    def solve_rest(self, answer: Any, T: ArrayLike, q_seed: ArrayLike | None, tolerance: float,
                   tcp: ArrayLike | None, copies: bool) -> IKSolutions:
        """:meth:`solve_one` of a call :attr:`solve_common` gave ``answer`` for (not an
        IKSolutions): the core's Answer of a usable pose without solutions, or None (a call it
        does not take as it is: the checked path converts, or says what is wrong)."""
        if answer is not None:
            return self._solutions(answer, tolerance)
        return self._solve_checked(T, q_seed, tolerance, tcp, copies)

    def _solve_checked(self, T: ArrayLike, q_seed: ArrayLike | None, tolerance: float,
                       tcp: ArrayLike | None, copies: bool) -> IKSolutions:
        """:meth:`solve_one` with every input checked (an InputError names the field)."""
        tolerance = check_tolerance(tolerance)
        copies = check_flag(copies, "copies")
        try:
            target = np.ascontiguousarray(T, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(f"T: expected a (4, 4) pose of numbers ({exc})", field="T") from exc
        if target.shape != (4, 4):
            raise InputError(f"T: expected a (4, 4) pose, got shape {np.shape(T)}", field="T")
        seed = self._zero_seed if q_seed is None else self._seeds(q_seed, 1)[0]
        frames = self.frames if tcp is None else self.frames_for(tcp)
        answer = self.core.solve(target, seed, tolerance, frames, copies)
        if answer.status:
            if answer.status == STATUS_BAD_SEED:
                raise InputError(field="q_seed", value=seed.tolist(),
                                 expected="finite values")
            raise InputError(pose_error_message("T", target, answer.status))
        return self._solutions(answer, tolerance)

    def _solutions(self, answer: Any, tolerance: float) -> IKSolutions:
        """The IKSolutions of a core ``Answer`` of a usable pose."""
        if answer.count == 0:
            return IKSolutions(q=np.zeros((0, self.dof)), family=self.family,
                               projection=answer.projection, dropped=answer.dropped,
                               reason=self._reason(answer.candidates, answer.verified,
                                                   answer.best_position, answer.best_rotation,
                                                   answer.why(), tolerance))
        return _from_core(answer, self.family, self._configure)

    def _reason(self, candidates: int, verified: int, best_position: float,
                best_rotation: float, why: NDArray[np.float64], tolerance: float) -> str:
        """Why one pose has no solution, from the core's counts and numbers: always true."""
        if candidates == 0:
            return (self.fit.explain(why, self._clamp(tolerance))
                    or "no branch of the closed form has a solution for this pose")
        if verified == 0:
            return (f"{candidates} branch solution(s) of the closed form did not verify on the "
                    f"exact chain at tolerance {tolerance:g} (closest: "
                    f"{best_position:.3g} m, {best_rotation:.3g} rad)")
        return (f"{verified} branch solution(s) verified, but no 2pi copy of any lies within "
                f"the joint limits")

    # -- batches ------------------------------------------------------------------------------

    def solve_batch(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                    tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                    copies: bool = False, chunk_size: int = DEFAULT_CHUNK,
                    workers: int | None = None) -> IKBatch:
        """Every solution of N poses (N, 4, 4), as :meth:`solve_one` pose by pose, padded to the
        largest count; poses run in chunks of ``chunk_size``, each shared among ``workers``
        threads (default: the CPUs this process may use; see :data:`POSES_PER_WORKER`)."""
        tolerance = check_tolerance(tolerance)
        workers = check_workers(workers)
        targets, _ = as_targets(T)
        seeds = self._seeds(q_seed, targets.shape[0])
        frames = self.frames if tcp is None else self.frames_for(tcp)
        return self._batch(targets, seeds, tolerance, frames, check_flag(copies, "copies"),
                           _check_chunk(chunk_size), 0, workers)

    def _batch(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
               tolerance: float, frames: NDArray[np.float64], copies: bool, chunk_size: int,
               first_index: int, workers: int = 1) -> IKBatch:
        """solve_batch of checked inputs; ``first_index`` numbers the poses in errors.

        Chunk by chunk: the principal solutions of a chunk (steps 1-3), then its solutions
        (step 4) straight into the result. Without copies the result is B wide (then trimmed to
        the widest pose); with every copy each chunk is expanded into its own arrays and the
        chunks are joined at the end. Memory: the result and one chunk's work."""
        if self.completed:
            return self._batch_rows(targets, seeds, tolerance, frames, copies, chunk_size,
                                    first_index, workers)
        if not copies:
            return self._batch_nearest(targets, seeds, tolerance, frames, chunk_size,
                                       first_index, workers)
        N = targets.shape[0]
        chunks: list[tuple[int, int, Any]] = []
        projection = np.empty(N)
        dropped = np.empty(N, np.int64)
        out = None if copies else self._batch_arrays(N, self.n_branches)
        width = 0
        for start in range(0, N, chunk_size):
            stop = min(start + chunk_size, N)
            part = seeds if seeds.shape[0] == 1 else seeds[start:stop]
            principal = self._principal(targets[start:stop], part, tolerance, frames, copies,
                                        first_index + start, workers)
            totals, info = principal[4:6]
            projection[start:stop] = info[:, INFO.projection]
            dropped[start:stop] = info[:, INFO.dropped]
            chunk_width = int(totals.sum(axis=1).max()) if stop > start else 0
            target = (self._batch_arrays(stop - start, chunk_width) if copies
                      else tuple(a[start:stop] for a in out))
            chunk_targets = targets[start:stop]

            def expand(a: int, b: int, chunk_targets: NDArray[np.float64] = chunk_targets,
                       part: NDArray[np.float64] = part, principal: tuple[Any, ...] = principal,
                       target: tuple[Any, ...] = target) -> None:
                q, ok, flags, errors = principal[:4]
                self.core.expand(chunk_targets[a:b], part if part.shape[0] == 1 else part[a:b],
                                 tolerance, frames, copies, q[a:b], ok[a:b], flags[a:b],
                                 errors[a:b], *(array[a:b] for array in target))

            _in_slices(stop - start, workers, expand)
            width = max(width, int(target[1].sum(axis=1).max()) if stop > start else 0)
            if copies:
                chunks.append((start, stop, target))
        if copies:
            out = self._batch_arrays(N, width)
            for start, stop, target in chunks:
                for whole, part_array in zip(out, target, strict=True):
                    whole[start:stop, :part_array.shape[1]] = part_array[:, :width]
                    if part_array.shape[1] < width:
                        whole[start:stop, part_array.shape[1]:] = 0
                out[2][start:stop, target[2].shape[1]:] = -1  # branch: none
        elif width < self.n_branches:
            out = tuple(np.ascontiguousarray(a[:, :width]) for a in out)
        out_q, out_valid, out_branch, out_flags, out_errors = out
        return IKBatch(q=out_q, valid=out_valid, flags=out_flags, branch=out_branch,
                       branch_labels=self.branch_labels, family=self.family,
                       residuals=out_errors, projection=projection, dropped=dropped)

    def _batch_nearest(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
                       tolerance: float, frames: NDArray[np.float64], chunk_size: int,
                       first_index: int, workers: int) -> IKBatch:
        """solve_batch without copies: the core writes each pose's solutions (its branches'
        nearest in-limit copies) straight into the result (``ClosedForm.nearest``)."""
        N, B = targets.shape[0], self.n_branches
        # uninitialised: the core writes every slot of each pose (empty values past its last
        # solution), and a rejected pose raises below
        out: tuple[NDArray[Any], ...] = (
            np.empty((N, B, self.dof)), np.empty((N, B), np.bool_), np.empty((N, B), np.int16),
            np.empty((N, B), np.uint8), np.empty((N, B, 2)))
        projection, dropped = np.empty(N), np.empty(N, np.int64)
        reports: list[tuple[int, int, int, int]] = []

        def solve(a: int, b: int, start: int = 0) -> None:
            a, b = start + a, start + b
            q, valid, branch, flags, errors = (array[a:b] for array in out)
            rejected, status, width = self.core.nearest(
                targets[a:b], seeds if seeds.shape[0] == 1 else seeds[a:b], tolerance, frames,
                q, valid, branch, flags, errors, projection[a:b], dropped[a:b])
            reports.append((a + rejected if rejected >= 0 else -1, status, width, a))

        for start in range(0, N, chunk_size):
            stop = min(start + chunk_size, N)
            _in_slices(stop - start, workers,
                       lambda a, b, start=start: solve(a, b, start))  # type: ignore[misc]
            rejected = [(index, status) for index, status, _, _ in reports if index >= 0]
            if rejected:
                index, status = min(rejected)
                self._raise_status(targets[index], status, first_index + index)
        width = max((w for _, _, w, _ in reports), default=0)
        if width < B:
            out = tuple(np.ascontiguousarray(a[:, :width]) for a in out)
        out_q, out_valid, out_branch, out_flags, out_errors = out
        return IKBatch(q=out_q, valid=out_valid, flags=out_flags, branch=out_branch,
                       branch_labels=self.branch_labels, family=self.family,
                       residuals=out_errors, projection=projection, dropped=dropped)

    def _batch_rows(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
                    tolerance: float, frames: NDArray[np.float64], copies: bool,
                    chunk_size: int, first_index: int, workers: int) -> IKBatch:
        """solve_batch of a completed table: the core answers each slice of poses as rows
        (``ClosedForm.rows``: a pose may have more solutions than branch slots), joined and
        padded to the largest count."""
        parts: dict[int, tuple[Any, ...]] = {}
        for start in range(0, targets.shape[0], chunk_size):
            stop = min(start + chunk_size, targets.shape[0])

            def solve(a: int, b: int, start: int = start) -> None:
                a, b = start + a, start + b
                parts[a] = self.core.rows(targets[a:b],
                                          seeds if seeds.shape[0] == 1 else seeds[a:b],
                                          tolerance, frames, copies)

            _in_slices(stop - start, workers, solve)
            rejected = [(first + int(part[7]), int(part[8])) for first, part in parts.items()
                        if part[7] >= 0]
            if rejected:
                index, status = min(rejected)
                self._raise_status(targets[index], status, first_index + index)
        ordered = [parts[first] for first in sorted(parts)]

        def joined(k: int, empty: NDArray[Any]) -> NDArray[Any]:
            return np.concatenate([part[k] for part in ordered]) if ordered else empty

        return IKBatch.from_rows(
            joined(0, np.zeros((0, self.dof))), joined(2, np.zeros(0, np.uint8)),
            joined(1, np.zeros(0, np.int16)), joined(3, np.zeros((0, 2))),
            joined(4, np.zeros(0, np.int64)), self.branch_labels, self.family,
            joined(5, np.zeros(0)), joined(6, np.zeros(0, np.int64)))

    def _batch_arrays(self, n_poses: int, width: int) -> tuple[NDArray[Any], ...]:
        """Result arrays of step 4: q, valid, branch, flags, residuals."""
        return (np.zeros((n_poses, width, self.dof)), np.zeros((n_poses, width), np.bool_),
                np.full((n_poses, width), -1, np.int16), np.zeros((n_poses, width), np.uint8),
                np.zeros((n_poses, width, 2)))

    def _principal(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
                   tolerance: float, frames: NDArray[np.float64], copies: bool,
                   first_index: int, workers: int = 1) -> tuple[NDArray[Any], ...]:
        """Steps 1-3 for checked poses: q, ok, flags, errors, totals, info (the core's
        ``principal``), then the roots beyond the slots: extra_q (N, E, n), extra_branch (-1
        past a pose's last), extra_flags (N, E), extra_errors (N, E, 2) (E = 0 on a table that
        is not completed); in contiguous slices on up to ``workers`` threads; a rejected pose
        raises InputError (its ``index`` the pose's)."""
        N, B, n = targets.shape[0], BRANCHES, self.dof
        E = EXTRA_ROOTS if self.completed else 0
        outputs: tuple[NDArray[Any], ...] = (
            np.empty((N, B, n)), np.empty((N, B), np.bool_), np.empty((N, B), np.uint8),
            np.empty((N, B, 2)), np.empty((N, B), np.int64), np.empty((N, WHY_SIZE)),
            np.empty((N, INFO.size)), np.empty((N, E, n)), np.empty((N, E), np.int16),
            np.empty((N, E), np.uint8), np.empty((N, E, 2)))

        def solve(a: int, b: int) -> None:
            self.core.principal(targets[a:b], seeds if seeds.shape[0] == 1 else seeds[a:b],
                                tolerance, frames, copies, *(array[a:b] for array in outputs))

        _in_slices(N, workers, solve)
        q, ok, flags, errors, totals, _, info, *extra = outputs
        self._raise_rejected(targets, info, first_index)
        return (q, ok, flags, errors, totals, info, *extra)

    def branches(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                 tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None
                 ) -> BranchSolutions:
        """The verified solution of every branch of N poses (N, 4, 4), before joint limits and
        2pi copies: values wrapped to (-pi, pi] (revolute joints), one row per branch (see
        :class:`BranchSolutions`)."""
        tolerance = check_tolerance(tolerance)
        targets, _ = as_targets(T)
        seeds = self._seeds(q_seed, targets.shape[0])
        frames = self.frames if tcp is None else self.frames_for(tcp)
        q, ok, flags, errors, _, info, extra_q, extra_branch, extra_flags, extra_errors = \
            self._principal(targets, seeds, tolerance, frames, False, 0)
        q[~ok] = 0.0
        errors[~ok] = 0.0
        width = int((extra_branch >= 0).sum(axis=1).max(initial=0))
        return BranchSolutions(q=q, valid=ok, flags=np.where(ok, flags, 0).astype(np.uint8),
                               residuals=errors, branch_labels=self.branch_labels,
                               dropped=info[:, INFO.dropped].astype(np.int64),
                               extra_q=np.ascontiguousarray(extra_q[:, :width]),
                               extra_branch=np.ascontiguousarray(extra_branch[:, :width]),
                               extra_flags=np.ascontiguousarray(extra_flags[:, :width]),
                               extra_residuals=np.ascontiguousarray(extra_errors[:, :width]))

    def _raise_rejected(self, targets: NDArray[np.float64], info: NDArray[np.float64],
                        start: int) -> None:
        bad = np.flatnonzero(info[:, INFO.status])
        if bad.size:
            index = int(bad[0])
            self._raise_status(targets[index], int(info[index, INFO.status]), start + index)

    @staticmethod
    def _raise_status(target: NDArray[np.float64], status: int, index: int) -> None:
        """The InputError of pose ``index`` (``target``) rejected with ``status``."""
        if status == STATUS_BAD_SEED:
            raise InputError(f"q_seed[{index}]: expected finite values", field="q_seed",
                             index=index, expected="finite values")
        raise InputError(pose_error_message(f"T[{index}]", target, status), field="T",
                         index=index)

    def solve_chunks(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                     tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                     copies: bool = False, chunk_size: int | None = None
                     ) -> Iterator[tuple[int, IKBatch]]:
        """:meth:`solve_batch` chunk by chunk: yields (index of the chunk's first pose, IKBatch
        of its poses). The default chunk holds at most :data:`STREAM_BYTES` of output."""
        tolerance = check_tolerance(tolerance)
        copies = check_flag(copies, "copies")
        targets, _ = as_targets(T)
        frames = self.frames if tcp is None else self.frames_for(tcp)
        if chunk_size is None:
            per_pose = (self.max_solutions if copies else self.max_roots) * (8 * self.dof + 20)
            chunk_size = int(min(DEFAULT_CHUNK, max(1024, STREAM_BYTES // per_pose)))
        chunk_size = _check_chunk(chunk_size)
        seeds = self._seeds(q_seed, targets.shape[0])
        for start in range(0, targets.shape[0], chunk_size):
            stop = min(start + chunk_size, targets.shape[0])
            part = seeds if seeds.shape[0] == 1 else seeds[start:stop]
            yield start, self._batch(targets[start:stop], part, tolerance, frames, copies,
                                     chunk_size, start)
