"""Hostile and sloppy input to the validator (issue 15): every bad argument, IK, return value and
failure file is a reported failure of a pose or a one-line InputError naming what is wrong,
never a traceback, an exit, a hang, a NaN verdict or a wrong PASS.

The reproducers of the issue come first, then fixed-seed fuzz tests: IKs that pick a hostile
behaviour per call at random, and every argument of ``validate`` given hostile values.
"""

from __future__ import annotations

import contextlib
import json
import math
import multiprocessing
import signal
import sys
import time
from decimal import Decimal
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import dhkin
from dhkin.errors import InputError, UnreachableError
from dhkin.validation import (
    MAX_SOLUTIONS_PER_CALL,
    ValidationReport,
    read_failure_file,
    replay,
    sample_joint_vectors,
    target_model,
    validate,
    write_failures,
)
from dhkin.validation.calls import KEPT_OF_A_BAD_ANSWER
from tests.test_cli import run

from . import broken
from .conftest import REPO

N = 5  # uniform samples per run (plus one special-angle and one near-singular sample)


@pytest.fixture(scope="module")
def ur5() -> dhkin.Robot:
    return dhkin.load("ur5")


def assert_one_line_error(code: int, err: str, *named: str) -> None:
    """Exit 2 with one line on stderr naming each of ``named``, no traceback."""
    assert code == 2, err
    assert err.strip().count("\n") == 0, err
    assert "Traceback" not in err
    for text in named:
        assert text in err, err


def correct(robot: dhkin.Robot) -> Any:
    """dhkin's closed-form IK as a seeded IK under test (passes on ur5, exact reference)."""
    def ik(T: np.ndarray, q_seed: np.ndarray | None = None) -> np.ndarray:
        return robot.ik(T, q_seed=q_seed).q

    return ik


def assert_reported(report: ValidationReport, *words: str) -> None:
    """Every sample failed, each with a one-line detail holding ``words``."""
    assert not report.ok
    assert len(report.failures) == report.samples
    for failure in report.failures:
        assert failure.detail and "\n" not in failure.detail
        for word in words:
            assert word in failure.detail, failure.detail


# ---------------------------------------------------------------------------------------------
# The reproducers: numeric arguments


def test_nan_tolerance_is_refused_on_the_command_line(capsys, monkeypatch) -> None:
    monkeypatch.chdir(REPO)
    code, out, _ = run(capsys, "validate", "ur5", "--ik", "tests.broken:garbage_row", "-n", "3",
                       "--reference", "exact", "--failures", "/dev/null")
    assert code == 1 and "FAIL" in out
    for option, value in (("--tolerance", "nan"), ("--tolerance", "-1e-9"),
                          ("--tolerance", "inf"), ("--joint-tolerance", "nan"),
                          ("--joint-tolerance", "0"), ("--timeout", "nan"), ("--timeout", "0"),
                          ("-n", "0"), ("-n", "10000000"), ("--seed", "-1")):
        code, _, err = run(capsys, "validate", "ur5", "--ik", "tests.broken:garbage_row",
                           f"{option}={value}")
        assert_one_line_error(code, err, option, "expected")


def test_nan_joint_tolerance_is_refused_by_the_api(ur5: dhkin.Robot) -> None:
    assert not validate(ur5, broken.dropped_branch, n=N, reference="exact").ok
    for value in (math.nan, np.float64("nan"), -1e-6, math.inf, "1e-6", None, True, 1.0):
        with pytest.raises(InputError) as caught:
            validate(ur5, broken.dropped_branch, n=N, joint_tolerance=value)
        assert caught.value.field == "joint_tolerance" and "expected" in str(caught.value)


def _failure_file(ur5: dhkin.Robot, tmp_path: Path) -> tuple[Path, dict[str, Any]]:
    """A real failure file (garbage_row fails every sample) and its JSON."""
    report = validate(ur5, broken.garbage_row, n=N, reference="exact")
    path = write_failures(report, tmp_path / "failures.json")
    return path, json.loads(path.read_text())


