"""A robot description as users bring it: a URDF or xacro file, read into its kinematic tree.

:func:`read_description` reads the file in the encoding it declares (:mod:`dhkin.xml_file`),
expands xacro (:mod:`dhkin.xacro_expansion`: ``$(find NAME)`` resolved without ROS by
:mod:`dhkin.ros_packages`, ``name:=value`` arguments) and reads the URDF's outline
(:mod:`dhkin.urdf_outline`: one tree, every fault named with its place in the user's file);
:class:`Description` answers the structural questions an import asks: the root, the leaves, the
joints on the path from a base link down to a tip link, and the joints that are off that path or
mimic another. Geometry (joint frames and axes) is read with Pinocchio by
:func:`dhkin.fit.read_chain`; this module holds no kinematics.

Joint values follow the URDF: radians (revolute, continuous) and metres (prismatic).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from dhkin.errors import URDFError
from dhkin.ros_packages import PackageFinder
from dhkin.urdf_outline import (
    MAX_DESCRIPTION_JOINTS,
    URDF_JOINT_TYPES,
    OutlineJoint,
    UrdfOutline,
    outline_urdf,
)
from dhkin.xacro_expansion import expand_xacro_located, is_xacro
from dhkin.xml_file import read_xml_file

#: Re-exported: the outline of a URDF lives in dhkin.urdf_outline.
__all__ = ["ACTUATED_TYPES", "CONTINUOUS_LIMIT", "MAX_DESCRIPTION_JOINTS", "UNSUPPORTED_TYPES",
           "URDF_JOINT_TYPES", "Description", "DescriptionJoint", "OutlineJoint", "UrdfOutline",
           "outline_urdf", "read_description", "read_urdf_file"]
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
    none), velocity and effort limits (0 where absent), the joint it mimics (or None), and its
    place in the user's file ("line L" or "line L of FILE", for messages)."""

    name: str
    type: str
    parent: str
    child: str
    lower: float | None
    upper: float | None
    velocity: float
    effort: float
    mimic: str | None
    place: str = ""

    @property
    def label(self) -> str:
        """``joint 'NAME' (PLACE)``, as messages name the joint."""
        return f"joint {self.name!r}" + (f" ({self.place})" if self.place else "")

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


def read_description(path: str | Path, xacro_args: Mapping[str, str] | None = None,
                     packages: Mapping[str, str | Path] | None = None,
                     environ: Mapping[str, str] | None = None) -> Description:
    """Read a URDF or xacro file (xacro when the name ends in ``.xacro`` or the text declares the
    xacro namespace; ``xacro_args`` are its ``name:=value`` arguments, ``packages`` the folders
    of the ROS packages its ``$(find NAME)`` name, besides those the environment ``environ``
    (default ``os.environ``) and the checkout around the file give: dhkin.ros_packages).
    URDFError, naming the file and the place, when it cannot be read, expanded or parsed, or
    when its links do not form one tree."""
    file = Path(path)
    raw = read_xml_file(file, "description")
    places = None
    if is_xacro(file, raw):
        finder = PackageFinder.for_description(file, packages, environ)
        expansion = expand_xacro_located(file, finder, xacro_args)
        text, places = expansion.text, expansion.places
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
    outline = outline_urdf(text, str(file), places)
    return Description(source=str(file), text=text, robot_name=outline.robot_name or file.stem,
                       links=outline.links, joints=tuple(_joint(j) for j in outline.joints))


def read_urdf_file(path: str | Path, packages: Mapping[str, str | Path] | None = None) -> str:
    """The URDF text of a description file (a xacro file expanded, as :func:`read_description`
    does); URDFError naming the file when it cannot be read, expanded or is not one tree."""
    file = Path(path)
    text = read_xml_file(file, "URDF")
    if not is_xacro(file, text):
        return text
    return read_description(file, packages=packages).text


def _joint(joint: OutlineJoint) -> DescriptionJoint:
    """An outline joint -> DescriptionJoint (velocity and effort 0 where the URDF gives none)."""
    limit = joint.limit or {}
    return DescriptionJoint(name=joint.name, type=joint.type, parent=joint.parent,
                            child=joint.child, lower=limit.get("lower"), upper=limit.get("upper"),
                            velocity=limit.get("velocity", 0.0), effort=limit.get("effort", 0.0),
                            mimic=joint.mimic, place=joint.place)
