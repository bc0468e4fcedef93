"""The Stanford family: an R-R-P arm and a spherical wrist (Spong's Stanford arm).

Conditions: joints revolute, revolute, prismatic, then three revolute joints; axis 1
perpendicular to axis 2; the slide direction of joint 3 perpendicular to axis 2; axes 4, 5, 6
meeting in one point (the wrist centre) with axis 4 perpendicular to 5 and 5 to 6. The slide line
need not meet axis 2, and axes 1 and 2 need not meet (shoulder offset); any joint offsets and
directions, standard or modified DH, any base and tool transform.

The method is that of :mod:`dhkin.ik.spherical_wrist` with the elbow replaced by the slide: in
the arm plane the wrist centre is ``A + t V`` turned about axis 2 (A: wrist centre at q = 0, V:
the slide direction, t = direction_3 * q3), so ``|A + t V| = |target|`` gives
``t = -A.V +- sqrt(|target|^2 - e^2)`` with e the distance of the slide line from axis 2: two
slide branches, "forward" (+) and "backward" (-). With Spong's frames (the built-in
``stanford_arm``) A = 0 and e = 0, so t = +-|target| and only "forward" fits a positive stroke.
Compiled solver: ``solve_stanford`` in cpp/dhkin/spherical.hpp.

Labels: shoulder lefty/righty and wrist noflip/flip as in the spherical-wrist family, slide
forward/backward. Free joints: q4 at the wrist singularity, q1 with the wrist centre on axis 1,
q2 with the wrist centre on axis 2.

A common textbook slip: the wrist-centre equations written as ``d3 s2 = dx c1 + dy s1``,
``-d3 c2 = dz - d1``, ``d2 = dy c1 - dx s1``; with Spong's frames the second is
``d3 c2 = dz - d1`` (the wrist centre z is d1 + d3 c2), so theta2 = atan2(dx c1 + dy s1, dz - d1),
not atan2(..., d1 - dz). ``tests/test_ik_stanford.py`` checks this with Pinocchio.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.ik.core import STANFORD, geometry_fields
from dhkin.ik.geometry import (
    Condition,
    FactorArrays,
    Vector,
    abs_cos,
    closest_points,
    dots,
    exact_tolerance,
    spherical_wrist_conditions,
    standard_rows,
    table_scale,
    type_conditions,
    wrist_and_shoulder,
    zero_configuration,
)
from dhkin.ik.spherical_wrist import (
    Solved,
    frame_one_x_point,
    make_shoulder,
    make_wrist,
    shoulder_label,
    shoulder_wrist_values,
    wrist_label,
)

FAMILY = "stanford"
#: Joints (0-based) a singularity leaves free: wrist (q4), slide line on axis 2 (q2), q1.
FREE_JOINTS = (3, 1, 0)


def structure(table: DHTable) -> tuple[list[str], list[Condition]]:
    """(joint type problems, measured structural conditions) of this family on ``table``."""
    wrong = type_conditions(table, "RRPRRR")
    if wrong:
        return wrong, []
    axes, _ = zero_configuration(table)
    return [], [
        *spherical_wrist_conditions(axes),
        Condition("axes 1 and 2 perpendicular (|cos|)",
                  abs_cos(axes[0].direction, axes[1].direction), "angle", "zero"),
        Condition("slide of joint 3 perpendicular to axis 2 (|cos|)",
                  abs_cos(axes[2].direction, axes[1].direction), "angle", "zero"),
    ]


def build(table: DHTable) -> Solved:
    """The compiled solver's geometry and the branch labels of a table of this family."""
    axes, flange_zero = zero_configuration(table)
    scale = table_scale(table)
    wrist = make_wrist(table, axes, flange_zero)
    slide = axes[2].direction
    mid_stroke = 0.5 * (table.joints[2].lower + table.joints[2].upper)
    references = [wrist.centre, wrist.centre + table.joints[2].direction * mid_stroke * slide,
                  frame_one_x_point(table, axes)]
    shoulder = make_shoulder(axes, wrist.centre, references, scale)
    wrist_at_zero = shoulder.planar(wrist.centre)
    slide_planar = complex(float(np.dot(slide, shoulder.up)),
                           float(np.dot(slide, shoulder.forward)))
    slide_planar /= abs(slide_planar)
    d = [table.joints[i].direction for i in range(3)]
    signs = (float(d[0]), d[1] * float(np.sign(np.dot(axes[1].direction, shoulder.lateral))),
             float(d[2]))
    along_and_offset = np.conj(slide_planar) * wrist_at_zero
    values = shoulder_wrist_values(shoulder, wrist, flange_zero, signs, scale)
    values.update({
        "upper_arm": (0.0, 0.0), "forearm": (0.0, 0.0), "upper_length": 0.0,
        "forearm_length": 0.0, "bend_at_zero": 0.0,
        "wrist_at_zero": (wrist_at_zero.real, wrist_at_zero.imag),
        "slide": (slide_planar.real, slide_planar.imag),
        "slide_along": along_and_offset.real, "slide_offset": abs(along_and_offset.imag),
        "spread": 0.0,
    })
    q5_sign_of_first_wrist = wrist.directions[1] > 0
    labels: list[Mapping[str, str]] = []
    for front in (True, False):
        for slide_label in ("forward", "backward"):
            for q5_positive in (q5_sign_of_first_wrist, not q5_sign_of_first_wrist):
                labels.append({"shoulder": shoulder_label(front), "slide": slide_label,
                               "wrist": wrist_label(front, q5_positive)})
    offset = abs(along_and_offset.imag)
    return Solved(FAMILY, STANFORD, geometry_fields(values), tuple(labels), FREE_JOINTS,
                  (offset, np.inf), scale)


