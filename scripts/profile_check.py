"""Where the time of `dhkin check` goes: IK, Pinocchio, sampling, the vendor checks, the rest.

Runs ``dhkin check`` (default ``--all``) with light timers around the functions that do each
kind of work and prints, per robot and in all, the seconds of each check (the columns of
``dhkin check --details``) split into:

* ``ik``: dhkin's IK (``Robot.ik``, ``ik_batch``, ``ik_batch_detailed``; whatever they call,
  numerical IK's Pinocchio calls included): the IK under test, the branches of the
  missing-branch check and the configuration labels;
* ``pinocchio``: the oracle outside the IK (``Reference.fk`` / ``jacobian`` / building a model):
  targets, checking each returned solution, sigma_min where a joint difference needs it;
* ``sampling``: the joint vectors and perturbed seeds of the validations;
* ``guard``: calling the IK as a guarded experiment (``IKCaller``: read-only copies, a timer,
  reading the answer), the IK itself excluded;
* ``other``: the rest of each check (Python bookkeeping of the validation, xacro and the URDF
  validators, ...).

The timers measure wall time; on a machine shared with other jobs compare the CPU time printed
beside the wall time (this process, all threads). A timer counts its time once: the outermost
``ik`` call owns everything inside it; other categories nest exclusively (a Pinocchio call
inside the guard counts as Pinocchio). The timers cost about a microsecond per call, so figures
are within a few per cent of a plain run.

Usage: python scripts/profile_check.py [ROBOT ...] [--ik-poses N] [--vendor-poses N]
(no ROBOT: every built-in robot). Run on an otherwise idle machine; say how loaded it was.
"""

from __future__ import annotations

import argparse
import functools
import io
import os
import sys
import time
from collections import defaultdict
from collections.abc import Callable
from contextlib import redirect_stdout
from typing import Any

from dhkin import checks
from dhkin.cli import main as dhkin_main
from dhkin.reference import Reference
from dhkin.robot import Robot
from dhkin.validation import calls, run

CATEGORIES = ("ik", "pinocchio", "sampling", "guard", "other")

#: seconds[robot][column][category]
seconds: dict[str, dict[str, dict[str, float]]] = defaultdict(
    lambda: defaultdict(lambda: defaultdict(float)))
_stack: list[list[Any]] = []  # [category, start, child seconds]
_current = {"robot": "", "column": ""}


def _timed(category: str, function: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if any(frame[0] == "ik" for frame in _stack):
            return function(*args, **kwargs)  # the outermost IK call owns it
        _stack.append([category, time.perf_counter(), 0.0])
        try:
            return function(*args, **kwargs)
        finally:
            name, start, children = _stack.pop()
            spent = time.perf_counter() - start
            seconds[_current["robot"]][_current["column"]][name] += spent - children
            if _stack:
                _stack[-1][2] += spent
    return wrapper


def _column(column: str, function: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        robot = args[0]
        _current.update(robot=robot.name, column=column)
        return _timed("other", function)(*args, **kwargs)
    return wrapper


def install() -> None:
    for name in ("ik", "ik_batch", "ik_batch_detailed"):
        setattr(Robot, name, _timed("ik", getattr(Robot, name)))
    for name in ("fk", "jacobian", "__init__"):
        setattr(Reference, name, _timed("pinocchio", getattr(Reference, name)))
    for name in ("sample_joint_vectors", "perturbed_seeds"):
        setattr(run, name, _timed("sampling", getattr(run, name)))
    calls.IKCaller.__call__ = _timed("guard", calls.IKCaller.__call__)  # type: ignore[method-assign]
    for column, name in (("generated", "check_generated"), ("validators", "check_validators"),
                         ("fk vs pin", "check_fk"), ("vendor", "check_vendor"),
                         ("ik vs pin", "check_ik"), ("ik vs vendor", "check_ik_vendor")):
        setattr(checks, name, _column(column, getattr(checks, name)))


def table(rows: dict[str, dict[str, float]], title: str) -> str:
    lines = [f"{title:<22}" + "".join(f"{c:>11}" for c in (*CATEGORIES, "total"))]
    for label, by_category in rows.items():
        total = sum(by_category.values())
        lines.append(f"{label:<22}" + "".join(f"{by_category.get(c, 0.0):>10.1f}s"
                                              for c in CATEGORIES) + f"{total:>10.1f}s")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robots", nargs="*")
    parser.add_argument("--ik-poses", default="10000")
    parser.add_argument("--vendor-poses", default="2000")
    args = parser.parse_args(argv)
    install()
    # --jobs 1: the timers live in this process (the figures do not depend on the jobs)
    command = ["check", *(args.robots or ["--all"]), "--ik-poses", args.ik_poses,
               "--vendor-poses", args.vendor_poses, "--jobs", "1"]
    started, cpu_started = time.perf_counter(), time.process_time()
    output = io.StringIO()
    with redirect_stdout(output):
        status = dhkin_main(command)
    wall, cpu = time.perf_counter() - started, time.process_time() - cpu_started
    print(output.getvalue())
    by_column: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
    by_robot: dict[str, dict[str, float]] = {}
    for robot, columns in seconds.items():
        by_robot[robot] = defaultdict(float)
        for column, by_category in columns.items():
            for category, value in by_category.items():
                by_column[column][category] += value
                by_robot[robot][category] += value
    total: dict[str, float] = defaultdict(float)
    for by_category in by_column.values():
        for category, value in by_category.items():
            total[category] += value
    print(f"dhkin {' '.join(command)}: {wall:.1f} s wall, {cpu:.1f} s CPU (this process, all "
          f"threads), {os.cpu_count()} CPUs, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())} at the end")
    print(table(by_column, "by check"))
    print(table({"all checks": total}, ""))
    print(table(by_robot, "by robot"))
    return status


if __name__ == "__main__":
    sys.exit(main())
