"""Vendor cross-check: the built-in tables against independent vendor URDFs, through Pinocchio.

``dhkin.compare.compare_with_urdf`` drives both URDFs with the same joint vector in chain order,
so it must cope with other link names, extra fixed frames (``world``, ``base_link_inertia``,
``ft_frame``...) and continuous joints (the vendor UR3's wrist_3_joint: Pinocchio nq = 7, nv = 6).

* robots/vendor (UniversalRobots ROS2 description, ABB abb_experimental, AUBO
  aubo_description): ur3/ur5/ur10 and the IRB 1200 base_link -> tool0 (and flange), the AUBO i10
  base_link -> wrist3_Link (no tool0 upstream), at 1e-9 m and rad. The UR files round pi/2 to
  1.570796327 and carry ~2e-11 m residues, so 1e-9 is as tight as they allow.
* example-robot-data's older ``ur_description/urdf/ur{3,5,10}_robot.urdf``: base_link, base and
  tool0 are the frames they share with ours (no flange; other intermediate link frames).
* A table that is wrong by 1 mm, 0.01 deg or a sign must fail the comparison.
* Joint properties (names, types, limits, velocities in chain order): each kind of difference is
  reported, on tables and vendor files changed in tmp_path; the built-in tables' limits and
  velocities are the vendor files' (IRB 1200 joint 6: +-6.283 rad, not +-2 pi), and the IK
  answers stay within them.
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
from dhkin.compare import LIMIT_TOLERANCE, compare_with_urdf
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


# --------------------------------------------------------------------------------------------
# Joint properties: names, types, limits and velocities, table against the other URDF

#: The only joint differences of the built-in tables from their vendor files: the vendor's
#: continuous joints, which a table writes as -360..360 deg (every angle, twice).
CONTINUOUS_IN_VENDOR: dict[str, set[int]] = {"ur3": {5}, "kinova_gen3_6dof": {0, 3, 5}}


def _table_variant(tmp_path: Path, name: str, joint: int, change: dict[str, Any],
                   remove: tuple[str, ...] = ()) -> dhkin.Robot:
    """A copy of a built-in table file in tmp_path with one joint entry changed."""
    data = yaml.safe_load((REPO / "robots" / f"{name}.yaml").read_text(encoding="utf-8"))
    data["joints"][joint].update(change)
    for key in remove:
        del data["joints"][joint][key]
    path = tmp_path / f"{name}_variant.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return dhkin.load(path)


def _urdf_variant(tmp_path: Path, name: str, old: str, new: str) -> Path:
    """A copy of a vendor URDF in tmp_path with one piece of text replaced (exactly once)."""
    text = vendor_path(name).read_text(encoding="utf-8")
    assert text.count(old) == 1, old
    path = tmp_path / f"{name}_variant.urdf"
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


@pytest.mark.parametrize("name", sorted(VENDOR_REFERENCES))
def test_builtin_limits_and_velocities_are_the_vendors(name: str) -> None:
    """Every built-in with a vendor reference takes its position and velocity limits from that
    URDF (within LIMIT_TOLERANCE = 1e-12) and its joint names; the types differ only where the
    vendor has a continuous joint, and there the table's range covers every angle."""
    entry = VENDOR_REFERENCES[name]
    report = compare_with_urdf(dhkin.load(name), REFERENCE_URDFS / entry.file,
                               base_frame=entry.base, tip=entry.tip, robot_tip=entry.robot_tip,
                               n=10, seed=5)
    assert report.limit_tolerance == LIMIT_TOLERANCE == 1e-12
    assert report.limit_differences == (), report.summary()
    differences = {(d.index, d.field) for d in report.joint_differences}
    assert differences == {(k, "type") for k in CONTINUOUS_IN_VENDOR.get(name, set())}
    for difference in report.joint_differences:
        assert (difference.ours, difference.theirs) == ("revolute", "continuous")
        assert "covers every angle" in difference.note
    for ours, theirs in zip(report.joints, report.other_joints, strict=True):
        if theirs.type != "continuous":
            assert theirs.lower is not None and theirs.upper is not None
            assert ours.lower == pytest.approx(theirs.lower, abs=LIMIT_TOLERANCE, rel=0)
            assert ours.upper == pytest.approx(theirs.upper, abs=LIMIT_TOLERANCE, rel=0)
        assert theirs.velocity is not None
        assert ours.velocity == pytest.approx(theirs.velocity, abs=LIMIT_TOLERANCE, rel=0)