@pytest.mark.parametrize("field", ["tolerance", "joint_tolerance"])
def test_nan_in_a_failure_file_is_refused(capsys, monkeypatch, tmp_path, ur5: dhkin.Robot,
                                          field: str) -> None:
    path, data = _failure_file(ur5, tmp_path)
    monkeypatch.chdir(REPO)
    code, _, _ = run(capsys, "validate", "ur5", "--ik", "tests.broken:garbage_row", "--replay",
                     str(path), "--failures", "/dev/null")
    assert code == 1
    data[field] = math.nan
    path.write_text(json.dumps(data))  # json writes the NaN literal, as Python reads it
    code, _, err = run(capsys, "validate", "ur5", "--ik", "tests.broken:garbage_row",
                       "--replay", str(path))
    assert_one_line_error(code, err, str(path), field)


# ---------------------------------------------------------------------------------------------
# The IK gets read-only copies; the validator keeps its own


def test_an_ik_writing_its_answer_into_the_seed_does_not_pass(ur5: dhkin.Robot) -> None:
    report = validate(ur5, broken.writes_its_answer_into_the_seed, n=N, reference="exact")
    assert not report.ok and report.counts["missing"] >= N - 1
    q, _ = sample_joint_vectors(ur5, N, 0)
    for failure in report.failures:
        assert failure.q_sampled == q[failure.index].tolist()


def test_an_ik_shifting_its_target_is_checked_against_the_real_one(ur5: dhkin.Robot) -> None:
    report = validate(ur5, broken.shifts_the_target, n=N, reference="exact")
    assert_reported(report, "read-only")
    model = target_model(ur5, "exact")
    for failure in report.failures:
        assert np.array_equal(failure.target, model.fk(np.array(failure.q_sampled)))


def test_the_ik_gets_read_only_copies(ur5: dhkin.Robot) -> None:
    seen: list[tuple[np.ndarray, np.ndarray]] = []

    def inspecting(T: np.ndarray, q_seed: np.ndarray | None = None) -> np.ndarray:
        assert q_seed is not None
        assert not T.flags.writeable and not q_seed.flags.writeable
        seen.append((T, q_seed))
        return ur5.ik(T, q_seed=q_seed).q

    assert validate(ur5, inspecting, n=N, reference="exact").ok
    assert len({id(T) for T, _ in seen}) == len(seen)  # a fresh copy per call


# ---------------------------------------------------------------------------------------------
# Exits, endless output, time limits, crashes


def test_sys_exit_in_the_ik_is_a_reported_failure(capsys, monkeypatch, tmp_path) -> None:
    monkeypatch.chdir(REPO)
    failures = tmp_path / "f.json"
    code, out, _ = run(capsys, "validate", "ur5", "--ik", "tests.broken:exits", "-n", "3",
                       "--reference", "exact", "--failures", str(failures))
    assert code == 1 and "FAIL" in out and "no_solution 100.000%" in out
    details = {f["detail"] for f in json.loads(failures.read_text())["failures"]}
    assert details == {"called sys.exit(0)"}


def test_an_endless_generator_is_stopped_at_the_limit(ur5: dhkin.Robot) -> None:
    started = time.perf_counter()
    report = validate(ur5, broken.endless, n=1, reference="exact")
    assert_reported(report, f"more than {MAX_SOLUTIONS_PER_CALL} solutions",
                    "MAX_SOLUTIONS_PER_CALL")
    assert all(len(f.returned) == KEPT_OF_A_BAD_ANSWER for f in report.failures)
    assert time.perf_counter() - started < 20


def test_a_call_over_the_time_limit_is_a_failure_of_its_pose(capsys, monkeypatch) -> None:
    monkeypatch.chdir(REPO)
    started = time.perf_counter()
    code, out, _ = run(capsys, "validate", "ur5", "--ik", "tests.broken:sleeps", "-n", "1",
                       "--timeout", "0.2", "--reference", "exact", "--failures", "/dev/null")
    assert code == 1 and "no_solution 100.000% (3)" in out
    assert time.perf_counter() - started < 30


