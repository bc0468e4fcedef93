"""`dhkin import`: URDF / xacro descriptions -> DH tables, checked against the description.

Every vendor URDF of robots/vendor is imported with the base and tip frames its README
gives, in both conventions; the written table is loaded back, its URDF generated through xacro
and compared with the vendor URDF by Pinocchio (``compare_with_urdf``: the round trip), and its
limits are the description's. The family the import reports is the one each arm's geometry has.
Bad descriptions give URDFErrors that name the file, and the CLI writes nothing then.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

import dhkin
from dhkin.cli import main
from dhkin.compare import compare_with_urdf
from dhkin.description import read_description
from dhkin.errors import InputError, URDFError
from dhkin.importer import CLEAN, import_description
from dhkin.reference import Reference
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import pose_error

from .conftest import REFERENCE_URDFS, REPO

#: vendor file -> (base, tip, the family its geometry has; None: no closed-form family).
VENDOR_IMPORTS: dict[str, tuple[str, str, str | None]] = {
    "abb_irb1200_7_70.urdf": ("base_link", "tool0", "spherical_wrist"),
    "kuka_kr6r900sixx.urdf": ("base_link", "tool0", "spherical_wrist"),
    "fanuc_m10ia.urdf": ("base_link", "tool0", "spherical_wrist"),
    "motoman_gp7.urdf": ("base_link", "tool0", "spherical_wrist"),
    "staubli_tx2_60.urdf": ("base_link", "tool0", "spherical_wrist"),
    "kinova_gen3_6dof.urdf": ("base_link", "end_effector_link", "spherical_wrist"),
    "ur3.urdf": ("base_link", "tool0", "offset_wrist"),
    "ur5.urdf": ("base_link", "tool0", "offset_wrist"),
    "ur10.urdf": ("base_link", "tool0", "offset_wrist"),
    "ur5e.urdf": ("base_link", "tool0", "offset_wrist"),
    "ur5e_calibrated.urdf": ("base_link", "tool0", "offset_wrist"),
    "aubo_i10.urdf": ("base_link", "wrist3_Link", "offset_wrist"),
    "tm5_900.urdf": ("link_0", "flange", "offset_wrist"),
    "xarm6.urdf": ("link_base", "link_eef", None),
    "fanuc_crx10ia.urdf": ("base_link", "flange", None),
    "franka_fr3.urdf": ("fr3_link0", "fr3_link8", None),
}
#: Joint vectors of the round-trip comparison (plus q = 0).
COMPARE_SAMPLES = 1000


def test_every_reference_urdf_is_covered() -> None:
    """Each vendor URDF is imported here, but the package arms' expansions (their xacros import
    in tests/test_vendor_packages.py, and scripts/import_vendor_tables.py --check, below,
    proves each file is its xacro's expansion)."""
    from dhkin.vendors import PACKAGE_ARMS

    expansions = {f"{name}.urdf" for name in PACKAGE_ARMS}
    assert sorted(p.name for p in REFERENCE_URDFS.glob("*.urdf")
                  if p.name not in expansions) == sorted(VENDOR_IMPORTS)


