"""DH table files: parsing, unit conversion, defaults, prismatic rows and every bad input.

Every bad table gives a dhkin exception (:class:`dhkin.DHError`, or :class:`dhkin.URDFError` for a
URDF without the requested frame) whose message names the file, the field at fault and what was
expected. The bad tables live in ``tests/data/bad_tables/``, one defect per file, each described by
the file's first comment line.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import dhkin
from dhkin.dh import DEFAULT_FLANGE_RPY_DEG
from dhkin.reference import Reference
from dhkin.transforms import pose_error, rot_x, rot_y, rot_z, translation

from .conftest import DATA, REFERENCE_URDFS

BAD_TABLES = DATA / "bad_tables"
DEG = math.pi / 180.0

#: (file stem in tests/data/bad_tables, field the message must name, expectation it must state).
#: An empty field means the defect concerns the whole file (not a mapping, not YAML).
BAD_CASES: list[tuple[str, str, str]] = [
    # unknown keys
    ("unknown_top_key", "tcp", "unknown key; expected one of ['name', 'convention'"),
    ("unknown_joint_key", "joints[1].alhpa", "unknown key; expected one of ['a', 'alpha'"),
    ("unknown_frame_key", "base.rot", "unknown key; expected one of ['xyz', 'rpy']"),
    ("duplicate_key", "joints[1].a",
     "given twice in one mapping (line 7, columns 6 and 59); expected each key once"),
    # missing keys
    ("missing_top_key", "convention", "missing required key"),
    ("missing_joint_key", "joints[1].lower", "missing required key"),
    ("missing_unit_key", "units.angle", "missing required key"),
    # wrong units
    ("unit_length_cm", "units.length", "expected one of ['m', 'mm'], got 'cm'"),
    ("unit_angle_degree", "units.angle", "expected one of ['rad', 'deg'], got 'degree'"),
    ("degrees_in_rad_table", "joints[0].alpha", "expected an angle within +-360 deg (+-2pi rad), "
     "got 90 rad; are units.angle right?"),
    ("units_not_mapping", "units", "expected a mapping {length: m|mm, angle: deg|rad}, got 'mm'"),
    # lower > upper (and an empty range)
    ("lower_above_upper", "joints[0].lower",
     "expected lower < upper, got lower = 170, upper = -170"),
    ("lower_equals_upper", "joints[1].lower", "expected lower < upper, got lower = 30, upper = 30"),
    # non-finite or non-numeric numbers
    ("nan_length", "joints[1].a", "expected a finite number, got nan"),
    ("infinite_limit", "joints[0].upper", "expected a finite number, got inf"),
    ("infinite_base", "base.xyz[2]", "expected a finite number, got -inf"),
    ("text_number", "joints[1].a", "expected a finite number, got '0.35'"),
    # a table with 0 joints, or joints that are not a list
    ("zero_joints", "joints", "expected at least one joint, got an empty list"),
    ("joints_not_list", "joints", "expected a list of joint entries, got dict"),
    # other values
    ("bad_convention", "convention", "expected one of ['standard', 'modified'], got 'craig'"),
    ("bad_direction", "joints[0].direction", "expected 1 or -1, got 2"),
    ("bad_joint_type", "joints[0].type", "expected one of ['revolute', 'prismatic']"),
    ("prismatic_with_d", "joints[1].d", "a prismatic joint's d is its joint variable"),
    ("revolute_with_theta", "joints[0].theta", "a revolute joint's theta is its joint variable"),
    ("duplicate_joint_name", "joints[1].name", "duplicate name 'axis'"),
    ("reserved_link_name", "joints[1].link", "'tool0' is reserved for a fixed frame"),
    ("negative_velocity", "joints[0].velocity", "expected a value >= 0, got -10"),
    ("short_rpy", "tool.rpy", "expected a list of 3 numbers, got [0, 90]"),
    ("bad_robot_name", "name", "expected a name of letters, digits"),
    # per-joint corrections (DESIGN.md, "Corrections")
    ("correction_not_mapping", "joints[1].correction",
     "expected a mapping {xyz: [x, y, z], rpy: [r, p, y]}, got [0.001, 0, 0, 0, 0, 0]"),
    ("correction_unknown_key", "joints[1].correction.rot",
     "unknown key; expected one of ['xyz', 'rpy']"),
    ("correction_short_xyz", "joints[1].correction.xyz",
     "expected a list of 3 numbers, got [1, 2]"),
    ("correction_text_number", "joints[1].correction.rpy[1]", "expected a finite number, got 'x'"),
    ("correction_nan", "joints[1].correction.xyz[1]", "expected a finite number, got nan"),
    ("correction_angle_too_large", "joints[1].correction.rpy[1]",
     "expected an angle within +-360 deg (+-2pi rad), got 400 deg; are units.angle right?"),
    ("correction_degrees_in_rad_table", "joints[1].correction.rpy[2]",
     "expected an angle within +-360 deg (+-2pi rad), got 90 rad; are units.angle right?"),
    # the file as a whole
    ("not_a_mapping", "", "expected a mapping with keys ('name', 'convention', 'units', 'joints')"),
    ("invalid_yaml", "", "not valid YAML"),
]


@pytest.mark.parametrize(("stem", "field", "expected"), BAD_CASES, ids=[c[0] for c in BAD_CASES])
def test_bad_table_raises_dherror_naming_file_field_and_expectation(stem: str, field: str,
                                                                   expected: str) -> None:
    """dhkin.load of a bad table raises DHError '<file>: <field>: <what was expected>'."""
    path = BAD_TABLES / f"{stem}.yaml"
    with pytest.raises(dhkin.DHError) as info:
        dhkin.load(path)
    message = str(info.value)
    assert message.startswith(f"{path}: "), message
    if field:
        assert message.startswith(f"{path}: {field}: "), message
    assert expected in message, message
    assert isinstance(info.value, dhkin.DhkinError) and isinstance(info.value, ValueError)


def test_every_bad_table_file_has_a_case() -> None:
    """No file in tests/data/bad_tables is left untested, and every case has its file."""
    assert {p.stem for p in BAD_TABLES.glob("*.yaml")} == {c[0] for c in BAD_CASES}


def test_bad_table_given_as_mapping_names_its_source() -> None:
    """parse_table (tables built in code) names the caller's source instead of a file."""
    data = {"name": "x", "convention": "standard", "units": {"length": "m", "angle": "deg"},
            "joints": [{"a": 0, "alpha": 0, "d": 0, "lower": 1, "upper": -1}]}
    with pytest.raises(dhkin.DHError, match=r"^my_generator: joints\[0\]\.lower: expected lower"):
        dhkin.parse_table(data, source="my_generator")


