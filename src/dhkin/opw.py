"""OPW parameters of a DH table (MoveIt's opw_kinematics), and the OPW forward kinematics.

OPW: M. Brandstötter, A. Angerer, M. Hofbaur, "An analytical solution of the inverse kinematics
problem of industrial serial manipulators with an ortho-parallel basis and a spherical wrist"
(Austrian Robotics Workshop 2014). An OPW arm is a 6R arm whose axis 1 is perpendicular to axis 2,
axis 2 parallel to axis 3 and axis 3 perpendicular to axis 4 (the ortho-parallel basis), and whose
axes 4, 5, 6 meet in one point, the wrist centre, with 4 perpendicular to 5 and 5 to 6 (the
spherical wrist). Seven lengths describe it, in the paper's zero pose (the arm straight up along
the OPW base z axis, the arm plane spanned by x and z, axes 2 and 3 along y):

* ``c1``: height of axis 2 above the OPW base origin (along z);
* ``a1``: shoulder offset, axis 1 -> axis 2 (along x);
* ``b``: lateral offset of the arm plane (along y, the direction of axes 2 and 3);
* ``c2``: upper arm, axis 2 -> axis 3 (along z);
* ``a2``: elbow offset, axis 3 -> axis 4 (along x);
* ``c3``: forearm, axis 3 -> the wrist centre (along z, which is axis 4);
* ``c4``: wrist centre -> OPW flange (along axis 6; dhkin puts the OPW flange where tool0
  projects onto axis 6).

Forward kinematics (:func:`opw_fk`; lengths in metres, angles in radians), OPW base -> OPW flange::

    T = Rz(t1) Trans(a1, b, c1) Ry(t2) Trans(0, 0, c2) Ry(t3) Trans(a2, 0, c3)
        Rz(t4) Ry(t5) Rz(t6) Trans(0, 0, c4)

Joint values follow MoveIt's opw_kinematics (its ``forward`` and ``inverse``, also
py-opw-kinematics): the OPW angle of joint i is ``t_i = sign_i * q_i - offset_i`` for the URDF
joint value ``q_i``, so ``q_i = (t_i + offset_i) * sign_i``.

:func:`opw_parameters` reads the parameters off a table's joint axes at q = 0 (corrections,
base and tool included), with the OPW base as close to base_link as the arm allows (base_link
itself when axis 1 is its z axis, up or down, through its origin), sign corrections +1 on joints
2 and 5, and c2, c3 >= 0 (c4 >= 0 too unless tool0's z axis lies on axis 6 pointing back to the
wrist: the OPW flange is then tool0 itself).
It states the fixed transforms ``base`` (base_link -> OPW base) and ``tool`` (OPW flange -> tool0),
identity where the arm allows, so that the table's FK base_link -> tool0 is
``base @ opw_fk(params, q) @ tool``; it checks that to :data:`TOLERANCE` on random and special
joint vectors, and raises a FamilyError otherwise. :mod:`dhkin.opw_yaml` writes them for MoveIt.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import DHTable, joint_batch
from dhkin.errors import FamilyError
from dhkin.ik.geometry import (
    Condition,
    JointAxis,
    abs_cos,
    abs_sin,
    common_point,
    exact_tolerance,
    joint_axes,
    point_line_distance,
    problems,
    separation,
    spherical_wrist_conditions,
    table_scale,
    type_conditions,
)
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import invert

#: Largest difference (matrix entries: metres and rotation entries) allowed between the table's
#: FK base_link -> tool0 and ``base @ opw_fk @ tool``.
TOLERANCE = 1e-12
#: Rounding residue of the geometry: lengths within SNAP x the table scale (m) of a shorter
#: decimal, angles within SNAP (rad) of a multiple of pi/2 and rotation entries within SNAP of 0
#: or +-1 are set onto those values; the FK check runs on the values so set.
SNAP = 1e-14
#: Fixed frames (base_link -> OPW base, OPW flange -> tool0) within this (m, rad) of the
#: identity are left out of the file MoveIt reads (dhkin.opw_yaml, "The plain form"): the
#: verification tolerance for positions; for rotations 1e-6 rad, which holds the rounding of an
#: rpy written with six decimals (each angle within 5e-7 rad, the three together within
#: sqrt(3) x 5e-7 = 8.7e-7 rad), a micrometre at a metre from the flange. A tool0 whose z axis
#: lies within the rotation band of axis 6 has its turn about axis 6 taken into offset 6, so
#: that only the tilt is left to the band.
PLAIN_FORM_BAND = (DEFAULT_TOLERANCE, 1e-6)
#: Random joint vectors (fixed seed) of the FK check, besides the special angles.
CHECK_SAMPLES = 512
#: Every combination of these angles (rad) over the six joints is checked too.
SPECIAL_ANGLES = (0.0, 0.5 * math.pi, -0.5 * math.pi, math.pi)
#: What an OPW arm is, in words (the ``expected`` of the FamilyError).
EXPECTED = ("a 6R arm with an ortho-parallel basis (axis 1 perpendicular to 2, 2 parallel to 3, "
            "3 perpendicular to 4) and a spherical wrist (axes 4, 5, 6 meeting in one point, "
            "4 perpendicular to 5, 5 to 6)")

Matrix = NDArray[np.float64]
Vector = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class OPWParameters:
    """OPW parameters of a robot (metres, radians; see the module docstring for the definition)
    and the names of its joints, in the order of ``offsets`` and ``sign_corrections``.

    ``offsets`` and ``sign_corrections`` map URDF joint values q to OPW angles
    ``t = sign * q - offset`` (opw_kinematics' convention). ``base`` is base_link -> OPW base and
    ``tool`` OPW flange -> tool0 (4x4, identity when the OPW frames are base_link and tool0).
    ``deviation`` is the largest difference found between :meth:`fk` and the table's FK.
    """

    name: str
    joint_names: tuple[str, ...]
    a1: float
    a2: float
    b: float
    c1: float
    c2: float
    c3: float
    c4: float
    offsets: tuple[float, float, float, float, float, float]
    sign_corrections: tuple[int, int, int, int, int, int]
    base: Matrix = field(default_factory=lambda: np.eye(4))
    tool: Matrix = field(default_factory=lambda: np.eye(4))
    deviation: float = 0.0

    @property
    def geometric(self) -> dict[str, float]:
        """The seven lengths by name: a1, a2, b, c1, c2, c3, c4 (m)."""
        return {"a1": self.a1, "a2": self.a2, "b": self.b, "c1": self.c1, "c2": self.c2,
                "c3": self.c3, "c4": self.c4}

    @property
    def base_is_identity(self) -> bool:
        return bool(np.array_equal(self.base, np.eye(4)))

    @property
    def tool_is_identity(self) -> bool:
        return bool(np.array_equal(self.tool, np.eye(4)))

    def fk(self, q: ArrayLike) -> Matrix:
        """base_link -> tool0 = ``base @ opw_fk(self, q) @ tool``; (6,) -> (4, 4), (N, 6) ->
        (N, 4, 4)."""
        return self.base @ opw_fk(self, q) @ self.tool


# --------------------------------------------------------------------------------------------
# Forward kinematics from the definition


def opw_fk(params: OPWParameters, q: ArrayLike) -> Matrix:
    """OPW base -> OPW flange for URDF joint values q (rad): (6,) -> (4, 4), (N, 6) -> (N, 4, 4).

    The product of elementary transforms of the module docstring, with ``t = sign * q - offset``.
    """
    Q, single = _joint_batch(q)
    t = Q * np.asarray(params.sign_corrections, dtype=float) - np.asarray(params.offsets)
    T = _turn("z", t[:, 0]) @ _shift(params.a1, params.b, params.c1)
    T = T @ _turn("y", t[:, 1]) @ _shift(0.0, 0.0, params.c2)
    T = T @ _turn("y", t[:, 2]) @ _shift(params.a2, 0.0, params.c3)
    T = T @ _turn("z", t[:, 3]) @ _turn("y", t[:, 4]) @ _turn("z", t[:, 5])
    T = T @ _shift(0.0, 0.0, params.c4)
    return T[0] if single else T


def _joint_batch(q: ArrayLike) -> tuple[Matrix, bool]:
    """q as a finite (N, 6) float array, and whether one vector was given; InputError otherwise."""
    return joint_batch(q, 6)


def _turn(axis: str, angle: NDArray[np.float64]) -> Matrix:
    """Rotations about x, y or z by angles (N,) -> (N, 4, 4)."""
    c, s = np.cos(angle), np.sin(angle)
    T = np.zeros((angle.shape[0], 4, 4))
    T[:, 3, 3] = 1.0
    i, j, k = {"x": (1, 2, 0), "y": (2, 0, 1), "z": (0, 1, 2)}[axis]
    T[:, k, k] = 1.0
    T[:, i, i] = c
    T[:, j, j] = c
    T[:, i, j] = -s
    T[:, j, i] = s
    return T


def _shift(x: float, y: float, z: float) -> Matrix:
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


# --------------------------------------------------------------------------------------------
# Structure


def opw_problems(table: DHTable) -> list[str]:
    """Why ``table`` is not an exact OPW arm, in words with the measured values (empty: it is).

    The conditions are measured on the table as written (corrections included) at q = 0, to
    :func:`dhkin.ik.geometry.exact_tolerance`; :func:`opw_parameters` then checks the FK too.
    """
    wrong = type_conditions(table, "RRRRRR")
    if wrong:
        return wrong
    axes = _axes(table)
    return problems(_conditions(axes), exact_tolerance(table))


def _axes(table: DHTable) -> list[JointAxis]:
    """Joint axes at q = 0 in base_link, each pointing where positive q turns right-handed."""
    points, directions = joint_axes(table, np.zeros((1, table.dof)))
    return [JointAxis(point=points[0, i].copy(), direction=joint.direction * directions[0, i])
            for i, joint in enumerate(table.joints)]


def _conditions(axes: list[JointAxis]) -> list[Condition]:
    axis1, axis2, axis3, axis4 = axes[:4]
    conditions = [
        Condition("axes 1 and 2 perpendicular (|cos|)", abs_cos(axis1.direction, axis2.direction),
                  "angle", "zero"),
        Condition("axes 2 and 3 parallel (|sin|)", abs_sin(axis2.direction, axis3.direction),
                  "angle", "zero"),
        Condition("axes 3 and 4 perpendicular (|cos|)", abs_cos(axis3.direction, axis4.direction),
                  "angle", "zero"),
        *spherical_wrist_conditions(axes),
        Condition("axes 2 and 3 apart (upper arm c2)", separation(axis2, axis3), "length",
                  "positive"),
    ]
    centre = common_point(axes[3:])
    conditions.append(Condition("wrist centre off axis 3 (sqrt(a2^2 + c3^2))",
                                point_line_distance(centre, axis3), "length", "positive"))
    return conditions


def _family_error(table: DHTable, found: list[str]) -> FamilyError:
    where = str(table.path) if table.path is not None else table.name
    hint = ""
    if table.corrected and not opw_problems(table.nominal()):
        hint = " (its nominal table, without the corrections, is an OPW arm)"
    return FamilyError(f"{where}: not an OPW arm (no opw_kinematics parameters): "
                       + "; ".join(found) + hint, field="opw", value=found, expected=EXPECTED)


# --------------------------------------------------------------------------------------------
# Parameters from the geometry at q = 0


def opw_parameters(table: DHTable) -> OPWParameters:
    """The OPW parameters of ``table``, checked: ``params.fk(q)`` equals ``table.fk(q)`` to
    :data:`TOLERANCE` on every combination of :data:`SPECIAL_ANGLES` and on
    :data:`CHECK_SAMPLES` random joint vectors within the limits (fixed seed).

    Raises FamilyError naming what the table lacks: a joint that is not revolute (the Stanford
    arm), a structural condition (the UR5's wrist is not spherical), or the FK difference when
    the structure holds only nearly (corrections that make a table not exactly OPW).
    """
    found = opw_problems(table)
    if found:
        raise _family_error(table, found)
    params = _with_deviation(_read_geometry(table), table)
    if not params.deviation <= TOLERANCE:
        raise _family_error(table, [
            f"the OPW parameters reproduce the table's FK base_link -> tool0 only to "
            f"{params.deviation:.3g}, expected <= {TOLERANCE:g} (the structure holds to "
            f"{exact_tolerance(table).angle:g} in |cos|/|sin|, not exactly)"])
    return params


def check_joint_vectors(table: DHTable) -> Matrix:
    """The joint vectors of the FK check of :func:`opw_parameters`: every combination of
    :data:`SPECIAL_ANGLES`, then :data:`CHECK_SAMPLES` random ones within the limits (seed 0)."""
    special = np.array(list(itertools.product(SPECIAL_ANGLES, repeat=table.dof)))
    return np.vstack([special, table.random_q(CHECK_SAMPLES, np.random.default_rng(0))])


def fk_deviation(params: OPWParameters, table: DHTable, q: ArrayLike) -> float:
    """Largest entry of |params.fk(q) - table.fk(q)| over joint vectors q (N, 6)."""
    Q, _ = _joint_batch(q)
    return float(np.abs(params.fk(Q) - table.fk(Q)).max())


def _with_deviation(params: OPWParameters, table: DHTable) -> OPWParameters:
    return replace(params, deviation=fk_deviation(params, table, check_joint_vectors(table)))


def _read_geometry(table: DHTable) -> OPWParameters:
    """The parameters of a table that passed :func:`opw_problems` (see the module docstring).

    Everything is measured at q = 0, where each OPW angle is ``t_i(0) = -offset_i``. Frames:
    B the OPW base, F the OPW base turned by t1(0) about z (its y along axis 2, the arm plane
    its xz plane); coordinates below are in F unless named.
    """
    scale = table_scale(table)
    axes = _axes(table)
    tool0 = table.fk(np.zeros(table.dof))
    base = _opw_base(axes[0], scale)
    to_base = invert(base)
    points = [to_base[:3, :3] @ a.point + to_base[:3, 3] for a in axes]
    directions = [to_base[:3, :3] @ a.direction for a in axes]
    tool_in_base = to_base @ tool0

    # Joint 1: F's y along axis 2 (so sign 2 is +1), z the OPW base's z.
    sign1 = _sign(directions[0][2])
    y = directions[1] - directions[1][2] * np.array([0.0, 0.0, 1.0])
    y /= np.linalg.norm(y)
    x = np.cross(y, [0.0, 0.0, 1.0])
    t1 = math.atan2(x[1], x[0])
    to_f = np.array([x, y, [0.0, 0.0, 1.0]])  # rows: B -> F
    p = [to_f @ point for point in points]
    u = [to_f @ direction for direction in directions]
    centre = to_f @ common_point([JointAxis(points[i], directions[i]) for i in (3, 4, 5)])
    tool_f = to_f @ tool_in_base[:3, 3]
    tool_rotation = to_f @ tool_in_base[:3, :3]

    # Joints 2 and 3 in the arm plane: axis 2 at (a1, c1), axis 3 at c2 from it.
    a1, c1 = p[1][0], p[1][2]
    upper = np.array([p[2][0] - a1, p[2][2] - c1])
    c2 = float(np.hypot(*upper))
    t2 = math.atan2(upper[0], upper[1])
    sign3 = _sign(u[2][1])

    # Forearm: axis 4 along the forearm's z, pointing to the wrist centre (c3 >= 0).
    forearm = np.array([centre[0] - p[2][0], centre[2] - p[2][2]])
    sign4 = _sign(float(np.dot(forearm, u[3][[0, 2]])), default=1)
    e4 = sign4 * u[3]
    t23 = math.atan2(e4[0], e4[2])
    a2 = forearm[0] * math.cos(t23) - forearm[1] * math.sin(t23)
    c3 = forearm[0] * math.sin(t23) + forearm[1] * math.cos(t23)
    b = centre[1]

    t4, t5, t6, sign6, c4 = _wrist(_rotation("y", t23), u[4], u[5], centre, tool_f,
                                   tool_rotation)

    o = [_snap_angle(-angle) for angle in (t1, t2, t23 - t2, t4, t5, t6)]
    params = OPWParameters(
        name=table.name, joint_names=tuple(table.joint_names),
        a1=_snap_length(a1, scale), a2=_snap_length(a2, scale), b=_snap_length(b, scale),
        c1=_snap_length(c1, scale), c2=_snap_length(c2, scale), c3=_snap_length(c3, scale),
        c4=_snap_length(c4, scale),
        offsets=(o[0], o[1], o[2], o[3], o[4], o[5]),
        sign_corrections=(sign1, 1, sign3, sign4, 1, sign6), base=base)
    flange = base @ opw_fk(params, np.zeros(6))
    return replace(params, tool=_snap_transform(invert(flange) @ tool0, scale))


def _wrist(forearm: Matrix, axis5: Vector, axis6: Vector, centre: Vector, tool_origin: Vector,
           tool_rotation: Matrix) -> tuple[float, float, float, int, float]:
    """The ZYZ wrist at q = 0 (coordinates in F; ``forearm``: F -> the frame turned by t2 + t3
    about y): t4, t5, t6, sign 6 and c4. Axis 5 is taken as it points (sign 5 is +1); axis 6
    along tool0's z when that lies on it within the rotation band of :data:`PLAIN_FORM_BAND`
    (then t6 turns the OPW flange onto tool0, up to that tilt), else pointing to tool0
    (c4 >= 0, t6 = 0)."""
    e5 = forearm.T @ axis5
    t4 = math.atan2(-e5[0], e5[1])
    after_4 = forearm @ _rotation("z", t4)
    tool_z = tool_rotation[:, 2]
    along_tool_z = abs_sin(tool_z, axis6) <= PLAIN_FORM_BAND[1]
    if along_tool_z:
        sign6 = _sign(float(np.dot(tool_z, axis6)))
    else:
        sign6 = _sign(float(np.dot(tool_origin - centre, axis6)), default=1)
    e6 = after_4.T @ (sign6 * axis6)
    t5 = math.atan2(e6[0], e6[2])
    tool_x = (after_4 @ _rotation("y", t5)).T @ tool_rotation[:, 0]
    t6 = math.atan2(tool_x[1], tool_x[0]) if along_tool_z else 0.0
    c4 = float(np.dot(tool_origin - centre, sign6 * axis6))
    return t4, t5, t6, sign6, c4


def _opw_base(axis1: JointAxis, scale: float) -> Matrix:
    """base_link -> OPW base: base_link itself when axis 1 is its z axis (either way), else the
    frame with z along axis 1, origin where base_link's origin projects onto it, and x the
    projection of base_link's x (or y)."""
    direction = axis1.direction
    origin = axis1.point - np.dot(axis1.point, direction) * direction
    if abs_sin(direction, np.array([0.0, 0.0, 1.0])) <= SNAP and \
            float(np.linalg.norm(origin)) <= SNAP * scale:
        return np.eye(4)
    x = np.array([1.0, 0.0, 0.0]) - direction[0] * direction
    if np.linalg.norm(x) < 0.5:
        x = np.array([0.0, 1.0, 0.0]) - direction[1] * direction
    x /= np.linalg.norm(x)
    base = np.eye(4)
    base[:3, :3] = np.column_stack([x, np.cross(direction, x), direction])
    base[:3, 3] = origin
    return _snap_transform(base, scale)


def _rotation(axis: str, angle: float) -> Matrix:
    return _turn(axis, np.array([angle]))[0, :3, :3]


def _sign(value: float, default: int | None = None) -> int:
    """The sign of ``value`` as +1 or -1 (``default`` for 0 when given)."""
    if value == 0.0 and default is not None:
        return default
    return 1 if value > 0.0 else -1


def _snap_length(value: float, scale: float) -> float:
    """``value`` (m) as the shortest decimal within :data:`SNAP` x ``scale`` of it (0 included):
    a table's 0.042 comes back as 0.042, not 0.04199999999999998."""
    limit = SNAP * scale
    if abs(value) <= limit:
        return 0.0
    for digits in range(1, 18):
        short = float(f"{value:.{digits}g}")
        if abs(short - value) <= limit:
            return short + 0.0
    return float(value) + 0.0


def _snap_angle(value: float) -> float:
    """``value`` wrapped to (-pi, pi], set onto a multiple of pi/2 within :data:`SNAP`."""
    wrapped = math.remainder(value, 2.0 * math.pi)
    if wrapped <= -math.pi:
        wrapped = math.pi
    quarter = round(wrapped / (0.5 * math.pi))
    if abs(wrapped - quarter * 0.5 * math.pi) > SNAP:
        return wrapped + 0.0
    return math.pi if abs(quarter) == 2 else quarter * (0.5 * math.pi) + 0.0


def _snap_transform(T: Matrix, scale: float) -> Matrix:
    """Rotation entries within SNAP of 0 or +-1 set onto them (when all are), translation
    entries within SNAP * scale of 0 set to 0."""
    out = T.copy()
    rotation = out[:3, :3]
    nearest = np.round(rotation)
    if np.all(np.abs(rotation - nearest) <= SNAP) and np.all(np.isin(nearest, (-1.0, 0.0, 1.0))):
        out[:3, :3] = nearest + 0.0
    translation = out[:3, 3]
    translation[np.abs(translation) <= SNAP * scale] = 0.0
    return out
