"""The closed-form IK of one robot: inputs checked, compiled pipeline called, results built.

:class:`ClosedFormSolver` holds a table's family fit (:mod:`dhkin.ik.family`) and the constants
of the compiled pipeline (:mod:`dhkin.ik.compiled.pipeline`, which documents every step). A
:class:`~dhkin.robot.Robot` keeps one. Poses are base_link -> tool0 (or -> a TCP given as
``tcp``, tool0 -> TCP) in metres; joint values are URDF joint values (rad, m).

Results: :meth:`ClosedFormSolver.solve_one` gives :class:`~dhkin.ik.result.IKSolutions` (one
pose, with configurations, flags, residuals, the input's projection and, when empty, the true
reason); :meth:`solve_batch` gives :class:`~dhkin.ik.result.IKBatch`; :meth:`solve_chunks`
streams a large batch. By default each branch gives one solution, its in-limit 2pi copy nearest
the seed (nearest 0 without one); ``copies=True`` lists every in-limit copy.
"""

from __future__ import annotations

import functools
import math
import os
import threading
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import ThreadPoolExecutor
from types import MappingProxyType, ModuleType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import DHTable
from dhkin.errors import InputError
from dhkin.ik.family import BAND, FamilyFit
from dhkin.ik.result import BranchSolutions, Configuration, IKBatch, IKSolutions, flag_names
from dhkin.transforms import invert, rot_x, rot_z, translation

TWO_PI = 2.0 * math.pi
#: A returned solution reproduces the target to this position (m) and rotation (rad) error.
DEFAULT_TOLERANCE = 1e-9
#: Poses per kernel call of :meth:`ClosedFormSolver.solve_batch`.
DEFAULT_CHUNK = 65536
#: A batch is shared among worker threads (the kernels release the GIL) only when each gets at
#: least this many poses: starting a slice costs ~30 us, the work of a few poses; each pose is
#: solved alone, so the result does not depend on the number of workers.
POSES_PER_WORKER = 512
#: Slices per worker thread of a shared batch (see :func:`_in_slices`).
SLICES_PER_WORKER = 4
#: solve_chunks' default chunks hold at most this much output (bytes).
STREAM_BYTES = 64 * 2**20
#: On a refined table, roots near a reach boundary are computed as if the target were at least
#: this fraction of the model deviation (m) inside it (dhkin.ik.compiled.spherical): enough to
#: give each of two roots that the ideal model merges a start on its own side, small enough not
#: to move starts near a sensitive boundary far from the exact roots (measured on the calibrated
#: UR5e, 2000 vendor poses: 0.2 and 0.02 lose 2-3 poses, 2.0 loses 10, none loses 29).
SPREAD_FRACTION = 0.2
#: Singularity flag names of each bit mask.
_FLAG_SETS: tuple[frozenset[str], ...] = tuple(flag_names(bits) for bits in range(8))


def _kernels() -> ModuleType:
    """dhkin.ik.compiled.pipeline, imported on first use (importing numba takes ~0.5 s)."""
    from dhkin.ik.compiled import pipeline

    return pipeline


def chain_array(table: DHTable) -> NDArray[np.float64]:
    """The exact chain of ``table`` (corrections included) as the compiled ``chain`` layout
    (n + 1, ROW): per joint the constant frame before its motion, its kind, direction and offset;
    the last row the frame after the last motion (see dhkin.ik.compiled.chain)."""
    from dhkin.ik.compiled.chain import JOINT, ROW

    n = table.dof
    chain = np.zeros((n + 1, ROW))
    after = np.eye(4)  # constant part since the previous joint's motion
    for j, joint in enumerate(table.joints):
        twist = rot_x(joint.alpha) @ translation(joint.a, 0, 0)
        if table.convention == "standard":
            before = after if joint.is_revolute else after @ rot_z(joint.theta)
            rest = translation(joint.a, 0, 0) @ rot_x(joint.alpha)
            after = (translation(0, 0, joint.d) @ rest if joint.is_revolute else rest)
        else:
            before = after @ twist if joint.is_revolute else after @ twist @ rot_z(joint.theta)
            after = translation(0, 0, joint.d) if joint.is_revolute else np.eye(4)
        after = after @ joint.correction_matrix
        chain[j, JOINT.pre:JOINT.pre + 12] = before[:3].ravel()
        chain[j, JOINT.revolute] = 1.0 if joint.is_revolute else 0.0
        chain[j, JOINT.direction] = joint.direction
        chain[j, JOINT.offset] = joint.offset
    chain[n, :12] = after[:3].ravel()
    return chain


