"""Inverse kinematics: result types, closed-form families and their shared pipeline."""

from dhkin.ik.result import (
    ELBOW,
    SHOULDER,
    WRIST,
    BranchSolutions,
    Configuration,
    IKBatch,
    IKSolutions,
)

__all__ = ["ELBOW", "SHOULDER", "WRIST", "BranchSolutions", "Configuration", "IKBatch",
           "IKSolutions"]
