"""Descriptions as real files have them (issue 27, items 2, 5 and 6): XML declarations,
byte-order marks and encodings, one-joint chains, chains of hundreds of metres, tool0 moved by
the last joint, names with '/', and faults named at their line in the user's file (a xacro's
macro file included). Issue 27's reproducers d01, d02, d03, d08 and d09 are
tests here: each gives the right table (its FK equal to Pinocchio's on the description to
DEFAULT_TOLERANCE) or one line naming the file and the field.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import dhkin
from dhkin.cli import main
from dhkin.compare import compare_with_urdf
from dhkin.importer import import_description
from dhkin.reference import Reference
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import pose_error
from dhkin.urdf_outline import AXIS_LENGTH_RANGE

from .conftest import REFERENCE_URDFS
from .urdf_text import ChainJoint, chain_urdf, six_joints

KUKA = REFERENCE_URDFS / "kuka_kr6r900sixx.urdf"


def assert_matches_description(table: dhkin.DHTable, text: str, tip: str, base: str,
                               seed: int = 3) -> None:
    """The table's FK equals Pinocchio's on the description (q = 0 and random vectors)."""
    q = np.vstack([np.zeros(table.dof), table.random_q(200, np.random.default_rng(seed))])
    position, rotation = pose_error(table.fk(q), Reference(text, tip=tip, base=base).fk(q))
    assert position.max() <= DEFAULT_TOLERANCE and rotation.max() <= DEFAULT_TOLERANCE


def one_line_error(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    """Run the CLI expecting exit 2 and one line on stderr; return that line."""
    code = main(list(argv))
    captured = capsys.readouterr()
    assert code == 2, captured.out
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err, captured.err
    return captured.err.removeprefix("dhkin: error: ").rstrip("\n")


# --------------------------------------------------------------------------------------------
# Declarations, byte-order marks, encodings (d01, d02)


@pytest.mark.parametrize(("name", "head", "encoding"), [
    ("d01 declaration with encoding", '<?xml version="1.0" encoding="utf-8"?>\n', "utf-8"),
    ("declaration, single quotes", "<?xml version='1.0' encoding='UTF-8' standalone='yes'?>\n",
     "utf-8"),
    ("d02 byte-order mark", "\ufeff", "utf-8"),
    ("BOM and declaration", '\ufeff<?xml version="1.0" encoding="UTF-8"?>\n', "utf-8"),
    ("UTF-16 with BOM", '\ufeff<?xml version="1.0" encoding="UTF-16"?>\n', "utf-16-le"),
    ("UTF-16 big endian", '\ufeff<?xml version="1.0" encoding="UTF-16"?>\n', "utf-16-be"),
    ("Latin-1", '<?xml version="1.0" encoding="ISO-8859-1"?>\n<!-- Gr\u00f6\u00dfe -->\n',
     "latin-1"),
    ("windows-1252", '<?xml version="1.0" encoding="windows-1252"?>\n<!-- \u20ac -->\n',
     "cp1252"),
])
def test_declarations_and_encodings_import(name: str, head: str, encoding: str,
                                           tmp_path: Path) -> None:
    text = head + KUKA.read_text(encoding="utf-8")
    path = tmp_path / "kuka.urdf"
    path.write_bytes(text.encode(encoding))
    result = import_description(path, tip="tool0")
    assert_matches_description(result.table, KUKA.read_text(encoding="utf-8"), "tool0",
                               "base_link")
    # compare reads the same file
    report = compare_with_urdf(dhkin.load("kuka_kr6r900sixx"), path, n=20)
    assert report.ok


def test_d01_a_comment_over_ten_megabytes(tmp_path: Path) -> None:
    """lxml refuses text nodes over 10 MB; dhkin reads the file as the XML it is."""
    text = KUKA.read_text(encoding="utf-8").replace("</robot>",
                                                    "<!-- " + "x" * 11_000_000 + " --></robot>")
    path = tmp_path / "kuka_comment.urdf"
    path.write_text(text, encoding="utf-8")
    result = import_description(path, tip="tool0")
    assert_matches_description(result.table, text, "tool0", "base_link")


@pytest.mark.parametrize(("data", "message"), [
    (b'<?xml version="1.0" encoding="klingon"?><robot/>',
     "the XML declaration names encoding 'klingon', which Python does not know"),
    (b'<?xml version="1.0" encoding="UTF-16"?><robot name="r"/>',
     "the XML declaration names encoding 'UTF-16', but the file is written in 8-bit text"),
    (b'<?xml version="1.0"?><robot name="\xff"/>', r"not UTF-8 text \(byte b'\\xff' at offset"),
    (b'<?xml version="1.0" encoding="ascii"?><robot name="\xc3\xa9"/>',
     r"not ASCII text \(byte b'\\xc3' at offset \d+\)"),
])
def test_encoding_faults_are_one_line(data: bytes, message: str, tmp_path: Path,
                                      capsys) -> None:
    path = tmp_path / "bad.urdf"
    path.write_bytes(data)
    line = one_line_error(capsys, "import", str(path), "-o", str(tmp_path / "t.yaml"))
    assert line.startswith(f"{path}: ") and re.search(message, line), line


# --------------------------------------------------------------------------------------------
# Chains of any size (d03, d08)


def test_d03_a_one_joint_chain(tmp_path: Path, capsys) -> None:
    """A turntable: a one-joint table, and `dhkin compare` of it against its description."""
    text = chain_urdf([ChainJoint("j1", "l1", (0, 0, 0.4)),
                       ChainJoint("j2", "tool0", (0, 0, 0.1), (0, math.pi / 2, 0), "fixed")])
    path = tmp_path / "one.urdf"
    path.write_text(text)
    table_file = tmp_path / "one.yaml"
    assert main(["import", str(path), "-o", str(table_file)]) == 0
    capsys.readouterr()
    table = dhkin.load(table_file).table
    assert table.dof == 1
    assert_matches_description(table, text, "tool0", "base_link")
    assert main(["compare", str(table_file), str(path), "-n", "50"]) == 0
    assert capsys.readouterr().out.startswith("OK:")


D08_SEED = 7


def d08_urdf(scale: float) -> str:
    """The reproducer's chain: six revolute joints with general axis directions, origins of
    0.3 m x ``scale`` (random, fixed seed), tool0 fixed after them."""
    rng = np.random.default_rng(D08_SEED)
    axes = [a / np.linalg.norm(a) for a in rng.normal(size=(6, 3))]
    xyz = rng.normal(0, 0.3, (7, 3))
    rpy = rng.uniform(-np.pi, np.pi, (7, 3))
    joints = [ChainJoint(f"j{i + 1}", f"l{i + 1}", xyz[i] * scale, rpy[i],
                         axis=" ".join(repr(float(v)) for v in axes[i]),
                         limit='lower="-3" upper="3" effort="1" velocity="1"') for i in range(6)]
    joints.append(ChainJoint("j7", "tool0", xyz[6] * scale, rpy[6], "fixed"))
    return chain_urdf(joints, robot="big")


@pytest.mark.parametrize("scale", [1, 30, 300, 1000])
@pytest.mark.parametrize("angle", ["deg", "rad"])
def test_d08_chains_of_hundreds_of_metres_import_exactly(scale: float, angle: str,
                                                         tmp_path: Path) -> None:
    """Up to a kilometre (dhkin.dh.MAX_LENGTH): the table equals the description to 1e-9 m."""
    text = d08_urdf(scale)
    path = tmp_path / "big.urdf"
    path.write_text(text)
    result = import_description(path, units={"length": "m", "angle": angle})
    assert max(result.deviation) <= DEFAULT_TOLERANCE
    written = tmp_path / "big.yaml"
    written.write_text(result.yaml())
    assert_matches_description(dhkin.load(written).table, text, "tool0", "base_link")


# --------------------------------------------------------------------------------------------
# Messages that name the file and the field (d09)


def d09_urdf(axis: str = "0 0 1", limits: str = 'lower="-3" upper="3"',
             name: str = "j1") -> str:
    return chain_urdf([
        ChainJoint(name, "l1", (0, 0, 0.4), axis=axis, limit=f'{limits} effort="1" velocity="1"'),
        ChainJoint("j2", "l2", (0.3, 0, 0), axis="0 1 0"),
        ChainJoint("j3", "tool0", (0.2, 0, 0), type="fixed")], robot="r")


@pytest.mark.parametrize(("axis", "accepted"), [
    ("0 0 0", False), ("0 0 1e300", False), ("0 0 1e-300", False), ("0 0 nan", False),
    ("0 0", False), ("0 0 1 0", False), ("0 0 2", True), ("0 0 -3", True), ("1 1 1", True),
    (f"0 0 {2 * AXIS_LENGTH_RANGE[0]!r}", True), (f"0 0 {0.5 * AXIS_LENGTH_RANGE[0]!r}", False),
    (f"0 0 {0.5 * AXIS_LENGTH_RANGE[1]!r}", True), (f"0 0 {2 * AXIS_LENGTH_RANGE[1]!r}", False),
])
def test_d09_axes(axis: str, accepted: bool, tmp_path: Path, capsys) -> None:
    """An axis Pinocchio normalises exactly is read (its table equals Pinocchio's FK, at the
    edges of AXIS_LENGTH_RANGE too); any other is one line naming file, joint, line and axis
    (before: "neither revolute nor prismatic", no file)."""
    text = d09_urdf(axis=axis)
    path = tmp_path / "axis.urdf"
    path.write_text(text)
    if accepted:
        assert_matches_description(import_description(path).table, text, "tool0", "base_link")
        return
    line = one_line_error(capsys, "import", str(path), "-o", str(tmp_path / "t.yaml"))
    assert line.startswith(f"{path}: joint 'j1' (line 4) axis: expected "), line


def test_d09_limits_beyond_two_turns_name_the_file(tmp_path: Path, capsys) -> None:
    path = tmp_path / "wide.urdf"
    path.write_text(d09_urdf(limits='lower="-20" upper="20"'))
    line = one_line_error(capsys, "import", str(path), "-o", str(tmp_path / "t.yaml"))
    assert line == (f"{path}: joint 'j1' (line 4) lower: expected a revolute joint limit within "
                    "+-12.5664 rad (+-2 turns, dhkin.dh.MAX_JOINT_TURNS), got -20.0")


@pytest.mark.parametrize("name", ["j${x}", "j$(arg x)", "j 1", "j.1", "/j1", "j1/"])
def test_d09_names_a_table_cannot_hold(name: str, tmp_path: Path, capsys) -> None:
    path = tmp_path / "names.urdf"
    path.write_text(d09_urdf(name=name.replace("<", "&lt;")))
    line = one_line_error(capsys, "import", str(path), "-o", str(tmp_path / "t.yaml"))
    assert line.startswith(f"{path}: joint {name!r} (line 4) name: expected a name of "), line


def test_d09_limits_the_wrong_way_round(tmp_path: Path, capsys) -> None:
    path = tmp_path / "inverted.urdf"
    path.write_text(d09_urdf(limits='lower="2" upper="-2"'))
    line = one_line_error(capsys, "import", str(path), "-o", str(tmp_path / "t.yaml"))
    assert line.startswith(f"{path}: joint 'j1' (line 4) lower: expected lower < upper"), line


# --------------------------------------------------------------------------------------------
# Names as real descriptions have them (item 2)


@pytest.mark.parametrize("moved", ["tool0", "flange"])
def test_a_moving_joints_child_may_be_tool0_or_flange(moved: str, tmp_path: Path,
                                                      capsys) -> None:
    """The last moving joint moves tool0 itself (or flange): the table names that link link_6,
    says so, and its own tool0 is the description's tip (tool0, or flange) at every q."""
    text = chain_urdf(six_joints(moved))
    path = tmp_path / "linked.urdf"
    path.write_text(text)
    table_file = tmp_path / "linked.yaml"
    assert main(["import", str(path), "-o", str(table_file)]) == 0
    out = capsys.readouterr().out
    assert (f"note: joint 'wrist_3_joint' (line 14) moves link '{moved}', a name dhkin's URDF "
            "gives a fixed frame: the table names the link 'link_6'") in out
    assert ("and writes its own fixed tool0 at the same place" in out) == (moved == "tool0")
    robot = dhkin.load(table_file)
    assert robot.table.joints[5].link == "link_6"
    assert_matches_description(robot.table, text, moved, "base_link")
    q = robot.table.random_q(50, np.random.default_rng(4))
    position, rotation = pose_error(robot.reference("tool0").fk(q),
                                    Reference(text, tip=moved).fk(q))
    assert position.max() <= DEFAULT_TOLERANCE and rotation.max() <= DEFAULT_TOLERANCE


