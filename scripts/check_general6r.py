#!/usr/bin/env python
"""The general 6R solver's acceptance figures (issues 16 and 26) at full or chosen sizes.

    python scripts/check_general6r.py --poses 10000 --special 1000 --q5 1000 --starts 2000 \\
        --tables 100 --table-poses 1000 --table-starts 2000

Per arm (CRX-10iA, xArm6, the UR5 with joint 2's alpha tilted 10 deg) and per sample set
(random joint vectors within the limits; special angles, every joint in {0, +-pi/2, pi}
clipped to the limits; random with q5 = 0), targets by Pinocchio on the generated URDF, the
solver called without a seed and with the sampled q as seed:

* reference roots: a multistart of ``--starts`` fixed starts (Newton on the exact chain, no
  elimination: :mod:`dhkin.validation.multistart`), each root verified on Pinocchio, isolated
  (sigma_min of Pinocchio's Jacobian >= 1e-6) and with an in-limit 2pi copy; the validator's
  definition: a root where Newton converged (error <= 1e-12), a near-root where it stalled
  inside the tolerance (counted apart: the exact targets here leave none);
* missing: reference roots the unseeded answer lacks (not within 1e-6 rad mod 2pi, nor one root
  with a returned one: the segment between them verifies on Pinocchio at 1e-9), and near-roots
  it lacks (nor tied to a returned one along their valley, within 1e-9);
* wrong: returned solutions off by more than 1e-9 on Pinocchio; the largest residual, and the
  rows above 1e-12 (of them, those flagged singular; apart, those set onto a joint limit: a
  root up to tolerance / lever outside a limit counts as on it, as in the families, and keeps
  the residual of the part outside);
* seed-dependent: poses whose regular roots (not flagged "singular") differ with and without the
  seed (mod 2pi, 1e-9 rad): the seed may choose a member of a curve of solutions, not a root;
* the median time of an unseeded call.

Random tables (fixed seed; limits +-2pi, so every root has an in-limit copy): the same per
table, and odd counts of returned roots without a "singular" flag. UR5 and IRB 1200
(``--family-poses``): the same solution set as the family solvers (mod 2pi), both seeded with
the sampled q.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
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
from dhkin.validation.multistart import RootReference, missing_roots
from dhkin.validation.references import ReferenceSpec, TargetModel

TOLERANCE = 1e-9
JOINT_TOLERANCE = 1e-6
#: The residual every returned root must reach on the oracle (REFINE_FRACTION x TOLERANCE).
RESIDUAL = 1e-12


def seed_dependent(unseeded: dhkin.IKSolutions, seeded: dhkin.IKSolutions) -> bool:
    """Whether the regular roots (not flagged singular) differ between the two answers."""
    def regular(result: dhkin.IKSolutions) -> np.ndarray:
        keep = [k for k, flag in enumerate(result.flags) if "singular" not in flag]
        return np.asarray(result.q)[keep].reshape(-1, 6)

    a, b = regular(unseeded), regular(seeded)
    if len(a) != len(b):
        return True
    if not len(a):
        return False
    d = np.abs(_wrap(a[:, None, :] - b[None, :, :])).max(axis=2)
    return not (np.all(d.min(axis=1) <= 1e-9) and np.all(d.min(axis=0) <= 1e-9))


def measure(robot: Robot, solver: General6RSolver, Q: np.ndarray, starts: int,
            odd_counts: bool = False, report: Callable[[str], None] = print) -> dict[str, float]:
    """The figures of the module docstring on the joint vectors Q."""
    model = TargetModel(ReferenceSpec(kind="exact"), robot.reference())
    reference = RootReference(robot, model, starts=starts)
    targets = model.fk(Q)
    figures = {"poses": len(Q), "reference_roots": 0, "near_roots": 0, "missing": 0,
               "poses_missing": 0, "wrong": 0, "worst": 0.0, "above_1e-12": 0,
               "above_1e-12_singular": 0, "above_1e-12_on_limit": 0, "seed_dependent": 0,
               "odd": 0, "exceptions": 0}
    times = []
    for q, T in zip(Q, targets, strict=True):
        try:
            start = time.perf_counter()
            unseeded = solver.solve_one(T)
            times.append(time.perf_counter() - start)
            seeded = solver.solve_one(T, q)
        except Exception as exc:  # counted and shown: the acceptance wants none
            figures["exceptions"] += 1
            report(f"  exception at q = {q.tolist()}: {type(exc).__name__}: {exc}")
            continue
        points = reference.points(T, TOLERANCE)
        figures["reference_roots"] += len(points.roots)
        figures["near_roots"] += len(points.near_roots)
        lacking = missing_roots(model, T, points.roots, unseeded.q, TOLERANCE, JOINT_TOLERANCE)
        lacking += missing_roots(model, T, points.near_roots, unseeded.q, TOLERANCE,
                                 JOINT_TOLERANCE, along_valley=True)
        if lacking:
            figures["missing"] += len(lacking)
            figures["poses_missing"] += 1
            report(f"  missing at q = {q.tolist()}: " + "; ".join(
                f"{r.tolist()} (closest {d:.2e})" for r, d in lacking))
        if len(unseeded):
            position, rotation = pose_errors(model.fk(unseeded.q),
                                             np.repeat(T[None], len(unseeded), axis=0))
            error = np.maximum(position, rotation)
            figures["worst"] = max(figures["worst"], float(error.max()))
            figures["wrong"] += int(np.sum(error > TOLERANCE))
            on_limit = np.any((unseeded.q == robot.lower) | (unseeded.q == robot.upper), axis=1)
            figures["above_1e-12"] += int(np.sum((error > RESIDUAL) & ~on_limit))
            figures["above_1e-12_on_limit"] += int(np.sum((error > RESIDUAL) & on_limit))
            singular = np.array(["singular" in flag for flag in unseeded.flags])
            figures["above_1e-12_singular"] += int(np.sum((error > RESIDUAL) & singular
                                                          & ~on_limit))
        if seed_dependent(unseeded, seeded):
            figures["seed_dependent"] += 1
            report(f"  seed-dependent at q = {q.tolist()}")
        flagged = any("singular" in flag for flag in unseeded.flags)
        if odd_counts and len(unseeded) % 2 and not flagged:
            figures["odd"] += 1
            report(f"  odd count without a flag at q = {q.tolist()}: {len(unseeded)}")
    figures["median_us"] = 1e6 * float(np.median(times)) if times else math.nan
    return figures


def arm_samples(robot: Robot, kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    if kind == "special":
        return np.clip(SPECIAL[rng.integers(0, 4, size=(n, 6))], robot.lower, robot.upper)
    Q = robot.table.random_q(n, rng)
    if kind == "q5":
        Q[:, 4] = 0.0
    return Q


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=10000)
    parser.add_argument("--special", type=int, default=1000)
    parser.add_argument("--q5", type=int, default=1000)
    parser.add_argument("--starts", type=int, default=2000)
    parser.add_argument("--tables", type=int, default=100)
    parser.add_argument("--table-poses", type=int, default=1000)
    parser.add_argument("--table-starts", type=int, default=2000)
    parser.add_argument("--family-poses", type=int, default=0)
    parser.add_argument("--arms", nargs="*", default=["fanuc_crx10ia", "xarm6", "ur5_tilted"])
    args = parser.parse_args()
    rng = np.random.default_rng(26)
    for name in args.arms:
        robot = ur5_tilted() if name == "ur5_tilted" else dhkin.load(name)
        solver = General6RSolver(robot.table)
        for kind, n in (("random", args.poses), ("special", args.special), ("q5", args.q5)):
            if n:
                Q = arm_samples(robot, kind, n, rng)
                print(name, kind, measure(robot, solver, Q, args.starts), flush=True)
    totals: dict[str, float] = {}
    medians = []
    for index in range(args.tables):
        table = random_table(rng, index)
        robot = Robot(table)
        Q = rng.uniform(-math.pi, math.pi, size=(args.table_poses, 6))
        figures = measure(robot, General6RSolver(table), Q, args.table_starts, odd_counts=True,
                          report=lambda line, i=index: print(f"table {i}:{line}", flush=True))
        medians.append(figures.pop("median_us"))
        for key, value in figures.items():
            totals[key] = max(totals.get(key, 0.0), value) if key == "worst" else (
                totals.get(key, 0) + value)
    if args.tables:
        print(f"random tables ({args.tables} x {args.table_poses} poses):", totals,
              f"median_us (median over tables) {np.median(medians):.1f}", flush=True)
    for name in ("ur5", "abb_irb1200_7_70") if args.family_poses else ():
        family_comparison(name, args.family_poses, rng)


def family_comparison(name: str, n: int, rng: np.random.Generator) -> None:
    robot = dhkin.load(name)
    solver = General6RSolver(robot.table)
    Q = robot.table.random_q(n, rng)
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
          f"returns both halves; every point between them verifies at 1e-9)", flush=True)


if __name__ == "__main__":
    main()