def test_the_time_limit_gives_back_an_earlier_timer(ur5: dhkin.Robot) -> None:
    fired: list[int] = []

    def ours(signum: int, frame: Any) -> None:
        fired.append(signum)

    previous = signal.signal(signal.SIGALRM, ours)
    try:
        signal.setitimer(signal.ITIMER_REAL, 100.0)
        report = validate(ur5, broken.sleeps, n=1, timeout=0.1, reference="exact")
        remaining = signal.getitimer(signal.ITIMER_REAL)[0]
        assert_reported(report, "timed out", "0.1 s")
        assert 90.0 < remaining <= 100.0 and not fired
        assert signal.getsignal(signal.SIGALRM) is ours
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def test_isolated_calls_survive_a_crash_and_a_hang(ur5: dhkin.Robot) -> None:
    assert_reported(validate(ur5, broken.crashes, n=1, isolate=True, reference="exact"),
                    "process died", "SIGSEGV")
    assert_reported(validate(ur5, broken.sleeps, n=1, isolate=True, timeout=0.3,
                             reference="exact"), "timed out")
    assert_reported(validate(ur5, broken.exits, n=1, isolate=True, reference="exact"),
                    "sys.exit(0)")
    assert validate(ur5, correct(ur5), n=N, isolate=True, reference="exact").ok


def test_isolate_without_fork_needs_a_picklable_ik(ur5: dhkin.Robot, monkeypatch) -> None:
    """Where only spawn exists, an IK that cannot be pickled is one clear error, not a crash."""
    monkeypatch.setattr(multiprocessing, "get_all_start_methods", lambda: ["spawn"])
    with pytest.raises(InputError, match=r"^isolate: cannot start the IK in a child process"):
        validate(ur5, lambda T: [], n=1, isolate=True, reference="exact")


def test_isolate_on_the_command_line(capsys, monkeypatch) -> None:
    monkeypatch.chdir(REPO)
    code, out, _ = run(capsys, "validate", "ur5", "--ik", "tests.broken:crashes", "--isolate",
                       "-n", "1", "--reference", "exact", "--failures", "/dev/null")
    assert code == 1 and "no_solution 100.000% (3)" in out


# ---------------------------------------------------------------------------------------------
# Bad return values, bad modules


@pytest.mark.parametrize(("ik", "words"), [
    (broken.raises, ("raised ZeroDivisionError", "divided by zero second line")),
    (broken.returns_none, ("returned None", "expected an iterable of joint vectors")),
    (broken.returns_a_scalar, ("returned float 0.5",)),
    (broken.returns_strings, ("strings",)),
    (broken.returns_the_wrong_shape, ("expected (6,)",)),
    (broken.exits, ("sys.exit(0)",)),
])
def test_bad_return_values_are_reported(ur5: dhkin.Robot, ik: Any, words: tuple[str]) -> None:
    report = validate(ur5, ik, n=N, reference="exact")
    if ik is broken.returns_the_wrong_shape:  # a pose with 2 branches gives a (6, 2) array
        assert not report.ok and report.counts["wrong"] == report.samples
    else:
        assert_reported(report, *words)


@pytest.mark.parametrize(("source", "spec", "words"), [
    ("raise RuntimeError('boom\\nsecond line')\n", "hostile_raises:ik",
     ("raised RuntimeError: boom second line",)),
    ("import sys\nsys.exit(3)\n", "hostile_exits:ik", ("raised SystemExit",)),
    ("def ik(:\n", "hostile_syntax:ik", ("raised SyntaxError",)),
    ("ik = 5\n", "hostile_data:ik", ("is a int, not a callable",)),
    ("", "hostile_empty:ik", ("no callable 'ik'",)),
    (None, "hostile_no_such_module:ik", ("cannot import module",)),
    (None, "hostile_data", ("expected 'module:function'",)),
    (None, "a:b:c", ("expected 'module:function'",)),
    (None, "hostile data:ik", ("expected 'module:function'",)),
])
def test_bad_ik_modules_are_one_line_errors(capsys, monkeypatch, tmp_path, source: str | None,
                                            spec: str, words: tuple[str]) -> None:
    module = spec.split(":")[0]
    if source is not None:
        (tmp_path / f"{module}.py").write_text(source)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "validate", "ur5", "--ik", spec, "-n", "1")
    assert_one_line_error(code, err, "--ik", *words)
    sys.modules.pop(module, None)


# ---------------------------------------------------------------------------------------------
# Failure files


def _nested(depth: int) -> str:
    return "[" * depth + "]" * depth


