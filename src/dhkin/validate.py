"""Cross-validation of any IK callable against the oracle (Pinocchio on the generated URDF).

An IK is a callable ``ik(T) -> iterable of joint vectors``: T is a 4x4 pose base_link -> tool0
in metres, joint vectors are URDF joint values in radians (metres for prismatic joints). Two
optional keyword parameters are honoured when the callable declares them: ``q_seed`` (the sampled
joint vector is passed, so that a solver can pick free joints at a singularity from it) and
``robot`` (the :class:`~dhkin.robot.Robot` under test). :func:`adapt` wraps an IK that works in
degrees or for another tool frame.

Samples (fixed seed): ``uniform`` joint vectors within the limits; ``special`` vectors whose
joints take the special angles 0, +-pi/2, pi (those inside the limits); ``near_singular``
vectors with the wrist joint q5 in [0, 1e-6] (q5 = 0 exactly for a quarter of them). Targets
come from Pinocchio; every returned solution is checked with Pinocchio.

Outcome per sample, as in IKFast's test tooling:

* ``wrong``: a returned solution is not exact (position > tolerance m or rotation >
  tolerance rad), not finite, of the wrong length, or outside the joint limits;
* ``no_solution``: nothing came back (every target is reachable: it was made from q);
* ``missing``: solutions came back but none is the sampled q up to in-limit 2pi shifts (joint
  difference modulo 2pi <= ``joint_tolerance``). At the wrist singularity (|sin q5| <=
  :data:`WRIST_SINGULAR` in the sampled q) the pose fixes only a one-parameter family; an IK that
  takes ``q_seed`` gets the sampled q and must return it, while for an IK without ``q_seed`` only
  the joints every such family keeps (joints 1 and 5) are compared. Near a singularity a pose
  fixes q only to about (pose rounding) / sigma_min(J), so the joint tolerance there is
  ``joint_tolerance + POSE_ROUNDING / sigma_min`` (sigma_min from Pinocchio's Jacobian at the
  sampled q);
* ``success``: none of the above.
"""

from __future__ import annotations

import importlib
import inspect
import json
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.errors import DhkinError, FamilyError
from dhkin.ik.closed_form import wrap_revolute
from dhkin.robot import Robot
from dhkin.transforms import invert, pose_error

IKCallable = Callable[..., Iterable[ArrayLike]]
SAMPLE_SETS: tuple[str, ...] = ("uniform", "special", "near_singular")
OUTCOMES: tuple[str, ...] = ("success", "wrong", "no_solution", "missing")
SPECIAL_ANGLES = (0.0, np.pi / 2, -np.pi / 2, np.pi)
#: Wrist joint (0-based) whose zero is the wrist singularity of both closed-form families.
WRIST_JOINT = 4
NEAR_SINGULAR_MAX = 1e-6
#: |sin q5| at or below which a sample is on the wrist singularity for the missing check.
WRIST_SINGULAR = 1e-6
#: Pose rounding (m and rad) of a target computed in floating point, a few ulps of a 1 m arm:
#: the joint difference a pose cannot resolve is about POSE_ROUNDING / sigma_min(J).
POSE_ROUNDING = 1e-14
#: Joints (0-based) compared at the wrist singularity for an IK that takes no seed.
SINGULAR_FAMILY_FIXED_JOINTS = (0, 4)


class ValidationInputError(DhkinError, ValueError):
    """A validation was asked with bad arguments (IK spec, sample count, replay file...)."""


@dataclass(frozen=True)
class SampleResult:
    """What happened to one sample."""

    index: int
    sample_set: str
    q_sampled: list[float]
    target: list[list[float]]
    returned: list[list[float]]
    position_errors: list[float]
    rotation_errors: list[float]
    outcome: str
    detail: str = ""
    configuration: str = ""


