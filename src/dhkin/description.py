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

#: Most joints (of any type, fixed ones included) a URDF may have: dhkin reads descriptions of
#: single arms, and a real one, with its gripper, tool changer, cameras and sensor frames, has a
#: few dozen (the reference descriptions in robots/vendor have 7 to 12, the UR files with
#: their fixed frames the most; a two-finger gripper adds 2 to 10). The limit
#: is checked while the file is parsed, before Pinocchio or yourdfpy build anything, so that a
#: runaway file (a generator loop, a whole cell of robots) gets a clear error instead of
#: exhausting memory; 256 leaves room for a description ten times larger than any real arm's.
MAX_DESCRIPTION_JOINTS = 256

#: URDF joint types (urdfdom refuses any other).
URDF_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
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
    outline_urdf(text, str(file))  # the faults yourdfpy would report vaguely, with their lines
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


# --------------------------------------------------------------------------------------------
# The outline of a URDF, read with the standard library's XML parser before Pinocchio or yourdfpy
# see the text: urdfdom reports any fault as "The XML stream does not contain a valid URDF model"
# (the cause only on its stderr), yourdfpy as an lxml or KeyError message; here each fault is
# named with its line.


@dataclass(frozen=True)
class OutlineJoint:
    """A ``<joint>`` element of a URDF as written: name, type, parent and child link, the joint
    it mimics (or None), and its line in the file."""

    name: str
    type: str
    parent: str
    child: str
    mimic: str | None
    line: int


@dataclass(frozen=True)
class UrdfOutline:
    """The links and joints of a URDF that forms one tree (checked by :func:`outline_urdf`)."""

    source: str
    links: tuple[str, ...]
    joints: tuple[OutlineJoint, ...]

    def joints_above(self, link: str, base: str | None = None) -> list[OutlineJoint]:
        """The joints from ``base`` (default: the root) down to ``link``, base to tip; empty
        when ``link`` is not a link of the file (a frame Pinocchio names after a joint)."""
        by_child = {joint.child: joint for joint in self.joints}
        path: list[OutlineJoint] = []
        while link in by_child and link != base:
            joint = by_child[link]
            path.append(joint)
            link = joint.parent
        return path[::-1]


def read_urdf_file(path: str | Path) -> str:
    """The text of a URDF file; URDFError naming the file when it cannot be read or is not
    UTF-8 text."""
    file = Path(path)
    try:
        return file.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise URDFError(f"{file}: not UTF-8 text (byte {exc.object[exc.start:exc.start + 1]!r} "
                        f"at offset {exc.start}); expected a URDF (XML text)",
                        field="urdf", value=str(file), expected="a URDF (XML text)") from exc
    except OSError as exc:
        reason = ("no such URDF file" if isinstance(exc, FileNotFoundError)
                  else exc.strerror or str(exc))
        raise URDFError(f"{file}: cannot read URDF ({reason})", field="urdf",
                        value=str(file), expected="a readable URDF file") from exc


class _OutlineReader:
    """expat handlers collecting the ``<link>`` and ``<joint>`` children of ``<robot>`` and the
    ``<parent>``, ``<child>``, ``<mimic>`` of each joint (depth-tracked: the ``<joint>`` of a
    ``<transmission>`` is not a joint)."""

    def __init__(self, source: str) -> None:
        from xml.parsers import expat

        self.source = source
        self.parser = expat.ParserCreate()
        self.parser.StartElementHandler = self.start
        self.parser.EndElementHandler = self.end
        self.depth = 0
        self.root: str | None = None
        self.links: list[tuple[str | None, str]] = []
        self.joints: list[dict[str, Any]] = []
        self.current: dict[str, Any] | None = None

    def fail(self, message: str, **parts: Any) -> URDFError:
        return URDFError(f"{self.source}: {message}", **parts)

    def start(self, tag: str, attributes: dict[str, str]) -> None:
        self.depth += 1
        line = self.parser.CurrentLineNumber
        if self.depth == 1:
            self.root = tag
            if tag != "robot":
                raise self.fail(f"the root element is <{tag}> (line {line}); expected <robot>",
                                field="robot", value=tag, expected="a <robot> root element")
        elif self.depth == 2 and tag == "link":
            where = f"line {line}, column {self.parser.CurrentColumnNumber + 1}"
            self.links.append((attributes.get("name"), where))
        elif self.depth == 2 and tag == "joint":
            if len(self.joints) >= MAX_DESCRIPTION_JOINTS:
                raise self.fail(f"more than {MAX_DESCRIPTION_JOINTS} joints (joint "
                                f"{len(self.joints) + 1}, {attributes.get('name')!r}, at line "
                                f"{line}); expected at most "
                                f"MAX_DESCRIPTION_JOINTS = {MAX_DESCRIPTION_JOINTS} (one arm "
                                "with its tools)", field="joints",
                                value=len(self.joints) + 1,
                                expected=f"at most {MAX_DESCRIPTION_JOINTS} joints")
            self.current = {"name": attributes.get("name"), "type": attributes.get("type"),
                            "line": line, "parent": None, "child": None, "mimic": None}
            self.joints.append(self.current)
        elif self.depth == 3 and self.current is not None and tag in ("parent", "child"):
            self.current[tag] = attributes.get("link")
        elif self.depth == 3 and self.current is not None and tag == "mimic":
            self.current["mimic"] = attributes.get("joint") or "?"

    def end(self, tag: str) -> None:
        if self.depth == 2:
            self.current = None
        self.depth -= 1