def test_irb1200_limits_are_the_vendors_rounded_radians() -> None:
    """The case of the issue: IRB 1200 joint 6 at +-6.283 rad as ABB's URDF, not +-2 pi."""
    table = dhkin.load("abb_irb1200_7_70").table
    assert (table.joints[5].lower, table.joints[5].upper) == (-6.283, 6.283)
    assert (table.joints[2].lower, table.joints[2].upper) == (-3.491, 1.222)


def _ik_against_vendor_limits(robot: dhkin.Robot, name: str,
                              q6_band: tuple[float, float]) -> tuple[int, int]:
    """Poses made by the vendor URDF with q6 in ``q6_band``, solved seeded at either end of the
    vendor's ranges, with and without every 2 pi copy; each answer must be exact on the vendor
    URDF. Returns the number of answers and of answers outside the vendor's limits."""
    entry = VENDOR_REFERENCES[name]
    path = REFERENCE_URDFS / entry.file
    vendor = Reference(path.read_text(encoding="utf-8"), tip=entry.tip, base=entry.base)
    lower = np.array([j.lower for j in vendor.joint_properties()])
    upper = np.array([j.upper for j in vendor.joint_properties()])
    rng = np.random.default_rng(6)
    q = rng.uniform(lower, upper, (20, 6))
    q[:, 5] = rng.uniform(*q6_band, len(q))
    found = outside = 0
    for row in q:
        target = vendor.fk(row)
        for seed, copies in ((lower, False), (upper, False), (None, True)):
            solutions = robot.ik(target, q_seed=seed, copies=copies)
            assert len(solutions) > 0
            found += len(solutions)
            outside += int(np.sum(np.any((solutions.q < lower) | (solutions.q > upper), axis=1)))
            position, rotation = pose_error(vendor.fk(solutions.q),
                                            np.broadcast_to(target, (len(solutions), 4, 4)))
            assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE
    return found, outside


def test_irb1200_ik_answers_are_within_the_vendor_limits() -> None:
    """The issue's case: q6 in (0, 1.8e-4) rad has a 2 pi copy in (-2 pi, -6.283), which the
    table's old +-360 deg let through and ABB's +-6.283 rad rejects. Now no answer of any seed
    or copy leaves the vendor's limits, while the old table's answers do."""
    band = (1e-6, 1.8e-4)
    found, outside = _ik_against_vendor_limits(dhkin.load("abb_irb1200_7_70"),
                                               "abb_irb1200_7_70", band)
    assert found > 60 and outside == 0
    data = yaml.safe_load((REPO / "robots" / "abb_irb1200_7_70.yaml").read_text(encoding="utf-8"))
    data["joints"][5].update(lower=-2 * math.pi, upper=2 * math.pi)
    old = dhkin.Robot(dhkin.parse_table(data, source="IRB 1200 with joint 6 at +-360 deg"))
    assert _ik_against_vendor_limits(old, "abb_irb1200_7_70", band)[1] > 0


def test_aubo_ik_answers_are_within_the_vendor_limits() -> None:
    found, outside = _ik_against_vendor_limits(dhkin.load("aubo_i10"), "aubo_i10",
                                               (-math.pi, math.pi))
    assert found > 60 and outside == 0


def test_limit_difference_is_reported(tmp_path: Path) -> None:
    """UR5 table with elbow_joint upper = 179 deg: one 'upper' difference, poses still OK."""
    robot = _table_variant(tmp_path, "ur5", 2, {"upper": 179})
    report = compare_with_urdf(robot, vendor_path("ur5"), n=50)
    assert report.ok and not report.joints_ok and not report.strict_ok
    assert len(report.joint_differences) == 1
    difference = report.joint_differences[0]
    assert (difference.index, difference.joint, difference.field) == (2, "elbow_joint", "upper")
    assert difference.ours == math.radians(179) and difference.theirs == math.pi
    assert report.limit_differences == (difference,)
    assert "179 deg" in difference.note and "3.141592653589793 rad" in difference.note
    lines = report.summary().splitlines()
    assert lines[0].startswith("OK: ")
    assert lines[1].startswith("joints: 1 difference(s) in the 6 chain joints")
    assert lines[2] == f"  {difference}"
    assert lines[2].startswith("  joint 3 (elbow_joint) upper: ")


