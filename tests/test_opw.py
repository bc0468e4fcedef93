"""OPW parameters (MoveIt's opw_kinematics) of a table: ``dhkin.opw`` and ``dhkin export --format
opw``.

The oracle is Pinocchio: the exported parameters, through the OPW forward kinematics written from
the published definition, must give Pinocchio's base_link -> tool0 on the generated URDF (and on
ABB's own URDF for the IRB 1200) to 1e-12, on 10^3 random joint vectors (fixed seed) and every
combination of 0, +-pi/2 and pi. Tables that are not OPW arms raise a FamilyError naming what
they lack. (py-opw-kinematics, optional, is checked against the export in
scripts/check_opw_peer.py.)
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

import dhkin
from dhkin.cli import main
from dhkin.opw import OPWParameters, opw_fk, opw_parameters
from dhkin.opw_yaml import opw_yaml
from dhkin.reference import Reference
from dhkin.transforms import rot_y, translation, xyz_rpy_to_matrix

from .conftest import DATA, PER_ROBOT_BUILTINS, REFERENCE_URDFS

TOLERANCE = 1e-12
N_RANDOM = 1000
#: The built-in robots that are OPW arms; every other built-in must raise a FamilyError.
OPW_BUILTINS = ("abb_irb1200_7_70", "anthropomorphic_arm", "fanuc_m10ia", "kuka_kr6r900sixx",
                "motoman_gp7", "staubli_tx2_60")
#: The arms of the ROS-Industrial support packages (dhkin.vendors.PACKAGE_ARMS) that are OPW
#: arms: exactly those with a spherical wrist (dhkin.ik.family.fit_family decides that, not
#: dhkin.opw).
OPW_PACKAGE_ARMS = ("fanuc_cr35ia", "fanuc_cr7ia", "fanuc_cr7ial", "fanuc_lrmate200i",
                    "fanuc_lrmate200ib", "fanuc_lrmate200ib3l", "fanuc_lrmate200ic",
                    "fanuc_lrmate200ic5l", "fanuc_m16ib20", "fanuc_m20ib25", "fanuc_m6ib",
                    "fanuc_m6ib6s", "fanuc_m710ic45m", "fanuc_m710ic50", "fanuc_m900ia260l",
                    "fanuc_m900ib700", "fanuc_r1000ia80f", "kuka_kr10r1100sixx",
                    "kuka_kr10r1420", "kuka_kr10r900_2", "kuka_kr3r540", "kuka_kr5_arc",
                    "motoman_ar2010", "motoman_gp110", "motoman_gp12", "motoman_gp180",
                    "motoman_gp180_120", "motoman_gp200r", "motoman_gp25", "motoman_gp35l",
                    "motoman_gp4", "motoman_gp50", "motoman_gp70l", "motoman_gp88",
                    "motoman_hc20", "motoman_ma2010", "motoman_mh110", "motoman_mh50",
                    "motoman_motomini", "motoman_ms210")
#: OPW arms whose tool0 is not OPW's flange frame (the export carries tool0 as a fixed frame).
TOOL_NOT_OPW_FLANGE = ("motoman_gp7", "motoman_gp12", "motoman_gp25", "motoman_gp50",
                       "motoman_ma2010", "motoman_mh50")
#: Tables in other conventions and layouts: modified DH, a lateral offset b, joints turning about
#: negative axes, base and tool transforms that are not identity.
OPW_TABLES = ("abb_irb1200_7_70_modified.yaml", "puma560_standard.yaml", "puma560_modified.yaml",
              "kinova_gen3_6dof_nominal.yaml", "custom_arm_modified.yaml")
GEOMETRIC_KEYS = ["a1", "a2", "b", "c1", "c2", "c3", "c4"]


def joint_vectors(table: dhkin.DHTable, seed: int = 7) -> np.ndarray:
    """N_RANDOM joint vectors within the limits (fixed seed) and every combination of 0, +-pi/2
    and pi."""
    special = np.array(list(itertools.product((0.0, math.pi / 2, -math.pi / 2, math.pi),
                                              repeat=6)))
    return np.vstack([table.random_q(N_RANDOM, np.random.default_rng(seed)), special])


def largest_difference(A: np.ndarray, B: np.ndarray) -> float:
    return float(np.abs(A - B).max())


# --------------------------------------------------------------------------------------------
# Against Pinocchio


@pytest.mark.parametrize("name", [*OPW_BUILTINS,
                                  *(n for n in OPW_PACKAGE_ARMS if n in PER_ROBOT_BUILTINS)])
def test_builtin_opw_fk_equals_pinocchio_on_the_generated_urdf(name: str) -> None:
    robot = dhkin.load(name)
    params = opw_parameters(robot.table)
    assert params.base_is_identity  # OPW's base frame: base_link
    assert params.tool_is_identity == (name not in TOOL_NOT_OPW_FLANGE)
    q = joint_vectors(robot.table)
    T = robot.reference().fk(q)
    assert largest_difference(params.fk(q), T) <= TOLERANCE  # base @ OPW FK @ tool
    if params.tool_is_identity:
        assert largest_difference(opw_fk(params, q), T) <= TOLERANCE


@pytest.mark.parametrize("file", OPW_TABLES)
def test_table_opw_fk_equals_pinocchio_on_the_generated_urdf(file: str) -> None:
    robot = dhkin.load(DATA / file)
    params = opw_parameters(robot.table)
    q = joint_vectors(robot.table)
    assert largest_difference(params.fk(q), robot.reference().fk(q)) <= TOLERANCE


def test_irb1200_opw_fk_equals_pinocchio_on_abbs_urdf() -> None:
    """ABB's own description (abb_experimental), base_link -> tool0."""
    path = REFERENCE_URDFS / "abb_irb1200_7_70.urdf"
    vendor = Reference(path.read_text(encoding="utf-8"), tip="tool0", source=str(path))
    table = dhkin.load("abb_irb1200_7_70").table
    q = joint_vectors(table, seed=11)
    assert largest_difference(opw_fk(opw_parameters(table), q), vendor.fk(q)) <= TOLERANCE


