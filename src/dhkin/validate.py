"""Cross-validation of any IK callable against an oracle: Pinocchio on a *reference description*.

An IK is a callable ``ik(T) -> iterable of joint vectors``: T is a 4x4 pose base_link -> tool0
in metres, joint vectors are URDF joint values in radians (metres for prismatic joints). Two
optional keyword parameters are honoured when the callable declares them: ``q_seed`` (the sampled
joint vector is passed, so that a solver can pick free joints at a singularity from it) and
``robot`` (the robot under test: a :class:`dhkin.robot.Robot`, or any
:class:`~dhkin.arm.Arm`). :func:`adapt` wraps an IK that works in degrees or for another tool
frame.

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
* a vendor URDF (a path) with its ``base`` and ``tip`` frames (defaults from
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
  difference modulo 2pi <= ``joint_tolerance``). At the wrist singularity (|sin q5| <=
  :data:`WRIST_SINGULAR` in the sampled q) the pose fixes only a one-parameter family; an IK that
  takes ``q_seed`` gets the sampled q and must return it, while for an IK without ``q_seed`` only
  the joints every such family keeps (joints 1 and 5) are compared. Near a singularity a pose
  fixes q only to about (pose uncertainty) / sigma_min(J), so the joint tolerance there is
  ``joint_tolerance + max(POSE_ROUNDING, reference deviation, residual) / sigma_min``
  (sigma_min from Pinocchio's Jacobian at the sampled q; residual: the returned solutions'
  largest error on the reference);
* ``missing_branch``: a branch of the closed-form solution set is not among the solutions, on
  any pose, whether or not the sampled q lies on it. The branches of a pose are dhkin's own
  closed-form answer ``robot.ik(T, q_seed=q, copies=False)`` (one solution per branch; those
  that verify on the reference); each must be matched by a returned solution like the sampled q
  is above (mod 2pi, same widening at the branch's own sigma_min; on the wrist singularity, where
  a branch is a family, joints 1 and 5 only). Checked for robots with a closed-form family and
  IKs that promise every solution (``complete_expected``);
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

import importlib
import inspect
import json
import re
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.arm import Arm
from dhkin.errors import DhkinError, FamilyError, InputError, URDFError
from dhkin.reference import Reference
from dhkin.transforms import invert, pose_error
from dhkin.vendors import VENDOR_REFERENCES

IKCallable = Callable[..., Iterable[ArrayLike]]
SAMPLE_SETS: tuple[str, ...] = ("uniform", "special", "near_singular")
OUTCOMES: tuple[str, ...] = ("success", "wrong", "no_solution", "missing", "missing_branch",
                             "discontinuous")
#: Outcomes that fail a run only when the IK promises every solution (complete_expected).
COMPLETENESS_OUTCOMES: tuple[str, ...] = ("missing", "missing_branch")
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
#: Significant digits of the default "rounded" reference (see :func:`rounded_urdf`).
ROUNDED_DIGITS = 10
#: Continuity check: each revolute joint of the seed moves by +- this much (rad, random signs).
SEED_PERTURBATION = 0.05
#: Continuity check: the solution nearest the perturbed seed lies within this of it on every
#: joint (rad, mod 2pi). Twice the perturbation plus margin: at q5 = 0 a free joint taken from
#: the perturbed seed moves its partner (q4 +- q6 fixed) by the same 0.05.
CONTINUITY_DISTANCE = 0.25
#: Sample sets on which the continuity check runs (the singular sets).
CONTINUITY_SETS: tuple[str, ...] = ("special", "near_singular")
#: Names of the built-in reference descriptions (anything else is a URDF path).
REFERENCE_KINDS: tuple[str, ...] = ("rounded", "exact")


# --------------------------------------------------------------------------------------------
# Reference descriptions


_ROUNDED_ELEMENT = re.compile(r"<(?:origin|axis|limit)\b[^>]*>")
_NUMERIC_ATTRIBUTE = re.compile(
    r"""(\b(?:xyz|rpy|lower|upper|velocity|effort)\s*=\s*)(["'])([^"']*)\2""")


def _round_token(token: str, digits: int) -> str:
    try:
        value = float(token)
    except ValueError:
        return token
    return token if not np.isfinite(value) else f"{value:.{digits}g}"


def rounded_urdf(urdf_text: str, digits: int = ROUNDED_DIGITS) -> str:
    """``urdf_text`` with every number of its ``<origin xyz rpy>``, ``<axis xyz>`` and
    ``<limit lower upper velocity effort>`` attributes rounded to ``digits`` significant digits
    (``f"{x:.{digits}g}"``): pi/2 = 1.5707963267948966 becomes 1.570796327 at 10 digits, as in
    UR's vendor files. Everything else (comments, names, layout) is kept character for character.
    """
    if int(digits) != digits or digits < 1:
        raise InputError(f"digits: expected a positive integer, got {digits!r}", field="digits")

    def attribute(match: re.Match[str]) -> str:
        numbers = " ".join(_round_token(t, int(digits)) for t in match.group(3).split())
        return f"{match.group(1)}{match.group(2)}{numbers}{match.group(2)}"

    return _ROUNDED_ELEMENT.sub(lambda m: _NUMERIC_ATTRIBUTE.sub(attribute, m.group(0)),
                                urdf_text)


@dataclass(frozen=True)
class ReferenceSpec:
    """Which description makes the targets and checks the solutions.

    ``kind``: "rounded" (generated URDF rounded to ``digits``), "exact" (generated URDF) or
    "vendor" (the URDF at ``path``, frames ``base`` -> ``tip``; ``tip`` is the frame equal to the
    table's ``robot_tip``, normally tool0).
    """

    kind: str = "rounded"
    path: str = ""
    base: str = "base_link"
    tip: str = "tool0"
    robot_tip: str = "tool0"
    digits: int = ROUNDED_DIGITS

    def describe(self) -> str:
        if self.kind == "rounded":
            return f"rounded (generated URDF, {self.digits} significant digits)"
        if self.kind == "exact":
            return "exact (generated URDF)"
        tip = self.tip if self.robot_tip == "tool0" else f"{self.tip} = {self.robot_tip}"
        return f"vendor {self.path} ({self.base} -> {tip})"

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_json(cls, data: Any, source: str = "reference") -> ReferenceSpec:
        """From :meth:`to_json`'s dict, or one of the names "rounded" / "exact"."""
        if isinstance(data, str) and data in REFERENCE_KINDS:
            return cls(kind=data)
        if not isinstance(data, Mapping) or data.get("kind") not in (*REFERENCE_KINDS, "vendor"):
            raise InputError(f"{source}: expected 'rounded', 'exact' or a vendor "
                             f"reference {{kind, path, base, tip}}, got {data!r}", field=source)
        known = {k: data[k] for k in ("kind", "path", "base", "tip", "robot_tip", "digits")
                 if k in data}
        return cls(**known)


def resolve_reference(robot: Arm, reference: str | Path | ReferenceSpec | None = None,
                      base: str | None = None, tip: str | None = None) -> ReferenceSpec:
    """``reference`` ("rounded", the default; "exact"; a vendor URDF path; or a ReferenceSpec)
    with the vendor frames ``base`` / ``tip`` -> a :class:`ReferenceSpec`. A vendor file's frames
    default to :data:`~dhkin.vendors.VENDOR_REFERENCES` for a robot listed there, else
    base_link / tool0."""
    if isinstance(reference, ReferenceSpec):
        spec = reference
    elif reference is None or (isinstance(reference, str) and reference in REFERENCE_KINDS):
        if base is not None or tip is not None:
            raise InputError("base/tip (--base/--tip): frames apply to a vendor URDF "
                             "reference only, not to 'rounded' or 'exact'")
        return ReferenceSpec(kind=str(reference or "rounded"))
    else:
        path = Path(reference)
        if not path.is_file():
            raise InputError(f"reference (--reference): {str(path)!r} is not a file; "
                             f"expected {' or '.join(map(repr, REFERENCE_KINDS))} or "
                             "the path of a URDF of the same robot", field="reference")
        listed = VENDOR_REFERENCES.get(robot.name)
        spec = ReferenceSpec(kind="vendor", path=str(path.resolve()),
                             base=listed.base if listed else "base_link",
                             tip=listed.tip if listed else "tool0",
                             robot_tip=listed.robot_tip if listed else "tool0")
    if spec.kind == "vendor" and (base is not None or tip is not None):
        spec = ReferenceSpec(kind="vendor", path=spec.path, base=base or spec.base,
                             tip=tip or spec.tip, robot_tip=spec.robot_tip)
    return spec


class TargetModel:
    """Pinocchio on the reference description, in the table's terms: ``fk(q)`` is the pose of
    the table's tool0 relative to its base_link, q in chain order (see :func:`target_model`)."""

    def __init__(self, spec: ReferenceSpec, reference: Reference,
                 tip_offset: NDArray[np.float64] | None = None) -> None:
        self.spec = spec
        self.reference = reference
        #: Largest pose difference (m and rad, the larger) between this description and the
        #: table's own model over the samples of a run (0 for "exact"; set by the run): a
        #: solution exact on the table may be off by this much here.
        self.deviation = 0.0
        #: robot_tip -> tool0 (constant), when the reference's tip is not the table's tool0.
        self._to_tool0 = tip_offset

    @property
    def description(self) -> str:
        return self.spec.describe()

    def fk(self, q: ArrayLike) -> NDArray[np.float64]:
        T = self.reference.fk(q)
        return T if self._to_tool0 is None else T @ self._to_tool0


def target_model(robot: Arm, reference: str | Path | ReferenceSpec | None = None,
                 base: str | None = None, tip: str | None = None) -> TargetModel:
    """The Pinocchio model that makes the targets and checks the solutions (see
    :func:`resolve_reference`). Bad files, frames or chains raise InputError naming
    the argument."""
    spec = resolve_reference(robot, reference, base, tip)
    if spec.kind == "exact":
        return TargetModel(spec, robot.reference())
    if spec.kind == "rounded":
        text = rounded_urdf(robot.urdf(), spec.digits)
        return TargetModel(spec, Reference(text, tip="tool0", source=f"{robot.name}.urdf "
                                                                     f"(rounded)"))
    path = Path(spec.path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"reference (--reference): cannot read {str(path)!r} "
                         f"({exc.strerror})", field="reference") from exc
    try:
        model = Reference(text, tip=spec.tip, base=spec.base, source=str(path))
    except URDFError as exc:
        raise InputError(_frame_error(text, spec, exc)) from exc
    if model.dof != robot.dof:
        raise InputError(
            f"reference (--reference): in {path} the chain {spec.base} -> {spec.tip} has "
            f"{model.dof} actuated joints {model.joint_names}; expected {robot.dof} like "
            f"{robot.name} (choose the frames with --base/--tip)", field="reference")
    offset = None
    if spec.robot_tip != "tool0":
        offset = invert(tool_frame_from_robot(robot, spec.robot_tip))
    return TargetModel(spec, model, offset)


def _frame_error(text: str, spec: ReferenceSpec, exc: URDFError) -> str:
    """Which argument a Reference error is about: the file, --tip or --base."""
    import pinocchio as pin

    try:
        model = pin.buildModelFromXML(text)
    except Exception:
        return f"reference (--reference): {exc}"
    if not model.existFrame(spec.tip):
        return f"tip (--tip): {exc}"
    if not model.existFrame(spec.base):
        return f"base (--base): {exc}"
    return f"reference (--reference): {exc}"


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
    #: The perturbed seed of the continuity check (empty outside CONTINUITY_SETS).
    perturbed_seed: list[float] = field(default_factory=list)
    #: What came back for the perturbed seed (when the continuity call was made).
    returned_perturbed: list[list[float]] = field(default_factory=list)
    #: Configurations of the closed-form branches not returned (outcome missing_branch).
    missing_branches: list[str] = field(default_factory=list)


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
    #: The description that made the targets and checked the solutions (ReferenceSpec.to_json).
    reference: dict[str, Any] = field(default_factory=lambda: ReferenceSpec().to_json())
    samples: int = 0
    counts: dict[str, int] = field(default_factory=dict)
    by_set: dict[str, dict[str, int]] = field(default_factory=dict)
    by_configuration: dict[str, dict[str, int]] = field(default_factory=dict)
    solution_counts: dict[str, float] = field(default_factory=dict)
    residuals: dict[str, float] = field(default_factory=dict)
    #: Largest pose difference between the reference and the table's own model (Pinocchio on
    #: the generated URDF) at the sampled q: m and rad ({"position_max", "rotation_max"}).
    reference_deviation: dict[str, float] = field(default_factory=dict)
    #: Samples whose missing branches / seed continuity were checked.
    branch_checked: int = 0
    continuity_checked: int = 0
    seconds: float = 0.0
    failures: list[SampleResult] = field(default_factory=list)

    def rate(self, outcome: str) -> float:
        return self.counts.get(outcome, 0) / self.samples if self.samples else 0.0

    @property
    def reference_name(self) -> str:
        return ReferenceSpec.from_json(self.reference).describe()

    @property
    def failing(self) -> int:
        """Samples that fail the run (see :attr:`ok`)."""
        failing = sum(self.counts.get(o, 0) for o in ("wrong", "no_solution", "discontinuous"))
        if self.complete_expected:
            failing += sum(self.counts.get(o, 0) for o in COMPLETENESS_OUTCOMES)
        return failing

    @property
    def ok(self) -> bool:
        """No wrong, unsolved or discontinuous sample, and (when completeness is expected) no
        missing sample or branch."""
        return self.samples > 0 and self.failing == 0

    def _reference_line(self) -> str:
        d = self.reference_deviation
        text = self.reference_name
        if d:
            text += (f", {d.get('position_max', 0):.1e} m / {d.get('rotation_max', 0):.1e} rad "
                     "from the table's own model")
        if d:
            text += (f"; residuals allowed up to the tolerance + that deviation "
                     f"({self.tolerance + max(d.values()):.1e})")
        return text

    def _checks_line(self) -> str:
        return (f"missing branches checked on {self.branch_checked} samples; seed continuity "
                f"(+-{SEED_PERTURBATION} rad, nearest within {CONTINUITY_DISTANCE} rad) on "
                f"{self.continuity_checked}")

    def summary(self) -> str:
        """Plain-text report: rates, per set, per configuration, residuals, counts."""
        lines = [f"{self.robot}: {self.ik_name} on {self.samples} samples (seed {self.seed}, "
                 f"tolerance {self.tolerance:.0e} m / rad, {self.seconds:.1f} s)",
                 f"  reference: {self._reference_line()}"]
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
        lines.append("  " + self._checks_line())
        if not self.complete_expected:
            lines.append("  (this IK returns one solution per call: missing samples are "
                         "reported, not failed; branches are not checked)")
        lines.append("  PASS" if self.ok else f"  FAIL: {self.failing} failing samples")
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["reference_name"] = self.reference_name
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
            f"Verdict: **{'PASS' if self.ok else 'FAIL'}**.", "",
            f"Targets made and solutions checked on: {self._reference_line()}.", "",
            f"Checks: {self._checks_line()}.", "", *rows, "", *sets, "", *configs, "",
            f"Residuals: position max {r.get('position_max', 0):.2e} m (median "
            f"{r.get('position_median', 0):.2e}), rotation max {r.get('rotation_max', 0):.2e} "
            f"rad (median {r.get('rotation_median', 0):.2e}).", "",
            f"Solutions per pose: min {c.get('min', 0):.0f}, median {c.get('median', 0):.0f}, "
            f"max {c.get('max', 0):.0f}.", ""])


