"""Closed-form IK of 6R arms with an ortho-parallel R-R-R arm and a spherical wrist.

The family covers the IRB 1200, the KUKA/FANUC/Puma class and the anthropomorphic arm of seed 003:
axis 1 perpendicular to axis 2, axis 2 parallel to axis 3 (the arm), axes 4, 5, 6 meeting in one
point, the wrist centre, with axis 4 perpendicular to 5 and 5 perpendicular to 6 (the wrist). The
arm may have a shoulder offset a1 (axis 2 off axis 1), a lateral offset b (the wrist centre off the
arm plane along axis 2, seed 003's d2), any upper arm, elbow offset (a3) and forearm (d4); any
joint offsets and directions, standard or modified DH, any base and tool transform.

How it works (everything in DH frame 0, metres and radians):

* **Geometry, not layout.** The solver reads the joint axes of the table at q = 0 (product of
  exponentials: ``T(q) = E1(q1) ... E6(q6) M``, where ``Ei`` turns about joint i's axis at q = 0
  by ``direction_i * q_i`` and ``M`` = DH frame 0 -> DH frame n at q = 0). The joint axis of row i
  is z_{i-1} (standard DH) or z_i (modified DH). From the axes it derives the shoulder frame
  (axis 1 ``k`` = "up", arm-plane direction ``f`` = "forward", axis-2 direction ``u``), the
  shoulder offset a1, the lateral offset b, and the upper arm and forearm as planar vectors.
* **Position.** The wrist centre w = T_dh @ (wrist centre in DH frame n). Turning about axis 1
  must bring the arm-plane point (X, b) to w's coordinates across axis 1, so
  ``X = +-sqrt(r^2 - b^2)`` (r = distance of w from axis 1): two shoulder branches. In the arm
  plane a 2R problem (law of cosines) gives two elbow branches.
* **Orientation.** With q1..q3 known the wrist must produce ``R456 = R123^T R_target M_R^T``; in a
  frame with z along axis 4 and y along axis 5 this is a ZYZ Euler problem (two wrist branches,
  ``(q4 + pi, -q5, q6 + pi)`` is the flip). q6 is computed from the remainder
  ``Ry(-theta) Rz(-alpha) H``, so the pose stays exact even where q4 alone is ill-conditioned.

Singularities (flags from :mod:`dhkin.ik.result`):

* wrist: |sin| of the angle between axes 4 and 6 <= :data:`SINGULAR_FLAG_TOLERANCE`; below
  :data:`WRIST_SNAP_TOLERANCE` the wrist is taken as exactly singular: q4 comes from ``q_seed``
  and q6 carries the sum (seed 000), and the flip branch is the same with q4 + pi;
* shoulder: the wrist centre within SINGULAR_FLAG_TOLERANCE * scale of the plane of axes 1 and 2
  (X = 0, where the two q1 branches merge; with b = 0 that is the wrist centre on axis 1). On axis
  1 (within SNAP_TOLERANCE * scale, b = 0) q1 is free and comes from ``q_seed``;
* elbow: |sin| of the angle between upper arm and forearm (measured from stretched) <=
  SINGULAR_FLAG_TOLERANCE: the arm stretched or folded, where the two elbow branches merge.

Within SNAP_TOLERANCE * scale of a workspace boundary (scale: :func:`table_scale`) the wrist
centre counts as on it: slightly outside, the square root's argument is clamped to 0; slightly
inside, the two merging branches are returned once (the other branch is marked invalid). Either
moves the pose by at most that distance, far below the pipeline's verification tolerance.

Configuration labels (seed 000, section 2, generalised from its IRB 1200 table to any geometry):

* shoulder: "lefty" when the wrist centre lies on the forward side of axis 1 (seed 000 2.1:
  p'_x >= 0, the wrist centre's x in the frame turned by q1), "righty" when behind. "Forward" is
  the side where the wrist centre is at q = 0 (the x axis of DH frame 1 when that is undecided).
  Seed 000 section 3 contradicts 2.1 (it calls the forward q1 = atan2(e_y, e_x) "righty" when
  q2 > 0); section 2 is the definition used here.
* elbow: lefty: "up" when the elbow lies above the shoulder -> wrist-centre line (for the IRB 1200
  that is q3 > -atan(d4/a3), seed 000 2.2); righty: the other way round. "Above" is towards
  base_link +z along axis 1.
* wrist: lefty: "noflip" when q5 > 0, "flip" when q5 < 0; righty: the other way round (seed 000
  2.3). q5 is measured from the position where axes 4 and 6 are parallel in the same sense.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.errors import FamilyError
from dhkin.ik.closed_form import Branches, CompiledSolver
from dhkin.ik.result import ELBOW, SHOULDER, WRIST

FAMILY = "spherical_wrist"
#: Structural conditions hold within this tolerance: |cos| or |sin| of angles between axes, and
#: distances between axes in units of :func:`table_scale` (so 1e-9 means 1 nm on a 1 m arm).
GEOMETRY_TOLERANCE = 1e-9
#: Within this distance (times the table scale) of a workspace boundary a wrist centre counts as
#: exactly on it (see the module docstring). Rounding puts a target built on a boundary ~1e-16 x
#: scale off it; a branch snapped onto the boundary moves by at most ~4e-7 rad in joint space.
SNAP_TOLERANCE = 1e-14
#: Below this |sin| of the angle between axes 4 and 6 (computed from the target) the wrist counts
#: as exactly singular: q5 is set to the singular value and q4 comes from the seed, which turns
#: the pose by at most this angle (rad). A pose built with q5 = 0 computes as ~1e-16 x the arm's
#: conditioning off it: up to ~1e-12 rad near a stretched elbow, more within ~1e-5 rad of one.
WRIST_SNAP_TOLERANCE = 1e-10
#: Singularity flags are set within this |sin| (wrist, elbow) or distance times scale (shoulder).
SINGULAR_FLAG_TOLERANCE = 1e-6

Vector = NDArray[np.float64]


# --------------------------------------------------------------------------------------------
# Geometry of a table at q = 0


@dataclass(frozen=True)
class JointAxis:
    """A joint axis at q = 0 in DH frame 0: a point on it and its unit direction (the DH z axis
    of the joint, so that increasing ``direction * q`` turns it right-handed about it)."""

    point: Vector
    direction: Vector


def zero_configuration(table: DHTable) -> tuple[list[JointAxis], NDArray[np.float64]]:
    """Joint axes of ``table`` at q = 0 and M = DH frame 0 -> DH frame n at q = 0."""
    links = table.link_transforms(np.zeros((1, table.dof)))[0]
    frames = [np.eye(4)]
    for link in links:
        frames.append(frames[-1] @ link)
    first = 0 if table.convention == "standard" else 1  # joint i turns about z_{i-1} or z_i
    axes = [JointAxis(point=frames[i + first][:3, 3].copy(),
                      direction=frames[i + first][:3, 2].copy()) for i in range(table.dof)]
    return axes, frames[-1]


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


def point_line_distance(point: Vector, axis: JointAxis) -> float:
    """Distance of ``point`` from the line ``axis`` (m)."""
    offset = point - axis.point
    return float(np.linalg.norm(offset - np.dot(offset, axis.direction) * axis.direction))


def common_point(axes: Sequence[JointAxis]) -> Vector:
    """Least-squares point nearest to all lines (the wrist centre of a spherical wrist)."""
    normal_matrix = np.zeros((3, 3))
    rhs = np.zeros(3)
    for axis in axes:
        projector = np.eye(3) - np.outer(axis.direction, axis.direction)
        normal_matrix += projector
        rhs += projector @ axis.point
    return np.linalg.lstsq(normal_matrix, rhs, rcond=None)[0]


def abs_cos(first: Vector, second: Vector) -> float:
    return abs(float(np.dot(first, second)))


def abs_sin(first: Vector, second: Vector) -> float:
    return float(np.linalg.norm(np.cross(first, second)))


def type_problems(table: DHTable, expected: str) -> list[str]:
    """Joint count and types: ``expected`` like "RRPRRR" (R revolute, P prismatic)."""
    if table.dof != len(expected):
        return [f"expected {len(expected)} joints, got {table.dof}"]
    problems = []
    for index, (joint, kind) in enumerate(zip(table.joints, expected, strict=True)):
        wanted = "revolute" if kind == "R" else "prismatic"
        if joint.type != wanted:
            problems.append(f"joint {index + 1} ({joint.name}) is {joint.type}, expected {wanted}")
    return problems


def wrist_problems(axes: Sequence[JointAxis], scale: float) -> list[str]:
    """Spherical-wrist conditions on axes 4, 5, 6 (0-based 3, 4, 5)."""
    tol = GEOMETRY_TOLERANCE
    axis4, axis5, axis6 = axes[3], axes[4], axes[5]
    problems = []
    centre = common_point([axis4, axis5, axis6])
    spread = max(point_line_distance(centre, a) for a in (axis4, axis5, axis6))
    if spread > tol * scale:
        problems.append(f"axes 4, 5, 6 do not meet in one point: nearest point is {spread:.3g} m "
                        f"from one of them, expected <= {tol * scale:.3g} m "
                        f"({tol:g} x scale {scale:.3g} m)")
    for name, first, second in (("4 and 5", axis4, axis5), ("5 and 6", axis5, axis6)):
        cosine = abs_cos(first.direction, second.direction)
        if cosine > tol:
            problems.append(f"axes {name} are not perpendicular: |cos| = {cosine:.3g}, "
                            f"expected <= {tol:g}")
    return problems


def shoulder_problems(axes: Sequence[JointAxis]) -> list[str]:
    """Axis 1 perpendicular to axis 2."""
    cosine = abs_cos(axes[0].direction, axes[1].direction)
    if cosine > GEOMETRY_TOLERANCE:
        return [f"axes 1 and 2 are not perpendicular: |cos| = {cosine:.3g}, expected <= "
                f"{GEOMETRY_TOLERANCE:g}"]
    return []


def arm_problems(axes: Sequence[JointAxis], wrist_centre: Vector, scale: float) -> list[str]:
    """Ortho-parallel arm: axis 2 parallel to axis 3, non-degenerate upper arm and forearm."""
    tol = GEOMETRY_TOLERANCE
    problems = shoulder_problems(axes)
    sine = abs_sin(axes[1].direction, axes[2].direction)
    if sine > tol:
        problems.append(f"axes 2 and 3 are not parallel: |sin| = {sine:.3g}, expected <= {tol:g}")
        return problems
    upper_arm = line_distance(axes[1], axes[2])
    if upper_arm <= tol * scale:
        problems.append(f"axes 2 and 3 coincide (distance {upper_arm:.3g} m): no upper arm")
    forearm = point_line_distance(wrist_centre, axes[2])
    if forearm <= tol * scale:
        problems.append(f"the wrist centre lies on axis 3 (distance {forearm:.3g} m): no forearm")
    return problems


# --------------------------------------------------------------------------------------------
# Batched rotations


def axis_rotation(axis: Vector, angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotations about a fixed unit ``axis`` (3,) by angles of any shape S -> S + (3, 3)."""
    c, s = np.cos(angle)[..., None, None], np.sin(angle)[..., None, None]
    x, y, z = axis
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return c * np.eye(3) + s * cross + (1.0 - c) * np.outer(axis, axis)