def explain(solved: Solved, why: NDArray[np.float64], clamp: float) -> str:
    """Why the geometry has no solution (too close to axis 1, or to axis 2: nearer than the
    slide line), from the solver's ``why`` numbers; "" when it has one."""
    radius, needed = float(why[0]), float(why[1])
    if radius < needed - clamp:
        return (f"the wrist centre is {radius:.6g} m from axis 1, closer than the lateral offset "
                f"{needed:.6g} m")
    distances = why[2:4][np.isfinite(why[2:4])]
    offset = solved.reach[0]
    if distances.size and np.all(distances < offset - clamp):
        return (f"the wrist centre is {float(distances.min()):.6g} m from axis 2, closer than "
                f"the slide line's distance {offset:.6g} m from it")
    return ""


# --------------------------------------------------------------------------------------------
# Singularity factors (dhkin.singularity.model documents the mathematics; no elbow: the elbow
# factor is the extension e, and its distance NaN)


def singularity_closed_form(table: DHTable) -> bool:
    """Whether the standard-DH closed forms of the factors apply (Spong's frames: a2 = a3 = 0,
    a4 = d4 = 0, a5 = d5 = 0, |sin alpha2| = 1)."""
    exact = exact_tolerance(table)
    angle, length = exact.angle, exact.length
    rows = table.joints
    return (table.convention == "standard" and abs(rows[1].a) <= length
            and abs(rows[2].a) <= length and abs(rows[3].d) <= length
            and abs(rows[3].a) <= length and abs(rows[4].a) <= length
            and abs(rows[4].d) <= length and abs(abs(np.sin(rows[1].alpha)) - 1.0) <= angle)


def singularity_factors(table: DHTable, theta: Vector, d: Vector, product: float
                        ) -> FactorArrays:
    """The closed-form factors of N configurations (theta, d: (N, 6) DH variables; product:
    the product of the joint directions)."""
    a, s_alpha, _ = standard_rows(table)
    t = [np.zeros(len(theta))] + [theta[:, k] for k in range(6)]
    extension = d[:, 2]
    wrist = s_alpha[4] * s_alpha[5] * np.sin(t[5])
    shoulder = -s_alpha[1] * (a[1] + s_alpha[2] * extension * np.sin(t[2]))
    constant = np.full(len(theta), -product)
    return (constant, shoulder, extension, wrist, np.abs(shoulder) / abs(s_alpha[1]),
            np.full(len(theta), np.nan))


def geometric_singularity_factors(o: Vector, z: Vector, product: float) -> FactorArrays:
    """The factors from the joint axes (points o, directions z: (N, 6, 3), any convention)."""
    o2, o4, o5 = o[:, 1], o[:, 3], o[:, 4]
    z2, z3, z4, z5 = (z[:, k] for k in range(1, 5))
    centre = closest_points(o4, z4, o5, z5)
    wrist, shoulder, shoulder_distance = wrist_and_shoulder(o, z, centre)
    meeting = closest_points(o2, z2, centre, z3)
    extension = dots(centre - meeting, z3)
    constant = np.full(len(o), -product)
    return constant, shoulder, extension, wrist, shoulder_distance, np.full(len(o), np.nan)
