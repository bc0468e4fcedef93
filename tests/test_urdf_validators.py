"""Every generated URDF passes three real validators: urdfdom's check_urdf, Pinocchio, yourdfpy.

For every built-in robot and the two custom tables in tests/data, ``robot.urdf()`` (produced by
xacro) is written to a file and

* ``check_urdf`` (urdfdom, installed with pin next to the Python executable) parses it and finds
  base_link as the root; the test fails, never skips, if the tool is missing;
* Pinocchio builds a model from the file with the table's joints and the frames base_link, base,
  every link, flange and tool0;
* yourdfpy loads and validates it with exactly those links and joints, the table's joint types,
  axes and limits, and its own forward kinematics agrees with Pinocchio's to 1e-12.

``prefix="r1_"`` must prefix every link and joint name and change nothing else.
"""

from __future__ import annotations

import functools
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy

import dhkin
from dhkin.transforms import pose_error
from dhkin.validators import load_in_pinocchio, load_in_yourdfpy, run_check_urdf

from .conftest import DATA, PER_ROBOT_BUILTINS

#: The built-ins (a sample of the package arms: conftest.PER_ROBOT_BUILTINS; `dhkin check --all`
#: runs the three validators on every one) and two custom tables.
TABLES = [*PER_ROBOT_BUILTINS, "custom_arm_modified", "custom_arm_prismatic"]
FIXED_FRAMES = ("base_link", "base", "flange", "tool0")


@functools.cache
def load(name: str) -> dhkin.Robot:
    """The robot named ``name``, loaded once per test process: the five tests of each table
    read its table and generated URDF (``Robot.urdf`` caches the expansion), never change it."""
    if name.startswith("custom_"):
        return dhkin.load(DATA / f"{name}.yaml")
    return dhkin.load(name)


@pytest.fixture(scope="module")
def check_urdf() -> Path:
    """urdfdom's check_urdf: on PATH or next to sys.executable (the venv's bin/); must exist."""
    found = shutil.which("check_urdf") or shutil.which("check_urdf",
                                                       path=str(Path(sys.executable).parent))
    assert found is not None, "check_urdf not found on PATH nor next to the Python executable"
    return Path(found)


def run_check(check_urdf: Path, file: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(check_urdf), str(file)], capture_output=True, text=True,
                          check=False)


def write(tmp_path: Path, text: str, name: str = "robot.urdf") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def expected_links(robot: dhkin.Robot) -> set[str]:
    return {*FIXED_FRAMES, *(j.link for j in robot.table.joints)}


@pytest.mark.parametrize("name", TABLES)
def test_check_urdf_accepts_generated_urdf(name: str, check_urdf: Path, tmp_path: Path) -> None:
    """check_urdf exits 0, parses the file and reports base_link as the root link."""
    robot = load(name)
    result = run_check(check_urdf, write(tmp_path, robot.urdf()))
    assert result.returncode == 0, result.stdout + result.stderr
    assert "Successfully Parsed XML" in result.stdout
    assert "root Link: base_link has 2 child(ren)" in result.stdout
    assert f"robot name is: {robot.name}" in result.stdout


def test_check_urdf_rejects_broken_urdfs(check_urdf: Path, tmp_path: Path) -> None:
    """check_urdf really validates: a generated URDF without its first joint (two roots) and a
    joint pointing at a missing link both fail."""
    root = ET.fromstring(dhkin.load("ur5").urdf())
    root.remove(root.find("joint"))
    result = run_check(check_urdf, write(tmp_path, ET.tostring(root, encoding="unicode"),
                                         "two_roots.urdf"))
    assert result.returncode != 0
    assert "Two root links found" in result.stdout + result.stderr
    dangling = ('<robot name="x"><link name="a"/><joint name="j" type="fixed">'
                '<parent link="a"/><child link="b"/></joint></robot>')
    assert run_check(check_urdf, write(tmp_path, dangling, "dangling.urdf")).returncode != 0


@pytest.mark.parametrize("name", TABLES)
def test_pinocchio_loads_generated_urdf_file(name: str, tmp_path: Path) -> None:
    """Pinocchio builds the model from the file: one joint of the right kind per table row, in
    order, and every expected frame."""
    robot = load(name)
    model = pin.buildModelFromUrdf(str(write(tmp_path, robot.urdf())))
    assert model.nq == model.nv == robot.dof
    assert [model.names[i] for i in range(1, model.njoints)] == robot.table.joint_names
    for i, joint in enumerate(robot.table.joints, start=1):
        kind = model.joints[i].shortname()  # JointModelRZ, JointModelRevoluteUnaligned, ...
        assert kind.startswith("JointModelR" if joint.is_revolute else "JointModelP"), kind
    for frame in expected_links(robot):
        assert model.existFrame(frame), frame
    np.testing.assert_allclose(model.lowerPositionLimit, robot.lower, rtol=1e-15)
    np.testing.assert_allclose(model.upperPositionLimit, robot.upper, rtol=1e-15)


