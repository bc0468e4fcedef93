"""Manipulability maps with singular loci: a workspace slice and joint-space slices, as PNG.

The measure drawn is the Yoshikawa manipulability sqrt(det(J J^T)) = |det J| (m^3: three
columns' linear parts carry metres) of the 6x6 Jacobian, computed from the analytic factorization
of :mod:`dhkin.singularity` (equal to Pinocchio's det J to 1e-9 relative, see the tests).

**Workspace slice**: tool0 positions on a plane of base_link ("xz": y = offset, "yz": x = offset,
"xy": z = offset) at one fixed tool0 orientation (URDF rpy). Each cell is solved by the
closed-form IK; the cell's value is the best |det J| over the distinct IK branches that have a
copy within the joint limits (2pi copies have the same kinematics), NaN (blank) when none has.
Singular loci, per kind:

* inside the reachable region, a cell is on a locus when, along x or along z, one IK branch's
  signed factor changes sign towards a neighbour, or its distance (|factor|) has a V-shaped
  minimum there (``d_i <= min(d_left, d_right)`` and ``d_i <= (d_left + d_right) / 4``: true
  when the zero lies within the cell; a smooth minimum passes only if it dips within the
  curvature of one cell), or, where the branch ends at the cell because two branches merge at
  the singularity and the solution carries on under the other label, its one-sided straight
  extrapolation reaches zero within the cell (``d_side >= 3 d_i``). Branch labels follow the
  sign of the factors, so the sign test alone would miss most loci (see ``_locus_cells``);
* on the boundary of the reachable region, the boundary point between a reachable cell and an
  unreachable neighbour is found by bisection (:data:`BOUNDARY_BISECTIONS` steps) and the cell
  is on a locus of each kind whose distance there is within the report's default threshold: the
  arm stretched or folded (elbow), the wrist point on the cylinder of the lateral offset around
  axis 1 (shoulder, offset wrist). Boundary parts set by joint limits are left unmarked. A
  locus running inside a boundary cell (where the interior test lacks a neighbour) is found on
  a finely sampled segment through the cell to the boundary point.

**Joint-space slices**: two joints varied over their limits, the others fixed; |det J| on the
grid, and the zero sets of the signed factors (exact curves: the factors are smooth in q), the
cells through which they pass marked as loci.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import DHTable
from dhkin.errors import InputError
from dhkin.singularity import (
    DEFAULT_THRESHOLDS,
    KINDS,
    SingularityModel,
    singularity_model,
)
from dhkin.transforms import xyz_rpy_to_matrix

if TYPE_CHECKING:
    from dhkin.arm import Arm

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]

PLANES: dict[str, tuple[int, int, int]] = {"xz": (0, 2, 1), "yz": (1, 2, 0), "xy": (0, 1, 2)}
AXIS_NAMES = "xyz"
#: Default tool0 orientation (URDF rpy, rad) of the workspace slice, per family, chosen so that
#: the x-z slice crosses wrist singular loci. Spherical wrist: tool0 z along +x, in the slice
#: (singular where the forearm, axis 4, is horizontal). Offset wrist: axis 4 stays parallel to
#: axis 2, i.e. horizontal and across the arm, so the wrist is singular only with a horizontal
#: tool axis across the arm: tool0 z horizontal at 45 deg to the slice (loci: vertical lines).
DEFAULT_RPY: dict[str, tuple[float, float, float]] = {
    "spherical_wrist": (0.0, math.pi / 2, 0.0),
    "stanford": (0.0, math.pi / 2, 0.0),
    "offset_wrist": (0.0, math.pi / 2, math.pi / 4),
}
DEFAULT_RESOLUTION = 161
DEFAULT_JOINT_RESOLUTION = 181
#: Bisection steps that locate the workspace boundary between two cells (2^-24 of a cell).
BOUNDARY_BISECTIONS = 24
#: Samples on the segment through a boundary cell searched for zeros (about 8 per cell).
SEGMENT_SAMPLES = 17
#: Poses per IK batch (memory: the batch holds every 2pi copy before it is reduced).
CHUNK = 2000
#: Figure size (inches) and resolution: the PNG is FIGURE_SIZE * DPI pixels.
FIGURE_SIZE = (18.0, 6.4)
DPI = 100
KIND_STYLE: dict[str, dict[str, str]] = {
    "wrist": {"color": "#e41a1c", "marker": "o", "label": "wrist singular"},
    "elbow": {"color": "#00e5ff", "marker": "s", "label": "elbow singular (stretched/folded)"},
    "shoulder": {"color": "#ff8c00", "marker": "D", "label": "shoulder singular"},
}
MEASURE_LABEL = "Yoshikawa manipulability |det J| (m$^3$)"


# --------------------------------------------------------------------------------------------
# IK over distinct branches


def principal_table(table: DHTable) -> DHTable:
    """The same table with every revolute joint limited to [-pi, pi]: IK then returns one copy
    per branch instead of every 2pi copy within the real limits."""
    joints = tuple(dataclasses.replace(j, lower=-math.pi, upper=math.pi) if j.is_revolute else j
                   for j in table.joints)
    return dataclasses.replace(table, joints=joints)


def has_copy_within_limits(table: DHTable, q: Array) -> Mask:
    """Whether some 2pi-shifted copy of each q (..., n) lies within the table's limits."""
    lower, upper = table.lower, table.upper
    revolute = np.array([j.is_revolute for j in table.joints])
    two_pi = 2.0 * math.pi
    first = np.ceil((lower - 1e-10 - q) / two_pi)
    last = np.floor((upper + 1e-10 - q) / two_pi)
    inside = np.where(revolute, first <= last, (q >= lower - 1e-10) & (q <= upper + 1e-10))
    return np.all(inside, axis=-1)