def _description_limits(path: Path, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """The description's limits of the named joints (continuous: one turn each way)."""
    description = read_description(path)
    lower, upper = [], []
    for name in names:
        joint = description.joint(name)
        if joint.type == "continuous":
            lower.append(-2 * math.pi)
            upper.append(2 * math.pi)
        else:
            lower.append(joint.lower)
            upper.append(joint.upper)
    return np.array(lower), np.array(upper)


@pytest.mark.parametrize("file", sorted(VENDOR_IMPORTS))
def test_vendor_import_round_trip(file: str, tmp_path: Path) -> None:
    """import -> table file -> load -> URDF through xacro -> Pinocchio vs the vendor URDF."""
    base, tip, family = VENDOR_IMPORTS[file]
    vendor = REFERENCE_URDFS / file
    output = tmp_path / "imported.yaml"
    assert main(["import", str(vendor), "--base", base, "--tip", tip, "-o", str(output)]) == 0
    robot = dhkin.load(output)
    report = compare_with_urdf(robot, vendor, base_frame=base, tip=tip, n=COMPARE_SAMPLES)
    assert report.max_position <= DEFAULT_TOLERANCE and report.max_rotation <= DEFAULT_TOLERANCE
    # Names, limits and velocities equal; the only joint difference allowed is a vendor
    # continuous joint, which a table holds as revolute -360..360 deg.
    continuous = {j.name for j in read_description(vendor).joints if j.type == "continuous"}
    assert all(d.field == "type" and d.joint in continuous for d in report.joint_differences), \
        report.summary()
    assert report.strict_ok == (not continuous)
    lower, upper = _description_limits(vendor, robot.table.joint_names)
    # The table file holds each limit as the shortest decimal that reads back bit for bit, or,
    # where none exists in degrees, the nearest (1 ulp).
    assert np.all(np.abs(robot.lower - lower) <= np.spacing(np.abs(lower)))
    assert np.all(np.abs(robot.upper - upper) <= np.spacing(np.abs(upper)))
    assert robot.table.joint_names == list(Reference(vendor.read_text(), tip=tip,
                                                     base=base).joint_names)
    expected = "no closed form" if family is None else family
    assert (robot.ik_solver.family if robot.has_closed_form else "no closed form") == expected


@pytest.mark.parametrize("file", sorted(VENDOR_IMPORTS))
@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_vendor_import_is_exact_and_reports_the_family(file: str, convention: str) -> None:
    base, tip, family = VENDOR_IMPORTS[file]
    result = import_description(REFERENCE_URDFS / file, base, tip, convention=convention)
    assert result.table.convention == convention
    assert max(result.deviation) <= DEFAULT_TOLERANCE
    assert result.family == family
    if family is None:
        assert result.family_reason
    # Independent of the import's own check: Pinocchio on the vendor file, other joint vectors.
    rng = np.random.default_rng(7)
    q = np.vstack([np.zeros(result.table.dof), result.table.random_q(500, rng)])
    position, rotation = pose_error(result.table.fk(q),
                                    Reference((REFERENCE_URDFS / file).read_text(), tip=tip,
                                              base=base).fk(q))
    assert position.max() <= DEFAULT_TOLERANCE and rotation.max() <= DEFAULT_TOLERANCE


def test_corrections_only_where_no_exact_dh_exists() -> None:
    """Exact DH rows wherever the axes allow (rounded constants kept as written); corrections
    only for axes parallel within the band but not exactly (the calibrated UR5e, Kinova's pi
    written as 3.1416), on top of the family's ideal geometry."""
    plain = ["ur5.urdf", "ur5e.urdf", "tm5_900.urdf", "abb_irb1200_7_70.urdf", "aubo_i10.urdf",
             "kuka_kr6r900sixx.urdf"]
    for file in plain:
        base, tip, _ = VENDOR_IMPORTS[file]
        assert not import_description(REFERENCE_URDFS / file, base, tip).table.corrected, file
    for file in ("ur5e_calibrated.urdf", "kinova_gen3_6dof.urdf"):
        base, tip, _ = VENDOR_IMPORTS[file]
        result = import_description(REFERENCE_URDFS / file, base, tip)
        assert result.table.corrected and result.refined
        nominal = result.table.nominal()
        for joint in nominal.joints:  # the ideal model: twists on multiples of 90 degrees
            assert abs(joint.alpha / (math.pi / 2) - round(joint.alpha / (math.pi / 2))) == 0
        assert any("within the band of parallel" in note for note in result.notes)


def test_ur5_table_reads_like_the_datasheet() -> None:
    """UR's published DH (d1 0.089159, a2 0.425, a3 0.39225, d4 0.10915, d5 0.09465, d6 0.0823;
    the signs of a follow the URDF's zero pose), twists as the URDF rounds them, no offsets."""
    table = import_description(REFERENCE_URDFS / "ur5.urdf", "base_link", "tool0").table
    assert [j.d for j in table.joints] == [0.089159, 0, 0, 0.10915, 0.09465, 0.0823]
    assert [abs(j.a) for j in table.joints] == [0, 0.425, 0.39225, 0, 0, 0]
    assert all(j.offset == 0 for j in table.joints)
    alphas = np.degrees([abs(j.alpha) for j in table.joints])
    assert np.all(np.abs(alphas - [90, 0, 0, 90, 90, 0]) < 1e-7)
    assert table.joints[0].name == "shoulder_pan_joint"


def test_kuka_directions_follow_the_urdf_axes() -> None:
    """KUKA's joint 1 turns about -z of base_link: direction -1 keeps the URDF's positive sense
    with an upright DH frame 0 (base = identity)."""
    result = import_description(REFERENCE_URDFS / "kuka_kr6r900sixx.urdf", "base_link", "tool0")
    assert result.table.joints[0].direction == -1
    assert np.array_equal(result.table.base, np.eye(4))


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70", "stanford_arm", "planar_3r",
                                  "aubo_i10", "anthropomorphic_arm"])