def test_names_with_a_slash_are_kept_both_ways(tmp_path: Path) -> None:
    """Interbotix-style namespaced names (wx250s/...): import keeps them, export writes them
    (and prefix "wx250s/" makes them from plain names), and the exported URDF imports back to
    the same table."""
    text = chain_urdf(six_joints("gripper_link", prefix="wx250s/"), base="wx250s/base_link")
    path = tmp_path / "wx250s.urdf"
    path.write_text(text)
    result = import_description(path)
    names = [j.name for j in six_joints(prefix="wx250s/")]
    assert result.table.joint_names == names
    assert result.table.joints[5].link == "wx250s/gripper_link"
    assert_matches_description(result.table, text, "wx250s/gripper_link", "wx250s/base_link")
    table_file = tmp_path / "wx250s.yaml"
    table_file.write_text(result.yaml())
    assert main(["export", str(table_file), "-o", str(tmp_path / "out")]) == 0
    exported = tmp_path / "out" / "wx250s.urdf"
    model = Reference(exported.read_text(), tip="wx250s/gripper_link")
    assert model.joint_names == names
    again = import_description(exported, base="base_link", tip="tool0")
    assert again.table.joint_names == names
    assert [j.link for j in again.table.joints] == [j.link for j in result.table.joints]
    prefixed = dhkin.load("ur5").urdf(prefix="wx250s/")
    assert Reference(prefixed, tip="wx250s/tool0", base="wx250s/base_link").joint_names[0] == \
        "wx250s/shoulder_pan_joint"