class BranchSolver:
    """IK of many poses, one solution per branch: q (N, B, n) and valid (N, B)."""

    def __init__(self, robot: Arm) -> None:
        from dhkin.ik.family import fit_family
        from dhkin.ik.solver import ClosedFormSolver

        self.table = robot.table
        principal = principal_table(robot.table)
        self.principal = ClosedFormSolver(principal, fit_family(principal))
        self.n_branches = len(self.principal.branch_labels)

    def solve(self, T: Array) -> tuple[Array, Mask]:
        n = len(T)
        q = np.zeros((n, self.n_branches, self.table.dof))
        valid = np.zeros((n, self.n_branches), bool)
        if n == 0:
            return q, valid
        batch = self.principal.solve_batch(T)
        pose, slot = np.nonzero(batch.valid)
        branch = batch.branch[pose, slot]
        q[pose, branch] = batch.q[pose, slot]
        valid[pose, branch] = True
        valid &= has_copy_within_limits(self.table, q)
        return q, valid


def _chunks(n: int, size: int, progress: bool, label: str) -> Iterator[slice]:
    starts = range(0, n, size)
    if progress:
        from tqdm import tqdm

        starts = tqdm(starts, total=math.ceil(n / size), desc=label, unit="chunk",
                      file=sys.stderr, leave=False)
    for start in starts:
        yield slice(start, min(start + size, n))


# --------------------------------------------------------------------------------------------
# Workspace slice


@dataclass(frozen=True)
class WorkspaceSlice:
    """Best |det J| over IK branches on a plane of tool0 positions at a fixed orientation.

    Grids have shape (len(v), len(u)) (row = v, column = u). ``u``/``v`` are the in-plane
    base_link coordinates (m) named by ``plane`` ("xz": u = x, v = z); ``offset`` the third
    coordinate. ``manipulability``: best |det J| (m^3), NaN where unreachable; ``solutions``: number
    of IK branches within the limits; ``distances[kind]``: smallest distance over the branches
    (units of :data:`dhkin.singularity.DISTANCE_UNITS`); ``loci[kind]``: cells a singular locus of
    that kind passes through; ``boundary``: reachable cells next to an unreachable one.
    """

    robot: str
    plane: str
    offset: float
    rpy: tuple[float, float, float]
    u: Array
    v: Array
    manipulability: Array
    solutions: NDArray[np.int64]
    distances: dict[str, Array]
    loci: dict[str, Mask]
    boundary: Mask

    @property
    def rotation(self) -> Array:
        return xyz_rpy_to_matrix((0, 0, 0), self.rpy)[:3, :3]

    def position(self, row: int, column: int) -> Array:
        """base_link position (m) of a cell's centre."""
        return _plane_point(self.plane, self.offset, self.u[column], self.v[row])

    def pose(self, row: int, column: int) -> Array:
        """base_link -> tool0 pose (4x4) of a cell."""
        T = xyz_rpy_to_matrix((0, 0, 0), self.rpy)
        T[:3, 3] = self.position(row, column)
        return T

    @property
    def reachable(self) -> Mask:
        return ~np.isnan(self.manipulability)


def _plane_point(plane: str, offset: float, u: ArrayLike, v: ArrayLike) -> Array:
    iu, iv, normal = PLANES[plane]
    u_arr, v_arr = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
    out = np.empty((*u_arr.shape, 3))
    out[..., iu] = u_arr
    out[..., iv] = v_arr
    out[..., normal] = offset
    return out


def default_extent(robot: Arm, plane: str, n_samples: int = 20_000
                   ) -> tuple[tuple[float, float], tuple[float, float]]:
    """(u range, v range) covering tool0's reach: FK of random joint vectors (fixed seed), 5%
    margin; horizontal extents symmetric about axis 1."""
    rng = np.random.default_rng(0)
    positions = robot.fk(robot.table.random_q(n_samples, rng))[:, :3, 3]
    iu, iv, _ = PLANES[plane]
    radius = float(np.max(np.hypot(positions[:, 0], positions[:, 1])))

    def span(axis: int) -> tuple[float, float]:
        if axis in (0, 1):
            low, high = -radius, radius
        else:
            low, high = float(positions[:, 2].min()), float(positions[:, 2].max())
        margin = 0.05 * (high - low)
        return low - margin, high + margin

    return span(iu), span(iv)