# --------------------------------------------------------------------------------------------
# Sampling


def sample_joint_vectors(robot: Arm, n: int, seed: int) -> tuple[NDArray[np.float64],
                                                                    list[str]]:
    """n uniform + n/10 special-angle + n/10 near-singular joint vectors (at least 1 each)."""
    if n < 1:
        raise InputError(f"n: expected at least 1 sample, got {n}", field="n")
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


def perturbed_seeds(robot: Arm, q: NDArray[np.float64], sets: list[str],
                    seed: int) -> NDArray[np.float64]:
    """Seeds of the continuity check: q with each revolute joint moved by +-SEED_PERTURBATION
    (random signs from ``seed``), clipped to the limits, for samples in CONTINUITY_SETS; NaN rows
    elsewhere."""
    rng = np.random.default_rng((seed, 1))
    signs = rng.choice([-1.0, 1.0], size=q.shape)
    revolute = np.array([j.is_revolute for j in robot.table.joints])
    seeds = np.clip(q + SEED_PERTURBATION * signs * revolute, robot.lower, robot.upper)
    seeds[[s not in CONTINUITY_SETS for s in sets]] = np.nan
    return seeds


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


def own_ik(robot: Arm) -> IKCallable:
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
        raise InputError(f"--ik: expected 'module:function', got {spec!r}")
    module_name, function_name = spec.split(":", 1)
    if str(Path.cwd()) not in sys.path:
        sys.path.insert(0, str(Path.cwd()))
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise InputError(f"--ik: cannot import module {module_name!r} ({exc})") from exc
    function = getattr(module, function_name, None)
    if not callable(function):
        raise InputError(f"--ik: {module_name!r} has no callable {function_name!r}")
    return function