# --------------------------------------------------------------------------------------------
# Faults at their line in the user's file (item 6)

MACRO = """<?xml version="1.0"?>
<robot xmlns:xacro="http://wiki.ros.org/xacro">
  <xacro:macro name="two_link" params="prefix">
    <link name="${prefix}base_link"/>
    <link name="${prefix}link_1"/>
    <link name="${prefix}tool0"/>
    <joint name="${prefix}joint_1" type="revolute">
      <origin xyz="0 0 0.3" rpy="0 0 0"/>
      <parent link="${prefix}base_link"/><child link="${prefix}link_1"/>
      <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/>
    </joint>
    <joint name="${prefix}joint_2" type="revolute">
      <origin xyz="0.4 0 0" rpy="0 0 0"/>
      <parent link="${prefix}link_1"/><child link="${prefix}tool0"/>
      <axis xyz="0 1 0"/><limit lower="-3" upper="${upper}" effort="1" velocity="1"/>
    </joint>
  </xacro:macro>
</robot>
"""
TOP = """<?xml version="1.0"?>
<robot name="two" xmlns:xacro="http://wiki.ros.org/xacro">
  <xacro:property name="upper" value="3"/>
  <xacro:include filename="two_macro.xacro"/>
  <xacro:two_link prefix=""/>
</robot>
"""


