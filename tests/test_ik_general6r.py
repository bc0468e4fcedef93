"""The general 6R solver (dhkin.ik.general6r): every solution of arms outside the families.

Targets come from Pinocchio on the generated URDF (the oracle); every returned solution is
checked there at the verification tolerance. Sizes are CI-friendly; scripts/check_general6r.py
runs the issue's full sizes.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import dhkin
from dhkin.dh import DHTable, Joint
from dhkin.ik.general6r import General6RSolver, _wrap
from dhkin.robot import Robot
from dhkin.tolerances import DEFAULT_TOLERANCE

SPECIAL = np.array([0.0, math.pi / 2, -math.pi / 2, math.pi])


def ur5_tilted() -> Robot:
    """The UR5 with joint 2's alpha tilted by 10 degrees (no family fits)."""
    table = dhkin.load("ur5").table
    joints = list(table.joints)
    joints[1] = replace(joints[1], alpha=joints[1].alpha + math.radians(10.0))
    return Robot(replace(table, name="ur5_tilted", joints=tuple(joints)))


def random_table(rng: np.random.Generator, index: int) -> DHTable:
    """A random 6R table: lengths 0.05-1 m, alphas uniform, offsets random, limits +-2pi."""
    joints = tuple(Joint(name=f"joint_{i + 1}", link=f"link_{i + 1}", type="revolute",
                         a=rng.uniform(0.05, 1.0), alpha=rng.uniform(-math.pi, math.pi),
                         d=rng.uniform(0.05, 1.0) * rng.choice([-1.0, 1.0]), theta=0.0,
                         offset=rng.uniform(-math.pi, math.pi), direction=1,
                         lower=-2 * math.pi, upper=2 * math.pi, velocity=1.0, effort=1.0)
                   for i in range(6))
    return DHTable(name=f"random_{index}", convention="standard", joints=joints)


def pose_errors(T: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and rotation angle (rad) of T against targets, (N,) each."""
    position = np.linalg.norm(T[:, :3, 3] - targets[:, :3, 3], axis=1)
    E = np.einsum("nji,njk->nik", T[:, :3, :3], targets[:, :3, :3])
    cos = np.clip((np.trace(E, axis1=1, axis2=2) - 1) / 2, -1, 1)
    skew = np.stack([E[:, 2, 1] - E[:, 1, 2], E[:, 0, 2] - E[:, 2, 0],
                     E[:, 1, 0] - E[:, 0, 1]], axis=1)
    return position, np.arctan2(np.linalg.norm(skew, axis=1) / 2, cos)


def run(robot: Robot, Q: np.ndarray, seeded: bool = True) -> tuple[int, float, int]:
    """Solve the Pinocchio poses of Q: (poses whose q came back, worst oracle error, total
    solutions); asserts every solution verifies on the oracle."""
    solver = General6RSolver(robot.table)
    reference = robot.reference()
    targets = reference.fk(Q)
    recovered, worst, total = 0, 0.0, 0
    for q, T in zip(Q, targets, strict=True):
        result = solver.solve_one(T, q if seeded else None)
        total += len(result)
        if len(result) == 0:
            continue
        position, rotation = pose_errors(reference.fk(result.q), np.repeat(T[None], len(result),
                                                                            axis=0))
        worst = max(worst, float(position.max()), float(rotation.max()))
        if np.min(np.max(np.abs(_wrap(result.q - q)), axis=1)) < 1e-6:
            recovered += 1
    return recovered, worst, total


@pytest.mark.parametrize("name", ["fanuc_crx10ia", "xarm6", "ur5_tilted"])
def test_arms_outside_the_families(name: str) -> None:
    robot = ur5_tilted() if name == "ur5_tilted" else dhkin.load(name)
    Q = robot.table.random_q(300, np.random.default_rng(16))
    recovered, worst, _ = run(robot, Q)
    assert worst <= DEFAULT_TOLERANCE
    assert recovered == len(Q)


@pytest.mark.parametrize("name", ["fanuc_crx10ia", "xarm6", "ur5_tilted"])
def test_special_angles_give_no_wrong_solution(name: str) -> None:
    robot = ur5_tilted() if name == "ur5_tilted" else dhkin.load(name)
    rng = np.random.default_rng(17)
    Q = SPECIAL[rng.integers(0, 4, size=(100, 6))]
    Q = np.clip(Q, robot.lower, robot.upper)
    _, worst, _ = run(robot, Q, seeded=False)
    assert worst <= DEFAULT_TOLERANCE


def test_random_tables_counts_even_and_complete() -> None:
    rng = np.random.default_rng(1616)
    for index in range(8):
        table = random_table(rng, index)
        solver = General6RSolver(table)
        Q = rng.uniform(-math.pi, math.pi, size=(40, 6))
        for q in Q:
            T_dh = solver.target_dh(table.fk(q))
            roots, _, _ = solver.roots(T_dh, None, DEFAULT_TOLERANCE)
            assert roots.shape[0] % 2 == 0 and roots.shape[0] <= 16
            assert np.min(np.max(np.abs(_wrap(roots - q)), axis=1)) < 1e-6
        recovered, worst, _ = run(Robot(table), Q[:20])
        assert worst <= DEFAULT_TOLERANCE and recovered == 20


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70"])
def test_same_solutions_as_the_family_solver(name: str) -> None:
    robot = dhkin.load(name)
    solver = General6RSolver(robot.table)
    Q = robot.table.random_q(200, np.random.default_rng(18))
    for q, T in zip(Q, robot.fk(Q), strict=True):
        family = robot.ik(T, q)
        general = solver.solve_one(T, q)
        assert len(family) == len(general)
        a = np.array(sorted(map(tuple, np.round(_wrap(family.q), 6))))
        b = np.array(sorted(map(tuple, np.round(_wrap(general.q), 6))))
        assert np.max(np.abs(_wrap(a - b))) < 1e-5
