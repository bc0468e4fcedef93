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
  largest error on the reference);
* ``missing_branch``: a branch of the complete solution set is not among the solutions, on
  any pose, whether or not the sampled q lies on it. The branches of a pose are dhkin's own
  complete answer ``robot.ik(T, q_seed=q, copies=False)``: the closed-form family's (one
  solution per branch), or for six-revolute arms without a family the general 6R solver's
  (every root; dhkin.ik.general6r); those that verify on the reference. Each must be matched
  by a returned solution like the sampled q is above (mod 2pi, same widening at the branch's
  own sigma_min; on the wrist singularity, where a branch is a family, joints 1 and 5 only).
  Checked for robots with a complete IK (``robot.complete_ik``) and IKs that promise every
  solution (``complete_expected``);
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
from collections import Counter
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.errors import DhkinError, InputError
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import pose_error
from dhkin.validation import arguments
from dhkin.validation.adapters import IKCallable, own_ik
from dhkin.validation.calls import DEFAULT_CALL_TIMEOUT, CallResult, IKCaller, takes_seed
from dhkin.validation.matching import (
    SINGULAR_FAMILY_FIXED_JOINTS,
    configuration_labels,
    nearest_distances,
    residuals,
    wrap,
    wrist_singular,
)
from dhkin.validation.references import ReferenceSpec, TargetModel, target_model
from dhkin.validation.report import OUTCOMES, SampleResult, ValidationReport
from dhkin.validation.samples import (
    CONTINUITY_DISTANCE,
    SEED_PERTURBATION,
    perturbed_seeds,
    sample_joint_vectors,
)

#: Pose rounding (m and rad) of a target computed in floating point, a few ulps of a 1 m arm:
#: the joint difference a pose cannot resolve is about POSE_ROUNDING / sigma_min(J).
POSE_ROUNDING = 1e-14


def _compared_joints(robot: Arm, q_sampled: NDArray[np.float64],
                     seeded: bool) -> NDArray[np.int64]:
    """Joints the missing check compares (all, except at the wrist singularity without seed)."""
    if wrist_singular(robot, q_sampled) and not seeded:
        return np.array(SINGULAR_FAMILY_FIXED_JOINTS)
    return np.arange(robot.dof)


@dataclass(frozen=True)
class _Checked:
    """Outcome of one sample before it is turned into a (JSON-ready) SampleResult."""

    outcome: str
    detail: str
    position: NDArray[np.float64]
    rotation: NDArray[np.float64]


def _resolvable(robot: Arm, q: NDArray[np.float64], joint_tolerance: float,
                noise: float = POSE_ROUNDING) -> float:
    """Joint distance under which two solutions of one pose count as the same at q:
    joint_tolerance + noise / sigma_min of Pinocchio's Jacobian (6 x n) at q, with ``noise``
    the pose's uncertainty: its rounding, or the reference's deviation from the table's model
    (a vendor description's target is a pose of the vendor's model, not exactly of ours)."""
    sigma = np.linalg.svd(robot.reference().jacobian(q), compute_uv=False)
    return joint_tolerance + noise / max(float(sigma.min()), 1e-300)


def _matched(robot: Arm, model: TargetModel, Q: NDArray[np.float64], q: NDArray[np.float64],
             joints: NDArray[np.int64], joint_tolerance: float,
             residual: float = 0.0) -> tuple[bool, float]:
    """Whether some row of Q is q (mod 2pi on ``joints``, widened by :func:`_resolvable` with
    the pose's uncertainty: the reference's deviation, or the residual of the solutions (two
    joint vectors within r of one pose can differ by ~r / sigma_min))."""
    closest = float(np.abs(wrap(robot, Q - q)[:, joints]).max(axis=1).min())
    noise = max(POSE_ROUNDING, model.deviation, residual)
    found = closest <= joint_tolerance or closest <= _resolvable(robot, q, joint_tolerance, noise)
    return found, closest


def _verify(robot: Arm, model: TargetModel, T: NDArray[np.float64],
            returned: list[NDArray[np.float64]], tolerance: float
            ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], str]:
    """Finite solutions, their residuals on the reference, and what is wrong with them ('')."""
    dof = robot.dof
    shaped = [s for s in returned if s.shape == (dof,)]
    Q = np.array(shaped, dtype=float).reshape(len(shaped), dof)
    Q = Q[np.all(np.isfinite(Q), axis=1)]
    position: NDArray[np.float64] = np.zeros(0)
    rotation: NDArray[np.float64] = np.zeros(0)
    if len(Q):
        position, rotation = pose_error(model.fk(Q), np.broadcast_to(T, (len(Q), 4, 4)))
    if len(Q) < len(returned):
        return Q, position, rotation, (f"{len(returned) - len(Q)} solution(s) not finite or "
                                       f"not {dof} values")
    if len(Q) and not np.all(robot.table.in_limits(Q)):
        return Q, position, rotation, "a solution lies outside the joint limits"
    allowed = tolerance + model.deviation
    if len(Q) and (position.max() > allowed or rotation.max() > allowed):
        return Q, position, rotation, (f"residual {position.max():.2e} m / "
                                       f"{rotation.max():.2e} rad (allowed {allowed:.2e}: the "
                                       f"tolerance + the reference's deviation from the table)")
    return Q, position, rotation, ""