@pytest.mark.parametrize("name", TABLES)
def test_yourdfpy_loads_and_validates_generated_urdf(name: str, tmp_path: Path) -> None:
    """yourdfpy: valid; exactly the expected links; the table's joints with their types, axes
    (0, 0, direction) and limits; the fixed joints base_link -> base, link_n -> flange ->
    tool0."""
    robot = load(name)
    urdf = yourdfpy.URDF.load(str(write(tmp_path, robot.urdf())), load_meshes=False,
                              build_collision_scene_graph=False, load_collision_meshes=False)
    assert urdf.validate()
    assert urdf.base_link == "base_link"
    assert set(urdf.link_map) == expected_links(robot)
    assert urdf.actuated_joint_names == robot.table.joint_names
    for joint in robot.table.joints:
        theirs = urdf.joint_map[joint.name]
        assert theirs.type == joint.type
        np.testing.assert_array_equal(theirs.axis, [0, 0, joint.direction])
        assert (theirs.limit.lower, theirs.limit.upper) == pytest.approx(
            (joint.lower, joint.upper), rel=1e-15)
        assert (theirs.limit.velocity, theirs.limit.effort) == pytest.approx(
            (joint.velocity, joint.effort), rel=1e-15)
    fixed = {(j.parent, j.child) for j in urdf.joint_map.values() if j.type == "fixed"}
    assert fixed == {("base_link", "base"), (robot.table.joints[-1].link, "flange"),
                     ("flange", "tool0")}


@pytest.mark.parametrize("name", TABLES)
def test_yourdfpy_fk_equals_pinocchio_fk(name: str, tmp_path: Path) -> None:
    """A third, independent URDF reader: yourdfpy's FK of tool0, flange and base equals
    Pinocchio's on the same file to 1e-12 (100 random q within the limits)."""
    robot = load(name)
    path = write(tmp_path, robot.urdf())
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False,
                              load_collision_meshes=False)
    reference = robot.reference()
    Q = robot.table.random_q(100, np.random.default_rng(11))
    for frame in ("tool0", "flange", "base"):
        theirs = np.empty((len(Q), 4, 4))
        for k, q in enumerate(Q):
            urdf.update_cfg(q)
            theirs[k] = urdf.get_transform(frame, "base_link")
        position, rotation = pose_error(reference.fk(Q, frame=frame), theirs)
        assert position.max() <= 1e-12 and rotation.max() <= 1e-12, frame


@pytest.mark.parametrize("name", TABLES)
def test_prefix_prefixes_every_name(name: str, check_urdf: Path, tmp_path: Path) -> None:
    """prefix='r1_': every link and joint name and every parent/child reference carries it,
    removing it gives back the unprefixed URDF's names, and the kinematics are unchanged."""
    robot = load(name)
    plain = ET.fromstring(robot.urdf())
    text = robot.urdf(prefix="r1_")
    prefixed = ET.fromstring(text)
    assert prefixed.get("name") == plain.get("name") == robot.name
    names = [e.get("name") for e in prefixed.iter() if e.tag in ("link", "joint")]
    refs = [e.get("link") for e in prefixed.iter() if e.tag in ("parent", "child")]
    assert names and refs
    assert all(n.startswith("r1_") for n in names + refs), names + refs
    assert [n[3:] for n in names] == [e.get("name") for e in plain.iter()
                                      if e.tag in ("link", "joint")]
    assert [r[3:] for r in refs] == [e.get("link") for e in plain.iter()
                                     if e.tag in ("parent", "child")]
    assert run_check(check_urdf, write(tmp_path, text)).returncode == 0
    model = pin.buildModelFromXML(text)
    data = model.createData()
    for frame in expected_links(robot):
        assert model.existFrame(f"r1_{frame}") and not model.existFrame(frame), frame
    q = robot.table.random_q(1, np.random.default_rng(5))[0]
    pin.framesForwardKinematics(model, data, q)
    np.testing.assert_array_equal(data.oMf[model.getFrameId("r1_tool0")].homogeneous,
                                  robot.reference().fk(q))


def test_library_validators_agree(tmp_path: Path) -> None:
    """dhkin.validators (used by `dhkin check`) passes the generated URDF and fails a URDF that
    lacks tool0, in all three validators' own words."""
    robot = dhkin.load("abb_irb1200_7_70")
    good = write(tmp_path, robot.urdf(), "good.urdf")
    assert run_check_urdf(good).ok
    assert load_in_pinocchio(robot.urdf()).ok
    assert load_in_yourdfpy(good).ok
    root = ET.fromstring(robot.urdf())
    for element in list(root):
        if element.get("name") == "tool0" or (element.tag == "joint"
                                              and element.find("child").get("link") == "tool0"):
            root.remove(element)
    text = ET.tostring(root, encoding="unicode")
    bad = write(tmp_path, text, "no_tool0.urdf")
    assert run_check_urdf(bad).ok  # still a valid URDF, just without the frame
    verdict = load_in_pinocchio(text)
    assert not verdict.ok and "tool0" in verdict.detail
    verdict = load_in_yourdfpy(bad)
    assert not verdict.ok and "tool0" in verdict.detail