@pytest.mark.parametrize(("edit", "named"), [
    (lambda d: d.update(tolerance="1e-9"), ["tolerance", "'1e-9'"]),
    (lambda d: d.update(tolerance=1.0), ["tolerance", "(0, 0.01]"]),
    (lambda d: d.pop("joint_tolerance"), ["joint_tolerance", "missing"]),
    (lambda d: d.update(seed=-1), ["seed", "integer >= 0"]),
    (lambda d: d.update(seed=1.5), ["seed"]),
    (lambda d: d.update(complete_expected="yes"), ["complete_expected"]),
    (lambda d: d.update(robot="ur10"), ["robot", "'ur10'"]),
    (lambda d: d.update(reference={"kind": "rounded", "digits": "ten"}), ["reference.digits"]),
    (lambda d: d.update(reference={"kind": "vendor", "path": 5}), ["reference.path"]),
    (lambda d: d.update(failures=[]), ["failures", "1 to"]),
    (lambda d: d.update(failures={"0": 1}), ["failures"]),
    (lambda d: d["failures"].__setitem__(1, 5), ["failures[1]", "an object"]),
    (lambda d: d["failures"][1].update(q_sampled=[0.1] * 12),
     ["failures[1].q_sampled", "6 finite joint values", "12 values"]),
    (lambda d: d["failures"][2].update(q_sampled=["0.1"] * 6), ["failures[2].q_sampled"]),
    (lambda d: d["failures"][2].update(q_sampled=[True] * 6), ["failures[2].q_sampled"]),
    (lambda d: d["failures"][0].update(q_sampled=[10.0] * 6),
     ["failures[0].q_sampled", "within its joint limits"]),
    (lambda d: d["failures"][0].update(q_sampled=[10**400] * 6), ["failures[0].q_sampled"]),
    (lambda d: d["failures"][0].pop("q_sampled"), ["failures[0].q_sampled", "missing"]),
    (lambda d: d["failures"][0].update(sample_set="bogus"), ["failures[0].sample_set"]),
    (lambda d: d["failures"][0].update(perturbed_seed=[math.nan] * 6),
     ["failures[0].perturbed_seed"]),
])
def test_bad_failure_file_values_name_file_entry_and_field(tmp_path, ur5: dhkin.Robot,
                                                           edit: Any, named: list[str]) -> None:
    path, data = _failure_file(ur5, tmp_path)
    assert len(data["failures"]) >= 3
    edit(data)
    path.write_text(json.dumps(data))
    with pytest.raises(InputError) as caught:
        replay(ur5, broken.garbage_row, path)
    message = str(caught.value)
    assert message.startswith(f"{path}: ") and "\n" not in message
    for text in named:
        assert text in message, message


@pytest.mark.parametrize(("text", "named"), [
    (_nested(10_000), "nested too deeply"),
    ('{"robot": "ur5", "failures": ' + _nested(10_000) + "}", "nested too deeply"),
    ("[1, 2]", "top level"),
    ("{", "not JSON"),
    ("\xff\xfe", "not JSON"),
    ("{}", "not a dhkin failure file"),
])
def test_malformed_failure_files_are_one_line_errors(capsys, tmp_path, text: str,
                                                     named: str) -> None:
    path = tmp_path / "bad.json"
    path.write_text(text, encoding="utf-8")
    code, _, err = run(capsys, "validate", "ur5", "--replay", str(path))
    assert_one_line_error(code, err, str(path), named)


def test_a_valid_failure_file_reads_back(tmp_path, ur5: dhkin.Robot) -> None:
    path, data = _failure_file(ur5, tmp_path)
    recorded = read_failure_file(path, ur5)
    assert recorded.q.tolist() == [f["q_sampled"] for f in data["failures"]]
    assert recorded.reference.kind == "exact" and recorded.tolerance == data["tolerance"]


# ---------------------------------------------------------------------------------------------
# Command line: options that need --ik, the robot's own IK for every arm


@pytest.mark.parametrize("option", [["--deg"], ["--ik-frame", "flange"],
                                    ["--deg", "--ik-frame", "flange"]])
def test_ik_options_without_ik_are_usage_errors(capsys, option: list[str]) -> None:
    code, _, err = run(capsys, "validate", "ur5", *option, "-n", "1")
    assert_one_line_error(code, err, option[0], "--ik")


