"""The figures of a validation run, sample by sample: counts by outcome, set and configuration,
residuals, solution counts, and the failure record of each sample that did not succeed (what
:class:`~dhkin.validation.report.ValidationReport` holds). Shared by the pose-by-pose run
(:mod:`dhkin.validation.run`) and the batched one (:mod:`dhkin.validation.batched`), so that
both give the same figures for the same answers.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from dhkin.validation.report import OUTCOMES, SampleResult, ValidationReport

#: Returned solutions a failure record keeps (per call): every 2pi copy of the 16 branches of
#: a UR-type arm with +-360 deg joints (16 * 2^6), while an IK returning up to
#: MAX_SOLUTIONS_PER_CALL rows on every pose cannot make the report hold gigabytes.
FAILURE_SOLUTIONS_KEPT = 1024


@dataclass
class Tally:
    """The run's figures as the samples are checked (:meth:`add`), written into the report by
    :meth:`finish`. ``position`` / ``rotation``: every residual (m, rad) of every verified
    solution, the continuity calls' included."""

    counts: Counter[str] = field(default_factory=Counter)
    by_set: dict[str, Counter[str]] = field(default_factory=dict)
    by_configuration: dict[str, Counter[str]] = field(default_factory=dict)
    position: list[NDArray[np.float64]] = field(default_factory=list)
    rotation: list[NDArray[np.float64]] = field(default_factory=list)
    n_solutions: list[int] = field(default_factory=list)

    def residuals(self, position: NDArray[np.float64], rotation: NDArray[np.float64]) -> None:
        """Residuals of one call's solutions."""
        self.position.append(position)
        self.rotation.append(rotation)

    def count(self, sample_set: str, configuration: str, outcome: str, returned: int) -> None:
        """Count one sample's outcome and the number of solutions its first call returned."""
        self.counts[outcome] += 1
        self.by_set.setdefault(sample_set, Counter())[outcome] += 1
        if configuration:
            self.by_configuration.setdefault(configuration, Counter())[outcome] += 1
        self.n_solutions.append(returned)

    def add(self, report: ValidationReport, k: int, sample_set: str, configuration: str,
            outcome: str, detail: str, q: NDArray[np.float64], target: NDArray[np.float64],
            returned: list[NDArray[np.float64]], position: NDArray[np.float64],
            rotation: NDArray[np.float64], perturbed: NDArray[np.float64],
            returned_perturbed: list[NDArray[np.float64]], missing: list[str]) -> None:
        """:meth:`count` one sample (its residuals are given to :meth:`residuals`); a sample
        that did not succeed is recorded in ``report.failures`` with what came back."""
        self.count(sample_set, configuration, outcome, len(returned))
        if outcome == "success":
            return
        if max(len(returned), len(returned_perturbed)) > FAILURE_SOLUTIONS_KEPT:
            detail += (f" (the failure keeps the first {FAILURE_SOLUTIONS_KEPT} of "
                       f"{max(len(returned), len(returned_perturbed))} solutions)")
        report.failures.append(SampleResult(
            index=k, sample_set=sample_set, q_sampled=q.tolist(), target=target.tolist(),
            returned=[r.tolist() for r in returned[:FAILURE_SOLUTIONS_KEPT]],
            position_errors=position.tolist(), rotation_errors=rotation.tolist(),
            outcome=outcome, detail=detail, configuration=configuration,
            perturbed_seed=perturbed.tolist() if np.all(np.isfinite(perturbed)) else [],
            returned_perturbed=[r.tolist() for r in returned_perturbed[:FAILURE_SOLUTIONS_KEPT]],
            missing_branches=missing))

    def finish(self, report: ValidationReport) -> None:
        """Write the counts, solution counts and residual statistics into ``report``."""
        report.counts = {o: self.counts.get(o, 0) for o in OUTCOMES}
        report.by_set = {s: dict(c) for s, c in self.by_set.items()}
        report.by_configuration = {s: dict(c) for s, c in sorted(self.by_configuration.items())}
        report.solution_counts = {"min": float(min(self.n_solutions)),
                                  "max": float(max(self.n_solutions)),
                                  "median": float(np.median(self.n_solutions))}
        position, rotation = np.concatenate(self.position), np.concatenate(self.rotation)
        if position.size:
            report.residuals = {
                "position_max": float(position.max()),
                "position_median": float(np.median(position)),
                "rotation_max": float(rotation.max()),
                "rotation_median": float(np.median(rotation)),
            }