def xacro_pair(folder: Path, macro: str = MACRO, top: str = TOP) -> Path:
    (folder / "two_macro.xacro").write_text(macro)
    (folder / "two.urdf.xacro").write_text(top)
    return folder / "two.urdf.xacro"


def line_of(text: str, snippet: str) -> int:
    return 1 + next(k for k, line in enumerate(text.splitlines()) if snippet in line)


def test_a_loop_in_a_macro_names_both_joints_at_their_lines(tmp_path: Path, capsys) -> None:
    """Joint 2 closes a loop (its child is base_link): both joints are named at their lines in
    the macro file, not at line 7 of the expanded text."""
    macro = MACRO.replace('<child link="${prefix}tool0"/>', '<child link="${prefix}base_link"/>')
    top = xacro_pair(tmp_path, macro=macro)
    line = one_line_error(capsys, "import", str(top), "-o", str(tmp_path / "t.yaml"))
    macro_file = tmp_path / "two_macro.xacro"
    assert line.startswith(f"{top}: kinematic loop closed by joint 'joint_2' (line "
                           f"{line_of(macro, 'joint_2')} of {macro_file})"), line
    assert f"joint 'joint_1' (line {line_of(macro, 'joint_1')} of {macro_file})" in line


def test_a_bad_axis_in_a_macro_is_named_at_its_line(tmp_path: Path, capsys) -> None:
    macro = MACRO.replace('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>')
    top = xacro_pair(tmp_path, macro=macro)
    line = one_line_error(capsys, "compare", "planar_2r", str(top))
    assert line.startswith(f"{top}: joint 'joint_2' (line {line_of(macro, 'joint_2')} of "
                           f"{tmp_path / 'two_macro.xacro'}) axis: expected a direction"), line


