"""Cross-validation of any IK callable against an oracle: Pinocchio on a reference description
(:mod:`.run` documents what is checked). Every public name is importable from ``dhkin.validate``.
"""

from __future__ import annotations

from dhkin.validate.adapters import (
    IKCallable,
    adapt,
    load_ik,
    own_ik,
)
from dhkin.validate.references import (
    REFERENCE_KINDS,
    ROUNDED_DIGITS,
    ReferenceSpec,
    TargetModel,
    resolve_reference,
    rounded_urdf,
    target_model,
    tool_frame_from_robot,
)
from dhkin.validate.report import (
    COMPLETENESS_OUTCOMES,
    OUTCOMES,
    SAMPLE_SETS,
    SampleResult,
    ValidationReport,
    failures_json,
    write_failures,
)
from dhkin.validate.run import (
    POSE_ROUNDING,
    SINGULAR_FAMILY_FIXED_JOINTS,
    WRIST_SINGULAR,
    _resolvable,
    replay,
    validate,
)
from dhkin.validate.samples import (
    CONTINUITY_DISTANCE,
    CONTINUITY_SETS,
    NEAR_SINGULAR_MAX,
    SEED_PERTURBATION,
    SPECIAL_ANGLES,
    WRIST_JOINT,
    perturbed_seeds,
    sample_joint_vectors,
)

__all__ = [
    "COMPLETENESS_OUTCOMES",
    "CONTINUITY_DISTANCE",
    "CONTINUITY_SETS",
    "NEAR_SINGULAR_MAX",
    "OUTCOMES",
    "POSE_ROUNDING",
    "REFERENCE_KINDS",
    "ROUNDED_DIGITS",
    "SAMPLE_SETS",
    "SEED_PERTURBATION",
    "SINGULAR_FAMILY_FIXED_JOINTS",
    "SPECIAL_ANGLES",
    "WRIST_JOINT",
    "WRIST_SINGULAR",
    "IKCallable",
    "ReferenceSpec",
    "SampleResult",
    "TargetModel",
    "ValidationReport",
    "_resolvable",
    "adapt",
    "failures_json",
    "load_ik",
    "own_ik",
    "perturbed_seeds",
    "replay",
    "resolve_reference",
    "rounded_urdf",
    "sample_joint_vectors",
    "target_model",
    "tool_frame_from_robot",
    "validate",
    "write_failures",
]
