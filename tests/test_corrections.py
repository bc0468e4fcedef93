"""Per-joint corrections (DESIGN.md, "Corrections"), the table writer and the correction fit.

A correction C_i = Trans(xyz) Rz(y) Ry(p) Rx(r) follows row i's DH transform in both conventions.
The oracle is Pinocchio on the URDF generated through xacro (``Robot(table).reference()``):

* random corrected tables (both conventions, prismatic joints, joints without a correction): own
  FK and every frame equal Pinocchio to 1e-12, and differ from the nominal table's;
* ``table_to_yaml`` writes a file that reads back to the same table (FK to 1e-15);
* ``fit_corrections`` recovers, from a nominal table and a URDF, a table whose FK equals the
  URDF's to 1e-12: for URDFs generated from tables with known corrections, and for the vendor
  URDFs of the built-in robots ur5e, ur5e_calibrated, tm5_900 and kinova_gen3_6dof;
* the IK of a corrected table is exact on its URDF.
"""

from __future__ import annotations

import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import dhkin
from dhkin.compare import compare_with_urdf
from dhkin.dh import DHTable
from dhkin.fit import fit_corrections, largest_correction, read_chain, structural_relations
from dhkin.reference import Reference
from dhkin.table_file import exact_rpy, load_table, parse_table, table_to_yaml, write_table
from dhkin.transforms import invert, pose_error, rot_x, rot_y, rot_z, translation
from dhkin.validators import load_in_pinocchio, load_in_yourdfpy, run_check_urdf
from dhkin.vendors import VENDOR_REFERENCES

from .conftest import DATA, PER_ROBOT_BUILTINS, REFERENCE_URDFS, REPO

TOLERANCE = 1e-12
N_Q = 1000
N_TABLES = 24
FITTED_ROBOTS = ["ur5e_calibrated", "tm5_900", "kinova_gen3_6dof"]
NEW_ROBOTS = ["ur5e", *FITTED_ROBOTS]


# --------------------------------------------------------------------------------------------
# Random corrected tables


def random_table_data(seed: int, xyz_scale: float = 5e-3, rpy_scale: float = 0.05
                      ) -> dict[str, Any]:
    """A random 6-joint table (as parsed YAML, m and rad) with random corrections.

    Even seeds: standard convention, odd: modified. Every third table has a prismatic joint;
    joint ``seed % 6`` has no correction (so tables mix corrected and plain rows)."""
    rng = np.random.default_rng(1000 + seed)
    prismatic = seed % 6 if seed % 3 == 0 else None
    joints = []
    for i in range(6):
        revolute = i != prismatic
        twist = float(rng.choice([0.0, math.pi / 2, -math.pi / 2, math.pi]))
        if rng.random() < 0.3:
            twist += float(rng.normal(0.0, 0.3))
        entry: dict[str, Any] = {
            "name": f"joint_{i + 1}", "a": float(rng.uniform(-0.4, 0.4)), "alpha": twist,
            "direction": int(rng.choice([-1, 1])),
        }
        if revolute:
            entry.update(d=float(rng.uniform(-0.3, 0.3)), offset=float(rng.uniform(-3, 3)),
                         lower=-3.0, upper=3.0)
        else:
            entry.update(type="prismatic", theta=float(rng.uniform(-3, 3)),
                         offset=float(rng.uniform(-0.1, 0.1)), lower=0.0, upper=0.5)
        if i != seed % 6:
            entry["correction"] = {"xyz": rng.normal(0.0, xyz_scale, 3).tolist(),
                                   "rpy": rng.normal(0.0, rpy_scale, 3).tolist()}
        joints.append(entry)

    def frame() -> dict[str, list[float]]:
        return {"xyz": rng.uniform(-0.2, 0.2, 3).tolist(), "rpy": rng.uniform(-3, 3, 3).tolist()}

    return {"name": f"random_{seed}", "convention": "standard" if seed % 2 == 0 else "modified",
            "units": {"length": "m", "angle": "rad"}, "base": frame(), "tool": frame(),
            "flange": frame(), "joints": joints}


def random_table(seed: int, xyz_scale: float = 5e-3, rpy_scale: float = 0.05) -> DHTable:
    return parse_table(random_table_data(seed, xyz_scale, rpy_scale), source=f"random_{seed}")