def test_the_cli_validates_a_robot_without_closed_form(capsys, tmp_path) -> None:
    code, out, err = run(capsys, "validate", "planar_2r", "-n", "5", "--failures", "/dev/null")
    assert code == 0 and "PASS" in out and not err
    table = yaml.safe_load((REPO / "robots" / "ur5.yaml").read_text())
    extra = {k: v for k, v in table["joints"][-1].items() if k != "link"}
    table["joints"].append({**extra, "name": "extra_joint"})
    table["name"] = "seven"
    path = tmp_path / "seven.yaml"
    path.write_text(yaml.safe_dump(table))
    code, out, err = run(capsys, "validate", str(path), "-n", "5", "--failures",
                         str(tmp_path / "f.json"))
    assert code == 0, out + err
    assert "numerical" in out and "one solution per call" in out and "Traceback" not in err
    assert dhkin.validate(dhkin.load(path), n=5).ok


def test_the_readme_call_works(ur5: dhkin.Robot) -> None:
    report = dhkin.validate(ur5, correct(ur5), n=N, seed=0, reference="exact")
    assert isinstance(report, ValidationReport) and report.ok
    assert dhkin.validate is validate


def test_no_code_imports_the_old_module_name() -> None:
    old = "dhkin." + "validate"
    patterns = (f"from {old} import", f"import {old}", f"{old}.")
    found = [f"{path.relative_to(REPO)}: {pattern}"
             for folder in ("src", "tests", "scripts", "docs")
             for path in (REPO / folder).rglob("*.*") if path.suffix in (".py", ".md")
             for pattern in patterns if pattern in path.read_text(encoding="utf-8")]
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    found += [f"README.md: {p}" for p in patterns if p in readme]
    assert not found


# ---------------------------------------------------------------------------------------------
# Fuzz: hostile IKs (fixed seeds)


class _Custom(BaseException):
    """Not an Exception: only a BaseException guard catches it."""


GOOD = ("correct", "generator", "lists", "mutate_and_swallow")
BAD = ("raise", "none", "scalar", "string", "mapping", "ragged", "nan_row", "inf_row",
       "huge_rows", "flat", "huge_values", "complex", "booleans", "objects", "garbage_later",
       "raise_later", "endless", "mutate", "exit", "timeout", "three_d", "extra_column", "empty",
       "custom_base_exception")


class HostileIK:
    """Picks a behaviour per call (fixed seed); records which calls misbehaved, by target."""

    def __init__(self, robot: dhkin.Robot, seed: int) -> None:
        self.robot = robot
        self.rng = np.random.default_rng(seed)
        self.calls: list[tuple[bytes, str]] = []
        self.__name__ = f"hostile[{seed}]"

    def __call__(self, T: np.ndarray, q_seed: np.ndarray | None = None) -> Any:
        # mostly good behaviour, so that good and bad samples mix
        name = str(self.rng.choice(GOOD) if self.rng.random() < 0.4 else self.rng.choice(BAD))
        self.calls.append((np.array(T).tobytes(), name))
        q = self.robot.ik(T, q_seed=q_seed).q
        return getattr(self, name)(T, q_seed, q)

    def correct(self, T: Any, q_seed: Any, q: np.ndarray) -> Any:
        return q

    def generator(self, T: Any, q_seed: Any, q: np.ndarray) -> Any:
        return (row for row in q)

    def lists(self, T: Any, q_seed: Any, q: np.ndarray) -> Any:
        return q.tolist()

    def mutate_and_swallow(self, T: np.ndarray, q_seed: np.ndarray, q: np.ndarray) -> Any:
        for array in (T, q_seed):
            with contextlib.suppress(ValueError):  # read-only: the IK carries on regardless
                array[...] = 0.0
        return q

    def raise_(self) -> Any:
        kind = [ValueError, RuntimeError, KeyError, ZeroDivisionError, RecursionError,
                MemoryError, UnreachableError][int(self.rng.integers(7))]
        raise kind("hostile\nmessage")

    def __getattr__(self, name: str) -> Any:
        behaviours = {
            "raise": lambda T, s, q: self.raise_(),
            "none": lambda T, s, q: None,
            "scalar": lambda T, s, q: 1.5,
            "string": lambda T, s, q: "0 0 0 0 0 0",
            "mapping": lambda T, s, q: {i: row for i, row in enumerate(q)},
            "ragged": lambda T, s, q: [list(q[0]), list(q[0][:3])],
            "nan_row": lambda T, s, q: np.vstack([q, np.full(6, np.nan)]),
            "inf_row": lambda T, s, q: np.vstack([q, np.full(6, np.inf)]),
            "huge_rows": lambda T, s, q: np.zeros((MAX_SOLUTIONS_PER_CALL + 5, 6)),
            "flat": lambda T, s, q: np.zeros(10**6),
            "huge_values": lambda T, s, q: q * 1e300,
            "complex": lambda T, s, q: q + 1e-3j,
            "booleans": lambda T, s, q: np.ones(q.shape, dtype=bool),
            "objects": lambda T, s, q: [[object()] * 6],
            "garbage_later": lambda T, s, q: iter([*q, "x"]),
            "raise_later": lambda T, s, q: self._raise_later(q),
            "endless": lambda T, s, q: self._endless(q),
            "mutate": lambda T, s, q: T.__setitem__((0, 3), 0.0),
            "exit": lambda T, s, q: sys.exit(int(self.rng.integers(-1, 3))),
            "timeout": lambda T, s, q: time.sleep(30),
            "three_d": lambda T, s, q: q[None],
            "extra_column": lambda T, s, q: np.hstack([q, np.zeros((len(q), 1))]),
            "empty": lambda T, s, q: [],
            "custom_base_exception": lambda T, s, q: self._custom(),
        }
        if name in behaviours:
            return behaviours[name]
        raise AttributeError(name)

    @staticmethod
    def _raise_later(q: np.ndarray) -> Any:
        yield q[0]
        raise RuntimeError("a generator that fails half way")

    @staticmethod
    def _endless(q: np.ndarray) -> Any:
        while True:
            yield q[0]

    @staticmethod
    def _custom() -> Any:
        raise _Custom("not an Exception")


