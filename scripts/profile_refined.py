"""Where a refined table's IK time goes: the stages of the compiled pipeline timed on their own.

For a table refined on its exact chain (corrections or snapped constants, see docs/ik_core.md),
on N random poses made by Pinocchio on the table's URDF, per pose (us):

1. the closed form of the ideal model (input check, projection, frame change, 8 branches);
2. 1 + Newton on the exact chain from every ideal solution (``chain.refine``);
3. 1 + each branch settled as the pipeline does it (Newton, then continuation along the path of
   models where Newton fails: the cost of branches the exact chain lacks);
4. the whole pipeline (``ik_batch(..., copies=False, workers=1)``), which adds merging,
   corrected-target retries of lost branches, extras and the seed's root.

Also: the share of ideal branches that do not verify on the exact chain, and of poses that lose
one. Usage: ``python scripts/profile_refined.py [--robot ur5e_calibrated] [--poses 2000]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

import numpy as np
from numba import njit

import dhkin
from dhkin.ik.compiled import chain as exact
from dhkin.ik.compiled import pipeline as kernels
from dhkin.ik.compiled import pose as poses


@njit(cache=False)
def _stages(plan: np.ndarray, frames: np.ndarray, targets: np.ndarray, stage: int,
            tolerance: float) -> tuple[int, int, int]:
    """Run stages 1..stage over every target: (ideal branches, verified branches, poses that
    lost a branch)."""
    projected, T_dh, T_at = np.empty((3, 4)), np.empty((3, 4)), np.empty((3, 4))
    point, seed, state = np.empty(3), np.zeros(6), np.empty(12)
    q = np.empty((kernels.BRANCHES, 6))
    valid = np.empty(kernels.BRANCHES, np.bool_)
    flags = np.empty(kernels.BRANCHES, np.uint8)
    near = np.empty(kernels.BRANCHES, np.uint8)
    why, scratch = np.empty(kernels.WHY_SIZE), np.empty(16)
    fixed = np.zeros(6, np.bool_)
    ideal_count, verified, losing = 0, 0, 0
    for i in range(targets.shape[0]):
        poses.project(targets[i], projected)
        poses.to_dh(frames, projected, T_dh)
        poses.tcp_point(frames, point)
        poses.at_point(T_dh, point, T_at)
        pose_plan = kernels.plan_at_tcp(plan, point)
        g, chain, _ = kernels.plan_parts(pose_plan)
        clamp = tolerance * (1.0 + pose_plan[kernels.PLAN.lever]) + \
            pose_plan[kernels.PLAN.deviation]
        kernels._family(pose_plan, g, T_dh, seed, 0, clamp, q, valid, flags, near, why, scratch)
        if stage == 1:
            continue
        lost = False
        for b in range(kernels.BRANCHES):
            if not valid[b]:
                continue
            ideal_count += 1
            values = q[b].copy()
            if stage == 2:
                position, rotation = exact.refine(chain, T_at, values, fixed, tolerance)
            else:
                position, rotation = kernels._settle(pose_plan, chain, T_at, values, fixed,
                                                     False, False, tolerance, state)
            if exact.within(position, rotation, tolerance):
                verified += 1
            else:
                lost = True
        losing += lost
    return ideal_count, verified, losing


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robot", default="ur5e_calibrated")
    parser.add_argument("--poses", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    robot = dhkin.load(args.robot)
    solver = robot.ik_solver
    if not solver.fit.refine:
        parser.error(f"{args.robot} is an exact-family table: nothing is refined")
    q = robot.table.random_q(args.poses, np.random.default_rng(args.seed))
    targets = np.ascontiguousarray(robot.reference().fk(q))
    names = ["closed form of the ideal model", "+ Newton on the exact chain, every branch",
             "+ continuation where Newton fails (settle)"]
    print(f"{robot.name}, {args.poses} random poses (Pinocchio on the table's URDF), per pose:")
    for stage, name in enumerate(names, start=1):
        _stages(solver.plan, solver.frames, targets[:2], stage, 1e-9)  # compile
        start = time.perf_counter()
        ideal, verified, losing = _stages(solver.plan, solver.frames, targets, stage, 1e-9)
        seconds = time.perf_counter() - start
        print(f"  {name}: {seconds / args.poses * 1e6:.1f} us")
        if stage > 1:
            print(f"    ideal branches {ideal}, verified {verified} ({verified / ideal:.1%}), "
                  f"poses losing a branch {losing} ({losing / args.poses:.1%})")
    robot.ik_batch(targets[:2], copies=False, workers=1)
    start = time.perf_counter()
    robot.ik_batch(targets, copies=False, workers=1)
    seconds = time.perf_counter() - start
    print(f"  whole pipeline (ik_batch, 1 thread): {seconds / args.poses * 1e6:.1f} us")
    return 0


if __name__ == "__main__":
    sys.exit(main())
