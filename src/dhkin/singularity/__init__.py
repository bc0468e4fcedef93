"""Singularities and manipulability of 6-axis arms: analytic classes, checked against Pinocchio.

The analytic det J and its factors: :mod:`.model` (which documents the mathematics); the kinds and
thresholds: :mod:`.thresholds`; the report of one configuration: :mod:`.report`; paths:
:mod:`.paths`. Every public name is importable from ``dhkin.singularity``.
"""

from __future__ import annotations

from dhkin.ik.geometry import joint_axes
from dhkin.singularity.factors import (
    Factors,
)
from dhkin.singularity.model import (
    SingularityModel,
    family_fit,
    family_of,
    singularity_model,
)
from dhkin.singularity.paths import (
    PathAnalysis,
    PathEvent,
    analyse_path,
    line_poses,
    solve_pose_path,
)
from dhkin.singularity.report import (
    SingularityReport,
    report_to_json,
    singularity_report,
)
from dhkin.singularity.thresholds import (
    DEFAULT_THRESHOLDS,
    DISTANCE_UNITS,
    GRAZE_THRESHOLDS,
    KINDS,
    MOVING_JOINT,
    RACE_FACTOR,
    Array,
    Thresholds,
    as_thresholds,
)

__all__ = [
    "DEFAULT_THRESHOLDS",
    "DISTANCE_UNITS",
    "GRAZE_THRESHOLDS",
    "KINDS",
    "MOVING_JOINT",
    "RACE_FACTOR",
    "Array",
    "Factors",
    "PathAnalysis",
    "PathEvent",
    "SingularityModel",
    "SingularityReport",
    "Thresholds",
    "analyse_path",
    "as_thresholds",
    "family_fit",
    "family_of",
    "joint_axes",
    "line_poses",
    "report_to_json",
    "singularity_model",
    "singularity_report",
    "solve_pose_path",
]
