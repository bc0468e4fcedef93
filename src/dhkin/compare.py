"""Cross-check a DH table against another URDF (a vendor's): same joint values, same poses?

Both sides are evaluated with Pinocchio: ours on the URDF generated through xacro, theirs on the
given file. Joint vectors are sampled uniformly within the table's limits, plus the zero vector,
and fed to both in chain order (the actuated joints from the base frame to the tip), so link and
joint names may differ, continuous joints and fixed frames are fine.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.errors import URDFError
from dhkin.reference import Reference
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import pose_error

# Pass threshold of `dhkin compare`: dhkin's one DEFAULT_TOLERANCE (m and rad). The UR vendor
# files round pi/2 to 1.570796327 and carry 2e-11 m residues, so they sit ~6e-10 from the exact
# DH: 1e-9 is also the tightest honest threshold for them.


@dataclass(frozen=True)
class CompareReport:
    """Largest deviations between the table's URDF and the other URDF over ``samples`` q."""

    robot: str
    other: str
    base_frame: str
    tip: str
    robot_tip: str
    samples: int
    max_position: float
    max_rotation: float
    worst_q: NDArray[np.float64]
    tolerance: float

    @property
    def ok(self) -> bool:
        return self.max_position <= self.tolerance and self.max_rotation <= self.tolerance

    def summary(self) -> str:
        verdict = "OK" if self.ok else "FAIL"
        return (f"{verdict}: {self.robot} ({self.robot_tip}) vs {self.other} "
                f"({self.base_frame} -> {self.tip}) over {self.samples} joint vectors: "
                f"max position {self.max_position:.3e} m, max rotation {self.max_rotation:.3e} rad"
                f" (tolerance {self.tolerance:.0e})")


def compare_with_urdf(robot: Arm, urdf_path: str | Path, base_frame: str = "base_link",
                      tip: str = "tool0", robot_tip: str = "tool0", n: int = 1000, seed: int = 0,
                      tolerance: float = DEFAULT_TOLERANCE) -> CompareReport:
    """Compare ``robot`` (base_link -> robot_tip) with ``urdf_path`` (base_frame -> tip)."""
    path = Path(urdf_path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise URDFError(f"{path}: cannot read URDF ({exc.strerror})") from exc
    other = Reference(text, tip=tip, base=base_frame, source=str(path))
    ours = robot.reference(tip=robot_tip)
    if other.dof != robot.dof:
        raise URDFError(f"{path}: the chain {base_frame} -> {tip} has {other.dof} actuated joints "
                        f"{other.joint_names}; expected {robot.dof} like {robot.name}")
    if n < 1:
        raise URDFError(f"n: expected at least 1 sample, got {n}")
    rng = np.random.default_rng(seed)
    q = np.vstack([np.zeros(robot.dof), robot.table.random_q(n - 1, rng)])
    q = np.clip(q, robot.lower, robot.upper)
    position, rotation = pose_error(ours.fk(q), other.fk(q))
    worst = int(np.argmax(np.maximum(position, rotation)))
    return CompareReport(robot=robot.name, other=str(path), base_frame=base_frame, tip=tip,
                         robot_tip=robot_tip, samples=n, max_position=float(position.max()),
                         max_rotation=float(rotation.max()), worst_q=q[worst], tolerance=tolerance)