@pytest.mark.parametrize("seed", range(16))  # together they use every behaviour (2+ times)
def test_fuzz_hostile_iks_are_reported_never_passed(ur5: dhkin.Robot, seed: int) -> None:
    n = 8
    ik = HostileIK(ur5, seed)
    report = validate(ur5, ik, n=n, seed=seed, reference="exact", timeout=0.2)
    q, sets = sample_joint_vectors(ur5, n, seed)
    targets = {T.tobytes(): k for k, T in enumerate(target_model(ur5, "exact").fk(q))}
    bad = {targets[target] for target, name in ik.calls if name in BAD}
    failed = {f.index for f in report.failures}
    assert failed == bad, [(targets[t], name) for t, name in ik.calls]
    assert report.ok == (not bad)
    assert sum(report.counts.values()) == report.samples == len(sets)
    assert all(math.isfinite(report.rate(o)) for o in report.counts)
    assert all(math.isfinite(v) for v in report.residuals.values())
    for failure in report.failures:
        assert failure.detail and "\n" not in failure.detail and len(failure.detail) < 2000


# ---------------------------------------------------------------------------------------------
# Fuzz: hostile arguments


_COMMON_BAD: tuple[Any, ...] = (math.nan, math.inf, -math.inf, -1, "1e-9", True, [1e-9],
                                complex(1e-9, 0), np.float64("nan"), Decimal("1e-9"), {}, b"1")
HOSTILE_ARGUMENTS: dict[str, tuple[Any, ...]] = {
    "n": (*_COMMON_BAD, 0, None, 1.5, 2.0, 10**7),
    "seed": (*_COMMON_BAD, None, 1.5, -(2**70)),
    "tolerance": (*_COMMON_BAD, 0, None, 1.0, 1e308, -0.0),
    "joint_tolerance": (*_COMMON_BAD, 0, None, 1.0, 1e308),
    "timeout": (*_COMMON_BAD, 0, -0.5),
    "progress": (None, 0, 1, "yes", math.nan),
    "isolate": (None, 0, 1, "yes", math.nan),
    "complete_expected": (0, 1, "yes", math.nan),
    "ik_name": (5, b"x", ["a"]),
    "ik": (5, "tests.broken:sign_flip", [1]),
}


@pytest.mark.parametrize("name", sorted(HOSTILE_ARGUMENTS))
def test_fuzz_hostile_arguments_are_one_line_input_errors(ur5: dhkin.Robot, name: str) -> None:
    rng = np.random.default_rng(15)
    values = list(HOSTILE_ARGUMENTS[name])
    for index in rng.permutation(len(values)):
        value = values[int(index)]
        with pytest.raises(InputError) as caught:
            validate(ur5, **{"ik": correct(ur5), "n": N, name: value})
        message = str(caught.value)
        assert caught.value.field == name, (value, message)
        assert message.startswith(f"{name}: expected") and "\n" not in message
