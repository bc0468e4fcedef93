"""Numerical IK (issue 7): seed 003's examples, full-pose and position-only solves, redundancy,
several solutions, joint limits, honest failures and bad input.

The oracle is Pinocchio forward kinematics (``Reference.fk``) on the generated URDF of a table or
on the example-robot-data URDF of the Franka Panda; the closed-form solvers are a second oracle
for the UR5 and the IRB 1200 (every numerical answer must be one of their solutions).
"""

from __future__ import annotations

import math
from importlib.metadata import distribution
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import dhkin
from dhkin.errors import InputError
from dhkin.ik.numerical import (
    DEFAULT_TOLERANCE,
    NumericalIK,
    SolverSettings,
    numerical_ik,
)
from dhkin.reference import Reference
from dhkin.transforms import pose_error

PANDA_URDF = Path(str(distribution("example-robot-data").locate_file(
    "cmeel.prefix/share/example-robot-data/robots/panda_description/urdf/panda.urdf")))
PANDA_TIP = "panda_hand"


def wrapped(difference: np.ndarray) -> np.ndarray:
    """Angle differences wrapped to [-pi, pi)."""
    return np.mod(difference + math.pi, 2 * math.pi) - math.pi


@pytest.fixture(scope="module")
def solvers() -> dict[str, NumericalIK]:
    """One solver per robot, shared by the tests of this module."""
    made = {name: NumericalIK.from_robot(dhkin.load(name))
            for name in ("planar_2r", "planar_3r", "ur5", "abb_irb1200_7_70")}
    made["panda"] = NumericalIK.from_urdf(PANDA_URDF, PANDA_TIP)
    return made