def test_limit_difference_in_the_other_urdf_is_reported(tmp_path: Path) -> None:
    """The vendor UR5 with wrist_3_joint's limits rounded to 6.2832: lower and upper differ."""
    text = vendor_path("ur5").read_text(encoding="utf-8")
    start = text.index('<joint name="wrist_3_joint"')
    full = 'lower="-6.283185307179586" upper="6.283185307179586"'
    assert full in text[start:text.index("</joint>", start)]
    path = tmp_path / "ur5_variant.urdf"
    path.write_text(text[:start] + text[start:].replace(full, 'lower="-6.2832" upper="6.2832"', 1),
                    encoding="utf-8")
    report = compare_with_urdf(dhkin.load("ur5"), path, n=50)
    assert [(d.index, d.field, d.theirs) for d in report.joint_differences] == [
        (5, "lower", -6.2832), (5, "upper", 6.2832)]
    assert report.ok and not report.strict_ok


def test_limits_equal_within_the_stated_tolerance_only(tmp_path: Path) -> None:
    """A table limit 5e-13 rad off the vendor's is equal (deg/rad rounding is below 1e-12); one
    2e-12 rad off is reported. limit_tolerance= changes the threshold."""
    close = _table_variant(tmp_path, "ur5", 2, {"upper": math.degrees(math.pi + 5e-13)})
    assert abs(close.table.joints[2].upper - math.pi) < 1e-12
    assert compare_with_urdf(close, vendor_path("ur5"), n=5).joints_ok
    off = _table_variant(tmp_path, "ur5", 2, {"upper": math.degrees(math.pi + 2e-12)})
    report = compare_with_urdf(off, vendor_path("ur5"), n=5)
    assert [(d.index, d.field) for d in report.joint_differences] == [(2, "upper")]
    assert compare_with_urdf(off, vendor_path("ur5"), n=5, limit_tolerance=1e-11).joints_ok


def test_limit_tolerance_covers_deg_to_rad_rounding() -> None:
    """The derivation of LIMIT_TOLERANCE: every limit written in whole or tenth degrees up to
    +-720 deg, converted as the table reader does (v * fl(pi/180)), lands within 3.4e-16 |x|
    of the double nearest the exact radians (what a vendor URDF writing them in full gives),
    far below 1e-12."""
    from fractions import Fraction

    pi = Fraction("3.14159265358979323846264338327950288419716939937510582097494459")
    scale = math.pi / 180.0
    worst = 0.0
    for tenths in range(-7200, 7201):
        degrees = tenths / 10
        exact = float(Fraction(tenths, 10) * pi / 180)
        ours = degrees * scale
        worst = max(worst, abs(ours - exact))
        assert abs(ours - exact) <= 3.4e-16 * max(abs(exact), 1e-300) or ours == exact
    assert 0.0 < worst < 1e-14 < LIMIT_TOLERANCE


def test_type_difference_with_a_continuous_joint_is_reported() -> None:
    """The vendor UR3's continuous wrist_3_joint against the table's -360..360 deg: a type
    difference whose note says the URDF joint has no limits; no limit difference."""
    report = compare_with_urdf(dhkin.load("ur3"), vendor_path("ur3"), n=50)
    assert report.ok and not report.strict_ok
    assert report.limit_differences == ()
    (difference,) = report.joint_differences
    assert (difference.index, difference.joint, difference.field) == (5, "wrist_3_joint", "type")
    assert (difference.ours, difference.theirs) == ("revolute", "continuous")
    assert "no limits" in difference.note and "-360..360 deg covers every angle" in difference.note
    assert report.other_joints[5].lower is None and report.other_joints[5].upper is None


def test_type_difference_says_when_the_table_does_not_cover_every_angle(tmp_path: Path) -> None:
    robot = _table_variant(tmp_path, "ur3", 5, {"lower": -170, "upper": 170})
    (difference,) = compare_with_urdf(robot, vendor_path("ur3"), n=50).joint_differences
    assert difference.field == "type" and "does not cover every angle" in difference.note


def test_revolute_against_prismatic_is_a_type_difference(tmp_path: Path) -> None:
    """A vendor joint turned prismatic: a type difference (and the poses differ too)."""
    path = _urdf_variant(tmp_path, "ur5", '<joint name="wrist_2_joint" type="revolute">',
                         '<joint name="wrist_2_joint" type="prismatic">')
    report = compare_with_urdf(dhkin.load("ur5"), path, n=50)
    assert not report.ok
    types = [(d.index, d.ours, d.theirs) for d in report.joint_differences if d.field == "type"]
    assert types == [(4, "revolute", "prismatic")]