# --------------------------------------------------------------------------------------------
# The shoulder: axis 1 and the arm plane


@dataclass(frozen=True)
class Shoulder:
    """Axis 1 and the arm plane at q = 0, in DH frame 0.

    ``origin`` is the foot on axis 1 of the common normal to axis 2; ``(forward, lateral, up)`` is
    a right-handed frame with ``up`` = axis 1's direction, ``lateral`` = ±axis 2's direction and
    ``forward`` = lateral x up, pointing to the side of axis 1 where the wrist centre is at q = 0.
    Axis 2 meets the plane through ``origin`` normal to ``lateral`` at ``forward * shoulder_offset``
    (a1). ``lateral_offset`` is b: the wrist centre's coordinate along ``lateral``.
    """

    origin: Vector
    forward: Vector
    lateral: Vector
    up: Vector
    shoulder_offset: float
    lateral_offset: float

    def coordinates(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """(..., 3) points -> (..., 3) coordinates along (forward, lateral, up) from ``origin``."""
        basis = np.stack([self.forward, self.lateral, self.up])
        return (points - self.origin) @ basis.T

    def planar(self, point: Vector) -> complex:
        """Arm-plane coordinates of a point at q1 = 0 as ``height + 1j * reach``, measured from axis
        2 (height along ``up``, reach along ``forward``)."""
        forward, _, up = self.coordinates(point)
        return complex(up, forward - self.shoulder_offset)


def make_shoulder(axes: Sequence[JointAxis], wrist_centre: Vector,
                  references: Sequence[Vector], scale: float) -> Shoulder:
    """The shoulder frame; ``references`` are points (q = 0) whose side of axis 1 is "forward",
    tried in order until one lies off the plane of axes 1 and 2 (callers pass a point on DH
    frame 1's x axis last, see :func:`frame_one_x_point`)."""
    up = axes[0].direction
    lateral = axes[1].direction - np.dot(axes[1].direction, up) * up
    lateral /= np.linalg.norm(lateral)
    forward = np.cross(lateral, up)
    origin = axes[0].point + np.dot(axes[1].point - axes[0].point, up) * up
    sign = 1.0
    for reference in references:
        side = float(np.dot(reference - origin, forward))
        if abs(side) > GEOMETRY_TOLERANCE * scale:
            sign = 1.0 if side > 0 else -1.0
            break
    forward, lateral = sign * forward, sign * lateral
    shoulder_offset = float(np.dot(axes[1].point - origin, forward))
    lateral_offset = float(np.dot(wrist_centre - origin, lateral))
    return Shoulder(origin, forward, lateral, up, shoulder_offset, lateral_offset)


@dataclass(frozen=True)
class ShoulderSolution:
    """Per pose (N,) and shoulder branch (front, back) -> (N, 2): the turn of axis 1 about
    ``up`` (rad), the wrist centre's arm-plane target ``height + 1j * reach`` from axis 2,
    validity and the SHOULDER flag."""

    turn: NDArray[np.float64]
    target: NDArray[np.complex128]
    valid: NDArray[np.bool_]
    flags: NDArray[np.uint8]


def solve_shoulder(shoulder: Shoulder, wrist_centre: NDArray[np.float64],
                   seed_turn: NDArray[np.float64], scale: float) -> ShoulderSolution:
    """Both q1 branches for wrist centres (N, 3); ``seed_turn`` (N,) is used on axis 1.

    Turning about axis 1 by phi maps the arm-plane point (X, b) to the wrist centre's coordinates
    (x, y) across axis 1: X = +-sqrt(r^2 - b^2), phi = atan2(y, x) - atan2(b, X).
    """
    x, y, height = np.moveaxis(shoulder.coordinates(wrist_centre), -1, 0)
    b = shoulder.lateral_offset
    radius = np.hypot(x, y)
    gap = radius - abs(b)  # >= 0 when reachable across axis 1
    snap = SNAP_TOLERANCE * scale
    reachable = gap >= -snap
    merged = np.abs(gap) <= snap
    on_axis = radius <= snap
    forward_reach = np.where(merged, 0.0, np.sqrt(np.maximum(gap, 0.0) * (radius + abs(b))))
    reach = np.stack([forward_reach, -forward_reach], axis=1)
    turn = np.arctan2(y, x)[:, None] - np.arctan2(b, reach)
    seeded = np.stack([seed_turn, seed_turn + np.pi], axis=1)
    turn = np.where(on_axis[:, None], seeded, turn)
    valid = np.stack([reachable, reachable & (on_axis | ~merged)], axis=1)
    near = merged | (np.abs(forward_reach) <= SINGULAR_FLAG_TOLERANCE * scale)
    flags = np.where(near, SHOULDER, 0).astype(np.uint8)
    target = height[:, None] + 1j * (reach - shoulder.shoulder_offset)
    return ShoulderSolution(turn=turn, target=target, valid=valid,
                            flags=np.repeat(flags[:, None], 2, axis=1))


def explain_shoulder(shoulder: Shoulder, wrist_centre: Vector, scale: float) -> str:
    """Why a wrist centre cannot be reached across axis 1, or ""."""
    x, y, _ = shoulder.coordinates(wrist_centre)
    radius = float(np.hypot(x, y))
    b = abs(shoulder.lateral_offset)
    if radius - b < -SNAP_TOLERANCE * scale:
        return (f"wrist centre {radius:.4g} m from axis 1, closer than the lateral offset "
                f"{b:.4g} m")
    return ""


# --------------------------------------------------------------------------------------------
# The spherical wrist


@dataclass(frozen=True)
class Wrist:
    """Axes 4, 5, 6 at q = 0 as a ZYZ Euler problem.

    ``frame`` has columns (x, y, z) with z = axis 4 and y = axis 5 (DH directions); axis 6 is
    ``frame @ Ry(tilt) @ e_z``. Then ``Rot(a4, t4) Rot(a5, t5) Rot(a6, t6) = frame @ Rz(t4)
    Ry(t5 + tilt) Rz(t6) Ry(-tilt) @ frame.T`` with t_i = direction_i * q_i.
    """

    frame: NDArray[np.float64]
    tilt: float
    directions: tuple[int, int, int]
    centre: Vector  # wrist centre at q = 0, DH frame 0
    centre_in_flange: Vector  # the same point in DH frame n (constant)


def make_wrist(table: DHTable, axes: Sequence[JointAxis],
               flange_zero: NDArray[np.float64]) -> Wrist:
    """The wrist of ``table`` from its axes at q = 0 and M (DH frame 0 -> DH frame n at q = 0)."""
    axis4, axis5, axis6 = axes[3], axes[4], axes[5]
    z = axis4.direction
    y = axis5.direction - np.dot(axis5.direction, z) * z
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    frame = np.stack([x, y, z], axis=1)
    local6 = frame.T @ axis6.direction
    tilt = float(np.arctan2(local6[0], local6[2]))
    centre = common_point([axis4, axis5, axis6])
    centre_in_flange = flange_zero[:3, :3].T @ (centre - flange_zero[:3, 3])
    directions = (table.joints[3].direction, table.joints[4].direction,
                  table.joints[5].direction)
    return Wrist(frame, tilt, directions, centre, centre_in_flange)


def wrist_centres(wrist: Wrist, T_dh: NDArray[np.float64]) -> NDArray[np.float64]:
    """Wrist centres (N, 3) in DH frame 0 of flange targets T_dh (N, 4, 4)."""
    return T_dh[:, :3, 3] + T_dh[:, :3, :3] @ wrist.centre_in_flange


def solve_wrist(wrist: Wrist, wrist_rotation: NDArray[np.float64],
                seed_q4: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    """q4, q5, q6 of both wrist branches for required rotations ``R456`` (..., 3, 3).

    Returns joint values (..., 2, 3) (branch 0: sin(t5 + tilt) >= 0, branch 1: its flip) and
    flags (...,). ``seed_q4`` (...) is used where the wrist is exactly singular.
    """
    d4, d5, d6 = wrist.directions
    F = wrist.frame
    tilt_back = axis_rotation(np.array([0.0, 1.0, 0.0]), np.array(wrist.tilt))
    H = F.T @ wrist_rotation @ F @ tilt_back  # = Rz(t4) Ry(theta) Rz(t6), theta = t5 + tilt
    sine = np.hypot(H[..., 0, 2], H[..., 1, 2])
    singular = sine <= WRIST_SNAP_TOLERANCE
    sine = np.where(singular, 0.0, sine)
    theta = np.arctan2(sine, H[..., 2, 2])
    alpha = np.where(singular, d4 * seed_q4, np.arctan2(H[..., 1, 2], H[..., 0, 2]))
    ca, sa = np.cos(alpha), np.sin(alpha)
    ct, st = np.cos(theta), np.sin(theta)
    # Ry(-theta) Rz(-alpha) H = Rz(gamma): gamma from its first column
    gamma = np.arctan2(-sa * H[..., 0, 0] + ca * H[..., 1, 0],
                       ct * (ca * H[..., 0, 0] + sa * H[..., 1, 0]) - st * H[..., 2, 0])
    first = np.stack([d4 * alpha, d5 * (theta - wrist.tilt), d6 * gamma], axis=-1)
    flipped = np.stack([d4 * (alpha + np.pi), d5 * (-theta - wrist.tilt), d6 * (gamma + np.pi)],
                       axis=-1)
    flags = np.where(np.hypot(H[..., 0, 2], H[..., 1, 2]) <= SINGULAR_FLAG_TOLERANCE, WRIST, 0)
    return np.stack([first, flipped], axis=-2), flags.astype(np.uint8)


def wrist_rotations(arm_rotation: NDArray[np.float64], T_dh: NDArray[np.float64],
                    flange_zero: NDArray[np.float64]) -> NDArray[np.float64]:
    """R456 = R123^T R_target M_R^T for arm rotations (N, B, 3, 3) and targets (N, 4, 4)."""
    target = T_dh[:, :3, :3] @ flange_zero[:3, :3].T
    return np.swapaxes(arm_rotation, -1, -2) @ target[:, None]


def compiled_geometry(shoulder: Shoulder, wrist: Wrist, flange_zero: NDArray[np.float64],
                      arm_signs: tuple[float, float, float], scale: float,
                      arm: tuple[float, ...]) -> NDArray[np.float64]:
    """Geometry vector of the compiled solvers (dhkin.ik.kernels.arm_geometry): the shoulder,
    the wrist, the tolerances of this module and the family's ``arm`` values."""
    from dhkin.ik import kernels

    return kernels.arm_geometry(
        centre_in_flange=wrist.centre_in_flange, origin=shoulder.origin,
        forward=shoulder.forward, lateral=shoulder.lateral, up=shoulder.up,
        shoulder_offset=shoulder.shoulder_offset, lateral_offset=shoulder.lateral_offset,
        signs=arm_signs, wrist_frame=wrist.frame, flange_rotation=flange_zero[:3, :3],
        tilt=wrist.tilt, wrist_directions=wrist.directions, scale=scale, snap=SNAP_TOLERANCE,
        wrist_snap=WRIST_SNAP_TOLERANCE, flag=SINGULAR_FLAG_TOLERANCE, arm=arm)


# --------------------------------------------------------------------------------------------
# The elbow: a 2R problem in the arm plane


@dataclass(frozen=True)
class ElbowSolution:
    """Per pose and (shoulder, elbow) branch (N, 2, 2): turns of axes 2 and 3 about ``lateral``
    (rad), validity and the ELBOW flag."""

    turn2: NDArray[np.float64]
    turn3: NDArray[np.float64]
    valid: NDArray[np.bool_]
    flags: NDArray[np.uint8]


def solve_elbow(upper_arm: complex, forearm: complex, target: NDArray[np.complex128],
                seed_turn2: NDArray[np.float64], scale: float) -> ElbowSolution:
    """Both elbow branches reaching arm-plane targets (N, 2) (``height + 1j * reach`` from axis
    2); a turn t about ``lateral`` multiplies arm-plane points by exp(1j t).

    With psi the angle from the upper arm to the forearm, |target|^2 = L2^2 + L3^2 +
    2 L2 L3 cos(psi); then t3 = psi - psi_0 and t2 = arg(target) - arg(upper + exp(1j t3) fore).
    ``seed_turn2`` (N, 1) is used when the target is on axis 2 (folded arm with L2 = L3).
    """
    upper, fore = abs(upper_arm), abs(forearm)
    bend_at_zero = float(np.angle(forearm / upper_arm))
    distance = np.abs(target)
    outer = (upper + fore) - distance  # >= 0 inside the outer reach
    inner = distance - abs(upper - fore)  # >= 0 outside the inner reach
    snap = SNAP_TOLERANCE * scale
    reachable = (outer >= -snap) & (inner >= -snap)
    merged = (np.abs(outer) <= snap) | (np.abs(inner) <= snap)
    # (2 L2 L3 sin psi)^2 as a product of factors: accurate near both boundaries
    sine_squared = (np.maximum(outer, 0.0) * (upper + fore + distance)
                    * np.maximum(inner, 0.0) * (distance + abs(upper - fore)))
    sine_scaled = np.where(merged, 0.0, np.sqrt(sine_squared))
    cosine_scaled = distance**2 - upper**2 - fore**2
    psi = np.arctan2(np.stack([sine_scaled, -sine_scaled], axis=-1), cosine_scaled[..., None])
    turn3 = psi - bend_at_zero
    wrist_before_turn2 = upper_arm + np.exp(1j * turn3) * forearm
    turn2 = np.angle(target[..., None] * np.conj(wrist_before_turn2))
    on_axis_2 = distance <= snap
    turn2 = np.where(on_axis_2[..., None], seed_turn2[..., None], turn2)
    valid = np.stack([reachable, reachable & ~merged], axis=-1)
    near = merged | (sine_scaled <= SINGULAR_FLAG_TOLERANCE * 2 * upper * fore)
    flags = np.repeat(np.where(near, ELBOW, 0)[..., None], 2, axis=-1).astype(np.uint8)
    return ElbowSolution(turn2=turn2, turn3=turn3, valid=valid, flags=flags)


# --------------------------------------------------------------------------------------------
# Configuration labels


def up_sign(table: DHTable, up: Vector) -> float:
    """+1 when axis 1's direction points along base_link +z (or is horizontal), else -1."""
    return -1.0 if float((table.base[:3, :3] @ up)[2]) < 0 else 1.0


def shoulder_label(front: bool) -> str:
    return "lefty" if front else "righty"


def wrist_label(front: bool, q5_positive: bool) -> str:
    return "noflip" if q5_positive == front else "flip"


# --------------------------------------------------------------------------------------------
# The family


@dataclass(frozen=True)
class ArmGeometry:
    """Everything the solver needs, derived from the table at q = 0."""

    axes: tuple[JointAxis, ...]
    flange_zero: NDArray[np.float64]
    scale: float
    shoulder: Shoulder
    wrist: Wrist
    upper_arm: complex  # axis 3 relative to axis 2, arm plane at q = 0 (height + 1j * reach)
    forearm: complex  # wrist centre relative to axis 3, same plane
    arm_signs: tuple[float, float, float]  # t_i = sign_i * q_i: turn about up, lateral, lateral


def fit_problems(table: DHTable) -> list[str]:
    """The structural conditions of this family that ``table`` fails (empty list: it fits).

    Conditions: 6 revolute joints; axis 1 perpendicular to axis 2; axis 2 parallel to axis 3
    (distinct axes); axes 4, 5, 6 meeting in one point off axis 3; axis 4 perpendicular to 5 and
    5 to 6. Tolerance :data:`GEOMETRY_TOLERANCE` (|cos|, |sin|; distances times the table scale).
    """
    problems = type_problems(table, "RRRRRR")
    if problems:
        return problems
    axes, _ = zero_configuration(table)
    scale = table_scale(table)
    problems = wrist_problems(axes, scale)
    centre = common_point(axes[3:6])
    return problems + arm_problems(axes, centre, scale)


def make_geometry(table: DHTable) -> ArmGeometry:
    """The solver's geometry of a table that fits (see :func:`fit_problems`)."""
    axes, flange_zero = zero_configuration(table)
    scale = table_scale(table)
    wrist = make_wrist(table, axes, flange_zero)
    shoulder = make_shoulder(axes, wrist.centre,
                             [wrist.centre, axes[2].point, frame_one_x_point(table, axes)], scale)
    upper_arm = shoulder.planar(axes[2].point)
    forearm = shoulder.planar(wrist.centre) - upper_arm
    directions = [table.joints[i].direction for i in range(3)]
    signs = (directions[0] * 1.0,
             directions[1] * float(np.sign(np.dot(axes[1].direction, shoulder.lateral))),
             directions[2] * float(np.sign(np.dot(axes[2].direction, shoulder.lateral))))
    return ArmGeometry(tuple(axes), flange_zero, scale, shoulder, wrist, upper_arm, forearm,
                       signs)


def frame_one_x_point(table: DHTable, axes: Sequence[JointAxis]) -> Vector:
    """A point one metre along DH frame 1's x axis (q = 0) from axis 1: the last "forward"
    reference, seed 000's x' axis for its table."""
    link = table.link_transforms(np.zeros((1, table.dof)))[0][0]
    return axes[0].point + link[:3, 0]


def _bend_labels(table: DHTable, geometry: ArmGeometry) -> list[tuple[bool, str]]:
    """(front, elbow label) for the four (shoulder, elbow) branches."""
    up = up_sign(table, geometry.shoulder.up)
    labels = []
    for front in (True, False):
        for bend in (1.0, -1.0):
            # bend > 0: forearm turned from the upper arm towards "forward" in the (up, forward)
            # plane, which puts the elbow above the shoulder -> wrist line when it points forward
            above = (bend * up > 0) == front
            labels.append((front, "up" if above else "down"))
    return labels


class Solver(CompiledSolver):
    """Closed-form IK of one table of this family (the BranchSolver of ik/closed_form.py).

    Eight branches, index ``4 * shoulder + 2 * elbow + wrist``, with shoulder 0 = forward side
    (X >= 0), elbow 0 = bend > 0 (see :func:`_bend_labels`), wrist 0 = sin(t5 + tilt) >= 0.
    """

    family = FAMILY

    def __init__(self, table: DHTable) -> None:
        problems = fit_problems(table)
        if problems:
            raise FamilyError(f"{table.name}: not a {FAMILY} arm: " + "; ".join(problems))
        self.table = table
        self.geometry = make_geometry(table)
        labels: list[Mapping[str, str]] = []
        q5_sign_of_first_wrist = self.geometry.wrist.directions[1] > 0
        for front, elbow in _bend_labels(table, self.geometry):
            for q5_positive in (q5_sign_of_first_wrist, not q5_sign_of_first_wrist):
                labels.append({"shoulder": shoulder_label(front), "elbow": elbow,
                               "wrist": wrist_label(front, q5_positive)})
        self.branch_labels: tuple[Mapping[str, str], ...] = tuple(labels)

    @cached_property
    def _compiled(self) -> tuple[int, NDArray[np.float64]]:
        """The compiled twin of :meth:`solve` (dhkin.ik.kernels.solve_spherical_wrist): its
        family id and geometry vector."""
        from dhkin.ik import kernels

        g = self.geometry
        arm = (g.upper_arm.real, g.upper_arm.imag, g.forearm.real, g.forearm.imag,
               abs(g.upper_arm), abs(g.forearm), float(np.angle(g.forearm / g.upper_arm)))
        return kernels.SPHERICAL_WRIST, compiled_geometry(g.shoulder, g.wrist, g.flange_zero,
                                                          g.arm_signs, g.scale, arm)

    def solve_reference(self, T_dh: NDArray[np.float64], q_seed: NDArray[np.float64]
                        ) -> Branches:
        """:meth:`solve` in numpy, vectorised over N: the reference the compiled kernel follows
        (tests compare the two; they differ by rounding, and where the pose leaves joints
        ill-conditioned, e.g. q4 and q6 near q5 = 0, by as much as it allows)."""
        g = self.geometry
        n_poses = T_dh.shape[0]
        centre = wrist_centres(g.wrist, T_dh)
        s1, s2, s3 = g.arm_signs
        shoulder = solve_shoulder(g.shoulder, centre, s1 * q_seed[:, 0], g.scale)
        elbow = solve_elbow(g.upper_arm, g.forearm, shoulder.target, s2 * q_seed[:, 1, None],
                            g.scale)
        turn1 = np.repeat(shoulder.turn[:, :, None], 2, axis=2)  # (N, shoulder, elbow)
        arm_rotation = (axis_rotation(g.shoulder.up, turn1)
                        @ axis_rotation(g.shoulder.lateral, elbow.turn2 + elbow.turn3))
        arm_rotation = arm_rotation.reshape(n_poses, 4, 3, 3)
        required = wrist_rotations(arm_rotation, T_dh, g.flange_zero)
        wrist_q, wrist_flags = solve_wrist(g.wrist, required, np.repeat(q_seed[:, 3:4], 4, 1))
        q = np.empty((n_poses, 4, 2, 6))
        q[..., 0] = (s1 * turn1).reshape(n_poses, 4)[..., None]
        q[..., 1] = (s2 * elbow.turn2).reshape(n_poses, 4)[..., None]
        q[..., 2] = (s3 * elbow.turn3).reshape(n_poses, 4)[..., None]
        q[..., 3:] = wrist_q
        arm_valid = shoulder.valid[:, :, None] & elbow.valid
        arm_flags = shoulder.flags[:, :, None] | elbow.flags
        valid = np.repeat(arm_valid.reshape(n_poses, 4, 1), 2, axis=2)
        flags = arm_flags.reshape(n_poses, 4, 1) | wrist_flags[..., None]
        return Branches(q=q.reshape(n_poses, 8, 6), valid=valid.reshape(n_poses, 8),
                        flags=np.repeat(flags, 2, axis=2).reshape(n_poses, 8).astype(np.uint8))

    def explain(self, T_dh: NDArray[np.float64]) -> str:
        """Why one flange target (4, 4) has no solution, or "" when the geometry has some."""
        g = self.geometry
        centre = wrist_centres(g.wrist, T_dh[None])[0]
        reason = explain_shoulder(g.shoulder, centre, g.scale)
        if reason:
            return reason
        shoulder = solve_shoulder(g.shoulder, centre[None], np.zeros(1), g.scale)
        distances = np.abs(shoulder.target[0])
        longest, shortest = abs(g.upper_arm) + abs(g.forearm), abs(abs(g.upper_arm)
                                                                    - abs(g.forearm))
        snap = SNAP_TOLERANCE * g.scale
        if np.any((distances <= longest + snap) & (distances >= shortest - snap)):
            return ""
        where = (f"{distances[0]:.4g} m" if np.isclose(distances[0], distances[1])
                 else f"{distances[0]:.4g} m (lefty) / {distances[1]:.4g} m (righty)")
        if np.all(distances > longest):
            return f"wrist centre {where} from the shoulder (axis 2), reach {longest:.4g} m"
        return (f"wrist centre {where} from the shoulder (axis 2), inside the inner reach "
                f"{shortest:.4g} m")