def test_missing_table_file() -> None:
    """A path that does not exist: RobotNotFoundError from dhkin.load, DHError from load_table."""
    missing = DATA / "no_such_table.yaml"
    with pytest.raises(dhkin.RobotNotFoundError,
                       match=r"no_such_table\.yaml: no such DH table file"):
        dhkin.load(missing)
    with pytest.raises(dhkin.DHError, match=r"no_such_table\.yaml: cannot read DH table file"):
        dhkin.load_table(missing)


def test_unknown_robot_name_lists_the_builtins() -> None:
    """A name that is neither built in nor a file says which robots are built in."""
    with pytest.raises(dhkin.RobotNotFoundError) as info:
        dhkin.load("irb_9999")
    assert "'irb_9999' is neither a built-in robot nor a table file" in str(info.value)
    assert "ur5" in str(info.value) and "abb_irb1200_7_70" in str(info.value)


# --------------------------------------------------------------------------------------------
# A URDF without the requested frame


def test_generated_urdf_without_requested_frame_raises_urdferror() -> None:
    """Asking the generated URDF for a frame it lacks names the URDF, the frame and the choices."""
    robot = dhkin.load("ur5")
    with pytest.raises(dhkin.URDFError) as info:
        robot.reference(tip="tcp")
    message = str(info.value)
    assert message.startswith("ur5.urdf: no frame named 'tcp'; expected one of ["), message
    for frame in ("base_link", "base", "flange", "tool0", "wrist_3_link"):
        assert f"'{frame}'" in message
    with pytest.raises(dhkin.URDFError, match=r"ur5\.urdf: no frame named 'link_9'"):
        robot.reference().fk(np.zeros(6), frame="link_9")


def test_vendor_urdf_without_requested_frame_raises_urdferror() -> None:
    """The AUBO vendor URDF has no tool0: the error names the file and lists its frames."""
    path = REFERENCE_URDFS / "aubo_i10.urdf"
    with pytest.raises(dhkin.URDFError) as info:
        Reference(path.read_text(encoding="utf-8"), tip="tool0", source=str(path))
    message = str(info.value)
    assert message.startswith(f"{path}: no frame named 'tool0'; expected one of ["), message
    assert "'wrist3_Link'" in message


# --------------------------------------------------------------------------------------------
# Parsing, units and defaults


