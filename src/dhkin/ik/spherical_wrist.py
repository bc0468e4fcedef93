"""The spherical-wrist family: 6R arms with an ortho-parallel R-R-R arm and a spherical wrist.

The family covers the IRB 1200, the KUKA/FANUC/Puma class and the textbook anthropomorphic arm:
axis 1 perpendicular to axis 2, axis 2 parallel to axis 3 (the arm), axes 4, 5, 6 meeting in one
point, the wrist centre, with axis 4 perpendicular to 5 and 5 perpendicular to 6 (the wrist). The
arm may have a shoulder offset a1 (axis 2 off axis 1), a lateral offset b (the wrist centre off the
arm plane along axis 2), any upper arm, elbow offset (a3) and forearm (d4); any
joint offsets and directions, standard or modified DH, any base and tool transform.

This module reads the geometry of a table (its ideal model, see :mod:`dhkin.ik.family`) for the
compiled solver (``cpp/dhkin/spherical.hpp``), names the branches and
explains targets without a solution. How the solver works (everything in DH frame 0):

* **Geometry, not layout.** The joint axes at q = 0 (product of exponentials: ``T(q) = E1(q1)
  ... E6(q6) M``) give the shoulder frame (axis 1 ``up``, arm-plane direction ``forward``, axis-2
  direction ``lateral``), the shoulder offset a1, the lateral offset b, and the upper arm and
  forearm as planar vectors.
* **Position.** The wrist centre w = T_dh @ (wrist centre in DH frame n). Turning about axis 1
  must bring the arm-plane point (X, b) to w's coordinates across axis 1, so
  ``X = +-sqrt(r^2 - b^2)``: two shoulder branches. In the arm plane a 2R problem (law of
  cosines) gives two elbow branches.
* **Orientation.** With q1..q3 known the wrist must produce ``R456 = R123^T R_target M_R^T``; in a
  frame with z along axis 4 and y along axis 5 this is a ZYZ Euler problem (two wrist branches,
  ``(q4 + pi, -q5, q6 + pi)`` is the flip). q6 comes from the remainder ``Ry(-theta) Rz(-alpha)
  H``, so the pose stays exact even where q4 alone is ill-conditioned.

Free joints (taken from the seed where that verifies, see :mod:`dhkin.ik.solver`): q4
at the wrist singularity (axes 4 and 6 parallel: only q4 +- q6 is fixed), q1 with the wrist
centre on axis 1 (b = 0), q2 with the wrist centre on axis 2 (equal upper arm and forearm,
folded).

Configuration labels (ABB's IRB 1200 convention, generalised to any geometry; the words are
:data:`dhkin.ik.result.LABEL_WORDS`):

* shoulder: "lefty" when the wrist centre lies on the forward side of axis 1 (its x in the frame
  turned by q1 is >= 0), "righty" when behind. "Forward" is the side where the wrist centre is at
  q = 0 (the x axis of DH frame 1 when that is undecided).
* elbow: lefty: "up" when the elbow lies above the shoulder -> wrist-centre line (for the IRB 1200
  that is q3 > -atan(d4/a3)); righty: the other way round. "Above" is towards base_link +z along
  axis 1.
* wrist: lefty: "noflip" when q5 > 0, "flip" when q5 < 0; righty: the other way round. q5 is
  measured from the position where axes 4 and 6 are parallel in the same sense.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import DHTable
from dhkin.ik.core import SPHERICAL_WRIST, geometry_fields
from dhkin.ik.geometry import (
    Condition,
    FactorArrays,
    JointAxis,
    Vector,
    abs_cos,
    abs_sin,
    closest_points,
    common_point,
    dots,
    elbow_distance,
    exact_tolerance,
    point_line_distance,
    separation,
    spherical_wrist_conditions,
    standard_rows,
    table_scale,
    type_conditions,
    wrist_and_shoulder,
    zero_configuration,
)

FAMILY = "spherical_wrist"
#: Joints (0-based) a singularity leaves free: wrist (q4), elbow (q2), shoulder (q1).
FREE_JOINTS = (3, 1, 0)


def structure(table: DHTable) -> tuple[list[str], list[Condition]]:
    """(joint type problems, measured structural conditions) of this family on ``table``."""
    wrong = type_conditions(table, "RRRRRR")
    if wrong:
        return wrong, []
    axes, _ = zero_configuration(table)
    centre = common_point(axes[3:6])
    return [], [
        *spherical_wrist_conditions(axes),
        Condition("axes 1 and 2 perpendicular (|cos|)",
                  abs_cos(axes[0].direction, axes[1].direction), "angle", "zero"),
        Condition("axes 2 and 3 parallel (|sin|)", abs_sin(axes[1].direction, axes[2].direction),
                  "angle", "zero"),
        Condition("axes 2 and 3 apart (upper arm)", separation(axes[1], axes[2]), "length",
                  "positive"),
        Condition("wrist centre off axis 3 (forearm)", point_line_distance(centre, axes[2]),
                  "length", "positive"),
    ]


@dataclass(frozen=True)
class Shoulder:
    """Axis 1 and the arm plane at q = 0, in DH frame 0: ``origin`` is the foot on axis 1 of the
    common normal to axis 2; (forward, lateral, up) is right-handed with up = axis 1, lateral =
    +-axis 2 and forward pointing where the wrist centre is at q = 0. Axis 2 meets the plane
    through ``origin`` normal to ``lateral`` at ``forward * shoulder_offset`` (a1);
    ``lateral_offset`` (b) is the wrist centre's coordinate along ``lateral``."""

    origin: Vector
    forward: Vector
    lateral: Vector
    up: Vector
    shoulder_offset: float
    lateral_offset: float

    def planar(self, point: Vector) -> complex:
        """Arm-plane coordinates of a point at q1 = 0 as ``height + 1j * reach`` from axis 2."""
        relative = point - self.origin
        return complex(float(relative @ self.up),
                       float(relative @ self.forward) - self.shoulder_offset)


