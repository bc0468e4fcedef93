"""MoveIt's YAML of a table's OPW parameters (:mod:`dhkin.opw`): ``dhkin export --format opw``.

The keys are those MoveIt's opw_kinematics plugin reads (a robot support package's
``opw_kinematics_<robot>.yaml``, or a planning group's entry of kinematics.yaml):
``opw_kinematics_geometric_parameters`` (a1, a2, b, c1, c2, c3, c4 in m),
``opw_kinematics_joint_offsets`` (rad) and ``opw_kinematics_joint_sign_corrections``. Every float
is written with all its digits and a decimal point, so YAML 1.1 and 1.2 readers both take it for
the same float.

**The plain form.** MoveIt's plugin knows no fixed frames: its base and tip are the OPW base and
flange. When the OPW frames are not base_link and tool0, the file carries ``dhkin_fixed_frames``
(which the plugin ignores: the planning group's base and tip must be the OPW frames then). A
description whose tool0 (or base) differs from the OPW flange (or base) only by rounding would
get such a block for nothing (the MH12 URDF's tool0 rpy is 3.3e-7 rad off): within
:data:`PLAIN_FORM_BAND` (position m, rotation rad) the fixed frames are left out and the file
says by how much MoveIt's FK then differs from the table's (the band and its reasons:
:data:`dhkin.opw.PLAIN_FORM_BAND`).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from dhkin.dh import DHTable
from dhkin.files import output_folder, write_file
from dhkin.opw import (
    PLAIN_FORM_BAND,
    Matrix,
    OPWParameters,
    check_joint_vectors,
    fk_deviation,
    opw_parameters,
)
from dhkin.transforms import matrix_to_rpy, rotation_angle

#: The MoveIt plugin that reads the parameters (for a kinematics.yaml group entry).
MOVEIT_PLUGIN = "moveit_opw_kinematics_plugin/MoveItOPWKinematicsPlugin"


def frame_offset(T: Matrix) -> tuple[float, float]:
    """How far a fixed frame is from the identity: (translation m, rotation angle rad)."""
    return float(np.linalg.norm(T[:3, 3])), float(rotation_angle(T[:3, :3]))


def within_band(T: Matrix) -> bool:
    """Whether a fixed frame lies within :data:`PLAIN_FORM_BAND` of the identity."""
    position, rotation = frame_offset(T)
    return position <= PLAIN_FORM_BAND[0] and rotation <= PLAIN_FORM_BAND[1]


def plain_form(params: OPWParameters, table: DHTable) -> tuple[OPWParameters, str | None]:
    """``params`` without fixed frames when both lie within :data:`PLAIN_FORM_BAND` of the
    identity (its ``deviation`` then the FK difference from ``table`` this leaves), and a note
    saying so; ``params`` and None otherwise (frames identity or outside the band)."""
    if (params.base_is_identity and params.tool_is_identity) or not (
            within_band(params.base) and within_band(params.tool)):
        return params, None
    plain = replace(params, base=np.eye(4), tool=np.eye(4))
    plain = replace(plain, deviation=fk_deviation(plain, table, check_joint_vectors(table)))
    (base_m, base_rad), (tool_m, tool_rad) = frame_offset(params.base), frame_offset(params.tool)
    note = (f"base_link is {base_m:.2g} m, {base_rad:.2g} rad from the OPW base and tool0 "
            f"{tool_m:.2g} m, {tool_rad:.2g} rad from the OPW flange, within the band "
            f"{PLAIN_FORM_BAND[0]:g} m, {PLAIN_FORM_BAND[1]:g} rad: written as OPW base = "
            f"base_link, OPW flange = tool0 (MoveIt's FK differs from the table's by at most "
            f"{plain.deviation:.1e})")
    return plain, note


def opw_yaml(params: OPWParameters, group: str | None = None, note: str | None = None) -> str:
    """The YAML MoveIt's opw_kinematics plugin reads: ``opw_kinematics_geometric_parameters``
    (a1, a2, b, c1, c2, c3, c4 in m), ``opw_kinematics_joint_offsets`` (rad) and
    ``opw_kinematics_joint_sign_corrections``, at the top level (a robot support package's
    ``opw_kinematics_<robot>.yaml``) or, with ``group``, under that planning group with its
    ``kinematics_solver`` (a kinematics.yaml entry). Numbers are written with every digit.
    ``note`` (from :func:`plain_form`) is written as a comment.

    When the OPW frames are not base_link and tool0, the key ``dhkin_fixed_frames`` (which the
    plugin does not read) gives ``base_link_to_opw_base`` and ``opw_flange_to_tool0`` as URDF
    xyz (m) / rpy (rad): the planning group's base and tip must be those OPW frames.
    """
    lines = [f"# MoveIt opw_kinematics parameters of {params.name}, written by dhkin.",
             "# OPW (Brandstotter, Angerer, Hofbaur 2014); OPW angle = sign * q - offset.",
             f"# They reproduce the table's FK base_link -> tool0 to {params.deviation:.1e} "
             "(dhkin.opw)."]
    if group is None:
        lines.append("# For MoveIt: these keys in the planning group's namespace, with "
                     f"kinematics_solver: {MOVEIT_PLUGIN}.")
    lines.append(f"# Joints, in this order: {', '.join(params.joint_names)}.")
    frames = []
    if note is not None:
        lines.append(f"# {note}.")
    elif params.base_is_identity and params.tool_is_identity:
        lines.append("# OPW base = base_link, OPW flange = tool0.")
    else:
        lines.append("# The OPW frames are not base_link and tool0: see dhkin_fixed_frames (the "
                     "group's base and tip must be the OPW frames).")
        frames = ["dhkin_fixed_frames:",
                  f"  base_link_to_opw_base: {_origin(params.base)}",
                  f"  opw_flange_to_tool0: {_origin(params.tool)}"]
    body = ["opw_kinematics_geometric_parameters:"]
    body += [f"  {name}: {_number(value)}" for name, value in params.geometric.items()]
    body.append("opw_kinematics_joint_offsets: ["
                + ", ".join(_number(v) for v in params.offsets) + "]")
    body.append("opw_kinematics_joint_sign_corrections: ["
                + ", ".join(str(s) for s in params.sign_corrections) + "]")
    body += frames
    if group is not None:
        body = [f"{group}:", f"  kinematics_solver: {MOVEIT_PLUGIN}"] + ["  " + b for b in body]
    return "\n".join(lines + body) + "\n"


def export_opw(table: DHTable, directory: str | Path, force: bool = False) -> Path:
    """Write ``<name>_opw.yaml`` (:func:`opw_yaml` of :func:`opw_parameters`, in the plain form
    where the fixed frames lie within :data:`PLAIN_FORM_BAND`) into ``directory`` (created if
    needed); the path written. FamilyError for a table that is not an
    OPW arm (nothing is written then). Written as :mod:`dhkin.files` says: an existing file with
    other content only with ``force``, never through a symbolic link."""
    params, note = plain_form(opw_parameters(table), table)
    text = opw_yaml(params, note=note)
    with output_folder(directory) as folder:
        return write_file(folder / f"{table.name}_opw.yaml", text, force=force)


def _number(value: float) -> str:
    """A float with every digit, in a form every YAML reader takes for a float (with a '.')."""
    text = repr(float(value) + 0.0)
    if "e" in text and "." not in text:
        text = text.replace("e", ".0e")
    return text


def _origin(T: Matrix) -> str:
    xyz = ", ".join(_number(v) for v in T[:3, 3])
    rpy = ", ".join(_number(v) for v in matrix_to_rpy(T))
    return f"{{xyz: [{xyz}], rpy: [{rpy}]}}"
