"""Singularities and manipulability of 6-axis arms: analytic classes, checked against Pinocchio.

The determinant of the 6x6 geometric Jacobian J (columns ``[z_k x (p - o_k); z_k]`` for a
revolute joint, ``[z_k; 0]`` for a prismatic one) does not depend on the frame it is expressed in
(LOCAL, WORLD, LOCAL_WORLD_ALIGNED) nor on the reference point on the last body: both changes
multiply J by a matrix of determinant 1. A joint with ``direction = -1`` flips the sign of its
column. So det J can be taken at the most convenient point, where it factors.

Notation: joint k turns about *axis k*, the line through o_k along the unit vector z_k (in
standard DH the z axis of DH frame k-1, in modified DH that of DH frame k); ``theta_k =
direction_k q_k + offset_k``; ``a_k, alpha_k, d_k`` are row k of the table; ``ck = cos theta_k``,
``sk = sin theta_k``, ``s_alpha_k = sin alpha_k``.

**Spherical wrist** (IRB 1200, KUKA/FANUC class, the anthropomorphic arm: axis 2 parallel to
axis 3, axes 4, 5, 6 meeting in the wrist centre w). At w the wrist columns have no linear part,
so J is block triangular and, with ``(z x u) x (z x v) = z (z . (u x v))`` for the parallel axes 2
and 3,

    det J = k * S * E * W,   k = (z_2 . z_3) * prod(direction)
    S = (z_1 x (w - o_1)) . z_2                  shoulder factor (m)
    E = z_2 . ((w - o_2) x (w - o_3))            elbow factor (m^2)
    W = z_4 . (z_5 x z_6)                        wrist factor (1)

In standard DH (w = origin of DH frame 4, a4 = a5 = d5 = 0) these are, in closed form,

    u = a3 c3 + d4 s_alpha3 s3,   v = a3 s3 - d4 s_alpha3 c3      (w in DH frame 2)
    x_w = c2 (a2 + u) - cos(alpha2) s2 v                          (w along x of DH frame 1)
    S = -s_alpha1 (a1 + x_w),  E = cos(alpha2) a2 v,  W = s_alpha4 s_alpha5 s5,  k = cos(alpha2)

so det J = -s_alpha1 s_alpha4 s_alpha5 a2 (a1 + x_w) v s5 prod(direction).

**Offset wrist** (UR, AUBO: axes 2, 3, 4 parallel, axes 5 and 6 meeting in the wrist point p).
At p the columns 5 and 6 have no linear part; subtracting column 2 from 3 and 3 from 4 leaves
two purely linear columns perpendicular to the common direction z_2, and a Laplace expansion gives

    det J = k * S * E * W,   k = (z_2 . z_3) * prod(direction)
    S = (z_1 x (p - o_1)) . z_2                  shoulder factor (m)
    E = z_2 . ((o_2 - o_3) x (o_3 - o_4))        elbow factor (m^2)
    W = z_4 . (z_5 x z_6)                        wrist factor (1)

In standard DH with a4 = a5 = 0 (p = origin of DH frame 5), with kappa_i = cos(alpha_i) = +-1,
phi = theta2 + kappa2 theta3 and psi = phi + kappa2 kappa3 theta4:

    x_p = a2 c2 + a3 cos(phi) + kappa2 kappa3 s_alpha4 d5 sin(psi)
    S = -s_alpha1 (a1 + x_p),  E = kappa2 a2 a3 s3,  W = s_alpha4 s_alpha5 s5,  k = kappa2

which is the known UR result det J = s3 s5 a2 a3 (a2 c2 + a3 c23 + d5 s234) with the UR signs,
and holds for the AUBO's alpha = 180 rows through the kappas.

**Stanford arm** (R-R-P with a spherical wrist on the prismatic line, axis 2 perpendicular to and
meeting that line at x): with e = (w - x) . z_3 the extension (m),
det J = -prod(direction) * e * S * W, S as above; in standard DH (a2 = a3 = d4 = 0)
S = -s_alpha1 (a1 + s_alpha2 d3 s2), e = d3. There is no elbow.

**Distances** (what :class:`SingularityReport` calls ``distances``, all >= 0):

* wrist: |W|, dimensionless: |sin q5| on every built-in table (|sin| of the angle between axes 4
  and 6 when the wrist axes are mutually perpendicular);
* shoulder: |S| / |z_1 x z_2|, metres: the distance of the wrist centre (offset wrist: the wrist
  point) from the plane through axis 1 parallel to axis 2; without a lateral offset, that is its
  distance from axis 1;
* elbow: |E| / (distance between axes 2 and 3), metres: the distance of the wrist centre
  (offset wrist: of axis 4) from the plane of axes 2 and 3, i.e. forearm length times |sin| of
  the elbow angle measured from full stretch; zero stretched or folded.

**Thresholds**: a configuration is *at or near* a singularity when that distance is at most the
threshold (:data:`DEFAULT_THRESHOLDS`: 1e-4 for |sin q5|, 1e-4 m for the others, i.e. about
0.006 deg of q5 or 0.1 mm, where joint speeds are some 10^4 times the tool speed). Path
analysis uses the wider :data:`GRAZE_THRESHOLDS` to report near misses. Both can be set.

The numbers that come from Pinocchio (the oracle) are the singular values of the
LOCAL_WORLD_ALIGNED Jacobian at tool0, sigma_min, condition and the Yoshikawa measures.

**Which family**: the family registry decides (:func:`dhkin.ik.family.fit_family`, the decision
the closed-form IK and the maps use too): a table is in a family within the family's band
(rounded constants, calibration), and its factors are those of the family's ideal model (the
table with the band's deviations snapped off; it differs from the exact chain by at most the
fit's model deviation, and the Pinocchio numbers of a report come from the exact chain). A table
outside every family gets a :class:`~dhkin.errors.FamilyError` naming the structural conditions
it fails; its numerical measures remain available from ``robot.reference().manipulability(q)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import DHTable
from dhkin.errors import FamilyError, InputError, UnreachableError
from dhkin.ik.family import EXACT_RELATIVE, FamilyFit, fit_family
from dhkin.ik.geometry import table_scale
from dhkin.transforms import rotation_angle

if TYPE_CHECKING:
    from dhkin.arm import Arm

KINDS: tuple[str, ...] = ("wrist", "elbow", "shoulder")
#: Units of each kind's distance.
DISTANCE_UNITS: dict[str, str] = {"wrist": "|sin q5|", "elbow": "m", "shoulder": "m"}
#: The joint (1-based) whose value moves a configuration onto / off each singularity.
MOVING_JOINT: dict[str, int] = {"wrist": 5, "elbow": 3, "shoulder": 2}

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Thresholds:
    """Distances at or below which a configuration counts as at or near each singularity.

    ``wrist`` is dimensionless (|sin q5|), ``elbow`` and ``shoulder`` are metres; see the module
    docstring for what each distance measures.
    """

    wrist: float = 1e-4
    elbow: float = 1e-4
    shoulder: float = 1e-4

    def __post_init__(self) -> None:
        for kind in KINDS:
            value = getattr(self, kind)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or value < 0:
                raise InputError(f"thresholds.{kind}: expected a finite number >= 0, "
                                 f"got {value!r}")

    def of(self, kind: str) -> float:
        """The threshold of one kind ("wrist", "elbow" or "shoulder")."""
        if kind not in KINDS:
            raise InputError(f"kind: expected one of {list(KINDS)}, got {kind!r}", field="kind")
        return float(getattr(self, kind))


#: Thresholds of :func:`singularity_report`: about 0.006 deg of q5, 0.1 mm.
DEFAULT_THRESHOLDS = Thresholds()
#: Thresholds of :func:`analyse_path` for near misses ("grazes"): about 3 deg of q5, 2 cm.
GRAZE_THRESHOLDS = Thresholds(wrist=0.05, elbow=0.02, shoulder=0.02)
#: A path event's joints are said to race when its peak joint speed is this many times the
#: path's median.
RACE_FACTOR = 10.0


def as_thresholds(value: Thresholds | Mapping[str, float] | None,
                  default: Thresholds = DEFAULT_THRESHOLDS) -> Thresholds:
    """None -> ``default``; a mapping such as {"wrist": 1e-3} overrides some kinds of it."""
    if value is None:
        return default
    if isinstance(value, Thresholds):
        return value
    if not isinstance(value, Mapping):
        raise InputError(f"thresholds: expected Thresholds or a mapping of {list(KINDS)} "
                         f"to numbers, got {value!r}", field="thresholds")
    unknown = [k for k in value if k not in KINDS]
    if unknown:
        raise InputError(f"thresholds: unknown kind {unknown[0]!r}; expected keys among "
                         f"{list(KINDS)}", field="thresholds")
    merged = {kind: value.get(kind, default.of(kind)) for kind in KINDS}
    return Thresholds(**merged)


# --------------------------------------------------------------------------------------------
# Factors of det J


@dataclass(frozen=True)
class Factors:
    """Signed factors of det J for N configurations: ``det J = constant * shoulder * elbow *
    wrist`` (for the Stanford arm ``elbow`` holds the extension e, m, and is no singularity).

    All arrays have shape (N,). ``*_distance`` are the distances of the module docstring
    (``elbow_distance`` is NaN for the Stanford arm, which has no elbow).
    """

    family: str
    constant: Array
    shoulder: Array
    elbow: Array
    wrist: Array
    shoulder_distance: Array
    elbow_distance: Array

    @property
    def determinant(self) -> Array:
        """det J of the 6x6 joint Jacobian (any frame, any point on the last body)."""
        return self.constant * self.shoulder * self.elbow * self.wrist

    @property
    def wrist_distance(self) -> Array:
        return np.abs(self.wrist)

    def distance(self, kind: str) -> Array:
        """The distance of one kind, (N,)."""
        if kind == "wrist":
            return self.wrist_distance
        if kind == "elbow":
            return self.elbow_distance
        if kind == "shoulder":
            return self.shoulder_distance
        raise InputError(f"kind: expected one of {list(KINDS)}, got {kind!r}", field="kind")

    def signed(self, kind: str) -> Array:
        """The signed factor whose zero is that singularity, (N,)."""
        if kind == "wrist":
            return self.wrist
        if kind == "elbow":
            return self.elbow
        if kind == "shoulder":
            return self.shoulder
        raise InputError(f"kind: expected one of {list(KINDS)}, got {kind!r}", field="kind")

    def __getitem__(self, index: int | slice | NDArray[np.int64]) -> Factors:
        return Factors(self.family, *(np.atleast_1d(getattr(self, name)[index]) for name in
                                      ("constant", "shoulder", "elbow", "wrist",
                                       "shoulder_distance", "elbow_distance")))


def _dot(a: Array, b: Array) -> Array:
    """Dot products along the last axis."""
    return np.sum(a * b, axis=-1)


def joint_axes(table: DHTable, q: ArrayLike) -> tuple[Array, Array]:
    """Points o_k (N, n, 3) and unit directions z_k (N, n, 3) of the joint axes in base_link.

    Axis k is the z axis of DH frame k-1 (standard DH) or k (modified DH), oriented so that
    increasing theta_k turns right-handed about it (multiply by ``direction`` for q_k).
    """
    frames = table.fk_frames(q)
    first = 0 if table.convention == "standard" else 1
    chosen = frames[:, first:first + table.dof]
    return chosen[..., :3, 3], chosen[..., :3, 2]


def _closest_point(p1: Array, z1: Array, p2: Array, z2: Array) -> Array:
    """Midpoint of the shortest segment between lines (p1, z1) and (p2, z2) (unit z, not
    parallel), batched over leading axes."""
    w0 = p1 - p2
    b = _dot(z1, z2)
    d = _dot(z1, w0)
    e = _dot(z2, w0)
    denominator = 1.0 - b * b
    t1 = (b * e - d) / denominator
    t2 = (e - b * d) / denominator
    return 0.5 * ((p1 + t1[..., None] * z1) + (p2 + t2[..., None] * z2))


# --------------------------------------------------------------------------------------------
# Structure: which family, closed form or geometric


def _closed_form_available(table: DHTable, family: str) -> bool:
    """Whether the standard-DH closed forms of the module docstring apply to this table."""
    if table.convention != "standard":
        return False
    rows = table.joints
    tol = EXACT_RELATIVE * table_scale(table)  # the family's exact-structure tolerance

    def zero(x: float) -> bool:
        return abs(x) <= tol

    def sin_zero(alpha: float) -> bool:
        return abs(math.sin(alpha)) <= EXACT_RELATIVE

    if family == "spherical_wrist":
        return sin_zero(rows[1].alpha) and zero(rows[3].a) and zero(rows[4].a) \
            and zero(rows[4].d)
    if family == "offset_wrist":
        return sin_zero(rows[1].alpha) and sin_zero(rows[2].alpha) and zero(rows[3].a) \
            and zero(rows[4].a)
    return zero(rows[1].a) and zero(rows[2].a) and zero(rows[3].d) and zero(rows[3].a) \
        and zero(rows[4].a) and zero(rows[4].d) \
        and abs(abs(math.sin(rows[1].alpha)) - 1.0) <= EXACT_RELATIVE


def family_fit(table: DHTable) -> FamilyFit:
    """The table's family, decided by the family registry (:func:`dhkin.ik.family.fit_family`,
    the same decision as the closed-form IK's): an arm is in a family for IK, singularity
    analysis and maps alike, or for none of them.

    Raises FamilyError naming, per family, the conditions the table fails.
    """
    try:
        return fit_family(table)
    except FamilyError as exc:
        failed = exc.value if isinstance(exc.value, dict) else {}
        lines = "\n  ".join(f"{family}: " + "; ".join(problems)
                            for family, problems in failed.items())
        raise FamilyError(f"{table.name}: no analytic singularity family fits this table "
                          f"(its numerical measures: robot.reference().manipulability(q)):"
                          f"\n  {lines}", field="family", value=exc.value,
                          expected=exc.expected) from exc


def family_of(table: DHTable) -> str:
    """The analytic family of a table: "spherical_wrist", "offset_wrist" or "stanford"
    (:func:`family_fit`)."""
    return family_fit(table).family


class SingularityModel:
    """The analytic det J of one table, factored into shoulder, elbow and wrist terms.

    ``factors(q)`` uses the closed forms in the joint angles and DH parameters when the table is
    standard DH of the family's layout (every built-in robot), else the geometric form from the
    joint axes (any convention). ``geometric_factors`` is always available, as a cross-check.
    """

    def __init__(self, table: DHTable) -> None:
        fit = family_fit(table)
        #: The family's ideal model of the table (dhkin.ik.family): the factors are those of the
        #: ideal structure; a table within the family's band (rounded constants, calibration)
        #: differs from it by at most ``fit.model_deviation``, and Pinocchio's numbers in the
        #: report come from the exact chain.
        self.table = fit.ideal
        self.exact_table = table
        self.family = fit.family
        self.closed_form = _closed_form_available(fit.ideal, self.family)
        self.kinds: tuple[str, ...] = (("wrist", "shoulder") if self.family == "stanford"
                                       else KINDS)
        self.directions = np.array([j.direction for j in table.joints], dtype=float)

    def __repr__(self) -> str:
        form = "closed form" if self.closed_form else "geometric form"
        return f"SingularityModel({self.table.name!r}, {self.family}, {form})"

    def _batch(self, q: ArrayLike) -> Array:
        Q = np.asarray(q, dtype=float)
        if Q.ndim == 1:
            Q = Q[None]
        if Q.ndim != 2 or Q.shape[1] != 6:
            raise InputError(f"q: expected shape (6,) or (N, 6), got {np.shape(q)}", field="q")
        if not np.all(np.isfinite(Q)):
            raise InputError("q: expected finite joint values, got NaN or inf", field="q")
        return Q

    def factors(self, q: ArrayLike) -> Factors:
        """Signed factors and distances for q (6,) or (N, 6) (URDF joint values, rad and m)."""
        if self.closed_form:
            return self.closed_form_factors(q)
        return self.geometric_factors(q)

    def determinant(self, q: ArrayLike) -> Array:
        """Analytic det J, shape (N,)."""
        return self.factors(q).determinant

    # closed forms ---------------------------------------------------------------------------

    def closed_form_factors(self, q: ArrayLike) -> Factors:
        """The closed forms of the module docstring (standard DH tables of the family)."""
        if not self.closed_form:
            raise FamilyError(f"{self.table.name}: no closed form for this table "
                              f"({self.table.convention} DH); use geometric_factors")
        Q = self._batch(q)
        theta, d = self.table.dh_parameters(Q)
        rows = self.table.joints
        a = [0.0] + [j.a for j in rows]
        s_alpha = [0.0] + [math.sin(j.alpha) for j in rows]
        c_alpha = [0.0] + [math.copysign(1.0, math.cos(j.alpha)) for j in rows]
        t = [np.zeros(len(Q))] + [theta[:, k] for k in range(6)]
        product = float(np.prod(self.directions))
        wrist = s_alpha[4] * s_alpha[5] * np.sin(t[5])
        if self.family == "spherical_wrist":
            d4 = rows[3].d
            u = a[3] * np.cos(t[3]) + d4 * s_alpha[3] * np.sin(t[3])
            v = a[3] * np.sin(t[3]) - d4 * s_alpha[3] * np.cos(t[3])
            x_w = np.cos(t[2]) * (a[2] + u) - c_alpha[2] * np.sin(t[2]) * v
            shoulder = -s_alpha[1] * (a[1] + x_w)
            elbow = c_alpha[2] * a[2] * v
            constant = c_alpha[2] * product
            elbow_distance = np.abs(v)
        elif self.family == "offset_wrist":
            k2, k3 = c_alpha[2], c_alpha[3]
            d5 = rows[4].d
            phi = t[2] + k2 * t[3]
            psi = phi + k2 * k3 * t[4]
            x_p = a[2] * np.cos(t[2]) + a[3] * np.cos(phi) + k2 * k3 * s_alpha[4] * d5 * np.sin(psi)
            shoulder = -s_alpha[1] * (a[1] + x_p)
            elbow = k2 * a[2] * a[3] * np.sin(t[3])
            constant = k2 * product
            elbow_distance = np.abs(a[3] * np.sin(t[3]))
        else:  # stanford
            extension = d[:, 2]
            shoulder = -s_alpha[1] * (a[1] + s_alpha[2] * extension * np.sin(t[2]))
            elbow = extension
            constant = -product
            elbow_distance = np.full(len(Q), np.nan)
        return Factors(self.family, np.full(len(Q), constant), shoulder, elbow, wrist,
                       np.abs(shoulder) / abs(s_alpha[1]), elbow_distance)

    # geometric form -------------------------------------------------------------------------

    def geometric_factors(self, q: ArrayLike) -> Factors:
        """The factors from the joint axes (any DH convention); see the module docstring."""
        Q = self._batch(q)
        o, z = joint_axes(self.table, Q)
        o1, o2, o3, o4, o5, o6 = (o[:, k] for k in range(6))
        z1, z2, z3, z4, z5, z6 = (z[:, k] for k in range(6))
        product = float(np.prod(self.directions))
        wrist = _dot(z4, np.cross(z5, z6))
        axis_12 = np.linalg.norm(np.cross(z1, z2), axis=-1)
        if self.family == "offset_wrist":
            point = _closest_point(o5, z5, o6, z6)
        else:
            point = _closest_point(o4, z4, o5, z5)
        shoulder = _dot(np.cross(z1, point - o1), z2)
        if self.family == "stanford":
            meeting = _closest_point(o2, z2, point, z3)
            elbow = _dot(point - meeting, z3)
            constant = np.full(len(Q), -product)
            elbow_distance = np.full(len(Q), np.nan)
        else:
            between = o3 - o2
            axis_23 = np.linalg.norm(between - _dot(between, z2)[:, None] * z2, axis=-1)
            if self.family == "spherical_wrist":
                elbow = _dot(z2, np.cross(point - o2, point - o3))
            else:
                elbow = _dot(z2, np.cross(o2 - o3, o3 - o4))
            constant = np.sign(_dot(z2, z3)) * product
            elbow_distance = np.abs(elbow) / axis_23
        return Factors(self.family, constant, shoulder, elbow, wrist,
                       np.abs(shoulder) / axis_12, elbow_distance)

    # formulas and placement -----------------------------------------------------------------

    def formula(self) -> str:
        """det J as an expression in this table's joint angles, with its numbers."""
        return _formula(self)

    def place(self, q: ArrayLike, kind: str) -> Array:
        """q with one joint (:data:`MOVING_JOINT`) moved so that ``kind`` is exactly singular.

        Every factor is a sinusoid ``A + B cos x + C sin x`` of the moving joint's value x (the
        part beyond that joint turns rigidly about its axis), so the roots are found in closed
        form; the root within the joint limits nearest the current value is taken.
        InputError when the family has no such kind, UnreachableError when no root lies within
        the limits.
        """
        if kind not in self.kinds:
            raise InputError(f"kind: {self.table.name} ({self.family}) has the "
                             f"singularities {list(self.kinds)}, got {kind!r}", field="kind")
        start = self._batch(q)[0]
        joint = MOVING_JOINT[kind] - 1
        probes = np.repeat(start[None], 3, axis=0)
        probes[:, joint] = (0.0, 0.5 * math.pi, math.pi)
        f0, f1, f2 = self.factors(probes).signed(kind)
        # f(x) = A + B cos x + C sin x at x = 0, pi/2, pi
        A = 0.5 * (f0 + f2)
        B = 0.5 * (f0 - f2)
        C = f1 - A
        amplitude = math.hypot(B, C)
        if amplitude <= abs(A):
            raise UnreachableError(f"{self.table.name}: joint {joint + 1} cannot reach the "
                                   f"{kind} singularity from q = {np.round(start, 6).tolist()}",
                                   field="q", value=start.tolist())
        phase = math.atan2(C, B)
        spread = math.acos(-A / amplitude)
        lower, upper = self.table.lower[joint], self.table.upper[joint]
        candidates = []
        for root in (phase + spread, phase - spread):
            for turn in range(-3, 4):
                value = root + 2.0 * math.pi * turn
                if lower <= value <= upper:
                    candidates.append(value)
        if not candidates:
            raise UnreachableError(f"{self.table.name}: the {kind} singularity needs joint "
                                   f"{joint + 1} outside its limits from q = "
                                   f"{np.round(start, 6).tolist()}", field="q",
                                   value=start.tolist())
        placed = start.copy()
        placed[joint] = min(candidates, key=lambda value: abs(value - start[joint]))
        return placed


