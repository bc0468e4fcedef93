"""Vendor cross-check: the built-in tables against independent vendor URDFs, through Pinocchio.

``dhkin.compare.compare_with_urdf`` drives both URDFs with the same joint vector in chain order,
so it must cope with other link names, extra fixed frames (``world``, ``base_link_inertia``,
``ft_frame``...) and continuous joints (the vendor UR3's wrist_3_joint: Pinocchio nq = 7, nv = 6).

* ../shared/reference (UniversalRobots ROS2 description, ABB abb_experimental, AUBO
  aubo_description): ur3/ur5/ur10 and the IRB 1200 base_link -> tool0 (and flange), the AUBO i10
  base_link -> wrist3_Link (no tool0 upstream), at 1e-9 m and rad. The UR files round pi/2 to
  1.570796327 and carry ~2e-11 m residues, so 1e-9 is as tight as they allow.
* example-robot-data's older ``ur_description/urdf/ur{3,5,10}_robot.urdf``: base_link, base and
  tool0 are the frames they share with ours (no flange; other intermediate link frames).
* A table that is wrong by 1 mm, 0.01 deg or a sign must fail the comparison.
"""

from __future__ import annotations

import importlib.metadata
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import dhkin
from dhkin.compare import compare_with_urdf
from dhkin.reference import Reference
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import pose_error
from dhkin.vendors import VENDOR_REFERENCES

from .conftest import DATA, REFERENCE_URDFS, REPO
from .test_fk_oracle import special_grid

TOLERANCE = 1e-9
N_SAMPLES = 10_000

#: (robot, vendor frame, our frame) compared over base_link -> frame.
VENDOR_CASES = [
    ("ur3", "tool0", "tool0"),
    ("ur5", "tool0", "tool0"),
    ("ur10", "tool0", "tool0"),
    ("abb_irb1200_7_70", "tool0", "tool0"),
    ("aubo_i10", "wrist3_Link", "tool0"),
    ("ur3", "flange", "flange"),
    ("ur5", "flange", "flange"),
    ("ur10", "flange", "flange"),
    ("abb_irb1200_7_70", "flange", "flange"),
]
CASE_IDS = [f"{name}-{tip}" for name, tip, _ in VENDOR_CASES]


def vendor_path(name: str) -> Path:
    path = REFERENCE_URDFS / f"{name}.urdf"
    assert path.is_file(), f"{path}: vendor reference URDF missing"
    return path


@pytest.mark.parametrize(("name", "tip", "robot_tip"), VENDOR_CASES, ids=CASE_IDS)
def test_builtin_table_matches_vendor_urdf(name: str, tip: str, robot_tip: str) -> None:
    """compare_with_urdf over 10^4 random q (plus zero): deviations <= 1e-9 m and rad."""
    report = compare_with_urdf(dhkin.load(name), vendor_path(name), tip=tip, robot_tip=robot_tip,
                               n=N_SAMPLES, seed=1)
    assert report.samples == N_SAMPLES and report.tolerance == DEFAULT_TOLERANCE == 1e-9
    assert report.max_position <= TOLERANCE, report.summary()
    assert report.max_rotation <= TOLERANCE, report.summary()
    assert report.ok and report.summary().startswith("OK: ")


@pytest.mark.parametrize(("name", "tip", "robot_tip"), VENDOR_CASES, ids=CASE_IDS)
def test_builtin_table_matches_vendor_urdf_at_special_angles(name: str, tip: str,
                                                            robot_tip: str) -> None:
    """The same comparison on every combination of 0, +-pi/2, +-pi within the limits."""
    robot = dhkin.load(name)
    path = vendor_path(name)
    vendor = Reference(path.read_text(encoding="utf-8"), tip=tip, base="base_link",
                       source=str(path))
    Q = special_grid(robot.table)
    position, rotation = pose_error(robot.reference(tip=robot_tip).fk(Q), vendor.fk(Q))
    assert position.max() <= TOLERANCE, Q[position.argmax()]
    assert rotation.max() <= TOLERANCE, Q[rotation.argmax()]


