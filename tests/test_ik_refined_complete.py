"""A refined table's roots beyond its eight branch slots (cpp/dhkin/extra_roots.hpp).

Near the ideal model's singular sets the exact chain of a refined table (a calibrated UR5e, the
TM5-900's rounded constants, the Kinova Gen3's offsets) can have more isolated roots than the
eight branch slots hold. Here, on poses made by Pinocchio on the vendor's URDF (robots/vendor:
the table was fitted to it) at q5 = 0, at small |q5| and at special angles: every isolated root
that a multistart on Pinocchio finds (dhkin.validation.multistart.RootReference, its roots
verified on Pinocchio) is returned unless
it lies in the singular band (sigma_min(J) < sqrt(tolerance), where a member of the near-singular
family stands for it), unseeded and seeded; the roots returned outside the band are the same
with and without the seed; every returned row verifies on Pinocchio; the batch gives the single
call's rows; and roots beyond the slots are returned at all (the sets exercise them).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import dhkin
from dhkin.robot import Robot
from dhkin.transforms import pose_error
from dhkin.validation.multistart import ISOLATED, RootReference
from dhkin.validation.references import target_model
from dhkin.vendors import VENDOR_REFERENCES
from tests.conftest import REFERENCE_URDFS

TOLERANCE = 1e-9
#: A root is found when a returned row is within this of it on every joint (mod 2pi): the
#: validator's joint tolerance.
JOINT_TOLERANCE = 1e-6
#: sigma_min below which a member of a near-singular family may stand for a root: the general 6R
#: solver's singular band, sqrt(tolerance).
SINGULAR_BAND = math.sqrt(TOLERANCE)
SPECIAL = np.array([0.0, math.pi / 2, -math.pi / 2, math.pi])
REFINED = ("ur5e_calibrated", "kinova_gen3_6dof", "tm5_900")
#: Arms whose sample sets have roots beyond the slots (the calibrated UR5e's and the Kinova's
#: wrists are off the ideal model's by 1.7e-3 rad and 0.175 mm; the TM5-900's constants by
#: rounding, 3e-7 rad, whose roots the slots hold on these sets)
BEYOND_THE_SLOTS = ("ur5e_calibrated", "kinova_gen3_6dof")
POSES_PER_SET = 30


def wrapped(d: np.ndarray) -> np.ndarray:
    return np.mod(d + np.pi, 2.0 * np.pi) - np.pi


def sample_sets(robot: Robot, rng: np.random.Generator) -> np.ndarray:
    """q5 = 0, |q5| in [1e-6, 1e-2] and special angles (each joint in {0, +-pi/2, pi}, clipped
    to the limits): POSES_PER_SET each."""
    n = POSES_PER_SET
    wrist_zero = robot.table.random_q(n, rng)
    wrist_zero[:, 4] = 0.0
    wrist_small = robot.table.random_q(n, rng)
    wrist_small[:, 4] = rng.choice([-1.0, 1.0], size=n) * 10.0 ** rng.uniform(-6, -2, size=n)
    special = np.clip(SPECIAL[rng.integers(0, 4, size=(n, 6))], robot.lower, robot.upper)
    return np.concatenate([wrist_zero, wrist_small, special])


def found(roots: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Which roots a row holds (JOINT_TOLERANCE, mod 2pi)."""
    if not len(rows):
        return np.zeros(len(roots), dtype=bool)
    gap = np.abs(wrapped(roots[:, None, :] - rows[None, :, :])).max(axis=2)
    return gap.min(axis=1) <= JOINT_TOLERANCE