def singularity_model(robot_or_table: Arm | DHTable) -> SingularityModel:
    """The analytic model of a robot or a table (FamilyError outside the families)."""
    table = robot_or_table if isinstance(robot_or_table, DHTable) else robot_or_table.table
    return SingularityModel(table)


def _number(value: float) -> str:
    return f"{value:.6g}"


def _combination(*terms: tuple[float, str]) -> str:
    """A linear combination as text, e.g. ((0.042, "c3"), (-0.351, "s3")) -> "0.042 c3 - 0.351
    s3"; zero terms are left out, unit coefficients written as signs."""
    parts: list[str] = []
    for coefficient, symbol in terms:
        if abs(coefficient) < 1e-15:
            continue
        magnitude = abs(coefficient)
        body = symbol if (symbol and abs(magnitude - 1.0) < 1e-15) else \
            f"{_number(magnitude)} {symbol}".strip()
        if not parts:
            parts.append(body if coefficient > 0 else f"-{body}")
        else:
            parts.append(f"{'+' if coefficient > 0 else '-'} {body}")
    return " ".join(parts) if parts else "0"


def _angle(table: DHTable, k: int) -> str:
    """theta_k (or d_k of a prismatic joint) in terms of q_k, e.g. "q2 - 90 deg"."""
    joint = table.joints[k - 1]
    offset = math.degrees(joint.offset) if joint.is_revolute else joint.offset
    unit = " deg" if joint.is_revolute else " m"
    text = _combination((float(joint.direction), f"q{k}"))
    if abs(offset) > 1e-12:
        text += f" {'+' if offset > 0 else '-'} {_number(abs(offset))}{unit}"
    return text


