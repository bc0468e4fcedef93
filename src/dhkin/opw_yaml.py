"""MoveIt's YAML of a table's OPW parameters (:mod:`dhkin.opw`): ``dhkin export --format opw``.

The keys are those MoveIt's opw_kinematics plugin reads (a robot support package's
``opw_kinematics_<robot>.yaml``, or a planning group's entry of kinematics.yaml):
``opw_kinematics_geometric_parameters`` (a1, a2, b, c1, c2, c3, c4 in m),
``opw_kinematics_joint_offsets`` (rad) and ``opw_kinematics_joint_sign_corrections``. Every float
is written with all its digits and a decimal point, so YAML 1.1 and 1.2 readers both take it for
the same float.
"""

from __future__ import annotations

from pathlib import Path

from dhkin.dh import DHTable
from dhkin.files import output_folder, write_file
from dhkin.opw import Matrix, OPWParameters, opw_parameters
from dhkin.transforms import matrix_to_rpy

#: The MoveIt plugin that reads the parameters (for a kinematics.yaml group entry).
MOVEIT_PLUGIN = "moveit_opw_kinematics_plugin/MoveItOPWKinematicsPlugin"


def opw_yaml(params: OPWParameters, group: str | None = None) -> str:
    """The YAML MoveIt's opw_kinematics plugin reads: ``opw_kinematics_geometric_parameters``
    (a1, a2, b, c1, c2, c3, c4 in m), ``opw_kinematics_joint_offsets`` (rad) and
    ``opw_kinematics_joint_sign_corrections``, at the top level (a robot support package's
    ``opw_kinematics_<robot>.yaml``) or, with ``group``, under that planning group with its
    ``kinematics_solver`` (a kinematics.yaml entry). Numbers are written with every digit.

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
    if params.base_is_identity and params.tool_is_identity:
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
    """Write ``<name>_opw.yaml`` (:func:`opw_yaml` of :func:`opw_parameters`) into
    ``directory`` (created if needed); the path written. FamilyError for a table that is not an
    OPW arm (nothing is written then). Written as :mod:`dhkin.files` says: an existing file with
    other content only with ``force``, never through a symbolic link."""
    text = opw_yaml(opw_parameters(table))
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