def plan_array(table: DHTable, fit: FamilyFit) -> NDArray[np.float64]:
    """The ``plan`` of the compiled pipeline (layout PLAN, then geometry, chain and limits)."""
    from dhkin.ik.compiled.bands import FLAG_BAND

    kernels = _kernels()
    PLAN = kernels.PLAN
    geometry = fit.solved.geometry.copy()
    chain = chain_array(table)
    limits = np.stack([table.lower, table.upper], axis=1)
    scale = fit.solved.scale
    lever = max(1.0, scale)
    position, rotation = fit.model_deviation
    deviation = position + lever * rotation  # how far a point of the arm may move, m
    geometry[_spread_index(fit.solved.kernel)] = SPREAD_FRACTION * deviation
    head = np.zeros(PLAN.size)
    head[PLAN.family] = fit.solved.kernel
    head[PLAN.dof] = table.dof
    head[PLAN.refine] = 1.0 if fit.refine else 0.0
    # A refined table's exact singular set lies anywhere within the family band of the ideal
    # model's (the band bounds the structural deviation): the seed band covers it
    head[PLAN.seed_angle] = FLAG_BAND + (BAND.angle if fit.refine else 0.0)
    head[PLAN.seed_length] = FLAG_BAND * scale + (BAND.length if fit.refine else 0.0)
    head[PLAN.deviation] = 2.0 * deviation
    head[PLAN.lever] = lever
    head[PLAN.free_wrist], head[PLAN.free_elbow], head[PLAN.free_shoulder] = \
        fit.solved.free_joints
    ideal = chain_array(fit.ideal)
    path = model_path(ideal, chain)
    parts = [geometry, chain.ravel(), limits.ravel(), ideal.ravel(), path.ravel()]
    offsets = np.cumsum([PLAN.size] + [part.size for part in parts])
    head[PLAN.geometry_at] = offsets[0]
    head[PLAN.geometry_size] = geometry.size
    head[PLAN.chain_at], head[PLAN.limits_at] = offsets[1], offsets[2]
    head[PLAN.ideal_at], head[PLAN.path_at] = offsets[3], offsets[4]
    return np.ascontiguousarray(np.concatenate([head, *parts]))


def model_path(ideal: NDArray[np.float64], exact: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n + 1, 6): per constant frame of the chains, the rotation vector and translation of
    P(ideal)^-1 P(exact) (the continuation path of dhkin.ik.compiled.chain.interpolate)."""
    path = np.zeros((ideal.shape[0], 6))
    for j in range(ideal.shape[0]):
        P0, P1 = np.eye(4), np.eye(4)
        P0[:3] = ideal[j, :12].reshape(3, 4)
        P1[:3] = exact[j, :12].reshape(3, 4)
        step = invert(P0) @ P1
        R = step[:3, :3]
        angle = float(np.arctan2(0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0],
                                                       R[1, 0] - R[0, 1]]),
                                 0.5 * (np.trace(R) - 1.0)))
        axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        norm = float(np.linalg.norm(axis))
        path[j, :3] = axis * (angle / norm) if norm > 0 else 0.0
        path[j, 3:] = step[:3, 3]
    return path


def _spread_index(kernel: int) -> int:
    """Where a family's geometry vector keeps ``spread``."""
    from dhkin.ik.compiled import offset, spherical

    return offset.GEOMETRY.spread if kernel == _kernels().OFFSET_WRIST \
        else spherical.GEOMETRY.spread


def check_tolerance(tolerance: Any) -> float:
    """``tolerance`` as a float; InputError unless it is a positive finite number."""
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float, np.floating,
                                                                 np.integer)):
        raise InputError(f"tolerance: expected a positive finite number (m and rad), got "
                         f"{tolerance!r}", field="tolerance")
    value = float(tolerance)
    if not (math.isfinite(value) and value > 0.0):
        raise InputError(f"tolerance: expected a positive finite number (m and rad), got "
                         f"{tolerance!r}", field="tolerance")
    return value