def _formula(model: SingularityModel) -> str:
    table, family = model.table, model.family
    product = float(np.prod(model.directions))
    if not model.closed_form:
        return (f"det J = k S E W ({family}, geometric form, {table.convention} DH): "
                "S = (z1 x (w - o1)).z2, E = " +
                ("z2.((o2 - o3) x (o3 - o4))" if family == "offset_wrist" else
                 "z2.((w - o2) x (w - o3))" if family == "spherical_wrist" else "(w - x).z3")
                + ", W = z4.(z5 x z6), k = " + ("-prod(direction)" if family == "stanford"
                                                else "(z2.z3) prod(direction)"))
    rows = table.joints
    a = [0.0] + [j.a for j in rows]
    sa = [0.0] + [math.sin(j.alpha) for j in rows]
    ca = [0.0] + [math.copysign(1.0, math.cos(j.alpha)) for j in rows]
    angles = ", ".join(f"t{k} = {_angle(table, k)}" for k in (1, 2, 3, 4, 5)
                       if rows[k - 1].is_revolute)
    wrist = f"W = {_combination((sa[4] * sa[5], 'sin t5'))}"
    shoulder_sign = {1.0: "", -1.0: "-"}.get(round(-sa[1], 12), f"{_number(-sa[1])} ")
    if family == "spherical_wrist":
        d4 = rows[3].d
        u = _combination((a[3], "cos t3"), (d4 * sa[3], "sin t3"))
        v = _combination((a[3], "sin t3"), (-d4 * sa[3], "cos t3"))
        x_w = _combination((a[1], ""), (a[2], "cos t2"), (1.0, "u cos t2"), (-ca[2], "v sin t2"))
        lines = [
            f"det J = k S E W (spherical wrist, closed form), k = {_number(ca[2] * product)}",
            f"  S = {shoulder_sign}({x_w}) m   (shoulder)",
            f"  E = {_combination((ca[2] * a[2], 'v'))} m^2   (elbow)",
            f"  u = {u}, v = {v}",
        ]
    elif family == "offset_wrist":
        k2, k3 = ca[2], ca[3]
        phi = _combination((1.0, "t2"), (k2, "t3"))
        psi = _combination((1.0, "t2"), (k2, "t3"), (k2 * k3, "t4"))
        x_p = _combination((a[1], ""), (a[2], "cos t2"), (a[3], f"cos({phi})"),
                           (k2 * k3 * sa[4] * rows[4].d, f"sin({psi})"))
        lines = [
            f"det J = k S E W (offset wrist, closed form), k = {_number(k2 * product)}",
            f"  S = {shoulder_sign}({x_p}) m   (shoulder)",
            f"  E = {_combination((k2 * a[2] * a[3], 'sin t3'))} m^2   (elbow)",
        ]
    else:
        lines = [
            f"det J = k S E W (Stanford arm, closed form), k = {_number(-product)}",
            f"  S = {shoulder_sign}({_combination((a[1], ''), (sa[2], 'd3 sin t2'))}) m   "
            f"(shoulder)",
            f"  E = d3 = {_angle(table, 3)}   (extension, m; not a kind of singularity, zero "
            f"only with the wrist centre on axis 2)",
        ]
    lines.append(f"  {wrist}   (wrist)")
    lines.append(f"  {angles}")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# Report of one configuration