def _takes_seed(ik: IKCallable) -> bool:
    return "q_seed" in inspect.signature(ik).parameters


def _call(ik: IKCallable, robot: Arm, T: NDArray[np.float64],
          q_seed: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    parameters = inspect.signature(ik).parameters
    kwargs: dict[str, Any] = {}
    if "q_seed" in parameters:
        kwargs["q_seed"] = q_seed
    if "robot" in parameters:
        kwargs["robot"] = robot
    result = ik(T, **kwargs)
    if isinstance(result, np.ndarray) and result.ndim == 2:
        return list(result.astype(float, copy=False))
    return [np.asarray(q, dtype=float).reshape(-1) for q in result]


# --------------------------------------------------------------------------------------------
# Checking


def _wrap(robot: Arm, difference: NDArray[np.float64]) -> NDArray[np.float64]:
    """Joint differences with revolute joints wrapped to (-pi, pi] (prismatic ones as they are)."""
    revolute = np.array([j.is_revolute for j in robot.table.joints])
    return np.where(revolute, np.pi - np.mod(np.pi - difference, 2.0 * np.pi), difference)


def _configuration_labels(robot: Arm, targets: NDArray[np.float64],
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
        difference = _wrap(robot, candidates - q[k])
        best = int(np.argmin(np.abs(difference).max(axis=1)))
        label = batch.branch_labels[branches[best]]
        labels.append(" ".join(f"{key}={value}" for key, value in label.items()))
    return labels


def _wrist_singular(robot: Arm, q: NDArray[np.float64]) -> bool:
    return (robot.dof > WRIST_JOINT and robot.table.joints[WRIST_JOINT].is_revolute
            and abs(np.sin(q[WRIST_JOINT])) <= WRIST_SINGULAR)


def _compared_joints(robot: Arm, q_sampled: NDArray[np.float64],
                     seeded: bool) -> NDArray[np.int64]:
    """Joints the missing check compares (all, except at the wrist singularity without seed)."""
    if _wrist_singular(robot, q_sampled) and not seeded:
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
    closest = float(np.abs(_wrap(robot, Q - q)[:, joints]).max(axis=1).min())
    noise = max(POSE_ROUNDING, model.deviation, residual)
    found = closest <= joint_tolerance or closest <= _resolvable(robot, q, joint_tolerance, noise)
    return found, closest


def _verify(robot: Arm, model: TargetModel, T: NDArray[np.float64],
            returned: list[NDArray[np.float64]], tolerance: float
            ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], str]:
    """Finite solutions, their residuals on the reference, and what is wrong with them ('')."""
    dof = robot.dof
    good = [s for s in returned if s.shape == (dof,) and np.all(np.isfinite(s))]
    Q = np.array(good, dtype=float).reshape(len(good), dof)
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
                  T: NDArray[np.float64], returned: list[NDArray[np.float64]], tolerance: float,
                  joint_tolerance: float, seeded: bool) -> tuple[_Checked, NDArray[np.float64]]:
    """wrong / no_solution / missing / success of the first call, and its finite solutions."""
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
                      q_sampled: NDArray[np.float64], Q: NDArray[np.float64], tolerance: float,
                      joint_tolerance: float) -> list[tuple[str, float]]:
    """(configuration, closest distance) of each closed-form branch of T that Q lacks.

    The branches are ``robot.ik(T, q_seed=q_sampled, copies=False)``, those that verify on the
    reference. A branch on the wrist singularity is a one-parameter family: only joints 1 and 5
    are compared there.
    """
    try:
        branches = robot.ik(T, q_seed=q_sampled, copies=False)
    except DhkinError:
        return []
    if not len(branches):
        return []
    position, rotation = pose_error(model.fk(branches.q),
                                    np.broadcast_to(T, (len(branches), 4, 4)))
    missing = []
    allowed = tolerance + model.deviation
    for k in np.flatnonzero((position <= allowed) & (rotation <= allowed)):
        branch = branches.q[k]
        joints = (np.array(SINGULAR_FAMILY_FIXED_JOINTS) if _wrist_singular(robot, branch)
                  else np.arange(robot.dof))
        found, closest = _matched(robot, model, Q, branch, joints, joint_tolerance)
        if not found:
            name = (str(branches.configurations[k]) if k < len(branches.configurations)
                    else f"branch {k}")
            missing.append((name, closest))
    return missing


