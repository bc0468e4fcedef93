"""Standard and modified DH describe the same arm, and tables that are not built in export right.

Equivalence. A standard row is A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i), a modified (Craig)
row A'_i = Rx(alpha'_i) Tx(a'_i) Rz(theta_i) Tz(d_i). Regrouping the product, the same chain has

    alpha'_1 = a'_1 = 0,  alpha'_i = alpha_{i-1},  a'_i = a_{i-1} (i >= 2),  same d, offsets,
    tool' = Tx(a_n) Rx(alpha_n) @ tool,  flange' = Tx(a_n) Rx(alpha_n) @ flange,

and back: alpha_i = alpha'_{i+1}, a_i = a'_{i+1}, alpha_n = a_n = 0, base = base' Rx(alpha'_1)
Tx(a'_1). Both tables, run through xacro and Pinocchio, must give the same base, flange and tool0
poses and Jacobians, and link frames that differ only by d_i along the joint axis (the standard
URDF puts link_i at the start of row i, the modified one at DH frame i).

Export. A table for an arm that is not built in (negative joint directions, a base and a tool
transform, mm/deg or m/rad) written with ``dhkin.urdf.export`` and read back by Pinocchio from the
file gives the table's FK to 1e-12 (the acceptance test of issue 2), and so does an FK computed
here straight from the YAML numbers, independently of dhkin.dh.
"""

from __future__ import annotations

import math
import subprocess
import sys
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
import yaml
from numpy.typing import NDArray

import dhkin
from dhkin.dh import DHTable
from dhkin.transforms import matrix_to_rpy, pose_error
from dhkin.urdf import export

from .conftest import DATA, PER_ROBOT_BUILTINS
from .test_fk_oracle import expected_frames, pinocchio_frames, special_grid

TOLERANCE = 1e-12
CUSTOM_ARMS = ["custom_arm_modified.yaml", "custom_arm_prismatic.yaml"]


# --------------------------------------------------------------------------------------------
# Conversions between the conventions (tables in SI: m, rad)


def _rx(angle: float) -> NDArray[np.float64]:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _tx(x: float) -> NDArray[np.float64]:
    T = np.eye(4)
    T[0, 3] = x
    return T


def _frame(T: NDArray[np.float64]) -> dict[str, list[float]]:
    return {"xyz": [float(v) for v in T[:3, 3]], "rpy": list(matrix_to_rpy(T))}


def _row(table: DHTable, i: int, a: float, alpha: float) -> dict[str, Any]:
    joint = table.joints[i]
    row: dict[str, Any] = {"name": joint.name, "link": joint.link, "type": joint.type, "a": a,
                           "alpha": alpha, "offset": joint.offset, "direction": joint.direction,
                           "lower": joint.lower, "upper": joint.upper,
                           "velocity": joint.velocity, "effort": joint.effort}
    if joint.is_revolute:
        row["d"] = joint.d
    else:
        row["theta"] = joint.theta
    return row


def standard_to_modified(table: DHTable) -> DHTable:
    """The modified-DH table of the same arm as a standard one. A standard row i ends with
    X_i C_i (X_i = Tx(a_i) Rx(alpha_i), C_i its correction); the modified rows put X_i at the
    start of row i + 1, so row i's correction becomes X_i C_i X_i^-1 (and tool0 follows X_n)."""
    assert table.convention == "standard"
    n = table.dof
    shift = [(0.0, 0.0)] + [(table.joints[i - 1].a, table.joints[i - 1].alpha) for i in range(1, n)]
    tail = _tx(table.joints[-1].a) @ _rx(table.joints[-1].alpha)
    rows = [_row(table, i, a, alpha) for i, (a, alpha) in enumerate(shift)]
    for joint, row in zip(table.joints, rows, strict=True):
        if joint.has_correction:
            X = _tx(joint.a) @ _rx(joint.alpha)
            row["correction"] = _frame(X @ joint.correction_matrix @ np.linalg.inv(X))
    data = {"name": f"{table.name}_as_modified", "convention": "modified",
            "units": {"length": "m", "angle": "rad"}, "base": _frame(table.base),
            "tool": _frame(tail @ table.tool), "flange": _frame(tail @ table.flange),
            "joints": rows}
    return dhkin.parse_table(data, source="standard_to_modified")


