"""Analytic singularity classes and det J, cross-checked with Pinocchio (issue 5, items 1 and 2).

The oracle is Pinocchio on the URDF generated through xacro: its Jacobian (determinant, singular
values) and its frame placements (the URDF frame of joint k's child link sits on axis k with z
along it), never dhkin's own FK.

Tolerances. On uniform samples det J agrees to 1e-9 relative (the issue's figure). Near a
singularity Pinocchio's own det (an LU of an ill-conditioned J) loses relative accuracy: a
rounding error delta of the entries moves det J by about delta times the cofactor scale
sigma_1 ... sigma_5, so there the bound is 1e-9 |det| + 1e-13 sigma_1 ... sigma_5; a wrong
factor still errs by about |det| = sigma_1 ... sigma_6, far above it while sigma_6 >> 1e-13.
"""

from __future__ import annotations

import itertools
import math
import zlib

import numpy as np
import pytest
from numpy.typing import NDArray

import dhkin
from dhkin.errors import DhkinError, FamilyError, InputError
from dhkin.singularity import (
    DEFAULT_THRESHOLDS,
    KINDS,
    MOVING_JOINT,
    Thresholds,
    singularity_model,
    singularity_report,
)

from .conftest import DATA

ANALYTIC = ["abb_irb1200_7_70", "anthropomorphic_arm", "aubo_i10", "stanford_arm", "ur10", "ur3",
            "ur5"]
MODIFIED_ABB = str(DATA / "abb_irb1200_7_70_modified.yaml")
TABLES = [*ANALYTIC, pytest.param(MODIFIED_ABB, id="abb_irb1200_7_70_modified")]
FAMILY = {"abb_irb1200_7_70": "spherical_wrist", "anthropomorphic_arm": "spherical_wrist",
          "aubo_i10": "offset_wrist", "stanford_arm": "stanford", "ur10": "offset_wrist",
          "ur3": "offset_wrist", "ur5": "offset_wrist"}
N_UNIFORM = 10_000
RELATIVE = 1e-9
COFACTOR_ROUNDING = 1e-13


def rng_for(name: str, salt: str = "") -> np.random.Generator:
    return np.random.default_rng(zlib.crc32((name + salt).encode()))


def pinocchio_det(robot: dhkin.Robot, Q: NDArray[np.float64], frame: str | None = None,
                  reference: str = "local_world_aligned") -> NDArray[np.float64]:
    ref = robot.reference()
    return np.linalg.det(ref.jacobians(Q, frame, reference))


def cofactor_scale(robot: dhkin.Robot, Q: NDArray[np.float64]) -> NDArray[np.float64]:
    """sigma_1 ... sigma_5 of Pinocchio's Jacobian at each q."""
    ref = robot.reference()
    return np.prod(np.linalg.svd(ref.jacobians(Q), compute_uv=False)[:, :5], axis=1)


def exit_rate(robot: dhkin.Robot, q: NDArray[np.float64], kind: str) -> float:
    """How fast the kind's distance grows per unit of joint motion (m/rad or 1/rad) in the
    fastest direction, at a configuration on that singularity."""
    h = 1e-7
    probes = q + h * np.eye(robot.dof)
    return float(np.linalg.norm(singularity_model(robot).factors(probes).distance(kind) / h))


def placed(robot: dhkin.Robot, kind: str, n: int, rng: np.random.Generator,
           clearance: float = 0.02, min_rate: float = 0.0) -> NDArray[np.float64]:
    """n configurations exactly at ``kind``, at least ``clearance`` from the other kinds, whose
    distance to ``kind`` grows at least ``min_rate`` per rad (general position)."""
    model = singularity_model(robot)
    found = []
    for _ in range(50 * n):
        try:
            q = model.place(robot.table.random_q(1, rng)[0], kind)
        except InputError:
            continue
        factors = model.factors(q)
        if all(factors.distance(other)[0] >= clearance for other in model.kinds if other != kind) \
                and exit_rate(robot, q, kind) >= min_rate:
            found.append(q)
        if len(found) == n:
            return np.array(found)
    raise AssertionError(f"{robot.name}: could not place {n} configurations at {kind}")