@pytest.mark.parametrize("name", ["ur3", "ur5", "ur10", "abb_irb1200_7_70", "aubo_i10"])
def test_vendor_chain_is_driven_in_chain_order(name: str) -> None:
    """The vendor chain's actuated joints are found base to tip (names as the table's where the
    vendor uses the same ones), whatever fixed frames and continuous joints it has."""
    path = vendor_path(name)
    tip = "wrist3_Link" if name == "aubo_i10" else "tool0"
    vendor = Reference(path.read_text(encoding="utf-8"), tip=tip, base="base_link")
    assert vendor.joint_names == dhkin.load(name).table.joint_names
    if name == "ur3":
        assert (vendor.model.nq, vendor.model.nv) == (7, 6)  # continuous wrist_3_joint


def test_vendor_base_frames_agree() -> None:
    """UR: the vendor's `base` (base_link turned 180 deg about z) is our `base` frame too."""
    for name in ("ur3", "ur5", "ur10"):
        path = vendor_path(name)
        vendor = Reference(path.read_text(encoding="utf-8"), tip="tool0")
        ours = dhkin.load(name).reference()
        q = np.zeros(6)
        np.testing.assert_allclose(vendor.fk(q, frame="base"), ours.fk(q, frame="base"),
                                   rtol=0, atol=1e-9)


# --------------------------------------------------------------------------------------------
# example-robot-data


def example_robot_data_robots() -> Path:
    """The robots/ folder of the installed example-robot-data (its Python module, if present,
    else the cmeel prefix of the installed distribution)."""
    try:
        import example_robot_data  # type: ignore[import-not-found]

        return Path(example_robot_data.getModelPath("ur_description/urdf/ur5_robot.urdf"))
    except ImportError:
        distribution = importlib.metadata.distribution("example-robot-data")
        folder = Path(str(distribution.locate_file("cmeel.prefix/share/example-robot-data/robots")))
        assert folder.is_dir(), f"{folder}: example-robot-data robots folder not found"
        return folder


def erd_urdf(name: str) -> Path:
    path = example_robot_data_robots() / "ur_description" / "urdf" / f"{name}_robot.urdf"
    assert path.is_file(), f"{path}: missing from example-robot-data"
    return path


@pytest.mark.parametrize("name", ["ur3", "ur5", "ur10"])
def test_example_robot_data_frames(name: str) -> None:
    """What the older UR files offer: base_link, base and tool0 like ours, plus world and
    ee_link, and no flange; the same six joint names in chain order."""
    path = erd_urdf(name)
    reference = Reference(path.read_text(encoding="utf-8"), tip="tool0", source=str(path))
    frames = {f.name for f in reference.model.frames}
    assert {"world", "base_link", "base", "tool0", "ee_link"} <= frames
    assert "flange" not in frames
    assert reference.joint_names == dhkin.load(name).table.joint_names


@pytest.mark.parametrize("name", ["ur3", "ur5", "ur10"])
def test_builtin_table_matches_example_robot_data(name: str) -> None:
    """base_link -> tool0 (compare_with_urdf) and base -> tool0 agree with example-robot-data's
    ur{3,5,10}_robot.urdf to 1e-9."""
    robot = dhkin.load(name)
    path = erd_urdf(name)
    report = compare_with_urdf(robot, path, n=N_SAMPLES, seed=2)
    assert report.ok, report.summary()
    vendor = Reference(path.read_text(encoding="utf-8"), tip="tool0", base="base")
    ours = Reference(robot.urdf(), tip="tool0", base="base")
    Q = np.vstack([robot.table.random_q(2000, np.random.default_rng(3)),
                   special_grid(robot.table)])
    position, rotation = pose_error(ours.fk(Q), vendor.fk(Q))
    assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE


# --------------------------------------------------------------------------------------------
# Errors and failures


def test_vendor_urdf_without_the_requested_frame() -> None:
    """AUBO's URDF has no tool0: URDFError naming the file, the frame and the frames it has."""
    path = vendor_path("aubo_i10")
    with pytest.raises(dhkin.URDFError) as info:
        compare_with_urdf(dhkin.load("aubo_i10"), path, tip="tool0")
    message = str(info.value)
    assert message.startswith(f"{path}: no frame named 'tool0'; expected one of ["), message
    assert "'wrist3_Link'" in message and "'base_link'" in message


def test_vendor_urdf_without_the_requested_base_frame() -> None:
    """A base frame the vendor file lacks is reported the same way."""
    path = vendor_path("ur5")
    with pytest.raises(dhkin.URDFError, match="no frame named 'base_footprint'; expected one of"):
        compare_with_urdf(dhkin.load("ur5"), path, base_frame="base_footprint")