def _nearest_to_seed(robot: Arm, Q: NDArray[np.float64],
                     seed: NDArray[np.float64]) -> tuple[float, int]:
    """Largest joint distance (mod 2pi) of the solution nearest ``seed``, and its joint."""
    distance = np.abs(_wrap(robot, Q - seed))
    best = int(np.argmin(distance.max(axis=1)))
    joint = int(np.argmax(distance[best]))
    return float(distance[best, joint]), joint


def _progress(iterable: Iterable[Any], total: int, label: str, show: bool) -> Iterable[Any]:
    if not show:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=label, unit="pose", leave=False, file=sys.stderr)


def validate(robot: Arm, ik: IKCallable | None = None, n: int = 10_000, seed: int = 0,
             tolerance: float = 1e-9, joint_tolerance: float = 1e-6,
             progress: bool = False, ik_name: str | None = None,
             complete_expected: bool | None = None,
             reference: str | Path | ReferenceSpec | None = None, base: str | None = None,
             tip: str | None = None) -> ValidationReport:
    """Validate ``ik`` (default: dhkin's own) on ``robot``; see the module docstring.

    ``complete_expected`` (default: True, except for dhkin's own numerical IK, which returns
    one solution per call) says whether missing samples and branches fail the run.
    ``reference`` makes the targets and checks the solutions: "rounded" (default), "exact", or
    the path of a vendor URDF whose frames ``base`` -> ``tip`` are the table's base_link ->
    tool0 (defaults: :data:`~dhkin.vendors.VENDOR_REFERENCES`, else base_link / tool0).
    """
    if n < 1:
        raise InputError(f"n: expected at least 1 sample, got {n}", field="n")
    model = target_model(robot, reference, base, tip)
    callable_ik = own_ik(robot) if ik is None else ik
    if complete_expected is None:
        complete_expected = ik is not None or robot.has_closed_form
    q, sets = sample_joint_vectors(robot, n, seed)
    return _run(robot, model, callable_ik, q, sets, perturbed_seeds(robot, q, sets, seed), seed,
                tolerance, joint_tolerance, progress,
                ik_name or str(getattr(callable_ik, "__name__", "ik")), complete_expected)