def modified_to_standard(table: DHTable) -> DHTable:
    """The standard-DH table of the same arm as a modified one."""
    assert table.convention == "modified"
    n = table.dof
    shift = [(table.joints[i + 1].a, table.joints[i + 1].alpha) for i in range(n - 1)]
    shift.append((0.0, 0.0))
    head = _rx(table.joints[0].alpha) @ _tx(table.joints[0].a)
    data = {"name": f"{table.name}_as_standard", "convention": "standard",
            "units": {"length": "m", "angle": "rad"}, "base": _frame(table.base @ head),
            "tool": _frame(table.tool), "flange": _frame(table.flange),
            "joints": [_row(table, i, a, alpha) for i, (a, alpha) in enumerate(shift)]}
    return dhkin.parse_table(data, source="modified_to_standard")


def sample_q(table: DHTable, n: int) -> NDArray[np.float64]:
    rng = np.random.default_rng(zlib.crc32(table.name.encode()))
    return np.vstack([table.random_q(n, rng), special_grid(table)])


def assert_same_kinematics(standard: dhkin.Robot, modified: dhkin.Robot, n: int) -> None:
    """Pinocchio on both generated URDFs: equal base/flange/tool0 poses and tool0 Jacobians;
    link_i of the modified URDF = link_i of the standard one shifted by d_i along its z axis
    (revolute joints; for a prismatic joint both are the frame after the slide)."""
    assert standard.table.convention == "standard" and modified.table.convention == "modified"
    Q = sample_q(standard.table, n)
    links = [j.link for j in standard.table.joints]
    names = ["base", "flange", "tool0", *links]
    ours = pinocchio_frames(standard, Q, names)
    theirs = pinocchio_frames(modified, Q, names)
    for name in ("base", "flange", "tool0"):
        position, rotation = pose_error(ours[name], theirs[name])
        assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE, name
    for joint in standard.table.joints:
        shifted = ours[joint.link].copy()
        if joint.is_revolute:
            shifted[:, :3, 3] += joint.d * shifted[:, :3, 2]
        position, rotation = pose_error(shifted, theirs[joint.link])
        assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE, joint.link
    ref_s, ref_m = standard.reference(), modified.reference()
    for q in Q[:: max(1, len(Q) // 200)]:
        np.testing.assert_allclose(ref_s.jacobian(q), ref_m.jacobian(q), rtol=0, atol=TOLERANCE)


# --------------------------------------------------------------------------------------------
# Tables written by hand in both conventions


def test_puma560_modified_table_and_its_standard_equivalent() -> None:
    """Craig's PUMA 560 (modified, mm) and the standard table derived by hand (m) are the same
    arm through xacro + Pinocchio, on 10^4 random q and every special-angle combination."""
    modified = dhkin.load(DATA / "puma560_modified.yaml")
    standard = dhkin.load(DATA / "puma560_standard.yaml")
    assert_same_kinematics(standard, modified, 10_000)


def test_irb1200_modified_table_equals_the_builtin_standard_one() -> None:
    """The IRB 1200 in modified DH (derived by hand) is the built-in standard table's arm."""
    modified = dhkin.load(DATA / "abb_irb1200_7_70_modified.yaml")
    assert_same_kinematics(dhkin.load("abb_irb1200_7_70"), modified, 10_000)


def test_hand_derived_tables_match_the_conversion_rule() -> None:
    """The two hand-written equivalents are exactly what the conversion rule of this module
    gives (so the rule and the hand derivation check each other)."""
    pairs = [("puma560_standard.yaml", "puma560_modified.yaml"),
             ("../../robots/abb_irb1200_7_70.yaml", "abb_irb1200_7_70_modified.yaml")]
    for standard_file, modified_file in pairs:
        standard = dhkin.load_table(DATA / standard_file)
        modified = dhkin.load_table(DATA / modified_file)
        converted = standard_to_modified(standard)
        for mine, theirs in zip(converted.joints, modified.joints, strict=True):
            assert (mine.a, mine.alpha, mine.d, mine.offset) == pytest.approx(
                (theirs.a, theirs.alpha, theirs.d, theirs.offset), abs=1e-15)
        np.testing.assert_allclose(converted.tool, modified.tool, atol=1e-15)
        np.testing.assert_allclose(converted.base, modified.base, atol=1e-15)


# --------------------------------------------------------------------------------------------
# Every table, converted


@pytest.mark.parametrize("name", PER_ROBOT_BUILTINS)  # a sample of the package arms
def test_builtin_table_in_modified_dh_gives_the_same_urdf_kinematics(name: str) -> None:
    """Each built-in (standard) table, converted to modified DH, gives the same URDF kinematics
    (planar arms: their non-zero last a becomes a tool transform). Converted back, it is the
    original table, except that the last row's a and alpha stay in the tool."""
    standard = dhkin.load(name)
    table = standard.table
    modified = dhkin.Robot(standard_to_modified(table))
    assert_same_kinematics(standard, modified, 2000)
    back = modified_to_standard(modified.table)
    for i, (mine, original) in enumerate(zip(back.joints, table.joints, strict=True)):
        a, alpha = (0.0, 0.0) if i == table.dof - 1 else (original.a, original.alpha)
        assert (mine.a, mine.alpha, mine.d, mine.theta, mine.offset) == pytest.approx(
            (a, alpha, original.d, original.theta, original.offset), abs=1e-15)
    np.testing.assert_allclose(back.base, table.base, atol=1e-15)
    tail = _tx(table.joints[-1].a) @ _rx(table.joints[-1].alpha)
    np.testing.assert_allclose(back.tool, tail @ table.tool, atol=1e-15)


@pytest.mark.parametrize("file", CUSTOM_ARMS)
def test_custom_arm_in_the_other_convention(file: str) -> None:
    """The custom arms (one modified with a tilted base, one standard with a prismatic joint)
    converted to the other convention give the same URDF kinematics."""
    robot = dhkin.load(DATA / file)
    if robot.table.convention == "modified":
        assert_same_kinematics(dhkin.Robot(modified_to_standard(robot.table)), robot, 5000)
    else:
        assert_same_kinematics(robot, dhkin.Robot(standard_to_modified(robot.table)), 5000)


# --------------------------------------------------------------------------------------------
# Acceptance: a table that is not built in, exported and read back from the file


def yaml_fk(path: Path, Q: NDArray[np.float64]) -> NDArray[np.float64]:
    """base_link -> tool0 computed from the YAML numbers alone (not through dhkin.dh)."""
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    length = {"m": 1.0, "mm": 1e-3}[data["units"]["length"]]
    angle = {"rad": 1.0, "deg": math.pi / 180}[data["units"]["angle"]]

    def rot(axis: int, t: float) -> NDArray[np.float64]:
        c, s = math.cos(t), math.sin(t)
        j, k = [(1, 2), (2, 0), (0, 1)][axis]
        M = np.eye(4)
        M[j, j], M[j, k], M[k, j], M[k, k] = c, -s, s, c
        return M

    def shift(axis: int, v: float) -> NDArray[np.float64]:
        M = np.eye(4)
        M[axis, 3] = v
        return M

    def frame(entry: dict[str, Any] | None) -> NDArray[np.float64]:
        entry = entry or {}
        x, y, z = (length * v for v in entry.get("xyz", [0, 0, 0]))
        r, p, w = (angle * v for v in entry.get("rpy", [0, 0, 0]))
        return shift(0, x) @ shift(1, y) @ shift(2, z) @ rot(2, w) @ rot(1, p) @ rot(0, r)

    out = np.empty((len(Q), 4, 4))
    for k, q in enumerate(Q):
        T = frame(data.get("base"))
        for row, value in zip(data["joints"], q, strict=True):
            prismatic = row.get("type", "revolute") == "prismatic"
            variable = row.get("direction", 1) * value + row.get("offset", 0) * (
                length if prismatic else angle)
            theta = row.get("theta", 0) * angle if prismatic else variable
            d = variable if prismatic else row["d"] * length
            a, alpha = row["a"] * length, row["alpha"] * angle
            if data["convention"] == "standard":
                T = T @ rot(2, theta) @ shift(2, d) @ shift(0, a) @ rot(0, alpha)
            else:
                T = T @ rot(0, alpha) @ shift(0, a) @ rot(2, theta) @ shift(2, d)
        out[k] = T @ frame(data.get("tool"))
    return out


@pytest.mark.parametrize("file", CUSTOM_ARMS)
def test_exported_custom_arm_urdf_fk_equals_table_fk(file: str, tmp_path: Path) -> None:
    """Acceptance: export writes <name>_macro.xacro, <name>.urdf.xacro and <name>.urdf; Pinocchio
    reading that .urdf file gives the table's FK to 1e-12 for tool0, flange, base and every link,
    on 10^4 random q and all special-angle combinations; an FK from the raw YAML agrees too."""
    path = DATA / file
    robot = dhkin.load(path)
    table = robot.table
    assert any(j.direction == -1 for j in table.joints)
    assert not np.allclose(table.base, np.eye(4)) and not np.allclose(table.tool, np.eye(4))
    written = export(table, tmp_path / "out")
    assert sorted(p.name for p in written) == sorted(
        [f"{table.name}_macro.xacro", f"{table.name}.urdf.xacro", f"{table.name}.urdf"])
    model = pin.buildModelFromUrdf(str(tmp_path / "out" / f"{table.name}.urdf"))
    data = model.createData()
    assert model.nq == table.dof
    assert [model.names[i] for i in range(1, model.njoints)] == table.joint_names

    Q = sample_q(table, 10_000)
    names = ["base", "flange", "tool0", *[j.link for j in table.joints]]
    ids = [model.getFrameId(name) for name in names]
    poses = np.empty((len(names), len(Q), 4, 4))
    for k, q in enumerate(Q):
        pin.framesForwardKinematics(model, data, q)
        for j, frame_id in enumerate(ids):
            poses[j, k] = data.oMf[frame_id].homogeneous
    expected = expected_frames(table, Q)
    for j, name in enumerate(names):
        position, rotation = pose_error(expected[name], poses[j])
        assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE, name
    subset = slice(0, 2000)
    position, rotation = pose_error(yaml_fk(path, Q[subset]), poses[names.index("tool0"), subset])
    assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE


@pytest.mark.parametrize("file", CUSTOM_ARMS)
def test_exported_xacro_runs_with_the_xacro_command_and_a_prefix(file: str,
                                                                 tmp_path: Path) -> None:
    """The exported top-level xacro, expanded by the `xacro` command with prefix:=left_ (as a ROS
    user would), gives a URDF whose left_tool0 moves like the table's tool0."""
    table = dhkin.load(DATA / file).table
    export(table, tmp_path)
    xacro_exe = Path(sys.executable).parent / "xacro"
    assert xacro_exe.is_file(), f"{xacro_exe}: the xacro command is missing"
    result = subprocess.run([str(xacro_exe), str(tmp_path / f"{table.name}.urdf.xacro"),
                             "prefix:=left_"], capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stderr
    model = pin.buildModelFromXML(result.stdout)
    data = model.createData()
    assert [model.names[i] for i in range(1, model.njoints)] == [
        f"left_{n}" for n in table.joint_names]
    Q = sample_q(table, 500)
    frame_id = model.getFrameId("left_tool0")
    poses = np.empty((len(Q), 4, 4))
    for k, q in enumerate(Q):
        pin.framesForwardKinematics(model, data, q)
        poses[k] = data.oMf[frame_id].homogeneous
    position, rotation = pose_error(table.fk(Q), poses)
    assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE
