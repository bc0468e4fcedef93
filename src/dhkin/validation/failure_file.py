"""Reading a failure file (``dhkin validate --failures``) back for ``--replay``, value by value:
a file edited by hand or by another tool gets a one-line InputError naming the file, the entry
index and the field, and what was expected, never a traceback or a silently truncated value.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.errors import InputError
from dhkin.validation import arguments
from dhkin.validation.references import ReferenceSpec
from dhkin.validation.report import SAMPLE_SETS


@dataclass(frozen=True)
class FailureFile:
    """The checked contents of a failure file."""

    q: NDArray[np.float64]
    sets: list[str]
    tolerance: float
    joint_tolerance: float
    seed: int
    complete_expected: bool
    reference: ReferenceSpec
    #: The recorded perturbed seed of each entry (None where the entry has none).
    perturbed: list[NDArray[np.float64] | None]


def _error(file: Path, field: str, value: Any, expected: str, index: int | None = None,
           given: bool = True) -> InputError:
    got = f", got {arguments.quoted(value)}" if given else ""
    return InputError(f"{file}: {field}: expected {expected}{got}", field=field,
                      value=arguments.quoted(value) if given else None, expected=expected,
                      index=index)


def _parse(file: Path) -> Any:
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{file}: cannot read the failure file ({exc.strerror or exc})",
                         field="replay", value=str(file), expected="a readable file") from exc
    except UnicodeDecodeError as exc:
        raise InputError(f"{file}: not UTF-8 text ({exc.reason} at byte {exc.start}); expected "
                         "the JSON written by `dhkin validate --failures`", field="replay",
                         value=str(file), expected="UTF-8 JSON") from exc
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{file}: not JSON ({exc.msg} at line {exc.lineno} column "
                         f"{exc.colno}); expected the JSON written by `dhkin validate "
                         "--failures`", field="replay", value=str(file),
                         expected="JSON") from exc
    except RecursionError as exc:
        raise InputError(f"{file}: JSON nested too deeply to read; expected the JSON written "
                         "by `dhkin validate --failures`", field="replay", value=str(file),
                         expected="JSON") from exc
    except ValueError as exc:  # e.g. an integer literal beyond Python's digit limit
        raise InputError(f"{file}: not readable JSON ({arguments.one_line(str(exc), 120)})",
                         field="replay", value=str(file), expected="JSON") from exc


def _number_or_error(check: Any, file: Path, data: dict[str, Any], key: str) -> Any:
    if key not in data:
        raise _error(file, key, None, "a number (the run's value)", given=False)
    try:
        return check(data[key], key)
    except InputError as exc:
        raise InputError(f"{file}: {exc}", field=key, value=exc.value,
                         expected=exc.expected) from exc


def _finite(value: Any) -> bool:
    """A real number (not a bool) that is finite as a float."""
    try:
        return arguments.is_real(value) and math.isfinite(float(value))
    except OverflowError:  # an integer beyond float range
        return False


def _joint_vector(file: Path, robot: Arm, value: Any, field: str, index: int,
                  empty_ok: bool = False) -> NDArray[np.float64] | None:
    """A list of ``robot.dof`` finite numbers within the joint limits (or [] if ``empty_ok``)."""
    expected = (f"a list of {robot.dof} finite joint values of {robot.name} (rad / m) within "
                "its joint limits" + (", or []" if empty_ok else ""))
    if empty_ok and value in (None, []):
        return None
    if (not isinstance(value, list) or len(value) != robot.dof
            or not all(_finite(v) for v in value)):
        shown = (f"{len(value)} values" if isinstance(value, list) and len(value) != robot.dof
                 else value)
        raise _error(file, field, shown, expected, index)
    q = np.array(value, dtype=float)
    if not bool(robot.table.in_limits(q)):
        raise _error(file, field, value, expected, index)
    return q


def read_failure_file(path: str | Path, robot: Arm) -> FailureFile:
    """The failure file at ``path`` for ``robot``, every value checked (see the module
    docstring). Files without "seed", "complete_expected" or "reference" get 0, True and
    "exact" (files written before those were recorded)."""
    file = Path(path)
    data = _parse(file)
    if not isinstance(data, dict):
        raise _error(file, "top level", type(data).__name__,
                     "a JSON object {robot, tolerance, joint_tolerance, failures, ...}")
    for key in ("robot", "tolerance", "joint_tolerance", "failures"):
        if key not in data:
            raise InputError(f"{file}: {key}: missing, so not a dhkin failure file; expected "
                             "the JSON written by `dhkin validate --failures`", field=key,
                             expected=f"a key {key!r}")
    if data.get("robot") != robot.name:
        raise InputError(f"{file}: robot: failures of robot {arguments.quoted(data.get('robot'))}"
                         f", expected {robot.name!r}", field="robot",
                         value=arguments.quoted(data.get("robot")), expected=robot.name)
    tolerance = _number_or_error(arguments.tolerance_value, file, data, "tolerance")
    joint_tolerance = _number_or_error(arguments.joint_tolerance_value, file, data,
                                       "joint_tolerance")
    seed = _number_or_error(arguments.seed_value, file, {"seed": 0, **data}, "seed")
    complete = data.get("complete_expected", True)
    if not isinstance(complete, bool):
        raise _error(file, "complete_expected", complete, "true or false")
    reference = data.get("reference", "exact")
    try:
        spec = ReferenceSpec.from_json(reference, "reference")
    except InputError as exc:
        raise InputError(f"{file}: {exc}", field="reference", value=exc.value,
                         expected=exc.expected) from exc
    failures = data.get("failures")
    if not isinstance(failures, list) or not failures or len(failures) > arguments.MAX_SAMPLES:
        raise _error(file, "failures", failures if "failures" in data else None,
                     f"a list of 1 to {arguments.MAX_SAMPLES} failed samples",
                     given="failures" in data)
    q, sets, perturbed = [], [], []
    for k, entry in enumerate(failures):
        where = f"failures[{k}]"
        if not isinstance(entry, dict):
            raise _error(file, where, type(entry).__name__,
                         "an object {sample_set, q_sampled, ...}", k)
        if "q_sampled" not in entry:
            raise _error(file, f"{where}.q_sampled", None,
                         f"{robot.dof} joint values (the key is missing)", k, given=False)
        row = _joint_vector(file, robot, entry["q_sampled"], f"{where}.q_sampled", k)
        assert row is not None
        q.append(row)
        sample_set = entry.get("sample_set")
        if sample_set not in SAMPLE_SETS:
            raise _error(file, f"{where}.sample_set", sample_set,
                         "one of " + ", ".join(SAMPLE_SETS), k, given="sample_set" in entry)
        sets.append(str(sample_set))
        perturbed.append(_joint_vector(file, robot, entry.get("perturbed_seed"),
                                       f"{where}.perturbed_seed", k, empty_ok=True))
    return FailureFile(q=np.array(q, dtype=float).reshape(-1, robot.dof), sets=sets,
                       tolerance=tolerance, joint_tolerance=joint_tolerance, seed=seed,
                       complete_expected=complete, reference=spec, perturbed=perturbed)