def test_ur5_values_are_converted_to_si() -> None:
    """The built-in UR5 (m, deg) is held in metres and radians, base and flange as 4x4."""
    table = dhkin.load("ur5").table
    assert table.convention == "standard" and table.dof == 6
    assert table.joint_names[0] == "shoulder_pan_joint"
    assert [j.link for j in table.joints][-1] == "wrist_3_link"
    first, second = table.joints[0], table.joints[1]
    assert first.d == 0.089159 and first.a == 0.0
    assert second.a == -0.425
    assert first.alpha == pytest.approx(math.pi / 2, abs=1e-16)
    assert first.lower == pytest.approx(-2 * math.pi, abs=1e-15)
    assert first.velocity == pytest.approx(math.pi, abs=1e-15)
    assert first.effort == 150.0
    np.testing.assert_allclose(table.base, rot_z(math.pi), atol=1e-16)
    np.testing.assert_allclose(table.flange, rot_z(-math.pi / 2) @ rot_y(-math.pi / 2),
                               atol=1e-16)
    np.testing.assert_array_equal(table.tool, np.eye(4))


def test_millimetres_and_degrees_are_converted() -> None:
    """custom_arm_modified.yaml (mm, deg): lengths / 1000, angles * pi / 180, frames too."""
    table = dhkin.load(DATA / "custom_arm_modified.yaml").table
    arm = table.joints[1]
    assert arm.name == "axis_2" and arm.link == "arm"
    assert arm.a == pytest.approx(0.075, abs=1e-17)
    assert arm.d == pytest.approx(0.020, abs=1e-17)
    assert arm.alpha == pytest.approx(-90 * DEG, abs=1e-16)
    assert arm.offset == pytest.approx(-90 * DEG, abs=1e-16)
    assert (arm.lower, arm.upper) == pytest.approx((-90 * DEG, 150 * DEG), abs=1e-15)
    assert arm.velocity == pytest.approx(150 * DEG, abs=1e-15)
    assert table.joints[2].d == pytest.approx(-0.015, abs=1e-17)
    assert [j.direction for j in table.joints] == [-1, 1, -1, 1, -1, 1]
    base = translation(0.12, -0.045, 0.31) @ rot_z(30 * DEG) @ rot_y(-10 * DEG) @ rot_x(5 * DEG)
    tool = translation(0.010, -0.020, 0.135) @ rot_z(90 * DEG) @ rot_y(15 * DEG)
    flange = translation(0, 0, 0.004) @ rot_y(-90 * DEG)
    np.testing.assert_allclose(table.base, base, atol=1e-16)
    np.testing.assert_allclose(table.tool, tool, atol=1e-16)
    np.testing.assert_allclose(table.flange, flange, atol=1e-16)


def test_defaults() -> None:
    """Omitted keys: revolute, direction 1, offset 0, joint_i/link_i, no speed or effort limit,
    identity base and tool, flange turned (0, -90, 0) deg, empty description and source."""
    data = {"name": "two_links", "convention": "modified",
            "units": {"length": "m", "angle": "rad"},
            "joints": [{"a": 0, "alpha": 0, "d": 0.3, "lower": -1, "upper": 1},
                       {"a": 0.5, "alpha": 0, "d": 0, "lower": -2, "upper": 2}]}
    table = dhkin.parse_table(data)
    for i, joint in enumerate(table.joints, start=1):
        assert joint.name == f"joint_{i}" and joint.link == f"link_{i}"
        assert joint.type == "revolute" and joint.is_revolute
        assert joint.direction == 1 and joint.offset == 0.0 and joint.theta == 0.0
        assert joint.velocity == 0.0 and joint.effort == 0.0
    np.testing.assert_array_equal(table.base, np.eye(4))
    np.testing.assert_array_equal(table.tool, np.eye(4))
    assert DEFAULT_FLANGE_RPY_DEG == (0.0, -90.0, 0.0)
    np.testing.assert_allclose(table.flange, rot_y(-math.pi / 2), atol=1e-16)
    assert table.description == "" and table.source == "" and table.path is None
    np.testing.assert_array_equal(table.lower, [-1, -2])
    np.testing.assert_array_equal(table.upper, [1, 2])


def test_base_and_tool_default_to_identity_when_only_one_part_is_given() -> None:
    """A frame with only xyz has no rotation; one with only rpy has no translation."""
    data = {"name": "x", "convention": "standard", "units": {"length": "mm", "angle": "deg"},
            "base": {"xyz": [0, 0, 250]}, "tool": {"rpy": [0, 0, 90]},
            "joints": [{"a": 0, "alpha": 0, "d": 0, "lower": -90, "upper": 90}]}
    table = dhkin.parse_table(data)
    np.testing.assert_allclose(table.base, translation(0, 0, 0.25), atol=1e-16)
    np.testing.assert_allclose(table.tool, rot_z(math.pi / 2), atol=1e-16)


