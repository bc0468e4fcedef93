"""The core's direct path (cpp/dhkin/pipeline.hpp) answers a regular pose as the pipeline does.

The solver tries the direct path first and hands the poses it declines to the pipeline. That is
only sound if, on every pose it accepts, its answer is the pipeline's bit for bit: solutions,
verification errors, flags, copy counts, the per-pose info and the numbers that explain an empty
answer. Checked here on every closed-form robot, at q5 = 0, special angles, random poses, poses
out of reach, poses rounded to six digits and with a TCP; and that it declines what it must (a
refined table, a pose with a seeded candidate) while it takes every regular pose. On refined
tables the refined direct path is checked against the pipeline alone (to Newton's last bits).
"""

from __future__ import annotations

import numpy as np
import pytest

import dhkin
from dhkin.ik.core import EXTRA_ROOTS, WHY_SIZE
from dhkin.ik.solver import INFO
from dhkin.transforms import rot_x
from tests.test_ik_batch import ROBOTS, pose_set
from tests.test_ik_vendor_poses import (
    EXACT_TABLES,
    REFINED_TABLES,
    shoulder_singular_q,
    special_q,
    vendor,
)

N_POSES = 4000


def _outputs(solver, n_poses: int) -> tuple[np.ndarray, ...]:
    B, n = solver.n_branches, solver.dof
    E = EXTRA_ROOTS if solver.completed else 0
    return (np.zeros((n_poses, B, n)), np.zeros((n_poses, B), np.bool_),
            np.zeros((n_poses, B), np.uint8), np.zeros((n_poses, B, 2)),
            np.zeros((n_poses, B), np.int64), np.zeros((n_poses, WHY_SIZE)),
            np.zeros((n_poses, INFO.size)), np.zeros((n_poses, E, n)),
            np.zeros((n_poses, E), np.int16), np.zeros((n_poses, E), np.uint8),
            np.zeros((n_poses, E, 2)))


def both_paths(robot: dhkin.Robot, T: np.ndarray, seeds: np.ndarray, frames: np.ndarray,
               copies: bool) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...], np.ndarray]:
    """(pipeline outputs, direct outputs, which poses the direct path answered)."""
    solver = robot.ik_solver
    full, direct = _outputs(solver, len(T)), _outputs(solver, len(T))
    done = np.zeros(len(T), np.bool_)
    solver.core.principal(T, seeds, 1e-9, frames, copies, *full, direct=False)
    solver.core.principal(T, seeds, 1e-9, frames, copies, *direct)
    solver.core.direct_answers(T, seeds, 1e-9, frames, done)
    return full, direct, done


def assert_same_answers(full: tuple[np.ndarray, ...], direct: tuple[np.ndarray, ...],
                        done: np.ndarray) -> None:
    q, ok, flags, errors, totals, why, info = full[:7]
    dq, dok, dflags, derrors, dtotals, dwhy, dinfo = direct[:7]
    np.testing.assert_array_equal(dok[done], ok[done])
    kept = ok & done[:, None]  # values of branches without a solution are not part of the answer
    np.testing.assert_array_equal(dq[kept], q[kept])
    np.testing.assert_array_equal(dflags[kept], flags[kept])
    np.testing.assert_array_equal(derrors[kept], errors[kept])
    np.testing.assert_array_equal(dtotals[done], totals[done])
    np.testing.assert_array_equal(dwhy[done], why[done])  # NaN where unused, in both
    np.testing.assert_array_equal(dinfo[done], info[done])


@pytest.fixture(scope="module", params=ROBOTS, ids=lambda name: name.rsplit("/", 1)[-1])
def robot(request, load_robot) -> dhkin.Robot:
    return load_robot(request.param)


