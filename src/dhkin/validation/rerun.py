"""Rerunning the samples of a failure file (``dhkin validate --replay``) with an IK."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from dhkin.arm import Arm
from dhkin.errors import InputError
from dhkin.validation import arguments
from dhkin.validation.adapters import IKCallable
from dhkin.validation.calls import DEFAULT_CALL_TIMEOUT
from dhkin.validation.failure_file import read_failure_file
from dhkin.validation.references import ReferenceSpec, target_model
from dhkin.validation.report import ValidationReport
from dhkin.validation.run import RunSettings, ik_name_of, run_samples
from dhkin.validation.samples import CONTINUITY_SETS, perturbed_seeds


def replay(robot: Arm, ik: IKCallable, path: str | Path, ik_name: str | None = None,
           reference: str | Path | ReferenceSpec | None = None, base: str | None = None,
           tip: str | None = None, complete_expected: bool | None = None,
           timeout: float | None = DEFAULT_CALL_TIMEOUT, isolate: bool = False,
           packages: Mapping[str, str | Path] | None = None) -> ValidationReport:
    """Rerun the samples of a failure file with ``ik`` and check them again, on the reference
    the file records (files without one: "exact") unless ``reference`` / ``base`` / ``tip``
    say otherwise, with the recorded perturbed seeds. Every value of the file is checked
    (:func:`~dhkin.validation.failure_file.read_failure_file`): a wrong one is an InputError
    naming the file, the entry and the field."""
    if not callable(ik):
        raise InputError(f"ik: expected a callable ik(T) -> joint vectors, got "
                         f"{arguments.quoted(ik)}", field="ik", value=arguments.quoted(ik),
                         expected="a callable")
    recorded = read_failure_file(path, robot)
    if reference is None:
        reference = recorded.reference
    model = target_model(robot, reference, base, tip, packages)
    perturbed = perturbed_seeds(robot, recorded.q, recorded.sets, recorded.seed)
    for k, row in enumerate(recorded.perturbed):
        if row is not None and recorded.sets[k] in CONTINUITY_SETS:
            perturbed[k] = row
    expected = arguments.flag(complete_expected, "complete_expected", optional=True)
    settings = RunSettings(
        seed=recorded.seed, tolerance=recorded.tolerance,
        joint_tolerance=recorded.joint_tolerance, timeout=arguments.timeout_value(timeout),
        isolate=bool(arguments.flag(isolate, "isolate")), progress=False,
        ik_name=ik_name_of(ik, arguments.optional_text(ik_name, "ik_name")),
        complete_expected=recorded.complete_expected if expected is None else bool(expected))
    return run_samples(robot, model, ik, recorded.q, recorded.sets, perturbed, settings)
