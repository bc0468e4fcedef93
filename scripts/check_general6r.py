#!/usr/bin/env python
"""The general 6R solver's acceptance figures (issue 16) at full or chosen sizes.

    python scripts/check_general6r.py --poses 10000 --special 1000 --tables 100 --table-poses 1000

Per arm (CRX-10iA, xArm6, UR5 with joint 2's alpha tilted 10 deg): random poses within the
limits, targets by Pinocchio on the generated URDF, solved without a seed (a seed near the pose
is a Newton start of the solver, which would return the sampled q by itself: without one, the
elimination alone must find it): the share of poses whose q came back (mod 2pi, 1e-6 rad), the
worst oracle error of any returned solution, the median time per single call; the same seeded
with the sampled q; special angles (joints in {0, +-pi/2, pi}), unseeded and seeded: wrong
solutions and exceptions. Random tables (fixed seed): the same (unseeded), plus solution counts
(before limits) even and at most 16. UR5 and IRB 1200: the same solution set as the family
solvers (mod 2pi), both seeded with the sampled q.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_ik_general6r import (
    SPECIAL,
    pose_errors,
    random_table,
    same_solution_sets,
    ur5_tilted,
)

import dhkin
from dhkin.ik.general6r import General6RSolver
from dhkin.ik.general6r_arrangement import wrap as _wrap
from dhkin.robot import Robot


def measure(robot: Robot, Q: np.ndarray, seeded: bool) -> dict[str, float]:
    solver = General6RSolver(robot.table)
    reference = robot.reference()
    targets = reference.fk(Q)
    times, recovered, worst, errors, wrong, counts = [], 0, 0.0, 0, 0, []
    for q, T in zip(Q, targets, strict=True):
        start = time.perf_counter()
        try:
            result = solver.solve_one(T, q if seeded else None)
        except Exception:
            errors += 1
            continue
        times.append(time.perf_counter() - start)
        counts.append(len(result))
        if len(result) == 0:
            continue
        position, rotation = pose_errors(reference.fk(result.q),
                                         np.repeat(T[None], len(result), axis=0))
        worst = max(worst, float(position.max()), float(rotation.max()))
        wrong += int(np.sum((position > 1e-9) | (rotation > 1e-9)))
        if np.min(np.max(np.abs(_wrap(result.q - q)), axis=1)) < 1e-6:
            recovered += 1
    return {"poses": len(Q), "recovered": recovered / len(Q), "worst": worst, "wrong": wrong,
            "exceptions": errors, "median_us": 1e6 * float(np.median(times)),
            "mean_solutions": float(np.mean(counts))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=10000)
    parser.add_argument("--special", type=int, default=1000)
    parser.add_argument("--tables", type=int, default=100)
    parser.add_argument("--table-poses", type=int, default=1000)
    parser.add_argument("--family-poses", type=int, default=10000)
    parser.add_argument("--family-only", action="store_true",
                        help="run only the UR5 / IRB 1200 comparison with the family solvers")
    args = parser.parse_args()
    rng = np.random.default_rng(16)
    if not args.family_only:  # --family-only: its poses then differ (the rng is fresh)
        for name in ("fanuc_crx10ia", "xarm6", "ur5_tilted"):
            robot = ur5_tilted() if name == "ur5_tilted" else dhkin.load(name)
            Q = robot.table.random_q(args.poses, rng)
            print(name, "random, unseeded", measure(robot, Q, False), flush=True)
            print(name, "random, seeded", measure(robot, Q, True), flush=True)
            Q = np.clip(SPECIAL[rng.integers(0, 4, size=(args.special, 6))], robot.lower,
                        robot.upper)
            print(name, "special, unseeded", measure(robot, Q, False), flush=True)
            print(name, "special, seeded", measure(robot, Q, True), flush=True)
        odd, over, recovered, total, worst, wrong = 0, 0, 0, 0, 0.0, 0
        for index in range(args.tables):
            table = random_table(rng, index)
            solver = General6RSolver(table)
            Q = rng.uniform(-math.pi, math.pi, size=(args.table_poses, 6))
            for q in Q:
                roots, _, _ = solver.roots(solver.target_dh(table.fk(q)), 1e-9)
                if roots.shape[0] % 2:
                    print(f"odd count: table {index}, q = {q.tolist()}: {roots.shape[0]} roots",
                          flush=True)
                odd += roots.shape[0] % 2
                over += roots.shape[0] > 16
                total += 1
                recovered += bool(roots.shape[0]) and bool(
                    np.min(np.max(np.abs(_wrap(roots - q)), axis=1)) < 1e-6)
            figures = measure(Robot(table), Q[: max(1, args.table_poses // 10)], False)
            worst = max(worst, figures["worst"])
            wrong += int(figures["wrong"])
        print(f"random tables: {args.tables} x {args.table_poses} poses: recovered "
              f"{recovered / total:.5f}, odd counts {odd}, counts > 16: {over}; oracle check on "
              f"a tenth: worst {worst:.2e}, wrong {wrong}")
    for name in ("ur5", "abb_irb1200_7_70"):
        robot = dhkin.load(name)
        solver = General6RSolver(robot.table)
        Q = robot.table.random_q(args.family_poses, rng)
        reference = robot.reference()
        same, merged = 0, 0
        for q, T in zip(Q, robot.fk(Q), strict=True):
            family, general = robot.ik(T, q), solver.solve_one(T, q)
            exact = len(family) == len(general)
            if exact:
                d = np.abs(_wrap(family.q[:, None, :] - general.q[None, :, :])).max(axis=2)
                exact = bool(np.all(d.min(axis=1) < 1e-6) and np.all(d.min(axis=0) < 1e-6))
            if exact:
                same += 1
            elif same_solution_sets(reference, T, family.q, general.q):
                merged += 1
            else:
                print(f"{name}: differs at q = {q.tolist()}", flush=True)
        print(f"{name}: same solution set as the family solver on {same} of {len(Q)} poses, "
              f"and on {merged} more where one solver merges a split double root (the other "
              f"returns both halves; every point between them verifies at 1e-9)")


if __name__ == "__main__":
    main()
