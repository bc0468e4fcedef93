"""dhkin's own complete IK validated in batches: the checks and figures of the pose-by-pose run
(:mod:`dhkin.validation.run`), with the IK called once for all samples and the bookkeeping done
on arrays.

Used by :func:`~dhkin.validation.run.validate` for dhkin's own IK (``ik=None``) of a robot with
a complete IK (a closed-form family or the general 6R solver), unless ``isolate`` asks for a
child process. What changes is how the work is done, not what is checked:

* **One call per pose, as before, made as a batch.** The IK under test is
  ``robot.ik(T, q_seed=q)`` (:func:`~dhkin.validation.adapters.own_ik`; unseeded, ``robot.ik(T)``,
  for a general 6R arm); here ``robot.ik_batch_detailed(targets, q_seed=q)`` (or without seeds)
  answers every sample at once, pose by pose the same solutions in the same order
  (tests/test_ik_batch.py and tests/test_validate.py assert it). A batch that raises falls back
  on the guarded pose-by-pose run.
* **Verification on arrays.** Every returned solution goes through Pinocchio on the reference
  in one call; finite values, joint limits, residuals and the distance to the sampled q are
  array operations. A sample that all of them clear (solutions returned, every one finite,
  within the limits and within the tolerance plus the reference's deviation, one within
  ``joint_tolerance`` of the sampled q) is a success; every other sample goes through the very
  functions of the pose-by-pose run (:mod:`dhkin.validation.sample_checks`) with the same
  answer, so that its outcome, detail and figures are those the pose-by-pose run gives.
* **Branches: the answer itself.** The missing-branch check compares the returned solutions
  with dhkin's own complete answer ``robot.ik(T, q_seed=q)``; for dhkin's own IK that is the
  answer under test (the pose-by-pose run made the identical call twice), so every branch is
  returned by construction: the samples are counted (``branch_checked``) without a second call.
  For another IK (:func:`~dhkin.validation.validate` with ``ik=``) the branches are a second,
  independent answer and the check runs pose by pose. A general 6R arm's roots are checked
  against the multistart reference (:mod:`dhkin.validation.multistart`) on its samples, as in
  the pose-by-pose run.
* **Continuity.** The samples of the singular sets that succeeded are solved again in one batch
  with their perturbed seeds; the nearest solution to each seed is found on arrays, and any
  sample not cleared goes through :func:`~dhkin.validation.sample_checks.check_continuity`.
  For an arm the general 6R solver answers, both batches come from one search for each pose's
  roots (:meth:`~dhkin.robot.Robot.ik_batch_seeds`: its roots do not depend on the seed, and
  each seed set's answer equals its own ``ik_batch_detailed``, row for row).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.errors import DhkinError
from dhkin.transforms import pose_error
from dhkin.validation.calls import CallResult
from dhkin.validation.matching import wrap
from dhkin.validation.multistart import RootReference, check_reference
from dhkin.validation.references import TargetModel
from dhkin.validation.report import ValidationReport
from dhkin.validation.sample_checks import check_continuity, check_sample
from dhkin.validation.samples import CONTINUITY_DISTANCE, CONTINUITY_SETS, reference_samples
from dhkin.validation.tally import Tally


class Answers:
    """The solutions of N poses from one batch (``q`` (N, m, dof) and ``valid`` (N, m), as
    :class:`~dhkin.ik.result.IKBatch` holds them), as flat rows: ``rows`` (M, dof) in pose
    order, ``owner`` (M,) the pose of each row, ``starts`` (N + 1,) where each pose's rows
    begin."""

    def __init__(self, q: NDArray[np.float64], valid: NDArray[np.bool_]) -> None:
        self.q, self.valid = q, valid
        self.rows: NDArray[np.float64] = q[valid]
        self.owner: NDArray[np.int64] = np.nonzero(valid)[0]
        counts = valid.sum(axis=1)
        self.counts: NDArray[np.int64] = counts
        self.starts: NDArray[np.int64] = np.concatenate(([0], np.cumsum(counts)))

    @classmethod
    def solve(cls, robot: Arm, targets: NDArray[np.float64],
              seeds: NDArray[np.float64] | None) -> Answers:
        """``robot.ik_batch_detailed(targets, q_seed=seeds)``'s answers (``seeds``: one per
        pose, or None: unseeded)."""
        batch = robot.ik_batch_detailed(targets, q_seed=seeds)
        return cls(batch.q, batch.valid)

    def of_poses(self, poses: NDArray[np.int64]) -> Answers:
        """The answers of the poses ``poses`` (indices), in that order."""
        return Answers(self.q[poses], self.valid[poses])

    def of(self, k: int) -> NDArray[np.float64]:
        """The solutions of pose k, (count, dof)."""
        return self.rows[self.starts[k]:self.starts[k + 1]]

    def call(self, k: int) -> CallResult:
        """Pose k's answer as the guarded call reads dhkin's own IK's (a list of rows)."""
        return CallResult(list(np.array(self.of(k), dtype=float, copy=True)))

    def screen(self, robot: Arm, model: TargetModel, targets: NDArray[np.float64],
               allowed: float) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                        NDArray[np.bool_]]:
        """Residuals of every row on the reference (Pinocchio, one call; NaN for a row that is
        not finite) and, per pose, whether it has solutions and every one is finite, within the
        limits and within ``allowed``."""
        finite = np.all(np.isfinite(self.rows), axis=1)
        position, rotation = np.full(len(self.rows), np.nan), np.full(len(self.rows), np.nan)
        if finite.any():
            position[finite], rotation[finite] = pose_error(model.fk(self.rows[finite]),
                                                            targets[self.owner[finite]])
        bad = (~finite | ~robot.table.in_limits(self.rows) | ~(position <= allowed)
               | ~(rotation <= allowed))
        clean = (self.counts > 0) & (np.bincount(self.owner[bad], minlength=len(self.counts))
                                     == 0)
        return position, rotation, clean

    def nearest(self, robot: Arm, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """Per pose, the largest joint difference (mod 2pi) of its finite row nearest ``q[k]``
        (inf for a pose without one)."""
        closest = np.full(len(self.counts), np.inf)
        finite = np.all(np.isfinite(self.rows), axis=1)
        rows, owner = self.rows[finite], self.owner[finite]
        np.minimum.at(closest, owner, np.abs(wrap(robot, rows - q[owner])).max(axis=1))
        return closest


def check_all_batched(robot: Arm, model: TargetModel, q: NDArray[np.float64], sets: list[str],
                      perturbed: NDArray[np.float64], targets: NDArray[np.float64],
                      labels: list[str], tolerance: float, joint_tolerance: float,
                      report: ValidationReport, reference: RootReference | None = None) -> bool:
    """Check every sample with dhkin's own IK answering in batches (see the module docstring);
    fill the report as the pose-by-pose run does. False (nothing filled) when the batch
    raises: the caller then runs pose by pose. ``reference``: the multistart reference of a
    general 6R arm, whose IK is then called unseeded and checked against it."""
    unseeded = reference is not None
    in_sets = np.array([s in CONTINUITY_SETS for s in sets], dtype=bool)
    seedable = in_sets & np.all(np.isfinite(perturbed), axis=1)
    try:
        first, continued = _answers(robot, targets, None if unseeded else q, perturbed, seedable)
    except DhkinError:
        return False
    allowed = tolerance + model.deviation
    position, rotation, clean = first.screen(robot, model, targets, allowed)
    # Every joint within the joint tolerance: a success however many joints
    # sample_checks.compared_joints compares (all of them for a seeded call).
    success = clean & (first.nearest(robot, q) <= joint_tolerance)
    n = len(sets)
    outcome = np.where(success, "success", "").astype(object)
    detail: list[str] = [""] * n
    tally = Tally()
    tally.residuals(position[success[first.owner]], rotation[success[first.owner]])
    row_errors: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
    for k in np.flatnonzero(~success).tolist():
        checked, _ = check_sample(robot, model, q[k], targets[k], first.call(k), tolerance,
                                  joint_tolerance, not unseeded)
        outcome[k], detail[k] = checked.outcome, checked.detail
        row_errors[k] = (checked.position, checked.rotation)
        tally.residuals(checked.position, checked.rotation)
    succeeded = outcome == "success"
    missing: dict[int, list[str]] = {}
    if reference is None:
        # Branches: dhkin's own complete answer is the answer under test (module docstring).
        report.branch_checked = int(succeeded.sum())
    else:
        # Roots: the multistart reference's, on the samples it is run on.
        for k in np.flatnonzero(succeeded & reference_samples(sets)).tolist():
            report.branch_checked += 1
            outcome[k], detail[k], missing[k] = check_reference(
                model, reference, targets[k], first.of(k), tolerance, joint_tolerance)
        succeeded = outcome == "success"
    moved = np.flatnonzero(succeeded & seedable)
    report.continuity_checked = len(moved)
    returned_perturbed: dict[int, list[NDArray[np.float64]]] = {}
    if len(moved):
        second = (continued.of_poses(moved) if continued is not None
                  else Answers.solve(robot, targets[moved], perturbed[moved]))
        position2, rotation2, clean2 = second.screen(robot, model, targets[moved], allowed)
        continuous = clean2 & (second.nearest(robot, perturbed[moved]) <= CONTINUITY_DISTANCE)
        tally.residuals(position2[continuous[second.owner]], rotation2[continuous[second.owner]])
        for j in np.flatnonzero(~continuous).tolist():
            m = int(moved[j])
            outcome[m], detail[m], returned_perturbed[m] = check_continuity(
                robot, model, second.call(j), targets[m], perturbed[m], tolerance, tally)
    for k in range(n):
        if outcome[k] == "success":
            tally.count(sets[k], labels[k], "success", int(first.counts[k]))
            continue
        errors = row_errors.get(k)
        if errors is None:  # succeeded first, then failed the continuity call
            rows = slice(first.starts[k], first.starts[k + 1])
            errors = (position[rows], rotation[rows])
        tally.add(report, k, sets[k], labels[k], str(outcome[k]), detail[k], q[k], targets[k],
                  first.call(k).solutions, errors[0], errors[1], perturbed[k],
                  returned_perturbed.get(k, []), missing.get(k, []))
    tally.finish(report)
    return True


def _answers(robot: Arm, targets: NDArray[np.float64], seeds: NDArray[np.float64] | None,
             perturbed: NDArray[np.float64], seedable: NDArray[np.bool_]
             ) -> tuple[Answers, Answers | None]:
    """The answers of every pose (seeded with ``seeds``, or unseeded), and, for an arm the
    general 6R solver answers, those of every pose with its perturbed seed (where ``seedable``;
    elsewhere its first seed) in the same call (:meth:`~dhkin.robot.Robot.ik_batch_seeds`: the
    general solver finds each pose's roots once for both seed sets; each answer equals its own
    ``ik_batch_detailed``, row for row), which halves the cost of the continuity check on
    singular sets, where finding the roots is most of a pose's work. None for the second
    otherwise (a closed-form family's roots depend on its seed): the caller solves the
    continuity samples on their own."""
    if robot.ik_family != "general6r" or not seedable.any():
        return Answers.solve(robot, targets, seeds), None
    first_seeds = np.zeros((len(targets), robot.dof)) if seeds is None else seeds
    continuity_seeds = np.where(seedable[:, None], perturbed, first_seeds)
    first, continued = robot.ik_batch_seeds(targets, [seeds, continuity_seeds])
    return Answers(first.q, first.valid), Answers(continued.q, continued.valid)