def _run(robot: Arm, model: TargetModel, ik: IKCallable, q: NDArray[np.float64],
         sets: list[str], perturbed: NDArray[np.float64], seed: int, tolerance: float,
         joint_tolerance: float, progress: bool, ik_name: str,
         complete_expected: bool = True) -> ValidationReport:
    started = time.perf_counter()
    targets = model.fk(q)
    labels = _configuration_labels(robot, targets, q)
    report = ValidationReport(robot=robot.name, ik_name=ik_name, tolerance=tolerance,
                              joint_tolerance=joint_tolerance, seed=seed,
                              complete_expected=complete_expected,
                              reference=model.spec.to_json(), samples=len(sets))
    if model.spec.kind != "exact":
        position, rotation = pose_error(targets, robot.reference().fk(q))
        report.reference_deviation = {"position_max": float(position.max()),
                                      "rotation_max": float(rotation.max())}
        model.deviation = max(report.reference_deviation.values())
    counts: Counter[str] = Counter()
    by_set: dict[str, Counter[str]] = {}
    by_configuration: dict[str, Counter[str]] = {}
    all_position, all_rotation, n_solutions = [], [], []
    seeded = _takes_seed(ik)
    check_branches = complete_expected and robot.has_closed_form
    for k in _progress(range(len(sets)), len(sets), f"validate {robot.name}", progress):
        try:
            returned = _call(ik, robot, targets[k], q[k])
        except DhkinError as exc:
            returned, error = [], f"raised {type(exc).__name__}: {exc}"
        else:
            error = ""
        checked, Q = _check_sample(robot, model, q[k], targets[k], returned, tolerance,
                                   joint_tolerance, seeded)
        outcome, detail = checked.outcome, error or checked.detail
        all_position.append(checked.position)
        all_rotation.append(checked.rotation)
        missing: list[str] = []
        if outcome == "success" and check_branches:
            report.branch_checked += 1
            lacking = _missing_branches(robot, model, targets[k], q[k], Q, tolerance,
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
                robot, model, ik, targets[k], perturbed[k], tolerance, all_position,
                all_rotation)
        counts[outcome] += 1
        by_set.setdefault(sets[k], Counter())[outcome] += 1
        if labels[k]:
            by_configuration.setdefault(labels[k], Counter())[outcome] += 1
        n_solutions.append(len(returned))
        if outcome != "success":
            report.failures.append(SampleResult(
                index=k, sample_set=sets[k], q_sampled=q[k].tolist(), target=targets[k].tolist(),
                returned=[r.tolist() for r in returned],
                position_errors=checked.position.tolist(),
                rotation_errors=checked.rotation.tolist(), outcome=outcome, detail=detail,
                configuration=labels[k],
                perturbed_seed=(perturbed[k].tolist() if np.all(np.isfinite(perturbed[k]))
                                else []),
                returned_perturbed=[r.tolist() for r in returned_perturbed],
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
    report.seconds = time.perf_counter() - started
    return report


def _check_continuity(robot: Arm, model: TargetModel, ik: IKCallable, T: NDArray[np.float64],
                      seed: NDArray[np.float64], tolerance: float,
                      all_position: list[NDArray[np.float64]],
                      all_rotation: list[NDArray[np.float64]]
                      ) -> tuple[str, str, list[NDArray[np.float64]]]:
    """Second call with the perturbed seed: (outcome, detail, what came back)."""
    try:
        returned = _call(ik, robot, T, seed)
    except DhkinError as exc:
        return ("discontinuous", f"with the perturbed seed: raised {type(exc).__name__}: {exc}",
                [])
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


# --------------------------------------------------------------------------------------------
# Failure files


def write_failures(report: ValidationReport, path: str | Path) -> Path:
    """Write the failing samples as JSON (robot, tolerances, the reference description, and
    per sample: set, sampled q, target pose, what came back, residuals, outcome, perturbed seed)
    for ``dhkin validate --replay``."""
    file = Path(path)
    file.write_text(json.dumps({
        "robot": report.robot, "ik": report.ik_name, "tolerance": report.tolerance,
        "joint_tolerance": report.joint_tolerance, "seed": report.seed,
        "complete_expected": report.complete_expected, "reference": report.reference,
        "failures": [asdict(f) for f in report.failures],
    }, indent=1), encoding="utf-8")
    return file


def replay(robot: Arm, ik: IKCallable, path: str | Path, ik_name: str | None = None,
           reference: str | Path | ReferenceSpec | None = None, base: str | None = None,
           tip: str | None = None, complete_expected: bool | None = None) -> ValidationReport:
    """Rerun the samples of a failure file with ``ik`` and check them again, on the reference
    the file records (files without one: "exact") unless ``reference`` / ``base`` / ``tip``
    say otherwise, with the recorded perturbed seeds."""
    file = Path(path)
    try:
        data: Mapping[str, Any] = json.loads(file.read_text(encoding="utf-8"))
        failures = data["failures"]
        q = np.array([f["q_sampled"] for f in failures], dtype=float).reshape(-1, robot.dof)
        sets = [str(f["sample_set"]) for f in failures]
        tolerance = float(data["tolerance"])
        joint_tolerance = float(data["joint_tolerance"])
        recorded = [np.asarray(f.get("perturbed_seed") or [], dtype=float) for f in failures]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(f"{file}: not a dhkin failure file ({exc}); expected the JSON "
                         "written by `dhkin validate --failures`") from exc
    if data.get("robot") != robot.name:
        raise InputError(f"{file}: failures of robot {data.get('robot')!r}, "
                         f"expected {robot.name!r}")
    if not failures:
        raise InputError(f"{file}: no failures to replay")
    if reference is None:
        reference = ReferenceSpec.from_json(data.get("reference", "exact"), f"{file}: reference")
    model = target_model(robot, reference, base, tip)
    seed = int(data.get("seed", 0))
    perturbed = perturbed_seeds(robot, q, sets, seed)
    for k, row in enumerate(recorded):
        if row.shape == (robot.dof,) and sets[k] in CONTINUITY_SETS:
            perturbed[k] = row
    if complete_expected is None:
        complete_expected = bool(data.get("complete_expected", True))
    return _run(robot, model, ik, q, sets, perturbed, seed, tolerance, joint_tolerance, False,
                ik_name or str(getattr(ik, "__name__", "ik")), complete_expected)


def tool_frame_from_robot(robot: Arm, frame: str) -> NDArray[np.float64]:
    """tool0 -> ``frame`` of the generated URDF (constant), for :func:`adapt`'s ``tool``."""
    reference = robot.reference()
    q = np.zeros(robot.dof)
    return invert(reference.fk(q, "tool0")) @ reference.fk(q, frame)


__all__ = ["CONTINUITY_DISTANCE", "CONTINUITY_SETS", "OUTCOMES", "ROUNDED_DIGITS", "SAMPLE_SETS",
           "SEED_PERTURBATION", "ReferenceSpec", "TargetModel",
           "ValidationReport", "adapt", "load_ik", "own_ik", "perturbed_seeds", "replay",
           "resolve_reference", "rounded_urdf", "target_model", "validate", "write_failures"]
