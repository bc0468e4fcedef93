"""Closed-form IK of offset-wrist arms: the UR family and the AUBO i-series.

Geometry (checked by :func:`fit_problems`, all in DH frame 0 at q = 0): six revolute joints;
the axes of joints 2, 3 and 4 are parallel (same or opposite sense, as on the AUBO, whose
alpha2 = alpha3 = 180 deg) and distinct; axis 1 is perpendicular to them; axis 5 is perpendicular
to axis 4; axis 6 is perpendicular to axis 5 and meets it in the *wrist point*. Nothing else is
assumed: joint offsets, directions, a1 != 0, a4 != 0, either DH convention, and zero or non-zero
d5, d6 all work, because the solver works from the joint axes, not from one DH layout.

Method (product of exponentials): ``T = E1(q1) ... E6(q6) M`` with ``E_i`` the rotation by q_i
about joint axis i at q = 0 (its direction multiplied by the joint's ``direction``) and ``M`` the
DH flange at q = 0. ``T`` is DH frame 0 -> DH frame 6; lengths in metres, angles in radians, joint
values are URDF joint values q (``theta = direction * q + offset``).

1. q1: joints 2-6 never move the wrist point along the common direction ``n`` of axes 2-4, so
   ``n(q1) . (p - r1) = c`` (c: the lateral offset, d2 + d3 + d4 on a UR table): two roots.
2. q5: ``n(q1) . z6 = cos(q5 - psi)``; the sine is taken as the norm of a cross product, so q5
   keeps its absolute accuracy (~1e-16) for tiny angles (no arccos, no sqrt(1 - cos^2)).
3. q6: rotation about axis 6 taking ``L^T n`` to ``R5^T n``; at the wrist singularity
   (|sin(q5 - psi)| <= :data:`WRIST_SINGULAR_SIN`) q6 is free and taken from the seed.
4. q2, q3, q4: what remains, ``G = E1^-1 T M^-1 E6^-1 E5^-1``, is a planar motion about ``n``:
   the law of cosines for q3, a planar rotation for q2, the rotation angle of G for q4. G is
   matched exactly (rotation and one point), so an ill-determined q6 (near the wrist
   singularity it is fixed only to ~1e-16 / |sin q5|) costs no exactness; where it would put
   axis 4 out of the arm's reach, q6 is turned onto the reach boundary within the band where the
   orientation does not notice (:meth:`Solver._keep_in_reach`).

Branches (8): shoulder left/right x elbow up/down x wrist up/down, in that nesting order. Labels
are geometric, with ``up`` the z axis of joint 1 (DH frame 0's z for standard DH) and the
*reach* the horizontal direction from axis 1 to the wrist point, past the lateral offset:

* shoulder ``left``: facing along the reach, the lateral offset (the link stack along ``n``) is on
  the left; ``right``: on the right. With no lateral offset (c = 0): ``left`` = reach along
  ``n x up``.
* elbow ``up``: the elbow (axis 3) lies above the line from axis 2 to axis 4, "above" meaning
  towards ``up`` when that line is turned to point along the reach.
* wrist ``up``: sin(q5 - q5s) > 0, with q5s the singular value of q5 (axis 6 parallel to axis 4)
  nearest to 0 (q5s = 0 on UR and AUBO tables).

Where two branches meet (shoulder: the wrist point in the plane of axis 1 and ``n``; elbow: arm
stretched or folded; wrist: axis 6 parallel to axis 4) they give one solution: it is kept on the
first label (left / up / up), the twin branch is marked invalid, and the solution is flagged.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.errors import FamilyError
from dhkin.ik.closed_form import Branches, CompiledSolver
from dhkin.ik.result import ELBOW, SHOULDER, WRIST

FAMILY = "offset_wrist"
#: Structural tolerance of :func:`fit_problems`: |sin| of angles between axes, and metres.
FIT_TOLERANCE = 1e-9
#: A reach condition violated by at most this much (m) counts as met: the target sits on the
#: boundary up to rounding. Beyond it the branch is invalid (a tenth of the default FK tolerance).
REACH_TOLERANCE = 1e-10
#: Two shoulder (or elbow) roots closer than twice this angle (rad) are one solution: rounding of
#: a pose on the boundary alone spreads them by ~1e-7 rad; collapsing them moves the pose by
#: less than 1e-12 m (the error is second order in the angle).
MERGE_ANGLE = 1e-6
#: |sin(q5 - q5s)| at or below which the wrist is singular: q5 = q5s (+pi) and q6 comes from the
#: seed. Rounding puts an exactly singular pose at ~1e-16, and up to ~1e-11 near the shoulder
#: singularity, where q1 itself is ill-conditioned; taking q6 from the seed at this threshold moves
#: the pose by at most ~pi * 1e-10 (rad, and m per m of arm), inside the 1e-9 FK check. Above it
#: q6 is solved, and the solution is exact to rounding.
WRIST_SINGULAR_SIN = 1e-10
#: Largest orientation change (rad) allowed when q6 is turned to bring the arm into reach near the
#: wrist singularity (see :meth:`Solver._keep_in_reach`); position moves by at most ~1e-12 m too.
EXACT_BAND = 1e-12
#: Wrist point closer than this (m) to axis 1, or arm point closer to axis 2: that joint is free.
AXIS_TOLERANCE = 1e-12

BRANCH_LABELS: tuple[dict[str, str], ...] = tuple(
    {"shoulder": shoulder, "elbow": elbow, "wrist": wrist}
    for shoulder in ("left", "right") for elbow in ("up", "down") for wrist in ("up", "down")
)


# --------------------------------------------------------------------------------------------
# Geometry of the table


@dataclass(frozen=True)
class JointAxes:
    """Joint axes at q = 0 in DH frame 0: ``directions`` (n, 3) unit vectors, already multiplied
    by each joint's ``direction`` (positive q turns right-handed about them), ``points`` (n, 3)
    one point of each axis line (m), ``up`` (n, 3) the DH z axes without the direction sign, and
    ``home`` (4, 4) the DH flange (frame n) at q = 0."""

    directions: NDArray[np.float64]
    points: NDArray[np.float64]
    up: NDArray[np.float64]
    home: NDArray[np.float64]


def joint_axes(table: DHTable) -> JointAxes:
    """The joint axes of ``table`` at q = 0, in DH frame 0 (standard or modified DH)."""
    A = table.link_transforms(np.zeros(table.dof))[0]
    frames = [np.eye(4)]
    for i in range(table.dof):
        frames.append(frames[-1] @ A[i])
    # standard DH: joint i turns about z of frame i-1; modified (Craig): about z of frame i.
    axis_frames = frames[:-1] if table.convention == "standard" else frames[1:]
    z = np.array([F[:3, 2] for F in axis_frames])
    points = np.array([F[:3, 3] for F in axis_frames])
    direction = np.array([j.direction for j in table.joints], dtype=float)
    return JointAxes(directions=z * direction[:, None], points=points, up=z, home=frames[-1])


def _line_distance(p1: NDArray[np.float64], w1: NDArray[np.float64], p2: NDArray[np.float64],
                   w2: NDArray[np.float64]) -> float:
    """Distance (m) between two lines given by a point and a unit direction each."""
    normal = np.cross(w1, w2)
    if np.linalg.norm(normal) < 1e-12:
        offset = p2 - p1
        return float(np.linalg.norm(offset - np.dot(offset, w1) * w1))
    return float(abs(np.dot(p2 - p1, normal)) / np.linalg.norm(normal))


def _closest_point(p1: NDArray[np.float64], w1: NDArray[np.float64], p2: NDArray[np.float64],
                   w2: NDArray[np.float64]) -> NDArray[np.float64]:
    """Midpoint of the common perpendicular of two non-parallel lines."""
    offset = p2 - p1
    b = np.dot(w1, w2)
    denominator = 1.0 - b * b
    s = (np.dot(offset, w1) - b * np.dot(offset, w2)) / denominator
    t = (b * np.dot(offset, w1) - np.dot(offset, w2)) / denominator
    return 0.5 * ((p1 + s * w1) + (p2 + t * w2))


def fit_problems(table: DHTable) -> list[str]:
    """The structural conditions of the offset-wrist family that ``table`` fails (empty: fits).

    Each problem names the joints, the measured value and the tolerance :data:`FIT_TOLERANCE`
    (|sin| or |cos| of the angle between axes, or metres), measured on the axes at q = 0.
    """
    if table.dof != 6:
        return [f"expected 6 joints, got {table.dof}"]
    prismatic = [j.name for j in table.joints if not j.is_revolute]
    if prismatic:
        return [f"expected 6 revolute joints, got prismatic {prismatic}"]
    axes = joint_axes(table)
    w, p = axes.directions, axes.points
    tol = FIT_TOLERANCE
    problems = []

    def parallel(i: int, k: int) -> None:
        sine = float(np.linalg.norm(np.cross(w[i], w[k])))
        if sine > tol:
            problems.append(f"axes {i + 1} and {k + 1} must be parallel: "
                            f"|sin(angle)| = {sine:.3g} > {tol:g}")
        else:
            gap = _line_distance(p[i], w[i], p[k], w[k])
            if gap <= tol:
                problems.append(f"axes {i + 1} and {k + 1} must be distinct parallel lines: "
                                f"{gap:.3g} m apart <= {tol:g} m")

    def perpendicular(i: int, k: int) -> None:
        cosine = float(abs(np.dot(w[i], w[k])))
        if cosine > tol:
            problems.append(f"axes {i + 1} and {k + 1} must be perpendicular: "
                            f"|cos(angle)| = {cosine:.3g} > {tol:g}")

    parallel(1, 2)
    parallel(2, 3)
    perpendicular(0, 1)
    perpendicular(3, 4)
    perpendicular(4, 5)
    if abs(np.dot(w[4], w[5])) <= tol:
        gap = _line_distance(p[4], w[4], p[5], w[5])
        if gap > tol:
            problems.append(f"axes 5 and 6 must intersect: {gap:.3g} m apart > {tol:g} m")
    return problems


@dataclass(frozen=True)
class OffsetWristGeometry:
    """What the solver needs, derived once from the joint axes (DH frame 0, q = 0, SI units).

    ``n``: direction of axis 2 (axes 3 and 4 are ``sign3 * n``, ``sign4 * n``); ``lateral``: the
    wrist point's offset along ``n`` from axis 1 (c); ``wrist_point``: where axes 5 and 6 meet,
    and ``wrist_in_flange`` the same point in DH flange coordinates; ``upper_arm`` /
    ``forearm``: axis 2 -> axis 3 and axis 3 -> axis 4 projected onto the plane normal to ``n``
    (lengths ``upper_length``, ``forearm_length``); ``psi``: the phase with
    ``n(q1) . z6 = cos(q5 - psi)``; ``q5_singular``: the q5 nearest 0 where axis 6 is parallel
    to axis 4; ``plane_x``: a unit vector normal to ``n`` from which angles about ``n`` are
    measured.
    """

    axes: JointAxes
    home_inverse: NDArray[np.float64]
    n: NDArray[np.float64]
    sign3: float
    sign4: float
    lateral: float
    wrist_point: NDArray[np.float64]
    wrist_in_flange: NDArray[np.float64]
    upper_arm: NDArray[np.float64]
    forearm: NDArray[np.float64]
    upper_length: float
    forearm_length: float
    psi: float
    q5_singular: float
    plane_x: NDArray[np.float64]

    @classmethod
    def from_table(cls, table: DHTable) -> OffsetWristGeometry:
        axes = joint_axes(table)
        w, p = axes.directions, axes.points
        n = w[1]
        wrist_point = _closest_point(p[4], w[4], p[5], w[5])
        home_inverse = np.linalg.inv(axes.home)
        wrist_in_flange = home_inverse[:3, :3] @ wrist_point + home_inverse[:3, 3]
        upper_arm = _in_plane(p[2] - p[1], n)
        forearm = _in_plane(p[3] - p[2], n)
        psi = float(np.arctan2(np.dot(n, np.cross(w[4], w[5])), np.dot(n, w[5])))
        q5_singular = float(psi - np.pi * np.round(psi / np.pi))
        plane_x = _in_plane(w[0], n)
        return cls(axes=axes, home_inverse=home_inverse, n=n,
                   sign3=float(np.sign(np.dot(w[2], n))), sign4=float(np.sign(np.dot(w[3], n))),
                   lateral=float(np.dot(n, wrist_point - p[0])), wrist_point=wrist_point,
                   wrist_in_flange=wrist_in_flange, upper_arm=upper_arm, forearm=forearm,
                   upper_length=float(np.linalg.norm(upper_arm)),
                   forearm_length=float(np.linalg.norm(forearm)), psi=psi,
                   q5_singular=q5_singular, plane_x=plane_x / np.linalg.norm(plane_x))

    @property
    def reach(self) -> tuple[float, float]:
        """Smallest and largest distance (m) of axis 4 from axis 2."""
        return (abs(self.upper_length - self.forearm_length),
                self.upper_length + self.forearm_length)

    def plane_angle(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Angle (rad) about ``n`` of vectors x (..., 3), from ``plane_x``."""
        return np.arctan2(x @ np.cross(self.n, self.plane_x), x @ self.plane_x)