@dataclass(frozen=True)
class SingularityReport:
    """How close one configuration is to each singularity, and how dexterous it is.

    ``kinds``: names among "wrist", "elbow", "shoulder" whose distance is at most its threshold
    (empty when none). ``distances``: per kind, in :data:`DISTANCE_UNITS`. ``factors``: the
    signed factors with ``determinant = factors["k"] * factors["shoulder"] * factors["elbow"] *
    factors["wrist"]`` (analytic); ``determinant_pinocchio`` is det J from Pinocchio. From
    Pinocchio (LOCAL_WORLD_ALIGNED Jacobian at tool0): ``singular_values`` (descending),
    ``sigma_min``, ``condition`` (sigma_max / sigma_min) and the Yoshikawa ``manipulability``
    (whole = |det J|), ``translational`` and ``rotational`` (linear / angular rows).
    """

    robot: str
    family: str
    q: Array
    kinds: tuple[str, ...]
    distances: Mapping[str, float]
    thresholds: Thresholds
    factors: Mapping[str, float]
    determinant: float
    determinant_pinocchio: float
    formula: str
    singular_values: Array
    sigma_min: float
    manipulability: float
    translational: float
    rotational: float
    condition: float
    joint_names: tuple[str, ...] = field(default=())

    @property
    def singular(self) -> bool:
        """Whether the configuration is at or near any singularity."""
        return bool(self.kinds)

    def __str__(self) -> str:
        status = ", ".join(self.kinds) if self.kinds else "none"
        lines = [f"{self.robot} ({self.family}) at q = "
                 f"{np.array2string(self.q, precision=6, floatmode='fixed')} (rad/m)",
                 f"singular (at or near): {status}"]
        for kind in KINDS:
            if kind not in self.distances:
                continue
            flag = "  <= threshold" if kind in self.kinds else ""
            lines.append(f"  {kind:8s} distance {self.distances[kind]:.6g} "
                         f"{DISTANCE_UNITS[kind]} (threshold {self.thresholds.of(kind):g})"
                         f"{flag}")
        lines.append(f"det J = {self.determinant:.9g} (analytic), "
                     f"{self.determinant_pinocchio:.9g} (Pinocchio)")
        lines.append("factors: " + ", ".join(f"{k} = {v:.6g}" for k, v in self.factors.items()))
        lines.append(self.formula)
        lines.append("Pinocchio, LOCAL_WORLD_ALIGNED at tool0:")
        lines.append("  singular values " + np.array2string(self.singular_values, precision=6,
                                                          max_line_width=200))
        lines.append(f"  sigma_min {self.sigma_min:.6g}, condition {self.condition:.6g}")
        lines.append(f"  Yoshikawa manipulability {self.manipulability:.6g} (m^3), translational "
                     f"{self.translational:.6g} (m^3), rotational {self.rotational:.6g}")
        return "\n".join(lines)