def oracle_pose_errors(reference: Reference, q: np.ndarray,
                       T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and rotation (rad) errors of Pinocchio FK(q) (k, n) against T (4, 4)."""
    return pose_error(reference.fk(np.atleast_2d(q)), np.broadcast_to(T, (len(np.atleast_2d(q)),
                                                                         4, 4)))


def random_targets(solver: NumericalIK, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Joint vectors drawn within the limits and their poses (reachable targets)."""
    rng = np.random.default_rng(seed)
    Q = rng.uniform(solver.lower, solver.upper, size=(count, solver.dof))
    return Q, solver.reference.fk(Q)


def assert_within_limits(solver: NumericalIK, Q: np.ndarray) -> None:
    assert np.all(solver.lower <= Q) and np.all(solver.upper >= Q)


# --------------------------------------------------------------------------- seed 003, 4-3-1
def test_seed_4_3_1_newton_raphson_iterates(solvers):
    """2R arm to [1, 1] from [2pi/3, -2pi/3]: the seed's numbers, iteration by iteration."""
    ik = solvers["planar_2r"]
    reference = ik.reference
    q0 = np.array([2 * math.pi / 3, -2 * math.pi / 3])
    np.testing.assert_allclose(reference.fk(q0)[:2, 3], [0.5, 0.866], atol=5e-4)

    first = ik.descend([1.0, 1.0], q0, method="newton", max_iterations=1)
    np.testing.assert_allclose(first.q, [1.517, -1.6717], atol=5e-4)
    np.testing.assert_allclose(reference.fk(first.q)[:2, 3], [1.0418, 0.8445], atol=5e-5)
    assert not first.converged and first.iterations == 1

    third = ik.descend([1.0, 1.0], q0, method="newton", max_iterations=3)
    np.testing.assert_allclose(reference.fk(third.q)[:2, 3], [1.0, 0.9999], atol=1e-4)
    np.testing.assert_allclose(third.q, [1.5708, -1.5709], atol=5e-5)
    assert not third.converged  # 7e-5 m off: an iterate, not a solution

    done = ik.descend([1.0, 1.0], q0, method="newton")
    assert done.converged and done.iterations <= 6
    np.testing.assert_allclose(done.q, [math.pi / 2, -math.pi / 2], atol=1e-10)
    tip = reference.fk(done.q)[:3, 3]
    assert np.linalg.norm(tip - [1.0, 1.0, 0.0]) <= DEFAULT_TOLERANCE


def test_seed_4_3_1_both_solutions(solvers):
    """[1, 1] has two elbow solutions, (pi/2, -pi/2) and (0, pi/2); the seed's comes first."""
    ik = solvers["planar_2r"]
    seed = [2 * math.pi / 3, -2 * math.pi / 3]
    near = ik.solve([1.0, 1.0], seed)
    np.testing.assert_allclose(near.q[0], [math.pi / 2, -math.pi / 2], atol=1e-10)
    both = ik.solve([1.0, 1.0, 0.0], seed, max_solutions=2)
    assert len(both) == 2 and both.numerical and both.family == "numerical"
    expected = np.array([[math.pi / 2, -math.pi / 2], [0.0, math.pi / 2]])
    np.testing.assert_allclose(both.q, expected, atol=1e-9)
    tips = ik.reference.fk(both.q)[:, :3, 3]
    assert np.abs(tips - [1.0, 1.0, 0.0]).max() <= DEFAULT_TOLERANCE
    assert np.all(both.residuals[:, 0] <= DEFAULT_TOLERANCE)
    assert np.all(np.isnan(both.residuals[:, 1]))  # orientation is not part of the task


# --------------------------------------------------------------------------- seed 003, 4-3-2
def test_seed_4_3_2_redundant_3r(solvers):
    """3R arm to [2, 2]: the seed's (59.01, -41.9, 40.9) deg is (to its rounding) a solution, and
    the pseudo-inverse iteration started there ends on an exact one a few millidegrees away."""
    ik = solvers["planar_3r"]
    reference = ik.reference
    seed_answer = np.radians([59.01, -41.9, 40.9])
    assert np.linalg.norm(reference.fk(seed_answer)[:2, 3] - [2.0, 2.0]) < 1e-3

    pseudo_inverse = ik.descend([2.0, 2.0], seed_answer, method="newton")
    assert pseudo_inverse.converged
    assert np.abs(np.degrees(pseudo_inverse.q - seed_answer)).max() < 0.02
    assert np.linalg.norm(reference.fk(pseudo_inverse.q)[:2, 3] - [2, 2]) <= DEFAULT_TOLERANCE

    solved = ik.solve([2.0, 2.0], seed_answer)  # null space pulled toward the seed
    assert len(solved) == 1
    assert np.abs(np.degrees(solved.q[0] - seed_answer)).max() < 0.02
    assert np.linalg.norm(reference.fk(solved.q[0])[:2, 3] - [2, 2]) <= DEFAULT_TOLERANCE

    from_zero = ik.descend([2.0, 2.0], np.zeros(3), method="newton")
    assert from_zero.converged
    assert np.linalg.norm(reference.fk(from_zero.q)[:2, 3] - [2, 2]) <= DEFAULT_TOLERANCE


@pytest.mark.parametrize("name, offset", [
    ("planar_2r", [0.05, -0.03, 0.0]),  # 3 rows, 2 joints: the z row is zero (rank 2 of 3)
    ("planar_2r", [0.05, -0.03]),       # square 2 x 2
    ("planar_3r", [0.05, -0.03]),       # 2 rows, 3 joints
    ("planar_3r", [0.05, -0.03, 0.0]),  # 3 x 3 of rank 2
])
def test_newton_step_is_the_moore_penrose_step(solvers, name, offset):
    """One Newton step is q0 - J^+ e, J^+ numpy's pseudo-inverse of the position Jacobian (by
    Pinocchio's FK, central differences): the core's pseudo-inverse (one-sided Jacobi) for tall,
    square, wide and rank-deficient task Jacobians."""
    ik = solvers[name]
    q0 = np.array([0.3, 0.9, -0.4][: ik.dof])
    rows = len(offset)
    target = ik.reference.fk(q0)[:rows, 3] + offset  # a step well within the joint limits

    def error(q):
        return ik.reference.fk(q)[:rows, 3] - np.asarray(target)

    step = 1e-6
    J = np.column_stack([(error(q0 + step * e) - error(q0 - step * e)) / (2 * step)
                         for e in np.eye(ik.dof)])
    expected = q0 - np.linalg.pinv(J) @ error(q0)
    first = ik.descend(target, q0, method="newton", max_iterations=1)
    # central differences of a smooth FK: J to ~1e-10, a step of ~1 rad to ~1e-9
    np.testing.assert_allclose(first.q, expected, atol=1e-8)


@pytest.mark.parametrize("name", ["planar_2r", "planar_3r"])
def test_planar_arms_reach_random_points(solvers, name):
    """300 reachable points per arm, seed-free: all solved, exact by Pinocchio, in limits."""
    ik = solvers[name]
    _, T = random_targets(ik, 300, seed=431)
    for k, target in enumerate(T):
        planar = target[:2, 3] if k % 2 else target[:3, 3]  # (x, y) and (x, y, z) targets
        solutions = ik.solve(planar)
        assert len(solutions) == 1, solutions.reason
        tip = ik.reference.fk(solutions.q[0])[:3, 3]
        assert np.linalg.norm(tip[:planar.size] - planar) <= DEFAULT_TOLERANCE
        assert_within_limits(ik, solutions.q)


# -------------------------------------------------------------------------- full-pose solves
@pytest.mark.parametrize("name, count", [("ur5", 300), ("abb_irb1200_7_70", 300)])
def test_full_pose_matches_closed_form(solvers, name, count):
    """Seed-free pose solves: each is exact by Pinocchio, in limits, and one of the closed-form
    solutions (which include every 2 pi-shifted copy within the limits)."""
    ik = solvers[name]
    robot = dhkin.load(name)
    _, T = random_targets(ik, count, seed=7)
    for target in T:
        solutions = ik.solve(target)
        assert len(solutions) == 1, solutions.reason
        q = solutions.q[0]
        position, rotation = oracle_pose_errors(ik.reference, q, target)
        assert position[0] <= DEFAULT_TOLERANCE and rotation[0] <= DEFAULT_TOLERANCE
        assert np.all(solutions.residuals <= DEFAULT_TOLERANCE)
        assert_within_limits(ik, solutions.q)
        closed_form = robot.ik(target, copies=True)
        assert np.abs(closed_form.q - q).max(axis=1).min() < 1e-6


def test_full_pose_panda(solvers):
    """The 7-axis Panda (example-robot-data URDF, tip panda_hand): 100 seed-free pose solves,
    every one exact by Pinocchio and within the limits."""
    ik = solvers["panda"]
    assert ik.dof == 7 and ik.is_redundant("pose")
    _, T = random_targets(ik, 100, seed=3)
    for target in T:
        solutions = ik.solve(target)
        assert len(solutions) == 1, solutions.reason
        position, rotation = oracle_pose_errors(ik.reference, solutions.q[0], target)
        assert position[0] <= DEFAULT_TOLERANCE and rotation[0] <= DEFAULT_TOLERANCE
        assert_within_limits(ik, solutions.q)


def test_seed_first_returns_the_seeded_branch(solvers):
    """Seeded near a known solution, the solve returns that solution (not another branch)."""
    ik = solvers["ur5"]
    Q, T = random_targets(ik, 100, seed=11)
    rng = np.random.default_rng(12)
    for q_true, target in zip(Q, T, strict=True):
        seed = q_true + rng.normal(scale=0.05, size=6)
        solutions = ik.solve(target, seed)
        # same solution; joint values agree to ~tolerance / sigma_min of the Jacobian
        np.testing.assert_allclose(solutions.q[0], q_true, atol=1e-6)


def test_tcp_targets(solvers):
    """With a TCP offset the target is the TCP's pose (or point)."""
    ik = solvers["ur5"]
    tcp = np.eye(4)
    tcp[:3, :3] = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    tcp[:3, 3] = [0.01, -0.02, 0.15]
    _, T = random_targets(ik, 50, seed=21)
    for flange_pose in T:
        target = flange_pose @ tcp
        pose = ik.solve(target, tcp=tcp)
        reached = ik.reference.fk(pose.q[0]) @ tcp
        position, rotation = pose_error(reached, target)
        assert position <= DEFAULT_TOLERANCE and rotation <= DEFAULT_TOLERANCE
        point = ik.solve(target[:3, 3], tcp=tcp)
        reached_point = (ik.reference.fk(point.q[0]) @ tcp)[:3, 3]
        assert np.linalg.norm(reached_point - target[:3, 3]) <= DEFAULT_TOLERANCE


# ----------------------------------------------------------------------- position-only tasks
def test_position_only_on_a_six_axis_arm(solvers):
    """A point target on the UR5 (redundant for position): exact position, orientation free
    (rotation residual NaN); a pose given with mode='position' asks for its translation only."""
    ik = solvers["ur5"]
    _, T = random_targets(ik, 100, seed=5)
    for target in T:
        solutions = ik.solve(target[:3, 3])
        assert len(solutions) == 1, solutions.reason
        tip = ik.reference.fk(solutions.q[0])[:3, 3]
        assert np.linalg.norm(tip - target[:3, 3]) <= DEFAULT_TOLERANCE
        assert math.isnan(solutions.residuals[0, 1])
        assert solutions.configurations[0].labels["mode"] == "position"
    same = ik.solve(T[0], mode="position")
    assert np.linalg.norm(ik.reference.fk(same.q[0])[:3, 3] - T[0][:3, 3]) <= DEFAULT_TOLERANCE


def test_under_actuated_pose_is_least_squares_not_a_solution(solvers):
    """A full pose for the 2R arm: reachable when its orientation agrees with the arm's plane
    (solved), not otherwise (empty, honest) -- and then the descent stops at a least-squares
    point, where J^T e = 0 (seed 003's case m > n)."""
    ik = solvers["planar_2r"]
    q_true = np.array([0.4, 1.1])
    consistent = ik.reference.fk(q_true)
    solved = ik.solve(consistent, [0.3, 1.0])
    np.testing.assert_allclose(solved.q[0], q_true, atol=1e-9)

    tilted = consistent.copy()
    tilted[:3, :3] = tilted[:3, :3] @ np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    empty = ik.solve(tilted)
    assert len(empty) == 0 and "did not converge" in empty.reason
    least = ik.descend(tilted, [0.3, 1.0])
    assert not least.converged
    assert least.rotation_error == pytest.approx(math.pi / 2, abs=1e-9)

    def cost(q: np.ndarray) -> float:  # |log6(T_target^-1 T(q))|^2 by Pinocchio
        error = pin.SE3(tilted).actInv(pin.SE3(ik.reference.fk(q)))
        return float(np.sum(pin.log6(error).vector ** 2))

    offsets = np.linspace(-0.02, 0.02, 21)
    neighbours = [cost(least.q + np.array([a, b])) for a in offsets for b in offsets]
    assert cost(least.q) <= min(neighbours) + 1e-12  # a local least-squares minimum
    step = 1e-6
    gradient = [(cost(least.q + step * unit) - cost(least.q - step * unit)) / (2 * step)
                for unit in np.eye(2)]
    assert np.abs(gradient).max() < 1e-6


# ------------------------------------------------------------------------------- redundancy
def projected_pull(ik: NumericalIK, q: np.ndarray, preferred: np.ndarray,
                   rows: slice) -> np.ndarray:
    """(I - J^+ J)(preferred - q) with Pinocchio's Jacobian (LOCAL_WORLD_ALIGNED rows)."""
    J = ik.reference.jacobian(q, reference="local_world_aligned")[rows]
    return (np.eye(ik.dof) - np.linalg.pinv(J) @ J) @ (preferred - q)


def test_null_space_pulls_toward_the_seed_planar_3r(solvers):
    """Redundant 3R arm, 300 random points and seeds: the solution with null-space motion is
    never farther from the seed than the one without, and (joints off their limits) it is a
    stationary point of the distance to the seed on the set of solutions."""
    ik = solvers["planar_3r"]
    rng = np.random.default_rng(432)
    _, T = random_targets(ik, 300, seed=433)
    stationary = off_limits_count = 0
    for target in T:
        seed = rng.uniform(ik.lower, ik.upper)
        pulled = ik.solve(target[:2, 3], seed)
        plain = ik.solve(target[:2, 3], seed, nullspace=None)
        assert len(pulled) == 1 and len(plain) == 1
        tip = ik.reference.fk(pulled.q[0])[:2, 3]
        assert np.linalg.norm(tip - target[:2, 3]) <= DEFAULT_TOLERANCE
        distance_pulled = np.linalg.norm(pulled.q[0] - seed)
        assert distance_pulled <= np.linalg.norm(plain.q[0] - seed) + 1e-9
        off_limits = bool(np.all(np.abs(pulled.q[0] - ik.lower) > 1e-6) and np.all(
            np.abs(pulled.q[0] - ik.upper) > 1e-6))
        off_limits_count += off_limits
        pull = projected_pull(ik, pulled.q[0], seed, slice(0, 2))
        stationary += off_limits and np.abs(pull).max() < 1e-5
    # (at a limit the optimum is a KKT point, where the projected pull need not vanish)
    assert off_limits_count >= 0.8 * len(T)
    assert stationary >= 0.95 * off_limits_count


def test_null_space_pulls_toward_mid_range_panda(solvers):
    """Panda, 60 pose targets, seed-free: sliding toward the middle of the joint ranges never
    ends farther from it than the plain solve from the same start, and is closer in most."""
    ik = solvers["panda"]
    _, T = random_targets(ik, 60, seed=17)
    closer = 0
    for target in T:
        pulled = ik.solve_detailed(target)
        plain = ik.solve_detailed(target, nullspace=None)
        assert pulled.solutions and plain.solutions
        assert np.array_equal(pulled.descents[0].start, plain.descents[0].start)
        distance_pulled = np.linalg.norm(pulled.solutions.q[0] - ik.mid_range)
        distance_plain = np.linalg.norm(plain.solutions.q[0] - ik.mid_range)
        assert distance_pulled <= distance_plain + 1e-9
        closer += distance_pulled < distance_plain - 1e-6
        position, rotation = oracle_pose_errors(ik.reference, pulled.solutions.q[0], target)
        assert position[0] <= DEFAULT_TOLERANCE and rotation[0] <= DEFAULT_TOLERANCE
    assert closer >= 0.9 * len(T)


def test_redundancy_is_detected_from_the_jacobian_rank(solvers):
    assert not solvers["planar_2r"].is_redundant("position", rows=2)
    assert solvers["planar_3r"].is_redundant("position", rows=2)
    assert solvers["planar_3r"].is_redundant("position", rows=3)  # z is out of the arm's reach
    assert not solvers["ur5"].is_redundant("pose")
    assert solvers["ur5"].is_redundant("position")
    assert solvers["panda"].is_redundant("pose")


# ------------------------------------------------------------------- several distinct solutions
@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70"])
def test_several_distinct_solutions_are_the_closed_form_branches(solvers, name):
    """Asked for up to 16, the solver finds every closed-form branch (modulo 2 pi) and nothing
    else, each exact and in limits."""
    ik = solvers[name]
    robot = dhkin.load(name)
    _, T = random_targets(ik, 8, seed=8)
    for target in T:
        found = ik.solve(target, max_solutions=16, restarts=300)
        closed_form = robot.ik(target, copies=True).q
        branches = np.unique(np.round(wrapped(closed_form), 7), axis=0)
        assert len(found) == len(branches)
        for q in found.q:
            assert np.abs(wrapped(branches - q)).max(axis=1).min() < 1e-6
        pairwise = np.abs(wrapped(found.q[:, None] - found.q[None])).max(axis=2)
        assert np.all(pairwise[~np.eye(len(found), dtype=bool)] > 1e-4)
        assert_within_limits(ik, found.q)
        position, rotation = oracle_pose_errors(ik.reference, found.q, target)
        assert position.max() <= DEFAULT_TOLERANCE and rotation.max() <= DEFAULT_TOLERANCE


def test_max_solutions_stops_early_and_is_reproducible(solvers):
    ik = solvers["ur5"]
    target = ik.reference.fk(np.array([0.3, -1.0, 1.2, 0.4, 0.9, 0.1]))
    branches = np.unique(np.round(wrapped(dhkin.load("ur5").ik(target).q), 7), axis=0)
    assert len(branches) == 8
    first = ik.solve_detailed(target, max_solutions=3)
    again = ik.solve_detailed(target, max_solutions=3)
    assert len(first.solutions) == 3
    assert sum(d.converged for d in first.descents) >= 3
    assert first.descents[-1].converged  # it stopped at the third distinct solution
    np.testing.assert_array_equal(first.solutions.q, again.solutions.q)
    other_rng = ik.solve(target, max_solutions=3, rng=np.random.default_rng(99))
    assert len(other_rng) == 3


# ------------------------------------------------------------------------------ joint limits
def test_narrow_limits_are_respected(solvers):
    """User limits narrower than the URDF's: answers stay inside; a target whose only solutions
    lie outside gives an empty result, never an out-of-limit q."""
    ur5 = solvers["ur5"]
    lower = np.full(6, -1.0)
    upper = np.full(6, 1.0)
    boxed = NumericalIK(ur5.reference, lower, upper)
    rng = np.random.default_rng(23)
    inside = rng.uniform(lower, upper, size=(100, 6))
    for target in ur5.reference.fk(inside):
        solutions = boxed.solve(target)
        assert len(solutions) >= 1, solutions.reason
        assert np.all(solutions.q >= lower) and np.all(solutions.q <= upper)
        position, rotation = oracle_pose_errors(ur5.reference, solutions.q[0], target)
        assert position[0] <= DEFAULT_TOLERANCE and rotation[0] <= DEFAULT_TOLERANCE
    outside = np.array([2.5, -2.0, 2.0, 2.0, 2.0, 2.5])
    target = ur5.reference.fk(outside)
    closed_form = dhkin.load("ur5").ik(target).q
    assert not np.any(np.all((closed_form >= lower) & (closed_form <= upper), axis=1))
    empty = boxed.solve(target, restarts=10)
    assert len(empty) == 0 and "did not converge" in empty.reason


def test_limits_irb_and_panda(solvers):
    for name in ("abb_irb1200_7_70", "panda"):
        ik = solvers[name]
        _, T = random_targets(ik, 40, seed=31)
        for target in T:
            found = ik.solve(target, max_solutions=4, restarts=60)
            assert len(found) >= 1
            assert_within_limits(ik, found.q)


def test_out_of_limit_seed_is_projected(solvers):
    ik = solvers["abb_irb1200_7_70"]
    q_true = np.array([0.2, 0.3, -0.4, 0.5, 0.6, 0.7])
    target = ik.reference.fk(q_true)
    far_seed = q_true + np.array([0.0, 0.0, 0.0, 0.0, 5.0, 2 * math.pi])
    solutions = ik.solve(target, far_seed)
    assert_within_limits(ik, solutions.q)
    position, rotation = oracle_pose_errors(ik.reference, solutions.q[0], target)
    assert position[0] <= DEFAULT_TOLERANCE and rotation[0] <= DEFAULT_TOLERANCE


def test_continuous_joints(solvers):
    """A URDF with continuous joints (Pinocchio stores cos/sin): no limits, answers exact."""
    text = dhkin.load("planar_2r").urdf().replace('type="revolute"', 'type="continuous"')
    ik = NumericalIK(Reference(text, tip="tool0"))
    assert np.all(np.isinf(ik.lower)) and np.all(np.isinf(ik.upper))
    rng = np.random.default_rng(41)
    for _ in range(50):
        point = rng.uniform(-1.4, 1.4, size=2)
        solutions = ik.solve(point, max_solutions=2)
        assert len(solutions) == 2
        tips = ik.reference.fk(solutions.q)[:, :2, 3]
        assert np.abs(tips - point).max() <= DEFAULT_TOLERANCE


def test_base_frame_in_the_middle_of_the_chain():
    """Chain link_1 -> tool0 of the 2R arm: one joint; targets in link_1's frame."""
    reference = Reference(dhkin.load("planar_2r").urdf(), tip="tool0", base="link_1")
    ik = NumericalIK(reference)
    assert ik.dof == 1
    solutions = ik.solve([1.0, 1.0])
    np.testing.assert_allclose(solutions.q, [[math.pi / 2]], atol=1e-10)


# ------------------------------------------------------------------------------ honest failures
def test_unreachable_targets_are_empty_with_how_close(solvers):
    ik = solvers["ur5"]
    far = np.eye(4)
    far[:3, 3] = [2.0, 0.0, 0.3]
    report = ik.solve_detailed(far, restarts=5)
    assert len(report.solutions) == 0 and report.starts == 6
    assert report.best is not None and report.best.residual > 0.5
    reason = report.solutions.reason
    assert "did not converge from 6 starts" in reason and "position" in reason
    assert f"{report.best.position_error:.3g}" in reason
    assert report.solutions.numerical and report.solutions.family == "numerical"
    assert report.solutions.q.shape == (0, 6)

    out_of_plane = solvers["planar_3r"].solve([1.0, 1.0, 0.5], restarts=3)
    assert len(out_of_plane) == 0 and "0.5 m" in out_of_plane.reason


def test_a_cut_short_descent_is_never_a_solution(solvers):
    """One iteration per start cannot reach the tolerance from a random start: none returned."""
    ik = solvers["ur5"]
    _, T = random_targets(ik, 20, seed=51)
    for target in T:
        report = ik.solve_detailed(target, max_iterations=1, restarts=3)
        assert len(report.solutions) == 0
        assert all(not d.converged for d in report.descents)
        assert report.best is not None and report.best.residual > DEFAULT_TOLERANCE


def test_tolerance_is_honoured(solvers):
    ik = solvers["abb_irb1200_7_70"]
    _, T = random_targets(ik, 30, seed=61)
    for target in T:
        loose = ik.solve(target, tolerance=1e-4)
        assert np.all(loose.residuals <= 1e-4)
        position, rotation = oracle_pose_errors(ik.reference, loose.q[0], target)
        assert position[0] <= 1e-4 and rotation[0] <= 1e-4


# ----------------------------------------------------------------------------- entry points
def test_numerical_ik_entry_points(solvers):
    robot = dhkin.load("planar_2r")
    by_name = numerical_ik("planar_2r", [1.0, 1.0], [2.0, -2.0])
    by_robot = numerical_ik(robot, [1.0, 1.0], [2.0, -2.0])
    np.testing.assert_allclose(by_name.q, by_robot.q)
    assert robot.numerical_solver() is robot.numerical_solver()
    assert numerical_ik(robot, [1.0, 1.0]).q.shape[1] == 2  # the robot's own solver
    _, T = random_targets(solvers["panda"], 1, seed=71)
    by_urdf = numerical_ik(PANDA_URDF, T[0], tip=PANDA_TIP)
    position, rotation = oracle_pose_errors(solvers["panda"].reference, by_urdf.q[0], T[0])
    assert position[0] <= DEFAULT_TOLERANCE and rotation[0] <= DEFAULT_TOLERANCE
    with pytest.raises(InputError, match="tip"):
        numerical_ik(PANDA_URDF, T[0])


def test_solve_batch(solvers):
    ik = solvers["abb_irb1200_7_70"]
    Q_true, T = random_targets(ik, 20, seed=91)
    Q, valid = ik.solve_batch(T, max_solutions=2)
    assert Q.shape == (20, 2, 6) and valid.shape == (20, 2) and valid[:, 0].all()
    position, rotation = pose_error(ik.reference.fk(Q[valid]), T[np.nonzero(valid)[0]])
    assert position.max() <= DEFAULT_TOLERANCE and rotation.max() <= DEFAULT_TOLERANCE
    seeded, seeded_valid = ik.solve_batch(T, Q_true)
    assert seeded_valid.all()
    np.testing.assert_allclose(seeded[:, 0], Q_true, atol=1e-6)
    with pytest.raises(InputError, match="q_seed"):
        ik.solve_batch(T, np.zeros((3, 6)))
    with pytest.raises(InputError, match="targets"):
        ik.solve_batch(np.zeros(4))


def test_textbook_methods_reach_exact_solutions(solvers):
    """Plain Newton (pseudo-inverse) and fixed-damping DLS converge too from starts 0.01 rad
    away, on targets away from singularities (sigma_min of Pinocchio's Jacobian > 0.05)."""
    ik = solvers["ur5"]
    Q, T = random_targets(ik, 60, seed=81)
    rng = np.random.default_rng(82)
    tried = 0
    for q_true, target in zip(Q, T, strict=True):
        if ik.reference.manipulability(q_true).sigma_min <= 0.05:
            continue
        tried += 1
        start = q_true + rng.normal(scale=0.01, size=6)
        for method in ("newton", "dls"):
            descent = ik.descend(target, start, method=method, damping=1e-3)
            assert descent.converged, method
            position, rotation = oracle_pose_errors(ik.reference, descent.q, target)
            assert position[0] <= DEFAULT_TOLERANCE and rotation[0] <= DEFAULT_TOLERANCE
    assert tried >= 30


# -------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("target, options, message", [
    (np.eye(3), {}, r"target: expected a pose \(4, 4\)"),
    (np.full((4, 4), np.nan), {}, "finite"),
    ([1.0, 2.0, 3.0, 4.0, 5.0], {}, "got shape"),
    ([0.3, float("nan"), 0.2], {}, "finite"),
    ("abc", {}, "target: expected numbers"),
    ([0.3, 0.1, 0.2], {"mode": "pose"}, "mode='pose' needs a"),
    (np.eye(4), {"mode": "orientation"}, "mode: expected"),
    (np.diag([1.0, 1.0, -1.0, 1.0]), {}, "not a rotation matrix"),
    (2 * np.eye(4), {}, "not a rotation matrix"),
    (np.eye(4), {"q_seed": [0.0] * 5}, r"q_seed: expected shape \(6,\)"),
    (np.eye(4), {"q_seed": [0.0, 0.0, np.nan, 0.0, 0.0, 0.0]}, "q_seed: expected finite"),
    (np.eye(4), {"max_solutions": 0}, "max_solutions"),
    (np.eye(4), {"restarts": -1}, "restarts"),
    (np.eye(4), {"tolerance": 0.0}, "tolerance"),
    (np.eye(4), {"tolerance": float("nan")}, "tolerance"),
    (np.eye(4), {"method": "gauss"}, "method"),
    (np.eye(4), {"max_iterations": 0}, "max_iterations"),
    (np.eye(4), {"nullspace": "elbow_up"}, "nullspace"),
    (np.eye(4), {"nullspace": [0.0, 1.0]}, r"nullspace: expected shape \(6,\)"),
    (np.eye(4), {"nullspace": "seed"}, "needs a q_seed"),
    (np.eye(4), {"tcp": np.eye(3)}, "tcp"),
    (np.eye(4), {"rng": "seven"}, "rng"),
])
def test_bad_input_raises(solvers, target, options, message):
    with pytest.raises(InputError, match=message):
        solvers["ur5"].solve(target, **options)