def test_missing_velocity_is_reported(tmp_path: Path) -> None:
    """A table without `velocity` writes velocity="0" into its URDF: reported as none given."""
    robot = _table_variant(tmp_path, "ur5", 0, {}, remove=("velocity",))
    assert 'velocity="0"' in robot.urdf()
    report = compare_with_urdf(robot, vendor_path("ur5"), n=50)
    (difference,) = report.joint_differences
    assert (difference.index, difference.field) == (0, "velocity")
    assert (difference.ours, difference.theirs) == (None, math.pi)
    assert difference.note.startswith("the table gives none")
    assert report.limit_differences == (difference,) and report.ok and not report.strict_ok


def test_velocity_missing_in_the_other_urdf_is_reported(tmp_path: Path) -> None:
    """A continuous vendor joint without <limit> states no velocity (Pinocchio: inf)."""
    path = _urdf_variant(tmp_path, "ur3", '<limit effort="12.0" velocity="6.283185307179586" />',
                         "")
    report = compare_with_urdf(dhkin.load("ur3"), path, n=50)
    assert [(d.index, d.field) for d in report.joint_differences] == [(5, "type"),
                                                                       (5, "velocity")]
    velocity = report.joint_differences[1]
    assert velocity.theirs is None and "none stated in the other URDF" in velocity.note


def test_different_velocity_is_reported(tmp_path: Path) -> None:
    robot = _table_variant(tmp_path, "ur5", 3, {"velocity": 191})
    (difference,) = compare_with_urdf(robot, vendor_path("ur5"), n=50).joint_differences
    assert (difference.index, difference.field) == (3, "velocity")
    assert difference.ours == math.radians(191) and difference.theirs == math.pi


def test_renamed_joint_is_reported(tmp_path: Path) -> None:
    """A table naming shoulder_lift_joint joint_2: a name difference; poses and limits agree."""
    robot = _table_variant(tmp_path, "ur5", 1, {"name": "joint_2"})
    report = compare_with_urdf(robot, vendor_path("ur5"), n=50)
    (difference,) = report.joint_differences
    assert (difference.index, difference.field) == (1, "name")
    assert (difference.ours, difference.theirs) == ("joint_2", "shoulder_lift_joint")
    assert report.ok and report.limit_differences == () and not report.strict_ok
    assert "'joint_2' vs 'shoulder_lift_joint'" in report.summary()


def test_equal_joints_are_summarised_in_one_line() -> None:
    report = compare_with_urdf(dhkin.load("ur5"), vendor_path("ur5"), n=20)
    assert report.strict_ok and report.joints_ok
    assert report.summary().splitlines()[1] == (
        "joints: the 6 chain joints have equal names, types, limits and velocities (limits "
        "within 1e-12)")


def test_negative_limit_tolerance_is_refused() -> None:
    with pytest.raises(dhkin.InputError, match="limit_tolerance: expected a number >= 0"):
        compare_with_urdf(dhkin.load("ur5"), vendor_path("ur5"), n=5, limit_tolerance=-1.0)


def test_check_fails_on_a_limit_difference_only(tmp_path: Path) -> None:
    """`dhkin check`'s vendor cell: a vendor file whose IRB 1200 joint 6 runs +-2 pi (what the
    table said before) fails it, naming the joint; the UR3's continuous joint is listed but
    passes; equal joints say so."""
    from dhkin.checks import check_vendor

    text = vendor_path("abb_irb1200_7_70").read_text(encoding="utf-8")
    assert text.count('lower="-6.283" upper="6.283"') == 1
    (tmp_path / "abb_irb1200_7_70.urdf").write_text(
        text.replace('lower="-6.283" upper="6.283"',
                     'lower="-6.283185307179586" upper="6.283185307179586"'), encoding="utf-8")
    cell = check_vendor(dhkin.load("abb_irb1200_7_70"), tmp_path)
    assert cell is not None and not cell.ok
    assert "joint_6 lower -6.283 vs -6.283185307179586" in cell.text
    assert "joint_6 upper 6.283 vs 6.283185307179586" in cell.text
    ur3 = check_vendor(dhkin.load("ur3"), REFERENCE_URDFS)
    assert ur3 is not None and ur3.ok and "wrist_3_joint type revolute vs continuous" in ur3.text
    ur5 = check_vendor(dhkin.load("ur5"), REFERENCE_URDFS)
    assert ur5 is not None and ur5.ok and ur5.text.endswith(", joints equal")


def test_compare_joints_needs_chains_of_equal_length() -> None:
    from dhkin.compare import compare_joints, table_joint_properties

    joints = table_joint_properties(dhkin.load("ur5").table)
    with pytest.raises(dhkin.InputError, match="theirs: expected 6 joints like ours, got 5"):
        compare_joints(joints, joints[:5])