@pytest.mark.parametrize("copies", [False, True])
def test_direct_path_answers_as_the_pipeline_bit_for_bit(robot, copies):
    T, seeds = pose_set(robot, N_POSES, seed=31)
    rounded = np.round(T, 6)
    rounded[:, 3] = [0.0, 0.0, 0.0, 1.0]
    targets = np.ascontiguousarray(np.concatenate([T, rounded]))
    for seed in (np.zeros((1, robot.dof)), np.concatenate([seeds, seeds])):
        full, direct, done = both_paths(robot, targets, seed, robot.ik_solver.frames, copies)
        assert_same_answers(full, direct, done)
        # every random pose of general position takes the direct path (pose_set: a quarter at
        # q5 = 0, a quarter at special angles, then random poses, the last five out of reach)
        general = np.r_[N_POSES // 2:N_POSES - 5, N_POSES + N_POSES // 2:2 * N_POSES - 5]
        assert done[general].all()
        # and q5 = 0 never does: the wrist's free joint takes the seed's value (pipeline)
        assert not done[:N_POSES // 4].any()


def test_direct_path_with_a_tcp(load_robot):
    robot = load_robot("ur5")
    tcp = np.eye(4)
    tcp[:3, 3] = [0.01, -0.02, 0.15]
    tcp[:3, :3] = rot_x(0.3)[:3, :3]
    q = robot.table.random_q(2000, np.random.default_rng(5))
    T = np.ascontiguousarray(robot.fk(q) @ tcp)
    full, direct, done = both_paths(robot, T, np.zeros((1, 6)), robot.ik_solver.frames_for(tcp),
                                    False)
    assert done.all()
    assert_same_answers(full, direct, done)
    solutions = robot.ik(T[0], tcp=tcp)
    assert any(np.allclose(np.angle(np.exp(1j * (s - q[0]))), 0.0, atol=1e-6)
               for s in solutions.q)


def test_direct_path_declines_refined_tables(load_robot):
    robot = load_robot("ur5e_calibrated")
    assert robot.ik_solver.fit.refine
    q = robot.table.random_q(200, np.random.default_rng(6))
    T = np.ascontiguousarray(robot.fk(q))
    _, _, done = both_paths(robot, T, np.zeros((1, 6)), robot.ik_solver.frames, False)
    assert not done.any()


@pytest.mark.parametrize("name", EXACT_TABLES)
def test_direct_path_on_vendor_poses(name):
    """Targets by Pinocchio on the vendor URDF (robots/vendor), not our FK: random, q5 = 0,
    |q5| in [1e-12, 1e-6], special angles and shoulder-singular poses, without a seed and seeded
    with the sampled q moved by 0.05 rad: the direct path answers as the pipeline does; the
    vendor's rounded constants (UR: pi/2 as 1.570796327) leave random poses regular."""
    robot = dhkin.load(name)
    reference = vendor(name)
    rng = np.random.default_rng(41)
    random = robot.table.random_q(2000, rng)
    wrist = robot.table.random_q(1000, rng)
    wrist[:500, 4] = 0.0
    wrist[500:, 4] = np.exp(rng.uniform(np.log(1e-12), np.log(1e-6), 500)) \
        * rng.choice([-1.0, 1.0], 500)
    q = np.concatenate([random, wrist, special_q(robot, 500, rng),
                        shoulder_singular_q(robot, 50, rng)])
    T = np.ascontiguousarray(reference.fk(q))
    seeds = q + rng.normal(0.0, 0.05, q.shape)
    for seed in (np.zeros((1, robot.dof)), seeds):
        full, direct, done = both_paths(robot, T, seed, robot.ik_solver.frames, False)
        assert_same_answers(full, direct, done)
        assert done[:2000].all()
        assert not done[2000:2500].any()  # q5 = 0: the seed's wrist split, by the pipeline


@pytest.mark.parametrize("name", REFINED_TABLES)
def test_refined_direct_path_answers_as_the_pipeline(name, load_robot):
    """On a refined table the solver first tries the refined direct path (closed form and Newton
    for the eight branches in lanes, cpp/dhkin/refined_direct.hpp) and hands every other pose to
    the pipeline. Against the pipeline alone (``direct=False``), on random poses, q5 = 0, special
    angles and poses out of reach, unseeded and seeded: the same branches, flags, copy counts,
    info and explanations; joint values equal to Newton's last bits (the lanes solve the square
    Gauss-Newton system, the pipeline its damped least squares) and residuals no larger than
    the pipeline's or 1e-12."""
    robot = load_robot(name)
    assert robot.ik_solver.fit.refine
    T, seeds = pose_set(robot, 600, seed=37)
    for seed in (np.zeros((1, robot.dof)), seeds):
        full, direct, _ = both_paths(robot, T, seed, robot.ik_solver.frames, False)
        q, ok, flags, errors, totals, why, info, extra_q, extra_branch, extra_flags, _ = full
        dq, dok, dflags, derrors, dtotals, dwhy, dinfo, dextra_q, dextra_branch, dextra_flags, _ = \
            direct
        np.testing.assert_array_equal(dok, ok)
        np.testing.assert_array_equal(dflags[ok], flags[ok])
        np.testing.assert_array_equal(dtotals, totals)
        np.testing.assert_array_equal(dwhy, why)
        np.testing.assert_array_equal(dinfo, info)
        np.testing.assert_allclose(np.angle(np.exp(1j * (dq[ok] - q[ok]))), 0.0, atol=1e-9)
        assert (derrors[ok] <= np.maximum(errors[ok], 1e-12)).all()
        # the roots beyond the slots: the pipeline's (every pose it takes gets them) on the poses
        # the direct path settles too, where only a branch moved beyond the band asks for them
        np.testing.assert_array_equal(dextra_branch, extra_branch)
        found = extra_branch >= 0
        np.testing.assert_array_equal(dextra_flags[found], extra_flags[found])
        np.testing.assert_array_equal(dextra_q[found], extra_q[found])


@pytest.mark.parametrize("name", REFINED_TABLES)
def test_refined_direct_answers_says_which_poses_the_lanes_settle(name, load_robot):
    """``ClosedForm.refined_direct_answers`` (scripts/check_refined.py's split of the poses): on
    random poses of a refined table the refined direct path settles most poses; at q5 = 0 every
    pose has a candidate within the wrist's seed band and goes to the pipeline; an exact-family
    table never takes the refined path at all."""
    robot = load_robot(name)
    rng = np.random.default_rng(43)
    q = robot.table.random_q(500, rng)
    q[400:, 4] = 0.0
    T = np.ascontiguousarray(robot.reference().fk(q))  # Pinocchio on the generated URDF
    seeds = np.zeros((1, robot.dof))
    settled = np.zeros(len(T), np.bool_)
    robot.ik_solver.core.refined_direct_answers(T, seeds, 1e-9, robot.ik_solver.frames, settled)
    assert settled[:400].mean() > 0.5
    assert not settled[400:].any()
    exact = load_robot("ur5")
    none = np.ones(len(T), np.bool_)
    exact.ik_solver.core.refined_direct_answers(T, seeds, 1e-9, exact.ik_solver.frames, none)
    assert not none.any()