def workspace_slice(robot: Arm, plane: str = "xz", offset: float = 0.0,
                    rpy: Sequence[float] | None = None,
                    extent: tuple[tuple[float, float], tuple[float, float]] | None = None,
                    resolution: int = DEFAULT_RESOLUTION, progress: bool = False
                    ) -> WorkspaceSlice:
    """Best |det J| over the IK branches on a ``resolution`` x ``resolution`` grid of a plane.

    ``plane`` "xz" | "yz" | "xy" of base_link at ``offset`` (m) along the third axis; tool0's
    orientation is URDF ``rpy`` (rad) in base_link (default: :data:`DEFAULT_RPY` of the family);
    ``extent`` ((u0, u1), (v0, v1)) in m (default:
    :func:`default_extent`). ``progress`` shows a tqdm bar on stderr.
    """
    if plane not in PLANES:
        raise InputError(f"plane: expected one of {list(PLANES)}, got {plane!r}", field="plane")
    _check_resolution(resolution)
    model = singularity_model(robot)
    if rpy is None:
        rpy = DEFAULT_RPY[model.family]
    rpy_values = tuple(float(x) for x in np.asarray(rpy, dtype=float).reshape(-1))
    if len(rpy_values) != 3 or not all(math.isfinite(x) for x in rpy_values):
        raise InputError(f"rpy: expected 3 finite angles (rad), got {rpy!r}", field="rpy")
    if not math.isfinite(offset):
        raise InputError(f"offset: expected a finite distance (m), got {offset!r}", field="offset")
    (u0, u1), (v0, v1) = extent if extent is not None else default_extent(robot, plane)
    if not (u0 < u1 and v0 < v1):
        raise InputError(f"extent: expected ((u0, u1), (v0, v1)) with u0 < u1 and "
                         f"v0 < v1, got {extent!r}", field="extent")
    u = np.linspace(u0, u1, resolution)
    v = np.linspace(v0, v1, resolution)
    uu, vv = np.meshgrid(u, v)
    rotation = xyz_rpy_to_matrix((0, 0, 0), rpy_values)
    positions = _plane_point(plane, offset, uu, vv).reshape(-1, 3)
    solver = BranchSolver(robot)
    cells = len(positions)
    shape = (cells, solver.n_branches)
    det = np.full(shape, np.nan)
    signed = {kind: np.full(shape, np.nan) for kind in model.kinds}
    distance = {kind: np.full(shape, np.nan) for kind in model.kinds}
    for part in _chunks(cells, CHUNK, progress, f"{robot.name} workspace IK"):
        T = np.repeat(rotation[None], part.stop - part.start, axis=0)
        T[:, :3, 3] = positions[part]
        q, valid = solver.solve(T)
        rows, branches = np.nonzero(valid)
        if rows.size == 0:
            continue
        factors = model.factors(q[rows, branches])
        target = (rows + part.start, branches)
        det[target] = np.abs(factors.determinant)
        for kind in model.kinds:
            signed[kind][target] = factors.signed(kind)
            distance[kind][target] = factors.distance(kind)
    grid = (resolution, resolution)
    count = np.sum(~np.isnan(det), axis=1)
    best = np.where(count > 0, np.nanmax(np.where(np.isnan(det), -np.inf, det), axis=1), np.nan)
    reachable = (count > 0).reshape(grid)
    boundary = _boundary_cells(reachable)
    loci = {}
    minimum = {}
    for kind in model.kinds:
        per_branch_signed = signed[kind].T.reshape((solver.n_branches, *grid))
        per_branch_distance = distance[kind].T.reshape((solver.n_branches, *grid))
        minimum[kind] = np.where(reachable, np.min(
            np.where(np.isnan(per_branch_distance), np.inf, per_branch_distance), axis=0),
            np.nan)
        loci[kind] = _locus_cells(per_branch_signed, per_branch_distance)
    edge_kinds = _classify_boundary(robot, model, solver, plane, offset, rotation[:3, :3], u, v,
                                    reachable, progress)
    for kind in model.kinds:
        per_branch_distance = distance[kind].T.reshape((solver.n_branches, *grid))
        edge_kinds[kind] |= _branch_end_cells(model, solver, kind, plane, offset,
                                              rotation[:3, :3], u, v, per_branch_distance)
    for kind, cells_on_locus in edge_kinds.items():
        loci[kind] = loci[kind] | cells_on_locus
    return WorkspaceSlice(robot=robot.name, plane=plane, offset=float(offset), rpy=rpy_values,
                          u=u, v=v, manipulability=best.reshape(grid),
                          solutions=count.reshape(grid), distances=minimum, loci=loci,
                          boundary=boundary)


