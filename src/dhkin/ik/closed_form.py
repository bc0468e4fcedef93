"""The shared pipeline of the closed-form solvers.

A family solver (spherical wrist, offset wrist, ...) solves for the *DH flange*: the pose of DH
frame n in DH frame 0, one principal solution per branch. This module does the rest, the same way
for every family:

1. target conversion: ``T_dh = base^-1 @ T @ tcp^-1 @ tool^-1`` (T is base_link -> TCP, where
   ``tcp`` is tool0 -> TCP, identity by default: targets may be given for another tool frame);
2. call the family's :meth:`BranchSolver.solve` -> :class:`Branches`;
3. wrap revolute values to (-pi, pi], verify every branch by FK against ``T_dh`` (position and
   rotation tolerance, :data:`DEFAULT_TOLERANCE`) and drop any that is not exact;
4. expand each surviving branch into all its 2pi-shifted copies inside the joint limits (values
   within :data:`LIMIT_TOLERANCE` outside a limit are set onto the limit, then verified again).

How it runs (:class:`Pipeline`): steps 1, 3 and 4 are compiled kernels (:mod:`dhkin.ik.kernels`,
numba), and so is step 2 for a family that provides ``compiled()`` (spherical wrist, Stanford);
other families' numpy ``solve`` runs between the kernels. A 2pi-shifted copy is not verified
again unless it was moved onto a limit or its branch's error is within :data:`COPY_MARGIN` of the
tolerance: the shift changes FK by rounding only (~1e-15 m per m of arm, rad), so every returned
solution still reproduces the target within the tolerance, and the result is that of verifying
every copy. Poses run in chunks of ``chunk_size``; kernels allocate nothing per pose, so memory is
the inputs and outputs (:meth:`Pipeline.solve_chunks` streams a batch chunk by chunk instead).

``copies=False`` returns one solution per branch instead of every copy: the copy with each joint
nearest to 0 (the principal value where it lies within the limits), like the peer libraries that
return principal solutions only.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import threading
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from types import MappingProxyType, ModuleType
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import DHTable
from dhkin.errors import IKInputError
from dhkin.ik.result import Configuration, IKBatch, IKSolutions, flag_names
from dhkin.transforms import invert, pose_error

TWO_PI = 2.0 * np.pi
#: A returned solution reproduces the target to this position (m) and rotation (rad) error.
DEFAULT_TOLERANCE = 1e-9
#: Values this far (rad or m) outside a joint limit count as on the limit.
LIMIT_TOLERANCE = 1e-10
#: A branch whose error is within this of the tolerance has each of its copies verified itself
#: (a 2pi shift changes FK by rounding, ~1e-15 per m of arm: a thousandfold margin up to 10 m).
COPY_MARGIN = 1e-11
#: Poses per kernel call of :meth:`Pipeline.solve_batch` (and at most per chunk of solve_chunks).
DEFAULT_CHUNK = 65536
#: solve_chunks' default chunks hold at most this much output (bytes).
STREAM_BYTES = 64 * 2**20
#: Singularity flag names of each bit mask, shared by every result.
_FLAG_SETS: tuple[frozenset[str], ...] = tuple(flag_names(bits) for bits in range(8))


@dataclass(frozen=True)
class Branches:
    """Principal solutions of N poses on B branches: ``q`` (N, B, n), ``valid`` (N, B) and
    singularity ``flags`` (N, B) as bits of :mod:`dhkin.ik.result`."""

    q: NDArray[np.float64]
    valid: NDArray[np.bool_]
    flags: NDArray[np.uint8]


class BranchSolver(Protocol):
    """What a closed-form family provides."""

    family: str
    #: One label mapping per branch, e.g. {"shoulder": "righty", "elbow": "up", "wrist": "flip"}.
    branch_labels: tuple[Mapping[str, str], ...]

    def solve(self, T_dh: NDArray[np.float64], q_seed: NDArray[np.float64]) -> Branches:
        """Branch solutions for targets ``T_dh`` (N, 4, 4): DH frame 0 -> DH frame n.

        ``q_seed`` (N, n) supplies the free joint at a singularity. Invalid branches (no real
        solution) have ``valid`` False; their ``q`` may hold anything finite.
        """
        ...

    def explain(self, T_dh: NDArray[np.float64]) -> str:
        """Why one target (4, 4) has no solution, in words and numbers, e.g. "wrist centre
        0.83 m from the shoulder, reach 0.70 m". Empty when the geometry has solutions (then
        the joint limits exclude all of them)."""
        ...

    # Optional: ``compiled() -> (family id, geometry vector)`` selects a compiled solver of
    # dhkin.ik.kernels that gives the same branches as ``solve``.


def as_targets(T: ArrayLike) -> tuple[NDArray[np.float64], bool]:
    """Validate poses: (4, 4) or (N, 4, 4), finite, proper rotation. Returns (N, 4, 4), single."""
    targets = np.asarray(T, dtype=float)
    single = targets.ndim == 2
    if single:
        targets = targets[None]
    if targets.ndim != 3 or targets.shape[1:] != (4, 4):
        raise IKInputError(f"T: expected a (4, 4) pose or (N, 4, 4) poses, got {np.shape(T)}")
    if not np.all(np.isfinite(targets)):
        raise IKInputError("T: expected finite numbers, got NaN or inf")
    R = targets[:, :3, :3]
    orthogonality = np.abs(R @ np.swapaxes(R, 1, 2) - np.eye(3)).max(axis=(1, 2))
    bad = np.flatnonzero((orthogonality > 1e-6) | (np.linalg.det(R) < 0))
    if bad.size:
        raise IKInputError(f"T[{bad[0]}]: rotation block is not a rotation matrix "
                           f"(|R R^T - I| = {orthogonality[bad[0]]:.2e}, expected <= 1e-6)")
    return targets, single


def as_seeds(q_seed: ArrayLike | None, n_poses: int, dof: int) -> NDArray[np.float64]:
    """Seeds broadcast to (N, n); None -> zeros."""
    if q_seed is None:
        return np.zeros((n_poses, dof))
    seeds = np.asarray(q_seed, dtype=float)
    if seeds.shape == (dof,):
        seeds = np.broadcast_to(seeds, (n_poses, dof))
    if seeds.shape != (n_poses, dof) or not np.all(np.isfinite(seeds)):
        raise IKInputError(f"q_seed: expected finite values of shape ({dof},) or "
                           f"({n_poses}, {dof}), got {np.shape(q_seed)}")
    return np.array(seeds)


def wrap_revolute(table: DHTable, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Revolute joint values wrapped to (-pi, pi]; prismatic values unchanged."""
    revolute = np.array([j.is_revolute for j in table.joints])
    wrapped = np.pi - np.mod(np.pi - q, TWO_PI)
    return np.where(revolute, wrapped, q)