@dataclass
class ValidationReport:
    """Rates, residual statistics and failures of one validation run."""

    robot: str
    ik_name: str
    tolerance: float
    joint_tolerance: float
    seed: int
    #: Whether the IK promises every solution; if not, "missing" samples do not fail the run.
    complete_expected: bool = True
    samples: int = 0
    counts: dict[str, int] = field(default_factory=dict)
    by_set: dict[str, dict[str, int]] = field(default_factory=dict)
    by_configuration: dict[str, dict[str, int]] = field(default_factory=dict)
    solution_counts: dict[str, float] = field(default_factory=dict)
    residuals: dict[str, float] = field(default_factory=dict)
    seconds: float = 0.0
    failures: list[SampleResult] = field(default_factory=list)

    def rate(self, outcome: str) -> float:
        return self.counts.get(outcome, 0) / self.samples if self.samples else 0.0

    @property
    def ok(self) -> bool:
        """No wrong, no unsolved, and (when completeness is expected) no missing sample."""
        failing = self.counts.get("wrong", 0) + self.counts.get("no_solution", 0)
        if self.complete_expected:
            failing += self.counts.get("missing", 0)
        return self.samples > 0 and failing == 0

    def summary(self) -> str:
        """Plain-text report: rates, per set, per configuration, residuals, counts."""
        lines = [f"{self.robot}: {self.ik_name} on {self.samples} samples (seed {self.seed}, "
                 f"tolerance {self.tolerance:.0e} m / rad, {self.seconds:.1f} s)"]
        lines.append("  " + "  ".join(f"{o} {100 * self.rate(o):.3f}% ({self.counts.get(o, 0)})"
                                      for o in OUTCOMES))
        for name, counts in self.by_set.items():
            total = sum(counts.values())
            lines.append(f"  {name:14s} {total:6d} samples: " + ", ".join(
                f"{o} {counts.get(o, 0)}" for o in OUTCOMES))
        for name, counts in self.by_configuration.items():
            total = sum(counts.values())
            lines.append(f"  {name:40s} {total:6d}: " + ", ".join(
                f"{o} {counts.get(o, 0)}" for o in OUTCOMES if counts.get(o, 0)))
        r, c = self.residuals, self.solution_counts
        lines.append(f"  residuals: position max {r.get('position_max', 0):.2e} m, median "
                     f"{r.get('position_median', 0):.2e}; rotation max "
                     f"{r.get('rotation_max', 0):.2e} rad, median "
                     f"{r.get('rotation_median', 0):.2e}")
        lines.append(f"  solutions per pose: min {c.get('min', 0):.0f}, median "
                     f"{c.get('median', 0):.0f}, max {c.get('max', 0):.0f}")
        if not self.complete_expected:
            lines.append("  (this IK returns one solution per call: missing samples are "
                         "reported, not failed)")
        lines.append("  PASS" if self.ok else f"  FAIL: {len(self.failures)} failing samples")
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["rates"] = {o: self.rate(o) for o in OUTCOMES}
        data["ok"] = self.ok
        return data

    def markdown(self) -> str:
        """A Markdown report (for --report)."""
        rows = ["| outcome | samples | rate |", "|---|---:|---:|"]
        rows += [f"| {o} | {self.counts.get(o, 0)} | {100 * self.rate(o):.3f} % |"
                 for o in OUTCOMES]
        sets = ["| sample set | " + " | ".join(OUTCOMES) + " |",
                "|---|" + "---:|" * len(OUTCOMES)]
        sets += [f"| {name} | " + " | ".join(str(c.get(o, 0)) for o in OUTCOMES) + " |"
                 for name, c in self.by_set.items()]
        configs = ["| configuration | " + " | ".join(OUTCOMES) + " |",
                   "|---|" + "---:|" * len(OUTCOMES)]
        configs += [f"| {name} | " + " | ".join(str(c.get(o, 0)) for o in OUTCOMES) + " |"
                    for name, c in self.by_configuration.items()]
        r, c = self.residuals, self.solution_counts
        return "\n".join([
            f"# IK validation: {self.robot}, {self.ik_name}", "",
            f"{self.samples} samples, seed {self.seed}, tolerance {self.tolerance:.0e} m / rad, "
            f"joint tolerance {self.joint_tolerance:.0e}, {self.seconds:.1f} s. "
            f"Verdict: **{'PASS' if self.ok else 'FAIL'}**.", "", *rows, "", *sets, "",
            *configs, "",
            f"Residuals: position max {r.get('position_max', 0):.2e} m (median "
            f"{r.get('position_median', 0):.2e}), rotation max {r.get('rotation_max', 0):.2e} "
            f"rad (median {r.get('rotation_median', 0):.2e}).", "",
            f"Solutions per pose: min {c.get('min', 0):.0f}, median {c.get('median', 0):.0f}, "
            f"max {c.get('max', 0):.0f}.", ""])