SEEDS = list(range(N_TABLES))


def sample_q(table: DHTable, n: int = N_Q, seed: int = 0) -> np.ndarray:
    return table.random_q(n, np.random.default_rng(seed))


def test_random_tables_cover_both_conventions_and_prismatic_joints() -> None:
    tables = [random_table(seed) for seed in SEEDS]
    assert len(tables) >= 20
    assert {t.convention for t in tables} == {"standard", "modified"}
    prismatic = [t for t in tables if any(not j.is_revolute for j in t.joints)]
    assert {t.convention for t in prismatic} == {"standard", "modified"}
    assert all(t.corrected and sum(j.has_correction for j in t.joints) == 5 for t in tables)


@pytest.mark.parametrize("seed", SEEDS)
def test_own_fk_equals_pinocchio_and_differs_from_nominal(seed: int) -> None:
    """Own FK of a corrected table equals Pinocchio on its generated URDF (xacro) to 1e-12 on
    1000 random q; the nominal table's FK is far from it (the corrections are not ignored)."""
    table = random_table(seed)
    robot = dhkin.Robot(table)
    q = sample_q(table, seed=seed)
    reference = robot.reference().fk(q)
    position, rotation = pose_error(robot.fk(q), reference)
    assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE
    nominal_position, nominal_rotation = pose_error(table.nominal().fk(q), reference)
    assert min(nominal_position.max(), nominal_rotation.max()) > 1e-3


def explicit_row(convention: str, joint: dhkin.Joint, q: float) -> np.ndarray:
    """A_i @ C_i written out from the DESIGN.md formulas, independently of dhkin.dh."""
    value = joint.direction * q + joint.offset
    theta, d = (value, joint.d) if joint.is_revolute else (joint.theta, value)
    r, p, y = joint.correction[3:]
    C = translation(*joint.correction[:3]) @ rot_z(y) @ rot_y(p) @ rot_x(r)
    if convention == "standard":
        A = rot_z(theta) @ translation(0, 0, d) @ translation(joint.a, 0, 0) @ rot_x(joint.alpha)
    else:
        A = rot_x(joint.alpha) @ translation(joint.a, 0, 0) @ rot_z(theta) @ translation(0, 0, d)
    return A @ C


@pytest.mark.parametrize("seed", SEEDS[:6])
def test_fk_is_the_product_of_rows_and_corrections(seed: int) -> None:
    """fk = base A_1 C_1 ... A_n C_n tool and fk_frames / link_transforms follow it."""
    table = random_table(seed)
    for q in sample_q(table, 20, seed):
        T = table.base.copy()
        frames = [T]
        for joint, value in zip(table.joints, q, strict=True):
            T = T @ explicit_row(table.convention, joint, value)
            frames.append(T)
        np.testing.assert_allclose(table.fk(q), T @ table.tool, rtol=0, atol=1e-14)
        np.testing.assert_allclose(table.fk_frames(q)[0], np.array(frames), rtol=0, atol=1e-14)


@pytest.mark.parametrize("seed", SEEDS[:8])
def test_every_generated_frame_follows_the_exact_chain(seed: int) -> None:
    """base, link_i, flange and tool0 of the generated URDF: standard link_i = F_{i-1} turned by
    theta_i (shifted by d_i), modified link_i = F_{i-1} A_i (before C_i); flange = F_n flange,
    tool0 = F_n tool, with F_i = base A_1 C_1 ... A_i C_i."""
    table = random_table(seed)
    robot = dhkin.Robot(table)
    reference = robot.reference()
    for q in sample_q(table, 30, seed):
        F = table.fk_frames(q)[0]
        theta, d = table.dh_parameters(q[None, :])
        expected = {"base": table.base, "flange": F[-1] @ table.flange,
                    "tool0": F[-1] @ table.tool}
        for i, joint in enumerate(table.joints):
            if table.convention == "modified":
                expected[joint.link] = F[i + 1] @ invert(joint.correction_matrix)
            else:
                shift = 0.0 if joint.is_revolute else d[0, i]
                expected[joint.link] = F[i] @ rot_z(theta[0, i]) @ translation(0, 0, shift)
        for name, T in expected.items():
            np.testing.assert_allclose(reference.fk(q, frame=name), T, rtol=0, atol=1e-13,
                                       err_msg=name)