def as_targets(T: ArrayLike) -> tuple[NDArray[np.float64], bool]:
    """Poses (4, 4) or (N, 4, 4) as C-contiguous float64 (N, 4, 4) and whether one was given."""
    try:
        targets = np.ascontiguousarray(T, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"T: expected a (4, 4) pose or (N, 4, 4) poses of numbers ({exc})"
                         , field="T") from exc
    single = targets.ndim == 2
    if single:
        targets = targets[None]
    if targets.ndim != 3 or targets.shape[1:] != (4, 4):
        raise InputError(field="T", value=np.shape(T),
                         expected="a (4, 4) pose or (N, 4, 4) poses")
    return targets, single


def pose_error_message(name: str, T: NDArray[np.float64], status: int) -> str:
    """The error message for a pose the kernels rejected with ``status``."""
    from dhkin.ik.compiled import pose

    if status == pose.STATUS_NOT_FINITE:
        return f"{name}: expected finite numbers, got NaN or inf"
    if status == pose.STATUS_BOTTOM_ROW:
        return (f"{name}: bottom row is {T[3].tolist()}, expected [0, 0, 0, 1] (within "
                f"{pose.BOTTOM_ROW_TOLERANCE:g})")
    R = T[:3, :3]
    orthonormality = float(np.abs(R @ R.T - np.eye(3)).max())
    return (f"{name}: rotation block is not a rotation (|R R^T - I| = {orthonormality:.2e}, "
            f"det = {np.linalg.det(R):.3g}); expected |R R^T - I| <= "
            f"{pose.ORTHONORMALITY_GATE:g} and det > 0 (a rotation rounded to a few digits)")