def leave(robot: dhkin.Robot, q: NDArray[np.float64], kind: str,
          step: float) -> NDArray[np.float64]:
    """q moved by ``step`` (rad / m, Euclidean in joint space) along the gradient of the kind's
    signed factor: the direction that leaves the singularity fastest."""
    model = singularity_model(robot)
    h = 1e-6
    probes = q + h * np.eye(robot.dof)
    gradient = (model.factors(probes).signed(kind) - model.factors(q).signed(kind)[0]) / h
    return q + step * gradient / np.linalg.norm(gradient)


# --------------------------------------------------------------------------------------------
# det J against Pinocchio


@pytest.mark.parametrize("name", TABLES)
def test_determinant_matches_pinocchio_on_uniform_samples(name: str, load_robot) -> None:
    """Item 2: 10^4 random q within the limits, analytic det J = Pinocchio's to 1e-9 relative
    (the modified-DH IRB 1200 goes through the geometric form)."""
    robot = load_robot(name)
    Q = robot.table.random_q(N_UNIFORM, rng_for(robot.name))
    expected = pinocchio_det(robot, Q)
    analytic = singularity_model(robot).determinant(Q)
    relative = np.abs(analytic - expected) / np.abs(expected)
    assert relative.max() <= RELATIVE, (name, relative.max(), Q[np.argmax(relative)])


@pytest.mark.parametrize("name", TABLES)
def test_determinant_at_special_and_near_singular_configurations(name: str, load_robot) -> None:
    """Every combination of {0, +-90, 180} deg (clipped to the limits; many exactly singular)
    and configurations 1e-3 and 1e-6 from each singularity: |error| <= 1e-9 |det| + 1e-13
    sigma_1...sigma_5 (module docstring)."""
    robot = load_robot(name)
    model = singularity_model(robot)
    values = np.array([0.0, math.pi / 2, -math.pi / 2, math.pi])
    special = np.clip(np.array(list(itertools.product(values, repeat=6))), robot.lower,
                      robot.upper)
    rng = rng_for(robot.name, "near")
    near = [leave(robot, q, kind, step) for kind in model.kinds
            for q in placed(robot, kind, 20, rng) for step in (1e-3, 1e-6)]
    Q = np.vstack([special, near])
    expected = pinocchio_det(robot, Q)
    error = np.abs(model.determinant(Q) - expected)
    bound = RELATIVE * np.abs(expected) + COFACTOR_ROUNDING * cofactor_scale(robot, Q)
    assert np.all(error <= bound), (name, Q[np.argmax(error / bound)])
    assert np.sum(np.abs(expected) < 1e-12) > 100  # the special set holds singular ones


@pytest.mark.parametrize("name", ANALYTIC)
def test_determinant_is_the_same_in_every_frame_and_point(name: str, load_robot) -> None:
    """det J is the same in LOCAL, WORLD and LOCAL_WORLD_ALIGNED, at tool0, at the flange and
    at the last link's frame (other points and axes on the same body)."""
    robot = load_robot(name)
    Q = robot.table.random_q(100, rng_for(robot.name, "frames"))
    analytic = singularity_model(robot).determinant(Q)
    for frame in ("tool0", "flange", robot.table.joints[-1].link):
        for reference in ("local", "world", "local_world_aligned"):
            expected = pinocchio_det(robot, Q, frame, reference)
            relative = np.abs(analytic - expected) / np.abs(expected)
            assert relative.max() <= RELATIVE, (frame, reference, relative.max())


