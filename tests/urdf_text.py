"""URDF text of serial chains written link by link, for the description tests (no dhkin code:
the text is what a user or another library writes)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field


def numbers(values: Sequence[float]) -> str:
    return " ".join(repr(float(v)) for v in values)


@dataclass
class ChainJoint:
    """One joint of a chain: its name, type, child link, origin (xyz m, rpy rad), axis and
    limits (rad or m; ``None``: no <limit>), and free text for its line."""

    name: str
    child: str
    xyz: Sequence[float] = (0.0, 0.0, 0.1)
    rpy: Sequence[float] = (0.0, 0.0, 0.0)
    type: str = "revolute"
    axis: str | None = "0 0 1"
    limit: str | None = 'lower="-3" upper="3" effort="10" velocity="2"'
    extra: str = ""
    attributes: dict[str, str] = field(default_factory=dict)


def chain_urdf(joints: Sequence[ChainJoint], base: str = "base_link", robot: str = "arm",
               declaration: str = "", comment: str = "") -> str:
    """A URDF: ``base``, then each joint with its child link, one joint per line."""
    lines = [declaration] if declaration else []
    lines.append(f'<robot name="{robot}">')
    if comment:
        lines.append(f"<!-- {comment} -->")
    lines.append(f'<link name="{base}"/>')
    parent = base
    for joint in joints:
        body = [f'<origin xyz="{numbers(joint.xyz)}" rpy="{numbers(joint.rpy)}"/>',
                f'<parent link="{parent}"/>', f'<child link="{joint.child}"/>']
        if joint.axis is not None and joint.type != "fixed":
            body.append(f'<axis xyz="{joint.axis}"/>')
        if joint.limit is not None and joint.type != "fixed":
            body.append(f"<limit {joint.limit}/>")
        lines.append(f'<link name="{joint.child}"/>')
        lines.append(f'<joint name="{joint.name}" type="{joint.type}">{"".join(body)}'
                     f'{joint.extra}</joint>')
        parent = joint.child
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def six_joints(last_child: str = "tool0", prefix: str = "") -> list[ChainJoint]:
    """A UR-like 6R arm written link by link (UR e-series, FANUC CRX in some libraries): the
    last moving joint's child is ``last_child``, no fixed frame after it."""
    p = prefix
    return [
        ChainJoint(f"{p}shoulder_pan_joint", f"{p}shoulder_link", (0, 0, 0.1625), (0, 0, 0)),
        ChainJoint(f"{p}shoulder_lift_joint", f"{p}upper_arm_link", (0, 0, 0),
                   (1.5707963267948966, 0, 0)),
        ChainJoint(f"{p}elbow_joint", f"{p}forearm_link", (-0.425, 0, 0), (0, 0, 0)),
        ChainJoint(f"{p}wrist_1_joint", f"{p}wrist_1_link", (-0.3922, 0, 0.1333), (0, 0, 0)),
        ChainJoint(f"{p}wrist_2_joint", f"{p}wrist_2_link", (0, -0.0997, 0),
                   (1.5707963267948966, 0, 0)),
        ChainJoint(f"{p}wrist_3_joint", f"{p}{last_child}", (0, 0.0996, 0),
                   (1.5707963267948966, 3.141592653589793, 3.141592653589793)),
    ]
