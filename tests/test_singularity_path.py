"""Singularities along paths (issue 5, item 3): where a path crosses or grazes one, and how fast
the joints race there.

Two behaviours of a wrist singularity, both checked on the IRB 1200 and the UR5:

* a straight line at fixed orientation *through* a wrist-singular pose crosses it smoothly: the
  IK path (nearest solution each step) lets q5 change sign while q4 and q6 stay slow, and the
  crossing is reported where the line meets the singular pose;
* a straight line that *misses* it narrowly (here turning the tool past it, q5 staying >= ~1e-3)
  makes joints 4 and 6 swing half a turn over a few tenths of a millimetre (seed 000: "near
  q5 = 0 a short move makes joint 4 race"); it is reported as a graze where Pinocchio's smallest
  singular value along the path is smallest.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

import dhkin
from dhkin.errors import InputError, UnreachableError
from dhkin.singularity import (
    GRAZE_THRESHOLDS,
    analyse_path,
    joint_axes,
    line_poses,
    singularity_model,
)

#: Generic configurations on the wrist singularity (q5 = 0), far from the other kinds.
WRIST_SINGULAR = {
    "abb_irb1200_7_70": np.array([0.3, 0.2, -0.3, 0.4, 0.0, 0.5]),
    "ur5": np.array([0.3, -1.2, 1.4, -0.6, 0.0, 0.5]),
}


def rotation_about(axis: NDArray[np.float64], angle: float) -> NDArray[np.float64]:
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def sigma_min_along(robot: dhkin.Robot, q: NDArray[np.float64]) -> NDArray[np.float64]:
    ref = robot.reference()
    return np.array([ref.manipulability(row).sigma_min for row in q])


@pytest.mark.parametrize("name", sorted(WRIST_SINGULAR))
def test_line_through_the_wrist_singularity_reports_where_it_crosses(name: str,
                                                                      load_robot) -> None:
    """Acceptance: a 0.2 m straight line at fixed orientation through a wrist-singular pose,
    101 samples, the singular pose at 43.7 % of the way: one wrist crossing at sample 43.7,
    tool0 there within 0.1 mm of the singular pose, and no race (smooth crossing)."""
    robot = load_robot(name)
    q_star = WRIST_SINGULAR[name]
    assert singularity_report_kinds(robot, q_star) == ("wrist",)
    T_star = robot.fk(q_star)
    direction = np.array([0.6, 0.5, -0.3]) / np.linalg.norm([0.6, 0.5, -0.3])
    length, fraction, n = 0.2, 0.437, 101
    start, end = T_star.copy(), T_star.copy()
    start[:3, 3] -= fraction * length * direction
    end[:3, 3] += (1 - fraction) * length * direction
    analysis = analyse_path(robot, line_poses(start, end, n), q_start=q_star)

    np.testing.assert_allclose(robot.reference().fk(analysis.q)[:, :3, 3],
                               line_poses(start, end, n)[:, :3, 3], atol=1e-9)
    assert [(e.kind, e.how) for e in analysis.events] == [("wrist", "crosses")]
    event = analysis.events[0]
    assert event.sample == pytest.approx(fraction * (n - 1), abs=0.05)
    assert event.arc_length == pytest.approx(fraction * length, abs=1e-4)
    assert np.linalg.norm(event.position - T_star[:3, 3]) < 1e-4
    assert event.distance < 0.01
    assert event.blow_up < 3.0
    crossing = round(event.sample)
    assert np.sign(analysis.q[crossing - 2, 4]) == -np.sign(analysis.q[crossing + 2, 4])
    assert "crosses the wrist singularity at sample 43.70" in analysis.summary()


def singularity_report_kinds(robot: dhkin.Robot, q: NDArray[np.float64]) -> tuple[str, ...]:
    from dhkin.singularity import singularity_report

    return singularity_report(robot, q).kinds


def grazing_line(robot: dhkin.Robot, q_star: NDArray[np.float64], miss: float,
                 n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A straight line (positions linear, orientation turning about one axis) passing ``miss``
    (rad of q5) from the wrist singularity at q_star: from the configuration with q5 = miss, the
    tool turns about z4 x z5 (the direction the singular wrist cannot turn about) around the
    wrist point, from -0.1 to +0.15 rad. Returns the poses and the start configuration."""
    q_miss = q_star.copy()
    q_miss[4] = miss
    points, axes = joint_axes(robot.table, q_miss)
    lost = np.cross(axes[0, 3], axes[0, 4])
    lost /= np.linalg.norm(lost)
    centre = points[0, 4]
    T = robot.fk(q_miss)

    def turned(angle: float) -> NDArray[np.float64]:
        R = rotation_about(lost, angle)
        out = T.copy()
        out[:3, :3] = R @ T[:3, :3]
        out[:3, 3] = centre + R @ (T[:3, 3] - centre)
        return out

    return line_poses(turned(-0.1), turned(0.15), n), q_miss


