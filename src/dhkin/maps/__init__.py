"""Manipulability maps with singular loci: a workspace slice and joint slices (computed in
:mod:`.workspace` and :mod:`.joints`, drawn by :mod:`.draw`). Every public name is importable
from ``dhkin.maps``.
"""

from __future__ import annotations

from dhkin.maps.branches import (
    AXIS_NAMES,
    CHUNK,
    DEFAULT_JOINT_RESOLUTION,
    DEFAULT_RESOLUTION,
    DEFAULT_RPY,
    PLANES,
    Array,
    BranchSolver,
    Mask,
    has_copy_within_limits,
    principal_table,
)
from dhkin.maps.draw import (
    DPI,
    FIGURE_SIZE,
    KIND_STYLE,
    MEASURE_LABEL,
    SingularityMaps,
    describe,
    draw_maps,
)
from dhkin.maps.joints import (
    JointSlice,
    default_fixed_q,
    joint_slice,
)
from dhkin.maps.workspace import (
    BOUNDARY_BISECTIONS,
    SEGMENT_SAMPLES,
    WorkspaceSlice,
    default_extent,
    workspace_slice,
)

__all__ = [
    "AXIS_NAMES",
    "BOUNDARY_BISECTIONS",
    "CHUNK",
    "DEFAULT_JOINT_RESOLUTION",
    "DEFAULT_RESOLUTION",
    "DEFAULT_RPY",
    "DPI",
    "FIGURE_SIZE",
    "KIND_STYLE",
    "MEASURE_LABEL",
    "PLANES",
    "SEGMENT_SAMPLES",
    "Array",
    "BranchSolver",
    "JointSlice",
    "Mask",
    "SingularityMaps",
    "WorkspaceSlice",
    "default_extent",
    "default_fixed_q",
    "describe",
    "draw_maps",
    "has_copy_within_limits",
    "joint_slice",
    "principal_table",
    "workspace_slice",
]