def test_bad_settings_and_limits_raise(solvers):
    with pytest.raises(InputError, match="nullspace_gain"):
        SolverSettings(nullspace_gain=2.0).checked()
    with pytest.raises(InputError, match="damping"):
        SolverSettings(method="dls", damping=0.0).checked()
    with pytest.raises(InputError, match="lower <= upper"):
        NumericalIK(solvers["ur5"].reference, np.ones(6), np.zeros(6))
    with pytest.raises(InputError, match="q_start"):
        solvers["ur5"].descend(np.eye(4), [0.0] * 7)
    with pytest.raises(dhkin.URDFError, match="no such URDF"):
        NumericalIK.from_urdf("/nonexistent/arm.urdf", "tool0")


_ODD_AXES_URDF = """<robot name="odd_axes">
  <link name="base_link"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/>
  <link name="l5"/><link name="l6"/><link name="tool0"/>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="l1"/>
    <origin xyz="0 0 0.3" rpy="0 0 0.2"/><axis xyz="0 0 -1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.1 0 0.2" rpy="0.3 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-0.2" upper="0.4" effort="1" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0 0.2 0" rpy="0 0.4 0"/><axis xyz="0.6 0 0.8"/>
    <limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>
  <joint name="j4" type="continuous"><parent link="l3"/><child link="l4"/>
    <origin xyz="0.3 0 0" rpy="0 0 0"/><axis xyz="-1 0 0"/></joint>
  <joint name="j5" type="prismatic"><parent link="l4"/><child link="l5"/>
    <origin xyz="0 0 0.1" rpy="0 0 0.5"/><axis xyz="0 0.8 -0.6"/>
    <limit lower="0" upper="0.3" effort="1" velocity="1"/></joint>
  <joint name="j6" type="revolute"><parent link="l5"/><child link="l6"/>
    <origin xyz="0 0.1 0" rpy="0.2 0.1 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="fixed" type="fixed"><parent link="l6"/><child link="tool0"/>
    <origin xyz="0.05 0.02 0.1" rpy="0.1 0.2 0.3"/></joint>
</robot>"""


def test_prismatic_joints_and_odd_axes():
    """The compiled descent runs on the chain built from the Pinocchio model (task._Chain.parts):
    prismatic joints, axes along negative, tilted and x / y directions, a continuous joint, a
    fixed tip frame. Poses of random in-limit joint vectors are solved to within tolerance by
    Pinocchio FK (each answer is also re-measured by the solver), every one of them."""
    ik = NumericalIK(Reference(_ODD_AXES_URDF, tip="tool0"))
    rng = np.random.default_rng(43)
    low = np.where(np.isfinite(ik.lower), ik.lower, -math.pi)
    high = np.where(np.isfinite(ik.upper), ik.upper, math.pi)
    for _ in range(30):
        target = ik.reference.fk(rng.uniform(low, high))
        solutions = ik.solve(target)
        assert len(solutions) == 1
        position, rotation = oracle_pose_errors(ik.reference, solutions.q[0], target)
        assert position[0] <= DEFAULT_TOLERANCE and rotation[0] <= DEFAULT_TOLERANCE