@pytest.mark.parametrize("name", sorted(WRIST_SINGULAR))
def test_line_grazing_the_wrist_singularity_makes_joint_4_race(name: str, load_robot) -> None:
    """A line passing ~2e-3 from the wrist singularity: one wrist graze where Pinocchio's
    sigma_min is smallest along the path, joint 4 among the racing joints, and a joint-speed
    blow-up of more than 100 times the path's median."""
    robot = load_robot(name)
    poses, q_miss = grazing_line(robot, WRIST_SINGULAR[name], miss=2e-3, n=121)
    analysis = analyse_path(robot, poses, q_start=q_miss)
    wrist_events = [e for e in analysis.events if e.kind == "wrist"]
    assert len(wrist_events) == 1, analysis.summary()
    event = wrist_events[0]
    assert event.how == "grazes"
    closest = int(np.argmin(sigma_min_along(robot, analysis.q)))
    assert abs(event.sample - closest) <= 1.5
    assert np.linalg.norm(event.position - analysis.poses[closest, :3, 3]) < 5e-4
    assert 4 in event.racing_joints
    assert event.blow_up > 100
    swing = abs(analysis.q[closest + 3, 3] - analysis.q[closest - 3, 3])
    assert swing > 2.0  # q4 turns by more than 2 rad over 6 samples (~1.5 mm of tool motion)
    assert event.distance < 5e-3
    assert "racing: " in analysis.summary()


@pytest.mark.parametrize("name", ["abb_irb1200_7_70", "ur5", "aubo_i10", "stanford_arm"])
def test_joint_path_crossings_are_located(name: str, load_robot) -> None:
    """A straight joint-space path through a configuration placed exactly at each kind, 51
    samples, the singular one at 37.17 % of the way: a crossing of that kind at sample 18.585."""
    robot = load_robot(name)
    model = singularity_model(robot)
    rng = np.random.default_rng(17)
    for kind in model.kinds:
        q_star = model.place(np.clip(np.array([0.3, 0.5, -0.8, 0.4, 0.9, 0.5]), robot.lower,
                                     robot.upper), kind)
        direction = rng.normal(size=6)
        direction *= 0.4 / np.linalg.norm(direction)
        s = np.linspace(0.0, 1.0, 51)[:, None] - 0.3717
        path = q_star + s * direction
        analysis = analyse_path(robot, path)
        mine = [e for e in analysis.events if e.kind == kind]
        assert len(mine) == 1, (kind, analysis.summary())
        assert mine[0].how == "crosses"
        assert mine[0].sample == pytest.approx(0.3717 * 50, abs=0.05)
        np.testing.assert_allclose(mine[0].position, robot.fk(q_star)[:3, 3], atol=2e-3)


def test_path_far_from_singularities_has_no_events(load_robot) -> None:
    robot = load_robot("abb_irb1200_7_70")
    q = np.array([0.1, 0.2, 0.3, 0.4, 0.8, 0.6])
    path = q + np.linspace(0, 0.05, 20)[:, None] * np.array([1, -1, 1, 1, 1, 1])
    analysis = analyse_path(robot, path)
    assert analysis.events == ()
    assert "no singularity crossed or grazed" in analysis.summary()
    assert np.all(analysis.joint_speed > 0) and np.all(np.isfinite(analysis.joint_speed))


def test_graze_threshold_decides_what_a_near_miss_is(load_robot) -> None:
    """q5 dipping to 0.03 (inside the default 0.05) is a graze; with a 0.01 threshold it is not."""
    robot = load_robot("ur5")
    q5 = 0.03 + 0.2 * np.linspace(-1, 1, 41) ** 2
    path = np.tile(WRIST_SINGULAR["ur5"], (41, 1))
    path[:, 4] = q5
    assert GRAZE_THRESHOLDS.wrist == 0.05
    events = analyse_path(robot, path).events
    assert [(e.kind, e.how, e.sample) for e in events] == [("wrist", "grazes", 20.0)]
    assert analyse_path(robot, path, thresholds={"wrist": 0.01}).events == ()


def test_line_poses_interpolates_position_and_orientation() -> None:
    start = np.eye(4)
    end = np.eye(4)
    end[:3, :3] = rotation_about(np.array([0.0, 0.0, 1.0]), 0.8)
    end[:3, 3] = (0.3, -0.1, 0.2)
    poses = line_poses(start, end, 5)
    np.testing.assert_allclose(poses[0], start, atol=1e-15)
    np.testing.assert_allclose(poses[-1], end, atol=1e-15)
    np.testing.assert_allclose(poses[2, :3, 3], [0.15, -0.05, 0.1], atol=1e-15)
    np.testing.assert_allclose(poses[2, :3, :3],
                               rotation_about(np.array([0.0, 0.0, 1.0]), 0.4), atol=1e-15)


def test_unreachable_pose_is_named(load_robot) -> None:
    robot = load_robot("ur5")
    poses = np.repeat(np.eye(4)[None], 3, axis=0)
    poses[2, :3, 3] = (5.0, 0.0, 0.0)
    poses[:2, :3, 3] = (0.4, 0.1, 0.3)
    with pytest.raises(UnreachableError, match=r"poses\[2\]: no IK solution") as caught:
        analyse_path(robot, poses)
    assert (caught.value.field, caught.value.index) == ("poses", 2)


@pytest.mark.parametrize("bad", [np.zeros((5, 5)), np.zeros((2, 6)), np.zeros((4, 3, 3))])
def test_bad_path_shapes_are_dhkin_errors(bad, load_robot) -> None:
    with pytest.raises(InputError, match="path: expected"):
        analyse_path(load_robot("ur5"), bad)


def test_bad_line_poses_arguments() -> None:
    with pytest.raises(InputError, match="n: expected an integer >= 2"):
        line_poses(np.eye(4), np.eye(4), 1)
    flipped = np.eye(4)
    flipped[:3, :3] = rotation_about(np.array([1.0, 0.0, 0.0]), math.pi)
    with pytest.raises(InputError, match="half a turn apart"):
        line_poses(np.eye(4), flipped, 10)
