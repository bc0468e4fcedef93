"""The outline of a URDF, read with the standard library's XML parser before Pinocchio sees it.

urdfdom reports any fault as "The XML stream does not contain a valid URDF model" (the cause
only on its stderr), and reads some faults silently (an axis of length 0 or 1e300 becomes no
motion at all); here each fault is one line naming the file, the joint or link and its place,
and what was expected. The outline also holds what an import needs of each joint (type, links,
axis, limits, mimic), so no other URDF reader is needed.

A *place* is where an element was written: "line L" of a URDF, or, for a xacro file expanded by
:mod:`dhkin.xacro_expansion`, "line L of FILE" in the user's file (the macro file for an element
a macro made); ``places`` gives one per element of the expanded text, in document order.

Joint values and limits follow the URDF: radians (revolute, continuous) and metres (prismatic).
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from dhkin.errors import URDFError

#: Most joints (of any type, fixed ones included) a URDF may have: dhkin reads descriptions of
#: single arms, and a real one, with its gripper, tool changer, cameras and sensor frames, has a
#: few dozen (the vendor descriptions in robots/vendor have 7 to 12, the UR files with their
#: fixed frames the most; a two-finger gripper adds 2 to 10). The limit is checked while the
#: file is parsed, before Pinocchio builds anything, so that a runaway file (a generator loop, a
#: whole cell of robots) gets a clear error instead of exhausting memory; 256 leaves room for a
#: description ten times larger than any real arm's.
MAX_DESCRIPTION_JOINTS = 256

#: URDF joint types (urdfdom refuses any other).
URDF_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
#: Joint types whose ``<axis>`` urdfdom reads (the others ignore it).
AXIS_TYPES = ("revolute", "continuous", "prismatic", "planar")
#: The axis urdfdom gives a joint without ``<axis>``.
DEFAULT_AXIS = (1.0, 0.0, 0.0)
#: Attributes of ``<limit>`` that are numbers.
LIMIT_KEYS = ("lower", "upper", "velocity", "effort")

#: A decimal number as urdfdom reads one (no "inf", "nan", digit separators or hex).
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
#: Lengths of an axis that Pinocchio normalises exactly: its squared length must be a normal
#: float (a smaller one loses digits as a subnormal, a larger one overflows to inf).
AXIS_LENGTH_RANGE = (math.sqrt(sys.float_info.min), math.sqrt(sys.float_info.max))


@dataclass(frozen=True)
class OutlineJoint:
    """A ``<joint>`` element of a URDF as written: name, type, parent and child link, the joint
    it mimics (or None), its line in the text, its place in the user's file (see the module
    docstring), its unit axis (:data:`DEFAULT_AXIS` when not given; moving joints only) and its
    ``<limit>`` numbers (a key absent when not written; None: no ``<limit>``)."""

    name: str
    type: str
    parent: str
    child: str
    mimic: str | None
    line: int
    place: str = ""
    axis: tuple[float, float, float] = DEFAULT_AXIS
    limit: dict[str, float] | None = field(default=None, compare=False)

    @property
    def label(self) -> str:
        """``joint 'NAME' (PLACE)``, as messages name the joint."""
        return f"joint {self.name!r} ({self.place or f'line {self.line}'})"


@dataclass(frozen=True)
class UrdfOutline:
    """The links and joints of a URDF that forms one tree (checked by :func:`outline_urdf`)."""

    source: str
    links: tuple[str, ...]
    joints: tuple[OutlineJoint, ...]
    robot_name: str = ""

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


class _OutlineReader:
    """expat handlers collecting the ``<link>`` and ``<joint>`` children of ``<robot>`` and the
    ``<parent>``, ``<child>``, ``<mimic>``, ``<axis>`` and ``<limit>`` of each joint
    (depth-tracked: the ``<joint>`` of a ``<transmission>`` is not a joint)."""

    def __init__(self, source: str, places: Sequence[str | None] | None) -> None:
        from xml.parsers import expat

        self.source = source
        self.places = places
        self.parser = expat.ParserCreate()
        self.parser.StartElementHandler = self.start
        self.parser.EndElementHandler = self.end
        self.depth = 0
        self.elements = 0
        self.root: str | None = None
        self.robot_name = ""
        self.links: list[tuple[str | None, str]] = []
        self.joints: list[dict[str, Any]] = []
        self.current: dict[str, Any] | None = None

    def fail(self, message: str, **parts: Any) -> URDFError:
        return URDFError(f"{self.source}: {message}", **parts)

    def place(self, line: int, column: int | None = None) -> str:
        """Where the element just started was written (see the module docstring)."""
        if self.places is not None:
            index = self.elements - 1
            found = self.places[index] if index < len(self.places) else None
            return found or f"line {line} of the xacro-expanded text"
        return f"line {line}" + ("" if column is None else f", column {column}")

    def start(self, tag: str, attributes: dict[str, str]) -> None:
        self.depth += 1
        self.elements += 1
        line = self.parser.CurrentLineNumber
        if self.depth == 1:
            self.root = tag
            self.robot_name = attributes.get("name", "")
            if tag != "robot":
                raise self.fail(f"the root element is <{tag}> ({self.place(line)}); expected "
                                "<robot>", field="robot", value=tag,
                                expected="a <robot> root element")
        elif self.depth == 2 and tag == "link":
            self.links.append((attributes.get("name"),
                               self.place(line, self.parser.CurrentColumnNumber + 1)))
        elif self.depth == 2 and tag == "joint":
            if len(self.joints) >= MAX_DESCRIPTION_JOINTS:
                raise self.fail(f"more than {MAX_DESCRIPTION_JOINTS} joints (joint "
                                f"{len(self.joints) + 1}, {attributes.get('name')!r}, at "
                                f"{self.place(line)}); expected at most "
                                f"MAX_DESCRIPTION_JOINTS = {MAX_DESCRIPTION_JOINTS} (one arm "
                                "with its tools)", field="joints",
                                value=len(self.joints) + 1,
                                expected=f"at most {MAX_DESCRIPTION_JOINTS} joints")
            self.current = {"name": attributes.get("name"), "type": attributes.get("type"),
                            "line": line, "place": self.place(line), "parent": None,
                            "child": None, "mimic": None, "axis": None, "limit": None}
            self.joints.append(self.current)
        elif self.depth == 3 and self.current is not None:
            if tag in ("parent", "child"):
                self.current[tag] = attributes.get("link")
            elif tag == "mimic":
                self.current["mimic"] = attributes.get("joint") or "?"
            elif tag == "axis":
                self.current["axis"] = attributes.get("xyz")
            elif tag == "limit":
                self.current["limit"] = dict(attributes)

    def end(self, tag: str) -> None:
        if self.depth == 2:
            self.current = None
        self.depth -= 1


def outline_urdf(text: str, source: str = "<urdf>",
                 places: Sequence[str | None] | None = None) -> UrdfOutline:
    """Check that ``text`` is a URDF whose links and joints form one tree, and return its outline.

    One-line URDFError naming ``source``, the place and the fault: not XML (the parser's message,
    line and column), a root element other than ``<robot>``, more than
    :data:`MAX_DESCRIPTION_JOINTS` joints, a link or joint without a name or named twice, a joint
    without a known type or without ``<parent link>``/``<child link>``, a joint naming a link the
    file does not define, a moving joint's axis that is not a direction Pinocchio reads exactly,
    a ``<limit>`` number that is not a finite number, a link with two parent joints or a cycle
    (a kinematic loop: the joint closing it is named), several roots or none. ``places``: the
    user's place of each element of ``text`` (an expanded xacro; see the module docstring).
    """
    from xml.parsers import expat

    reader = _OutlineReader(source, places)
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
    return UrdfOutline(source=source, links=tuple(links), joints=tuple(joints),
                       robot_name=reader.robot_name)


def _outline_links(reader: _OutlineReader) -> dict[str, str]:
    """Link name -> its place; URDFError for a link without a name or named twice."""
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
    """The joints, checked one by one (name, type, parent, child, known links, axis, limit)."""
    joints: list[OutlineJoint] = []
    seen: dict[str, str] = {}
    for entry in reader.joints:
        name, place = entry["name"], entry["place"]
        if not name:
            raise reader.fail(f"the <joint> at {place} has no name; expected "
                              "<joint name=... type=...>", field="joint", value=place,
                              expected="a named joint")
        where = f"joint {name!r} ({place})"
        if name in seen:
            raise reader.fail(f"{where} is defined twice ({seen[name]} and {place}); "
                              "expected one <joint> per name", field="joint", value=name,
                              expected="unique joint names")
        seen[name] = place
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
        axis = DEFAULT_AXIS
        if entry["type"] in AXIS_TYPES and entry["axis"] is not None:
            axis = _axis(reader, where, entry["axis"])
        limit = None if entry["limit"] is None else _limit(reader, where, entry["limit"])
        joints.append(OutlineJoint(name, entry["type"], entry["parent"], entry["child"],
                                   entry["mimic"], entry["line"], place, axis, limit))
    return joints


def _numbers(text: str) -> list[float] | None:
    parts = text.split()
    if not all(_NUMBER.fullmatch(part) for part in parts):
        return None
    return [float(part) for part in parts]


def _axis(reader: _OutlineReader, where: str, text: str) -> tuple[float, float, float]:
    """The unit axis of ``<axis xyz=TEXT>``; URDFError unless it is three decimal numbers whose
    length lies in :data:`AXIS_LENGTH_RANGE` (Pinocchio reads any other as no motion, or
    normalises it inexactly)."""
    values = _numbers(text)
    low, high = AXIS_LENGTH_RANGE
    if values is None or len(values) != 3:
        raise reader.fail(f"{where} axis: expected three decimal numbers, got {text!r}",
                          field="axis", value=text, expected="three numbers")
    square = math.fsum(v * v for v in values)
    if not low * low <= square <= high * high:
        raise reader.fail(f"{where} axis: expected a direction of length between {low:.3g} and "
                          f"{high:.3g} (which Pinocchio normalises exactly), got {text!r}",
                          field="axis", value=text, expected="a non-zero direction")
    length = math.sqrt(square)
    return (values[0] / length, values[1] / length, values[2] / length)


def _limit(reader: _OutlineReader, where: str, attributes: dict[str, str]) -> dict[str, float]:
    """The numbers of a ``<limit>``; URDFError for one that is not a finite decimal number."""
    limit = {}
    for key in LIMIT_KEYS:
        if key not in attributes:
            continue
        values = _numbers(attributes[key])
        if values is None or len(values) != 1:
            raise reader.fail(f"{where} limit {key}: expected a number, got "
                              f"{attributes[key]!r}", field=key, value=attributes[key],
                              expected="a number")
        limit[key] = values[0]
    return limit


def _outline_tree(source: str, links: dict[str, str], joints: list[OutlineJoint]) -> None:
    """One tree: one parent joint per link, no cycle, one root. A loop is named by the joint
    that closes it (the later one in the text)."""
    parent_joint: dict[str, OutlineJoint] = {}
    for joint in joints:
        other = parent_joint.get(joint.child)
        if other is not None:
            raise URDFError(f"{source}: kinematic loop closed by {joint.label}: link "
                            f"{joint.child!r} is already the child of {other.label}; expected a "
                            "tree (one parent joint per link)", field="joint", value=joint.name,
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
            closing = max(cycle, key=joints.index)  # the later one in the text
            members = ", ".join(j.label for j in cycle[::-1])
            raise URDFError(f"{source}: kinematic loop closed by {closing.label}: joints "
                            f"{members} form a cycle; expected a tree", field="joint",
                            value=closing.name, expected="a tree of links")
    roots = [link for link in links if link not in parent_joint]
    if len(roots) != 1:
        raise URDFError(f"{source}: {len(roots)} root links {roots[:10]} (links that are no "
                        "joint's child); expected one tree with one root link", field="links",
                        value=roots[:10], expected="one root link")
