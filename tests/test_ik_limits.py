"""Joint limits at the edges: a value within the slack of a limit is on it, and a singular family
whose seed's member lies outside the limits answers its member nearest the seed inside them.

The slack is the tolerance over the lever (``tolerance / max(1 m, table scale)``): moving one
joint by it moves the pose by at most the tolerance, so a joint value that far outside a limit is
set onto the limit and verified again (the limit check uses the pose check's tolerance).
Targets are made by Pinocchio on the table's generated URDF.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dhkin
from dhkin.tolerances import DEFAULT_TOLERANCE

from .conftest import REPO


def _limited(robot: dhkin.Robot, limits: dict[int, tuple[float, float]]) -> dhkin.Robot:
    """The robot with some joints' limits replaced (radians)."""
    joints = tuple(dataclasses.replace(j, lower=limits[i][0], upper=limits[i][1])
                   if i in limits else j for i, j in enumerate(robot.table.joints))
    return dhkin.Robot(dataclasses.replace(robot.table, joints=joints))


def _wrapped(x: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * x))


def test_d07_the_singular_branch_inside_tight_limits_is_answered_for_every_seed() -> None:
    """The reproducer d07: UR5 with shoulder_lift_joint limited to [-90, 90] deg and
    wrist_1_joint to [-180, 90] deg; q = (0, -90, 90, 90, 0, 180) deg lies within them, two
    joints exactly on their limits, q5 = 0. Its branch's members inside the limits lie within
    1e-3 rad of q: the branch is answered unseeded, seeded with q (q itself, within 1e-9 rad) and
    with the seed moved by 0.05 rad (the in-limit member nearest the seed), and the set of
    solutions has the same size for every seed."""
    ur5 = dhkin.load(REPO / "robots" / "ur5.yaml")
    robot = _limited(ur5, {1: (-np.pi / 2, np.pi / 2), 3: (-np.pi, np.pi / 2)})
    q = np.radians([0.0, -90.0, 90.0, 90.0, 0.0, 180.0])
    assert robot.table.in_limits(q)
    T = robot.reference().fk(q)
    counts = []
    for seed in (None, q, q + np.radians([-2.86, 0.0, 2.86, 0.0, -2.86, 2.86])):
        solutions = robot.ik(T, q_seed=seed)
        counts.append(len(solutions))
        assert np.all(robot.table.in_limits(solutions.q))
        distance = np.abs(_wrapped(solutions.q - q)).max(axis=1)
        assert distance.min() <= (1e-9 if seed is q else 1e-3), (seed, solutions.q)
        assert "wrist" in solutions.flags[int(np.argmin(distance))]
        position, rotation = (np.abs(e) for e in solutions.residuals.T)
        assert position.max() <= DEFAULT_TOLERANCE and rotation.max() <= DEFAULT_TOLERANCE
    assert len(set(counts)) == 1, counts


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70"])
def test_a_joint_within_the_slack_of_its_limit_is_on_it(name: str, load_robot) -> None:
    """A solution whose joint 2 lies half the slack beyond a limit is answered, set onto the
    limit and within the tolerance; at twice the slack beyond it, it is not answered."""
    base = load_robot(name)
    rng = np.random.default_rng(71)
    q = base.table.random_q(40, rng)
    slack = DEFAULT_TOLERANCE / max(1.0, base.ik_solver.fit.solved.scale)
    answered = refused = 0
    for k in range(len(q)):
        T = base.reference().fk(q[k])
        for factor, expect in ((0.5, True), (2.0, False)):
            upper = q[k, 1] - factor * slack
            robot = _limited(base, {1: (min(base.lower[1], upper - 1.0), upper)})
            solutions = robot.ik(T, q_seed=q[k])
            # the copy of q itself (another 2pi copy of joint 2 may lie inside the limits)
            near = (np.abs(solutions.q - q[k]).max(axis=1) <= 1e-6 if len(solutions)
                    else np.zeros(0, bool))
            assert near.any() == expect, (k, factor)
            if expect:
                kept = solutions.q[np.argmax(near)]
                assert kept[1] == upper  # set onto the limit
                assert solutions.residuals[np.argmax(near)].max() <= DEFAULT_TOLERANCE
                answered += 1
            else:
                refused += 1
    assert answered == refused == len(q)
