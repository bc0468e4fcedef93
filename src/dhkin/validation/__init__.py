"""Cross-validation of any IK callable against an oracle: Pinocchio on a reference description
(:mod:`.run` documents what is checked; :mod:`.calls` how the IK under test is called, guarded;
:mod:`.arguments` the limits of the arguments). Every public name is importable from
``dhkin.validation``; :func:`validate` is also ``dhkin.validate``.
"""

from __future__ import annotations

from dhkin.validation.adapters import (
    IKCallable,
    adapt,
    load_ik,
    own_ik,
)
from dhkin.validation.arguments import (
    MAX_JOINT_TOLERANCE,
    MAX_SAMPLES,
    MAX_TOLERANCE,
)
from dhkin.validation.calls import (
    DEFAULT_CALL_TIMEOUT,
    MAX_SOLUTIONS_PER_CALL,
    CallResult,
    IKCaller,
)
from dhkin.validation.failure_file import FailureFile, read_failure_file
from dhkin.validation.matching import SINGULAR_FAMILY_FIXED_JOINTS, WRIST_SINGULAR
from dhkin.validation.references import (
    REFERENCE_KINDS,
    ROUNDED_DIGITS,
    ReferenceSpec,
    TargetModel,
    resolve_reference,
    rounded_urdf,
    target_model,
    tool_frame_from_robot,
)
from dhkin.validation.report import (
    COMPLETENESS_OUTCOMES,
    OUTCOMES,
    SAMPLE_SETS,
    SampleResult,
    ValidationReport,
    failures_json,
    write_failures,
)
from dhkin.validation.rerun import replay
from dhkin.validation.run import (
    DEFAULT_JOINT_TOLERANCE,
    _resolvable,
    validate,
)
from dhkin.validation.sample_checks import POSE_ROUNDING
from dhkin.validation.samples import (
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
    "DEFAULT_CALL_TIMEOUT",
    "DEFAULT_JOINT_TOLERANCE",
    "MAX_JOINT_TOLERANCE",
    "MAX_SAMPLES",
    "MAX_SOLUTIONS_PER_CALL",
    "MAX_TOLERANCE",
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
    "CallResult",
    "FailureFile",
    "IKCallable",
    "IKCaller",
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
    "read_failure_file",
    "replay",
    "resolve_reference",
    "rounded_urdf",
    "sample_joint_vectors",
    "target_model",
    "tool_frame_from_robot",
    "validate",
    "write_failures",
]
