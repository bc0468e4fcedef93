"""Closed-form IK of the Stanford arm class (R-R-P arm + spherical wrist), against the oracle.

Targets are made with Pinocchio on the generated URDF and every solution is checked with it.
Tolerances and the answer's form (branches, copies nearest the seed, the seeded wrist) as in
test_ik_spherical_wrist.py: pose 1e-10 m / rad (1e-9 at singularities and on refined tables),
completeness 1e-6 in joint space (rad, and m for the slide).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import dhkin
from dhkin.errors import FamilyError
from dhkin.ik import WRIST
from dhkin.ik.family import family_problems, fit_family
from dhkin.transforms import pose_error

from .test_ik_spherical_wrist import (
    COMPLETENESS_TOLERANCE,
    IK_TOLERANCE,
    _nearest_point,
    check_branch_sources,
    check_continuity,
    check_copies_of_principal,
    check_distinct,
    check_nearest_copies,
    check_singular_set,
    check_wrist_flags,
    completeness_gap,
    jacobian_axes,
    oracle_max_errors,
    principal_branches,
    returned_rows,
)

RANDOM_POSES = 20_000
SINGULAR_POSES = 2_000

#: Stanford-class variants: modified DH, a slide line off axis 2 (a = 0.05 m), the slide turned
#: the negative way with a stroke offset, other joint offsets and directions, base and tool.
STANFORD_MODIFIED = {
    "name": "stanford_modified", "convention": "modified", "units": {"length": "m", "angle": "deg"},
    "base": {"xyz": [0.2, -0.1, 0.05], "rpy": [0, 10, 35]},
    "tool": {"xyz": [0.0, 0.02, 0.07], "rpy": [20, 0, -30]},
    "joints": [
        {"a": 0, "alpha": 0, "d": 0.4, "offset": 15, "lower": -180, "upper": 180},
        {"a": 0, "alpha": -90, "d": 0.15, "direction": -1, "offset": -20, "lower": -180,
         "upper": 180},
        {"type": "prismatic", "a": 0.05, "alpha": 90, "theta": 0, "offset": 0.1, "direction": -1,
         "lower": -0.9, "upper": 0.6},
        {"a": 0, "alpha": 0, "d": 0, "offset": 40, "lower": -180, "upper": 180},
        {"a": 0, "alpha": -90, "d": 0, "direction": -1, "lower": -180, "upper": 180},
        {"a": 0, "alpha": 90, "d": 0.1, "offset": -75, "lower": -180, "upper": 180}]}


def _variant(alpha3: float) -> dhkin.DHTable:
    data = {**STANFORD_MODIFIED, "joints": [dict(j) for j in STANFORD_MODIFIED["joints"]]}
    data["joints"][2]["alpha"] = alpha3
    return dhkin.parse_table(data)


def test_stanford_arm_fits_its_family_only(load_robot):
    robot = load_robot("stanford_arm")
    problems = family_problems(robot.table)
    assert problems["stanford"] == []
    assert problems["spherical_wrist"] == ["joint 3 (joint_3) is prismatic, expected revolute"]
    assert problems["offset_wrist"] == ["joint 3 (joint_3) is prismatic, expected revolute"]
    fit = fit_family(robot.table)
    assert fit.family == "stanford" and not fit.refine
    assert robot.ik_solver.family == "stanford"
    assert robot.ik_solver.branch_labels[0] == {"shoulder": "lefty", "slide": "forward",
                                                "wrist": "noflip"}
    assert family_problems(load_robot("abb_irb1200_7_70").table)["stanford"] == [
        "joint 3 (joint_3) is revolute, expected prismatic"]
    with pytest.raises(FamilyError, match=re.escape(
            "stanford: joint 3 (joint_3) is revolute, expected prismatic")):
        fit_family(load_robot("abb_irb1200_7_70").table, family="stanford")


def test_slide_not_perpendicular_to_axis_2_is_named():
    """alpha3 = 60 deg turns the slide about the common normal of axis 2 and the slide, so |cos|
    between them is |cos 60 deg| = 0.5: named on the ideal model (too far to snap, so it must
    hold exactly) and on the exact chain (beyond the band)."""
    table = _variant(60)
    problems = family_problems(table)["stanford"]
    assert ("ideal model: slide of joint 3 perpendicular to axis 2 (|cos|): 0.5, expected <= "
            "1e-09") in problems, problems
    assert ("beyond the band: slide of joint 3 perpendicular to axis 2 (|cos|): 0.5, expected "
            "<= 0.02") in problems, problems
    with pytest.raises(FamilyError, match=re.escape(f"stanford: {problems[0]}")):
        fit_family(table, family="stanford")
    assert not dhkin.Robot(table).has_closed_form


def test_the_band_edges_of_the_slide():
    """The slide 0.019 rad off perpendicular to axis 2 is inside the band: the family fits with
    refinement on the exact chain, and every solution of 1000 random poses (targets by
    Pinocchio) is exact to the IK tolerance; 0.021 rad off is outside: no family."""
    inside = _variant(90 + np.degrees(0.019))
    assert family_problems(inside)["stanford"] == []
    fit = fit_family(inside)
    assert fit.family == "stanford" and fit.refine
    robot = dhkin.Robot(inside)
    rng = np.random.default_rng(324)
    q = inside.random_q(1000, rng)
    T = robot.reference().fk(q)
    every = robot.ik_batch_detailed(T, copies=True)
    values, targets, _ = returned_rows(every.q, every.valid, T)
    worst = oracle_max_errors(robot, values, targets)
    gap = completeness_gap(every.q, every.valid, q)
    print(f"\nstanford variant, slide 0.019 rad off: max error {worst[0]:.2e} m / {worst[1]:.2e} "
          f"rad, original q missing for {(gap > COMPLETENESS_TOLERANCE).sum()} of {len(q)}, "
          f"dropped branches {every.dropped.sum()}")
    assert max(worst) <= IK_TOLERANCE
    assert every.valid.any(axis=1).all()
    outside = _variant(90 + np.degrees(0.021))
    message = ("beyond the band: slide of joint 3 perpendicular to axis 2 (|cos|): 0.021, "
               "expected <= 0.02")
    assert message in family_problems(outside)["stanford"]
    with pytest.raises(FamilyError, match=re.escape(message)):
        fit_family(outside)


def test_random_poses_exact_and_complete(load_robot):
    """Spong's frames, stroke 0.3..1.0 m: all 8 branch solutions exist and are exact; the 4 with
    the slide "backward" (d3 < 0) fall outside the stroke, so 4 solutions are returned, by
    default and with every copy (limits +-180 deg: one copy each)."""
    robot = load_robot("stanford_arm")
    rng = np.random.default_rng(321)
    q = robot.table.random_q(RANDOM_POSES, rng)
    T = robot.reference().fk(q)
    principal, principal_valid, flags, branches = principal_branches(robot, T, None)
    assert principal_valid.all()
    np.testing.assert_array_equal(branches.dropped, 0)
    assert np.all(flags == 0)
    check_distinct(principal, principal_valid, q)
    errors = oracle_max_errors(robot, principal.reshape(-1, 6), np.repeat(T, 8, axis=0))
    assert max(errors) <= 1e-10, errors
    every = robot.ik_batch_detailed(T, copies=True)
    default = robot.ik_batch_detailed(T)
    for batch in (every, default):
        np.testing.assert_array_equal(batch.valid.sum(axis=1), 4)
        values, targets, _ = returned_rows(batch.q, batch.valid, T)
        errors = oracle_max_errors(robot, values, targets)
        assert max(errors) <= 1e-10, errors
        check_branch_sources(robot.table, principal, principal_valid, batch)
        np.testing.assert_array_equal(batch.dropped, 0)
        assert batch.projection.max() <= 1e-14
    check_copies_of_principal(robot.table, principal, principal_valid, every.q, every.valid)
    check_nearest_copies(robot.table, principal, principal_valid, default, None)
    returned = np.zeros(principal_valid.shape, bool)
    np.put_along_axis(returned, np.maximum(default.branch.astype(np.int64), 0), default.valid,
                      axis=1)
    assert np.all(principal[..., 2][returned] >= 0.3)  # forward: in the stroke
    assert np.all(principal[..., 2][~returned] < 0)  # backward: d3 < 0
    gap = completeness_gap(every.q, every.valid, q)
    print(f"\nstanford_arm: {RANDOM_POSES} poses, max error {errors[0]:.2e} m / {errors[1]:.2e} "
          f"rad, completeness gap {gap.max():.2e}")
    assert gap.max() <= COMPLETENESS_TOLERANCE


def test_variant_with_slide_off_axis_2_negative_directions_and_offsets():
    robot = dhkin.Robot(dhkin.parse_table(STANFORD_MODIFIED))
    assert robot.ik_solver.family == "stanford" and not robot.ik_solver.fit.refine
    rng = np.random.default_rng(322)
    q = robot.table.random_q(5000, rng)
    T = robot.reference().fk(q)
    principal, principal_valid, flags, branches = principal_branches(robot, T, None)
    np.testing.assert_array_equal(branches.dropped, 0)
    check_distinct(principal, principal_valid, q)
    every = robot.ik_batch_detailed(T, copies=True)
    default = robot.ik_batch_detailed(T, q_seed=q)
    for batch in (every, default):
        values, targets, _ = returned_rows(batch.q, batch.valid, T)
        assert max(oracle_max_errors(robot, values, targets)) <= 1e-10
        check_branch_sources(robot.table, principal, principal_valid, batch)
    check_copies_of_principal(robot.table, principal, principal_valid, every.q, every.valid)
    check_nearest_copies(robot.table, principal, principal_valid, default, q)
    check_wrist_flags(robot, principal, principal_valid, flags, [every, default])
    assert completeness_gap(every.q, every.valid, q).max() <= COMPLETENESS_TOLERANCE
    assert completeness_gap(default.q, default.valid, q).max() <= COMPLETENESS_TOLERANCE
    both_slides = every.valid.sum(axis=1) == 8
    assert both_slides.any() and (~both_slides).any()  # the stroke admits both roots sometimes


def test_wrist_singularity_q5_zero(load_robot):
    """q5 = 0 with the seed = q: exact, flagged, the original q back; per arm branch (2
    shoulders x 2 slides, before the stroke) one solution where its wrist is singular (with
    Spong's frames both slides of a shoulder have axis 4 along the slide: both singular), else
    two."""
    robot = load_robot("stanford_arm")
    rng = np.random.default_rng(323)
    q = robot.table.random_q(SINGULAR_POSES, rng)
    q[:, 4] = 0.0
    check_singular_set(robot, q, np.full(SINGULAR_POSES, 4))
    T = robot.reference().fk(q)
    batch = robot.ik_batch_detailed(T, q_seed=q)
    same_arm = batch.valid & (np.abs(batch.q[..., :3] - q[:, None, :3]).max(-1) < 1e-9)
    assert np.all((batch.flags[same_arm] & WRIST) != 0)
    np.testing.assert_array_equal(same_arm.sum(axis=1), 1)


def test_wrist_singularity_q5_near_zero(load_robot):
    """|q5| in [1e-12, 1e-6]: as in test_ik_spherical_wrist.test_q5_near_zero."""
    robot = load_robot("stanford_arm")
    rng = np.random.default_rng(325)
    q = robot.table.random_q(SINGULAR_POSES, rng)
    q[:, 4] = rng.choice([-1.0, 1.0], SINGULAR_POSES) * 10 ** rng.uniform(-12, -6, SINGULAR_POSES)
    check_singular_set(robot, q, np.full(SINGULAR_POSES, 4))


def test_wrist_singularity_is_continuous_in_the_seed(load_robot):
    """Seeds perturbed by +-0.05 (rad, m): at q5 = 0 the nearest member of the q4 + q6 family;
    within 0.25 of the seed there and for |q5| in [1e-12, 1e-6]."""
    robot = load_robot("stanford_arm")
    rng = np.random.default_rng(326)
    q = robot.table.random_q(1000, rng)
    q[:, 4] = 0.0
    at_zero = check_continuity(robot, q, rng, member="sum")
    q = robot.table.random_q(1000, rng)
    q[:, 4] = rng.choice([-1.0, 1.0], 1000) * 10 ** rng.uniform(-12, -6, 1000)
    near_zero = check_continuity(robot, q, rng)
    print(f"\nstanford_arm: largest distance from the seed {at_zero:.3g} (q5 = 0), "
          f"{near_zero:.3g} (|q5| <= 1e-6)")


def test_unreachable_reasons(load_robot):
    """Beyond the stroke: every branch verifies but none has its slide in 0.3..1 m (the reason
    counts them); closer to axis 1 than the lateral offset d2; (variant) closer to axis 2 than
    the slide line."""
    robot = load_robot("stanford_arm")
    far = np.eye(4)
    far[:3, 3] = (1.5, 0.3, 0.9)
    principal, principal_valid, _, _ = principal_branches(robot, far[None], None)
    slides = principal[0][principal_valid[0]][:, 2]
    assert np.all((slides < 0.3) | (slides > 1.0))
    centre = far[:3, 3] - 0.1 * far[:3, 2]  # d6 = 0.1 back along the flange's z
    assert np.sort(np.abs(slides)) == pytest.approx(
        np.full(len(slides), np.sqrt(np.sum((centre - (0, 0, 0.4)) ** 2) - 0.15**2)))
    for copies in (False, True):
        assert robot.ik(far, copies=copies).reason == (
            f"{principal_valid.sum()} branch solution(s) verified, but no 2pi copy of any lies "
            f"within the joint limits")
    close = np.eye(4)  # wrist centre 0.05 m from axis 1, lateral offset d2 = 0.15 m
    close[:3, 3] = (0.05, 0.0, 0.9 + 0.1)
    assert robot.ik(close).reason == ("the wrist centre is 0.05 m from axis 1, closer than the "
                                      "lateral offset 0.15 m")
    variant = dhkin.Robot(dhkin.parse_table(STANFORD_MODIFIED))
    points, directions = jacobian_axes(variant, np.zeros((1, 6)))
    wrist_centre = _nearest_point(points[:, 3:], directions[:, 3:])[0]
    p1, u1, p2, u2 = points[0, 0], directions[0, 0], points[0, 1], directions[0, 1]
    assert abs(u1 @ u2) < 1e-12
    shoulder = p1 + ((p2 - p1) @ u1) * u1  # foot on axis 1 of the common normal to axis 2
    across = np.cross(u1, u2)  # perpendicular to axes 1 and 2
    for distance, reachable in ((0.03, False), (0.04, False), (0.06, True)):
        # at the shoulder's height, sqrt(d2^2 + distance^2) from axis 1: after turning about
        # axis 1, the wrist centre lies d2 along axis 2 and `distance` across it, level with it
        target = variant.reference().fk(np.zeros(6))
        target[:3, 3] += shoulder + np.hypot(0.15, distance) * across - wrist_centre
        sols = variant.ik(target)
        if reachable:
            assert variant.ik_solver.branches(target[None]).valid.sum() == 8
            continue
        assert len(sols) == 0
        assert sols.reason == (f"the wrist centre is {distance:.6g} m from axis 2, closer than "
                               f"the slide line's distance 0.05 m from it")


def test_target_for_another_tool_frame(load_robot):
    robot = load_robot("stanford_arm")
    tcp = np.eye(4)
    tcp[:3, 3] = (0.0, 0.05, 0.2)
    q = np.array([0.5, 0.9, 0.55, -0.4, 1.1, 0.3])
    T_tcp = robot.reference().fk(q) @ tcp
    sols = robot.ik(T_tcp, tcp=tcp)
    assert np.abs(sols.q - q).max(axis=1).min() <= 1e-9
    position, rotation = pose_error(robot.reference().fk(sols.q) @ tcp,
                                    np.broadcast_to(T_tcp, (len(sols), 4, 4)))
    assert position.max() <= 1e-10 and rotation.max() <= 1e-10