def outline_urdf(text: str, source: str = "<urdf>") -> UrdfOutline:
    """Check that ``text`` is a URDF whose links and joints form one tree, and return its outline.

    One-line URDFError naming ``source``, the line and the fault: not XML (the parser's message,
    line and column), a root element other than ``<robot>``, more than
    :data:`MAX_DESCRIPTION_JOINTS` joints, a link or joint without a name or named twice, a joint
    without a known type or without ``<parent link>``/``<child link>``, a joint naming a link the
    file does not define, a link with two parent joints or a cycle (a kinematic loop: the joint
    closing it is named), several roots or none.
    """
    from xml.parsers import expat

    reader = _OutlineReader(source)
    try:
        reader.parser.Parse(text, True)
    except expat.ExpatError as exc:
        reason = expat.errors.messages[exc.code] if exc.code else str(exc)
        raise URDFError(f"{source}: not well-formed XML ({reason} at line {exc.lineno}, column "
                        f"{exc.offset + 1}); expected a URDF", field="urdf", value=source,
                        expected="a URDF (well-formed XML)") from None
    except RecursionError:  # expat does not recurse; kept for exotic builds
        raise URDFError(f"{source}: XML nested too deeply to read; expected a URDF",
                        field="urdf", value=source, expected="a URDF") from None
    if reader.root is None:
        raise URDFError(f"{source}: no XML element; expected a <robot> element", field="urdf",
                        value=source, expected="a <robot> element")
    links = _outline_links(reader)
    if not links:
        raise URDFError(f"{source}: no <link> element in <robot>; expected a URDF with links",
                        field="urdf", value=source, expected="a URDF with links")
    joints = _outline_joints(reader, links)
    _outline_tree(source, links, joints)
    return UrdfOutline(source=source, links=tuple(links), joints=tuple(joints))


def _outline_links(reader: _OutlineReader) -> dict[str, str]:
    """Link name -> its place ("line L, column C"); URDFError for a link without a name or
    named twice."""
    places: dict[str, str] = {}
    for name, place in reader.links:
        if not name:
            raise reader.fail(f"the <link> at {place} has no name; expected <link name=...>",
                              field="link", value=place, expected="a named link")
        if name in places:
            raise reader.fail(f"link {name!r} is defined twice ({places[name]} and {place}); "
                              "expected one <link> per name", field="link", value=name,
                              expected="unique link names")
        places[name] = place
    return places


def _outline_joints(reader: _OutlineReader, links: dict[str, str]) -> list[OutlineJoint]:
    """The joints, checked one by one (name, type, parent, child, known links)."""
    joints: list[OutlineJoint] = []
    seen: dict[str, int] = {}
    for entry in reader.joints:
        name, line = entry["name"], entry["line"]
        if not name:
            raise reader.fail(f"the <joint> at line {line} has no name; expected "
                              "<joint name=... type=...>", field="joint", value=line,
                              expected="a named joint")
        where = f"joint {name!r} (line {line})"
        if name in seen:
            raise reader.fail(f"{where} is defined twice (lines {seen[name]} and {line}); "
                              "expected one <joint> per name", field="joint", value=name,
                              expected="unique joint names")
        seen[name] = line
        if entry["type"] not in URDF_JOINT_TYPES:
            raise reader.fail(f"{where} has type {entry['type']!r}; expected one of "
                              f"{list(URDF_JOINT_TYPES)}", field="joint", value=name,
                              expected=f"a type among {list(URDF_JOINT_TYPES)}")
        for role in ("parent", "child"):
            link = entry[role]
            if not link:
                raise reader.fail(f"{where} has no <{role} link=...>; expected one parent and "
                                  "one child link", field="joint", value=name,
                                  expected=f"a <{role} link=...> element")
            if link not in links:
                raise reader.fail(f"{where} names {role} link {link!r}, which no <link> "
                                  "defines; expected a link of the file", field="joint",
                                  value=name, expected="links defined by the file")
        joints.append(OutlineJoint(name, entry["type"], entry["parent"], entry["child"],
                                   entry["mimic"], line))
    return joints


def _outline_tree(source: str, links: dict[str, str], joints: list[OutlineJoint]) -> None:
    """One tree: one parent joint per link, no cycle, one root. A loop is named by the joint
    that closes it (the later one in the file)."""
    parent_joint: dict[str, OutlineJoint] = {}
    for joint in joints:
        other = parent_joint.get(joint.child)
        if other is not None:
            raise URDFError(f"{source}: kinematic loop closed by joint {joint.name!r} (line "
                            f"{joint.line}): link {joint.child!r} is already the child of joint "
                            f"{other.name!r} (line {other.line}); expected a tree (one parent "
                            "joint per link)", field="joint", value=joint.name,
                            expected="a tree of links")
        parent_joint[joint.child] = joint
    for start in links:  # cycles: walk up from each link (each link has one parent at most)
        seen: set[str] = set()
        link = start
        while link in parent_joint and link not in seen:
            seen.add(link)
            link = parent_joint[link].parent
        if link in seen:
            cycle = [parent_joint[link]]
            while cycle[-1].parent != link:
                cycle.append(parent_joint[cycle[-1].parent])
            closing = max(cycle, key=lambda j: j.line)
            raise URDFError(f"{source}: kinematic loop closed by joint {closing.name!r} (line "
                            f"{closing.line}): joints {[j.name for j in cycle[::-1]]} form a "
                            "cycle; expected a tree", field="joint", value=closing.name,
                            expected="a tree of links")
    roots = [link for link in links if link not in parent_joint]
    if len(roots) != 1:
        raise URDFError(f"{source}: {len(roots)} root links {roots[:10]} (links that are no "
                        "joint's child); expected one tree with one root link", field="links",
                        value=roots[:10], expected="one root link")
