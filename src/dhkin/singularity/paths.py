"""Singularities along a path: a joint path (or a pose path solved by IK) scanned for crossings and
near misses of the singular sets, with the joint speeds they cause.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import joint_vector
from dhkin.errors import InputError, UnreachableError
from dhkin.singularity.factors import Factors
from dhkin.singularity.model import singularity_model
from dhkin.singularity.thresholds import (
    DISTANCE_UNITS,
    GRAZE_THRESHOLDS,
    KINDS,
    RACE_FACTOR,
    Array,
    Thresholds,
    as_thresholds,
)
from dhkin.transforms import rotation_angle

if TYPE_CHECKING:
    from dhkin.arm import Arm


@dataclass(frozen=True)
class PathEvent:
    """A place where a path crosses or grazes one singularity.

    ``how``: "crosses" (the signed factor changes sign between two samples, or is 0 at one with
    opposite signs around it) or "grazes" (the distance has a local minimum at or below the
    graze threshold without a sign change; an IK path that bounces off the singularity, e.g.
    keeping the sign of q5 by turning q4 and q6 half a turn, shows up this way).
    ``sample``: fractional sample index of the estimated closest point; ``arc_length`` (m) and
    ``position`` (base_link, m) of tool0 there. ``distance``: the smallest distance sampled
    (units of :data:`DISTANCE_UNITS`). ``joint_speed``: the peak joint speed per unit tool
    speed around it (rad/m, i.e. rad/s at 1 m/s), ``blow_up`` that peak over the path's median;
    ``racing_joints``: 1-based joints whose speed there is at least half the peak, fastest first.
    """

    kind: str
    how: str
    sample: float
    arc_length: float
    position: Array
    distance: float
    joint_speed: float
    blow_up: float
    racing_joints: tuple[int, ...]

    def describe(self, joint_names: Sequence[str] = ()) -> str:
        names = [joint_names[j - 1] if joint_names else f"joint {j}" for j in self.racing_joints]
        return (f"{self.how} the {self.kind} singularity at sample {self.sample:.2f} "
                f"(s = {self.arc_length:.4f} m, tool0 at "
                f"{np.array2string(self.position, precision=4)} m), closest sampled distance "
                f"{self.distance:.3g} {DISTANCE_UNITS[self.kind]}; peak joint speed "
                f"{self.joint_speed:.3g} rad/m ({self.blow_up:.3g} x the path median); "
                f"{'racing' if self.blow_up >= RACE_FACTOR else 'fastest'}: {', '.join(names)}")


@dataclass(frozen=True)
class PathAnalysis:
    """Singularity analysis along a sampled path of M configurations.

    ``q`` (M, 6) joint values, ``poses`` (M, 4, 4) base_link -> tool0, ``arc_length`` (M,) the
    tool's cumulative path length ``sum sqrt(dp^2 + (rotation_length * dphi)^2)`` (m),
    ``factors`` along the path, ``joint_speed`` (M-1,) ``max_k |dq_k| / ds`` per segment (rad/m;
    inf where the tool does not move but a joint does), ``racing_joint`` (M-1,) the 1-based joint
    attaining it, ``events`` the crossings and grazes, in path order.
    """

    robot: str
    q: Array
    poses: Array
    arc_length: Array
    factors: Factors
    joint_speed: Array
    racing_joint: NDArray[np.int64]
    events: tuple[PathEvent, ...]
    thresholds: Thresholds
    joint_names: tuple[str, ...] = ()

    def summary(self) -> str:
        finite = self.joint_speed[np.isfinite(self.joint_speed)]
        median = float(np.median(finite)) if finite.size else float("nan")
        lines = [f"{self.robot}: path of {len(self.q)} samples, {self.arc_length[-1]:.4f} m of "
                 f"tool motion; median joint speed {median:.3g} rad/m, peak "
                 f"{float(np.max(self.joint_speed)):.3g} rad/m"]
        if not self.events:
            lines.append("no singularity crossed or grazed (graze thresholds: "
                         + ", ".join(f"{k} {self.thresholds.of(k):g} {DISTANCE_UNITS[k]}"
                                     for k in KINDS) + ")")
        for event in self.events:
            lines.append("  " + event.describe(self.joint_names))
        return "\n".join(lines)


def line_poses(start: ArrayLike, end: ArrayLike, n: int) -> Array:
    """n poses (n, 4, 4) on the straight line from ``start`` to ``end`` (4x4 each): positions
    linearly interpolated, orientation turning uniformly about one axis (geodesic)."""
    T0, T1 = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    if T0.shape != (4, 4) or T1.shape != (4, 4):
        raise InputError(f"start, end: expected 4x4 poses, got {T0.shape} and {T1.shape}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise InputError(f"n: expected an integer >= 2, got {n!r}", field="n")
    relative = T0[:3, :3].T @ T1[:3, :3]
    angle = float(rotation_angle(relative))
    axis = np.array([relative[2, 1] - relative[1, 2], relative[0, 2] - relative[2, 0],
                     relative[1, 0] - relative[0, 1]])
    norm = float(np.linalg.norm(axis))
    axis = axis / norm if norm > 1e-12 else np.array([0.0, 0.0, 1.0])
    if angle > math.pi - 1e-6:
        raise InputError("start, end: orientations half a turn apart; the rotation axis "
                         "is ambiguous, expected less than 180 deg between them")
    fractions = np.linspace(0.0, 1.0, n)
    poses = np.repeat(np.eye(4)[None], n, axis=0)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    for i, f in enumerate(fractions):
        phi = f * angle
        R = np.eye(3) + math.sin(phi) * K + (1 - math.cos(phi)) * K @ K
        poses[i, :3, :3] = T0[:3, :3] @ R
        poses[i, :3, 3] = (1 - f) * T0[:3, 3] + f * T1[:3, 3]
    return poses


def solve_pose_path(robot: Arm, poses: ArrayLike, q_start: ArrayLike | None = None) -> Array:
    """Joint path of a pose path: each pose solved by IK, taking the solution nearest to the
    previous one (the first: nearest to ``q_start``, default zeros) and the previous solution as
    seed for a free joint at a singularity. UnreachableError naming the first unreachable pose
    (its ``index``).
    """
    targets = np.asarray(poses, dtype=float)
    if targets.ndim != 3 or targets.shape[1:] != (4, 4):
        raise InputError(f"poses: expected shape (M, 4, 4), got {targets.shape}", field="poses")
    previous = (np.zeros(robot.dof) if q_start is None
                else joint_vector(q_start, robot.dof, "q_start"))
    path = np.empty((len(targets), robot.dof))
    for i, T in enumerate(targets):
        solutions = robot.ik(T, q_seed=previous)
        if not solutions:
            raise UnreachableError(f"poses[{i}]: no IK solution ({solutions.reason}); "
                                   f"expected a path inside the workspace", field="poses",
                                   index=i, expected="a path inside the workspace")
        previous = solutions.nearest(previous)
        path[i] = previous
    return path


def analyse_path(robot: Arm, path: ArrayLike, q_start: ArrayLike | None = None,
                 thresholds: Thresholds | Mapping[str, float] | None = None,
                 rotation_length: float = 0.1, window: int = 2) -> PathAnalysis:
    """Where a path crosses or grazes a singularity, and how fast the joints race there.

    ``path``: joint vectors (M, 6) or poses base_link -> tool0 (M, 4, 4), M >= 3; poses are
    solved by :func:`solve_pose_path` from ``q_start``. ``thresholds`` (default
    :data:`GRAZE_THRESHOLDS`) set how close a local minimum must come to count as a graze.
    ``rotation_length`` (m/rad) weighs tool rotation in the Cartesian step; ``window``: segments
    on each side of an event over which its peak joint speed is taken.
    """
    limits = as_thresholds(thresholds, GRAZE_THRESHOLDS)
    model = singularity_model(robot)
    data = np.asarray(path, dtype=float)
    if data.ndim == 3 and data.shape[1:] == (4, 4):
        q = solve_pose_path(robot, data, q_start)
    elif data.ndim == 2 and data.shape[1] == robot.dof:
        q = data
    else:
        raise InputError(f"path: expected joint vectors (M, {robot.dof}) or poses "
                         f"(M, 4, 4), got shape {data.shape}", field="path")
    if len(q) < 3:
        raise InputError(f"path: expected at least 3 samples, got {len(q)}", field="path")
    if not np.all(np.isfinite(q)):
        raise InputError("path: expected finite values, got NaN or inf", field="path")
    if not (math.isfinite(rotation_length) and rotation_length >= 0):
        raise InputError(f"rotation_length: expected a finite number >= 0 (m/rad), got "
                         f"{rotation_length!r}", field="rotation_length")
    poses = robot.fk(q)
    steps = _cartesian_steps(poses, rotation_length)
    arc = np.concatenate([[0.0], np.cumsum(steps)])
    joint_steps = np.abs(np.diff(q, axis=0))
    biggest = joint_steps.max(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        speed = np.where(steps > 0, biggest / np.where(steps > 0, steps, 1.0),
                         np.where(biggest > 0, np.inf, 0.0))
    factors = model.factors(q)
    finite = speed[np.isfinite(speed)]
    median = float(np.median(finite)) if finite.size else float("nan")
    events = []
    for kind in model.kinds:
        for sample, how in _events(factors.signed(kind), factors.distance(kind),
                                   limits.of(kind)):
            events.append(_event(kind, how, sample, arc, poses, factors.distance(kind),
                                 joint_steps, steps, speed, median, window))
    events.sort(key=lambda e: e.sample)
    return PathAnalysis(robot=robot.name, q=q, poses=poses, arc_length=arc, factors=factors,
                        joint_speed=speed, racing_joint=np.argmax(joint_steps, axis=1) + 1,
                        events=tuple(events), thresholds=limits,
                        joint_names=tuple(robot.table.joint_names))


def _cartesian_steps(poses: Array, rotation_length: float) -> Array:
    dp = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)
    relative = np.swapaxes(poses[:-1, :3, :3], 1, 2) @ poses[1:, :3, :3]
    dphi = rotation_angle(relative)
    return np.hypot(dp, rotation_length * dphi)


def _events(signed: Array, distance: Array, threshold: float) -> list[tuple[float, str]]:
    """(fractional sample, "crosses" | "grazes") of one kind along a path."""
    found: list[tuple[float, str]] = []
    used = np.zeros(len(signed), bool)
    sign = np.sign(signed)
    for i in range(len(signed) - 1):
        if sign[i] * sign[i + 1] < 0:
            found.append((i + signed[i] / (signed[i] - signed[i + 1]), "crosses"))
            used[i] = used[i + 1] = True
    for i in np.flatnonzero(sign == 0).tolist():
        if used[i]:
            continue
        before = sign[i - 1] if i > 0 else 0
        after = sign[i + 1] if i + 1 < len(sign) else 0
        found.append((float(i), "crosses" if before * after < 0 else "grazes"))
        used[max(i - 1, 0):i + 2] = True
    for i in range(len(distance)):
        if used[i] or distance[i] > threshold:
            continue
        left = distance[i - 1] if i > 0 else np.inf
        right = distance[i + 1] if i + 1 < len(distance) else np.inf
        if distance[i] <= left and distance[i] < right:
            found.append((_valley(distance, i), "grazes"))
            used[max(i - 1, 0):i + 2] = True
    return found


def _valley(distance: Array, i: int) -> float:
    """Fractional index of the minimum of a distance around its sampled minimum i.

    A V (|f| of a factor with a zero between samples: ``d_i <= (d_left + d_right) / 4``) is
    fitted with two lines of opposite slope; a smooth minimum with a parabola. The estimate
    stays within half a sample of i.
    """
    if i == 0 or i == len(distance) - 1:
        return float(i)
    left, middle, right = distance[i - 1], distance[i], distance[i + 1]
    if middle <= 0.25 * (left + right):
        slope = max(left, right) - middle
        offset = middle / slope if slope > 0 else 0.0
        offset = offset if right <= left else -offset
    else:
        curvature = left - 2.0 * middle + right
        offset = 0.5 * (left - right) / curvature if curvature > 0 else 0.0
    return float(i + min(max(offset, -0.5), 0.5))


def _event(kind: str, how: str, sample: float, arc: Array, poses: Array, distance: Array,
           joint_steps: Array, steps: Array, speed: Array, median: float,
           window: int) -> PathEvent:
    i = math.floor(sample)
    fraction = sample - i
    j = min(i + 1, len(arc) - 1)
    position = (1 - fraction) * poses[i, :3, 3] + fraction * poses[j, :3, 3]
    first = max(i - window, 0)
    last = min(i + window, len(steps) - 1)
    segment_steps = steps[first:last + 1, None]
    moved = joint_steps[first:last + 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        per_joint = np.where(segment_steps > 0, moved / np.where(segment_steps > 0,
                                                                 segment_steps, 1.0),
                             np.where(moved > 0, np.inf, 0.0)).max(axis=0)
    peak = float(np.max(speed[first:last + 1]))
    order = np.argsort(-per_joint, kind="stable")
    top = per_joint[order[0]]
    racing = tuple(int(k) + 1 for k in order if per_joint[k] >= 0.5 * top and per_joint[k] > 0)
    return PathEvent(kind=kind, how=how, sample=float(sample),
                     arc_length=float((1 - fraction) * arc[i] + fraction * arc[j]),
                     position=position, distance=float(np.min(distance[first:last + 2])),
                     joint_speed=peak, blow_up=peak / median if median > 0 else float("inf"),
                     racing_joints=racing)
