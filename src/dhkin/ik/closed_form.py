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
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
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


def _dh_target(table: DHTable, T: NDArray[np.float64],
               tcp: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    flange_to_target = table.tool if tcp is None else table.tool @ tcp
    return invert(table.base) @ T @ invert(flange_to_target)


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
    """All 2pi-shifted copies of solutions q (R, n) inside the joint limits.

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


def solve_batch(solver: BranchSolver, table: DHTable, T: ArrayLike, q_seed: ArrayLike | None = None,
                tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None) -> IKBatch:
    """Every solution of N poses within the limits, verified by FK; see the module docstring."""
    targets, _ = as_targets(T)
    n_poses, dof = targets.shape[0], table.dof
    seeds = as_seeds(q_seed, n_poses, dof)
    T_dh = _dh_target(table, targets, _as_tcp(tcp))
    branches = solver.solve(T_dh, seeds)
    n_branches = branches.q.shape[1]

    pose_idx, branch_idx = np.nonzero(branches.valid)
    principal = wrap_revolute(table, branches.q[pose_idx, branch_idx])
    finite = np.all(np.isfinite(principal), axis=1)
    pose_idx, branch_idx, principal = pose_idx[finite], branch_idx[finite], principal[finite]
    exact, _ = _exact(table, principal, T_dh[pose_idx], tolerance)
    pose_idx, branch_idx, principal = pose_idx[exact], branch_idx[exact], principal[exact]

    rows, values = expand_turns(table, principal)
    pose_of, branch_of = pose_idx[rows], branch_idx[rows]
    exact, _ = _exact(table, values, T_dh[pose_of], tolerance)
    pose_of, branch_of, values = pose_of[exact], branch_of[exact], values[exact]

    counts = np.bincount(pose_of, minlength=n_poses)
    width = int(counts.max()) if counts.size and counts.max() > 0 else 0
    slot = np.arange(pose_of.size) - np.repeat(np.cumsum(counts) - counts, counts)
    Q = np.zeros((n_poses, width, dof))
    valid = np.zeros((n_poses, width), bool)
    flags = np.zeros((n_poses, width), np.uint8)
    branch = np.full((n_poses, width), -1, np.int16)
    Q[pose_of, slot] = values
    valid[pose_of, slot] = True
    flags[pose_of, slot] = branches.flags[pose_of, branch_of]
    branch[pose_of, slot] = branch_of
    assert n_branches == len(solver.branch_labels)
    return IKBatch(q=Q, valid=valid, flags=flags, branch=branch,
                   branch_labels=tuple(solver.branch_labels), family=solver.family)


def solve_one(solver: BranchSolver, table: DHTable, T: ArrayLike, q_seed: ArrayLike | None = None,
              tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None) -> IKSolutions:
    """Every solution of one pose (4, 4), with configurations, flags, residuals and a reason."""
    target = np.asarray(T, dtype=float)
    if target.shape != (4, 4):
        raise IKInputError(f"T: expected a (4, 4) pose, got shape {target.shape}")
    batch = solve_batch(solver, table, target[None], None if q_seed is None else
                        np.asarray(q_seed, dtype=float)[None], tolerance, tcp)
    T_dh = _dh_target(table, target[None], _as_tcp(tcp))[0]
    keep = batch.valid[0]
    q = batch.q[0][keep]
    if q.shape[0] == 0:
        reason = solver.explain(T_dh)
        if not reason:
            reason = "no branch solution lies within the joint limits"
        return IKSolutions(q=np.zeros((0, table.dof)), reason=reason, family=solver.family)
    turns = turns_of(table, q)
    configurations = tuple(
        Configuration(labels=dict(batch.branch_labels[b]), turns=tuple(int(t) for t in tr))
        for b, tr in zip(batch.branch[0][keep], turns, strict=True))
    flags = tuple(flag_names(f) for f in batch.flags[0][keep])
    _, residuals = _exact(table, q, np.broadcast_to(T_dh, (q.shape[0], 4, 4)), tolerance)
    return IKSolutions(q=q, configurations=configurations, flags=flags, residuals=residuals,
                       family=solver.family)