@pytest.mark.parametrize("seed", [0, 3, 6, 9])
def test_generated_urdf_with_corrections_passes_the_validators(seed: int, tmp_path: Path) -> None:
    """check_urdf, Pinocchio and yourdfpy accept the URDF of a corrected table, and its comments
    name the corrections."""
    robot = dhkin.Robot(random_table(seed))
    path = tmp_path / f"{robot.name}.urdf"
    path.write_text(robot.urdf(), encoding="utf-8")
    for verdict in (run_check_urdf(path), load_in_pinocchio(robot.urdf()), load_in_yourdfpy(path)):
        assert verdict.ok, (verdict.validator, verdict.detail)
    assert robot.generated().macro.count("correction xyz=(") == 5


@pytest.mark.parametrize("tilt", [0.0, 1e-16, 1e-14, 1e-13, 1e-12, 1e-10, 3.3e-7])
def test_origins_near_gimbal_lock_are_written_exactly(tilt: float) -> None:
    """A correction that puts a joint origin's pitch within 1e-12 of 90 deg (where the plain rpy
    conversion snaps the pitch and loses up to 1e-12) still gives a URDF equal to the table's own
    FK to 1e-14, and exact_rpy rebuilds such rotations to 4e-15."""
    data = random_table_data(0)
    data["joints"][0]["alpha"] = 0.0
    data["joints"][1].update(alpha=0.0, offset=0.0)
    data["joints"][0]["correction"] = {"rpy": [0.3, math.pi / 2 - tilt, 0.0]}
    table = parse_table(data)
    q = sample_q(table, 200, seed=3)
    np.testing.assert_allclose(dhkin.Robot(table).reference().fk(q), table.fk(q), rtol=0,
                               atol=1e-14)
    for k in range(50):
        rng = np.random.default_rng(k)
        M = rot_z(rng.uniform(-3, 3)) @ rot_y(-math.pi / 2 + tilt) @ rot_x(rng.uniform(-3, 3))
        rebuilt = rot_z(exact_rpy(M)[2]) @ rot_y(exact_rpy(M)[1]) @ rot_x(exact_rpy(M)[0])
        assert np.abs(rebuilt - M).max() <= 4e-15


def test_plain_tables_have_no_correction_comment() -> None:
    """Tables without corrections generate what they always did (no correction in comments)."""
    for name in ("ur5", "stanford_arm", "ur5e"):
        assert "correction" not in dhkin.load(name).generated().macro


# --------------------------------------------------------------------------------------------
# The data model


def test_correction_fields_and_nominal() -> None:
    """Joint.correction (m, rad), correction_matrix, has_correction; DHTable.corrected and
    nominal(), which drops every correction and keeps everything else."""
    data = random_table_data(0)
    data["units"] = {"length": "mm", "angle": "deg"}
    data["joints"][1]["correction"] = {"xyz": [1, -2, 3], "rpy": [10, -20, 30]}
    data["joints"][2]["correction"] = {"rpy": [0, 0, 5]}
    data["joints"][3]["correction"] = {}
    data["joints"][4]["correction"] = {"xyz": [0, 0, 0]}
    table = parse_table(data)
    second = table.joints[1]
    assert second.correction == pytest.approx((1e-3, -2e-3, 3e-3, math.radians(10),
                                               math.radians(-20), math.radians(30)), abs=1e-16)
    expected = (translation(1e-3, -2e-3, 3e-3) @ rot_z(math.radians(30))
                @ rot_y(math.radians(-20)) @ rot_x(math.radians(10)))
    np.testing.assert_allclose(second.correction_matrix, expected, rtol=0, atol=1e-16)
    assert table.joints[2].correction[:5] == (0.0,) * 5 and table.joints[2].has_correction
    assert not table.joints[3].has_correction and not table.joints[4].has_correction
    np.testing.assert_array_equal(table.joints[3].correction_matrix, np.eye(4))
    assert table.corrected
    nominal = table.nominal()
    assert not nominal.corrected and all(j.correction == (0.0,) * 6 for j in nominal.joints)
    assert [replace(j, correction=(0.0,) * 6) for j in table.joints] == list(nominal.joints)
    for name in ("base", "tool", "flange"):
        np.testing.assert_array_equal(getattr(nominal, name), getattr(table, name))
    assert not dhkin.load("ur5").table.corrected
    assert dhkin.load("ur5").table.nominal().joints == dhkin.load("ur5").table.joints


