"""DH table -> ROS-Industrial style xacro (macro + top level) -> URDF through the xacro package.

Frames of the generated description (the names ROS users expect):

* ``base_link``: the robot's root; ``base``: DH frame 0 (= base_link @ table.base), a fixed frame.
* ``link_i`` (or the table's link name): the frame joint i moves. With the modified convention it
  is DH frame i (before row i's correction, if any); with the standard convention it is DH frame
  i-1 (after row i-1's correction) turned by theta_i (resp. shifted by d_i), because a standard DH
  row places the joint at the start of the row. The axis is always z of the joint's link frame.
* ``flange``: DH frame n @ table.flange (default: x along the last joint's axis, ROS-Industrial).
* ``tool0``: DH frame n @ table.tool, z out of the flange.

Each URDF joint origin is built from the parts of two consecutive DH rows that do not depend on
the joint variable; see :func:`joint_origins`.

Text: names (robot, joints, links, ``prefix``) are written as they are and must follow
:mod:`dhkin.xml_text`'s rules (checked on load, and again here for tables made in Python).
Each of the three files starts with a banner comment, then one comment per non-empty free-text
field of the table, ``<!-- description: ... -->`` and ``<!-- source: ... -->``, outside the
``<robot>`` element, where xacro does not look; the text is escaped as
:func:`dhkin.xml_text.comment_body` says (``--`` is written ``-\\-``) and
:func:`dhkin.xml_text.comment_text` recovers it exactly. Errors name the user's table (its path,
or its name for a table made in Python), never the temporary folder xacro runs in.
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xacro
from numpy.typing import NDArray

from dhkin.dh import DHTable, Joint, fixed_joint_names
from dhkin.errors import DHError, FileWriteError, InputError, URDFError
from dhkin.files import output_folder, write_files
from dhkin.table_file import exact_rpy
from dhkin.transforms import (
    invert,
    matrix_to_rpy,
    rot_x,
    rot_z,
    translation,
    xyz_rpy_to_matrix,
)
from dhkin.xacro_expansion import XACRO_LOCK
from dhkin.xml_text import (
    NAME_RULE,
    ROBOT_NAME_RULE,
    comment_body,
    name_problem,
    prefix_problem,
    text_problem,
)

#: Values below this (m or rad) are written as 0 in generated files (they come from cos(pi/2)).
ZERO_SNAP = 1e-15
#: An origin's rpy must rebuild its rotation to this; near gimbal lock (a corrected table's
#: pitch within 1e-12 of +-90 deg) dhkin.dh.exact_rpy replaces the plain conversion.
RPY_TOLERANCE = 1e-15


@dataclass(frozen=True)
class GeneratedFiles:
    """The three text artefacts generated for a robot, keyed by their file names."""

    macro_name: str
    macro: str
    top_name: str
    top: str
    urdf_name: str
    urdf: str

    def as_dict(self) -> dict[str, str]:
        return {self.macro_name: self.macro, self.top_name: self.top, self.urdf_name: self.urdf}


def joint_origins(table: DHTable) -> tuple[list[NDArray[np.float64]], NDArray[np.float64]]:
    """Fixed transforms of the URDF chain.

    Returns ``origins`` (origin of joint i in its parent link, i = 1..n; joint 1's parent is
    base_link) and ``tail`` (link_n -> DH frame n). With ``before_i`` the part of row i that comes
    before the joint motion and ``after_i`` the part after it::

        standard, revolute:   before = Rz(offset)            after = Tz(d) Tx(a) Rx(alpha)
        standard, prismatic:  before = Rz(theta) Tz(offset)  after = Tx(a) Rx(alpha)
        modified, revolute:   before = Rx(alpha) Tx(a) Rz(offset) Tz(d)    after = I
        modified, prismatic:  before = Rx(alpha) Tx(a) Rz(theta) Tz(offset) after = I

    and ``origin_i = after_{i-1} @ C_{i-1} @ before_i`` with ``after_0 @ C_0 = table.base``, where
    ``C_i`` is row i's correction (identity without one; it follows the row's DH transform), so
    the tail is ``after_n @ C_n``.
    """
    origins = []
    previous_after = table.base
    for joint in table.joints:
        before, after = _row_split(table.convention, joint)
        origins.append(previous_after @ before)
        previous_after = after @ joint.correction_matrix if joint.has_correction else after
    return origins, previous_after


def _row_split(convention: str, joint: Joint) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    if joint.is_revolute:
        turn, shift = rot_z(joint.offset), translation(0, 0, joint.d)
    else:
        turn, shift = rot_z(joint.theta), translation(0, 0, joint.offset)
    if convention == "standard":
        twist = translation(joint.a, 0, 0) @ rot_x(joint.alpha)
        if joint.is_revolute:
            return turn, shift @ twist
        return turn @ shift, twist
    return rot_x(joint.alpha) @ translation(joint.a, 0, 0) @ turn @ shift, np.eye(4)


def _fmt(value: float) -> str:
    if abs(value) < ZERO_SNAP:
        return "0"
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


def _origin(T: NDArray[np.float64]) -> str:
    xyz = " ".join(_fmt(v) for v in T[:3, 3])
    angles = matrix_to_rpy(T)
    rebuilt = xyz_rpy_to_matrix(T[:3, 3], angles)
    if np.abs(rebuilt[:3, :3] - T[:3, :3]).max() > RPY_TOLERANCE:  # near gimbal lock
        angles = exact_rpy(T)
    rpy = " ".join(_fmt(v) for v in angles)
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def _row_comment(table: DHTable, index: int) -> str:
    """Comment above joint ``index``: its DH row and how the URDF origin is made of the rows."""
    joint = table.joints[index]
    parts = [f"a={_fmt(joint.a)} m", f"alpha={_fmt(math.degrees(joint.alpha))} deg"]
    if joint.is_revolute:
        parts += [f"d={_fmt(joint.d)} m", f"offset={_fmt(math.degrees(joint.offset))} deg"]
    else:
        parts += [f"theta={_fmt(math.degrees(joint.theta))} deg", f"offset={_fmt(joint.offset)} m"]
    parts.append(f"direction={joint.direction:+d}")
    if joint.has_correction:
        xyz = ", ".join(_fmt(v) for v in joint.correction[:3])
        rpy = ", ".join(_fmt(math.degrees(v)) for v in joint.correction[3:])
        parts.append(f"correction xyz=({xyz}) m rpy=({rpy}) deg")
    row = index + 1
    previous = table.joints[index - 1] if row > 1 else None
    corrected = " and its correction" if previous is not None and previous.has_correction else ""
    if table.convention == "modified":
        origin = (f"origin = row {row - 1}'s correction, then row {row} before its motion"
                  if corrected else f"origin = row {row} before its motion")
    elif row == 1:
        origin = "origin = base, then row 1 before its motion"
    else:
        origin = f"origin = the rest of row {row - 1}{corrected}, then row {row} before its motion"
    return f"<!-- {table.convention} DH row {row}: " + ", ".join(parts) + f"; {origin} -->"


def macro_xacro(table: DHTable) -> str:
    """Text of ``<name>_macro.xacro``: a macro ``<name>`` with a ``prefix`` parameter."""
    origins, tail = joint_origins(table)
    p = "${prefix}"
    lines = [
        *_header(table),
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro">',
        f'  <xacro:macro name="{table.name}" params="prefix">',
        f'    <link name="{p}base_link"/>',
    ]
    lines += [f'    <link name="{p}{j.link}"/>' for j in table.joints]
    lines += [f'    <link name="{p}{name}"/>' for name in ("base", "flange", "tool0")]
    parent = "base_link"
    for index, (joint, origin) in enumerate(zip(table.joints, origins, strict=True)):
        lines += [
            f"    {_row_comment(table, index)}",
            f'    <joint name="{p}{joint.name}" type="{joint.type}">',
            f'      <parent link="{p}{parent}"/>',
            f'      <child link="{p}{joint.link}"/>',
            f"      {_origin(origin)}",
            f'      <axis xyz="0 0 {joint.direction}"/>',
            f'      <limit lower="{_fmt(joint.lower)}" upper="{_fmt(joint.upper)}" '
            f'effort="{_fmt(joint.effort)}" velocity="{_fmt(joint.velocity)}"/>',
            "    </joint>",
        ]
        parent = joint.link
    last = table.joints[-1].link
    fixed = zip(fixed_joint_names(last), [
        ("base_link", "base", table.base),
        (last, "flange", tail @ table.flange),
        ("flange", "tool0", invert(table.flange) @ table.tool),
    ], strict=True)
    for name, (parent_link, child, origin) in fixed:
        lines += [
            f'    <joint name="{p}{name}" type="fixed">',
            f'      <parent link="{p}{parent_link}"/>',
            f'      <child link="{p}{child}"/>',
            f"      {_origin(origin)}",
            "    </joint>",
        ]
    lines += ["  </xacro:macro>", "</robot>", ""]
    return "\n".join(lines)


def top_xacro(table: DHTable) -> str:
    """Text of ``<name>.urdf.xacro``: includes the macro and instantiates it with ``prefix``."""
    return "\n".join([
        *_header(table),
        f'<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="{table.name}">',
        '  <xacro:arg name="prefix" default=""/>',
        f'  <xacro:include filename="{table.name}_macro.xacro"/>',
        f'  <xacro:{table.name} prefix="$(arg prefix)"/>',
        "</robot>",
        "",
    ])


def text_notes(table: DHTable) -> list[tuple[str, str]]:
    """The table's non-empty free-text fields as (label, text): description, then source; each
    becomes a comment ``<!-- label: text -->`` (escaped, see dhkin.xml_text) in every file."""
    return [(label, text) for label, text in (("description", table.description),
                                              ("source", table.source)) if text]


def check_text(table: DHTable) -> None:
    """Raise :class:`DHError` naming the table and the field if a name or a free-text field of
    ``table`` cannot be written into the generated files (the rules of :mod:`dhkin.xml_text`,
    which the table loader applies too; a table made in Python has not been through it)."""
    label = table_label(table)
    checks: list[tuple[str, object, str | None, str]] = [
        ("name", table.name, name_problem(table.name, macro=True), ROBOT_NAME_RULE)]
    for i, joint in enumerate(table.joints):
        checks += [(f"joints[{i}].{key}", value, name_problem(value), NAME_RULE)
                   for key, value in (("name", joint.name), ("link", joint.link))]
    checks += [(key, text, text_problem(text), "text without control characters other than "
                                               "tab and line feed")
               for key, text in (("description", table.description), ("source", table.source),
                                 ("file name", table.path.name if table.path else ""))]
    for field_name, value, problem, expected in checks:
        if problem is not None:
            raise DHError(f"{label}: {field_name}: {problem}", field=field_name, value=value,
                          expected=expected)


def table_label(table: DHTable) -> str:
    """How messages name a table: its file's path, or ``table 'name'`` for one made in Python."""
    return str(table.path) if table.path is not None else f"table {table.name!r}"


