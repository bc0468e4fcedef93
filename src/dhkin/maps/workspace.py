"""Manipulability maps with singular loci: a workspace slice and joint-space slices, as PNG.

The measure drawn is the Yoshikawa manipulability sqrt(det(J J^T)) = ``|det J|`` (m^3: three
columns' linear parts carry metres) of the 6x6 Jacobian, computed from the analytic factorization
of :mod:`dhkin.singularity` (equal to Pinocchio's det J to 1e-9 relative, see the tests).

**Workspace slice**: tool0 positions on a plane of base_link ("xz": y = offset, "yz": x = offset,
"xy": z = offset) at one fixed tool0 orientation (URDF rpy). Each cell is solved by the
closed-form IK; the cell's value is the best ``|det J|`` over the distinct IK branches that have a
copy within the joint limits (2pi copies have the same kinematics), NaN (blank) when none has.
Singular loci, per kind:

* inside the reachable region, a cell is on a locus when, along x or along z, one IK branch's
  signed factor changes sign towards a neighbour, or its distance (``|factor|``) has a V-shaped
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

**Joint-space slices**: two joints varied over their limits, the others fixed; ``|det J|`` on the
grid, and the zero sets of the signed factors (exact curves: the factors are smooth in q), the
cells through which they pass marked as loci.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import real_array
from dhkin.errors import InputError
from dhkin.maps.branches import (
    CHUNK,
    DEFAULT_RESOLUTION,
    DEFAULT_RPY,
    PLANES,
    Array,
    BranchSolver,
    Mask,
    _check_resolution,
    _chunks,
)
from dhkin.singularity import (
    DEFAULT_THRESHOLDS,
    SingularityModel,
    singularity_model,
)
from dhkin.transforms import xyz_rpy_to_matrix

if TYPE_CHECKING:
    from dhkin.arm import Arm

#: Bisection steps that locate the workspace boundary between two cells (2^-24 of a cell).
BOUNDARY_BISECTIONS = 24


#: Samples on the segment through a boundary cell searched for zeros (about 8 per cell).
SEGMENT_SAMPLES = 17


@dataclass(frozen=True)
class WorkspaceSlice:
    """Best ``|det J|`` over IK branches on a plane of tool0 positions at a fixed orientation.

    Grids have shape (len(v), len(u)) (row = v, column = u). ``u``/``v`` are the in-plane
    base_link coordinates (m) named by ``plane`` ("xz": u = x, v = z); ``offset`` the third
    coordinate. ``manipulability``: best ``|det J|`` (m^3), NaN where unreachable;
    ``solutions``: number of IK branches within the limits; ``distances[kind]``: smallest
    distance over the branches (units of :data:`dhkin.singularity.DISTANCE_UNITS`);
    ``loci[kind]``: cells a singular locus of that kind passes through; ``boundary``: reachable
    cells next to an unreachable one.
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
    """Best ``|det J|`` over the IK branches on a ``resolution`` x ``resolution`` grid of a plane.

    ``plane`` "xz" | "yz" | "xy" of base_link at ``offset`` (m) along the third axis; tool0's
    orientation is URDF ``rpy`` (rad) in base_link (default: :data:`DEFAULT_RPY` of the family);
    ``extent`` ((u0, u1), (v0, v1)) in m (default:
    :func:`default_extent`). ``progress`` shows a tqdm bar on stderr.
    """
    if not isinstance(plane, str) or plane not in PLANES:
        raise InputError(f"plane: expected one of {list(PLANES)}, got {plane!r}", field="plane")
    _check_resolution(resolution)
    model = singularity_model(robot)
    if rpy is None:
        rpy = DEFAULT_RPY[model.family]
    rpy_values = tuple(float(x) for x in real_array(rpy, "rpy", "3 finite angles (rad)")
                       .reshape(-1))
    if len(rpy_values) != 3 or not all(math.isfinite(x) for x in rpy_values):
        raise InputError(f"rpy: expected 3 finite angles (rad), got {rpy!r}", field="rpy")
    if isinstance(offset, bool) or not isinstance(offset, (int, float, np.integer, np.floating)) \
            or not math.isfinite(offset):
        raise InputError(f"offset: expected a finite distance (m), got {offset!r}", field="offset")
    bounds = real_array(extent if extent is not None else default_extent(robot, plane),
                        "extent", "((u0, u1), (v0, v1)) in m")
    if bounds.shape != (2, 2):
        raise InputError(f"extent: expected ((u0, u1), (v0, v1)) in m, got shape {bounds.shape}",
                         field="extent", value=bounds.shape, expected="shape (2, 2)")
    (u0, u1), (v0, v1) = bounds.tolist()
    if not (u0 < u1 and v0 < v1) or not np.all(np.isfinite(bounds)):
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


def _boundary_cells(reachable: Mask) -> Mask:
    """Reachable cells with an unreachable 4-neighbour (cells on the grid's edge excluded)."""
    padded = np.pad(reachable, 1, constant_values=True)
    neighbours_ok = (padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:])
    return reachable & ~neighbours_ok


def _locus_cells(signed: Array, distance: Array) -> Mask:
    """Cells a zero of one kind's factor passes through, from per-branch grids (B, rows, cols)
    of the signed factor and the distance (NaN where the branch has no solution).

    Along rows and along columns, a cell is marked when one branch b valid there

    * changes the sign of its factor towards a neighbour (the cell with the smaller ``|factor|``),
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
