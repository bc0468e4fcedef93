"""The singularity report of one configuration: the analytic factors beside Pinocchio's singular
values and manipulability (the oracle), as text or JSON.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from dhkin.dh import joint_vector
from dhkin.singularity.model import singularity_model
from dhkin.singularity.thresholds import DISTANCE_UNITS, KINDS, Array, Thresholds, as_thresholds

if TYPE_CHECKING:
    from dhkin.arm import Arm


@dataclass(frozen=True)
class SingularityReport:
    """How close one configuration is to each singularity, and how dexterous it is.

    ``kinds``: names among "wrist", "elbow", "shoulder" whose distance is at most its threshold
    (empty when none). ``distances``: per kind, in :data:`DISTANCE_UNITS`. ``factors``: the
    signed factors with ``determinant = factors["k"] * factors["shoulder"] * factors["elbow"] *
    factors["wrist"]`` (analytic); ``determinant_pinocchio`` is det J from Pinocchio. From
    Pinocchio (LOCAL_WORLD_ALIGNED Jacobian at tool0): ``singular_values`` (descending),
    ``sigma_min``, ``condition`` (sigma_max / sigma_min) and the Yoshikawa ``manipulability``
    (whole = ``|det J|``), ``translational`` and ``rotational`` (linear / angular rows).
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
    values = joint_vector(q, robot.dof)
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