BAD_CORRECTIONS = [
    ([0, 0, 0], "joints[2].correction", "expected a mapping {xyz: [x, y, z], rpy: [r, p, y]}"),
    # (None: `correction:` left empty means no correction, like every optional key left empty)
    ("0 0 0", "joints[2].correction", "expected a mapping"),
    ({"rot": [0, 0, 1]}, "joints[2].correction.rot", "unknown key; expected one of ['xyz', 'rpy']"),
    ({"xyz": [1, 2]}, "joints[2].correction.xyz", "expected a list of 3 numbers, got [1, 2]"),
    ({"xyz": [1, 2, 3, 4]}, "joints[2].correction.xyz", "expected a list of 3 numbers"),
    ({"xyz": "0 0 0"}, "joints[2].correction.xyz", "expected a list of 3 numbers, got '0 0 0'"),
    ({"rpy": [0, "x", 0]}, "joints[2].correction.rpy[1]", "expected a finite number, got 'x'"),
    ({"rpy": [0, 0, True]}, "joints[2].correction.rpy[2]", "expected a finite number, got True"),
    ({"xyz": [math.inf, 0, 0]}, "joints[2].correction.xyz[0]", "expected a finite number, got inf"),
    ({"rpy": [0, 7, 0]}, "joints[2].correction.rpy[1]",
     "expected an angle within +-360 deg (+-2pi rad), got 7 rad; are units.angle right?"),
]


@pytest.mark.parametrize(("correction", "field", "expected"), BAD_CORRECTIONS,
                         ids=[f"{c[1]}-{k}" for k, c in enumerate(BAD_CORRECTIONS)])
def test_bad_correction_raises_dherror_naming_the_field(correction: Any, field: str,
                                                       expected: str) -> None:
    data = random_table_data(1)
    data["joints"][2]["correction"] = correction
    with pytest.raises(dhkin.DHError) as info:
        parse_table(data, source="my_table")
    assert str(info.value).startswith(f"my_table: {field}: "), str(info.value)
    assert expected in str(info.value)


# --------------------------------------------------------------------------------------------
# Writing tables


def assert_same_table(original: DHTable, read_back: DHTable, tolerance: float) -> None:
    q = original.random_q(N_Q, np.random.default_rng(5))
    position, rotation = pose_error(original.fk(q), read_back.fk(q))
    assert position.max() <= tolerance and rotation.max() <= tolerance
    for name in ("base", "tool", "flange"):
        np.testing.assert_allclose(getattr(read_back, name), getattr(original, name), rtol=0,
                                   atol=tolerance)
    assert (read_back.name, read_back.convention, read_back.description, read_back.source) == (
        original.name, original.convention, original.description, original.source)


@pytest.mark.parametrize("name", PER_ROBOT_BUILTINS)  # a sample of the package arms
def test_builtin_tables_round_trip_through_the_writer(name: str, tmp_path: Path) -> None:
    """In m/rad every joint value and correction reads back bit for bit, the FK to 1e-15; in
    mm/deg to 1e-12."""
    table = dhkin.load(name).table
    path = write_table(table, tmp_path / f"{name}.yaml")
    read_back = load_table(path)
    assert read_back.joints == table.joints
    assert_same_table(table, read_back, 1e-15)
    other = parse_table(yaml.safe_load(table_to_yaml(table, {"length": "mm", "angle": "deg"})))
    assert_same_table(table, other, 1e-12)


@pytest.mark.parametrize("seed", SEEDS)
def test_corrected_tables_round_trip_through_the_writer(seed: int) -> None:
    table = random_table(seed)
    text = table_to_yaml(table)
    read_back = parse_table(yaml.safe_load(text))
    assert read_back.joints == table.joints
    assert text.count("correction:") == 5
    assert_same_table(table, read_back, 1e-15)


