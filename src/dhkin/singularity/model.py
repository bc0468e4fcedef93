"""The analytic det J of the three families and its factors, checked against Pinocchio.

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
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from dhkin.dh import DHTable, joint_batch
from dhkin.errors import FamilyError, InputError, UnreachableError
from dhkin.ik.family import FAMILIES, FamilyFit, fit_family
from dhkin.ik.geometry import joint_axes
from dhkin.singularity.factors import Factors
from dhkin.singularity.thresholds import KINDS, MOVING_JOINT, Array

if TYPE_CHECKING:
    from dhkin.arm import Arm


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
        lines = " | ".join(f"{family}: " + "; ".join(problems)
                           for family, problems in failed.items())
        raise FamilyError(f"{table.name}: no analytic singularity family fits this table "
                          f"(its numerical measures: robot.reference().manipulability(q)): "
                          f"{lines}", field="family", value=exc.value,
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

    def __init__(self, table: DHTable, fit: FamilyFit | None = None) -> None:
        fit = fit if fit is not None else family_fit(table)
        #: The family's ideal model of the table (dhkin.ik.family): the factors are those of the
        #: ideal structure; a table within the family's band (rounded constants, calibration)
        #: differs from it by at most ``fit.model_deviation``, and Pinocchio's numbers in the
        #: report come from the exact chain.
        self.table = fit.ideal
        self.exact_table = table
        self.family = fit.family
        #: The family's module: its structure, ideal geometry, labels and singularity factors.
        self._module = FAMILIES[fit.family]
        self.closed_form = bool(self._module.singularity_closed_form(fit.ideal))
        self.kinds: tuple[str, ...] = (("wrist", "shoulder") if self.family == "stanford"
                                       else KINDS)
        self.directions = np.array([j.direction for j in table.joints], dtype=float)

    def __repr__(self) -> str:
        form = "closed form" if self.closed_form else "geometric form"
        return f"SingularityModel({self.table.name!r}, {self.family}, {form})"

    def _batch(self, q: ArrayLike) -> Array:
        return joint_batch(q, 6)[0]

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
        """The closed forms of the module docstring (standard DH tables of the family), from the
        family's module (:mod:`dhkin.ik.family` registry)."""
        if not self.closed_form:
            raise FamilyError(f"{self.table.name}: no closed form for this table "
                              f"({self.table.convention} DH); use geometric_factors")
        Q = self._batch(q)
        theta, d = self.table.dh_parameters(Q)
        product = float(np.prod(self.directions))
        return Factors(self.family, *self._module.singularity_factors(self.table, theta, d,
                                                                       product))

    # geometric form -------------------------------------------------------------------------

    def geometric_factors(self, q: ArrayLike) -> Factors:
        """The factors from the joint axes (any DH convention), from the family's module; see
        the module docstring."""
        Q = self._batch(q)
        o, z = joint_axes(self.table, Q)
        product = float(np.prod(self.directions))
        return Factors(self.family, *self._module.geometric_singularity_factors(o, z, product))

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
    """The analytic model of a robot or a table (FamilyError outside the families). A robot's
    model reuses the family fit its closed-form IK already made (fitting costs ~3 ms)."""
    if isinstance(robot_or_table, DHTable):
        return SingularityModel(robot_or_table)
    robot = robot_or_table
    fit = robot.ik_solver.fit if robot.has_closed_form else None
    return SingularityModel(robot.table, fit)


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