# --------------------------------------------------------------------------------------------
# Batched rotations and screw motions


def _skew(w: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _rotation(axis: NDArray[np.float64], angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotations by ``angle`` (any shape S) about the unit ``axis`` -> S + (3, 3) (Rodrigues)."""
    K = _skew(axis)
    s = np.sin(angle)[..., None, None]
    one_minus_c = (1.0 - np.cos(angle))[..., None, None]
    return np.eye(3) + s * K + one_minus_c * (K @ K)


def _screw(axis: NDArray[np.float64], point: NDArray[np.float64],
           angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rigid motions: rotation by ``angle`` (shape S) about the line (point, axis) -> S + (4, 4)."""
    R = _rotation(axis, angle)
    E = np.zeros((*np.shape(angle), 4, 4))
    E[..., :3, :3] = R
    E[..., :3, 3] = point - R @ point
    E[..., 3, 3] = 1.0
    return E


def _apply(T: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Transform points: T (..., 4, 4), x (..., 3) or (3,) -> (..., 3)."""
    return np.einsum("...ij,...j->...i", T[..., :3, :3], x) + T[..., :3, 3]


def _dot(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.einsum("...i,...i->...", a, b)


def _sign(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """+1 for x >= 0, -1 otherwise (a side must always be chosen)."""
    return np.where(x >= 0, 1.0, -1.0)


# --------------------------------------------------------------------------------------------
# The solver


@dataclass(frozen=True)
class _Shoulder:
    q1: NDArray[np.float64]          # (N, 2): left, right
    reach_side: NDArray[np.float64]  # (N, 2): sign of the wrist point along n x up
    valid: NDArray[np.bool_]         # (N, 2)
    singular: NDArray[np.bool_]      # (N,)
    distance: NDArray[np.float64]    # (N,): wrist point from axis 1 (m)


@dataclass(frozen=True)
class _Wrist:
    q5: NDArray[np.float64]          # (N, 2, 2): shoulder, wrist up/down
    q6: NDArray[np.float64]          # (N, 2, 2)
    sine: NDArray[np.float64]        # (N, 2): |sin(q5 - q5s)|, 0 where singular
    singular: NDArray[np.bool_]      # (N, 2)


@dataclass(frozen=True)
class _Elbow:
    q2: NDArray[np.float64]          # (N, 2, 2, 2): shoulder, wrist, elbow up/down
    q3: NDArray[np.float64]
    q4: NDArray[np.float64]
    valid: NDArray[np.bool_]
    singular: NDArray[np.bool_]      # (N, 2, 2)
    span: NDArray[np.float64]        # (N, 2, 2): axis 2 -> axis 4 in the arm plane (m)


class Solver(CompiledSolver):
    """Closed-form branch solver of the offset-wrist family (see the module docstring).

    ``solve(T_dh, q_seed)`` takes targets DH frame 0 -> DH frame 6, shape (N, 4, 4), and seeds
    (N, 6), and returns 8 branches per pose in the order of :data:`BRANCH_LABELS`, as URDF joint
    values (rad, any 2*pi representation). Vectorised over N: no Python loop over poses.

    The seed supplies a joint that the pose leaves free: q6 at the wrist singularity (or, if
    the seed's q6 would put axis 4 out of the arm's reach, the nearest q6 that does not), q1
    when the wrist point lies on axis 1 (possible only without a lateral offset), q2 when
    axis 4 lies on axis 2 (possible only with equal upper arm and forearm).
    """

    family = FAMILY
    branch_labels = BRANCH_LABELS

    def __init__(self, table: DHTable) -> None:
        problems = fit_problems(table)
        if problems:
            raise FamilyError(f"{table.name}: not an offset-wrist arm: " + "; ".join(problems))
        self.table = table
        self.geometry = OffsetWristGeometry.from_table(table)

    @cached_property
    def _compiled(self) -> tuple[int, NDArray[np.float64]]:
        """The compiled twin of :meth:`solve` (dhkin.ik.kernels.solve_offset_wrist): its family
        id and geometry vector."""
        from dhkin.ik import kernels

        g = self.geometry
        return kernels.OFFSET_WRIST, kernels.offset_wrist_geometry(
            directions=g.axes.directions, points=g.axes.points, up_1=g.axes.up[0], n=g.n,
            plane_x=g.plane_x, wrist_in_flange=g.wrist_in_flange, wrist_point=g.wrist_point,
            home=g.axes.home, home_inverse=g.home_inverse, upper_arm=g.upper_arm,
            forearm=g.forearm, lateral=g.lateral, psi=g.psi, q5_singular=g.q5_singular,
            sign3=g.sign3, sign4=g.sign4, upper_length=g.upper_length,
            forearm_length=g.forearm_length, axis_tolerance=AXIS_TOLERANCE,
            reach_tolerance=REACH_TOLERANCE, merge_angle=MERGE_ANGLE,
            wrist_singular_sin=WRIST_SINGULAR_SIN, exact_band=EXACT_BAND)

    # -- step 1: q1 -------------------------------------------------------------------------

    def _shoulder(self, wrist: NDArray[np.float64], seed_q1: NDArray[np.float64]) -> _Shoulder:
        """Both roots of ``n(q1) . (wrist - r1) = c`` for wrist points (N, 3)."""
        g = self.geometry
        w1, r1, up1 = g.axes.directions[0], g.axes.points[0], g.axes.up[0]
        side = np.cross(w1, g.n)
        h = wrist - r1
        along_n, along_side = h @ g.n, h @ side
        distance = np.hypot(along_n, along_side)
        on_axis = distance <= AXIS_TOLERANCE
        phase = np.where(on_axis, seed_q1, np.arctan2(along_side, along_n))
        c = g.lateral if abs(g.lateral) > AXIS_TOLERANCE else 0.0
        gap = distance - abs(c)
        valid = gap >= -REACH_TOLERANCE
        root = np.sqrt(np.maximum(gap, 0.0) * (distance + abs(c)))
        # merged roots, or the wrist point on axis 1 (only without lateral offset): q1 is free
        singular = valid & ((np.arctan2(root, abs(c)) <= MERGE_ANGLE) | on_axis)
        root = np.where(singular, 0.0, root)
        # sin(q1 - phase) = +-root / distance: the wrist point lies at t = dir1 * (+-root) along
        # n x up, and the shoulder is "left" when c * t > 0 (c = 0: when t > 0).
        lateral_sign = -1.0 if c < 0 else 1.0
        left_sign = lateral_sign * float(np.dot(w1, up1))
        half = np.where(on_axis, 0.0, np.arctan2(root, c))
        q1 = np.stack([phase + left_sign * half, phase - left_sign * half], axis=-1)
        reach_side = np.broadcast_to(np.array([lateral_sign, -lateral_sign]), q1.shape)
        branch_valid = np.stack([valid, valid & ~singular], axis=-1)
        return _Shoulder(q1=q1, reach_side=reach_side, valid=branch_valid, singular=singular,
                         distance=distance)

    # -- steps 2 and 3: q5, q6 --------------------------------------------------------------

    def _wrist(self, T: NDArray[np.float64], q1: NDArray[np.float64],
               seed_q6: NDArray[np.float64]) -> _Wrist:
        """q5 from ``n(q1) . z6 = cos(q5 - psi)``, q6 from the rest of the orientation."""
        g = self.geometry
        w = g.axes.directions
        n_now = _rotation(w[0], q1) @ g.n                              # n(q1), (N, 2, 3)
        # u = L^T n with L = R1^T R_T R_home^T: n(q1) seen from the flange, mapped to q = 0.
        in_flange = np.einsum("nji,nkj->nki", T[:, :3, :3], n_now)    # R_T^T n(q1)
        u = in_flange @ g.axes.home[:3, :3].T                          # (N, 2, 3)
        cosine = u @ w[5]
        sine = np.linalg.norm(np.cross(w[5], u), axis=-1)              # exact for tiny angles
        singular = sine <= WRIST_SINGULAR_SIN
        sine = np.where(singular, 0.0, sine)
        up_sign = 1.0 if np.cos(g.q5_singular - g.psi) > 0 else -1.0
        half = np.arctan2(sine, cosine)
        q5 = g.psi + np.stack([up_sign * half, -up_sign * half], axis=-1)   # (N, 2, 2)
        target = _rotation(w[4], -q5) @ g.n                            # R5^T n
        q6 = _rotation_angle_between(w[5], u[:, :, None, :], target)
        q6 = np.where(singular[..., None], seed_q6[:, None, None], q6)
        return _Wrist(q5=q5, q6=q6, sine=sine, singular=singular)

    def _motions_2_to_4(self, T: NDArray[np.float64], q1: NDArray[np.float64],
                        q5: NDArray[np.float64], q6: NDArray[np.float64]) -> NDArray[np.float64]:
        """G = E1^-1 T M^-1 E6^-1 E5^-1, shape (N, 2, 2, 4, 4): what joints 2-4 must do."""
        axes = self.geometry.axes
        w, p = axes.directions, axes.points
        T_home = T @ self.geometry.home_inverse                        # (N, 4, 4)
        left = _screw(w[0], p[0], -q1)[:, :, None] @ T_home[:, None, None]
        right = _screw(w[5], p[5], -q6) @ _screw(w[4], p[4], -q5)
        return left @ right

    def _keep_in_reach(self, G: NDArray[np.float64], wrist: _Wrist) -> NDArray[np.float64]:
        """q6, moved where the arm cannot reach G's arm point but a nearby q6 lets it.

        Near (or at) the wrist singularity q6 barely changes the orientation: turning it by
        ``delta`` moves the flange by about ``|sin(q5 - q5s)| * delta``. What it does move is the
        arm point (axis 4) on a circle about the wrist point, in the arm plane. When the arm
        point is out of reach, turn q6 the least that brings it onto the reach boundary, provided
        the orientation moves by at most :data:`EXACT_BAND`. This keeps a near-singular pose
        near the elbow boundary solvable, and a seed's q6 at the singularity usable.
        """
        g = self.geometry
        p, n = g.axes.points, g.n
        arm = _in_plane(_apply(G, p[3]) - p[1], n)                   # axis 2 -> arm point
        centre = _in_plane(_apply(G, g.wrist_point) - p[1], n)       # axis 2 -> wrist point
        low, high = g.reach
        span = np.linalg.norm(arm, axis=-1)
        too_far = span > high + REACH_TOLERANCE
        too_near = span < low - REACH_TOLERANCE
        boundary = np.where(too_far, high, low)
        radius = np.linalg.norm(arm - centre, axis=-1)
        distance = np.linalg.norm(centre, axis=-1)
        denominator = 2.0 * distance * radius
        movable = (too_far | too_near) & (denominator > AXIS_TOLERANCE)
        cos_needed = (boundary**2 - distance**2 - radius**2) / np.where(movable, denominator, 1.0)
        movable &= np.abs(cos_needed) <= 1.0
        opening = np.arccos(np.clip(cos_needed, -1.0, 1.0))
        now = g.plane_angle(arm - centre) - g.plane_angle(centre)
        turns = np.stack([_wrap(opening - now), _wrap(-opening - now)], axis=-1)
        turn = np.where(np.abs(turns[..., 0]) <= np.abs(turns[..., 1]), turns[..., 0],
                        turns[..., 1])
        # axis 6 after joints 5 and G, nearly +-n here: turning q6 by delta turns the arm point
        # about n by -sign * delta.
        axis6 = np.einsum("...ij,...j->...i", G[..., :3, :3],
                          _rotation(g.axes.directions[4], wrist.q5) @ g.axes.directions[5])
        delta = -_sign(axis6 @ n) * turn
        exact = np.abs(delta) * wrist.sine[..., None] <= EXACT_BAND
        return np.where(movable & exact, wrist.q6 + delta, wrist.q6)

    # -- step 4: q2, q3, q4 -----------------------------------------------------------------

    def _elbow(self, G: NDArray[np.float64], reach_side: NDArray[np.float64],
               seed_q2: NDArray[np.float64]) -> _Elbow:
        """Planar 3R part for the motions G (N, 2, 2, 4, 4): (shoulder, wrist) -> elbow last."""
        g = self.geometry
        w, p = g.axes.directions, g.axes.points
        n = g.n
        target = _in_plane(_apply(G, p[3]) - p[1], n)                 # (N, 2, 2, 3)
        span = np.linalg.norm(target, axis=-1)
        L2, L3 = g.upper_length, g.forearm_length
        v, u = g.upper_arm, g.forearm
        low, high = g.reach
        outer = high - span
        inner = span - low
        valid = (outer >= -REACH_TOLERANCE) & (inner >= -REACH_TOLERANCE)
        # (L2 L3)^2 - kappa^2 in factored form: accurate near both boundaries
        disc = (np.maximum(outer, 0.0) * (high + span) * np.maximum(inner, 0.0)
                * (span + low)) / 4.0
        root = np.sqrt(disc)
        kappa = (span * span - L2 * L2 - L3 * L3) / 2.0
        singular = valid & (np.arctan2(root, np.abs(kappa)) <= MERGE_ANGLE)
        root = np.where(singular, 0.0, root)
        # v . R(axis 3, q3) u = alpha cos q3 + beta sin q3 = kappa, alpha^2 + beta^2 = (L2 L3)^2
        alpha = float(np.dot(v, u))
        beta = float(np.dot(v, np.cross(w[2], u)))
        half = np.arctan2(root, kappa)
        q3 = np.arctan2(beta, alpha) + np.stack([half, -half], axis=-1)   # (N, 2, 2, 2)
        # elbow "up" when the turn (v x R3 u) . n at the elbow has the sign of the reach side
        turn = np.cos(q3) * float(np.dot(np.cross(v, u), n)) + g.sign3 * np.sin(q3) * alpha
        swap = _sign(turn[..., 0]) != reach_side[:, :, None]
        q3 = np.where(swap[..., None], q3[..., ::-1], q3)
        # q2: the rotation about n taking v + R3 u onto the target
        bent = v + _rotate_in_plane(w[2], u, q3)                      # (N, 2, 2, 2, 3)
        aim = target[..., None, :]
        q2 = np.arctan2(_dot(n, np.cross(bent, aim)), _dot(bent, aim))
        q2 = np.where(np.linalg.norm(bent, axis=-1) <= AXIS_TOLERANCE,
                      seed_q2[:, None, None, None], q2)
        # q4 from the angle of G about n = q2 + sign3 q3 + sign4 q4
        total = g.plane_angle(G[..., :3, :3] @ g.plane_x)[..., None]
        q4 = g.sign4 * (total - q2 - g.sign3 * q3)
        branch_valid = np.stack([valid, valid & ~singular], axis=-1)
        return _Elbow(q2=q2, q3=q3, q4=q4, valid=branch_valid, singular=singular, span=span)

    # -- the BranchSolver protocol ----------------------------------------------------------

    def _solve_parts(self, T: NDArray[np.float64],
                     seed: NDArray[np.float64]) -> tuple[_Shoulder, _Wrist, _Elbow]:
        g = self.geometry
        shoulder = self._shoulder(_apply(T, g.wrist_in_flange), seed[:, 0])
        wrist = self._wrist(T, shoulder.q1, seed[:, 5])
        G = self._motions_2_to_4(T, shoulder.q1, wrist.q5, wrist.q6)
        q6 = self._keep_in_reach(G, wrist)
        if np.any(q6 != wrist.q6):
            wrist = _Wrist(q5=wrist.q5, q6=q6, sine=wrist.sine, singular=wrist.singular)
            G = self._motions_2_to_4(T, shoulder.q1, wrist.q5, wrist.q6)
        return shoulder, wrist, self._elbow(G, shoulder.reach_side, seed[:, 1])

    def solve_reference(self, T_dh: NDArray[np.float64], q_seed: NDArray[np.float64]
                        ) -> Branches:
        """:meth:`solve` in numpy, vectorised over N: the reference the compiled kernel follows
        (tests compare the two; they differ by rounding, and where the pose leaves joints
        ill-conditioned, e.g. q4 and q6 near q5 = 0, by as much as it allows)."""
        T = np.asarray(T_dh, dtype=float)
        seed = np.asarray(q_seed, dtype=float)
        shoulder, wrist, elbow = self._solve_parts(T, seed)
        shape = elbow.q3.shape                                          # (N, 2, 2, 2)
        q = np.stack([
            np.broadcast_to(shoulder.q1[:, :, None, None], shape), elbow.q2, elbow.q3,
            elbow.q4, np.broadcast_to(wrist.q5[..., None], shape),
            np.broadcast_to(wrist.q6[..., None], shape),
        ], axis=-1)
        wrist_valid = np.stack([np.ones_like(wrist.singular), ~wrist.singular], axis=-1)
        valid = shoulder.valid[:, :, None, None] & wrist_valid[..., None] & elbow.valid
        flags = (np.where(shoulder.singular, SHOULDER, 0)[:, None, None, None]
                 | np.where(wrist.singular, WRIST, 0)[:, :, None, None]
                 | np.where(elbow.singular, ELBOW, 0)[..., None])
        flags = np.broadcast_to(flags, shape)
        # (N, shoulder, wrist, elbow) -> (N, shoulder, elbow, wrist) -> (N, 8)
        n_poses = T.shape[0]
        q = np.swapaxes(q, 2, 3).reshape(n_poses, 8, 6)
        valid = np.swapaxes(valid, 2, 3).reshape(n_poses, 8)
        flags = np.swapaxes(flags, 2, 3).reshape(n_poses, 8)
        finite = np.all(np.isfinite(q), axis=-1)
        q = np.where(finite[..., None], q, 0.0)
        return Branches(q=q, valid=valid & finite, flags=flags.astype(np.uint8))

    def explain(self, T_dh: NDArray[np.float64]) -> str:
        """Why the target (4, 4) has no solution, with numbers; "" if some branch exists."""
        T = np.asarray(T_dh, dtype=float)[None]
        g = self.geometry
        shoulder, _, elbow = self._solve_parts(T, np.zeros((1, 6)))
        if not shoulder.valid[0, 0]:
            return (f"the wrist point (where axes 5 and 6 meet) is {shoulder.distance[0]:.6g} m "
                    f"from axis 1; the lateral offset needs at least {abs(g.lateral):.6g} m")
        reachable = elbow.valid & shoulder.valid[:, :, None, None]
        if reachable.any():
            return ""
        low, high = g.reach
        spans = elbow.span[0][shoulder.valid[0]]
        where = ("beyond" if np.all(spans > high) else
                 "inside" if np.all(spans < low) else "outside")
        listed = ", ".join(f"{s:.6g}" for s in np.unique(np.round(spans.ravel(), 9)))
        return (f"axis 4 would have to be {listed} m from axis 2 (per shoulder/wrist branch), "
                f"{where} the arm's reach [{low:.6g}, {high:.6g}] m (upper arm "
                f"{g.upper_length:.6g} m, forearm {g.forearm_length:.6g} m)")


def _wrap(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)


def _in_plane(x: NDArray[np.float64], normal: NDArray[np.float64]) -> NDArray[np.float64]:
    """Component of vectors x (..., 3) normal to the unit vector ``normal``."""
    return x - (x @ normal)[..., None] * normal


def _rotate_in_plane(axis: NDArray[np.float64], x: NDArray[np.float64],
                     angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotate the vector x (3,), perpendicular to the unit axis, by angles (S) -> S + (3,)."""
    return (np.cos(angle)[..., None] * x + np.sin(angle)[..., None] * np.cross(axis, x))


def _rotation_angle_between(axis: NDArray[np.float64], a: NDArray[np.float64],
                            b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angle of the rotation about the unit ``axis`` taking a onto b (broadcast, ... x 3).

    Uses the components normal to the axis, formed explicitly: no cancellation when a and b are
    nearly parallel to the axis (their normal parts are then tiny but still carry the angle).
    """
    a_normal = a - (a @ axis)[..., None] * axis
    b_normal = b - (b @ axis)[..., None] * axis
    return np.arctan2(_dot(axis, np.cross(a_normal, b_normal)), _dot(a_normal, b_normal))
