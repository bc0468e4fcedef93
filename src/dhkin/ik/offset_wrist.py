"""The offset-wrist family: the UR family (CB3, e-series), the AUBO i-series, Techman.

Geometry (all in DH frame 0 at q = 0): six revolute joints; the axes of joints 2, 3 and 4 are
parallel (same or opposite sense, as on the AUBO, whose alpha2 = alpha3 = 180 deg) and distinct;
axis 1 is perpendicular to them; axis 5 is perpendicular to axis 4; axis 6 is perpendicular to
axis 5 and meets it in the *wrist point*. Nothing else is assumed: joint offsets, directions,
a1 != 0, a4 != 0, either DH convention, and zero or non-zero d5, d6 all work, because the solver
works from the joint axes, not from one DH layout.

Method (product of exponentials, compiled in ``cpp/dhkin/offset.hpp``):
``T = E1(q1) ... E6(q6) M`` with ``E_i`` the rotation by q_i about joint axis i at q = 0 (its
direction multiplied by the joint's ``direction``) and ``M`` the DH flange at q = 0.

1. q1: joints 2-6 never move the wrist point along the common direction ``n`` of axes 2-4, so
   ``n(q1) . (p - r1) = c`` (c: the lateral offset, d2 + d3 + d4 on a UR table): two roots.
2. q5: ``n(q1) . z6 = cos(q5 - psi)``; the sine is taken as the norm of a cross product, so q5
   keeps its absolute accuracy (~1e-16) for tiny angles (no arccos).
3. q6: rotation about axis 6 taking ``L^T n`` to ``R5^T n``; at the wrist singularity q6 is free.
4. q2, q3, q4: what remains, ``G = E1^-1 T M^-1 E6^-1 E5^-1``, is a planar motion about ``n``:
   the law of cosines for q3, a planar rotation for q2, the rotation angle of G for q4. G is
   matched exactly (rotation and one point), so an ill-determined q6 costs no exactness.

Free joints (taken from the seed where that verifies): q6 at the wrist singularity, q1 with the
wrist point on axis 1 (only without a lateral offset), q2 with axis 4 on axis 2 (equal upper arm
and forearm).

Branches (8): shoulder lefty/righty x elbow up/down x wrist noflip/flip, in that nesting order
(the words of every family: :data:`dhkin.ik.result.LABEL_WORDS`). Labels are geometric, with
``up`` the z axis of joint 1 and the *reach* the horizontal direction from axis 1 to the wrist
point, past the lateral offset:

* shoulder ``lefty``: facing along the reach, the lateral offset (the link stack along ``n``) is
  on the left; ``righty``: on the right. With no lateral offset (c = 0): ``lefty`` = reach along
  ``n x up``.
* elbow ``up``: the elbow (axis 3) lies above the line from axis 2 to axis 4, "above" meaning
  towards ``up`` when that line is turned to point along the reach.
* wrist ``noflip``: sin(q5 - q5s) > 0 (``flip``: < 0), with q5s the singular value of q5 (axis 6
  parallel to axis 4) nearest to 0 (q5s = 0 on UR and AUBO tables).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.ik.core import OFFSET_WRIST, geometry_fields
from dhkin.ik.geometry import (
    Condition,
    FactorArrays,
    Vector,
    abs_cos,
    abs_sin,
    closest_point,
    closest_points,
    dots,
    elbow_distance,
    exact_tolerance,
    line_distance,
    separation,
    standard_rows,
    table_scale,
    type_conditions,
    wrist_and_shoulder,
    zero_configuration,
)
from dhkin.ik.spherical_wrist import Solved

FAMILY = "offset_wrist"
#: Joints (0-based) a singularity leaves free: wrist (q6), elbow (q2), shoulder (q1).
FREE_JOINTS = (5, 1, 0)
BRANCH_LABELS: tuple[dict[str, str], ...] = tuple(
    {"shoulder": shoulder, "elbow": elbow, "wrist": wrist}
    for shoulder in ("lefty", "righty") for elbow in ("up", "down") for wrist in ("noflip", "flip")
)


def structure(table: DHTable) -> tuple[list[str], list[Condition]]:
    """(joint type problems, measured structural conditions) of this family on ``table``."""
    wrong = type_conditions(table, "RRRRRR")
    if wrong:
        return wrong, []
    axes, _ = zero_configuration(table)
    w = [a.direction for a in axes]
    return [], [
        Condition("axes 2 and 3 parallel (|sin|)", abs_sin(w[1], w[2]), "angle", "zero"),
        Condition("axes 3 and 4 parallel (|sin|)", abs_sin(w[2], w[3]), "angle", "zero"),
        Condition("axes 2 and 3 apart (upper arm)", separation(axes[1], axes[2]), "length",
                  "positive"),
        Condition("axes 3 and 4 apart (forearm)", separation(axes[2], axes[3]), "length",
                  "positive"),
        Condition("axes 1 and 2 perpendicular (|cos|)", abs_cos(w[0], w[1]), "angle", "zero"),
        Condition("axes 4 and 5 perpendicular (|cos|)", abs_cos(w[3], w[4]), "angle", "zero"),
        Condition("axes 5 and 6 perpendicular (|cos|)", abs_cos(w[4], w[5]), "angle", "zero"),
        Condition("axes 5 and 6 meet (distance)", line_distance(axes[4], axes[5]), "length",
                  "zero"),
    ]


def _in_plane(x: NDArray[np.float64], normal: NDArray[np.float64]) -> NDArray[np.float64]:
    """Component of x normal to the unit vector ``normal``."""
    return x - (x @ normal) * normal


def build(table: DHTable) -> Solved:
    """The compiled solver's geometry of a table of this family (its ideal model)."""
    axes, home = zero_configuration(table)
    scale = table_scale(table)
    signed = [a.direction * j.direction for a, j in zip(axes, table.joints, strict=True)]
    points = np.array([a.point for a in axes])
    directions = np.array(signed)
    n = directions[1]
    wrist_point = closest_point(axes[4], axes[5])
    home_inverse = np.linalg.inv(home)
    upper_arm = _in_plane(points[2] - points[1], n)
    forearm = _in_plane(points[3] - points[2], n)
    psi = float(np.arctan2(np.dot(n, np.cross(directions[4], directions[5])),
                           np.dot(n, directions[5])))
    q5_singular = float(psi - np.pi * np.round(psi / np.pi))
    plane_x = _in_plane(directions[0], n)
    plane_x /= np.linalg.norm(plane_x)
    lateral = float(np.dot(n, wrist_point - points[0]))
    lateral = lateral if abs(lateral) > 1e-12 * scale else 0.0
    lateral_sign = -1.0 if lateral < 0 else 1.0
    alpha = float(np.dot(upper_arm, forearm))
    beta = float(np.dot(upper_arm, np.cross(directions[2], forearm)))
    values = {
        "directions": directions, "points": points, "n": n, "side": np.cross(directions[0], n),
        "plane_x": plane_x, "plane_y": np.cross(n, plane_x),
        "wrist_in_flange": home_inverse[:3, :3] @ wrist_point + home_inverse[:3, 3],
        "wrist_point": wrist_point, "home_rotation": home[:3, :3],
        "home_inverse": home_inverse[:3, :], "upper_arm": upper_arm, "forearm": forearm,
        "axis3_x_forearm": np.cross(directions[2], forearm), "lateral": lateral,
        "left_sign": lateral_sign * float(np.dot(directions[0], axes[0].direction)),
        "lateral_sign": lateral_sign,
        "up_sign": 1.0 if np.cos(q5_singular - psi) > 0 else -1.0, "psi": psi,
        "sign3": float(np.sign(np.dot(directions[2], n))),
        "sign4": float(np.sign(np.dot(directions[3], n))),
        "upper_length": float(np.linalg.norm(upper_arm)),
        "forearm_length": float(np.linalg.norm(forearm)),
        "elbow_alpha": alpha, "elbow_base": float(np.arctan2(beta, alpha)),
        "elbow_turn": float(np.dot(np.cross(upper_arm, forearm), n)), "scale": scale,
        "spread": 0.0,
    }
    L2, L3 = values["upper_length"], values["forearm_length"]
    return Solved(FAMILY, OFFSET_WRIST, geometry_fields(values), BRANCH_LABELS, FREE_JOINTS,
                  (abs(L2 - L3), L2 + L3), scale)


