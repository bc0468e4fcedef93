"""dhkin's own IK validated in batches (dhkin.validation.batched) gives the report of the
pose-by-pose run: every count, residual, solution count and failure record the same.

The pose-by-pose run is what ``validate`` does with an explicit IK: ``ik=own_ik(robot)`` is the
very callable ``validate(robot)`` validates, called guarded pose by pose. Real robots of every
complete family (closed form: offset wrist, spherical wrist, Stanford; the general 6R solver),
on the exact URDF and on a vendor URDF, all pass; a robot whose IK is made faulty in ways that
depend only on the pose and the seed (wrong, unsolved, non-finite, missing, discontinuous
answers) fails both runs the same way, sample for sample.
"""

from __future__ import annotations

import json
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

import dhkin
from dhkin.ik.result import IKSolutions
from dhkin.validation import own_ik, validate
from dhkin.validation.report import ValidationReport

from .conftest import REFERENCE_URDFS

N = 150  # uniform samples per run, plus 15 special-angle and 15 near-singular ones


def figures(report: ValidationReport) -> str:
    """Every figure of the report but its seconds, as JSON text (NaN compares equal)."""
    data = report.to_json()
    data.pop("seconds")
    return json.dumps(data, sort_keys=True)


def both_runs(robot: dhkin.Robot, **options: Any) -> tuple[ValidationReport, ValidationReport]:
    """(the batched run of validate(robot), the pose-by-pose run of the same IK)."""
    batched = validate(robot, n=N, seed=3, **options)
    by_pose = validate(robot, ik=own_ik(robot), n=N, seed=3, **options)
    return batched, by_pose


@pytest.mark.parametrize(("name", "reference"), [
    ("ur5", "exact"), ("ur5", "vendor"), ("abb_irb1200_7_70", "rounded"),
    ("stanford_arm", "exact"), ("fanuc_crx10ia", "vendor")])
def test_the_batched_run_gives_the_pose_by_pose_report(name: str, reference: str) -> None:
    robot = dhkin.load(name)
    batched, by_pose = both_runs(robot, reference=reference)
    assert batched.ok and batched.branch_checked > 0 and batched.continuity_checked > 0
    assert figures(batched) == figures(by_pose)


def valid_rows_first(batch: Any, q: np.ndarray, valid: np.ndarray) -> Any:
    """``batch`` with the rows ``q`` and flags ``valid``, each pose's valid rows first in their
    order (as the IK's own batches are)."""
    order = np.argsort(~valid, axis=1, kind="stable")
    return replace(batch, q=np.take_along_axis(q, order[..., None], axis=1),
                   valid=np.take_along_axis(valid, order, axis=1))


class SinglePoseFromBatch(dhkin.Robot):
    """A robot whose ``ik`` is its ``ik_batch_detailed`` on one pose (faults made there show in
    both runs)."""

    def ik(self, T: Any, q_seed: Any = None, *args: Any, **kwargs: Any) -> Any:
        seed = None if q_seed is None else np.asarray(q_seed)[None]
        batch = self.ik_batch_detailed(np.asarray(T)[None], seed)
        return IKSolutions(q=batch.q[0][batch.valid[0]])


class FaultyRobot(SinglePoseFromBatch):
    """UR5 whose IK answers, batch and pose by pose alike, depend on a hash of the seed: some
    poses get nothing (unsolved), a shifted solution or a NaN (wrong), or lose the solution
    nearest the seed (missing); a seed with joint 5 about 0.05 rad from 0 (a perturbed seed of
    the continuity check at q5 = 0) may get nothing (discontinuous). Without a seed (the
    configuration labels) the answer is dhkin's own."""

    def ik_batch_detailed(self, T: Any, q_seed: Any = None, *args: Any, **kwargs: Any) -> Any:
        batch = super().ik_batch_detailed(T, q_seed, *args, **kwargs)
        if q_seed is None:
            return batch
        q, valid = batch.q.copy(), batch.valid.copy()
        for k, seed in enumerate(np.broadcast_to(q_seed, (len(q), 6))):
            kind = int(abs(seed[:5].sum()) * 1e6)
            rows = np.flatnonzero(valid[k])
            if (0.04 < abs(seed[4]) < 0.06 and kind % 3 == 0) or kind % 13 == 0:
                valid[k] = False
            elif kind % 13 == 1 and len(rows):
                q[k, rows[0], 1] += 1e-6
            elif kind % 13 == 2 and len(rows):
                q[k, rows[-1], 3] = np.nan
            elif kind % 13 == 3 and len(rows):
                valid[k, rows[np.argmin(np.abs(q[k, rows] - seed).max(axis=1))]] = False
        return valid_rows_first(batch, q, valid)


def test_a_faulty_ik_fails_both_runs_sample_for_sample() -> None:
    robot = FaultyRobot(dhkin.load("ur5").table)
    batched, by_pose = both_runs(robot, reference="exact")
    outcomes = {o for o, count in batched.counts.items() if count}
    assert outcomes == {"success", "wrong", "no_solution", "missing", "discontinuous"}
    assert figures(batched) == figures(by_pose)
    batched, by_pose = both_runs(robot, reference=REFERENCE_URDFS / "ur5.urdf")
    assert not batched.ok and figures(batched) == figures(by_pose)


class FaultyGeneral6R(SinglePoseFromBatch):
    """xArm6 (general 6R solver) whose unseeded answers, batch and pose by pose alike, depend on
    a hash of the target: some poses get nothing (unsolved), one root shifted (wrong), or lose
    their first root (the sampled q's, else a root the multistart reference finds: missing or
    missing_branch). Seeded answers (the continuity call) are dhkin's own."""

    def ik_batch_detailed(self, T: Any, q_seed: Any = None, *args: Any, **kwargs: Any) -> Any:
        batch = super().ik_batch_detailed(T, q_seed, *args, **kwargs)
        if q_seed is not None:
            return batch
        q, valid = batch.q.copy(), batch.valid.copy()
        for k, target in enumerate(np.reshape(T, (-1, 4, 4))):
            kind = int(abs(target[:3, 3].sum()) * 1e6)
            rows = np.flatnonzero(valid[k])
            if kind % 11 == 0:
                valid[k] = False
            elif kind % 11 == 1 and len(rows):
                q[k, rows[0], 2] += 1e-6
            elif kind % 11 in (2, 3, 4) and len(rows) > 1:
                valid[k, rows[0]] = False
        return valid_rows_first(batch, q, valid)


def test_a_faulty_general_6r_ik_fails_both_runs_sample_for_sample() -> None:
    """The general 6R arms' batched run (unseeded calls, the multistart reference) gives the
    pose-by-pose report when the IK fails too."""
    robot = FaultyGeneral6R(dhkin.load("xarm6").table)
    assert robot.ik_family == "general6r"
    batched, by_pose = both_runs(robot, reference="exact")
    outcomes = {o for o, count in batched.counts.items() if count}
    assert outcomes == {"success", "wrong", "no_solution", "missing", "missing_branch"}
    assert figures(batched) == figures(by_pose)