def make_shoulder(axes: Sequence[JointAxis], wrist_centre: Vector,
                  references: Sequence[Vector], scale: float) -> Shoulder:
    """The shoulder frame; ``references`` are points (q = 0) whose side of axis 1 is "forward",
    tried in order until one lies off the plane of axes 1 and 2."""
    up = axes[0].direction
    lateral = axes[1].direction - np.dot(axes[1].direction, up) * up
    lateral /= np.linalg.norm(lateral)
    forward = np.cross(lateral, up)
    origin = axes[0].point + np.dot(axes[1].point - axes[0].point, up) * up
    sign = 1.0
    for reference in references:
        side = float(np.dot(reference - origin, forward))
        if abs(side) > 1e-9 * scale:
            sign = 1.0 if side > 0 else -1.0
            break
    forward, lateral = sign * forward, sign * lateral
    lateral_offset = float(np.dot(wrist_centre - origin, lateral))
    if abs(lateral_offset) <= 1e-12 * scale:  # rounding of an exact 0: the wrist centre can
        lateral_offset = 0.0                  # then lie on axis 1, where q1 is free
    return Shoulder(origin, forward, lateral, up, float(np.dot(axes[1].point - origin, forward)),
                    lateral_offset)


@dataclass(frozen=True)
class Wrist:
    """Axes 4, 5, 6 at q = 0 as a ZYZ Euler problem: ``frame`` has columns (x, y, z) with z =
    axis 4 and y = axis 5; axis 6 is ``frame @ Ry(tilt) @ e_z``."""

    frame: NDArray[np.float64]
    tilt: float
    directions: tuple[int, int, int]
    centre: Vector            # wrist centre at q = 0, DH frame 0
    centre_in_flange: Vector  # the same point in DH frame n


def make_wrist(table: DHTable, axes: Sequence[JointAxis],
               flange_zero: NDArray[np.float64]) -> Wrist:
    """The wrist from the axes at q = 0 and M (DH frame 0 -> DH frame n at q = 0)."""
    axis4, axis5, axis6 = axes[3], axes[4], axes[5]
    z = axis4.direction
    y = axis5.direction - np.dot(axis5.direction, z) * z
    y /= np.linalg.norm(y)
    frame = np.stack([np.cross(y, z), y, z], axis=1)
    local6 = frame.T @ axis6.direction
    centre = common_point([axis4, axis5, axis6])
    return Wrist(frame, float(np.arctan2(local6[0], local6[2])),
                 (table.joints[3].direction, table.joints[4].direction,
                  table.joints[5].direction),
                 centre, flange_zero[:3, :3].T @ (centre - flange_zero[:3, 3]))


