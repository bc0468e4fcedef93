#!/usr/bin/env python
"""Completeness and time of the prototype CompleteRefined below (issue 25, branch i25ai) on
check_refined.py's sets: robot.ik merged with the general 6R's non-singular roots on the poses
each trigger picks ("left": the pose leaves the refined direct path; "newton": that, or
Kantorovich's condition fails at some ideal candidate with its own error; "moved": "left", or
refinement moved a branch more than the family band's 0.02 rad from the ideal model's
candidate; "always").

    python scripts/prototype_complete_refined.py --poses 100 --starts 2000

Per pose robot.ik and the general 6R solver run once each (unseeded, CPU time of this thread);
a mode's time is robot.ik's plus the general solver's on the poses it triggers (its trigger's
own cost, a direct-path run and the ideal candidates, free in a core implementation, is not
counted).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

sys.path.insert(0, str(Path(__file__).resolve().parent))

from check_refined import DEFAULT_ARMS, SETS, TOLERANCE, binned_roots, missing, samples

import dhkin
from dhkin.ik.family import BAND
from dhkin.ik.general6r import General6RSolver
from dhkin.transforms import pose_error
from dhkin.validation.multistart import RootReference
from dhkin.validation.references import target_model

MODES = ("left", "newton", "moved", "always")

# Prototype (issue 25, branch i25ai; not wired into Robot.ik): a refined table's answer made
# complete by the general 6R solver's roots on the same exact chain.
#
# A refined table answers one root per branch slot; near the ideal model's singular sets its exact
# chain has more isolated roots than slots (scripts/check_refined.py: every missing root measured
# sits in a slot that holds another returned root). Here a pose that leaves the refined direct path
# (depending on the trigger) is also solved by :class:`~dhkin.ik.general6r.General6RSolver` on the
# table itself (its roots are complete: docs/general6r.md), and each of its roots that no branch
# answer holds (none within ``SAME`` rad, mod 2pi) and that it does not flag "singular" (a member of
# a near-singular family: the branch answers already hold the seed's member there) is appended,
# labelled with the family's branch of its q (the ideal model's closed form at the ideal model's
# pose of that q gives q itself in that branch).
#
# Triggers (``mode``): "always"; "left" (the pose leaves the refined direct path); "kantorovich"
# ("left", or a returned root's sigma_min of the exact chain's Jacobian (Pinocchio's, in this
# prototype) below :meth:`CompleteRefined.kantorovich_sigma`: where Newton from the ideal model's
# root is not certain to converge to a unique root nearby, the exact chain may hold roots the
# ideal model's branches do not lead to).

#: Two roots are one when every joint agrees within this (rad, mod 2pi): the validator's joint
#: tolerance (scripts/check_general6r.py, check_refined.py).
SAME = 1e-6


def _wrapped(d: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(np.mod(d + np.pi, 2.0 * np.pi) - np.pi)


class CompleteRefined:
    """``solve(T, q_seed)`` -> (q (k, 6), branch labels (k,)): robot.ik's rows, then the general
    6R's roots that no row holds (module docstring)."""

    def __init__(self, robot: object, mode: str = "kantorovich",
                 general: General6RSolver | None = None) -> None:
        from dhkin.robot import Robot

        assert isinstance(robot, Robot)
        self.robot = robot
        self.solver = robot.ik_solver
        self.general = general or General6RSolver(robot.table)
        self.ideal = Robot(self.solver.fit.ideal)
        self.mode = mode
        self.reference = robot.reference()
        self._direct = np.zeros(1, dtype=bool)
        self.sigma_bound = self.kantorovich_sigma()

    def kantorovich_sigma(self) -> float:
        """sqrt(2 r L): Kantorovich's theorem makes Newton from a point of pose error r, where the
        Jacobian's smallest singular value is sigma and its Lipschitz constant L, converge to a
        unique root within ~2 r / sigma once r L / sigma^2 <= 1/2. r: the model deviation
        (the ideal model's pose error on the exact chain, metres, rotations times the lever:
        plan["deviation"]); L: the lever (a revolute Jacobian's columns turn by at most the
        lever per radian)."""
        plan = self.solver.plan
        return float(np.sqrt(2.0 * float(plan["deviation"]) * float(plan["lever"])))

    def triggered(self, target: NDArray[np.float64], q_seed: ArrayLike | None,
                  q: NDArray[np.float64]) -> bool:
        """Whether the general 6R solver runs on this pose (the module docstring's modes)."""
        if self.mode == "always":
            return True
        seed = np.zeros((1, 6)) if q_seed is None else np.asarray(q_seed, float)[None]
        self.solver.core.refined_direct_answers(target[None], seed, 1e-9, self.solver.frames,
                                               self._direct)
        if not self._direct[0] or self.mode == "left" or not len(q):
            return not self._direct[0]
        if self.mode == "newton":
            return self.newton_uncertain(target)
        if self.mode == "moved":
            return self.moved_beyond_band(target)
        jacobians = self.reference.jacobians(q)
        return bool(np.linalg.svd(jacobians, compute_uv=False)[:, -1].min() < self.sigma_bound)

    def newton_uncertain(self, target: NDArray[np.float64]) -> bool:
        """Whether Kantorovich's condition fails at some ideal candidate: h = r L / sigma^2 > 1/2,
        r its pose error on the exact chain (position + lever x rotation), sigma the smallest
        singular value of the exact chain's Jacobian there, L the lever (as
        :meth:`kantorovich_sigma`, with the candidate's own error instead of the model's
        deviation). Where it holds at every candidate, Newton from each converges to a unique
        root within 2 r / sigma of it."""
        found = self.ideal.ik_solver.branches(target)
        candidates = found.q[0][found.valid[0]]
        if not len(candidates):
            return False
        lever = float(self.solver.plan["lever"])
        position, rotation = pose_error(self.robot.fk(candidates),
                                        np.broadcast_to(target, (len(candidates), 4, 4)))
        r = position + lever * rotation
        sigma = np.linalg.svd(self.reference.jacobians(candidates), compute_uv=False)[:, -1]
        return bool(np.any(r * lever > 0.5 * sigma ** 2))

    def moved_beyond_band(self, target: NDArray[np.float64]) -> bool:
        """Whether refinement moved some branch more than the family band's angle (0.02 rad,
        dhkin.ik.family.BAND) from the ideal model's candidate: within the band the exact chain
        is the ideal model's neighbour (its singular sets lie within the band of the ideal
        model's); a branch that moves farther sits where the two models' roots need not
        correspond one to one."""
        found = self.ideal.ik_solver.branches(target)
        settled = self.solver.branches(target)
        both = found.valid[0] & settled.valid[0]
        moved = np.abs(_wrapped(found.q[0][both] - settled.q[0][both]))
        return bool(moved.size and moved.max() > BAND.angle)

    def branch_of(self, q: NDArray[np.float64]) -> Mapping[str, str]:
        found = self.ideal.ik_solver.branches(self.ideal.fk(q))
        d = np.abs(_wrapped(found.q[0] - q)).max(axis=1)
        d[~found.valid[0]] = np.inf
        return self.ideal.ik_solver.branch_labels[int(np.argmin(d))]

    def solve(self, T: ArrayLike, q_seed: ArrayLike | None = None
              ) -> tuple[NDArray[np.float64], list[Mapping[str, str]]]:
        target = np.ascontiguousarray(T, dtype=np.float64)
        answer = self.robot.ik(target, q_seed)
        q = np.asarray(answer.q).reshape(-1, 6)
        labels = [c.labels for c in answer.configurations]
        if not self.triggered(target, q_seed, q):
            return q, labels
        return self.merged(q, labels, self.general.solve_one(target, q_seed))

    def merged(self, q: NDArray[np.float64], labels: list[Mapping[str, str]], roots: object
               ) -> tuple[NDArray[np.float64], list[Mapping[str, str]]]:
        """robot.ik's rows and labels, then the general 6R answer's roots no row holds."""
        from dhkin.ik.result import IKSolutions

        assert isinstance(roots, IKSolutions)
        extra = [k for k, flags in enumerate(roots.flags) if "singular" not in flags]
        if not extra:
            return q, labels
        candidates = np.asarray(roots.q)[extra]
        if len(q):
            d = np.abs(_wrapped(candidates[:, None, :] - q[None, :, :])).max(axis=2)
            candidates = candidates[d.min(axis=1) > SAME]
        for root in candidates:
            labels.append(self.branch_of(root))
        return np.vstack([q, candidates]) if len(candidates) else q, labels


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", nargs="*", default=list(DEFAULT_ARMS))
    parser.add_argument("--sets", nargs="*", default=list(SETS), choices=SETS)
    parser.add_argument("--poses", type=int, default=100)
    parser.add_argument("--starts", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=25)
    args = parser.parse_args()
    print("| arm | set | poses | roots per bin | missing per bin: " + " ; ".join(MODES)
          + " | wrong | general calls: left / newton / moved | us median / mean: "
          + ", ".join(("ik", *MODES)) + " |")
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
                points, _, bins = binned_roots(reference, model, T)
                if not len(points):
                    continue
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
                  + f" | {wrong} | {calls['left']} / {calls['newton']} / {calls['moved']} | "
                  f"{timing} |",
                  flush=True)


if __name__ == "__main__":
    main()