def _check_sample(robot: Arm, model: TargetModel, q_sampled: NDArray[np.float64],
                  T: NDArray[np.float64], call: CallResult, tolerance: float,
                  joint_tolerance: float, seeded: bool) -> tuple[_Checked, NDArray[np.float64]]:
    """wrong / no_solution / missing / success of the first call, and its finite solutions."""
    returned = call.solutions
    if call.problem:  # it raised, exited, timed out, or returned no list of joint vectors
        empty = np.zeros(0)
        return _Checked(call.outcome, call.problem, empty, empty), np.zeros((0, robot.dof))
    Q, position, rotation, problem = _verify(robot, model, T, returned, tolerance)
    if problem:
        return _Checked("wrong", problem, position, rotation), Q
    if not returned:
        return _Checked("no_solution", "nothing returned for a reachable target", position,
                        rotation), Q
    residual = float(max(position.max(), rotation.max())) if len(Q) else 0.0
    found, closest = _matched(robot, model, Q, q_sampled,
                              _compared_joints(robot, q_sampled, seeded), joint_tolerance,
                              residual)
    if not found:
        return _Checked("missing", f"closest returned solution differs by {closest:.2e} "
                                   "(mod 2pi)", position, rotation), Q
    return _Checked("success", "", position, rotation), Q


def _missing_branches(robot: Arm, model: TargetModel, T: NDArray[np.float64],
                      q_sampled: NDArray[np.float64], checked: _Checked, Q: NDArray[np.float64],
                      tolerance: float, joint_tolerance: float) -> list[tuple[str, float]]:
    """(configuration, closest distance) of each branch of T (closed form or general 6R) that
    Q lacks (``checked``: Q's residuals on the reference, reused for a branch equal to a row).

    The branches are ``robot.ik(T, q_seed=q_sampled, copies=False)``, those that verify on the
    reference. A branch on the wrist singularity is a one-parameter family: only joints 1 and 5
    are compared there. A branch is matched like the sampled q (:func:`_matched`, with the
    sigma_min widening at the branch where the plain joint tolerance does not do).
    """
    try:
        branches = robot.ik(T, q_seed=q_sampled, copies=False)
    except DhkinError:
        return []
    if not len(branches):
        return []
    position, rotation = residuals(model, T, branches.q, Q, checked.position, checked.rotation)
    allowed = tolerance + model.deviation
    verified = np.flatnonzero((position <= allowed) & (rotation <= allowed))
    rows = branches.q[verified]
    closest = nearest_distances(robot, Q, rows, wrist_singular(robot, rows))
    noise = max(POSE_ROUNDING, model.deviation)
    missing = []
    for k, distance in zip(verified, closest, strict=True):
        if distance <= joint_tolerance or distance <= _resolvable(
                robot, branches.q[k], joint_tolerance, noise):
            continue
        name = (str(branches.configurations[k]) if k < len(branches.configurations)
                else f"branch {k}")
        missing.append((name, float(distance)))
    return missing


def _nearest_to_seed(robot: Arm, Q: NDArray[np.float64],
                     seed: NDArray[np.float64]) -> tuple[float, int]:
    """Largest joint distance (mod 2pi) of the solution nearest ``seed``, and its joint."""
    distance = np.abs(wrap(robot, Q - seed))
    best = int(np.argmin(distance.max(axis=1)))
    joint = int(np.argmax(distance[best]))
    return float(distance[best, joint]), joint


def _progress(iterable: Iterable[Any], total: int, label: str, show: bool) -> Iterable[Any]:
    if not show:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=label, unit="pose", leave=False, file=sys.stderr)


#: Returned solutions a failure record keeps (per call): every 2pi copy of the 16 branches of
#: a UR-type arm with +-360 deg joints (16 * 2^6), while an IK returning up to
#: MAX_SOLUTIONS_PER_CALL rows on every pose cannot make the report hold gigabytes.
FAILURE_SOLUTIONS_KEPT = 1024


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
                perturbed_seeds(robot, q, sets, settings.seed), settings)


def run_samples(robot: Arm, model: TargetModel, ik: IKCallable, q: NDArray[np.float64],
         sets: list[str], perturbed: NDArray[np.float64],
         settings: RunSettings) -> ValidationReport:
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
    with IKCaller(ik, robot, settings.timeout, settings.isolate) as caller:
        _check_all(robot, model, caller, q, sets, perturbed, targets, labels, settings, report)
    report.seconds = time.perf_counter() - started
    return report