def test_writer_quotes_what_yaml_would_misread() -> None:
    """Names and texts YAML would read as something else (yes, null, 1e3, '#', ': ') survive."""
    data = random_table_data(2)
    data.update(name="yes", description="a: b # not a comment", source="'quoted' \"twice\"\nnext")
    data["joints"][0]["name"], data["joints"][1]["link"] = "null", "on"
    table = parse_table(data)
    read_back = parse_table(yaml.safe_load(table_to_yaml(table)))
    assert read_back.joints == table.joints
    assert_same_table(table, read_back, 1e-15)


def test_writer_refuses_unknown_units() -> None:
    with pytest.raises(dhkin.DHError, match="units: expected"):
        table_to_yaml(dhkin.load("ur5").table, {"length": "cm", "angle": "deg"})


# --------------------------------------------------------------------------------------------
# Fitting corrections to a URDF


@pytest.mark.parametrize("seed", SEEDS)
def test_fit_recovers_a_table_with_known_small_corrections(seed: int) -> None:
    """The nominal table fitted to the URDF of the table with calibration-sized corrections
    (0.5 mm, 1 mrad) reproduces that URDF to 1e-12 on 1000 random q, with corrections of the
    same size."""
    table = random_table(seed, xyz_scale=5e-4, rpy_scale=1e-3)
    robot = dhkin.Robot(table)
    fitted = fit_corrections(table.nominal(), robot.urdf(), "base_link", "tool0")
    q = sample_q(table, seed=seed + 100)
    position, rotation = pose_error(fitted.fk(q), robot.reference().fk(q))
    assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE
    for mine, nominal in zip(fitted.joints, table.nominal().joints, strict=True):
        assert replace(mine, correction=nominal.correction) == nominal
    assert not fitted.joints[-1].has_correction
    shift, turn = largest_correction(fitted)
    assert shift < 0.01 and turn < 0.02


@pytest.mark.parametrize("seed", SEEDS[:8])
def test_fit_is_exact_for_large_corrections_too(seed: int) -> None:
    """With the size limits lifted, 5 mm / 0.05 rad corrections are matched exactly as well, and
    the fitted table's own generated URDF agrees (through xacro and Pinocchio)."""
    table = random_table(seed)
    robot = dhkin.Robot(table)
    fitted = fit_corrections(table.nominal(), robot.urdf(), "base_link", "tool0",
                             max_translation=1.0, max_rotation=1.0)
    q = sample_q(table, seed=seed + 200)
    target = robot.reference().fk(q)
    for T in (fitted.fk(q), dhkin.Robot(fitted).reference().fk(q)):
        position, rotation = pose_error(T, target)
        assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70", "stanford_arm", "aubo_i10"])
def test_fit_of_a_table_to_its_own_urdf_finds_no_correction(name: str) -> None:
    table = dhkin.load(name).table
    fitted = fit_corrections(table, dhkin.load(name).urdf(), "base_link", "tool0")
    assert largest_correction(fitted) <= (1e-15, 1e-15)
    np.testing.assert_allclose(fitted.base, table.base, rtol=0, atol=1e-15)
    np.testing.assert_allclose(fitted.tool, table.tool, rtol=0, atol=1e-15)


def test_fit_keeps_the_flange_to_tool0_relation() -> None:
    table = random_table(4, xyz_scale=5e-4, rpy_scale=1e-3)
    fitted = fit_corrections(table.nominal(), dhkin.Robot(table).urdf(), "base_link", "tool0")
    np.testing.assert_allclose(invert(fitted.flange) @ fitted.tool,
                               invert(table.flange) @ table.tool, rtol=0, atol=1e-14)


def test_fit_refuses_a_wrong_nominal_table() -> None:
    """The UR5 (CB3) table is not a UR5e: d1 is 73 mm short, and the error says where."""
    with pytest.raises(dhkin.DHError) as info:
        fit_corrections(dhkin.load("ur5").table, REFERENCE_URDFS / "ur5e_calibrated.urdf",
                        "base_link", "tool0")
    message = str(info.value)
    assert "joints[0].correction (shoulder_pan_joint)" in message, message
    assert "73.59 mm" in message and "expected at most 10 mm and 0.1 rad" in message