def _header(table: DHTable) -> list[str]:
    """First lines of both xacro files: the declaration, the banner and the free-text notes."""
    origin = table.path.name if table.path is not None else table.name
    return [
        '<?xml version="1.0"?>',
        f"<!-- Generated by dhkin from {comment_body(origin)}: do not edit, regenerate with "
        "`dhkin export`. -->",
        *(f"<!-- {label}: {comment_body(text)} -->" for label, text in text_notes(table)),
    ]


def expand_xacro(top_file: Path, prefix: str = "", *, notes: Sequence[tuple[str, str]] = (),
                 label: str | None = None) -> str:
    """Run the xacro package on ``top_file`` (with ``prefix:=...``) and return the URDF text.

    xacro's banner names the absolute input path; it is replaced by one naming only the file, so
    that the output does not depend on where it was generated, followed by one comment
    ``<!-- label: text -->`` per note (text escaped as :func:`dhkin.xml_text.comment_body` says).
    ``label`` names the input in a :class:`URDFError` (default: ``top_file``); the folder of
    ``top_file`` is left out of xacro's own message then, so a temporary folder is never named.
    """
    try:
        with XACRO_LOCK:  # xacro keeps its state in module globals
            document = xacro.process_file(str(top_file), mappings={"prefix": prefix})
    except Exception as exc:  # xacro raises its own XacroException and plain errors alike
        if label is None:
            raise URDFError(f"{top_file}: xacro failed: {exc}") from exc
        detail = str(exc)
        for folder in (str(top_file.parent.resolve()), str(top_file.parent)):
            detail = detail.replace(folder + os.sep, "").replace(folder, ".")
        raise URDFError(f"{label}: xacro failed on the generated {top_file.name}: {detail}",
                        field=top_file.name) from exc
    for node in list(document.childNodes):
        if node.nodeType == node.COMMENT_NODE:
            document.removeChild(node)
    banner = document.createComment(
        f" Generated by dhkin: xacro {top_file.name} (prefix={prefix!r}). Do not edit. ")
    comments = [banner] + [document.createComment(f" {name}: {comment_body(text)} ")
                           for name, text in notes]
    for comment in comments:
        document.insertBefore(comment, document.documentElement)
    return document.toprettyxml(indent="  ")