def _check_all(robot: Arm, model: TargetModel, caller: IKCaller, q: NDArray[np.float64],
               sets: list[str], perturbed: NDArray[np.float64], targets: NDArray[np.float64],
               labels: list[str], settings: RunSettings, report: ValidationReport) -> None:
    """Call and check every sample; fill the report's counts, residuals and failures. The IK
    gets read-only copies (see :class:`IKCaller`): ``q``, ``targets`` and ``perturbed`` stay
    the validator's own, for the checks and the failure file."""
    tolerance, joint_tolerance = settings.tolerance, settings.joint_tolerance
    counts: Counter[str] = Counter()
    by_set: dict[str, Counter[str]] = {}
    by_configuration: dict[str, Counter[str]] = {}
    all_position, all_rotation, n_solutions = [], [], []
    seeded = takes_seed(caller.ik)
    check_branches = settings.complete_expected and robot.complete_ik
    for k in _progress(range(len(sets)), len(sets), f"validate {robot.name}", settings.progress):
        call = caller(targets[k], q[k])
        returned = call.solutions
        checked, Q = _check_sample(robot, model, q[k], targets[k], call, tolerance,
                                   joint_tolerance, seeded)
        outcome, detail = checked.outcome, checked.detail
        all_position.append(checked.position)
        all_rotation.append(checked.rotation)
        missing: list[str] = []
        if outcome == "success" and check_branches:
            report.branch_checked += 1
            lacking = _missing_branches(robot, model, targets[k], q[k], checked, Q, tolerance,
                                        joint_tolerance)
            if lacking:
                missing = [name for name, _ in lacking]
                outcome = "missing_branch"
                detail = f"{len(lacking)} branch(es) not returned: " + "; ".join(
                    f"{name} (closest solution differs by {closest:.2e})"
                    for name, closest in lacking)
        returned_perturbed: list[NDArray[np.float64]] = []
        if outcome == "success" and seeded and np.all(np.isfinite(perturbed[k])):
            report.continuity_checked += 1
            outcome, detail, returned_perturbed = _check_continuity(
                robot, model, caller, targets[k], perturbed[k], tolerance, all_position,
                all_rotation)
        counts[outcome] += 1
        by_set.setdefault(sets[k], Counter())[outcome] += 1
        if labels[k]:
            by_configuration.setdefault(labels[k], Counter())[outcome] += 1
        n_solutions.append(len(returned))
        if outcome != "success":
            if max(len(returned), len(returned_perturbed)) > FAILURE_SOLUTIONS_KEPT:
                detail += (f" (the failure keeps the first {FAILURE_SOLUTIONS_KEPT} of "
                           f"{max(len(returned), len(returned_perturbed))} solutions)")
            report.failures.append(SampleResult(
                index=k, sample_set=sets[k], q_sampled=q[k].tolist(), target=targets[k].tolist(),
                returned=[r.tolist() for r in returned[:FAILURE_SOLUTIONS_KEPT]],
                position_errors=checked.position.tolist(),
                rotation_errors=checked.rotation.tolist(), outcome=outcome, detail=detail,
                configuration=labels[k],
                perturbed_seed=(perturbed[k].tolist() if np.all(np.isfinite(perturbed[k]))
                                else []),
                returned_perturbed=[r.tolist()
                                    for r in returned_perturbed[:FAILURE_SOLUTIONS_KEPT]],
                missing_branches=missing))
    report.counts = {o: counts.get(o, 0) for o in OUTCOMES}
    report.by_set = {s: dict(c) for s, c in by_set.items()}
    report.by_configuration = {s: dict(c) for s, c in sorted(by_configuration.items())}
    report.solution_counts = {"min": float(min(n_solutions)), "max": float(max(n_solutions)),
                              "median": float(np.median(n_solutions))}
    position, rotation = np.concatenate(all_position), np.concatenate(all_rotation)
    if position.size:
        report.residuals = {
            "position_max": float(position.max()), "position_median": float(np.median(position)),
            "rotation_max": float(rotation.max()), "rotation_median": float(np.median(rotation)),
        }


def _check_continuity(robot: Arm, model: TargetModel, caller: IKCaller, T: NDArray[np.float64],
                      seed: NDArray[np.float64], tolerance: float,
                      all_position: list[NDArray[np.float64]],
                      all_rotation: list[NDArray[np.float64]]
                      ) -> tuple[str, str, list[NDArray[np.float64]]]:
    """Second call with the perturbed seed: (outcome, detail, what came back)."""
    call = caller(T, seed)
    returned = call.solutions
    if call.problem:
        outcome = "wrong" if call.outcome == "wrong" else "discontinuous"
        return outcome, f"with the perturbed seed: {call.problem}", returned
    Q, position, rotation, problem = _verify(robot, model, T, returned, tolerance)
    all_position.append(position)
    all_rotation.append(rotation)
    if problem:
        return "wrong", f"with the perturbed seed: {problem}", returned
    if not len(Q):
        return "discontinuous", "nothing returned for the perturbed seed", returned
    distance, joint = _nearest_to_seed(robot, Q, seed)
    if distance > CONTINUITY_DISTANCE:
        return ("discontinuous", f"with the seed perturbed by +-{SEED_PERTURBATION} rad the "
                f"nearest solution is {distance:.3f} from it on joint {joint + 1} (allowed "
                f"{CONTINUITY_DISTANCE})", returned)
    return "success", "", returned