def frame_one_x_point(table: DHTable, axes: Sequence[JointAxis]) -> Vector:
    """A point one metre along DH frame 1's x axis (q = 0) from axis 1: the last "forward"
    reference."""
    link = table.link_transforms(np.zeros((1, table.dof)))[0][0]
    return axes[0].point + link[:3, 0]


def shoulder_wrist_values(shoulder: Shoulder, wrist: Wrist, flange_zero: NDArray[np.float64],
                          signs: Sequence[float], scale: float) -> dict[str, ArrayLike]:
    """The shoulder and wrist fields of the compiled geometry (``SphericalGeometry``,
    cpp/dhkin/spherical.hpp)."""
    c, s = np.cos(wrist.tilt), np.sin(wrist.tilt)
    tilt_back = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return {
        "centre_in_flange": wrist.centre_in_flange, "origin": shoulder.origin,
        "forward": shoulder.forward, "lateral": shoulder.lateral, "up": shoulder.up,
        "shoulder_offset": shoulder.shoulder_offset, "lateral_offset": shoulder.lateral_offset,
        "signs": signs, "wrist_frame": wrist.frame,
        "target_to_wrist": flange_zero[:3, :3].T @ wrist.frame @ tilt_back,
        "tilt": wrist.tilt, "wrist_directions": wrist.directions, "scale": scale,
    }


def up_sign(table: DHTable, up: Vector) -> float:
    """+1 when axis 1's direction points along base_link +z (or is horizontal), else -1."""
    return -1.0 if float((table.base[:3, :3] @ up)[2]) < 0 else 1.0


def shoulder_label(front: bool) -> str:
    return "lefty" if front else "righty"


def wrist_label(front: bool, q5_positive: bool) -> str:
    return "noflip" if q5_positive == front else "flip"


@dataclass(frozen=True)
class Solved:
    """What the pipeline needs of a family on one (ideal) table."""

    family: str
    kernel: int                                 # the core's family id (dhkin.ik.core)
    geometry: Mapping[str, NDArray[np.float64]]  # named values (dhkin.ik.core.geometry_fields)
    branch_labels: tuple[Mapping[str, str], ...]
    free_joints: tuple[int, int, int]
    reach: tuple[float, float]   # the arm's smallest and largest reach (m), for explanations
    scale: float


def build(table: DHTable) -> Solved:
    """The compiled solver's geometry and the branch labels of a table of this family (its
    ideal model: the structure must hold exactly)."""
    axes, flange_zero = zero_configuration(table)
    scale = table_scale(table)
    wrist = make_wrist(table, axes, flange_zero)
    shoulder = make_shoulder(axes, wrist.centre,
                             [wrist.centre, axes[2].point, frame_one_x_point(table, axes)], scale)
    upper_arm = shoulder.planar(axes[2].point)
    forearm = shoulder.planar(wrist.centre) - upper_arm
    d = [table.joints[i].direction for i in range(3)]
    signs = (float(d[0]), d[1] * float(np.sign(np.dot(axes[1].direction, shoulder.lateral))),
             d[2] * float(np.sign(np.dot(axes[2].direction, shoulder.lateral))))
    values = shoulder_wrist_values(shoulder, wrist, flange_zero, signs, scale)
    values.update({
        "upper_arm": (upper_arm.real, upper_arm.imag), "forearm": (forearm.real, forearm.imag),
        "upper_length": abs(upper_arm), "forearm_length": abs(forearm),
        "bend_at_zero": float(np.angle(forearm / upper_arm)),
        "wrist_at_zero": (0.0, 0.0), "slide": (0.0, 0.0), "slide_along": 0.0,
        "slide_offset": 0.0, "spread": 0.0,
    })
    up = up_sign(table, shoulder.up)
    q5_sign_of_first_wrist = wrist.directions[1] > 0
    labels: list[Mapping[str, str]] = []
    for front in (True, False):
        for bend in (1.0, -1.0):
            # bend > 0: forearm turned from the upper arm towards "forward" in the (up, forward)
            # plane, which puts the elbow above the shoulder -> wrist line when it points forward
            elbow = "up" if (bend * up > 0) == front else "down"
            for q5_positive in (q5_sign_of_first_wrist, not q5_sign_of_first_wrist):
                labels.append({"shoulder": shoulder_label(front), "elbow": elbow,
                               "wrist": wrist_label(front, q5_positive)})
    reach = (abs(abs(upper_arm) - abs(forearm)), abs(upper_arm) + abs(forearm))
    return Solved(FAMILY, SPHERICAL_WRIST, geometry_fields(values), tuple(labels), FREE_JOINTS,
                  reach, scale)