@pytest.mark.parametrize("name", TABLES)
def test_closed_form_equals_geometric_form_factor_by_factor(name: str, load_robot) -> None:
    """The closed forms in the DH parameters and the geometric forms from the joint axes give
    the same signed shoulder, elbow and wrist factors (not only the same product)."""
    robot = load_robot(name)
    model = singularity_model(robot)
    Q = robot.table.random_q(2000, rng_for(robot.name, "forms"))
    geometric = model.geometric_factors(Q)
    if not model.closed_form:
        assert robot.table.convention == "modified"
        closed = singularity_model(load_robot("abb_irb1200_7_70")).closed_form_factors(Q)
    else:
        closed = model.closed_form_factors(Q)
    for name_ in ("constant", "shoulder", "elbow", "wrist", "shoulder_distance"):
        np.testing.assert_allclose(getattr(closed, name_), getattr(geometric, name_),
                                   rtol=0, atol=1e-12, err_msg=name_)


@pytest.mark.parametrize("name", ["ur3", "ur5", "ur10"])
def test_known_ur_formula(name: str, load_robot) -> None:
    """The literature's UR result det J = s3 s5 a2 a3 (a2 c2 + a3 c23 + d5 s234), written here
    independently from the DH rows, against Pinocchio."""
    robot = load_robot(name)
    rows = robot.table.joints
    a2, a3, d5 = rows[1].a, rows[2].a, rows[4].d
    Q = robot.table.random_q(2000, rng_for(robot.name, "ur"))
    q2, q3, q4, q5 = Q[:, 1], Q[:, 2], Q[:, 3], Q[:, 4]
    literature = (np.sin(q3) * np.sin(q5) * a2 * a3
                  * (a2 * np.cos(q2) + a3 * np.cos(q2 + q3) + d5 * np.sin(q2 + q3 + q4)))
    expected = pinocchio_det(robot, Q)
    np.testing.assert_allclose(literature, expected, rtol=RELATIVE, atol=0)


def test_known_stanford_formula(load_robot) -> None:
    """Spong's Stanford arm: |det J| = d3^2 |s2 s5| (here with the lateral offset d2, which
    does not enter)."""
    robot = load_robot("stanford_arm")
    Q = robot.table.random_q(2000, rng_for("stanford", "spong"))
    expected = np.abs(pinocchio_det(robot, Q))
    np.testing.assert_allclose(Q[:, 2] ** 2 * np.abs(np.sin(Q[:, 1]) * np.sin(Q[:, 4])),
                               expected, rtol=RELATIVE, atol=0)


# --------------------------------------------------------------------------------------------
# Placed singularities and their neighbours


@pytest.mark.parametrize("name", ANALYTIC)
def test_placed_singularities_are_singular_for_pinocchio_and_named(name: str, load_robot) -> None:
    """Item 2: exactly at each singularity type Pinocchio's sigma_min < 1e-12 and the report
    names that kind, and only it (the others are kept >= 2 cm / 0.02 away)."""
    robot = load_robot(name)
    model = singularity_model(robot)
    expected_kinds = ("wrist", "shoulder") if name == "stanford_arm" else KINDS
    assert model.kinds == expected_kinds
    assert model.family == FAMILY[name]
    rng = rng_for(robot.name, "placed")
    for kind in model.kinds:
        for q in placed(robot, kind, 10, rng):
            report = singularity_report(robot, q)
            assert report.sigma_min < 1e-12, (kind, q, report.sigma_min)
            assert report.kinds == (kind,), (kind, q, report.kinds)
            assert report.distances[kind] < 1e-12
            assert abs(report.determinant) < 1e-12
            assert report.manipulability < 1e-12