@pytest.mark.parametrize(("fault", "change", "expected"), [
    ("undefined property", ("${upper}", "${uper}"),
     r"{macro}: line {line}: xacro failed \(name 'uper' is not defined .*\) in macro "
     r"'two_link' \(expanding {top}\)"),
    ("unset argument", ("${upper}", "$(arg upper_limit)"),
     r"{macro}: line {line}: \$\(arg upper_limit\): xacro argument 'upper_limit' is not set; "
     r"expected --xacro-arg upper_limit:=VALUE"),
    ("unknown package", ("${upper}", "$(find no_such_pkg)"),
     r"{macro}: line {line}: \$\(find no_such_pkg\): package 'no_such_pkg' not found; give it "
     r"with --package no_such_pkg=DIR"),
])
def test_xacro_faults_name_the_macro_file_and_line(fault: str, change: tuple[str, str],
                                                   expected: str, tmp_path: Path,
                                                   capsys) -> None:
    macro = MACRO.replace(*change)
    top = xacro_pair(tmp_path, macro=macro)
    line = one_line_error(capsys, "import", str(top), "-o", str(tmp_path / "t.yaml"),
                          "--package", f"unrelated={tmp_path}")
    pattern = expected.format(macro=re.escape(str(tmp_path / "two_macro.xacro")),
                              line=line_of(macro, change[1]), top=re.escape(str(top)))
    assert re.match(pattern, line), line


def test_a_missing_include_and_bad_xml_in_an_include(tmp_path: Path, capsys) -> None:
    top_text = TOP.replace("two_macro.xacro", "gone.xacro")
    top = xacro_pair(tmp_path, top=top_text)
    line = one_line_error(capsys, "import", str(top), "-o", str(tmp_path / "t.yaml"))
    assert line.startswith(f"{top}: line {line_of(top_text, 'gone.xacro')}: <xacro:include> of "
                           f"{tmp_path / 'gone.xacro'}: "), line
    assert "no such xacro file" in line
    top = xacro_pair(tmp_path, macro=MACRO.replace("</xacro:macro>", "</xacro:macr>"))
    line = one_line_error(capsys, "import", str(top), "-o", str(tmp_path / "t.yaml"))
    assert line.startswith(f"{tmp_path / 'two_macro.xacro'}: not well-formed XML (mismatched "
                           f"tag at line {line_of(MACRO, '</xacro:macro>')}, column "), line
    assert line.endswith(f"(expanding {top})")


def test_the_expanded_xacro_imports(tmp_path: Path) -> None:
    """The same pair without a fault: a two-joint table equal to Pinocchio on the expansion."""
    from dhkin.xacro_expansion import expand_xacro

    top = xacro_pair(tmp_path)
    assert_matches_description(import_description(top).table, expand_xacro(top), "tool0",
                               "base_link")
