#!/usr/bin/env python
"""Which of two builds of dhkin is faster? Both answer the same poses, call by call on one CPU.

    python scripts/ab_builds.py /path/to/A/bin/python /path/to/B/bin/python [ROBOT ...]
    python scripts/ab_builds.py A_PYTHON B_PYTHON ur5 --rounds 400 --cpu 1 --poses 10000

Each build is an interpreter whose environment has that build installed (a clone with its own
venv, as for scripts/compare_builds.py). One worker process per build stays up for the whole
run, pinned to the same CPU (``taskset``), and the two take turns: round r times one
``ik_batch(T, copies=False, workers=1)`` of the same poses in each (the order swapped every
round), so that both see the same load. On a machine shared with other work a build's own
figure moves by +-15 % from run to run; the ratio of the two within a round moves much less.

Printed per robot: each build's median poses/s (process time of the call) and its best, the
median over rounds of B's rate over A's (the figure to read: above 1, B is faster), and the
median single-call ``robot.ik(T)`` time (wall, 2,000 poses, three rounds) of each.
Poses: ``--poses`` joint vectors drawn within the limits (seed 25), tool0 poses by Pinocchio FK.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time


def worker(poses: int) -> None:
    """Answer commands from stdin, one line each: ``batch ROBOT`` (poses/s of one batch call)
    or ``single ROBOT`` (median time of one ik call, us)."""
    import numpy as np

    import dhkin

    cache: dict[str, tuple[dhkin.Robot, np.ndarray]] = {}
    print("ready", flush=True)
    for line in sys.stdin:
        command, name = line.split()
        if name not in cache:
            robot = dhkin.load(name)
            rng = np.random.default_rng(25)
            q = rng.uniform(robot.lower, robot.upper, size=(poses, len(robot.lower)))
            T = np.ascontiguousarray(robot.reference().fk(q))
            robot.ik_batch(T, copies=False, workers=1)  # warm
            cache[name] = (robot, T)
        robot, T = cache[name]
        if command == "batch":
            start = time.process_time()
            robot.ik_batch(T, copies=False, workers=1)
            print(len(T) / (time.process_time() - start), flush=True)
        else:
            times = []
            for target in T[:2000]:
                start_ns = time.perf_counter_ns()
                robot.ik(target)
                times.append(time.perf_counter_ns() - start_ns)
            print(statistics.median(times) / 1000.0, flush=True)


class Build:
    """A worker process of one build, pinned to `cpu`."""

    def __init__(self, python: str, cpu: str, poses: int) -> None:
        command = [python, os.path.abspath(__file__), "--worker", "--poses", str(poses)]
        self.process = subprocess.Popen(["taskset", "-c", cpu, *command], text=True,
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        if self.ask_line() != "ready":
            raise RuntimeError(f"{python}: the worker did not start")

    def ask_line(self) -> str:
        assert self.process.stdout is not None
        return self.process.stdout.readline().strip()

    def ask(self, command: str) -> float:
        assert self.process.stdin is not None
        self.process.stdin.write(command + "\n")
        self.process.stdin.flush()
        return float(self.ask_line())

    def close(self) -> None:
        assert self.process.stdin is not None
        self.process.stdin.close()
        self.process.wait()


def alternate(a: Build, b: Build, command: str, rounds: int) -> tuple[list[float], list[float]]:
    """`command` in A and B, `rounds` times each, the order swapped every round."""
    out_a: list[float] = []
    out_b: list[float] = []
    for r in range(rounds):
        turns = ((a, out_a), (b, out_b)) if r % 2 == 0 else ((b, out_b), (a, out_a))
        for build, out in turns:
            out.append(build.ask(command))
    return out_a, out_b


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("python_a", nargs="?")
    parser.add_argument("python_b", nargs="?")
    parser.add_argument("robots", nargs="*", default=["ur5", "abb_irb1200_7_70"])
    parser.add_argument("--rounds", type=int, default=400, help="batch calls per build")
    parser.add_argument("--poses", type=int, default=10_000)
    parser.add_argument("--cpu", default="1", help="the CPU both workers run on")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.poses)
        return
    if args.python_a is None or args.python_b is None:
        parser.error("two interpreters are needed (A and B)")
    print(f"load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}; CPU {args.cpu}; "
          f"{args.poses} poses; {args.rounds} batch calls per build")
    a, b = Build(args.python_a, args.cpu, args.poses), Build(args.python_b, args.cpu, args.poses)
    try:
        for name in args.robots:
            rate_a, rate_b = alternate(a, b, f"batch {name}", args.rounds)
            ratio = statistics.median(y / x for x, y in zip(rate_a, rate_b, strict=True))
            single_a, single_b = alternate(a, b, f"single {name}", 3)
            print(f"{name}: batch A {statistics.median(rate_a) / 1e6:.3f} M/s (best "
                  f"{max(rate_a) / 1e6:.3f}), B {statistics.median(rate_b) / 1e6:.3f} M/s (best "
                  f"{max(rate_b) / 1e6:.3f}); B/A {ratio:.3f}; single call A "
                  f"{statistics.median(single_a):.2f} us, B {statistics.median(single_b):.2f} us",
                  flush=True)
    finally:
        a.close()
        b.close()
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