def generate(table: DHTable, prefix: str = "") -> GeneratedFiles:
    """Generate the macro, the top-level xacro and the URDF (expanded by xacro) for ``table``.

    Raises :class:`DHError` for a name or text of the table that the files cannot hold (see
    :func:`check_text`), :class:`InputError` for a ``prefix`` that does not make names of the
    names it goes before (:func:`dhkin.xml_text.prefix_problem`: ``left_``, ``arm1/``),
    :class:`URDFError` naming the table if xacro fails.
    """
    check_text(table)
    if (problem := prefix_problem(prefix)) is not None:
        raise InputError(f"prefix: {problem}", field="prefix", value=prefix,
                         expected=f"'' or text that makes names ({NAME_RULE})")
    macro, top = macro_xacro(table), top_xacro(table)
    names = (f"{table.name}_macro.xacro", f"{table.name}.urdf.xacro", f"{table.name}.urdf")
    try:
        with tempfile.TemporaryDirectory(prefix="dhkin-xacro-") as tmp:
            folder = Path(tmp)
            (folder / names[0]).write_text(macro, encoding="utf-8")
            (folder / names[1]).write_text(top, encoding="utf-8")
            urdf = expand_xacro(folder / names[1], prefix=prefix, notes=text_notes(table),
                                label=table_label(table))
    except OSError as exc:  # a full temporary folder: one line, not a traceback
        raise FileWriteError(f"{table_label(table)}: cannot write the xacro files for xacro in "
                             f"the temporary folder {tempfile.gettempdir()} ({exc.strerror})",
                             field="temporary folder", value=tempfile.gettempdir(),
                             expected="a writable temporary folder") from exc
    return GeneratedFiles(names[0], macro, names[1], top, names[2], urdf)


def export(table: DHTable, directory: str | Path, force: bool = False) -> list[Path]:
    """Write the three generated files into ``directory`` (created with its missing parents);
    return the paths. Generated first, then written all or none (:mod:`dhkin.files`): an
    existing file with other content is replaced only with ``force``, an identical one is left
    alone, a symbolic link is refused, and a failed export removes the folders it created."""
    files = generate(table).as_dict()
    with output_folder(directory) as folder:
        return write_files({folder / name: text for name, text in files.items()}, force=force)