def explain(solved: Solved, why: NDArray[np.float64], clamp: float) -> str:
    """Why the geometry has no solution, from the solver's ``why`` numbers (wrist centre
    distance from axis 1, the least it needs, distances from axis 2 front / back); "" when it
    has one (then the joint limits or the verification exclude them)."""
    radius, needed = float(why[0]), float(why[1])
    if radius < needed - clamp:
        return (f"the wrist centre is {radius:.6g} m from axis 1, closer than the lateral offset "
                f"{needed:.6g} m")
    distances = why[2:4][np.isfinite(why[2:4])]
    shortest, longest = solved.reach
    if distances.size and np.all(distances > longest + clamp):
        return (f"the wrist centre is {_listed(distances)} m from the shoulder (axis 2), beyond "
                f"the arm's reach {longest:.6g} m")
    if distances.size and np.all(distances < shortest - clamp):
        return (f"the wrist centre is {_listed(distances)} m from the shoulder (axis 2), inside "
                f"the arm's inner reach {shortest:.6g} m")
    return ""


def _listed(values: NDArray[np.float64]) -> str:
    unique = sorted({float(f"{v:.6g}") for v in values})
    return " / ".join(f"{v:.6g}" for v in unique)


# --------------------------------------------------------------------------------------------
# Singularity factors (dhkin.singularity.model documents the mathematics)


def singularity_closed_form(table: DHTable) -> bool:
    """Whether the standard-DH closed forms of the factors apply (a1 free; axis 2 parallel to 3
    through alpha2 = 0 or pi; the wrist centre at DH frame 4's origin: a4 = a5 = d5 = 0)."""
    exact = exact_tolerance(table)
    angle, length = exact.angle, exact.length
    rows = table.joints
    return (table.convention == "standard" and abs(np.sin(rows[1].alpha)) <= angle
            and abs(rows[3].a) <= length and abs(rows[4].a) <= length
            and abs(rows[4].d) <= length)


def singularity_factors(table: DHTable, theta: Vector, d: Vector, product: float
                        ) -> FactorArrays:
    """The closed-form factors of N configurations (theta, d: (N, 6) DH variables; product:
    the product of the joint directions)."""
    a, s_alpha, c_alpha = standard_rows(table)
    t = [np.zeros(len(theta))] + [theta[:, k] for k in range(6)]
    d4 = table.joints[3].d
    wrist = s_alpha[4] * s_alpha[5] * np.sin(t[5])
    u = a[3] * np.cos(t[3]) + d4 * s_alpha[3] * np.sin(t[3])
    v = a[3] * np.sin(t[3]) - d4 * s_alpha[3] * np.cos(t[3])
    x_w = np.cos(t[2]) * (a[2] + u) - c_alpha[2] * np.sin(t[2]) * v
    shoulder = -s_alpha[1] * (a[1] + x_w)
    elbow = c_alpha[2] * a[2] * v
    constant = np.full(len(theta), c_alpha[2] * product)
    return constant, shoulder, elbow, wrist, np.abs(shoulder) / abs(s_alpha[1]), np.abs(v)


def geometric_singularity_factors(o: Vector, z: Vector, product: float) -> FactorArrays:
    """The factors from the joint axes (points o, directions z: (N, 6, 3), any convention)."""
    o2, o3, o4, o5 = (o[:, k] for k in range(1, 5))
    z2, z3, z4, z5 = (z[:, k] for k in range(1, 5))
    centre = closest_points(o4, z4, o5, z5)
    wrist, shoulder, shoulder_distance = wrist_and_shoulder(o, z, centre)
    elbow = dots(z2, np.cross(centre - o2, centre - o3))
    constant = np.sign(dots(z2, z3)) * product
    return constant, shoulder, elbow, wrist, shoulder_distance, elbow_distance(o, z, elbow)
