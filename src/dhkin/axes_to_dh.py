"""Joint axes -> DH rows: the geometry of `dhkin import` (see :mod:`dhkin.importer` for the
choices: common normals, directions, offsets only where needed).

Input: the joint axes of a chain at q = 0 as lines (points, unit directions) in the base frame,
and the tip's origin. Output (:class:`AxisRows`): per joint a, alpha, d (revolute) or theta
(prismatic), offset and direction, in m and rad, in the standard or modified convention, with
DH frame 0 and DH frame n at q = 0 in the base frame, and the pairs of axes that are parallel
within ``band`` but not exactly (their rows are nominal: the caller adds corrections).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dhkin.tolerances import DEFAULT_TOLERANCE

#: Rounding that is not a difference (m and rad): a thousandth of the tolerance. Axes whose sine
#: times the arm's size stays below it are parallel.
CLEAN = DEFAULT_TOLERANCE * 1e-3


@dataclass
class _Normal:
    """The common normal from axis k to axis k + 1: its feet on both axes, unit x, length a
    (along x) and twist alpha (z_k -> z_{k+1} about x)."""

    start: NDArray[np.float64]
    end: NDArray[np.float64]
    x: NDArray[np.float64]
    a: float
    alpha: float


@dataclass(frozen=True)
class AxisRows:
    """Per joint: a, alpha, d (revolute) or theta (prismatic), offset, direction; DH frame 0 and
    DH frame n at q = 0 in the base; the parallel-within-band pairs (index k: axes k, k + 1)."""

    a: list[float]
    alpha: list[float]
    fixed: list[float]
    offset: list[float]
    direction: list[int]
    frame_0: NDArray[np.float64]
    frame_n: NDArray[np.float64]
    near_parallel: list[int]


def rows_from_axes(points: NDArray[np.float64], axes: NDArray[np.float64],
                   revolute: tuple[bool, ...], tip: NDArray[np.float64], convention: str,
                   band: float) -> AxisRows:
    """DH rows of the axes (lines ``points[i]`` + t ``axes[i]``, base frame, q = 0) of joints
    ``revolute[i]`` (else prismatic), ending at ``tip`` (4x4, base frame); ``band`` (rad): axes
    within it of parallel but not parallel to CLEAN are written parallel (nominal rows)."""
    n = len(revolute)
    size = max(_chain_size(points, tip[:3, 3]), CLEAN)
    z = [axes[0] * (-1.0 if axes[0][2] < -CLEAN else 1.0)]
    for k in range(1, n):
        previous = z[-1]
        antiparallel = float(np.dot(axes[k], previous)) < 0 and \
            float(np.linalg.norm(np.cross(axes[k], previous))) <= band
        z.append(-axes[k] if antiparallel else axes[k])
    direction = [1 if float(np.dot(z[k], axes[k])) > 0 else -1 for k in range(n)]

    # The normal before axis 1: foot nearest the base origin, x along the base's x.
    foot = _foot(points[0], z[0], np.zeros(3))
    helper = np.eye(3)[0] if float(np.linalg.norm(np.cross(np.eye(3)[0], z[0]))) >= 0.5 \
        else np.eye(3)[1]
    x_before = _unit(helper - np.dot(helper, z[0]) * z[0])
    normals = [_Normal(foot, foot, x_before, 0.0, 0.0)]
    near_parallel = []
    for k in range(n - 1):
        normal, near = _common_normal(points[k + 1], z[k], z[k + 1], normals[-1], size, band)
        normals.append(normal)
        if near:
            near_parallel.append(k)
    end = _foot(points[n - 1], z[n - 1], tip[:3, 3])
    normals.append(_Normal(end, end, normals[-1].x, 0.0, 0.0))

    a, alpha, fixed, offset = [], [], [], []
    for i in range(n):
        before, after = normals[i], normals[i + 1]
        along = float(np.dot(after.start - before.end, z[i]))
        turn = _angle_about(before.x, after.x, z[i])
        row = after if convention == "standard" else before
        a.append(row.a)
        alpha.append(row.alpha)
        if revolute[i]:
            fixed.append(along)
            offset.append(turn)
        else:
            fixed.append(turn)
            offset.append(along)
    frame_0 = _frame(normals[0].end, normals[0].x, z[0])
    frame_n = _frame(normals[n].start, normals[n].x, z[n - 1])
    return AxisRows(a, alpha, fixed, offset, direction, frame_0, frame_n, near_parallel)


def _common_normal(point: NDArray[np.float64], z: NDArray[np.float64],
                   z_next: NDArray[np.float64], before: _Normal, size: float, band: float
                   ) -> tuple[_Normal, bool]:
    """The normal from axis k (through ``before.end``, direction z) to axis k + 1 (through
    ``point``, direction ``z_next``), and whether the axes are parallel within the band but
    not exactly (the row is then nominal)."""
    origin = before.end
    cross = np.cross(z, z_next)
    sine = float(np.linalg.norm(cross))
    parallel = sine * size <= CLEAN
    near = not parallel and sine <= band
    if parallel or near:
        start = origin
        end = _foot(point, z_next, origin)
        span = end - start
        span -= np.dot(span, z) * z
        alpha = 0.0 if float(np.dot(z, z_next)) > 0 else math.pi
        direction = _unit(span) if float(np.linalg.norm(span)) > CLEAN else before.x
    else:
        w = point - origin
        t_k = float(np.dot(np.cross(w, z_next), cross)) / sine**2
        t_next = float(np.dot(np.cross(w, z), cross)) / sine**2
        start = origin + t_k * z
        end = point + t_next * z_next
        span = end - start
        direction = cross / sine
        alpha = float("nan")  # set below, once x is chosen
    x = _nearest_sign(direction, before.x, span)
    a = float(np.dot(span, x))
    if not (parallel or near):
        alpha = _angle_about(z, z_next, x)
    return _Normal(start, end, x, a, alpha), near


def _nearest_sign(direction: NDArray[np.float64], previous_x: NDArray[np.float64],
                  span: NDArray[np.float64]) -> NDArray[np.float64]:
    """+-direction: the one nearer ``previous_x`` (smallest offset); when both are equally near
    (to CLEAN), the one with a >= 0."""
    dot = float(np.dot(direction, previous_x))
    if abs(dot) > CLEAN:
        return direction if dot > 0 else -direction
    return direction if float(np.dot(span, direction)) >= -CLEAN else -direction


def _foot(point: NDArray[np.float64], axis: NDArray[np.float64], target: NDArray[np.float64]
          ) -> NDArray[np.float64]:
    """The point of the line (point, unit axis) nearest ``target``."""
    return point + float(np.dot(target - point, axis)) * axis


def _angle_about(u: NDArray[np.float64], v: NDArray[np.float64], axis: NDArray[np.float64]
                 ) -> float:
    """The angle that turns u onto v about ``axis`` (all unit, u and v perpendicular to it)."""
    return math.atan2(float(np.dot(np.cross(u, v), axis)), float(np.dot(u, v)))


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    return v / np.linalg.norm(v)


def _frame(origin: NDArray[np.float64], x: NDArray[np.float64], z: NDArray[np.float64]
           ) -> NDArray[np.float64]:
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = origin
    return T


def _chain_size(points: NDArray[np.float64], tip: NDArray[np.float64]) -> float:
    """An upper bound of the arm's extent: the polyline base origin -> axis points -> tip (m)."""
    path = np.vstack([np.zeros(3), points, tip])
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
