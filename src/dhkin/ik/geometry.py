"""Geometry of a table at q = 0, and structural conditions measured as numbers.

Joint axes are taken from the table's exact chain (corrections included) at q = 0, in DH frame 0:
joint i turns about z_{i-1} (standard DH) or z_i (modified DH), right-handed about
``direction_i * z``. A family's structure (axes parallel, perpendicular, meeting in a point) is a
list of :class:`Condition` values; the same list decides an exact fit (tight tolerances) and a
fit within the band of the family (:mod:`dhkin.ik.family`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import DHTable

Vector = NDArray[np.float64]


@dataclass(frozen=True)
class JointAxis:
    """A joint axis at q = 0 in DH frame 0: a point on it and its unit DH z direction (positive
    ``direction * q`` turns right-handed about it)."""

    point: Vector
    direction: Vector


def joint_axes(table: DHTable, q: ArrayLike, frame: Literal["base_link", "dh0"] = "base_link"
               ) -> tuple[Vector, Vector]:
    """Points o_k (N, n, 3) and unit directions z_k (N, n, 3) of the joint axes at q (N, n), in
    base_link or in DH frame 0 (``frame="dh0"``): the one joint-axis function of dhkin.

    Axis k is the z axis of DH frame k-1 (standard DH) or k (modified DH), oriented so that
    increasing theta_k turns right-handed about it (multiply by ``direction`` for q_k).
    """
    frames = table.fk_frames(q, None if frame == "base_link" else np.eye(4))
    first = 0 if table.convention == "standard" else 1
    chosen = frames[:, first:first + table.dof]
    return chosen[..., :3, 3], chosen[..., :3, 2]


def zero_configuration(table: DHTable) -> tuple[list[JointAxis], NDArray[np.float64]]:
    """Joint axes of ``table`` at q = 0 in DH frame 0 (:func:`joint_axes`) and M = DH frame 0 ->
    DH frame n at q = 0."""
    zero = np.zeros((1, table.dof))
    points, directions = joint_axes(table, zero, "dh0")
    axes = [JointAxis(point=points[0, i].copy(), direction=directions[0, i].copy())
            for i in range(table.dof)]
    return axes, table.fk_frames(zero, np.eye(4))[0, -1]


def table_scale(table: DHTable) -> float:
    """Length scale of a table (m): the sum of its |a| and |d| values and prismatic strokes."""
    total = 0.0
    for joint in table.joints:
        total += abs(joint.a) + abs(joint.d)
        if not joint.is_revolute:
            total += max(abs(joint.lower), abs(joint.upper)) + abs(joint.offset)
    return max(total, 1e-3)


def line_distance(first: JointAxis, second: JointAxis) -> float:
    """Shortest distance between two lines (m)."""
    normal = np.cross(first.direction, second.direction)
    offset = second.point - first.point
    norm = float(np.linalg.norm(normal))
    if norm < 1e-12:  # parallel: distance of a point from the other line
        return float(np.linalg.norm(offset - np.dot(offset, first.direction) * first.direction))
    return abs(float(np.dot(offset, normal))) / norm


def separation(first: JointAxis, second: JointAxis) -> float:
    """How far apart two (nearly) parallel axes are where the arm is: the distance of the second
    axis's point from the first line (m). :func:`line_distance` would give the common normal's
    length, which for lines a few microradians from parallel can meet far away."""
    return point_line_distance(second.point, first)


def point_line_distance(point: Vector, axis: JointAxis) -> float:
    """Distance of ``point`` from the line ``axis`` (m)."""
    offset = point - axis.point
    return float(np.linalg.norm(offset - np.dot(offset, axis.direction) * axis.direction))


def common_point(axes: Sequence[JointAxis]) -> Vector:
    """Least-squares point nearest to all lines."""
    normal_matrix = np.zeros((3, 3))
    rhs = np.zeros(3)
    for axis in axes:
        projector = np.eye(3) - np.outer(axis.direction, axis.direction)
        normal_matrix += projector
        rhs += projector @ axis.point
    return np.asarray(np.linalg.lstsq(normal_matrix, rhs, rcond=None)[0], dtype=np.float64)


def closest_point(first: JointAxis, second: JointAxis) -> Vector:
    """Midpoint of the common perpendicular of two non-parallel lines."""
    w1, w2 = first.direction, second.direction
    offset = second.point - first.point
    b = float(np.dot(w1, w2))
    denominator = 1.0 - b * b
    s = (np.dot(offset, w1) - b * np.dot(offset, w2)) / denominator
    t = (b * np.dot(offset, w1) - np.dot(offset, w2)) / denominator
    return 0.5 * ((first.point + s * w1) + (second.point + t * w2))


def abs_cos(first: Vector, second: Vector) -> float:
    return abs(float(np.dot(first, second)))


def abs_sin(first: Vector, second: Vector) -> float:
    return float(np.linalg.norm(np.cross(first, second)))


Kind = Literal["angle", "length"]


@dataclass(frozen=True)
class Condition:
    """One structural condition of a family, measured on a table.

    ``value`` is |cos| or |sin| of an angle between axes (``kind`` "angle") or a distance in
    metres ("length"). ``ideal`` "zero": the family needs it to be 0 (perpendicular, parallel,
    meeting); "positive": it must not vanish (distinct axes, a real upper arm).
    """

    what: str
    value: float
    kind: Kind
    ideal: Literal["zero", "positive"]


@dataclass(frozen=True)
class Tolerance:
    """Largest |cos| / |sin| (``angle``) and distance in metres (``length``) that count as 0."""

    angle: float
    length: float

    def of(self, kind: Kind) -> float:
        return self.angle if kind == "angle" else self.length


def problems(conditions: Sequence[Condition], tolerance: Tolerance) -> list[str]:
    """The conditions that fail at ``tolerance``, in words with the measured values."""
    out = []
    for c in conditions:
        limit = tolerance.of(c.kind)
        unit = " m" if c.kind == "length" else ""
        if c.ideal == "zero" and not c.value <= limit:
            out.append(f"{c.what}: {c.value:.3g}{unit}, expected <= {limit:.3g}{unit}")
        elif c.ideal == "positive" and not c.value > limit:
            out.append(f"{c.what}: {c.value:.3g}{unit}, expected > {limit:.3g}{unit}")
    return out


def deviation(conditions: Sequence[Condition]) -> tuple[float, float]:
    """Largest value of the "zero" conditions: (angle, length)."""
    angle = max([c.value for c in conditions if c.ideal == "zero" and c.kind == "angle"],
                default=0.0)
    length = max([c.value for c in conditions if c.ideal == "zero" and c.kind == "length"],
                 default=0.0)
    return angle, length


def type_conditions(table: DHTable, expected: str) -> list[str]:
    """Joint count and types, ``expected`` like "RRPRRR" (R revolute, P prismatic): the
    mismatches in words (these are not measured: a table has the types or not)."""
    if table.dof != len(expected):
        return [f"expected {len(expected)} joints, got {table.dof}"]
    out = []
    for index, (joint, kind) in enumerate(zip(table.joints, expected, strict=True)):
        wanted = "revolute" if kind == "R" else "prismatic"
        if joint.type != wanted:
            out.append(f"joint {index + 1} ({joint.name}) is {joint.type}, expected {wanted}")
    return out


def spherical_wrist_conditions(axes: Sequence[JointAxis]) -> list[Condition]:
    """Axes 4, 5, 6 (0-based 3, 4, 5) meet in one point, 4 perpendicular to 5, 5 to 6."""
    axis4, axis5, axis6 = axes[3], axes[4], axes[5]
    centre = common_point([axis4, axis5, axis6])
    spread = max(point_line_distance(centre, a) for a in (axis4, axis5, axis6))
    return [
        Condition("axes 4, 5, 6 meet in one point (largest distance of the nearest point)",
                  spread, "length", "zero"),
        Condition("axes 4 and 5 perpendicular (|cos|)", abs_cos(axis4.direction, axis5.direction),
                  "angle", "zero"),
        Condition("axes 5 and 6 perpendicular (|cos|)", abs_cos(axis5.direction, axis6.direction),
                  "angle", "zero"),
    ]


# --------------------------------------------------------------------------------------------
# Singularity factors: what each family module computes (see dhkin.singularity.model)

#: The factors of det J of N configurations, each (N,): (constant, shoulder, elbow, wrist,
#: shoulder distance, elbow distance) with det J = constant * shoulder * elbow * wrist.
FactorArrays = tuple[Vector, Vector, Vector, Vector, Vector, Vector]


def dots(a: Vector, b: Vector) -> Vector:
    """Dot products along the last axis (batched)."""
    return np.asarray(np.sum(a * b, axis=-1), dtype=np.float64)


def closest_points(p1: Vector, z1: Vector, p2: Vector, z2: Vector) -> Vector:
    """Midpoints of the shortest segments between lines (p1, z1) and (p2, z2) (unit z, not
    parallel), batched over leading axes."""
    w0 = p1 - p2
    b = dots(z1, z2)
    d = dots(z1, w0)
    e = dots(z2, w0)
    denominator = 1.0 - b * b
    t1 = (b * e - d) / denominator
    t2 = (e - b * d) / denominator
    return np.asarray(0.5 * ((p1 + t1[..., None] * z1) + (p2 + t2[..., None] * z2)),
                      dtype=np.float64)


def wrist_and_shoulder(o: Vector, z: Vector, point: Vector) -> tuple[Vector, Vector, Vector]:
    """The geometric wrist factor z4 . (z5 x z6), the shoulder factor (z1 x (point - o1)) . z2
    and the shoulder distance |shoulder| / |z1 x z2| of N configurations (o, z: (N, 6, 3) joint
    axes; point (N, 3): the family's wrist centre or wrist point)."""
    o1 = o[:, 0]
    z1, z2, z4, z5, z6 = z[:, 0], z[:, 1], z[:, 3], z[:, 4], z[:, 5]
    wrist = dots(z4, np.cross(z5, z6))
    shoulder = dots(np.cross(z1, point - o1), z2)
    axis_12 = np.linalg.norm(np.cross(z1, z2), axis=-1)
    return wrist, shoulder, np.abs(shoulder) / axis_12


def elbow_distance(o: Vector, z: Vector, elbow: Vector) -> Vector:
    """|elbow factor| / the distance between the parallel axes 2 and 3 (m), N configurations."""
    between = o[:, 2] - o[:, 1]
    z2 = z[:, 1]
    axis_23 = np.linalg.norm(between - dots(between, z2)[:, None] * z2, axis=-1)
    return np.asarray(np.abs(elbow) / axis_23, dtype=np.float64)


def standard_rows(table: DHTable) -> tuple[list[float], list[float], list[float]]:
    """a_k, sin(alpha_k) and sign(cos(alpha_k)), 1-based (index 0 unused), of a standard table."""
    a = [0.0] + [j.a for j in table.joints]
    s_alpha = [0.0] + [math.sin(j.alpha) for j in table.joints]
    c_alpha = [0.0] + [math.copysign(1.0, math.cos(j.alpha)) for j in table.joints]
    return a, s_alpha, c_alpha


#: Relative tolerance of an exact structure (|cos|, |sin|; x the table scale in m): an ideal
#: model fits its family, and a table's closed-form singularity factors apply, to this.
EXACT_RELATIVE = 1e-9


def exact_tolerance(table: DHTable) -> Tolerance:
    """The tolerance of an exact structure: :data:`EXACT_RELATIVE` in |cos| / |sin|, that times
    the table scale in metres."""
    return Tolerance(EXACT_RELATIVE, EXACT_RELATIVE * table_scale(table))