def same_roots(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(found(a, b).all() and found(b, a).all())


@pytest.mark.parametrize("name", REFINED)
def test_refined_tables_return_every_isolated_root(name):
    robot = dhkin.load(name)
    assert robot.ik_solver.completed
    listed = VENDOR_REFERENCES[name]  # Pinocchio on the vendor's URDF
    model = target_model(robot, REFERENCE_URDFS / listed.file, base=listed.base, tip=listed.tip)
    reference = RootReference(robot, model, starts=2000)
    rng = np.random.default_rng(2511)
    q = sample_sets(robot, rng)
    T = model.fk(q)
    seeds = q + rng.normal(0.0, 0.05, q.shape)
    beyond_slots = 0
    for i in range(len(q)):
        roots = reference.points(T[i], TOLERANCE).roots
        if len(roots):
            sigma = np.linalg.svd(model.reference.jacobians(roots), compute_uv=False)[:, -1]
            wanted = roots[sigma >= SINGULAR_BAND]
            assert np.all(sigma >= ISOLATED)
        else:
            wanted = roots
        answers = []
        for seed in (None, seeds[i]):
            answer = robot.ik(T[i], seed)
            rows = np.asarray(answer.q).reshape(-1, 6)
            assert found(wanted, rows).all(), (
                f"{name}, q = {q[i].tolist()}, seed {seed}: roots not returned "
                f"{wanted[~found(wanted, rows)].tolist()}")
            targets = np.broadcast_to(T[i], (len(rows), 4, 4))
            position, rotation = pose_error(model.fk(rows), targets)
            assert np.all(np.maximum(position, rotation) <= TOLERANCE)
            if len(rows):  # the rows outside the singular band
                sigma = np.linalg.svd(model.reference.jacobians(rows), compute_uv=False)[:, -1]
                rows = rows[sigma >= SINGULAR_BAND]
            answers.append(rows)
        # outside the singular band the seed only picks copies (within it, a member)
        assert same_roots(*answers), f"{name}, q = {q[i].tolist()}: the roots depend on the seed"
        beyond_slots += int((robot.ik_solver.branches(T[i]).extra_branch >= 0).sum())
    if name in BEYOND_THE_SLOTS:
        assert beyond_slots > 0, "no pose of the sets has roots beyond the slots"


@pytest.mark.parametrize("name", REFINED)
def test_refined_batches_give_the_single_calls_rows(name):
    """ik_batch (copies or not, one seed for all and one per pose, two workers) gives each
    pose's rows of robot.ik, in its order: the rows beyond the slots included."""
    robot = dhkin.load(name)
    rng = np.random.default_rng(2512)
    q = sample_sets(robot, rng)
    T = robot.reference().fk(q)
    seeds = q + rng.normal(0.0, 0.05, q.shape)
    for copies in (False, True):
        for seed in (None, seeds):
            batch = robot.ik_batch_detailed(T, seed, copies=copies, workers=2)
            assert batch.q.shape[1] == batch.counts().max()
            for i in range(len(q)):
                single = robot.ik(T[i], None if seed is None else seed[i], copies=copies)
                count = len(single)
                assert batch.counts()[i] == count
                np.testing.assert_array_equal(batch.q[i, :count], single.q)
                np.testing.assert_array_equal(batch.residuals[i, :count], single.residuals)
                labels = [robot.ik_solver.branch_labels[b] for b in batch.branch[i, :count]]
                assert labels == [c.labels for c in single.configurations]


def test_roots_beyond_the_slots_carry_their_ideal_configuration():
    """Each root beyond the slots is labelled with the branch the ideal model gives its joint
    values: the ideal model's closed form at the ideal model's own pose of those values, seeded
    with them (at q5 = 0 the ideal wrist is singular and the seed gives its free joint), returns
    them in that branch."""
    robot = dhkin.load("ur5e_calibrated")
    ideal = Robot(robot.ik_solver.fit.ideal)
    rng = np.random.default_rng(2513)
    q = sample_sets(robot, rng)[:POSES_PER_SET]  # q5 = 0
    T = robot.reference().fk(q)
    branches = robot.ik_solver.branches(T)
    rows = branches.extra_branch >= 0
    assert rows.any()
    values = branches.extra_q[rows]
    labels = branches.extra_branch[rows]
    own = ideal.ik_solver.branches(ideal.fk(values), values)
    for k in range(len(values)):
        slot = own.q[k, labels[k]]
        assert own.valid[k, labels[k]]
        assert np.abs(wrapped(slot - values[k])).max() <= JOINT_TOLERANCE