def singularity_report(robot: Arm, q: ArrayLike,
                       thresholds: Thresholds | Mapping[str, float] | None = None
                       ) -> SingularityReport:
    """Analytic singularity classes of one configuration q (6,), with Pinocchio's measures.

    ``thresholds`` (default :data:`DEFAULT_THRESHOLDS`) may be a :class:`Thresholds` or a
    mapping overriding some kinds, e.g. ``{"wrist": 1e-3}``.
    """
    limits = as_thresholds(thresholds)
    model = singularity_model(robot)
    values = np.asarray(q, dtype=float)
    if values.shape != (robot.dof,) or not np.all(np.isfinite(values)):
        raise InputError(f"q: expected {robot.dof} finite joint values, got "
                         f"{np.asarray(q).tolist()!r}", field="q")
    factors = model.factors(values)
    distances = {kind: float(factors.distance(kind)[0]) for kind in model.kinds}
    kinds = tuple(kind for kind in KINDS if kind in distances
                  and distances[kind] <= limits.of(kind))
    reference = robot.reference()
    measures = reference.manipulability(values)
    det_pinocchio = float(np.linalg.det(reference.jacobian(values)))
    elbow_name = "extension" if model.family == "stanford" else "elbow"
    signed = {"k": float(factors.constant[0]), "shoulder": float(factors.shoulder[0]) + 0.0,
              elbow_name: float(factors.elbow[0]) + 0.0, "wrist": float(factors.wrist[0]) + 0.0}
    return SingularityReport(
        robot=robot.name, family=model.family, q=values, kinds=kinds, distances=distances,
        thresholds=limits, factors=signed, determinant=float(factors.determinant[0]) + 0.0,
        determinant_pinocchio=det_pinocchio, formula=model.formula(),
        singular_values=measures.singular_values, sigma_min=measures.sigma_min,
        manipulability=measures.yoshikawa, translational=measures.translational,
        rotational=measures.rotational, condition=measures.condition,
        joint_names=tuple(robot.table.joint_names))


# --------------------------------------------------------------------------------------------
# Paths


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
                else np.asarray(q_start, dtype=float).reshape(-1))
    if previous.shape != (robot.dof,) or not np.all(np.isfinite(previous)):
        raise InputError(f"q_start: expected {robot.dof} finite joint values, got "
                         f"{np.asarray(q_start).tolist()!r}", field="q_start")
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


def report_to_json(report: SingularityReport) -> dict[str, object]:
    """The report as plain JSON types (q in rad and m)."""
    return {
        "robot": report.robot, "family": report.family, "q": report.q.tolist(),
        "kinds": list(report.kinds), "distances": dict(report.distances),
        "distance_units": {k: DISTANCE_UNITS[k] for k in report.distances},
        "thresholds": {k: report.thresholds.of(k) for k in KINDS},
        "factors": dict(report.factors), "determinant": report.determinant,
        "determinant_pinocchio": report.determinant_pinocchio, "formula": report.formula,
        "singular_values": report.singular_values.tolist(), "sigma_min": report.sigma_min,
        "manipulability": report.manipulability, "translational": report.translational,
        "rotational": report.rotational,
        "condition": report.condition if math.isfinite(report.condition) else None,
    }
