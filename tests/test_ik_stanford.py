"""Closed-form IK of the Stanford arm class (R-R-P arm + spherical wrist), against the oracle.

Targets are made with Pinocchio on the generated URDF and every solution is checked with it.
Tolerances as in test_ik_spherical_wrist.py: pose 1e-10 m / rad (1e-9 at singularities),
completeness 1e-6 in joint space (rad, and m for the slide).
"""

from __future__ import annotations

import numpy as np
import pytest

import dhkin
from dhkin.errors import FamilyError
from dhkin.ik import WRIST, spherical_wrist, stanford
from dhkin.transforms import pose_error

from .test_ik_spherical_wrist import (
    check_copies_of_principal,
    completeness_gap,
    oracle_max_errors,
    pairwise_distinct,
    principal_branches,
    returned_rows,
    wrapped_difference,
)

RANDOM_POSES = 20_000

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


def test_stanford_arm_fits_its_family_only(load_robot):
    robot = load_robot("stanford_arm")
    assert stanford.fit_problems(robot.table) == []
    assert robot.ik_solver.family == "stanford"
    assert robot.ik_solver.branch_labels[0] == {"shoulder": "lefty", "slide": "forward",
                                                "wrist": "noflip"}
    assert spherical_wrist.fit_problems(robot.table) == [
        "joint 3 (joint_3) is prismatic, expected revolute"]
    assert stanford.fit_problems(load_robot("abb_irb1200_7_70").table) == [
        "joint 3 (joint_3) is revolute, expected prismatic"]


def test_slide_not_perpendicular_to_axis_2_is_named():
    data = {**STANFORD_MODIFIED, "joints": [dict(j) for j in STANFORD_MODIFIED["joints"]]}
    data["joints"][2]["alpha"] = 60
    problems = stanford.fit_problems(dhkin.parse_table(data))
    assert any("the slide of joint 3 is not perpendicular to axis 2: |cos| = 0.5" in p
               for p in problems), problems
    with pytest.raises(FamilyError, match="stanford"):
        stanford.Solver(dhkin.parse_table(data))


def test_random_poses_exact_and_complete(load_robot):
    """Spong's frames, stroke 0.3..1.0 m: all 8 branch solutions exist and are exact; the 4 with
    the slide "backward" (d3 < 0) fall outside the stroke, so 4 solutions are returned."""
    robot = load_robot("stanford_arm")
    rng = np.random.default_rng(321)
    q = robot.table.random_q(RANDOM_POSES, rng)
    T = robot.reference().fk(q)
    principal, principal_valid, _ = principal_branches(robot, T, np.zeros_like(q))
    assert principal_valid.all()
    assert np.all(pairwise_distinct(principal, principal_valid))
    errors = oracle_max_errors(robot, principal.reshape(-1, 6), np.repeat(T, 8, axis=0))
    assert max(errors) <= 1e-10, errors
    Q, valid = robot.ik_batch(T)
    np.testing.assert_array_equal(valid.sum(axis=1), 4)
    values, targets, _ = returned_rows(Q, valid, T)
    errors = oracle_max_errors(robot, values, targets)
    assert max(errors) <= 1e-10, errors
    check_copies_of_principal(robot.table, principal, principal_valid, Q, valid)
    gap = completeness_gap(Q, valid, q)
    print(f"\nstanford_arm: {RANDOM_POSES} poses, max error {errors[0]:.2e} m / {errors[1]:.2e} "
          f"rad, completeness gap {gap.max():.2e}")
    assert gap.max() <= 1e-6


def test_variant_with_slide_off_axis_2_negative_directions_and_offsets():
    robot = dhkin.Robot(dhkin.parse_table(STANFORD_MODIFIED))
    assert robot.ik_solver.family == "stanford"
    rng = np.random.default_rng(322)
    q = robot.table.random_q(5000, rng)
    T = robot.reference().fk(q)
    principal, principal_valid, _ = principal_branches(robot, T, np.zeros_like(q))
    assert np.all(pairwise_distinct(principal, principal_valid))
    Q, valid = robot.ik_batch(T)
    values, targets, _ = returned_rows(Q, valid, T)
    assert max(oracle_max_errors(robot, values, targets)) <= 1e-10
    check_copies_of_principal(robot.table, principal, principal_valid, Q, valid)
    assert completeness_gap(Q, valid, q).max() <= 1e-6
    both_slides = valid.sum(axis=1) == 8
    assert both_slides.any() and (~both_slides).any()  # the stroke admits both roots sometimes


def test_wrist_singularity_is_flagged_exact_and_seeded(load_robot):
    robot = load_robot("stanford_arm")
    rng = np.random.default_rng(323)
    q = robot.table.random_q(2000, rng)
    q[:, 4] = 0.0
    T = robot.reference().fk(q)
    batch = robot.ik_batch_detailed(T, q_seed=q)
    values, targets, _ = returned_rows(batch.q, batch.valid, T)
    assert max(oracle_max_errors(robot, values, targets)) <= 1e-9
    assert np.all(np.isfinite(batch.q))
    same_arm = batch.valid & (np.abs(wrapped_difference(batch.q[..., :3],
                                                        q[:, None, :3])).max(-1) < 1e-9)
    assert np.all((batch.flags[same_arm] & WRIST) != 0)
    assert completeness_gap(batch.q, batch.valid, q).max() <= 1e-6  # q4 came from the seed


def test_unreachable_reasons(load_robot):
    robot = load_robot("stanford_arm")
    far = np.eye(4)
    far[:3, 3] = (1.5, 0.3, 0.9)
    reason = robot.ik(far).reason
    assert "from axis 2 needs joint 3 at" in reason
    assert reason.endswith("outside its stroke 0.3..1 m")
    close = np.eye(4)  # wrist centre 0.05 m from axis 1, lateral offset d2 = 0.15 m
    close[:3, 3] = (0.05, 0.0, 0.9 + 0.1)
    assert robot.ik(close).reason == ("wrist centre 0.05 m from axis 1, closer than the lateral "
                                      "offset 0.15 m")


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
