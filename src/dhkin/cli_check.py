"""`dhkin check`, the main job: the checks of dhkin.checks robot by robot, a line for each as it
finishes (dhkin.check_report), a progress bar on a terminal, then the failed checks, a summary
and, asked for, every figure (``--details``, ``--json FILE``). Exit 1 if a check failed."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from dhkin.cli_input import EXIT_FAILED, EXIT_OK
from dhkin.errors import DhkinError
from dhkin.robot import builtin_dir, builtin_names, load


def cmd_check(args: argparse.Namespace) -> int:
    """Run `dhkin check` (see the module docstring)."""
    from tqdm import tqdm

    from dhkin import check_report
    from dhkin.checks import VENDOR_POSES, CheckOptions, check_robot
    from dhkin.files import check_output, write_file
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
    # disable=None: no bar when stderr is not a terminal (tqdm's own test).
    with tqdm(robots, desc="dhkin check", unit="robot", file=sys.stderr, disable=None,
              leave=False) as bar:
        for robot in bar:
            bar.set_postfix_str(robot.name)
            result = check_robot(robot, options)
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
