"""A robot description as users bring it: a URDF or xacro file, read into its kinematic tree.

:func:`read_description` expands xacro (with the xacro package, ``name:=value`` arguments) and
parses the URDF with yourdfpy; :class:`Description` answers the structural questions an import
asks: the root, the leaves, the joints on the path from a base link down to a tip link, and the
joints that are off that path or mimic another. Geometry (joint frames and axes) is read with
Pinocchio by :func:`dhkin.fit.read_chain`; this module holds no kinematics.

Joint values follow the URDF: radians (revolute, continuous) and metres (prismatic).
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dhkin.errors import URDFError

#: URDF joint types that move, and the one kind of each a DH row can hold.
ACTUATED_TYPES: dict[str, str] = {"revolute": "revolute", "continuous": "revolute",
                                  "prismatic": "prismatic"}
#: Joint types a DH chain cannot hold (more than one degree of freedom).
UNSUPPORTED_TYPES = ("floating", "planar")
#: Limits written for a continuous joint, which has none in the URDF (rad): one turn each way.
CONTINUOUS_LIMIT = 2.0 * math.pi


@dataclass(frozen=True)
class DescriptionJoint:
    """One URDF joint: type, parent and child link, limits (rad or m; None where the URDF gives
    none), velocity and effort limits (0 where absent), and the joint it mimics (or None)."""

    name: str
    type: str
    parent: str
    child: str
    lower: float | None
    upper: float | None
    velocity: float
    effort: float
    mimic: str | None

    @property
    def actuated(self) -> bool:
        return self.type in ACTUATED_TYPES


@dataclass(frozen=True)
class Description:
    """The kinematic tree of a URDF: ``text`` is the URDF (xacro expanded), ``source`` the user's
    file name that every message names."""

    source: str
    text: str
    robot_name: str
    links: tuple[str, ...]
    joints: tuple[DescriptionJoint, ...]

    @property
    def root(self) -> str:
        """The one link that is no joint's child (checked on reading)."""
        children = {joint.child for joint in self.joints}
        return next(link for link in self.links if link not in children)

    def leaves(self) -> list[str]:
        """Links that are no joint's parent, in file order."""
        parents = {joint.parent for joint in self.joints}
        return [link for link in self.links if link not in parents]

    def joint(self, name: str) -> DescriptionJoint:
        return next(joint for joint in self.joints if joint.name == name)

    def path(self, base: str, tip: str) -> list[DescriptionJoint]:
        """The joints from ``base`` down to ``tip`` (base to tip). URDFError when a link is
        missing (listing the links) or ``tip`` does not hang below ``base``."""
        for role, link in (("base", base), ("tip", tip)):
            if link not in self.links:
                raise URDFError(f"{self.source}: no link {link!r} for the {role}; links: "
                                f"{list(self.links)}", field=role, value=link,
                                expected=f"one of {list(self.links)}")
        by_child = {joint.child: joint for joint in self.joints}
        path: list[DescriptionJoint] = []
        link = tip
        while link != base:
            joint = by_child.get(link)
            if joint is None:
                raise URDFError(f"{self.source}: link {tip!r} does not hang below {base!r} (the "
                                f"path up from {tip!r} ends at the root {link!r}); expected a "
                                "base link above the tip", field="tip", value=tip,
                                expected=f"a link below {base!r}")
            path.append(joint)
            link = joint.parent
        return path[::-1]