def test_every_builtin_is_opw_or_says_why_not() -> None:
    """Every OPW built-in gives its parameters (a package arm outside the per-robot sample: their
    FK equals Pinocchio's on 200 random joint vectors, leaner than the test above); every other
    built-in raises a FamilyError."""
    from dhkin.ik.family import fit_family
    from dhkin.vendors import PACKAGE_ARMS

    for name in dhkin.builtin_names():
        robot = dhkin.load(name)
        table = robot.table
        if name in PACKAGE_ARMS:
            try:
                fit_family(table, "spherical_wrist")
                spherical = True
            except dhkin.FamilyError:
                spherical = False
            assert (name in OPW_PACKAGE_ARMS) == spherical, name
        if name in OPW_BUILTINS or name in OPW_PACKAGE_ARMS:
            params = opw_parameters(table)
            if name not in PER_ROBOT_BUILTINS:
                q = table.random_q(200, np.random.default_rng(7))
                assert largest_difference(params.fk(q), robot.reference().fk(q)) <= TOLERANCE
            continue
        with pytest.raises(dhkin.FamilyError, match="not an OPW arm"):
            opw_parameters(table)


# --------------------------------------------------------------------------------------------
# The parameters themselves


def test_irb1200_parameters_are_its_datasheet_lengths() -> None:
    """The lengths of the table's sources (ABB's URDF and datasheet), exactly, and the joint 3
    offset between ABB's zero (forearm horizontal) and OPW's (arm straight up)."""
    params = opw_parameters(dhkin.load("abb_irb1200_7_70").table)
    assert params.geometric == {"a1": 0.0, "a2": -0.042, "b": 0.0, "c1": 0.3991, "c2": 0.35,
                                "c3": 0.351, "c4": 0.082}
    assert params.offsets == (0.0, 0.0, -math.pi / 2, 0.0, 0.0, 0.0)
    assert params.sign_corrections == (1, 1, 1, 1, 1, 1)


def test_anthropomorphic_parameters_are_the_examples_lengths() -> None:
    """Seed 003: L1 = L2 = L3 = 1, shoulder offset 0.1 along axis 2, tool 0.15 past the wrist."""
    params = opw_parameters(dhkin.load("anthropomorphic_arm").table)
    assert params.geometric == {"a1": 0.0, "a2": 0.0, "b": 0.1, "c1": 1.0, "c2": 1.0, "c3": 1.0,
                                "c4": 0.15}


def test_joints_turning_about_negative_axes_get_sign_corrections() -> None:
    """Kinova's joints 1 and 3 turn against their DH z (direction -1 on joint 1, alpha 180 deg
    on joint 2): the signs say so, and the FK check holds (Pinocchio: the test above)."""
    params = opw_parameters(dhkin.load(DATA / "kinova_gen3_6dof_nominal.yaml").table)
    assert params.sign_corrections[0] == -1 and params.sign_corrections[2] == -1
    assert params.b != 0.0
    assert min(params.c2, params.c3, params.c4) >= 0.0


