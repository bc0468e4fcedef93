"""The one default tolerance of dhkin.

A pose is *reproduced* when its position error is at most the tolerance in metres and its
rotation error (the angle of R_found^T R_target) at most the tolerance in radians. The same
default holds wherever dhkin decides that: an IK solution, closed-form or numerical, verified by
FK; a fitted table against its description; two descriptions compared; an IK validated against
the oracle. Every such call takes ``tolerance=`` to change it. Thresholds derived from it (the
closed form's refinement goal, the verification margin for FK rounding) are documented where
they are used (docs/ik_core.md).
"""

from __future__ import annotations

#: Position (m) and rotation (rad) error within which a pose counts as reproduced.
DEFAULT_TOLERANCE = 1e-9