@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_generated_urdfs_import_back(name: str, convention: str) -> None:
    """Our own generated URDFs (revolute and prismatic joints) import to tables with the same
    FK, checked by Pinocchio on the URDF."""
    urdf = REPO / "robots" / f"{name}.urdf"
    result = import_description(urdf, "base_link", "tool0", convention=convention)
    original = dhkin.load(name)
    assert [j.type for j in result.table.joints] == [j.type for j in original.table.joints]
    rng = np.random.default_rng(3)
    q = original.table.random_q(500, rng)
    position, rotation = pose_error(result.table.fk(q), original.reference().fk(q))
    assert position.max() <= DEFAULT_TOLERANCE and rotation.max() <= DEFAULT_TOLERANCE
    assert np.array_equal(result.table.lower, original.table.lower)


@pytest.mark.parametrize("units", [{"length": "mm", "angle": "rad"},
                                   {"length": "m", "angle": "deg"},
                                   {"length": "mm", "angle": "deg"}])
def test_units(units: dict[str, str], tmp_path: Path) -> None:
    result = import_description(REFERENCE_URDFS / "kuka_kr6r900sixx.urdf", "base_link", "tool0",
                                units=units)
    text = result.yaml()
    assert f"units: {{length: {units['length']}, angle: {units['angle']}}}" in text
    path = tmp_path / "kuka.yaml"
    path.write_text(text)
    table = dhkin.load_table(path)
    q = table.random_q(200, np.random.default_rng(1))
    position, rotation = pose_error(table.fk(q), result.table.fk(q))
    assert position.max() <= CLEAN * 10 and rotation.max() <= CLEAN * 10
    if units["length"] == "mm":
        assert "a: 455," in text  # datasheet millimetres, not 455.00000000000006


# --------------------------------------------------------------------------------------------
# xacro, branches, mimic joints


XACRO = """<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="two_link">
  <xacro:arg name="upper" default="0.3"/>
  <xacro:property name="upper" value="$(arg upper)"/>
  <link name="base_link"/>
  <link name="link_1"/>
  <link name="link_2"/>
  <link name="tool0"/>
  <joint name="joint_1" type="revolute">
    <parent link="base_link"/><child link="link_1"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="2" effort="10"/>
  </joint>
  <joint name="joint_2" type="revolute">
    <parent link="link_1"/><child link="link_2"/>
    <origin xyz="0 0 ${upper}" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" velocity="2" effort="10"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <parent link="link_2"/><child link="tool0"/><origin xyz="0.2 0 0" rpy="0 0 0"/>
  </joint>
</robot>
"""


def test_xacro_with_arguments(tmp_path: Path) -> None:
    path = tmp_path / "two_link.urdf.xacro"
    path.write_text(XACRO)
    default = import_description(path)
    longer = import_description(path, xacro_args={"upper": "0.5"})
    assert default.table.joints[0].d == pytest.approx(0.4, abs=1e-15)
    assert longer.table.joints[0].d == pytest.approx(0.6, abs=1e-15)
    assert max(longer.deviation) <= DEFAULT_TOLERANCE


def test_branches_and_mimic_joints_are_listed(tmp_path: Path) -> None:
    text = XACRO.replace('<link name="tool0"/>', """<link name="tool0"/>
  <link name="finger_a"/><link name="finger_b"/><link name="camera"/>
  <joint name="finger_a_joint" type="prismatic">
    <parent link="link_2"/><child link="finger_a"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" velocity="1" effort="1"/>
  </joint>
  <joint name="finger_b_joint" type="prismatic">
    <parent link="link_2"/><child link="finger_b"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" velocity="1" effort="1"/><mimic joint="finger_a_joint"/>
  </joint>
  <joint name="camera_joint" type="fixed">
    <parent link="base_link"/><child link="camera"/>
  </joint>""")
    path = tmp_path / "gripper.xacro"
    path.write_text(text)
    result = import_description(path, tip="tool0")
    assert result.table.joint_names == ["joint_1", "joint_2"]
    assert result.ignored == ("finger_a_joint (prismatic, off the chain)",
                              "finger_b_joint (mimics finger_a_joint)")
    assert "ignored: finger_a_joint" in result.summary()
    # Among several leaves the default tip is tool0 (ROS-Industrial's), else --tip is needed.
    assert import_description(path).table.joint_names == ["joint_1", "joint_2"]
    path.write_text(text.replace('"tool0"', '"tcp"'))
    with pytest.raises(URDFError, match=r"several leaf links \['tcp', 'finger_a', .* and none "
                                        r"is tool0; expected --tip"):
        import_description(path)