def test_a_correction_that_keeps_the_arm_opw_is_exported() -> None:
    """A 10 mm correction along axis 2 (z of DH frame 1) moves the wrist off the arm plane: the
    same arm with b = 10 mm, to 1e-12 against Pinocchio."""
    robot = dhkin.load("abb_irb1200_7_70")
    joints = list(robot.table.joints)
    joints[0] = dataclasses.replace(joints[0], correction=(0.0, 0.0, 0.01, 0.0, 0.0, 0.0))
    moved = dhkin.Robot(dataclasses.replace(robot.table, joints=tuple(joints)))
    params = opw_parameters(moved.table)
    assert abs(abs(params.b) - 0.01) <= 1e-15
    q = joint_vectors(moved.table)
    assert largest_difference(params.fk(q), moved.reference().fk(q)) <= TOLERANCE


# --------------------------------------------------------------------------------------------
# The definition


def some_parameters(**changes: object) -> OPWParameters:
    values: dict[str, object] = dict(
        name="arm", joint_names=tuple(f"joint_{i}" for i in range(1, 7)), a1=0.15, a2=-0.11,
        b=0.02, c1=0.45, c2=0.6, c3=0.72, c4=0.1, offsets=(0.0,) * 6, sign_corrections=(1,) * 6)
    values.update(changes)
    return OPWParameters(**values)  # type: ignore[arg-type]


def test_opw_zero_pose_is_the_arm_straight_up() -> None:
    """All OPW angles 0: the flange above the base at (a1 + a2, b, c1 + c2 + c3 + c4), unturned."""
    p = some_parameters()
    expected = translation(p.a1 + p.a2, p.b, p.c1 + p.c2 + p.c3 + p.c4)
    assert largest_difference(opw_fk(p, np.zeros(6)), expected) <= 1e-15


def test_positive_joint_2_leans_the_arm_towards_x() -> None:
    """t2 = pi/2 turns the arm above axis 2 about +y: the upper arm and forearm point along +x."""
    p = some_parameters()
    expected = translation(p.a1 + p.c2 + p.c3 + p.c4, p.b, p.c1 - p.a2) @ rot_y(math.pi / 2)
    assert largest_difference(opw_fk(p, [0, math.pi / 2, 0, 0, 0, 0]), expected) <= 1e-15


def test_joint_values_map_to_opw_angles_as_sign_times_q_minus_offset() -> None:
    """opw_kinematics' convention: t = sign * q - offset."""
    offsets = (0.3, -1.2, 0.7, 2.0, -0.4, 1.1)
    signs = (-1, 1, -1, -1, 1, -1)
    corrected = some_parameters(offsets=offsets, sign_corrections=signs)
    q = np.random.default_rng(3).uniform(-3.0, 3.0, (50, 6))
    t = q * np.array(signs) - np.array(offsets)
    assert largest_difference(opw_fk(corrected, q), opw_fk(some_parameters(), t)) <= 1e-15


@pytest.mark.parametrize("q", [np.zeros(5), np.zeros((3, 7)), [0, 0, np.nan, 0, 0, 0]])
def test_opw_fk_rejects_bad_joint_values(q: object) -> None:
    with pytest.raises(dhkin.InputError, match="q"):
        opw_fk(some_parameters(), q)  # type: ignore[arg-type]


# --------------------------------------------------------------------------------------------
# Tables that are not OPW arms


@pytest.mark.parametrize(("name", "reason"), [
    ("ur5", "axes 4, 5, 6 meet in one point"),
    ("ur5", "axes 3 and 4 perpendicular"),
    ("stanford_arm", "joint 3 (joint_3) is prismatic, expected revolute"),
    ("planar_2r", "expected 6 joints, got 2"),
])
def test_not_opw_raises_a_family_error_naming_what_is_missing(name: str, reason: str) -> None:
    table = dhkin.load(name).table
    with pytest.raises(dhkin.FamilyError) as raised:
        opw_parameters(table)
    assert reason in str(raised.value)
    assert str(table.path) in str(raised.value)
    assert raised.value.field == "opw"
    assert any(reason in problem for problem in raised.value.value)