@pytest.mark.parametrize("name", ANALYTIC)
def test_one_milliradian_away_is_not_flagged(name: str, load_robot) -> None:
    """Item 2: 1e-3 rad away from each placed singularity (along the fastest way out) nothing is
    flagged at the default thresholds, Pinocchio's sigma_min is clearly non-zero, and a
    threshold set above the distance flags it again (thresholds can be set).

    Placed in general position: the other kinds >= 2 cm / 0.02 away and the distance growing
    >= 0.2 m (or 0.2) per rad; e.g. a wrist centre 9 cm from axis 2 on the folded
    anthropomorphic arm moves only 0.09 mm per mrad, inside the 0.1 mm default threshold."""
    robot = load_robot(name)
    model = singularity_model(robot)
    rng = rng_for(robot.name, "away")
    for kind in model.kinds:
        for q in placed(robot, kind, 10, rng, min_rate=0.2):
            moved = leave(robot, q, kind, 1e-3)
            report = singularity_report(robot, moved)
            assert report.kinds == (), (kind, q, report.distances)
            assert report.distances[kind] > 2 * DEFAULT_THRESHOLDS.of(kind)
            assert report.sigma_min > 1e-6, (kind, report.sigma_min)
            wider = singularity_report(robot, moved, {kind: 2 * report.distances[kind]})
            assert wider.kinds == (kind,)


@pytest.mark.parametrize("name", ANALYTIC)
def test_distances_mean_what_the_docs_say(name: str, load_robot) -> None:
    """The distances, recomputed from Pinocchio's frame placements: the URDF frame of joint k's
    child link lies on axis k with z along it.

    wrist: |sin q5| and |z4 x z6|; shoulder: distance of the wrist point (spherical: where axes 4
    and 5 meet; offset: where 5 and 6 meet) from the plane through axis 1 parallel to axis 2;
    elbow: distance of the wrist centre (offset wrist: of axis 4) from the plane of axes 2, 3.
    """
    robot = load_robot(name)
    ref = robot.reference()
    links = [j.link for j in robot.table.joints]
    Q = robot.table.random_q(200, rng_for(robot.name, "distances"))
    factors = singularity_model(robot).factors(Q)
    for i, q in enumerate(Q):
        frames = [ref.fk(q, link) for link in links]
        o = [T[:3, 3] for T in frames]
        z = [T[:3, 2] for T in frames]
        wrist_point = o[5] if FAMILY[name] == "offset_wrist" else o[4]
        assert factors.wrist_distance[i] == pytest.approx(abs(math.sin(q[4])), abs=1e-12)
        assert factors.wrist_distance[i] == pytest.approx(np.linalg.norm(np.cross(z[3], z[5])),
                                                          abs=1e-12)
        normal = np.cross(z[0], z[1])
        shoulder = abs(np.dot(wrist_point - o[0], normal / np.linalg.norm(normal)))
        assert factors.shoulder_distance[i] == pytest.approx(shoulder, abs=1e-12)
        if FAMILY[name] == "stanford":
            assert math.isnan(factors.elbow_distance[i])
            continue
        normal = np.cross(z[1], o[2] - o[1])
        point = o[3] if FAMILY[name] == "offset_wrist" else wrist_point
        elbow = abs(np.dot(point - o[1], normal / np.linalg.norm(normal)))
        assert factors.elbow_distance[i] == pytest.approx(elbow, abs=1e-12)


def test_irb1200_shoulder_distance_is_the_wrist_centres_distance_from_axis_1(load_robot) -> None:
    """No lateral offset: the shoulder distance is the wrist centre's horizontal distance from
    axis 1 (base_link z), the wrist centre being link_5's origin in Pinocchio."""
    robot = load_robot("abb_irb1200_7_70")
    Q = robot.table.random_q(200, rng_for("irb", "axis1"))
    centres = robot.reference().fk(Q, "link_5")[:, :3, 3]
    distances = singularity_model(robot).factors(Q).shoulder_distance
    np.testing.assert_allclose(distances, np.hypot(centres[:, 0], centres[:, 1]), atol=1e-12)


# --------------------------------------------------------------------------------------------
# The report