# --------------------------------------------------------------------------------------------
# Bad input


def _two_link(tmp_path: Path, old: str = "", new: str = "", name: str = "bad.urdf") -> Path:
    import xacro  # the plain URDF of XACRO

    source = tmp_path / "source.xacro"
    source.write_text(XACRO)
    text = xacro.process_file(str(source)).toxml()
    assert old in text
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1))
    return path


def test_missing_links_are_listed(tmp_path: Path) -> None:
    path = _two_link(tmp_path)
    with pytest.raises(URDFError, match=r"no link 'flange' for the tip; links: \['base_link', "
                                        r"'link_1', 'link_2', 'tool0'\]") as caught:
        import_description(path, tip="flange")
    assert str(path) in str(caught.value)
    with pytest.raises(URDFError, match="no link 'world' for the base"):
        import_description(path, base="world", tip="tool0")
    with pytest.raises(URDFError, match="does not hang below 'link_2'"):
        import_description(path, base="link_2", tip="link_1")


def test_loop_is_an_error(tmp_path: Path) -> None:
    path = _two_link(tmp_path, '<child link="link_2"/>', '<child link="link_1"/>')
    with pytest.raises(URDFError, match=f"{path}: kinematic loop closed by joint 'joint_2' "
                                        r"\(line 1\): link 'link_1' is already the child of "
                                        "joint 'joint_1'"):
        import_description(path)


@pytest.mark.parametrize("kind", ["floating", "planar"])
def test_floating_or_planar_joint_on_the_chain(kind: str, tmp_path: Path) -> None:
    path = _two_link(tmp_path, 'name="joint_2" type="revolute"', f'name="joint_2" type="{kind}"')
    with pytest.raises(URDFError, match=f"joint 'joint_2' on the chain base_link -> tool0 is "
                                        f"{kind}"):
        import_description(path)


def test_mimic_joint_on_the_chain(tmp_path: Path) -> None:
    path = _two_link(tmp_path, '<child link="link_2"/>',
                     '<child link="link_2"/><mimic joint="joint_1"/>')
    with pytest.raises(URDFError, match=r"joint 'joint_2' on the chain .* mimics 'joint_1'"):
        import_description(path)


def test_not_a_urdf(tmp_path: Path) -> None:
    text_file = tmp_path / "notes.urdf"
    text_file.write_text("just some notes, not XML")
    with pytest.raises(URDFError, match=f"{text_file}: not a URDF"):
        import_description(text_file)
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'></robot>")
    with pytest.raises(URDFError, match=f"{broken}: not well-formed XML "
                                        r"\(mismatched tag at line 1, column"):
        import_description(broken)
    binary = tmp_path / "binary.urdf"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\x00<robot")
    with pytest.raises(URDFError, match="not UTF-8"):
        import_description(binary)
    binary.write_bytes(b"\xff\xfe\x00<robot")  # a UTF-16 byte-order mark, then odd bytes
    with pytest.raises(URDFError, match=r"binary\.urdf: not UTF-16-LE text"):
        import_description(binary)
    with pytest.raises(URDFError, match="cannot read"):
        import_description(tmp_path / "missing.urdf")


def test_xacro_error_names_the_users_file(tmp_path: Path) -> None:
    path = tmp_path / "typo.urdf.xacro"
    path.write_text(XACRO.replace("${upper}", "${uper}"))
    line = 1 + XACRO.splitlines().index(next(t for t in XACRO.splitlines() if "${upper}" in t))
    with pytest.raises(URDFError, match=f"{path}: line {line}: xacro failed .*uper"):
        import_description(path)


