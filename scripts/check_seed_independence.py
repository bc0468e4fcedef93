#!/usr/bin/env python
"""Whether the branches answered depend on the seed, per class of vendor poses.

    python scripts/check_seed_independence.py [--poses 60] [ROBOT ...]

For each robot (default: every closed-form built-in with a vendor URDF), poses made by Pinocchio
on its vendor URDF in five classes (random, q5 = 0, |q5| in [1e-12, 1e-6], special angles,
shoulder-singular), each solved unseeded, seeded with the sampled q and seeded 0.05 rad away from
it: the count of poses whose set of answered branches differs between the three calls. Issue 25,
item 4 asks for none; tests/test_ik_seed_independence.py asserts it on the random poses.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

import dhkin

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.test_ik_vendor_poses import (
    EXACT_TABLES,
    REFINED_TABLES,
    shoulder_singular_q,
    special_q,
    vendor,
)


def branch_sets(batch: dhkin.ik.result.IKBatch) -> list[frozenset[int]]:
    return [frozenset(batch.branch[i][batch.valid[i]].tolist()) for i in range(len(batch.q))]


def classes(robot: dhkin.Robot, n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    zero, tiny = robot.table.random_q(n, rng), robot.table.random_q(n, rng)
    zero[:, 4] = 0.0
    tiny[:, 4] = rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-12, -6, n)
    return {"random": robot.table.random_q(n, rng), "q5 = 0": zero, "|q5| tiny": tiny,
            "special angles": special_q(robot, n, rng),
            "shoulder-singular": shoulder_singular_q(robot, n // 2, rng)}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robots", nargs="*", default=[*EXACT_TABLES, *REFINED_TABLES])
    parser.add_argument("--poses", type=int, default=60, help="poses per class")
    args = parser.parse_args(argv)
    print("| robot | random | q5 = 0 | \\|q5\\| tiny | special angles | shoulder-singular |")
    print("|---|" + "---:|" * 5)
    for name in args.robots:
        robot = dhkin.load(name)
        rng = np.random.default_rng(2501)
        cells = []
        for q in classes(robot, args.poses, rng).values():
            T = vendor(name).fk(q)
            moved = np.clip(q + 0.05 * rng.choice([-1.0, 1.0], q.shape), robot.lower,
                            robot.upper)
            plain, by_q, by_moved = (branch_sets(robot.ik_batch_detailed(T, q_seed=seed))
                                     for seed in (None, q, moved))
            differ = sum(1 for i in range(len(q)) if not plain[i] == by_q[i] == by_moved[i])
            cells.append(f"{differ} / {len(q)}")
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