def read_description(path: str | Path, xacro_args: Mapping[str, str] | None = None
                     ) -> Description:
    """Read a URDF or xacro file (xacro when the name ends in ``.xacro`` or the text declares the
    xacro namespace; ``xacro_args`` are its ``name:=value`` arguments). URDFError, naming the
    file, when it cannot be read, expanded or parsed, or when its links do not form one tree."""
    file = Path(path)
    try:
        raw = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise URDFError(f"{file}: cannot read the description ({reason})", field="description",
                        value=str(file), expected="a readable URDF or xacro file") from exc
    if file.suffix == ".xacro" or "ros.org/wiki/xacro" in raw:
        text = _expand_xacro(file, xacro_args or {})
    elif xacro_args:
        raise URDFError(f"{file}: xacro arguments {dict(xacro_args)} given, but the file is not "
                        "xacro; expected a .xacro file or no arguments", field="xacro_args",
                        value=dict(xacro_args), expected="none for a plain URDF")
    else:
        text = raw
    if "<robot" not in text:
        raise URDFError(f"{file}: not a URDF (no <robot> element); expected a URDF or xacro "
                        "file", field="description", value=str(file),
                        expected="a URDF or xacro file")
    import yourdfpy  # here: it takes ~0.5 s to import, and only imports need it

    try:
        robot = yourdfpy.URDF.load(io.StringIO(text), build_scene_graph=False,
                                   load_meshes=False, build_collision_scene_graph=False,
                                   load_collision_meshes=False).robot
    except Exception as exc:  # yourdfpy raises lxml, KeyError, ValueError ... on bad XML
        raise URDFError(f"{file}: not a valid URDF ({type(exc).__name__}: {exc})",
                        field="description", value=str(file),
                        expected="a URDF or xacro file") from exc
    joints = tuple(_joint(joint) for joint in robot.joints)
    links = tuple(link.name for link in robot.links)
    _check_tree(str(file), links, joints)
    return Description(source=str(file), text=text, robot_name=str(robot.name or file.stem),
                       links=links, joints=joints)


def _expand_xacro(file: Path, arguments: Mapping[str, str]) -> str:
    import xacro

    try:
        document = xacro.process_file(str(file), mappings=dict(arguments))
    except BaseException as exc:  # xacro raises XacroException, XML errors and SystemExit
        if isinstance(exc, KeyboardInterrupt):
            raise
        raise URDFError(f"{file}: xacro failed ({type(exc).__name__}: {exc})",
                        field="description", value=str(file),
                        expected="a xacro file that expands to a URDF") from exc
    return str(document.toxml())


def _joint(joint: Any) -> DescriptionJoint:
    """A yourdfpy joint -> DescriptionJoint."""
    limit = joint.limit
    lower = upper = None
    velocity = effort = 0.0
    if limit is not None:
        lower = None if limit.lower is None else float(limit.lower)
        upper = None if limit.upper is None else float(limit.upper)
        velocity = float(limit.velocity or 0.0)
        effort = float(limit.effort or 0.0)
    mimic = joint.mimic.joint if joint.mimic is not None else None
    return DescriptionJoint(name=joint.name, type=joint.type, parent=joint.parent,
                            child=joint.child, lower=lower, upper=upper, velocity=velocity,
                            effort=effort, mimic=mimic)


def _check_tree(source: str, links: tuple[str, ...], joints: tuple[DescriptionJoint, ...]
                ) -> None:
    """One tree: every joint's links exist, every link has at most one parent joint, one root,
    no loop."""
    known = set(links)
    for joint in joints:
        for role, link in (("parent", joint.parent), ("child", joint.child)):
            if link not in known:
                raise URDFError(f"{source}: joint {joint.name!r} names {role} link {link!r}, "
                                f"which the file does not define; links: {list(links)}")
    parents: dict[str, str] = {}
    for joint in joints:
        if joint.child in parents:
            raise URDFError(f"{source}: link {joint.child!r} is the child of joints "
                            f"{parents[joint.child]!r} and {joint.name!r}: the joints form a "
                            "loop; expected a tree (one parent joint per link)")
        parents[joint.child] = joint.name
    roots = [link for link in links if link not in parents]
    if len(roots) != 1:
        what = "every link has a parent: the joints form a loop" if not roots else \
            f"several roots {roots}"
        raise URDFError(f"{source}: {what}; expected one tree with one root link")
    by_child = {joint.child: joint.parent for joint in joints}
    for link in links:  # a cycle not reaching the root (the root count alone can miss it)
        seen = {link}
        while link in by_child:
            link = by_child[link]
            if link in seen:
                raise URDFError(f"{source}: the joints above link {link!r} form a loop; "
                                "expected a tree")
            seen.add(link)