def test_report_fields_and_text(load_robot) -> None:
    robot = load_robot("abb_irb1200_7_70")
    q = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    report = singularity_report(robot, q)
    measures = robot.reference().manipulability(q)
    assert report.kinds == ()
    assert not report.singular
    assert set(report.distances) == set(KINDS)
    assert report.distances["wrist"] == pytest.approx(math.sin(0.5), abs=1e-15)
    assert report.determinant == pytest.approx(report.determinant_pinocchio, rel=1e-9)
    assert report.factors["k"] * report.factors["shoulder"] * report.factors["elbow"] \
        * report.factors["wrist"] == pytest.approx(report.determinant, rel=1e-15)
    assert report.manipulability == pytest.approx(abs(report.determinant), rel=1e-9)
    assert report.sigma_min == measures.sigma_min
    assert report.condition == measures.condition
    np.testing.assert_array_equal(report.singular_values, measures.singular_values)
    assert (report.translational, report.rotational) == (measures.translational,
                                                         measures.rotational)
    text = str(report)
    for expected in ("singular (at or near): none", "shoulder distance", "|sin q5|",
                     "sigma_min", "Yoshikawa", "t2 = q2 - 90 deg", "W = -sin t5"):
        assert expected in text, expected


def test_report_at_a_double_singularity_names_both(load_robot) -> None:
    """UR5 at q3 = q5 = 0 is elbow- and wrist-singular at once."""
    robot = load_robot("ur5")
    report = singularity_report(robot, [0.3, -1.0, 0.0, 0.4, 0.0, 0.2])
    assert report.kinds == ("wrist", "elbow")
    assert "singular (at or near): wrist, elbow" in str(report)


def test_thresholds_validation_and_mapping() -> None:
    assert Thresholds() == DEFAULT_THRESHOLDS
    for bad in (-1.0, float("nan"), "x", True):
        with pytest.raises(InputError, match=r"thresholds\.wrist"):
            Thresholds(wrist=bad)


@pytest.mark.parametrize("bad_q", [[0.0] * 5, [0.0, 0.0, float("nan"), 0.0, 0.0, 0.0],
                                   [[0.0] * 6]])
def test_bad_q_is_a_dhkin_error_naming_the_value(bad_q, load_robot) -> None:
    with pytest.raises(InputError, match=r"q: expected 6 finite joint values"):
        singularity_report(load_robot("ur5"), bad_q)


def test_unknown_threshold_kind_is_an_error(load_robot) -> None:
    with pytest.raises(InputError, match=r"unknown kind 'knee'"):
        singularity_report(load_robot("ur5"), np.zeros(6), {"knee": 1e-3})


@pytest.mark.parametrize("name", ["planar_2r", "planar_3r"])
def test_robot_outside_the_families_gets_a_clear_error(name: str, load_robot) -> None:
    with pytest.raises(DhkinError, match="no analytic singularity family fits") as caught:
        singularity_report(load_robot(name), np.zeros(load_robot(name).dof))
    assert "manipulability(q)" in str(caught.value)
    assert f"expected 6 joints, got {load_robot(name).dof}" in str(caught.value)


def test_a_six_axis_table_outside_the_families_names_the_failed_conditions(load_robot) -> None:
    """The IRB 1200 with a5 = 1 cm: the wrist axes no longer meet, the arm is no offset wrist."""
    import dataclasses

    table = load_robot("abb_irb1200_7_70").table
    joints = list(table.joints)
    joints[4] = dataclasses.replace(joints[4], a=0.01)
    broken = dhkin.Robot(dataclasses.replace(table, joints=tuple(joints)))
    with pytest.raises(FamilyError, match=r"axes 5 and 6 meet \(distance\): 0\.01 m") as caught:
        singularity_model(broken)
    assert "axes 3 and 4 parallel" in str(caught.value)
    assert set(caught.value.value) == {"spherical_wrist", "offset_wrist", "stanford"}