def test_bad_arguments(tmp_path: Path) -> None:
    path = REFERENCE_URDFS / "ur5.urdf"
    spaced = tmp_path / "my arm.urdf"
    spaced.write_text(path.read_text())
    with pytest.raises(InputError, match=r"name \(from the file name .*my arm.*give a name with"):
        import_description(spaced, "base_link", "tool0")
    assert import_description(spaced, "base_link", "tool0", name="my_arm").table.name == "my_arm"
    with pytest.raises(InputError, match=r"name \(from --name\): expected a name other than"):
        import_description(path, "base_link", "tool0", name="include")
    with pytest.raises(InputError, match="convention: expected one of"):
        import_description(path, "base_link", "tool0", convention="craig")
    with pytest.raises(InputError, match="units: expected"):
        import_description(path, "base_link", "tool0", units={"length": "in", "angle": "deg"})
    with pytest.raises(URDFError, match="not xacro"):
        import_description(path, "base_link", "tool0", xacro_args={"a": "1"})


def test_cli_writes_nothing_on_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = _two_link(tmp_path, 'name="joint_2" type="revolute"', 'name="joint_2" type="planar"')
    output = tmp_path / "out.yaml"
    assert main(["import", str(bad), "-o", str(output)]) == 2
    assert "planar" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.urdf", "source.xacro"]
    assert main(["import", str(bad), "-o", str(tmp_path / "out.txt")]) == 2
    assert main(["import", str(bad), "-o", str(tmp_path / "missing" / "out.yaml")]) == 2
    assert main(["import", str(bad), "-o", str(output), "--xacro-arg", "novalue"]) == 2


def test_cli_does_not_overwrite_without_force(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    good = _two_link(tmp_path)
    output = tmp_path / "table.yaml"
    output.write_text("hand-edited\n")
    assert main(["import", str(good), "-o", str(output)]) == 2
    assert "the file exists" in capsys.readouterr().err
    assert output.read_text() == "hand-edited\n"
    assert main(["import", str(good), "-o", str(output), "--force", "--name", "arm"]) == 0
    out = capsys.readouterr().out
    assert "closed-form family: none (2 joints" in out and f"wrote {output}" in out
    data = yaml.safe_load(output.read_text())
    assert data["name"] == "arm" and [j["name"] for j in data["joints"]] == ["joint_1", "joint_2"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.urdf", "source.xacro",
                                                          "table.yaml"]


# --------------------------------------------------------------------------------------------
# The built-in tables imported from vendor URDFs


def test_imported_builtins_equal_a_fresh_import() -> None:
    """scripts/import_vendor_tables.py --check: each committed imported table is what importing
    its vendor URDF gives now (so the library of real arms is reproducible)."""
    import subprocess
    import sys

    result = subprocess.run([sys.executable, str(REPO / "scripts" / "import_vendor_tables.py"),
                             "--check", "--reference-dir", str(REFERENCE_URDFS)],
                            capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 imported file(s) stale" in result.stdout


def test_imported_builtins_cite_their_source() -> None:
    """A table imported from a vendor URDF cites it and its upstream; one imported from a
    support package cites the package's xacro, its upstream repository @ commit and the
    expansion shipped beside the other vendor URDFs."""
    from dhkin.vendors import IMPORTED, PACKAGE_ARMS, VENDOR_REFERENCES

    assert set(IMPORTED) <= set(dhkin.builtin_names())
    assert set(PACKAGE_ARMS) <= set(IMPORTED)
    for name in IMPORTED:
        table = dhkin.load(name).table
        vendor = VENDOR_REFERENCES[name]
        arm = PACKAGE_ARMS.get(name)
        if arm is None:
            assert f"robots/vendor/{vendor.file} ({vendor.base} -> {vendor.tip})" \
                in table.source
            assert "Upstream (the file's first comment): github.com/" in table.source
            assert VENDOR_IMPORTS[vendor.file][:2] == (vendor.base, vendor.tip)
            continue
        assert (f"robots/vendor/packages/{arm.package}/urdf/{arm.xacro} (base_link -> "
                f"{arm.tip})") in table.source
        assert re.search(r"Upstream: github\.com/ros-industrial/\w+ @ [0-9a-f]{40}, package "
                         + arm.package, table.source), name
        assert f"Its expansion ships as robots/vendor/{vendor.file}." in table.source
