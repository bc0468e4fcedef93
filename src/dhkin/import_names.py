"""Names and faults of an imported chain, as the description has them (``dhkin import``).

**Names.** A table keeps the description's joint names and the names of the links its moving
joints move; both must be names the generated files can hold (:data:`dhkin.xml_text.NAME_RULE`:
ROS-style names, with '/' between parts, as in ``wx250s/gripper_link``, kept as written in both
directions: import writes them into the table, export into the URDF). A description may let its
last moving joint move ``tool0`` itself (descriptions written link by link, such as the UR
e-series or FANUC CRX files of some libraries), or ``flange``: names dhkin's generated URDF gives
its own fixed frames (:data:`dhkin.dh.RESERVED_LINK_NAMES`). Such a link is renamed
``link_<i>`` (i: the joint's number; ``_`` added while that name is taken); when it is the tip
(tool0 moved by the last joint), the table's own fixed tool0 is written at the same place (the
table's tool transform is the identity up to the DH frame), so base_link -> tool0 is unchanged.
The import says which link it renamed, in its notes.

**Faults.** A table the description would make but dhkin cannot hold (a limit beyond two turns,
a length beyond a kilometre) is refused by :class:`dhkin.dh.DHTable` with a field such as
``joints[0].lower``; :func:`described_error` names the description's file and joint (and its
place) instead.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from dhkin.description import DescriptionJoint
from dhkin.dh import RESERVED_LINK_NAMES
from dhkin.errors import DhkinError, URDFError
from dhkin.xml_text import NAME_RULE, name_problem

_JOINT_FIELD = re.compile(r"joints\[(\d+)\]\.?")
#: The source an imported table is read back under (its messages are renamed by
#: :func:`described_error`).
IMPORTED_TABLE = "<imported table>"


def table_link_names(source: str, joints: Sequence[DescriptionJoint], tip: str
                     ) -> tuple[list[str], list[str]]:
    """The table's link names for the moving ``joints`` (their child links, reserved names
    renamed: module docstring), and the notes saying which were renamed. URDFError naming the
    file and joint for a joint or link name that is not a name."""
    for joint in joints:
        for what, value in (("name", joint.name), ("child link", joint.child)):
            problem = name_problem(value)
            if problem is not None:
                raise URDFError(f"{source}: {joint.label} {what}: {problem}", field=what,
                                value=value, expected=NAME_RULE)
    taken = {joint.child for joint in joints}
    links, notes = [], []
    for i, joint in enumerate(joints):
        link = joint.child
        if link in RESERVED_LINK_NAMES:
            renamed = f"link_{i + 1}"
            while renamed in taken:
                renamed += "_"
            taken.add(renamed)
            notes.append(f"{joint.label} moves link {link!r}, a name dhkin's URDF gives a fixed "
                         f"frame: the table names the link {renamed!r}"
                         + (" and writes its own fixed tool0 at the same place"
                            if link == tip == "tool0" else ""))
            link = renamed
        links.append(link)
    return links, notes


def described_error(error: DhkinError, source: str, joints: Sequence[DescriptionJoint]
                    ) -> URDFError:
    """``error`` (a field ``joints[i].key`` or a table field) as a URDFError naming the file and
    the description's joint i."""
    message = str(error).removeprefix(f"{IMPORTED_TABLE}: ")
    found = _JOINT_FIELD.match(message)
    if found is not None and int(found.group(1)) < len(joints):
        joint = joints[int(found.group(1))]
        message = f"{joint.label} {message[found.end():]}"
    return URDFError(f"{source}: {message}", field=error.field, value=error.value,
                     expected=error.expected)