def test_fit_refuses_a_chain_that_does_not_match() -> None:
    ur5 = REFERENCE_URDFS / "ur5.urdf"
    with pytest.raises(dhkin.DHError, match=r"the table has 2 joints, the chain base_link -> "
                                            r"tool0 of .*ur5\.urdf has 6"):
        fit_corrections(dhkin.load("planar_2r").table, ur5, "base_link", "tool0")
    with pytest.raises(dhkin.DHError, match=r"joints\[2\] \(joint_3\) is prismatic, but joint "
                                            r"'elbow_joint' of .*ur5\.urdf is revolute"):
        fit_corrections(dhkin.load("stanford_arm").table, ur5, "base_link", "tool0")
    with pytest.raises(dhkin.URDFError, match="no frame named 'tcp'"):
        fit_corrections(dhkin.load("ur5").table, ur5, "base_link", "tcp")


# --------------------------------------------------------------------------------------------
# The new built-in robots against their vendor URDFs


def vendor(name: str) -> tuple[Path, Reference]:
    entry = VENDOR_REFERENCES[name]
    path = REFERENCE_URDFS / entry.file
    return path, Reference(path.read_text(encoding="utf-8"), tip=entry.tip, base=entry.base,
                           source=str(path))


@pytest.mark.parametrize("name", NEW_ROBOTS)
def test_new_builtin_matches_its_vendor_urdf(name: str) -> None:
    """Own FK and Pinocchio on the generated URDF equal the vendor's base -> tip FK on 2000
    random q: fitted tables to 1e-12, ur5e (the vendor rounds pi/2 to 1.570796327) to 1e-9."""
    robot = dhkin.load(name)
    _, other = vendor(name)
    q = np.vstack([np.zeros(6), sample_q(robot.table, 2000, seed=7)])
    tolerance = TOLERANCE if name in FITTED_ROBOTS else 1e-9
    assert robot.table.corrected == (name in FITTED_ROBOTS)
    for T in (robot.fk(q), robot.reference().fk(q)):
        position, rotation = pose_error(T, other.fk(q))
        assert position.max() <= tolerance and rotation.max() <= tolerance, name
    assert other.joint_names == robot.table.joint_names


@pytest.mark.parametrize("name", NEW_ROBOTS)
def test_dhkin_compare_passes_for_new_builtin(name: str) -> None:
    path, _ = vendor(name)
    entry = VENDOR_REFERENCES[name]
    report = compare_with_urdf(dhkin.load(name), path, base_frame=entry.base, tip=entry.tip,
                               n=1000)
    assert report.ok, report.summary()


@pytest.mark.parametrize("name", FITTED_ROBOTS)
def test_nominal_table_alone_misses_the_vendor_urdf(name: str) -> None:
    """Without its corrections each fitted robot is off its vendor URDF by more than 1e-9 (so the
    corrections are needed), and by less than 1 cm / 0.01 rad (so the nominal table is right)."""
    robot = dhkin.load(name)
    _, other = vendor(name)
    q = sample_q(robot.table, 500, seed=8)
    position, rotation = pose_error(robot.table.nominal().fk(q), other.fk(q))
    assert max(position.max(), rotation.max()) > 1e-9
    assert position.max() < 0.01 and rotation.max() < 0.01


def test_ur5e_fit_is_the_vendor_rounding() -> None:
    """Fitting the exact UR5e table to UR's file gives corrections of the size of its rounded
    pi/2 (|1.570796327 - pi/2| = 2.05e-10 rad) and an FK within 1e-12 of the file."""
    path, other = vendor("ur5e")
    fitted = fit_corrections(dhkin.load("ur5e").table, path, "base_link", "tool0")
    shift, turn = largest_correction(fitted)
    assert turn == pytest.approx(abs(1.570796327 - math.pi / 2), rel=1e-3) and shift < 1e-15
    q = sample_q(fitted, seed=9)
    position, rotation = pose_error(fitted.fk(q), other.fk(q))
    assert position.max() <= TOLERANCE and rotation.max() <= TOLERANCE


