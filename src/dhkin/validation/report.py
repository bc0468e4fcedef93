"""The validation report: per-sample outcomes, counts, worst residuals, text and JSON, and failure
files that reproduce every failed sample.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from dhkin.files import write_file
from dhkin.validation.references import ReferenceSpec
from dhkin.validation.samples import CONTINUITY_DISTANCE, SEED_PERTURBATION

SAMPLE_SETS: tuple[str, ...] = ("uniform", "special", "near_singular")


OUTCOMES: tuple[str, ...] = ("success", "wrong", "no_solution", "missing", "missing_branch",
                             "discontinuous")


#: Outcomes that fail a run only when the IK promises every solution (complete_expected).
COMPLETENESS_OUTCOMES: tuple[str, ...] = ("missing", "missing_branch")


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


def failures_json(report: ValidationReport) -> str:
    """The failing samples as JSON text (robot, tolerances, the reference description, and per
    sample: set, sampled q, target pose, what came back, residuals, outcome, perturbed seed)
    for ``dhkin validate --replay``."""
    return json.dumps({
        "robot": report.robot, "ik": report.ik_name, "tolerance": report.tolerance,
        "joint_tolerance": report.joint_tolerance, "seed": report.seed,
        "complete_expected": report.complete_expected, "reference": report.reference,
        "failures": [asdict(f) for f in report.failures],
    }, indent=1)


def write_failures(report: ValidationReport, path: str | Path, force: bool = False) -> Path:
    """Write :func:`failures_json` of ``report`` to ``path``, as :mod:`dhkin.files` says
    (atomically: a failed write leaves the old file whole; an existing file with other content
    only with ``force``)."""
    return write_file(path, failures_json(report), field="failures", force=force)