def _check_resolution(resolution: int) -> None:
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) \
            or not 8 <= resolution <= 2000:
        raise InputError(f"resolution: expected an integer from 8 to 2000, "
                         f"got {resolution!r}", field="resolution")


def _boundary_cells(reachable: Mask) -> Mask:
    """Reachable cells with an unreachable 4-neighbour (cells on the grid's edge excluded)."""
    padded = np.pad(reachable, 1, constant_values=True)
    neighbours_ok = (padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:])
    return reachable & ~neighbours_ok


def _locus_cells(signed: Array, distance: Array) -> Mask:
    """Cells a zero of one kind's factor passes through, from per-branch grids (B, rows, cols)
    of the signed factor and the distance (NaN where the branch has no solution).

    Along rows and along columns, a cell is marked when one branch b valid there

    * changes the sign of its factor towards a neighbour (the cell with the smaller |factor|),
    * or has a V-shaped minimum of its distance, valid on both sides:
      ``d <= min(d_left, d_right)`` and ``d <= (d_left + d_right) / 4``,
    * or is valid on one side only, whose straight-line extrapolation reaches zero within half a
      cell beyond this one: ``d_side >= 3 d``. That is the case where two branches merge at the
      singularity and the solution carries on under the other branch's label.
    """
    marked = np.zeros(signed.shape[1:], bool)
    for axis in (1, 2):
        a = np.moveaxis(signed, axis, 1)
        d = np.moveaxis(distance, axis, 1)
        out = np.moveaxis(marked, axis - 1, 0)
        change = np.sign(a[:, :-1]) * np.sign(a[:, 1:]) < 0
        first_smaller = np.abs(a[:, :-1]) <= np.abs(a[:, 1:])
        out[:-1] |= np.any(change & first_smaller, axis=0)
        out[1:] |= np.any(change & ~first_smaller, axis=0)
        left, middle, right = d[:, :-2], d[:, 1:-1], d[:, 2:]
        has_left, has_middle, has_right = ~np.isnan(left), ~np.isnan(middle), ~np.isnan(right)
        with np.errstate(invalid="ignore"):
            valley = has_left & has_right & (middle <= np.minimum(left, right)) \
                & (middle <= 0.25 * (left + right))
            from_right = ~has_left & has_right & (right >= 3.0 * middle) & (right > middle)
            from_left = has_left & ~has_right & (left >= 3.0 * middle) & (left > middle)
        out[1:-1] |= np.any(has_middle & (valley | from_right | from_left), axis=0)
    return marked


def _classify_boundary(robot: Arm, model: SingularityModel, solver: BranchSolver, plane: str,
                       offset: float, rotation: Array, u: Array, v: Array, reachable: Mask,
                       progress: bool) -> dict[str, Mask]:
    """Singular loci in the boundary cells, where a neighbour is missing for the interior test.

    Towards each unreachable 4-neighbour the boundary point is found by bisection; the cell is
    marked for each kind whose distance there is within the default report threshold, and for
    each kind with a zero inside the cell on the segment from the opposite neighbour's centre
    to the boundary point (:data:`SEGMENT_SAMPLES` samples, per branch: sign change or V)."""
    pairs = []
    rows, columns = reachable.shape
    for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        r, c = np.nonzero(reachable)
        nr, nc = r + dr, c + dc
        inside = (nr >= 0) & (nr < rows) & (nc >= 0) & (nc < columns)
        r, c, nr, nc = r[inside], c[inside], nr[inside], nc[inside]
        out = ~reachable[nr, nc]
        pairs.append(np.stack([r[out], c[out], nr[out], nc[out]], axis=1))
    all_pairs = np.concatenate(pairs)
    marks = {kind: np.zeros_like(reachable) for kind in model.kinds}
    if len(all_pairs) == 0:
        return marks
    inner = np.stack([u[all_pairs[:, 1]], v[all_pairs[:, 0]]], axis=1)
    outer = np.stack([u[all_pairs[:, 3]], v[all_pairs[:, 2]]], axis=1)
    near = _bisect_boundary(solver, plane, offset, rotation, inner, outer, progress,
                            robot.name)
    signed, distance = _solve_points(solver, model, plane, offset, rotation, near)
    for kind in model.kinds:
        with np.errstate(invalid="ignore"):
            hit = np.any(distance[kind] <= DEFAULT_THRESHOLDS.of(kind), axis=1)
        marks[kind][all_pairs[hit, 0], all_pairs[hit, 1]] = True
    # samples from the opposite neighbour's centre (fraction -1) to the boundary point
    span = outer - inner
    reach = np.sum((near - inner) * span, axis=1) / np.sum(span * span, axis=1)
    fractions = -1.0 + (reach[:, None] + 1.0) * np.linspace(0.0, 1.0, SEGMENT_SAMPLES)[None]
    points = inner[:, None] + fractions[..., None] * span[:, None]
    signed, distance = _solve_points(solver, model, plane, offset, rotation,
                                     points.reshape(-1, 2))
    for kind in model.kinds:
        shape = (len(all_pairs), SEGMENT_SAMPLES, solver.n_branches)
        where = _zeros_on_segments(signed[kind].reshape(shape), distance[kind].reshape(shape),
                                   fractions)
        in_cell = np.any(np.abs(where) <= 0.5, axis=1)
        marks[kind][all_pairs[in_cell, 0], all_pairs[in_cell, 1]] = True
    return marks