def test_corrections_that_break_the_structure_are_named() -> None:
    """Kinova's fitted table: wrist axes 0.18 mm apart, axes microradians off; its nominal table
    is an OPW arm, and the message says so."""
    with pytest.raises(dhkin.FamilyError, match="axes 4, 5, 6 meet") as raised:
        opw_parameters(dhkin.load("kinova_gen3_6dof").table)
    assert "nominal table, without the corrections, is an OPW arm" in str(raised.value)


def test_a_nearly_opw_table_fails_the_fk_check() -> None:
    """A 1e-11 rad correction passes the structural tolerance (1e-9) but moves tool0 by more
    than 1e-12: not exactly OPW, so no parameters."""
    table = dhkin.load("abb_irb1200_7_70").table
    joints = list(table.joints)
    joints[2] = dataclasses.replace(joints[2], correction=(0.0, 0.0, 0.0, 1e-11, 0.0, 0.0))
    with pytest.raises(dhkin.FamilyError, match=r"reproduce the table's FK .* only to"):
        opw_parameters(dataclasses.replace(table, joints=tuple(joints)))


# --------------------------------------------------------------------------------------------
# YAML and command line


def test_yaml_holds_the_parameters_digit_for_digit() -> None:
    params = opw_parameters(dhkin.load("anthropomorphic_arm").table)
    data = yaml.safe_load(opw_yaml(params))
    assert sorted(data) == ["opw_kinematics_geometric_parameters",
                            "opw_kinematics_joint_offsets", "opw_kinematics_joint_sign_corrections"]
    assert data["opw_kinematics_geometric_parameters"] == params.geometric
    assert tuple(data["opw_kinematics_joint_offsets"]) == params.offsets
    assert tuple(data["opw_kinematics_joint_sign_corrections"]) == params.sign_corrections
    assert all(isinstance(v, float) for v in data["opw_kinematics_joint_offsets"])


def test_yaml_for_a_planning_group_names_the_plugin() -> None:
    params = opw_parameters(dhkin.load("abb_irb1200_7_70").table)
    group = yaml.safe_load(opw_yaml(params, group="manipulator"))["manipulator"]
    assert group["kinematics_solver"] == "moveit_opw_kinematics_plugin/MoveItOPWKinematicsPlugin"
    assert list(group["opw_kinematics_geometric_parameters"]) == GEOMETRIC_KEYS


def test_yaml_states_fixed_frames_that_are_not_identity() -> None:
    """custom_arm_modified: its base_link is not on axis 1 and its tool0 is off axis 6."""
    params = opw_parameters(dhkin.load(DATA / "custom_arm_modified.yaml").table)
    assert not params.base_is_identity and not params.tool_is_identity
    frames = yaml.safe_load(opw_yaml(params))["dhkin_fixed_frames"]
    for key, expected in (("base_link_to_opw_base", params.base),
                          ("opw_flange_to_tool0", params.tool)):
        T = xyz_rpy_to_matrix(frames[key]["xyz"], frames[key]["rpy"])
        assert largest_difference(T, expected) <= 1e-15


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_cli_export_opw_writes_the_yaml(capsys, tmp_path: Path) -> None:
    code, out, _ = run(capsys, "export", "abb_irb1200_7_70", "--format", "opw", "-o",
                       str(tmp_path / "out"))
    path = tmp_path / "out" / "abb_irb1200_7_70_opw.yaml"
    assert code == 0
    assert out.strip() == str(path)
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    assert list(data["opw_kinematics_geometric_parameters"]) == GEOMETRIC_KEYS
    assert len(data["opw_kinematics_joint_offsets"]) == 6
    assert set(data["opw_kinematics_joint_sign_corrections"]) <= {-1, 1}


@pytest.mark.parametrize(("name", "reason"), [("ur5", "axes 4, 5, 6 meet"),
                                              ("stanford_arm", "prismatic"),
                                              ("planar_2r", "expected 6 joints")])
def test_cli_export_opw_of_another_arm_fails_and_writes_nothing(capsys, tmp_path: Path,
                                                                 name: str, reason: str) -> None:
    code, out, err = run(capsys, "export", name, "--format", "opw", "-o", str(tmp_path))
    assert code != 0
    assert "not an OPW arm" in err and reason in err
    assert out == ""
    assert list(tmp_path.iterdir()) == []


def test_cli_export_rejects_an_unknown_format(capsys, tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as raised:
        main(["export", "abb_irb1200_7_70", "--format", "sdf", "-o", str(tmp_path)])
    assert raised.value.code == 2
    assert "invalid choice" in capsys.readouterr().err