def explain(solved: Solved, why: NDArray[np.float64], clamp: float) -> str:
    """Why the geometry has no solution, from the solver's ``why`` numbers (the wrist point's
    distance from axis 1, the least it needs, the arm span of each shoulder/wrist branch); ""
    when it has one."""
    distance, needed = float(why[0]), float(why[1])
    if distance < needed - clamp:
        return (f"the wrist point (where axes 5 and 6 meet) is {distance:.6g} m from axis 1; "
                f"the lateral offset needs at least {needed:.6g} m")
    spans = why[2:6][np.isfinite(why[2:6])]
    low, high = solved.reach
    if spans.size and np.all((spans > high + clamp) | (spans < low - clamp)):
        where = ("beyond" if np.all(spans > high) else "inside" if np.all(spans < low)
                 else "outside")
        listed = ", ".join(f"{s:.6g}" for s in sorted({float(f'{v:.9g}') for v in spans}))
        return (f"axis 4 would have to be {listed} m from axis 2 (per shoulder/wrist branch), "
                f"{where} the arm's reach [{low:.6g}, {high:.6g}] m")
    return ""


# --------------------------------------------------------------------------------------------
# Singularity factors (dhkin.singularity.model documents the mathematics)


def singularity_closed_form(table: DHTable) -> bool:
    """Whether the standard-DH closed forms of the factors apply (axes 2, 3, 4 parallel through
    alpha2, alpha3 = 0 or pi; the wrist point at DH frame 5's origin: a4 = a5 = 0)."""
    exact = exact_tolerance(table)
    angle, length = exact.angle, exact.length
    rows = table.joints
    return (table.convention == "standard" and abs(np.sin(rows[1].alpha)) <= angle
            and abs(np.sin(rows[2].alpha)) <= angle and abs(rows[3].a) <= length
            and abs(rows[4].a) <= length)


