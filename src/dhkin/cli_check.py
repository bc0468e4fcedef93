"""`dhkin check`, the main job: the checks of dhkin.checks robot by robot, a line for each as it
finishes (dhkin.check_report; in the order the robots were named), a progress bar on a
terminal, then the failed checks, a summary and, asked for, every figure (``--details``,
``--json FILE``). Exit 1 if a check failed. ``--jobs N`` (default: the CPUs this process may
use) checks N robots at once, each in a worker process; the figures do not depend on it."""

from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing
import signal
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dhkin.cli_input import EXIT_FAILED, EXIT_OK
from dhkin.errors import DhkinError
from dhkin.robot import builtin_dir, builtin_names, load

if TYPE_CHECKING:
    from dhkin.checks import CheckOptions, RobotCheck


def cmd_check(args: argparse.Namespace) -> int:
    """Run `dhkin check` (see the module docstring)."""
    from tqdm import tqdm

    from dhkin import check_report
    from dhkin.checks import VENDOR_POSES, CheckOptions, check_robot
    from dhkin.files import check_output, write_file
    from dhkin.ik.workers import default_workers
    from dhkin.vendors import vendor_dir

    if not args.all and not args.robots:
        raise DhkinError("check: name robots to check, or --all for every built-in robot")
    if args.json is not None:  # checked before the run, so that no result is lost after it
        check_output(args.json, "--json", force=args.force)
    names = builtin_names() if args.all else args.robots
    reference_dir = Path(args.reference_dir) if args.reference_dir else vendor_dir()
    options = CheckOptions(reference_dir=reference_dir, ik_poses=args.ik_poses,
                           vendor_poses=(VENDOR_POSES if args.vendor_poses is None
                                         else args.vendor_poses), seed=args.seed)
    print(f"built-in robots: {builtin_dir()}", file=sys.stderr)
    print(f"vendor references: {reference_dir}", file=sys.stderr)
    started = time.perf_counter()
    robots = [load(name) for name in names]
    shown = [robot.name for robot in robots]
    for line in check_report.header_lines(shown):
        print(line, flush=True)
    results = []
    jobs = min(len(robots), default_workers() if args.jobs is None else args.jobs)
    with contextlib.ExitStack() as stack:
        if jobs > 1:  # the pool first: its processes start before any thread of this one
            from dhkin.checks import longest_first

            pool = stack.enter_context(_pool(jobs))
            # started longest first, read (and printed) in the order named
            started_checks = {k: pool.apply_async(_check_in_worker,
                                                  ((names[k], replace(options, progress=False)),))
                              for k in longest_first(robots)}
            checked = (started_checks[k].get() for k in range(len(names)))
        else:
            checked = (check_robot(robot, options) for robot in robots)
        # disable=None: no bar when stderr is not a terminal (tqdm's own test).
        bar = stack.enter_context(tqdm(checked, total=len(robots), desc="dhkin check",
                                       unit="robot", file=sys.stderr, disable=None,
                                       leave=False))
        for result in bar:
            results.append(result)
            tqdm.write(check_report.robot_line(result, shown), file=sys.stdout)
            sys.stdout.flush()
    seconds = time.perf_counter() - started
    for line in [*check_report.failure_lines(results),
                 *check_report.summary_lines(results, seconds)]:
        print(line)
    if args.details:
        print()
        print(check_report.details(results))
    if args.json is not None:
        write_file(args.json, json.dumps(check_report.to_json(results, options, seconds),
                                         indent=1), "--json", args.force)
        print(f"figures written to {args.json}")
    passed = all(result.ok for result in results)
    print("all checks passed" if passed else "SOME CHECKS FAILED")
    return EXIT_OK if passed else EXIT_FAILED


def _ignore_interrupts() -> None:
    """A worker leaves Ctrl-C to the command, which ends the pool and says it once."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _pool(jobs: int) -> Any:
    """``jobs`` worker processes, started afresh ("spawn": not forked from this process, whose
    IK worker threads a fork would not carry over)."""
    return multiprocessing.get_context("spawn").Pool(jobs, initializer=_ignore_interrupts)


def _check_in_worker(task: tuple[str, CheckOptions]) -> RobotCheck:
    """One robot's checks in a worker process (the robot given by name or table path)."""
    from dhkin.checks import check_named

    return check_named(*task)
