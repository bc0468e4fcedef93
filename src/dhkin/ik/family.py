"""Which closed-form family fits a table, and the ideal model its closed form solves.

*Closed form as the seed, the exact chain as the truth.* Real descriptions are not exactly in a
family: vendors round pi/2 to 1.570796 or pi to 3.1416, and a calibrated arm moves every joint
origin by up to millimetres and milliradians. A family is therefore chosen within a band:

1. The **ideal model** is the nominal table (corrections dropped) with every alpha within
   :data:`BAND.angle` (rad) of a multiple of 90 degrees set onto it and every a, d within
   :data:`BAND.length` (m) of 0 set to 0. It must fit the family exactly (to
   :data:`dhkin.ik.geometry.EXACT_RELATIVE`: 1e-9 in |cos| / |sin|, 1e-9 x the table scale in
   metres).
2. The **exact chain** (the table as written, corrections included) must fit the family within
   the band: each structural condition (|cos| of axes that should be perpendicular, |sin| of
   axes that should be parallel, distance between axes that should meet) at most the band.
3. The closed form solves the ideal model; when the exact chain differs from it (any snapped
   value, any correction), every branch is refined on the exact chain (damped Newton) and
   verified there (:mod:`dhkin.ik.compiled.pipeline`).

The band is physical: :data:`BAND` = 0.02 rad (1.15 degrees) and 2 mm. It is ten times the
largest structural deviation of the real calibrated UR5e of ``robots/vendor`` (see
docs/ik_core.md for the measured figures), wide enough for every rounded vendor constant (1e-7 to
7e-6 rad), and narrow enough that Newton's method started from the ideal model's solutions
converges to the exact chain's (the tests solve tables at several times the calibrated
deviations). The **model deviation** (:func:`model_deviation`) measures how far the exact
chain's poses are from the ideal model's over the joint range; it widens the seed band and the
reach clamps of the pipeline for refined tables.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from types import ModuleType

import numpy as np

from dhkin.dh import DHTable
from dhkin.errors import FamilyError
from dhkin.ik import offset_wrist, spherical_wrist, stanford
from dhkin.ik.geometry import Tolerance, deviation, exact_tolerance, problems
from dhkin.ik.spherical_wrist import Solved

#: The band within which an exact chain counts as a member of a family (see module docstring).
BAND = Tolerance(angle=0.02, length=0.002)
#: Joint vectors sampled (fixed seed) to measure the model deviation.
DEVIATION_SAMPLES = 256

#: Closed-form families, tried in this order.
FAMILIES: dict[str, ModuleType] = {
    "spherical_wrist": spherical_wrist,
    "stanford": stanford,
    "offset_wrist": offset_wrist,
}
_EXPLAIN: dict[str, Callable[..., str]] = {name: module.explain
                                           for name, module in FAMILIES.items()}


@dataclass(frozen=True)
class FamilyFit:
    """A table's family: the ideal model, whether branches are refined on the exact chain, the
    structural deviation of the exact chain (|cos| or |sin|, metres) and the model deviation
    (largest position (m) and rotation (rad) difference of DH frame n between the exact chain
    and the ideal model over the joint range)."""

    family: str
    ideal: DHTable
    refine: bool
    structural_deviation: tuple[float, float]
    model_deviation: tuple[float, float]
    solved: Solved

    def explain(self, why: np.ndarray, clamp: float) -> str:
        return _EXPLAIN[self.family](self.solved, why, clamp)


def ideal_model(table: DHTable, band: Tolerance = BAND) -> DHTable:
    """The nominal table with alphas within ``band.angle`` of a multiple of 90 degrees and a, d
    within ``band.length`` of 0 set onto those values (prismatic joints: their fixed theta is
    snapped like alpha)."""
    quarter = math.pi / 2

    def snap_angle(value: float) -> float:
        nearest = quarter * round(value / quarter)
        return float(nearest) if abs(value - nearest) <= band.angle else value

    def snap_length(value: float) -> float:
        return 0.0 if abs(value) <= band.length else value

    joints = tuple(dataclasses.replace(
        joint, alpha=snap_angle(joint.alpha), a=snap_length(joint.a), d=snap_length(joint.d),
        theta=joint.theta if joint.is_revolute else snap_angle(joint.theta))
        for joint in table.nominal().joints)
    return dataclasses.replace(table.nominal(), joints=joints)


def model_deviation(table: DHTable, ideal: DHTable) -> tuple[float, float]:
    """Largest (position m, rotation rad) difference of DH frame 0 -> n between ``table`` and
    ``ideal`` over DEVIATION_SAMPLES joint vectors within the limits (fixed seed) and q = 0."""
    rng = np.random.default_rng(0)
    q = np.vstack([np.zeros(table.dof), table.random_q(DEVIATION_SAMPLES, rng)])
    exact = _dh_fk(table, q)
    model = _dh_fk(ideal, q)
    position = np.linalg.norm(exact[:, :3, 3] - model[:, :3, 3], axis=1)
    relative = np.swapaxes(exact[:, :3, :3], 1, 2) @ model[:, :3, :3]
    cosine = np.clip((np.trace(relative, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    return float(position.max()), float(np.arccos(cosine).max())


def _dh_fk(table: DHTable, q: np.ndarray) -> np.ndarray:
    """DH frame 0 -> DH frame n (no base, no tool) for q (N, n)."""
    A = table.link_transforms(q)
    T = np.broadcast_to(np.eye(4), (q.shape[0], 4, 4)).copy()
    for i in range(table.dof):
        T = T @ A[:, i]
    return T


def family_problems(table: DHTable) -> dict[str, list[str]]:
    """For every family, why it does not fit ``table`` (empty list: it fits)."""
    return {name: _fit_problems(table, name) for name in FAMILIES}


def _fit_problems(table: DHTable, name: str) -> list[str]:
    module = FAMILIES[name]
    wrong, conditions = module.structure(table)
    if wrong:
        return wrong
    ideal = ideal_model(table)
    _, ideal_conditions = module.structure(ideal)
    found = [f"ideal model: {p}" for p in problems(ideal_conditions, exact_tolerance(ideal))]
    found += [f"beyond the band: {p}" for p in problems(conditions, BAND)]
    return found


def fit_family(table: DHTable, family: str | None = None) -> FamilyFit:
    """The first family that fits ``table`` (or ``family``) within the band: the one decision
    of "which family is this arm" that IK, singularity analysis and maps all use.

    Raises FamilyError naming, per family, the conditions the table fails (its ``value``: a
    dict family -> those conditions).
    """
    if family is not None and family not in FAMILIES:
        raise FamilyError(f"family: expected one of {list(FAMILIES)}, got {family!r}")
    names = [family] if family is not None else list(FAMILIES)
    report = []
    problems_of: dict[str, list[str]] = {}  # the FamilyError's ``value``: what each family lacks
    for name in names:
        found = _fit_problems(table, name)
        if found:
            problems_of[name] = found
            report.append(f"{name}: " + "; ".join(found))
            continue
        ideal = ideal_model(table)
        _, conditions = FAMILIES[name].structure(table)
        refine = ideal.joints != table.joints
        deviation_of_model = model_deviation(table, ideal) if refine else (0.0, 0.0)
        return FamilyFit(name, ideal, refine, deviation(conditions), deviation_of_model,
                         FAMILIES[name].build(ideal))
    raise FamilyError(f"{table.name}: no closed-form IK family fits this table: "
                      + " | ".join(report), field="family", value=problems_of,
                      expected="a table within the band of one of " + ", ".join(FAMILIES))
