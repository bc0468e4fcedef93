#!/usr/bin/env python
"""Completeness and time of the prototype dhkin.ik.complete_refined (issue 25, branch i25ai) on
check_refined.py's sets: robot.ik merged with the general 6R's non-singular roots on the poses
each trigger picks ("left": the pose leaves the refined direct path; "kantorovich": that, or a
returned root's sigma_min below sqrt(2 deviation lever); "always").

    python scripts/prototype_complete_refined.py --poses 100 --starts 2000

Per pose robot.ik and the general 6R solver run once each (unseeded, CPU time of this thread);
a mode's time is robot.ik's plus the general solver's on the poses it triggers (its trigger's
own cost, one direct-path run and eight sigma_min in the core, is not counted).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from check_refined import BINS, DEFAULT_ARMS, SETS, TOLERANCE, missing, samples

import dhkin
from dhkin.ik.complete_refined import CompleteRefined
from dhkin.ik.general6r import General6RSolver
from dhkin.transforms import pose_error
from dhkin.validation.multistart import RootReference
from dhkin.validation.references import target_model

MODES = ("left", "kantorovich", "always")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", nargs="*", default=list(DEFAULT_ARMS))
    parser.add_argument("--sets", nargs="*", default=list(SETS), choices=SETS)
    parser.add_argument("--poses", type=int, default=100)
    parser.add_argument("--starts", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=25)
    args = parser.parse_args()
    print("| arm | set | poses | roots per bin | missing per bin: left ; kantorovich ; always | "
          "wrong | general calls: left / kantorovich | us median / mean: ik, left, "
          "kantorovich, always |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for arm in args.arms:
        robot = dhkin.load(arm)
        general = General6RSolver(robot.table)
        model = target_model(robot, "exact")
        reference = RootReference(robot, model, starts=args.starts)
        solvers = {mode: CompleteRefined(robot, mode, general) for mode in MODES}
        for kind in args.sets:
            rng = np.random.default_rng([args.seed, SETS.index(kind)])
            Q = samples(robot, kind, args.poses, rng)
            roots_bins = [0, 0, 0]
            miss = {mode: [0, 0, 0] for mode in MODES}
            calls = {mode: 0 for mode in MODES}
            times: dict[str, list[float]] = {mode: [] for mode in ("ik", *MODES)}
            wrong = 0
            for T in model.fk(Q):
                start = time.thread_time()
                answer = robot.ik(T)
                ik_time = time.thread_time() - start
                start = time.thread_time()
                roots = general.solve_one(T)
                general_time = time.thread_time() - start
                times["ik"].append(ik_time)
                q = np.asarray(answer.q).reshape(-1, 6)
                labels = [c.labels for c in answer.configurations]
                answers = {}
                for mode, solver in solvers.items():
                    on = solver.triggered(T, None, q)
                    calls[mode] += int(on)
                    answers[mode] = solver.merged(q, list(labels), roots)[0] if on else q
                    times[mode].append(ik_time + (general_time if on else 0.0))
                merged = answers["always"]
                if len(merged):
                    p, r = pose_error(model.fk(merged), np.broadcast_to(T, (len(merged), 4, 4)))
                    wrong += int(np.sum(np.maximum(p, r) > TOLERANCE + model.deviation))
                points = reference.points(T, TOLERANCE).roots
                if not len(points):
                    continue
                sigma = np.linalg.svd(model.reference.jacobians(points), compute_uv=False)[:, -1]
                bins = np.digitize(sigma, BINS) - 1
                for b in bins:
                    roots_bins[b] += 1
                for mode, rows in answers.items():
                    for b in bins[missing(points, rows)]:
                        miss[mode][b] += 1
            us = {k: 1e6 * np.asarray(v) for k, v in times.items()}
            timing = ", ".join(f"{np.median(us[k]):.0f} / {us[k].mean():.0f}"
                               for k in ("ik", *MODES))
            print(f"| {arm} | {kind} | {len(Q)} | {' / '.join(map(str, roots_bins))} | "
                  + " ; ".join(" / ".join(map(str, miss[m])) for m in MODES)
                  + f" | {wrong} | {calls['left']} / {calls['kantorovich']} | {timing} |",
                  flush=True)


if __name__ == "__main__":
    main()
