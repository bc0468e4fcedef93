#!/usr/bin/env python
"""Where a refined table's IK time goes, pose by pose: the heavy tail against the common case.

    python scripts/profile_refined.py [--poses 3000] [ROBOT ...]

For each robot (default: ur5e_calibrated, tm5_900, kinova_gen3_6dof), poses drawn uniformly
within the limits (fixed seed, Pinocchio FK on the table) are solved one call at a time
(``robot.ik(T, copies=False)``, unseeded) and each call is timed. Printed per robot: the median,
mean and upper quantiles of the per-call time, the share of poses and of the total time above
10, 100 and 1000 us, and the same against the number of branches the ideal model solves (a pose
whose ideal model misses branches has long shots: candidates clamped onto a reach boundary that
the pipeline chases on the exact chain before it drops them, unless cpp/dhkin/reach_bound.hpp
shows that the exact chain cannot reach them), and against the least |sin q5| among the
solutions answered (near the wrist singular set the valley scans and seeded candidates run). The
mean is what ``ik_batch`` pays per pose; the median is the single-call figure of
scripts/bench_ik.py. Also printed: the refined direct path alone on the poses it settles against
the ideal model's whole batch on them (the floor of a refined table's batch time).
"""

from __future__ import annotations

import argparse
import gc
import time
from collections.abc import Callable, Sequence

import numpy as np

import dhkin

ROBOTS = ("ur5e_calibrated", "tm5_900", "kinova_gen3_6dof")


#: Classes of poses by the least |sin q5| among the solutions answered: the wrist singular set's
#: neighbourhood, where the valley scans and seeded candidates run, and the rest.
WRIST_CLASSES = ((0.0, 0.05), (0.05, 0.2), (0.2, 1.01))


def call_times(robot: dhkin.Robot, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-call time (us) of robot.ik(T, copies=False) for each pose, after one warm-up pass, and
    the least |sin q5| among each pose's solutions (inf for none)."""
    for T in poses[:50]:
        robot.ik(T, copies=False)
    times = np.empty(len(poses))
    wrist = np.full(len(poses), np.inf)
    gc.disable()
    try:
        for i, T in enumerate(poses):
            start = time.perf_counter_ns()
            solutions = robot.ik(T, copies=False)
            times[i] = (time.perf_counter_ns() - start) / 1e3
            if len(solutions):
                wrist[i] = np.abs(np.sin(solutions.q[:, 4])).min()
    finally:
        gc.enable()
    return times, wrist


def best_seconds(call: Callable[[], object], runs: int = 3) -> float:
    """The fastest of `runs` wall times of call() (s)."""
    best = np.inf
    for _ in range(runs):
        start = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - start)
    return float(best)


def floor_lines(robot: dhkin.Robot, ideal: dhkin.Robot, poses: np.ndarray,
                times: np.ndarray) -> list[str]:
    """The refined direct path alone (closed form of the ideal model, Newton on the exact chain
    for the eight branches in lanes, verification; ``refined_direct_answers``) on the poses it
    settles, against the ideal model's whole ``ik_batch`` on the same poses: the least a refined
    table's batch could cost per pose if no pose needed the pipeline."""
    solver = robot.ik_solver
    seeds = np.zeros((len(poses), robot.dof))  # unseeded: the zero seed, as robot.ik
    settled = np.zeros(len(poses), np.bool_)
    solver.core.refined_direct_answers(poses, seeds, 1e-9, solver.frames, settled)
    direct = np.ascontiguousarray(poses[settled])
    answered = np.zeros(len(direct), np.bool_)
    direct_us = best_seconds(lambda: solver.core.refined_direct_answers(
        direct, seeds[:len(direct)], 1e-9, solver.frames, answered)) / len(direct) * 1e6
    ideal_us = best_seconds(
        lambda: ideal.ik_batch(direct, copies=False, workers=1)) / len(direct) * 1e6
    left = ~settled
    return [f"refined direct path: settles {settled.mean():.1%} of the poses; on those it takes "
            f"{direct_us:.2f} us per pose alone, the ideal model's whole ik_batch "
            f"{ideal_us:.3f} us (x{direct_us / ideal_us:.1f}); the poses it leaves to the "
            f"pipeline take {times[left].mean() if left.any() else 0.0:.0f} us per call on "
            f"average, {times[left].sum() / times.sum():.1%} of the time", ""]


def report(name: str, n: int) -> list[str]:
    robot = dhkin.load(name)
    q = robot.table.random_q(n, np.random.default_rng(25))
    poses = np.ascontiguousarray(robot.reference().fk(q))
    times, wrist = call_times(robot, poses)
    ideal = dhkin.Robot(robot.ik_solver.fit.ideal)
    ideal_branches = ideal.ik_batch_detailed(poses, copies=False, workers=1).valid.sum(axis=1)
    quantiles = np.quantile(times, [0.5, 0.9, 0.99])
    lines = [f"### {name}: {n} poses", "",
             f"per call: median {quantiles[0]:.1f} us, mean {times.mean():.1f} us, "
             f"p90 {quantiles[1]:.1f} us, p99 {quantiles[2]:.1f} us, max {times.max():.0f} us",
             "", "| calls over | poses | share of the time |", "|---|---:|---:|"]
    for limit in (10, 100, 1000):
        slow = times > limit
        lines.append(f"| {limit} us | {slow.mean():.1%} | {times[slow].sum() / times.sum():.1%} |")
    lines += ["", *floor_lines(robot, ideal, poses, times)]
    lines += ["", "| ideal model branches | poses | median (us) | mean (us) | share of time |",
              "|---:|---:|---:|---:|---:|"]
    for count in np.unique(ideal_branches):
        group = ideal_branches == count
        lines.append(f"| {count} | {group.sum()} | {np.median(times[group]):.1f} | "
                     f"{times[group].mean():.1f} | {times[group].sum() / times.sum():.1%} |")
    lines += ["", "| least \\|sin q5\\| answered | poses | median (us) | mean (us) "
              "| share of time |", "|---|---:|---:|---:|---:|"]
    for low, high in WRIST_CLASSES:
        group = (wrist >= low) & (wrist < high)
        if group.any():
            lines.append(f"| [{low:g}, {min(high, 1.0):g}) | {group.sum()} | "
                         f"{np.median(times[group]):.1f} | {times[group].mean():.1f} | "
                         f"{times[group].sum() / times.sum():.1%} |")
    return [*lines, ""]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robots", nargs="*", default=list(ROBOTS))
    parser.add_argument("--poses", type=int, default=3000)
    args = parser.parse_args(argv)
    for name in args.robots:
        print("\n".join(report(name, args.poses)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