def test_chain_of_another_length_is_refused() -> None:
    """Comparing a 2-joint table with a 6-joint vendor chain names both counts."""
    path = vendor_path("ur5")
    with pytest.raises(dhkin.URDFError) as info:
        compare_with_urdf(dhkin.load("planar_2r"), path)
    assert "has 6 actuated joints" in str(info.value)
    assert "expected 2 like planar_2r" in str(info.value)


def test_unreadable_vendor_file() -> None:
    """A missing vendor file is a URDFError naming it."""
    missing = REFERENCE_URDFS / "no_such_robot.urdf"
    with pytest.raises(dhkin.URDFError, match=r"no_such_robot\.urdf: cannot read URDF"):
        compare_with_urdf(dhkin.load("ur5"), missing)


def test_table_with_d4_one_millimetre_off_fails() -> None:
    """tests/data/ur5_d4_plus_1mm.yaml (d4 + 1 mm) fails against the vendor UR5, and the report
    measures the slip: every distal frame is shifted by exactly 1 mm, not turned."""
    robot = dhkin.load(DATA / "ur5_d4_plus_1mm.yaml")
    report = compare_with_urdf(robot, vendor_path("ur5"), n=2000)
    assert not report.ok and report.summary().startswith("FAIL: ")
    assert report.max_position == pytest.approx(1e-3, abs=TOLERANCE)
    assert report.max_rotation <= TOLERANCE


def _ur5_variant(change: dict[str, Any], joint: int) -> dhkin.Robot:
    data = yaml.safe_load((REPO / "robots" / "ur5.yaml").read_text(encoding="utf-8"))
    data["joints"][joint].update(change)
    return dhkin.Robot(dhkin.parse_table(data, source="ur5 variant"))


WRONG_VARIANTS = [
    ({"offset": 0.01}, 1, "shoulder_lift offset 0.01 deg"),
    ({"direction": -1}, 2, "elbow turning the other way"),
    ({"alpha": 90}, 4, "wrist_2 twist sign"),
    ({"a": 0.425}, 1, "a2 sign (UR tables use -0.425)"),
]


@pytest.mark.parametrize(("change", "joint", "slip"), WRONG_VARIANTS,
                         ids=[v[2] for v in WRONG_VARIANTS])
def test_wrong_table_fails_the_comparison(change: dict[str, Any], joint: int, slip: str) -> None:
    """Typical slips in a UR5 table are caught by the vendor comparison."""
    report = compare_with_urdf(_ur5_variant(change, joint), vendor_path("ur5"), n=2000)
    assert not report.ok, slip
    assert max(report.max_position, report.max_rotation) > 1e3 * TOLERANCE, slip


def test_small_offset_slip_is_measured_exactly() -> None:
    """An offset 0.01 deg off turns every tool0 pose by exactly 0.01 deg: the report's worst
    rotation is that angle (to the vendor's 1e-9 rounding)."""
    report = compare_with_urdf(_ur5_variant({"offset": 0.01}, 1), vendor_path("ur5"), n=2000)
    assert report.max_rotation == pytest.approx(math.radians(0.01), abs=TOLERANCE)


# --------------------------------------------------------------------------------------------
# Every built-in robot with a vendor reference (dhkin.vendors), with that reference's frames


@pytest.mark.parametrize("name", sorted(VENDOR_REFERENCES))
def test_every_vendor_reference_matches_its_builtin(name: str) -> None:
    """Each entry of VENDOR_REFERENCES (what `dhkin check` compares) names a built-in robot and
    a vendor file whose base -> tip chain equals the table to 1e-9 on 10^3 random q: the new
    ur5e (plain DH; the vendor rounds pi/2) and the fitted ur5e_calibrated, tm5_900 and
    kinova_gen3_6dof (corrections) included."""
    entry = VENDOR_REFERENCES[name]
    assert name in dhkin.builtin_names()
    report = compare_with_urdf(dhkin.load(name), REFERENCE_URDFS / entry.file,
                               base_frame=entry.base, tip=entry.tip, robot_tip=entry.robot_tip,
                               n=1000, seed=4)
    assert report.ok, report.summary()