def test_committed_fitted_tables_are_up_to_date() -> None:
    """scripts/fit_tables.py --check: a fresh fit of each nominal table equals the committed
    robots/<name>.yaml (FK and corrections to 1e-14)."""
    result = subprocess.run([sys.executable, str(REPO / "scripts" / "fit_tables.py"), "--check",
                             "--reference-dir", str(REFERENCE_URDFS)],
                            capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 fitted table(s) stale" in result.stdout


@pytest.mark.parametrize(("name", "nominal"), [
    ("ur5e_calibrated", REPO / "robots" / "ur5e.yaml"),
    ("tm5_900", DATA / "tm5_900_nominal.yaml"),
    ("kinova_gen3_6dof", DATA / "kinova_gen3_6dof_nominal.yaml"),
])
def test_fitted_robot_is_its_nominal_table_plus_corrections(name: str, nominal: Path) -> None:
    """Same DH values, limits and names as the nominal table; only corrections, base and tool
    differ (and the base and tool only slightly)."""
    fitted, plain = dhkin.load(name).table, load_table(nominal)
    assert [replace(j, correction=(0.0,) * 6) for j in fitted.joints] == list(plain.joints)
    np.testing.assert_allclose(fitted.base, plain.base, rtol=0, atol=1e-5)
    np.testing.assert_allclose(fitted.tool, plain.tool, rtol=0, atol=1e-4)


def test_structural_deviations_of_the_vendor_chains() -> None:
    """The measured structure of each exact chain: Techman's 1.570796 tilts its wrist axes by
    pi/2 - 1.570796 = 3.27e-7 rad; Kinova's axes 4 and 6 miss each other by 2 x 0.17505 mm
    and its 3.1416 tilts the axes by up to 1.1e-5 rad; the calibrated UR5e's axes are up to
    2.0e-3 rad from parallel/perpendicular and axes 1 and 2 are 88 um apart."""

    def worst(name: str, kind: str) -> float:
        entry = VENDOR_REFERENCES[name]
        nominal = dhkin.load(name).table.nominal()
        chain = read_chain(REFERENCE_URDFS / entry.file, entry.base, entry.tip)
        relations = structural_relations(nominal, chain)
        assert relations == structural_relations(nominal, dhkin.load(name).table) or all(
            math.isclose(a.deviation, b.deviation, rel_tol=1e-6, abs_tol=1e-15)
            for a, b in zip(relations, structural_relations(nominal, dhkin.load(name).table),
                            strict=True))
        return max(r.deviation for r in relations
                   if r.kind == kind or (kind == "angle" and r.kind != "intersecting"))

    assert worst("tm5_900", "angle") == pytest.approx(math.pi / 2 - 1.570796, rel=1e-6)
    assert worst("tm5_900", "intersecting") < 1e-15
    assert worst("kinova_gen3_6dof", "intersecting") == pytest.approx(2 * 0.00017505, rel=2e-3)
    assert worst("kinova_gen3_6dof", "angle") == pytest.approx(
        (3.1416 - math.pi) + (1.5708 - math.pi / 2), rel=1e-3)
    assert worst("ur5e_calibrated", "angle") == pytest.approx(2.007e-3, rel=1e-3)
    assert worst("ur5e_calibrated", "intersecting") == pytest.approx(8.798e-5, rel=1e-3)


# --------------------------------------------------------------------------------------------
# IK of corrected tables


@pytest.mark.parametrize("name", FITTED_ROBOTS)
def test_corrected_robot_ik_is_exact_on_the_urdf(name: str) -> None:
    """robot.ik of a corrected table (closed form refined on the exact chain, or the numerical
    fallback) returns solutions that Pinocchio verifies on the generated URDF to 1e-9, among
    them the q the pose came from."""
    robot = dhkin.load(name)
    q = np.clip(np.array([0.3, -0.4, 1.1, 0.2, 0.8, -0.5]), robot.lower, robot.upper)
    T = robot.reference().fk(q)
    solutions = robot.ik(T, q_seed=q + 0.05)
    assert len(solutions) >= 1
    position, rotation = pose_error(robot.reference().fk(solutions.q),
                                    np.broadcast_to(T, (len(solutions), 4, 4)))
    assert position.max() <= 1e-9 and rotation.max() <= 1e-9
    assert np.abs(solutions.nearest(q) - q).max() <= 1e-6