@pytest.mark.parametrize("name", dhkin.builtin_names())
def test_every_builtin_table_is_valid(name: str) -> None:
    """Each built-in table loads with finite values, lower < upper and unique joint names."""
    table = dhkin.load(name).table
    assert table.name == name and table.path is not None and table.path.name == f"{name}.yaml"
    values = [[j.a, j.alpha, j.d, j.theta, j.offset, j.lower, j.upper] for j in table.joints]
    assert np.all(np.isfinite(values))
    assert np.all(table.lower < table.upper)
    assert len(set(table.joint_names)) == table.dof


def test_joint_values_are_checked_by_fk() -> None:
    """FK refuses a q of the wrong length or with NaN, naming q and the expected shape."""
    table = dhkin.load("ur5").table
    with pytest.raises(dhkin.InputError, match=r"q: expected shape \(6,\) or \(N, 6\), got \(5,\)"):
        table.fk(np.zeros(5))
    with pytest.raises(dhkin.InputError, match="q: expected finite joint values"):
        table.fk(np.array([0, 0, np.nan, 0, 0, 0]))


def test_random_q_and_in_limits() -> None:
    """random_q stays within the limits; in_limits rejects values just outside them."""
    table = dhkin.load("abb_irb1200_7_70").table
    q = table.random_q(2000, np.random.default_rng(7))
    assert q.shape == (2000, 6) and np.all(table.in_limits(q))
    outside = table.upper + 1e-9
    assert not table.in_limits(outside)
    assert table.in_limits(outside, tolerance=1e-8)


# --------------------------------------------------------------------------------------------
# Prismatic rows


def test_prismatic_row_units() -> None:
    """A prismatic row's theta is an angle; its offset, limits and speed are lengths (mm -> m)."""
    table = dhkin.load(DATA / "prismatic_mm.yaml").table
    turn, slide = table.joints
    assert turn.is_revolute and turn.velocity == pytest.approx(90 * DEG, abs=1e-16)
    assert turn.offset == pytest.approx(15 * DEG, abs=1e-16)
    assert not slide.is_revolute and slide.type == "prismatic"
    assert slide.theta == pytest.approx(30 * DEG, abs=1e-16)
    assert slide.d == 0.0
    assert slide.offset == pytest.approx(0.1, abs=1e-17)
    assert (slide.lower, slide.upper) == pytest.approx((0.05, 0.4), abs=1e-17)
    assert slide.velocity == pytest.approx(0.25, abs=1e-17)
    assert slide.effort == 800.0 and slide.direction == -1


def test_prismatic_joint_slides_along_its_axis_in_pinocchio() -> None:
    """d = direction * q + offset: raising q by s moves tool0 by -s (direction -1) along the
    joint's axis, z of DH frame 1 (= z of the ram link), with no rotation; own FK and Pinocchio
    agree along the stroke."""
    robot = dhkin.load(DATA / "prismatic_mm.yaml")
    reference = robot.reference()
    q_turn = 0.4
    strokes = np.linspace(0.05, 0.4, 8)
    Q = np.column_stack([np.full_like(strokes, q_turn), strokes])
    T = reference.fk(Q)
    position, rotation = pose_error(robot.fk(Q), T)
    assert position.max() <= 1e-12 and rotation.max() <= 1e-12
    axis = reference.fk(Q[0], frame="ram")[:3, 2]
    np.testing.assert_allclose(axis, robot.table.fk_frames(Q[0])[0, 1, :3, 2], atol=1e-15)
    for k in range(1, len(strokes)):
        moved = T[k, :3, 3] - T[0, :3, 3]
        np.testing.assert_allclose(moved, -(strokes[k] - strokes[0]) * axis, atol=1e-15)
        np.testing.assert_allclose(T[k, :3, :3], T[0, :3, :3], atol=1e-15)
    # At q = (0, 0.05 m): d = -0.05 + 0.1 = 0.05 m along z0, then a = 10 mm along x (theta 30 deg)
    # and the 50 mm tool along z; joint 1 (a = 25 mm, d = 300 mm, alpha -90, offset 15 deg).
    A1 = rot_z(15 * DEG) @ translation(0, 0, 0.3) @ translation(0.025, 0, 0) @ rot_x(-90 * DEG)
    A2 = rot_z(30 * DEG) @ translation(0, 0, 0.05) @ translation(0.01, 0, 0)
    expected = A1 @ A2 @ translation(0, 0, 0.05)
    np.testing.assert_allclose(reference.fk(np.array([0.0, 0.05])), expected, atol=1e-15)