@pytest.mark.parametrize("tilt, in_family", [(0.01, True), (math.radians(10.0), False)],
                         ids=["within the band", "oblique shoulder"])
def test_ik_singularity_analysis_and_maps_agree_on_the_family(tilt: float, in_family: bool,
                                                              load_robot) -> None:
    """Axis 2 tilted from perpendicular to axis 1 (alpha1 off 90 deg): 0.01 rad is within the
    family band (the IK refines on the exact chain), 10 deg is an oblique shoulder, which no
    family's closed form covers. IK, singularity analysis and maps decide alike."""
    import dataclasses

    from dhkin.maps import workspace_slice

    table = load_robot("abb_irb1200_7_70").table
    joints = list(table.joints)
    joints[0] = dataclasses.replace(joints[0], alpha=joints[0].alpha + tilt)
    robot = dhkin.Robot(dataclasses.replace(table, joints=tuple(joints)))
    assert robot.has_closed_form == in_family
    if in_family:
        assert singularity_model(robot).family == robot.ik_solver.family == "spherical_wrist"
        report = singularity_report(robot, np.full(6, 0.3))
        assert report.family == "spherical_wrist"
        return
    with pytest.raises(FamilyError):
        robot.ik_solver  # noqa: B018 (the property raises)
    with pytest.raises(FamilyError, match="no analytic singularity family"):
        singularity_model(robot)
    with pytest.raises(FamilyError):
        workspace_slice(robot, resolution=8)


def test_place_refuses_a_kind_the_family_does_not_have(load_robot) -> None:
    with pytest.raises(InputError, match="'elbow'"):
        singularity_model(load_robot("stanford_arm")).place(np.full(6, 0.5), "elbow")


def test_moving_joint_is_what_place_moves(load_robot) -> None:
    robot = load_robot("abb_irb1200_7_70")
    q = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    for kind in KINDS:
        moved = singularity_model(robot).place(q, kind)
        changed = np.flatnonzero(moved != q)
        assert changed.tolist() == [MOVING_JOINT[kind] - 1]
        assert robot.table.in_limits(moved)


# --------------------------------------------------------------------------------------------
# Command line: `dhkin singularity`


def run_cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    from dhkin.cli import main

    code = main(["singularity", *argv])
    return code, capsys.readouterr().out


def test_cli_prints_the_report_in_degrees(capsys) -> None:
    code, out = run_cli(capsys, "abb_irb1200_7_70", "0", "30", "-20", "0", "0", "0", "--deg")
    assert code == 0
    assert "singular (at or near): wrist" in out
    assert "sigma_min" in out


def test_cli_thresholds_and_json(capsys) -> None:
    import json

    code, out = run_cli(capsys, "ur5", "0.1", "-1", "1", "0.3", "0.05", "0.2", "--wrist", "0.1",
                        "--json")
    data = json.loads(out)
    assert code == 0
    assert data["kinds"] == ["wrist"]
    assert data["distances"]["wrist"] == pytest.approx(math.sin(0.05))
    assert data["thresholds"]["wrist"] == 0.1


def test_cli_wrong_number_of_values_is_a_dhkin_error(capsys) -> None:
    from dhkin.cli import main

    assert main(["singularity", "ur5", "1", "2", "3"]) == 2
    assert "q: ur5 has 6 joints, got 3 values" in capsys.readouterr().err


@pytest.mark.parametrize("name", dhkin.builtin_names())
def test_every_built_in_robot_is_in_the_same_family_for_ik_and_singularities(name: str,
                                                                              load_robot) -> None:
    """Refined tables (rounded vendor constants, a calibrated UR5e) included: one decision."""
    robot = load_robot(name)
    if not robot.has_closed_form:
        with pytest.raises(FamilyError):
            singularity_model(robot)
        return
    model = singularity_model(robot)
    assert model.family == robot.ik_solver.family
    assert model.exact_table is robot.table