def _solve_points(solver: BranchSolver, model: SingularityModel, plane: str, offset: float,
                  rotation: Array, points: Array) -> tuple[dict[str, Array], dict[str, Array]]:
    """Per-branch signed factors and distances (M, B) at in-plane points (M, 2); NaN where a
    branch has no solution within the limits."""
    shape = (len(points), solver.n_branches)
    signed = {kind: np.full(shape, np.nan) for kind in model.kinds}
    distance = {kind: np.full(shape, np.nan) for kind in model.kinds}
    T = np.repeat(np.eye(4)[None], len(points), axis=0)
    T[:, :3, :3] = rotation
    T[:, :3, 3] = _plane_point(plane, offset, points[:, 0], points[:, 1])
    for part in _chunks(len(points), CHUNK, False, ""):
        q, valid = solver.solve(T[part])
        rows, branches = np.nonzero(valid)
        if rows.size == 0:
            continue
        factors = model.factors(q[rows, branches])
        for kind in model.kinds:
            signed[kind][rows + part.start, branches] = factors.signed(kind)
            distance[kind][rows + part.start, branches] = factors.distance(kind)
    return signed, distance


def _zeros_on_segments(signed: Array, distance: Array, fractions: Array) -> Array:
    """Where (as fractions, NaN if none) each segment's samples (P, S, B) show a zero of one
    branch's factor: a sign change (interpolated) or a V (at the middle sample); (P, S - 1)."""
    where = np.full(fractions[:, :-1].shape, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        change = np.any(np.sign(signed[:, :-1]) * np.sign(signed[:, 1:]) < 0, axis=2)
        where = np.where(change, 0.5 * (fractions[:, :-1] + fractions[:, 1:]), where)
        left, middle, right = distance[:, :-2], distance[:, 1:-1], distance[:, 2:]
        valley = np.any((middle <= np.minimum(left, right)) & (middle <= 0.25 * (left + right)),
                        axis=2)
    where[:, 1:] = np.where(valley, fractions[:, 1:-1], where[:, 1:])
    return where


def _branch_end_cells(model: SingularityModel, solver: BranchSolver, kind: str, plane: str,
                      offset: float, rotation: Array, u: Array, v: Array,
                      distance: Array) -> Mask:
    """Reachable cells where an IK branch ends at a singularity of ``kind`` inside the
    reachable region (two branches merging, e.g. elbow up and down at full stretch, while other
    branches carry on).

    Candidates: a branch valid in a cell and the one before it, missing in the next (which is
    reachable through other branches), whose distance extrapolated linearly in d or in d^2 (a
    merge goes like the square root of the distance to it) reaches zero before the next cell.
    Each candidate is bisected to the branch's end, and kept if the distance there is within
    the default threshold."""
    rows, columns = distance.shape[1:]
    valid = ~np.isnan(distance)
    reachable = valid.any(axis=0)
    found = []
    for axis in (1, 2):
        for step in (1, -1):
            d = np.moveaxis(distance, axis, 1)
            ok = np.moveaxis(np.asarray(valid), axis, 1)
            there = np.moveaxis(np.asarray(reachable), axis - 1, 0)
            if step == -1:
                d, ok, there = d[:, ::-1], ok[:, ::-1], there[::-1]
            previous, current = d[:, :-2], d[:, 1:-1]
            ends = ok[:, :-2] & ok[:, 1:-1] & ~ok[:, 2:] & there[None, 2:]
            with np.errstate(invalid="ignore", divide="ignore"):
                linear = current / (previous - current)
                square = current ** 2 / (previous ** 2 - current ** 2)
                close = ((previous > current) & ((linear <= 1.0) | (square <= 1.0)))
            b, i, j = np.nonzero(ends & close)
            i = i + 1
            if step == -1:
                i = d.shape[1] - 1 - i
            cell = np.stack([i, j], axis=1) if axis == 1 else np.stack([j, i], axis=1)
            neighbour = cell.copy()
            neighbour[:, axis - 1] += step
            found.append((b, cell, neighbour))
    marks = np.zeros((rows, columns), bool)
    b = np.concatenate([f[0] for f in found])
    if b.size == 0:
        return marks
    cell = np.concatenate([f[1] for f in found])
    neighbour = np.concatenate([f[2] for f in found])
    inner = np.stack([u[cell[:, 1]], v[cell[:, 0]]], axis=1)
    outer = np.stack([u[neighbour[:, 1]], v[neighbour[:, 0]]], axis=1)
    end = _bisect_boundary(solver, plane, offset, rotation, inner, outer, False, "", branch=b)
    _, at_end = _solve_points(solver, model, plane, offset, rotation, end)
    with np.errstate(invalid="ignore"):
        hit = at_end[kind][np.arange(len(b)), b] <= DEFAULT_THRESHOLDS.of(kind)
    marks[cell[hit, 0], cell[hit, 1]] = True
    return marks


def _bisect_boundary(solver: BranchSolver, plane: str, offset: float, rotation: Array,
                     inner: Array, outer: Array, progress: bool, name: str,
                     branch: NDArray[np.int64] | None = None) -> Array:
    """Reachable points within 2^-BOUNDARY_BISECTIONS of the segment inner -> outer from the
    edge of the reachable set (inner reachable, outer not); with ``branch`` (one index per
    segment), the edge of where that IK branch has a solution."""
    low, high = inner.copy(), outer.copy()
    steps: Iterator[int] | range = range(BOUNDARY_BISECTIONS)
    if progress:
        from tqdm import tqdm

        steps = tqdm(steps, desc=f"{name} boundary", unit="step", file=sys.stderr, leave=False)
    for _ in steps:
        middle = 0.5 * (low + high)
        T = np.repeat(np.eye(4)[None], len(middle), axis=0)
        T[:, :3, :3] = rotation
        T[:, :3, 3] = _plane_point(plane, offset, middle[:, 0], middle[:, 1])
        ok = np.zeros(len(middle), bool)
        for part in _chunks(len(middle), CHUNK, False, ""):
            _, valid = solver.solve(T[part])
            if branch is None:
                ok[part] = valid.any(axis=1)
            else:
                ok[part] = valid[np.arange(len(valid)), branch[part]]
        low = np.where(ok[:, None], middle, low)
        high = np.where(ok[:, None], high, middle)
    return low


# --------------------------------------------------------------------------------------------
# Joint-space slices


@dataclass(frozen=True)
class JointSlice:
    """|det J| over two joints (1-based ``joints``), the others at ``q_fixed``.

    Grids have shape (len(v), len(u)); ``u`` holds joint ``joints[0]``'s values, ``v`` joint
    ``joints[1]``'s (rad, or m for a prismatic joint). ``signed[kind]`` is the kind's signed
    factor, ``loci[kind]`` the cells its zero set passes through.
    """

    robot: str
    joints: tuple[int, int]
    q_fixed: Array
    u: Array
    v: Array
    manipulability: Array
    signed: dict[str, Array]
    loci: dict[str, Mask]


def default_fixed_q(robot: Arm) -> Array:
    """Joint values held fixed in the joint slices: 0 (clipped to the limits), except joint 2 at
    30 deg (away from the upright pose, where the stretched arm puts the wrist centre on axis 1)
    and joint 5 at theta5 = 90 deg (farthest from the wrist singularity), each when within its
    limits."""
    q = np.clip(np.zeros(robot.dof), robot.lower, robot.upper)
    shoulder = robot.table.joints[1]
    if shoulder.is_revolute and shoulder.lower <= math.pi / 6 <= shoulder.upper:
        q[1] = math.pi / 6
    wrist = robot.table.joints[4]
    if wrist.is_revolute:
        value = (math.pi / 2 - wrist.offset) / wrist.direction
        if wrist.lower <= value <= wrist.upper:
            q[4] = value
    return q


def joint_slice(robot: Arm, joints: tuple[int, int] = (2, 3), q_fixed: ArrayLike | None = None,
                resolution: int = DEFAULT_JOINT_RESOLUTION) -> JointSlice:
    """|det J| and singular loci on a grid of two joints over their limits (one turn, centred
    on 0, for a joint whose limits span more), the others at ``q_fixed`` (default:
    :func:`default_fixed_q`)."""
    _check_resolution(resolution)
    model = singularity_model(robot)
    if len(joints) != 2 or len(set(joints)) != 2 or not all(
            isinstance(j, (int, np.integer)) and 1 <= j <= robot.dof for j in joints):
        raise InputError(f"joints: expected two different joint numbers 1..{robot.dof}, "
                         f"got {joints!r}", field="joints")
    fixed = default_fixed_q(robot) if q_fixed is None else np.asarray(q_fixed, dtype=float)
    if fixed.shape != (robot.dof,) or not np.all(np.isfinite(fixed)):
        raise InputError(f"q_fixed: expected {robot.dof} finite joint values, got "
                         f"{np.asarray(q_fixed).tolist()!r}", field="q_fixed")
    first, second = joints[0] - 1, joints[1] - 1
    u = np.linspace(*_slice_range(robot.table, first), resolution)
    v = np.linspace(*_slice_range(robot.table, second), resolution)
    uu, vv = np.meshgrid(u, v)
    Q = np.repeat(fixed[None], uu.size, axis=0)
    Q[:, first] = uu.ravel()
    Q[:, second] = vv.ravel()
    factors = model.factors(Q)
    grid = uu.shape
    signed = {kind: factors.signed(kind).reshape(grid) for kind in model.kinds}
    loci = {kind: _sign_change_cells(values) for kind, values in signed.items()}
    return JointSlice(robot=robot.name, joints=(int(joints[0]), int(joints[1])), q_fixed=fixed,
                      u=u, v=v, manipulability=np.abs(factors.determinant).reshape(grid),
                      signed=signed, loci=loci)


def _slice_range(table: DHTable, joint: int) -> tuple[float, float]:
    """A joint's limits, or one turn [-pi, pi] centred on 0 when they span more than a turn (the
    kinematics repeat every turn)."""
    info = table.joints[joint]
    if info.is_revolute and info.upper - info.lower > 2 * math.pi:
        return -math.pi, math.pi
    return info.lower, info.upper


def _sign_change_cells(values: Array) -> Mask:
    """Cells at a zero of ``values`` or, of two neighbours of opposite sign, the smaller one."""
    marked = values == 0
    for axis in (0, 1):
        a = np.moveaxis(values, axis, 0)
        out = np.moveaxis(marked, axis, 0)
        change = np.sign(a[:-1]) * np.sign(a[1:]) < 0
        first_smaller = np.abs(a[:-1]) <= np.abs(a[1:])
        out[:-1] |= change & first_smaller
        out[1:] |= change & ~first_smaller
    return marked


# --------------------------------------------------------------------------------------------
# Figure


@dataclass(frozen=True)
class SingularityMaps:
    """What :func:`draw_maps` computed and drew."""

    workspace: WorkspaceSlice
    joint_slices: tuple[JointSlice, ...]
    path: Path


def draw_maps(robot: Arm, output: str | Path, plane: str = "xz", offset: float = 0.0,
              rpy: Sequence[float] | None = None, resolution: int = DEFAULT_RESOLUTION,
              joint_resolution: int = DEFAULT_JOINT_RESOLUTION,
              q_fixed: ArrayLike | None = None, progress: bool = False) -> SingularityMaps:
    """Compute a workspace slice and the q2-q3 and q3-q5 joint slices; write them as one PNG
    of FIGURE_SIZE * DPI pixels to ``output``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(output)
    if path.suffix.lower() != ".png":
        raise InputError(f"output: expected a .png file name, got {str(output)!r}", field="output")
    if not path.parent.exists():
        raise InputError(f"output: folder {str(path.parent)!r} does not exist", field="output")
    workspace = workspace_slice(robot, plane, offset, rpy, resolution=resolution,
                                progress=progress)
    slices = (joint_slice(robot, (2, 3), q_fixed, joint_resolution),
              joint_slice(robot, (3, 5), q_fixed, joint_resolution))
    figure, axes = plt.subplots(1, 3, figsize=FIGURE_SIZE, dpi=DPI,
                                gridspec_kw={"width_ratios": [1.25, 1, 1]})
    _draw_workspace(axes[0], figure, workspace)
    for ax, data in zip(axes[1:], slices, strict=True):
        _draw_joint_slice(ax, figure, robot, data)
    model = singularity_model(robot)
    figure.suptitle(f"{robot.name} ({model.family.replace('_', ' ')}): manipulability "
                    f"|det J| and singular loci", fontsize=15)
    figure.tight_layout(rect=(0, 0, 1, 0.95))
    figure.savefig(path, dpi=DPI)
    plt.close(figure)
    return SingularityMaps(workspace=workspace, joint_slices=slices, path=path)


def _draw_workspace(ax, figure, data: WorkspaceSlice) -> None:
    from matplotlib.lines import Line2D

    iu, iv, normal = PLANES[data.plane]
    image = ax.pcolormesh(data.u, data.v, np.ma.masked_invalid(data.manipulability),
                          shading="nearest", cmap="viridis")
    colorbar = figure.colorbar(image, ax=ax, fraction=0.046, pad=0.03)
    colorbar.set_label(MEASURE_LABEL + ", best over IK solutions")
    ax.contour(data.u, data.v, data.reachable.astype(float), levels=[0.5], colors="0.35",
               linewidths=0.8)
    handles = [Line2D([], [], color="0.35", lw=0.8, label="reach boundary (blank: unreachable)")]
    uu, vv = np.meshgrid(data.u, data.v)
    for kind in ("shoulder", "elbow", "wrist"):  # wrist loci drawn on top
        if kind not in data.loci or not data.loci[kind].any():
            continue
        style = KIND_STYLE[kind]
        mask = data.loci[kind]
        ax.scatter(uu[mask], vv[mask], s=7, c=style["color"], marker=style["marker"],
                   linewidths=0)
        handles.append(Line2D([], [], color=style["color"], marker=style["marker"], ls="",
                              label=style["label"]))
    ax.legend(handles=handles, loc="lower left", fontsize=8, framealpha=0.85)
    ax.set_aspect("equal")
    ax.set_xlabel(f"{AXIS_NAMES[iu]} (m, base_link)")
    ax.set_ylabel(f"{AXIS_NAMES[iv]} (m, base_link)")
    rpy_deg = ", ".join(f"{math.degrees(a):.0f}" for a in data.rpy)
    ax.set_title(f"Workspace slice {AXIS_NAMES[normal]} = {data.offset:g} m, tool0 rpy "
                 f"({rpy_deg}) deg\n(tool0 z along {_direction_text(data.rotation[:, 2])})",
                 fontsize=11)


def _direction_text(vector: Array) -> str:
    parts = [f"{value:+.2f}{name}" for value, name in zip(vector, AXIS_NAMES, strict=True)
             if abs(value) > 5e-3]
    return " ".join(parts)


def _joint_label(robot: Arm, joint: int) -> tuple[str, float]:
    info = robot.table.joints[joint - 1]
    if info.is_revolute:
        return f"q{joint} {info.name} (deg)", 180.0 / math.pi
    return f"q{joint} {info.name} (m)", 1.0


def _draw_joint_slice(ax, figure, robot: Arm, data: JointSlice) -> None:
    from matplotlib.lines import Line2D

    u_label, u_scale = _joint_label(robot, data.joints[0])
    v_label, v_scale = _joint_label(robot, data.joints[1])
    u, v = data.u * u_scale, data.v * v_scale
    image = ax.pcolormesh(u, v, data.manipulability, shading="nearest", cmap="viridis")
    colorbar = figure.colorbar(image, ax=ax, fraction=0.046, pad=0.03)
    colorbar.set_label(MEASURE_LABEL)
    handles = []
    for kind in KINDS:
        if kind not in data.signed:
            continue
        values = data.signed[kind]
        if not (np.nanmin(values) <= 0 <= np.nanmax(values)):
            continue
        style = KIND_STYLE[kind]
        dashes = "--" if kind == "shoulder" else "-"
        ax.contour(u, v, values, levels=[0.0], colors=style["color"], linewidths=1.8,
                   linestyles=dashes)
        handles.append(Line2D([], [], color=style["color"], lw=1.8, ls=dashes,
                              label=style["label"]))
    if handles:
        ax.legend(handles=handles, loc="lower left", fontsize=8, framealpha=0.85)
    ax.set_xlabel(u_label)
    ax.set_ylabel(v_label)
    others = [k for k in range(1, robot.dof + 1) if k not in data.joints]
    fixed = ", ".join(f"q{k} = {_format_joint(robot, k, data.q_fixed[k - 1])}" for k in others)
    ax.set_title(f"Joint slice q{data.joints[0]}-q{data.joints[1]}\n({fixed})", fontsize=11)


def _format_joint(robot: Arm, joint: int, value: float) -> str:
    if robot.table.joints[joint - 1].is_revolute:
        return f"{math.degrees(value):.0f} deg"
    return f"{value:.3g} m"


def describe(maps: SingularityMaps) -> str:
    """What a figure shows, in words and counts."""
    workspace = maps.workspace
    normal = PLANES[workspace.plane][2]
    rpy_deg = ", ".join(f"{math.degrees(a):.1f}" for a in workspace.rpy)
    cells = workspace.manipulability.size
    reachable = int(workspace.reachable.sum())
    best = float(np.nanmax(workspace.manipulability)) if reachable else float("nan")
    lines = [f"wrote {maps.path} ({int(FIGURE_SIZE[0] * DPI)} x {int(FIGURE_SIZE[1] * DPI)} px)",
             f"workspace slice {AXIS_NAMES[normal]} = {workspace.offset:g} m, tool0 rpy "
             f"({rpy_deg}) deg: {reachable} of {cells} cells reachable, best |det J| "
             f"{best:.4g} m^3",
             "  cells on singular loci: " + ", ".join(
                 f"{kind} {int(mask.sum())}" for kind, mask in workspace.loci.items())]
    for data in maps.joint_slices:
        lines.append(f"joint slice q{data.joints[0]}-q{data.joints[1]}: max |det J| "
                     f"{float(np.max(data.manipulability)):.4g} m^3; cells on loci: "
                     + ", ".join(f"{kind} {int(mask.sum())}" for kind, mask in data.loci.items()))
    return "\n".join(lines)