# --------------------------------------------------------------------------------------------
# Sampling


def sample_joint_vectors(robot: Robot, n: int, seed: int) -> tuple[NDArray[np.float64],
                                                                    list[str]]:
    """n uniform + n/10 special-angle + n/10 near-singular joint vectors (at least 1 each)."""
    if n < 1:
        raise ValidationInputError(f"n: expected at least 1 sample, got {n}")
    rng = np.random.default_rng(seed)
    lower, upper = robot.lower, robot.upper
    extra = max(1, n // 10)
    uniform = robot.table.random_q(n, rng)
    special = robot.table.random_q(extra, rng)
    for k, joint in enumerate(robot.table.joints):
        choices = [a for a in SPECIAL_ANGLES if joint.is_revolute and lower[k] <= a <= upper[k]]
        if choices:
            special[:, k] = rng.choice(choices, size=extra)
    sets = ["uniform"] * n + ["special"] * extra
    parts = [uniform, special]
    if robot.dof > WRIST_JOINT and robot.table.joints[WRIST_JOINT].is_revolute:
        near = robot.table.random_q(extra, rng)
        magnitude = rng.uniform(0.0, NEAR_SINGULAR_MAX, size=extra)
        magnitude[: extra // 4] = 0.0
        sign = rng.choice([-1.0, 1.0], size=extra)
        near[:, WRIST_JOINT] = np.clip(sign * magnitude, lower[WRIST_JOINT], upper[WRIST_JOINT])
        parts.append(near)
        sets += ["near_singular"] * extra
    return np.vstack(parts), sets


# --------------------------------------------------------------------------------------------
# Adapters and loading


def adapt(ik: IKCallable, degrees: bool = False, tool: ArrayLike | None = None) -> IKCallable:
    """Wrap a user IK: ``degrees`` -> it returns degrees (revolute and prismatic alike are
    converted, so use it for all-revolute arms); ``tool`` (4x4, tool0 -> the user's tool frame)
    -> it expects targets of that frame: T_user = T_tool0 @ tool."""
    tool_frame = None if tool is None else np.asarray(tool, dtype=float)

    def convert(T: NDArray[np.float64], **kwargs: Any) -> list[NDArray[np.float64]]:
        target = T if tool_frame is None else T @ tool_frame
        solutions = [np.asarray(q, dtype=float) for q in ik(target, **kwargs)]
        return [np.radians(q) for q in solutions] if degrees else solutions

    def adapted_seeded(T: NDArray[np.float64],
                       q_seed: NDArray[np.float64] | None = None) -> list[NDArray[np.float64]]:
        seed = None if q_seed is None else (np.degrees(q_seed) if degrees else q_seed)
        return convert(T, q_seed=seed)

    def adapted_plain(T: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        return convert(T)

    # Offer q_seed only when the wrapped IK takes it: the validator's missing check depends on it.
    adapted = adapted_seeded if _takes_seed(ik) else adapted_plain
    adapted.__name__ = getattr(ik, "__name__", "ik") + ("[deg]" if degrees else "")
    return adapted


def own_ik(robot: Robot) -> IKCallable:
    """dhkin's own IK of ``robot`` as a validation callable.

    The closed-form IK takes the sampled q as seed (it only uses it for free joints at a
    singularity). The numerical IK gets no seed: starting at the answer would prove nothing.
    """
    if not robot.has_closed_form:
        def numerical(T: NDArray[np.float64]) -> NDArray:
            return robot.ik(T).q

        numerical.__name__ = f"dhkin:{robot.name} (numerical)"
        return numerical

    def ik(T: NDArray[np.float64], q_seed: NDArray[np.float64] | None = None) -> NDArray:
        return robot.ik(T, q_seed=q_seed).q

    ik.__name__ = f"dhkin:{robot.name}"
    return ik


def load_ik(spec: str) -> IKCallable:
    """'package.module:function' -> the callable (the working directory is importable)."""
    if ":" not in spec:
        raise ValidationInputError(f"--ik: expected 'module:function', got {spec!r}")
    module_name, function_name = spec.split(":", 1)
    if str(Path.cwd()) not in sys.path:
        sys.path.insert(0, str(Path.cwd()))
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ValidationInputError(f"--ik: cannot import module {module_name!r} ({exc})") from exc
    function = getattr(module, function_name, None)
    if not callable(function):
        raise ValidationInputError(f"--ik: {module_name!r} has no callable {function_name!r}")
    return function


def _takes_seed(ik: IKCallable) -> bool:
    return "q_seed" in inspect.signature(ik).parameters


def _call(ik: IKCallable, robot: Robot, T: NDArray[np.float64],
          q_sampled: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    parameters = inspect.signature(ik).parameters
    kwargs: dict[str, Any] = {}
    if "q_seed" in parameters:
        kwargs["q_seed"] = q_sampled
    if "robot" in parameters:
        kwargs["robot"] = robot
    result = ik(T, **kwargs)
    if isinstance(result, np.ndarray) and result.ndim == 2:
        return list(result.astype(float, copy=False))
    return [np.asarray(q, dtype=float).reshape(-1) for q in result]


# --------------------------------------------------------------------------------------------
# Checking


def _configuration_labels(robot: Robot, targets: NDArray[np.float64],
                          q: NDArray[np.float64]) -> list[str]:
    """Configuration of each sampled q according to dhkin's closed-form solver ('' if none)."""
    try:
        batch = robot.ik_batch_detailed(targets)
    except FamilyError:
        return [""] * q.shape[0]
    labels = []
    for k in range(q.shape[0]):
        candidates = batch.q[k][batch.valid[k]]
        branches = batch.branch[k][batch.valid[k]]
        if candidates.shape[0] == 0:
            labels.append("unlabelled")
            continue
        difference = wrap_revolute(robot.table, candidates - q[k])
        best = int(np.argmin(np.abs(difference).max(axis=1)))
        label = batch.branch_labels[branches[best]]
        labels.append(" ".join(f"{key}={value}" for key, value in label.items()))
    return labels


def _compared_joints(robot: Robot, q_sampled: NDArray[np.float64],
                     seeded: bool) -> NDArray[np.int64]:
    """Joints the missing check compares (all, except at the wrist singularity without seed)."""
    wrist_singular = (robot.dof > WRIST_JOINT
                      and abs(np.sin(q_sampled[WRIST_JOINT])) <= WRIST_SINGULAR)
    if wrist_singular and not seeded:
        return np.array(SINGULAR_FAMILY_FIXED_JOINTS)
    return np.arange(robot.dof)


@dataclass(frozen=True)
class _Checked:
    """Outcome of one sample before it is turned into a (JSON-ready) SampleResult."""

    outcome: str
    detail: str
    position: NDArray[np.float64]
    rotation: NDArray[np.float64]


def _resolvable(robot: Robot, q: NDArray[np.float64], joint_tolerance: float) -> float:
    """Joint distance under which two solutions of one pose count as the same at q:
    joint_tolerance + POSE_ROUNDING / sigma_min of Pinocchio's Jacobian (6 x n) at q."""
    sigma = np.linalg.svd(robot.reference().jacobian(q), compute_uv=False)
    return joint_tolerance + POSE_ROUNDING / max(float(sigma.min()), 1e-300)


def _check_sample(robot: Robot, q_sampled: NDArray[np.float64], T: NDArray[np.float64],
                  returned: list[NDArray[np.float64]], tolerance: float, joint_tolerance: float,
                  seeded: bool) -> _Checked:
    dof = robot.dof
    if all(s.shape == (dof,) for s in returned):
        stacked = np.array(returned).reshape(len(returned), dof)
        Q = stacked[np.isfinite(stacked).all(axis=1)]
    else:
        Q = np.array([s for s in returned if s.shape == (dof,) and np.all(np.isfinite(s))])
    position: NDArray[np.float64] = np.zeros(0)
    rotation: NDArray[np.float64] = np.zeros(0)
    if len(Q):
        position, rotation = pose_error(robot.reference().fk(Q), np.broadcast_to(T, (len(Q), 4, 4)))
    if len(Q) < len(returned):
        bad = len(returned) - len(Q)
        return _Checked("wrong", f"{bad} solution(s) not finite or not {dof} values", position,
                        rotation)
    if not returned:
        return _Checked("no_solution", "nothing returned for a reachable target", position,
                        rotation)
    if not np.all(robot.table.in_limits(Q)):
        return _Checked("wrong", "a solution lies outside the joint limits", position, rotation)
    if position.max() > tolerance or rotation.max() > tolerance:
        return _Checked("wrong", f"residual {position.max():.2e} m / {rotation.max():.2e} rad",
                        position, rotation)
    difference = wrap_revolute(robot.table, Q - q_sampled)
    closest = np.abs(difference[:, _compared_joints(robot, q_sampled, seeded)]).max(axis=1).min()
    if closest > joint_tolerance and closest > _resolvable(robot, q_sampled, joint_tolerance):
        return _Checked("missing", f"closest returned solution differs by {closest:.2e} "
                                   "(mod 2pi)", position, rotation)
    return _Checked("success", "", position, rotation)


def _progress(iterable: Iterable[Any], total: int, label: str, show: bool) -> Iterable[Any]:
    if not show:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=label, unit="pose", leave=False, file=sys.stderr)


def validate(robot: Robot, ik: IKCallable | None = None, n: int = 10_000, seed: int = 0,
             tolerance: float = 1e-9, joint_tolerance: float = 1e-6,
             progress: bool = False, ik_name: str | None = None,
             complete_expected: bool | None = None) -> ValidationReport:
    """Validate ``ik`` (default: dhkin's own) on ``robot``; see the module docstring.

    ``complete_expected`` (default: True, except for dhkin's own numerical IK, which returns
    one solution per call) says whether missing samples fail the run.
    """
    callable_ik = own_ik(robot) if ik is None else ik
    if complete_expected is None:
        complete_expected = ik is not None or robot.has_closed_form
    q, sets = sample_joint_vectors(robot, n, seed)
    return _run(robot, callable_ik, q, sets, seed, tolerance, joint_tolerance, progress,
                ik_name or getattr(callable_ik, "__name__", "ik"), complete_expected)


def _run(robot: Robot, ik: IKCallable, q: NDArray[np.float64], sets: list[str], seed: int,
         tolerance: float, joint_tolerance: float, progress: bool,
         ik_name: str, complete_expected: bool = True) -> ValidationReport:
    started = time.perf_counter()
    targets = robot.reference().fk(q)
    labels = _configuration_labels(robot, targets, q)
    report = ValidationReport(robot=robot.name, ik_name=ik_name, tolerance=tolerance,
                              joint_tolerance=joint_tolerance, seed=seed,
                              complete_expected=complete_expected, samples=len(sets))
    counts: Counter[str] = Counter()
    by_set: dict[str, Counter[str]] = {}
    by_configuration: dict[str, Counter[str]] = {}
    all_position, all_rotation, n_solutions = [], [], []
    seeded = _takes_seed(ik)
    for k in _progress(range(len(sets)), len(sets), f"validate {robot.name}", progress):
        try:
            returned = _call(ik, robot, targets[k], q[k])
        except DhkinError as exc:
            returned, error = [], f"raised {type(exc).__name__}: {exc}"
        else:
            error = ""
        checked = _check_sample(robot, q[k], targets[k], returned, tolerance, joint_tolerance,
                                seeded)
        counts[checked.outcome] += 1
        by_set.setdefault(sets[k], Counter())[checked.outcome] += 1
        if labels[k]:
            by_configuration.setdefault(labels[k], Counter())[checked.outcome] += 1
        all_position.append(checked.position)
        all_rotation.append(checked.rotation)
        n_solutions.append(len(returned))
        if checked.outcome != "success":
            report.failures.append(SampleResult(
                index=k, sample_set=sets[k], q_sampled=q[k].tolist(), target=targets[k].tolist(),
                returned=[r.tolist() for r in returned],
                position_errors=checked.position.tolist(),
                rotation_errors=checked.rotation.tolist(), outcome=checked.outcome,
                detail=error or checked.detail, configuration=labels[k]))
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
    report.seconds = time.perf_counter() - started
    return report


# --------------------------------------------------------------------------------------------
# Failure files


def write_failures(report: ValidationReport, path: str | Path) -> Path:
    """Write the failing samples as JSON (robot, tolerance, and per sample: set, sampled q,
    target pose, what came back, residuals, outcome) for ``dhkin validate --replay``."""
    file = Path(path)
    file.write_text(json.dumps({
        "robot": report.robot, "ik": report.ik_name, "tolerance": report.tolerance,
        "joint_tolerance": report.joint_tolerance, "seed": report.seed,
        "failures": [asdict(f) for f in report.failures],
    }, indent=1), encoding="utf-8")
    return file


def replay(robot: Robot, ik: IKCallable, path: str | Path,
           ik_name: str | None = None) -> ValidationReport:
    """Rerun the samples of a failure file with ``ik`` and check them again."""
    file = Path(path)
    try:
        data: Mapping[str, Any] = json.loads(file.read_text(encoding="utf-8"))
        failures = data["failures"]
        q = np.array([f["q_sampled"] for f in failures], dtype=float).reshape(-1, robot.dof)
        sets = [str(f["sample_set"]) for f in failures]
        tolerance = float(data["tolerance"])
        joint_tolerance = float(data["joint_tolerance"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValidationInputError(f"{file}: not a dhkin failure file ({exc}); expected the JSON "
                                   "written by `dhkin validate --failures`") from exc
    if data.get("robot") != robot.name:
        raise ValidationInputError(f"{file}: failures of robot {data.get('robot')!r}, "
                                   f"expected {robot.name!r}")
    if not failures:
        raise ValidationInputError(f"{file}: no failures to replay")
    return _run(robot, ik, q, sets, int(data.get("seed", 0)), tolerance, joint_tolerance, False,
                ik_name or getattr(ik, "__name__", "ik"))


def tool_frame_from_robot(robot: Robot, frame: str) -> NDArray[np.float64]:
    """tool0 -> ``frame`` of the generated URDF (constant), for :func:`adapt`'s ``tool``."""
    reference = robot.reference()
    q = np.zeros(robot.dof)
    return invert(reference.fk(q, "tool0")) @ reference.fk(q, frame)


__all__ = ["SAMPLE_SETS", "ValidationReport", "adapt", "load_ik", "own_ik", "replay",
           "validate", "write_failures"]
