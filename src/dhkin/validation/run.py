"""Cross-validation of any IK callable against an oracle: Pinocchio on a *reference description*.

An IK is a callable ``ik(T) -> iterable of joint vectors``: T is a 4x4 pose base_link -> tool0
in metres, joint vectors are URDF joint values in radians (metres for prismatic joints). Two
optional keyword parameters are honoured when the callable declares them: ``q_seed`` (the sampled
joint vector is passed, so that a solver can pick free joints at a singularity from it) and
``robot`` (the robot under test: a :class:`dhkin.robot.Robot`, or any
:class:`~dhkin.arm.Arm`). :func:`adapt` wraps an IK that works in degrees or for another tool
frame. Each call is guarded (:mod:`dhkin.validation.calls`): the IK gets read-only copies, and
whatever it raises or returns, however long it runs, is a result of that pose.

Samples (fixed seed): ``uniform`` joint vectors within the limits; ``special`` vectors whose
joints take the special angles 0, +-pi/2, pi (those inside the limits); ``near_singular``
vectors with the wrist joint q5 in [0, 1e-6] (q5 = 0 exactly for a quarter of them).

**Reference.** Targets are made by Pinocchio on a reference description of the same robot, and
every returned solution is checked on that same description (joint vectors in chain order, see
:class:`dhkin.reference.Reference`; the reference's tip frame is the table's tool0). A bug shared
by the table's own model and the IK under test cannot hide behind another description:

* ``"rounded"`` (default): the table's generated URDF with every number of its origin, axis and
  limit attributes rounded to :data:`ROUNDED_DIGITS` significant digits (:func:`rounded_urdf`),
  as vendors write them (UR's pi/2 is 1.570796327): about 1e-10 from the exact table;
* a vendor URDF (a path, or ``"vendor"``: the robot's vendor URDF shipped with dhkin,
  :func:`dhkin.vendors.vendor_file`) with its ``base`` and ``tip`` frames (defaults from
  :data:`dhkin.vendors.VENDOR_REFERENCES` when the robot is listed there, else base_link /
  tool0);
* ``"exact"``: the generated URDF itself.

Outcome per sample (one each, the first that applies, in this order):

* ``wrong``: a returned solution is not exact on the reference (position or rotation error above
  the tolerance plus the reference's measured deviation from the table's own model: a solution
  exact on the table is off by that much on another description), not finite, of the wrong
  length, or outside the joint limits (the solutions of the continuity call below included);
* ``no_solution``: nothing came back (every target is reachable: it was made from q);
* ``missing``: solutions came back but none is the sampled q up to in-limit 2pi shifts (joint
  difference modulo 2pi <= ``joint_tolerance``). At the wrist singularity (``|sin q5|`` <=
  :data:`~dhkin.validation.matching.WRIST_SINGULAR` in the sampled q) the pose fixes only a
  one-parameter family; an IK that takes ``q_seed`` gets the sampled q and must return it,
  while for an IK without ``q_seed`` only the joints every such family keeps (joints 1 and 5)
  are compared. Near a singularity a pose fixes q only to about (pose uncertainty) /
  sigma_min(J), so the joint tolerance there is
  ``joint_tolerance + max(POSE_ROUNDING, reference deviation, residual) / sigma_min``
  (sigma_min from Pinocchio's Jacobian at the sampled q; residual: the returned solutions'
  largest error on the reference); on a six-revolute arm a returned solution that is one root
  with q (the segment between them solves the pose at the tolerance) matches it too;
* ``missing_branch``: a branch of the complete solution set is not among the solutions, on
  any pose, whether or not the sampled q lies on it. For an arm with a closed-form family the
  branches of a pose are dhkin's own answer ``robot.ik(T, q_seed=q, copies=False)`` (one
  solution per branch), those that verify on the reference; each must be matched by a
  returned solution like the sampled q is above (mod 2pi, same widening at the branch's own
  sigma_min; on the wrist singularity, where a branch is a family, joints 1 and 5 only). For
  a six-revolute arm without one (``robot.ik_family == "general6r"``) the reference is
  independent of dhkin's IK: every isolated root (sigma_min >= 1e-6) of a multistart of Newton
  from fixed starts, verified on the reference (:mod:`dhkin.validation.multistart`), on every
  other special-angle sample, every 10th near-singular and every 100th uniform one
  (:func:`~dhkin.validation.samples.reference_samples`); each must be within the joint
  tolerance of a solution of the IK called without a seed, or one root with it (the segment
  between them solves the pose). A point where Newton stalls inside the tolerance without
  converging (a near-root: :data:`~dhkin.validation.multistart.CONVERGED`) may instead be
  tied to a solution along its valley of near-solutions (:mod:`dhkin.validation.valley`).
  Such IKs are called unseeded for every sample (a seed may choose a free joint, in the
  continuity call below; it must not find roots). Checked for
  robots with a complete IK (``robot.complete_ik``) and IKs that promise every solution
  (``complete_expected``);
* ``discontinuous``: on the singular sets (:data:`CONTINUITY_SETS`), an IK that takes ``q_seed``
  is called a second time with the seed perturbed by :data:`SEED_PERTURBATION` rad (each
  revolute joint +- at random, fixed seed, clipped to the limits); the returned solution nearest
  the perturbed seed must lie within :data:`CONTINUITY_DISTANCE` rad of it on every joint (mod
  2pi). At q5 = 0 the free joint must follow the seed, not jump;
* ``success``: none of the above.

``wrong``, ``no_solution`` and ``discontinuous`` always fail a run; ``missing`` and
``missing_branch`` fail it when the IK promises every solution.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.errors import InputError
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import pose_error
from dhkin.validation import arguments
from dhkin.validation.adapters import IKCallable, own_ik
from dhkin.validation.batched import check_all_batched
from dhkin.validation.calls import DEFAULT_CALL_TIMEOUT, IKCaller, takes_seed
from dhkin.validation.matching import configuration_labels
from dhkin.validation.multistart import RootReference, check_reference, needs_reference
from dhkin.validation.references import ReferenceSpec, TargetModel, target_model
from dhkin.validation.report import ValidationReport
from dhkin.validation.sample_checks import (
    check_continuity,
    check_sample,
    missing_branches,
    resolvable,
)
from dhkin.validation.samples import perturbed_seeds, reference_samples, sample_joint_vectors
from dhkin.validation.tally import Tally


def _progress(iterable: Iterable[Any], total: int, label: str, show: bool) -> Iterable[Any]:
    if not show:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=label, unit="pose", leave=False, file=sys.stderr)


#: Default ``joint_tolerance`` (rad, m for prismatic joints) of the missing checks.
DEFAULT_JOINT_TOLERANCE = 1e-6


@dataclass(frozen=True)
class RunSettings:
    """The checked arguments of one run (of :func:`validate` or :func:`~.rerun.replay`)."""

    seed: int
    tolerance: float
    joint_tolerance: float
    timeout: float | None
    isolate: bool
    progress: bool
    ik_name: str
    complete_expected: bool


def ik_name_of(ik: Any, given: str | None) -> str:
    if given is not None:
        return given
    try:
        return arguments.one_line(str(getattr(ik, "__name__", "ik")), 120)
    except Exception:  # a hostile __getattr__ / __str__: the IK gets a plain name
        return "ik"


def validate(robot: Arm, ik: IKCallable | None = None, n: int = 10_000, seed: int = 0,
             tolerance: float = DEFAULT_TOLERANCE,
             joint_tolerance: float = DEFAULT_JOINT_TOLERANCE,
             progress: bool = False, ik_name: str | None = None,
             complete_expected: bool | None = None,
             reference: str | Path | ReferenceSpec | None = None, base: str | None = None,
             tip: str | None = None, timeout: float | None = DEFAULT_CALL_TIMEOUT,
             isolate: bool = False, packages: Mapping[str, str | Path] | None = None
             ) -> ValidationReport:
    """Validate ``ik`` (default: dhkin's own) on ``robot``; see the module docstring.

    ``complete_expected`` (default: True, except for dhkin's own numerical IK, which returns
    one solution per call) says whether missing samples and branches fail the run.
    ``reference`` makes the targets and checks the solutions: "rounded" (default), "exact",
    "vendor" (the robot's shipped vendor URDF) or the path of a vendor URDF whose frames
    ``base`` -> ``tip`` are the table's base_link -> tool0 (defaults:
    :data:`~dhkin.vendors.VENDOR_REFERENCES`, else base_link / tool0); a xacro reference is
    expanded (``packages``: {NAME: folder} for its ``$(find NAME)``).
    ``timeout`` (s, None: no limit) bounds each IK call and ``isolate`` runs the calls in a
    child process (:mod:`dhkin.validation.calls`). Every argument is checked first
    (:mod:`dhkin.validation.arguments`): a wrong one is an InputError naming it.
    """
    if ik is not None and not callable(ik):
        raise InputError(f"ik: expected a callable ik(T) -> joint vectors (or None for "
                         f"dhkin's own), got {arguments.quoted(ik)}", field="ik",
                         value=arguments.quoted(ik), expected="a callable or None")
    n = arguments.sample_count(n)
    settings = RunSettings(
        seed=arguments.seed_value(seed), tolerance=arguments.tolerance_value(tolerance),
        joint_tolerance=arguments.joint_tolerance_value(joint_tolerance),
        timeout=arguments.timeout_value(timeout),
        isolate=bool(arguments.flag(isolate, "isolate")),
        progress=bool(arguments.flag(progress, "progress")),
        ik_name=ik_name_of(ik if ik is not None else own_ik(robot),
                         arguments.optional_text(ik_name, "ik_name")),
        complete_expected=(ik is not None or robot.complete_ik
                           if arguments.flag(complete_expected, "complete_expected",
                                             optional=True) is None
                           else bool(complete_expected)))
    model = target_model(robot, reference, base, tip, packages)
    callable_ik = own_ik(robot) if ik is None else ik
    q, sets = sample_joint_vectors(robot, n, settings.seed)
    return run_samples(robot, model, callable_ik, q, sets,
                       perturbed_seeds(robot, q, sets, settings.seed), settings,
                       batched=ik is None and robot.complete_ik and not settings.isolate)


def run_samples(robot: Arm, model: TargetModel, ik: IKCallable, q: NDArray[np.float64],
                sets: list[str], perturbed: NDArray[np.float64], settings: RunSettings,
                batched: bool = False) -> ValidationReport:
    """Check the samples ``q`` (sets ``sets``, continuity seeds ``perturbed``) of ``ik`` on
    ``model``. ``batched``: ``ik`` is dhkin's own complete IK of ``robot``
    (:func:`~dhkin.validation.adapters.own_ik`), answered in batches
    (:mod:`dhkin.validation.batched`: the same checks and figures); else pose by pose, each call
    guarded."""
    started = time.perf_counter()
    targets = model.fk(q)
    labels = configuration_labels(robot, targets, q)
    report = ValidationReport(robot=robot.name, ik_name=settings.ik_name,
                              tolerance=settings.tolerance,
                              joint_tolerance=settings.joint_tolerance, seed=settings.seed,
                              complete_expected=settings.complete_expected,
                              reference=model.spec.to_json(), samples=len(sets))
    if model.spec.kind != "exact":
        position, rotation = pose_error(targets, robot.reference().fk(q))
        report.reference_deviation = {"position_max": float(position.max()),
                                      "rotation_max": float(rotation.max())}
        model.deviation = max(report.reference_deviation.values())
    reference = (RootReference(robot, model)
                 if settings.complete_expected and needs_reference(robot) else None)
    if not (batched and check_all_batched(robot, model, q, sets, perturbed, targets, labels,
                                          settings.tolerance, settings.joint_tolerance,
                                          report, reference)):
        with IKCaller(ik, robot, settings.timeout, settings.isolate) as caller:
            _check_all(robot, model, caller, q, sets, perturbed, targets, labels, settings,
                       report, reference)
    report.seconds = time.perf_counter() - started
    return report


def _check_all(robot: Arm, model: TargetModel, caller: IKCaller, q: NDArray[np.float64],
               sets: list[str], perturbed: NDArray[np.float64], targets: NDArray[np.float64],
               labels: list[str], settings: RunSettings, report: ValidationReport,
               reference: RootReference | None) -> None:
    """Call and check every sample; fill the report's counts, residuals and failures. The IK
    gets read-only copies (see :class:`IKCaller`): ``q``, ``targets`` and ``perturbed`` stay
    the validator's own, for the checks and the failure file. ``reference``: the multistart
    reference of a general 6R arm (its IK is then called unseeded and checked against it)."""
    tolerance, joint_tolerance = settings.tolerance, settings.joint_tolerance
    tally = Tally()
    seeded = takes_seed(caller.ik)
    check_branches = settings.complete_expected and robot.complete_ik and reference is None
    referenced = reference_samples(sets)
    # an IK complete without a seed (the general 6R solver's arms) is run unseeded: a seed may
    # choose a free joint (the continuity call below), it must not find roots
    unseeded = reference is not None
    for k in _progress(range(len(sets)), len(sets), f"validate {robot.name}", settings.progress):
        call = caller(targets[k], None if unseeded else q[k])
        checked, Q = check_sample(robot, model, q[k], targets[k], call, tolerance,
                                   joint_tolerance, seeded and not unseeded)
        outcome, detail = checked.outcome, checked.detail
        tally.residuals(checked.position, checked.rotation)
        missing: list[str] = []
        if outcome == "success" and check_branches:
            report.branch_checked += 1
            lacking = missing_branches(robot, model, targets[k], q[k], checked, Q, tolerance,
                                        joint_tolerance)
            if lacking:
                missing = [name for name, _ in lacking]
                outcome = "missing_branch"
                detail = f"{len(lacking)} branch(es) not returned: " + "; ".join(
                    f"{name} (closest solution differs by {closest:.2e})"
                    for name, closest in lacking)
        if outcome == "success" and reference is not None and referenced[k]:
            report.branch_checked += 1
            outcome, detail, missing = check_reference(model, reference, targets[k], Q,
                                                       tolerance, joint_tolerance)
        returned_perturbed: list[NDArray[np.float64]] = []
        if outcome == "success" and seeded and np.all(np.isfinite(perturbed[k])):
            report.continuity_checked += 1
            outcome, detail, returned_perturbed = check_continuity(
                robot, model, caller(targets[k], perturbed[k]), targets[k], perturbed[k],
                tolerance, tally)
        tally.add(report, k, sets[k], labels[k], outcome, detail, q[k], targets[k],
                  call.solutions, checked.position, checked.rotation, perturbed[k],
                  returned_perturbed, missing)
    tally.finish(report)


#: The former private name of :func:`~dhkin.validation.sample_checks.resolvable`.
_resolvable = resolvable