def wrap_revolute(table: DHTable, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Revolute joint values wrapped to (-pi, pi]; prismatic values unchanged."""
    revolute = np.array([j.is_revolute for j in table.joints])
    wrapped = np.pi - np.mod(np.pi - q, TWO_PI)
    return np.where(revolute, wrapped, q)


def turns_of(table: DHTable, q: NDArray[np.float64]) -> NDArray[np.int64]:
    """round(q / 2pi) for revolute joints, 0 for prismatic ones; shape of q."""
    revolute = np.array([j.is_revolute for j in table.joints])
    return np.where(revolute, np.round(q / TWO_PI), 0).astype(np.int64)


class ClosedFormSolver:
    """The closed-form IK of one table (see the module docstring); safe to call from several
    threads (the kernels release the GIL; single-pose buffers are per thread)."""

    def __init__(self, table: DHTable, fit: FamilyFit) -> None:
        self.table, self.fit = table, fit
        self.family = fit.family
        self.dof = table.dof
        self.branch_labels: tuple[Mapping[str, str], ...] = tuple(
            MappingProxyType(dict(labels)) for labels in fit.solved.branch_labels)
        self.n_branches = len(self.branch_labels)
        self.plan = plan_array(table, fit)
        self._base_inverse = invert(table.base)
        self.frames = self.frames_for(None)
        self._zero_seed = np.zeros(self.dof)
        self._buffers = threading.local()
        self._configurations: dict[tuple[int, tuple[int, ...]], Configuration] = {}
        self._revolute = np.array([j.is_revolute for j in table.joints], dtype=float)
        spans = table.upper - table.lower
        revolute = np.array([j.is_revolute for j in table.joints])
        copies = np.where(revolute, np.floor(spans / TWO_PI) + 2, 1).astype(np.int64)
        #: Most solutions one pose can have with every copy.
        self.max_solutions = int(self.n_branches * np.prod(copies))

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
            status = self._status(frame)
            if status:
                raise InputError(pose_error_message("tcp", frame, status))
            projected = np.eye(4)
            from dhkin.ik.compiled.pose import project

            project(np.ascontiguousarray(frame), projected[:3])
            tool = tool @ projected
        return np.ascontiguousarray(np.stack([self._base_inverse, invert(tool)]))

    @staticmethod
    def _status(T: NDArray[np.float64]) -> int:
        from dhkin.ik.compiled.pose import status

        return int(status(np.ascontiguousarray(T, dtype=np.float64)))

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
        """The reach band of the kernels (dhkin.ik.compiled.pipeline, ``clamp``)."""
        PLAN = _kernels().PLAN
        return tolerance * (1.0 + float(self.plan[PLAN.lever])) + float(self.plan[PLAN.deviation])

    # -- one pose -----------------------------------------------------------------------------

    def solve_one(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                  tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                  copies: bool = False) -> IKSolutions:
        """Every branch's solution of one pose (4, 4) (see the module docstring)."""
        tolerance = check_tolerance(tolerance)
        try:
            target = np.ascontiguousarray(T, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(f"T: expected a (4, 4) pose of numbers ({exc})", field="T") from exc
        if target.shape != (4, 4):
            raise InputError(f"T: expected a (4, 4) pose, got shape {np.shape(T)}", field="T")
        seed = self._zero_seed if q_seed is None else self._seeds(q_seed, 1)[0]
        frames = self.frames if tcp is None else self.frames_for(tcp)
        try:
            buffers = self._buffers.arrays
        except AttributeError:
            buffers = self._one_buffers()
        out_q, out_branch, out_flags, out_errors, why, info, fwork, bwork, uwork, iwork = buffers
        count = self._one_kernel(self.plan, frames, target, seed, tolerance, bool(copies), out_q,
                                 out_branch, out_flags, out_errors, why, info, fwork, bwork,
                                 uwork, iwork)
        INFO = _kernels().INFO
        status = int(info[INFO.status])
        if status:
            from dhkin.ik.compiled.pose import STATUS_BAD_SEED

            if status == STATUS_BAD_SEED:
                raise InputError(field="q_seed", value=seed.tolist(),
                                 expected="finite values")
            raise InputError(pose_error_message("T", target, status))
        if count < 0:  # cannot happen: max_solutions counts every copy
            raise RuntimeError("IK expansion: more solutions than counted")
        projection, dropped = float(info[INFO.projection]), int(info[INFO.dropped])
        if count == 0:
            return IKSolutions(q=np.zeros((0, self.dof)), family=self.family,
                               reason=self._reason(info, why, tolerance),
                               projection=projection, dropped=dropped)
        q = out_q[:count].copy()
        turns = (np.rint(q * (1.0 / TWO_PI)) * self._revolute).astype(np.int64).tolist()
        configurations = tuple(map(self._configuration, out_branch[:count].tolist(),
                                   map(tuple, turns)))
        return IKSolutions(q=q, configurations=configurations,
                           flags=tuple(_FLAG_SETS[f] for f in out_flags[:count].tolist()),
                           residuals=out_errors[:count].copy(), family=self.family,
                           projection=projection, dropped=dropped)

    def _one_buffers(self) -> tuple[NDArray[Any], ...]:
        kernels = _kernels()
        floats, bools, uints, ints = kernels.work_sizes(self.dof)
        rows = self.max_solutions
        arrays = (np.empty((rows, self.dof)), np.empty(rows, np.int16), np.empty(rows, np.uint8),
                  np.empty((rows, 2)), np.empty(kernels.WHY_SIZE), np.empty(kernels.INFO.size),
                  np.empty(floats), np.empty(bools, np.bool_), np.empty(uints, np.uint8),
                  np.empty(ints, np.int64))
        self._buffers.arrays = arrays
        return arrays

    @functools.cached_property
    def _one_kernel(self) -> Callable[..., int]:
        """kernels.solve_one's compiled entry point for this solver's argument types (skips
        numba's per-call type resolution of 16 arguments; callers pass exactly those types).
        Compiles (or loads from the cache) by one call on the identity pose."""
        kernel = _kernels().solve_one
        args = (self.plan, self.frames, np.eye(4), self._zero_seed, DEFAULT_TOLERANCE, False,
                *self._one_buffers())
        kernel(*args)
        try:
            from numba import typeof

            return kernel.overloads[tuple(typeof(arg) for arg in args)].entry_point
        except (AttributeError, KeyError, TypeError):  # another numba: the dispatcher
            return kernel

    def _configuration(self, branch: int, turns: tuple[int, ...]) -> Configuration:
        """The (shared) Configuration of a branch and its turns."""
        key = (branch, turns)
        found = self._configurations.get(key)
        if found is None:
            if len(self._configurations) >= 65536:
                self._configurations.clear()
            found = Configuration(labels=self.branch_labels[branch], turns=turns)
            self._configurations[key] = found
        return found

    def _reason(self, info: NDArray[np.float64], why: NDArray[np.float64],
                tolerance: float) -> str:
        """Why one pose has no solution, from the kernel's counts and numbers: always true."""
        INFO = _kernels().INFO
        candidates, verified = int(info[INFO.candidates]), int(info[INFO.verified])
        if candidates == 0:
            return (self.fit.explain(why, self._clamp(tolerance))
                    or "no branch of the closed form has a solution for this pose")
        if verified == 0:
            return (f"{candidates} branch solution(s) of the closed form did not verify on the "
                    f"exact chain at tolerance {tolerance:g} (closest: "
                    f"{info[INFO.best_position]:.3g} m, {info[INFO.best_rotation]:.3g} rad)")
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
        return self._batch(targets, seeds, tolerance, frames, bool(copies),
                           _check_chunk(chunk_size), 0, workers)

    def _batch(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
               tolerance: float, frames: NDArray[np.float64], copies: bool, chunk_size: int,
               first_index: int, workers: int = 1) -> IKBatch:
        """solve_batch of checked inputs; ``first_index`` numbers the poses in errors.

        Chunk by chunk: the principal solutions of a chunk (steps 1-3), then its solutions
        (step 4) straight into the result. Without copies the result is B wide (then trimmed to
        the widest pose); with every copy each chunk is expanded into its own arrays and the
        chunks are joined at the end. Memory: the result and one chunk's work."""
        kernels = _kernels()
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
            totals, info = principal[4:]
            projection[start:stop] = info[:, kernels.INFO.projection]
            dropped[start:stop] = info[:, kernels.INFO.dropped]
            chunk_width = int(totals.sum(axis=1).max()) if stop > start else 0
            target = (self._batch_arrays(stop - start, chunk_width) if copies
                      else tuple(a[start:stop] for a in out))  # type: ignore[union-attr]
            chunk_targets = targets[start:stop]

            def expand(a: int, b: int, chunk_targets: NDArray[np.float64] = chunk_targets,
                       part: NDArray[np.float64] = part, principal: tuple[Any, ...] = principal,
                       target: tuple[Any, ...] = target) -> None:
                q, ok, flags, errors = principal[:4]
                kernels.expand_batch(self.plan, frames, chunk_targets[a:b],
                                     part if part.shape[0] == 1 else part[a:b], tolerance,
                                     copies, q[a:b], ok[a:b], flags[a:b], errors[a:b],
                                     *(array[a:b] for array in target))

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
            out = tuple(np.ascontiguousarray(a[:, :width]) for a in out)  # type: ignore
        out_q, out_valid, out_branch, out_flags, out_errors = out  # type: ignore[misc]
        return IKBatch(q=out_q, valid=out_valid, flags=out_flags, branch=out_branch,
                       branch_labels=self.branch_labels, family=self.family,
                       residuals=out_errors, projection=projection, dropped=dropped)

    def _batch_arrays(self, n_poses: int, width: int) -> tuple[NDArray[Any], ...]:
        """Result arrays of step 4: q, valid, branch, flags, residuals."""
        return (np.zeros((n_poses, width, self.dof)), np.zeros((n_poses, width), np.bool_),
                np.full((n_poses, width), -1, np.int16), np.zeros((n_poses, width), np.uint8),
                np.zeros((n_poses, width, 2)))

    def _principal(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
                   tolerance: float, frames: NDArray[np.float64], copies: bool,
                   first_index: int, workers: int = 1) -> tuple[NDArray[Any], ...]:
        """Steps 1-3 for checked poses: q, ok, flags, errors, totals, info (see
        dhkin.ik.compiled.pipeline.solve_batch), in contiguous slices on up to ``workers``
        threads; a rejected pose raises InputError (its ``index`` the pose's)."""
        kernels = _kernels()
        N, B, n = targets.shape[0], self.n_branches, self.dof
        q = np.empty((N, B, n))
        ok = np.empty((N, B), np.bool_)
        flags = np.empty((N, B), np.uint8)
        errors = np.empty((N, B, 2))
        totals = np.empty((N, B), np.int64)
        why = np.empty((N, kernels.WHY_SIZE))
        info = np.empty((N, kernels.INFO.size))

        def solve(a: int, b: int) -> None:
            kernels.solve_batch(self.plan, frames, targets[a:b],
                                seeds if seeds.shape[0] == 1 else seeds[a:b], tolerance, copies,
                                q[a:b], ok[a:b], flags[a:b], errors[a:b], totals[a:b], why[a:b],
                                info[a:b])

        _in_slices(N, workers, solve)
        self._raise_rejected(targets, info, first_index)
        return q, ok, flags, errors, totals, info

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
        kernels = _kernels()
        q, ok, flags, errors, _, info = self._principal(targets, seeds, tolerance, frames, False,
                                                        0)
        q[~ok] = 0.0
        errors[~ok] = 0.0
        INFO = kernels.INFO
        return BranchSolutions(q=q, valid=ok, flags=np.where(ok, flags, 0).astype(np.uint8),
                               residuals=errors, branch_labels=self.branch_labels,
                               dropped=info[:, INFO.dropped].astype(np.int64))

    def _raise_rejected(self, targets: NDArray[np.float64], info: NDArray[np.float64],
                        start: int) -> None:
        INFO = _kernels().INFO
        bad = np.flatnonzero(info[:, INFO.status])
        if bad.size:
            from dhkin.ik.compiled.pose import STATUS_BAD_SEED

            index = int(bad[0])
            status = int(info[index, INFO.status])
            if status == STATUS_BAD_SEED:
                raise InputError(f"q_seed[{start + index}]: expected finite values",
                                 field="q_seed", index=start + index, expected="finite values")
            raise InputError(pose_error_message(f"T[{start + index}]", targets[index], status),
                             field="T", index=start + index)

    def solve_chunks(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                     tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                     copies: bool = False, chunk_size: int | None = None
                     ) -> Iterator[tuple[int, IKBatch]]:
        """:meth:`solve_batch` chunk by chunk: yields (index of the chunk's first pose, IKBatch
        of its poses). The default chunk holds at most :data:`STREAM_BYTES` of output."""
        tolerance = check_tolerance(tolerance)
        targets, _ = as_targets(T)
        frames = self.frames if tcp is None else self.frames_for(tcp)
        if chunk_size is None:
            per_pose = (self.max_solutions if copies else self.n_branches) * (8 * self.dof + 20)
            chunk_size = int(min(DEFAULT_CHUNK, max(1024, STREAM_BYTES // per_pose)))
        chunk_size = _check_chunk(chunk_size)
        seeds = self._seeds(q_seed, targets.shape[0])
        for start in range(0, targets.shape[0], chunk_size):
            stop = min(start + chunk_size, targets.shape[0])
            part = seeds if seeds.shape[0] == 1 else seeds[start:stop]
            yield start, self._batch(targets[start:stop], part, tolerance, frames, bool(copies),
                                     chunk_size, start)


def default_workers() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def check_workers(workers: Any) -> int:
    """``workers`` as a positive int (None: :func:`default_workers`); IKInputError otherwise."""
    if workers is None:
        return default_workers()
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise InputError(f"workers: expected a positive integer or None (the CPUs this "
                         f"process may use), got {workers!r}", field="workers")
    return int(workers)


def _in_slices(n: int, workers: int, work: Callable[[int, int], None]) -> None:
    """work(a, b) over contiguous slices of range(n), each of at least POSES_PER_WORKER poses,
    SLICES_PER_WORKER per worker thread (poses near singularities or on refined tables take
    longer: small slices keep the threads busy alike); one slice, in this thread, for a small n
    or one worker."""
    threads = max(1, min(workers, n // POSES_PER_WORKER))
    if threads == 1:
        work(0, n)
        return
    slices = max(threads, min(threads * SLICES_PER_WORKER, n // POSES_PER_WORKER))
    bounds = [n * k // slices for k in range(slices + 1)]
    futures = [_pool(threads).submit(work, bounds[k], bounds[k + 1]) for k in range(slices)]
    for future in futures:
        future.result()


_POOL: dict[int, ThreadPoolExecutor] = {}
_POOL_LOCK = threading.Lock()


def _pool(size: int) -> ThreadPoolExecutor:
    """A shared pool of ``size`` threads for batch slices (created on first use)."""
    with _POOL_LOCK:
        if size not in _POOL:
            _POOL[size] = ThreadPoolExecutor(max_workers=size, thread_name_prefix="dhkin-ik")
        return _POOL[size]


def _check_chunk(chunk_size: Any) -> int:
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, (int, np.integer)) \
            or chunk_size < 1:
        raise InputError(field="chunk_size", value=chunk_size, expected="a positive integer")
    return int(chunk_size)