def _as_tcp(tcp: ArrayLike | None) -> NDArray[np.float64] | None:
    if tcp is None:
        return None
    frame = np.asarray(tcp, dtype=float)
    if frame.shape != (4, 4) or not np.all(np.isfinite(frame)):
        raise IKInputError(f"tcp: expected a finite (4, 4) transform tool0 -> TCP, "
                           f"got shape {frame.shape}")
    return frame


def _dh_fk(table: DHTable, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """DH frame 0 -> DH frame n for q (M, n).

    The product of ``table.link_transforms(q)``, evaluated factor by factor on the rotation's
    columns x, y, z and the origin p with elementwise operations instead of (M, 4, 4) matrix
    products: this check runs on every 2pi copy (up to 512 per pose on a +-360 deg arm).
    """
    theta, d = table.dh_parameters(q)
    cos_theta, sin_theta = np.cos(theta), np.sin(theta)
    x, y, z = (np.broadcast_to(np.eye(3)[k], (q.shape[0], 3)) for k in range(3))
    p = np.zeros((q.shape[0], 3))
    for i, joint in enumerate(table.joints):
        c, s = cos_theta[:, i, None], sin_theta[:, i, None]
        ca, sa = np.cos(joint.alpha), np.sin(joint.alpha)
        if table.convention == "standard":  # Rz(theta) Tz(d) Tx(a) Rx(alpha)
            x, y = c * x + s * y, c * y - s * x
            p = p + d[:, i, None] * z + joint.a * x
            y, z = ca * y + sa * z, ca * z - sa * y
        else:  # modified: Rx(alpha) Tx(a) Rz(theta) Tz(d)
            y, z = ca * y + sa * z, ca * z - sa * y
            p = p + joint.a * x
            x, y = c * x + s * y, c * y - s * x
            p = p + d[:, i, None] * z
    T = np.zeros((q.shape[0], 4, 4))
    T[:, :3, 0], T[:, :3, 1], T[:, :3, 2], T[:, :3, 3] = x, y, z, p
    T[:, 3, 3] = 1.0
    return T


def _exact(table: DHTable, q: NDArray[np.float64], T_dh: NDArray[np.float64],
           tolerance: float) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Which rows of q (M, n) reach T_dh (M, 4, 4), and their (position, rotation) errors."""
    if q.shape[0] == 0:
        return np.zeros(0, bool), np.zeros((0, 2))
    position, rotation = pose_error(_dh_fk(table, q), T_dh)
    ok = (position <= tolerance) & (rotation <= tolerance)
    return ok, np.stack([position, rotation], axis=1)


def expand_turns(table: DHTable, q: NDArray[np.float64]) -> tuple[NDArray[np.int64],
                                                                   NDArray[np.float64]]:
    """All 2pi-shifted copies of solutions q (R, n) inside the joint limits (numpy; the kernels
    expand the same way, in the same order: tests/test_ik_batch.py compares them).

    Returns (row index into q (M,), values (M, n)). Prismatic joints have no copies. Values
    within LIMIT_TOLERANCE outside a limit are put on it.
    """
    lower, upper = table.lower, table.upper
    revolute = np.array([j.is_revolute for j in table.joints])
    lo = np.ceil((lower - LIMIT_TOLERANCE - q) / TWO_PI)
    hi = np.floor((upper + LIMIT_TOLERANCE - q) / TWO_PI)
    lo = np.where(revolute, lo, 0.0)
    hi = np.where(revolute, hi, 0.0)
    inside_prismatic = (q >= lower - LIMIT_TOLERANCE) & (q <= upper + LIMIT_TOLERANCE)
    counts = np.where(revolute, hi - lo + 1, inside_prismatic.astype(float)).astype(np.int64)
    counts = np.maximum(counts, 0)
    totals = np.prod(counts, axis=1)
    rows = np.repeat(np.arange(q.shape[0]), totals)
    if rows.size == 0:
        return rows, np.zeros((0, q.shape[1]))
    starts = np.cumsum(totals) - totals
    index_in_row = np.arange(rows.size) - np.repeat(starts, totals)
    # mixed-radix digits of index_in_row, last joint fastest
    radix = counts[rows]
    place = np.cumprod(radix[:, ::-1], axis=1)[:, ::-1]
    place = np.concatenate([place[:, 1:], np.ones((rows.size, 1), np.int64)], axis=1)
    digits = (index_in_row[:, None] // place) % np.maximum(radix, 1)
    values = q[rows] + TWO_PI * (lo[rows] + digits)
    values = np.clip(values, lower, upper)
    return rows, values


def turns_of(table: DHTable, q: NDArray[np.float64]) -> NDArray[np.int64]:
    """round(q / 2pi) for revolute joints, 0 for prismatic ones; shape of q."""
    revolute = np.array([j.is_revolute for j in table.joints])
    return np.where(revolute, np.round(q / TWO_PI), 0).astype(np.int64)



def _kernels() -> ModuleType:
    """dhkin.ik.kernels, imported on first use (importing numba takes ~0.5 s)."""
    from dhkin.ik import kernels

    return kernels


def _input_error(targets: NDArray[np.float64], index: int, status: int) -> IKInputError:
    """The error :func:`as_targets` raises for pose ``index`` (status from the kernels)."""
    kernels = _kernels()
    if status == kernels.STATUS_NOT_FINITE:
        return IKInputError("T: expected finite numbers, got NaN or inf")
    R = np.asarray(targets[index], dtype=float)[:3, :3]
    orthogonality = float(np.abs(R @ R.T - np.eye(3)).max())
    return IKInputError(f"T[{index}]: rotation block is not a rotation matrix "
                        f"(|R R^T - I| = {orthogonality:.2e}, expected <= 1e-6)")


def solve_compiled(solver: BranchSolver, T_dh: ArrayLike, q_seed: ArrayLike) -> Branches:
    """:meth:`BranchSolver.solve` by the solver's compiled twin (``solver.compiled()``):
    principal solutions of DH targets (N, 4, 4) with seeds (N, n)."""
    kernels = _kernels()
    family_id, geometry = solver.compiled()  # type: ignore[attr-defined]
    targets = np.ascontiguousarray(T_dh, dtype=np.float64)
    seeds = np.ascontiguousarray(q_seed, dtype=np.float64)
    if targets.ndim != 3 or targets.shape[1:] != (4, 4):
        raise IKInputError(f"T_dh: expected (N, 4, 4) targets, got {targets.shape}")
    n_poses, n_branches = targets.shape[0], len(solver.branch_labels)
    dof = seeds.shape[-1]
    if seeds.shape != (n_poses, dof):
        raise IKInputError(f"q_seed: expected shape ({n_poses}, n), got {seeds.shape}")
    q = np.empty((n_poses, n_branches, dof))
    valid = np.empty((n_poses, n_branches), bool)
    flags = np.zeros((n_poses, n_branches), np.uint8)
    kernels.solve_branches(family_id, geometry, targets, seeds, q, valid, flags)
    return Branches(q=q, valid=valid, flags=flags)


class CompiledSolver:
    """Base of a family solver with a compiled twin in :mod:`dhkin.ik.kernels`: the subclass
    sets ``_compiled`` = (family id, geometry vector) and provides ``solve_reference``, the
    vectorised numpy formulation the kernel ports step by step (tests compare the two)."""

    _compiled: tuple[int, NDArray[np.float64]]

    def compiled(self) -> tuple[int, NDArray[np.float64]]:
        """Family id and geometry vector of the compiled solver (dhkin.ik.kernels)."""
        return self._compiled

    def solve(self, T_dh: NDArray[np.float64], q_seed: NDArray[np.float64]) -> Branches:
        """Principal solutions (N, B, n) of flange targets T_dh (N, 4, 4), DH frame 0 -> n,
        computed by the compiled twin of ``solve_reference``."""
        return solve_compiled(self, T_dh, q_seed)


class Pipeline:
    """The pipeline of one family solver and table, with the constants of the compiled kernels
    built once (a :class:`~dhkin.robot.Robot` keeps one).

    :meth:`solve_batch`, :meth:`solve_chunks` and :meth:`solve_one` give the results of the
    module docstring; they are safe to call from several threads (the kernels release the GIL).
    """

    def __init__(self, solver: BranchSolver, table: DHTable) -> None:
        kernels = _kernels()
        self.solver, self.table, self.kernels = solver, table, kernels
        self.dof = table.dof
        self.n_branches = len(solver.branch_labels)
        joints = table.joints
        self.chain = kernels.chain_array(
            np.array([j.a for j in joints]), np.array([j.alpha for j in joints]),
            np.array([j.d for j in joints]), np.array([j.theta for j in joints]),
            np.array([j.direction for j in joints], dtype=float),
            np.array([j.offset for j in joints]), np.array([j.is_revolute for j in joints]))
        self.modified = table.convention == "modified"
        self.limits = np.ascontiguousarray(np.stack([table.lower, table.upper], axis=1))
        self._base_inverse = invert(table.base)
        self.frames = self.frames_for(None)
        compiled = getattr(solver, "compiled", None)
        if callable(compiled):
            family_id, geometry = compiled()
        else:
            family_id, geometry = kernels.NO_KERNEL, np.zeros(1)
        self.family_id = int(family_id)
        self.geometry = np.ascontiguousarray(geometry, dtype=np.float64)
        spans = table.upper - table.lower + 2 * LIMIT_TOLERANCE
        per_joint = np.where([j.is_revolute for j in joints], np.floor(spans / TWO_PI) + 1, 1)
        #: Most solutions one pose can have (every branch with every copy).
        self.max_solutions = int(self.n_branches * np.prod(per_joint))
        self._zero_seed = np.zeros(self.dof)
        self._labels = tuple(MappingProxyType(dict(labels)) for labels in solver.branch_labels)
        self._configurations: dict[int, Configuration] = {}
        self._descriptions: dict[bytes, tuple[tuple[Configuration, ...],
                                              tuple[frozenset[str], ...]]] = {}
        self._configuration_by_key: dict[int, Configuration] = {}
        self._tolerances: dict[float, NDArray[np.float64]] = {}
        self._buffers = threading.local()
        self.family = solver.family
        #: The packed constants of kernels.solve_one (None without a compiled family solver).
        self.plan = None if family_id == kernels.NO_KERNEL else kernels.plan_array(
            family_id, self.modified, self.n_branches, self.geometry, self.chain, self.limits)

    @property
    def compiled(self) -> bool:
        """Whether the family's solver itself is compiled (else its numpy ``solve`` runs)."""
        return self.family_id != self.kernels.NO_KERNEL

    # ---------------------------------------------------------------------------------------
    # Per-call constants

    def frames_for(self, tcp: ArrayLike | None) -> NDArray[np.float64]:
        """(2, 4, 4): base^-1 and (tool @ tcp)^-1 (see kernels)."""
        frame = _as_tcp(tcp)
        flange_to_target = self.table.tool if frame is None else self.table.tool @ frame
        return np.ascontiguousarray(np.stack([self._base_inverse, invert(flange_to_target)]))

    def tolerances(self, tolerance: float) -> NDArray[np.float64]:
        """The kernels' tolerance vector for ``tolerance`` (cached per value)."""
        found = self._tolerances.get(tolerance)
        if found is None:
            def tangent(angle: float) -> float:
                return math.tan(angle) if 0.0 <= angle < 0.5 * math.pi else math.nan

            tol = float(tolerance)
            found = np.array([tol, tangent(tol), tol - COPY_MARGIN, tangent(tol - COPY_MARGIN),
                              LIMIT_TOLERANCE])
            if len(self._tolerances) < 64:
                self._tolerances[tolerance] = found
        return found

    def _seeds(self, q_seed: ArrayLike | None, n_poses: int) -> NDArray[np.float64]:
        """Seeds as (1, n) (one for all poses) or (N, n); as_seeds' checks and errors."""
        if q_seed is None:
            return self._zero_seed[None]
        seeds = np.asarray(q_seed, dtype=float)
        if seeds.shape == (self.dof,) and np.all(np.isfinite(seeds)):
            return np.ascontiguousarray(seeds[None])
        return np.ascontiguousarray(as_seeds(seeds, n_poses, self.dof))

    # ---------------------------------------------------------------------------------------
    # Batches

    def solve_batch(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                    tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                    copies: bool = True, chunk_size: int = DEFAULT_CHUNK) -> IKBatch:
        """Every solution of N poses (N, 4, 4) within the limits (one per branch with
        ``copies=False``), verified by FK; rows padded to the largest count.

        Memory: the input and the output, plus per pose 8 (B + 1) bytes of counts with
        ``copies=True`` and per chunk a few arrays of chunk_size x B. With ``copies=False`` the
        output is written in place of the principal solutions (its rows may then be a view
        of B-wide arrays)."""
        targets = self._targets(T, chunk_size)
        n_poses, dof, n_branches = targets.shape[0], self.dof, self.n_branches
        seeds = self._seeds(q_seed, n_poses)
        frames = self.frames_for(tcp) if tcp is not None else self.frames
        tolerances = self.tolerances(tolerance)
        q = np.empty((n_poses, n_branches, dof))
        ok = np.empty((n_poses, n_branches), bool)
        flags = np.zeros((n_poses, n_branches), np.uint8)
        chunks = [(start, min(start + chunk_size, n_poses))
                  for start in range(0, n_poses, chunk_size)]
        if copies:  # every principal solution first: the output's width is the largest count
            recheck = np.empty((n_poses, n_branches), bool)
            totals = np.empty((n_poses, n_branches), np.int64)
            for start, stop in chunks:
                self._principal(targets, start, stop, seeds, frames, tolerances,
                                q[start:stop], ok[start:stop], flags[start:stop],
                                recheck[start:stop], totals[start:stop])
            width = int(np.where(ok, totals, 0).sum(axis=1).max()) if n_poses else 0
            out_q = np.empty((n_poses, width, dof))
            out_valid = np.empty((n_poses, width), bool)
            out_flags = np.empty((n_poses, width), np.uint8)
        else:  # one row per branch at most: each chunk is expanded over its own principal rows
            width = n_branches
            out_q, out_valid, out_flags = q, ok, flags
        out_branch = np.empty((n_poses, width), np.int16)
        widest = 0
        for start, stop in chunks:
            rows = slice(start, stop)
            if not copies:
                recheck = np.empty((stop - start, n_branches), bool)
                totals = np.empty((stop - start, n_branches), np.int64)
                self._principal(targets, start, stop, seeds, frames, tolerances, q[rows],
                                ok[rows], flags[rows], recheck, totals)
            chunk_rows = slice(0, stop - start) if not copies else rows
            used = self.kernels.expand(
                self.chain, self.modified, self.limits, frames,
                np.ascontiguousarray(targets[rows], dtype=np.float64), tolerances, copies,
                q[rows], ok[rows], flags[rows], recheck[chunk_rows], totals[chunk_rows],
                out_q[rows], out_valid[rows], out_flags[rows], out_branch[rows], not copies)
            if used < 0:  # cannot happen: width counts every copy
                raise RuntimeError("IK expansion: more solutions than counted")
            widest = max(widest, used)
        if widest < width:
            out_q, out_valid = out_q[:, :widest], out_valid[:, :widest]
            out_flags, out_branch = out_flags[:, :widest], out_branch[:, :widest]
        return IKBatch(q=out_q, valid=out_valid, flags=out_flags, branch=out_branch,
                       branch_labels=tuple(self.solver.branch_labels), family=self.family)

    @staticmethod
    def _targets(T: ArrayLike, chunk_size: int) -> NDArray[np.float64]:
        """Poses as (N, 4, 4) (a single (4, 4) pose is N = 1), without a copy where possible."""
        targets = np.asarray(T)
        if targets.shape == (4, 4):
            targets = targets[None]
        if targets.ndim != 3 or targets.shape[1:] != (4, 4):
            raise IKInputError(f"T: expected a (4, 4) pose or (N, 4, 4) poses, got {np.shape(T)}")
        if not np.issubdtype(targets.dtype, np.number) or np.iscomplexobj(targets):
            raise IKInputError(f"T: expected real numbers, got dtype {targets.dtype}")
        if chunk_size < 1:
            raise IKInputError(f"chunk_size: expected a positive number, got {chunk_size}")
        return targets

    def solve_chunks(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                     tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                     copies: bool = True,
                     chunk_size: int | None = None) -> Iterator[tuple[int, IKBatch]]:
        """:meth:`solve_batch` chunk by chunk: yields (index of the chunk's first pose, its
        IKBatch); each chunk is padded to its own largest count. Only one chunk's results are
        held at a time, so any number of poses (and UR's 256 and more copies each) fits. The
        default chunk_size holds :data:`STREAM_BYTES` of output at the most solutions a pose
        of this robot can have (:attr:`max_solutions`, or B with ``copies=False``)."""
        if chunk_size is None:
            per_pose = (self.max_solutions if copies else self.n_branches) * (8 * self.dof + 4)
            chunk_size = int(min(DEFAULT_CHUNK, max(1024, STREAM_BYTES // per_pose)))
        targets = self._targets(T, chunk_size)
        seeds = self._seeds(q_seed, targets.shape[0])
        for start in range(0, targets.shape[0], chunk_size):
            stop = min(start + chunk_size, targets.shape[0])
            chunk_seeds = seeds[0] if seeds.shape[0] == 1 else seeds[start:stop]
            try:
                batch = self.solve_batch(targets[start:stop], chunk_seeds, tolerance, tcp,
                                         copies, chunk_size)
            except IKInputError as error:
                raise _shift_index(error, start) from None
            yield start, batch

    def _principal(self, targets: NDArray[np.float64], start: int, stop: int,
                   seeds: NDArray[np.float64], frames: NDArray[np.float64],
                   tolerances: NDArray[np.float64], q: NDArray[np.float64],
                   ok: NDArray[np.bool_], flags: NDArray[np.uint8],
                   recheck: NDArray[np.bool_], totals: NDArray[np.int64]) -> None:
        """Steps 1-3 for poses start:stop into the given slices of the principal arrays."""
        kernels = self.kernels
        chunk = np.ascontiguousarray(targets[start:stop], dtype=np.float64)
        chunk_seeds = seeds if seeds.shape[0] == 1 else seeds[start:stop]
        status = np.empty(stop - start, np.int8)
        if self.compiled:
            kernels.solve_principal(self.family_id, self.geometry, self.chain, self.modified,
                                    self.limits, frames, chunk, chunk_seeds, tolerances, q, ok,
                                    flags, recheck, totals, status)
        else:
            kernels.check_targets(chunk, status)
        bad = np.flatnonzero(status)
        if bad.size:
            raise _input_error(targets, start + int(bad[0]), int(status[bad[0]]))
        if self.compiled:
            return
        T_dh = frames[0] @ chunk @ frames[1]
        branches = self.solver.solve(T_dh, np.array(np.broadcast_to(chunk_seeds,
                                                                    (stop - start, self.dof))))
        q[:] = branches.q
        flags[:] = branches.flags
        kernels.finish_principal(self.chain, self.modified, self.limits,
                                 np.ascontiguousarray(T_dh), tolerances, q,
                                 np.ascontiguousarray(branches.valid, dtype=bool), ok, recheck,
                                 totals)

    # ---------------------------------------------------------------------------------------
    # One pose

    def solve_one(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                  tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                  copies: bool = True) -> IKSolutions:
        """Every solution of one pose (4, 4), with configurations, flags, residuals and, when
        there is none, the reason. One kernel call, made through its compiled entry point
        (:meth:`_one_kernel`); buffers are kept per thread."""
        target = np.ascontiguousarray(T, dtype=np.float64)
        if target.shape != (4, 4):
            raise IKInputError(f"T: expected a (4, 4) pose, got shape {np.shape(T)}")
        if self.plan is None:
            return self._solve_one_numpy(target, q_seed, tolerance, tcp, copies)
        if q_seed is None:
            seed = self._zero_seed
        else:
            seed = np.ascontiguousarray(q_seed, dtype=np.float64)
            if seed.shape != (self.dof,):
                raise IKInputError(f"q_seed: expected shape ({self.dof},) for one pose, got "
                                   f"{np.shape(q_seed)}")
        tolerances = self._tolerances.get(tolerance)
        if tolerances is None:
            tolerances = self.tolerances(tolerance)
        try:
            shared_q, shared_errors, out_keys, scratch = self._buffers.arrays
        except AttributeError:  # first call in this thread
            shared_q, shared_errors, out_keys, scratch = self._one_buffers()
        if copies:  # up to max_solutions rows: into this thread's buffers, then copied out
            out_q, out_errors = shared_q, shared_errors
        else:  # at most one row per branch: new arrays that the result keeps (no copy)
            out_q = np.empty((self.n_branches, self.dof))
            out_errors = np.empty((self.n_branches, 2))
        # Every argument has the exact type the entry point was compiled for: C-contiguous
        # float64 arrays of the right dimensions (target and seed just above), a bool.
        count = self._one_kernel(self.plan, self.frames if tcp is None else self.frames_for(tcp),
                                 target, seed, tolerances, bool(copies), out_q,
                                 out_errors, out_keys, scratch)
        if count <= 0:
            return self._no_solution(count, target, seed, tcp)
        keys = out_keys[:count]
        described = self._descriptions.get(keys.tobytes())
        if copies:
            q, residuals = out_q[:count].copy(), out_errors[:count].copy()
        elif count < self.n_branches:
            q, residuals = out_q[:count], out_errors[:count]
        else:
            q, residuals = out_q, out_errors
        if described is None:
            described = self._describe(keys, q)
        return _solutions(q, described[0], described[1], residuals, self.family)

    def _one_buffers(self) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                    NDArray[np.int64], NDArray[np.float64]]:
        """This thread's output and scratch arrays of kernels.solve_one."""
        arrays = (np.empty((self.max_solutions, self.dof)), np.empty((self.max_solutions, 2)),
                  np.empty(self.max_solutions, np.int64),
                  np.empty(self.kernels.one_scratch_size(self.dof, self.n_branches)))
        self._buffers.arrays = arrays
        return arrays

    @functools.cached_property
    def _one_kernel(self) -> Callable[..., int]:
        """kernels.solve_one's compiled entry point for this pipeline's argument types.

        Calling a numba dispatcher resolves the type of every argument first: with solve_one's
        ten arguments that is about 1 us, a sixth of a single-pose solve. The entry point skips
        it, so it must only get arguments of the types it was compiled for (solve_one makes
        sure). Compiles (or loads from the cache) by one call on the identity pose. Where numba
        does not expose the entry point, the dispatcher is used."""
        kernel = self.kernels.solve_one
        args = (self.plan, self.frames, np.eye(4), self._zero_seed,
                self.tolerances(DEFAULT_TOLERANCE), True, *self._one_buffers())
        kernel(*args)
        try:
            from numba import typeof

            return kernel.overloads[tuple(typeof(arg) for arg in args)].entry_point
        except (AttributeError, KeyError, TypeError):  # another numba: the plain dispatcher
            return kernel

    def _describe(self, keys: NDArray[np.int64], q: NDArray[np.float64]
                  ) -> tuple[tuple[Configuration, ...], tuple[frozenset[str], ...]]:
        """Configurations and flags of solutions from solve_one's keys (see kernels.solve_one),
        from per-key caches; short key sequences are remembered whole. The caches are emptied
        when they grow past 2^16 entries."""
        listed = keys.tolist()
        try:
            configurations = tuple(map(self._configuration_by_key.__getitem__, listed))
        except KeyError:
            configurations = tuple(self._remember_key(key, q[k]) for k, key in enumerate(listed))
        flags = tuple(map(_FLAG_SETS.__getitem__, (keys & 7).tolist()))
        if len(listed) <= 64 and min(listed) >= 0:
            if len(self._descriptions) >= 65536:
                self._descriptions.clear()
            self._descriptions[keys.tobytes()] = configurations, flags
        return configurations, flags

    def _remember_key(self, key: int, q: NDArray[np.float64]) -> Configuration:
        """The Configuration of one solve_one key, cached by key where its code fits."""
        found = self._configuration_by_key.get(key)
        if found is None:
            code = key >> 3
            branch = code % self.n_branches if code >= 0 else code + self.n_branches
            found = self._configuration(code, branch, q)
            if code >= 0:  # else turns too large to encode: not cacheable
                if len(self._configuration_by_key) >= 65536:
                    self._configuration_by_key.clear()
                self._configuration_by_key[key] = found
        return found

    def _no_solution(self, count: int, target: NDArray[np.float64], seed: NDArray[np.float64],
                     tcp: ArrayLike | None) -> IKSolutions:
        """solve_one's answer for a kernel count <= 0: an input error, or no solution."""
        kernels = self.kernels
        if count == -kernels.STATUS_BAD_SEED:
            raise IKInputError(f"q_seed: expected finite values, got {seed.tolist()}")
        if count == kernels.NEEDS_MORE_ROWS:  # cannot happen: max_solutions counts every copy
            raise RuntimeError("IK expansion: more solutions than counted")
        if count < 0:
            raise _input_error(target[None], 0, -count)
        frames = self.frames if tcp is None else self.frames_for(tcp)
        reason = self.solver.explain(frames[0] @ target @ frames[1])
        return IKSolutions(q=np.zeros((0, self.dof)), family=self.family,
                           reason=reason or "no branch solution lies within the joint limits")

    def _configuration(self, code: int, branch: int, q: NDArray[np.float64]) -> Configuration:
        """The (shared, read-only) Configuration of a branch and turns; cached by code (-1: a
        turn too large to encode; the branch then comes from the caller)."""
        found = self._configurations.get(code) if code >= 0 else None
        if found is None:
            turns = tuple(int(t) for t in turns_of(self.table, q[None])[0])
            found = Configuration(labels=self._labels[branch], turns=turns)
            if code >= 0:
                self._configurations[code] = found
        return found

    def _solve_one_numpy(self, target: NDArray[np.float64], q_seed: ArrayLike | None,
                         tolerance: float, tcp: ArrayLike | None, copies: bool) -> IKSolutions:
        """solve_one for a family without a compiled solver: the batch path with N = 1."""
        seeds = None if q_seed is None else np.asarray(q_seed, dtype=float)[None]
        batch = self.solve_batch(target[None], seeds, tolerance, tcp, copies)
        keep = batch.valid[0]
        q = batch.q[0][keep]
        frames = self.frames if tcp is None else self.frames_for(tcp)
        T_dh = frames[0] @ target @ frames[1]
        if q.shape[0] == 0:
            reason = self.solver.explain(T_dh) or "no branch solution lies within the joint limits"
            return IKSolutions(q=np.zeros((0, self.dof)), reason=reason, family=self.solver.family)
        configurations = tuple(
            Configuration(labels=self._labels[b], turns=tuple(int(t) for t in turns))
            for b, turns in zip(batch.branch[0][keep], turns_of(self.table, q), strict=True))
        _, residuals = _exact(self.table, q, np.broadcast_to(T_dh, (q.shape[0], 4, 4)),
                              tolerance)
        return IKSolutions(q=q, configurations=configurations,
                           flags=tuple(_FLAG_SETS[int(f)] for f in batch.flags[0][keep]),
                           residuals=residuals, family=self.solver.family)


def _plain_dataclass(cls: type) -> bool:
    """Whether instances of the dataclass ``cls`` are plain __dict__ objects whose __init__ only
    stores its fields (so that filling __dict__ directly gives the same object)."""
    return (not hasattr(cls, "__post_init__") and not hasattr(cls, "__slots__")
            and all(f.init for f in dataclasses.fields(cls)))


#: Fields of IKSolutions a successful solve_one leaves at their class-level defaults.
_DEFAULTED = {"reason": "", "numerical": False}
_FAST_SOLUTIONS = _plain_dataclass(IKSolutions) and all(
    getattr(IKSolutions, name, None) == value for name, value in _DEFAULTED.items())


def _solutions(q: NDArray[np.float64], configurations: tuple[Configuration, ...],
               flags: tuple[frozenset[str], ...], residuals: NDArray[np.float64],
               family: str) -> IKSolutions:
    """IKSolutions of a successful solve_one, built without the frozen dataclass's field by
    field __init__ where that is equivalent (it is a third of the single-pose overhead): the
    fields with a class-level default equal to the value here (reason "", numerical False)
    are read from the class, as attributes of any dataclass with defaults are."""
    if not _FAST_SOLUTIONS:
        return IKSolutions(q=q, configurations=configurations, flags=flags, residuals=residuals,
                           family=family)
    result = object.__new__(IKSolutions)
    fields = result.__dict__
    fields["q"] = q
    fields["configurations"] = configurations
    fields["flags"] = flags
    fields["residuals"] = residuals
    fields["family"] = family
    return result


def _shift_index(error: IKInputError, start: int) -> IKInputError:
    """An IKInputError about pose T[i] of a chunk, renumbered to T[start + i] of the batch."""
    message = str(error)
    if start and message.startswith("T["):
        index, rest = message[2:].split("]", 1)
        if index.isdigit():
            return IKInputError(f"T[{int(index) + start}]{rest}")
    return error


def solve_batch(solver: BranchSolver, table: DHTable, T: ArrayLike, q_seed: ArrayLike | None = None,
                tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                copies: bool = True, chunk_size: int = DEFAULT_CHUNK) -> IKBatch:
    """Every solution of N poses within the limits, verified by FK; see the module docstring.
    (Builds a :class:`Pipeline` per call: keep one to solve repeatedly.)"""
    return Pipeline(solver, table).solve_batch(T, q_seed, tolerance, tcp, copies, chunk_size)


def solve_one(solver: BranchSolver, table: DHTable, T: ArrayLike, q_seed: ArrayLike | None = None,
              tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
              copies: bool = True) -> IKSolutions:
    """Every solution of one pose (4, 4), with configurations, flags, residuals and a reason.
    (Builds a :class:`Pipeline` per call: keep one to solve repeatedly.)"""
    return Pipeline(solver, table).solve_one(T, q_seed, tolerance, tcp, copies)