def singularity_factors(table: DHTable, theta: Vector, d: Vector, product: float
                        ) -> FactorArrays:
    """The closed-form factors of N configurations (theta, d: (N, 6) DH variables; product:
    the product of the joint directions)."""
    a, s_alpha, c_alpha = standard_rows(table)
    t = [np.zeros(len(theta))] + [theta[:, k] for k in range(6)]
    k2, k3 = c_alpha[2], c_alpha[3]
    d5 = table.joints[4].d
    wrist = s_alpha[4] * s_alpha[5] * np.sin(t[5])
    phi = t[2] + k2 * t[3]
    psi = phi + k2 * k3 * t[4]
    x_p = a[2] * np.cos(t[2]) + a[3] * np.cos(phi) + k2 * k3 * s_alpha[4] * d5 * np.sin(psi)
    shoulder = -s_alpha[1] * (a[1] + x_p)
    elbow = k2 * a[2] * a[3] * np.sin(t[3])
    constant = np.full(len(theta), k2 * product)
    return (constant, shoulder, elbow, wrist, np.abs(shoulder) / abs(s_alpha[1]),
            np.abs(a[3] * np.sin(t[3])))


def geometric_singularity_factors(o: Vector, z: Vector, product: float) -> FactorArrays:
    """The factors from the joint axes (points o, directions z: (N, 6, 3), any convention)."""
    o2, o3, o4, o5, o6 = (o[:, k] for k in range(1, 6))
    z2, z3, z5, z6 = z[:, 1], z[:, 2], z[:, 4], z[:, 5]
    point = closest_points(o5, z5, o6, z6)
    wrist, shoulder, shoulder_distance = wrist_and_shoulder(o, z, point)
    elbow = dots(z2, np.cross(o2 - o3, o3 - o4))
    constant = np.sign(dots(z2, z3)) * product
    return constant, shoulder, elbow, wrist, shoulder_distance, elbow_distance(o, z, elbow)
