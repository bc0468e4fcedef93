#!/usr/bin/env python
"""Completeness of the refined closed-form tables against the general 6R solver (issue 25).

    python scripts/check_refined.py --poses 100 --starts 2000
    python scripts/check_refined.py --arms ur5e_calibrated --sets q5 --poses 300 --verbose

A refined table (a family fits within the band; each branch refined by Newton on the exact
chain: docs/ik_core.md) answers one root per branch slot. Near the ideal model's singular sets
its exact chain can have more isolated roots, or roots no ideal branch leads to. Per arm and per
sample set (fixed seeds), targets by Pinocchio on the exact generated URDF, both solvers called
without a seed:

* reference roots: dhkin.validation.multistart.RootReference with ``--starts`` fixed starts,
  every root verified on Pinocchio, isolated (sigma_min of Pinocchio's Jacobian >= 1e-6) and with
  an in-limit 2pi copy; binned by that sigma_min: [1e-6, sqrt(tolerance) = 3.2e-5) is the
  singular band (a member of a near-singular family may be returned instead of the root, and
  the general 6R solver flags its roots there "singular"), [3.2e-5, 1e-3) near-singular,
  [1e-3, inf) regular;
* missing: reference roots with no returned row within 1e-6 rad (mod 2pi) of them, from
  ``robot.ik(T)`` and from ``General6RSolver(robot.table).solve_one(T)`` (the same exact chain);
  for robot.ik, split by whether the pose took the refined direct path (the core's
  ``refined_direct_answers``) and by whether the family's branch of the missing root (the
  branch whose ideal-model solution of the ideal model's pose at that q is that q) holds another
  returned root ("slot taken": the branch has more than one root) or none ("slot empty": the
  branch was not found);
* wrong: returned rows whose error on Pinocchio exceeds the tolerance (1e-9 m and rad);
* time: median and mean CPU time (this thread's) of one unseeded call of each solver.

Sets: random (q within the limits), q5 = 0, |q5| in [1e-6, 1e-2] (either sign), q3 = 0, special
angles (each joint in {0, +-pi/2, pi}, clipped to the limits).
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from numpy.typing import NDArray

import dhkin
from dhkin.ik.general6r import General6RSolver
from dhkin.ik.result import IKSolutions
from dhkin.robot import Robot
from dhkin.transforms import pose_error
from dhkin.validation.multistart import ISOLATED, RootReference
from dhkin.validation.references import TargetModel, target_model

TOLERANCE = 1e-9
#: A reference root is returned when a row is within this of it (rad, mod 2pi): the
#: validator's joint tolerance (scripts/check_general6r.py).
JOINT_TOLERANCE = 1e-6
#: sigma_min bins (m and rad): ISOLATED (the reference's floor), sqrt(TOLERANCE) (the singular
#: band: a root there is fixed by the pose only to ~sqrt(tolerance), and the general 6R solver
#: flags it "singular"), 1e-3 (near-singular: Newton from the ideal model's root converges, but
#: the exact chain's roots can be split from the ideal model's).
BINS = (ISOLATED, math.sqrt(TOLERANCE), 1e-3, math.inf)
BIN_NAMES = ("[1e-6,3.2e-5)", "[3.2e-5,1e-3)", "[1e-3,inf)")
SPECIAL = np.array([0.0, math.pi / 2, -math.pi / 2, math.pi])
SETS = ("random", "q5", "q5_small", "q3", "special")
DEFAULT_ARMS = ("ur5e_calibrated", "tm5_900", "kinova_gen3_6dof")


def samples(robot: Robot, kind: str, n: int, rng: np.random.Generator) -> NDArray[np.float64]:
    """n joint vectors of the set ``kind`` (module docstring)."""
    if kind == "special":
        return np.clip(SPECIAL[rng.integers(0, 4, size=(n, 6))], robot.lower, robot.upper)
    Q = robot.table.random_q(n, rng)
    if kind == "q5":
        Q[:, 4] = 0.0
    elif kind == "q5_small":
        Q[:, 4] = rng.choice([-1.0, 1.0], size=n) * 10.0 ** rng.uniform(-6, -2, size=n)
    elif kind == "q3":
        Q[:, 2] = 0.0
    return Q


def wrapped(d: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(np.mod(d + np.pi, 2.0 * np.pi) - np.pi)


def missing(roots: NDArray[np.float64], Q: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which reference roots no row of Q is within JOINT_TOLERANCE of (mod 2pi)."""
    if not len(Q):
        return np.ones(len(roots), dtype=bool)
    d = np.abs(wrapped(roots[:, None, :] - Q[None, :, :])).max(axis=2)
    return np.asarray(d.min(axis=1) > JOINT_TOLERANCE)


def binned_roots(reference: RootReference, model: TargetModel, T: NDArray[np.float64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """The reference roots (k, 6) of the pose T, sigma_min of the oracle's Jacobian at each
    and its bin (index into BIN_NAMES)."""
    roots = reference.points(T, TOLERANCE).roots
    if not len(roots):
        return roots, np.zeros(0), np.zeros(0, np.int64)
    sigma = np.asarray(np.linalg.svd(model.reference.jacobians(roots), compute_uv=False)[:, -1],
                       dtype=np.float64)
    return roots, sigma, np.asarray(np.digitize(sigma, BINS) - 1, dtype=np.int64)


def wrong_rows(model: TargetModel, T: NDArray[np.float64], Q: NDArray[np.float64],
               allowed: float) -> int:
    """How many rows of Q miss the pose T by more than ``allowed`` on the oracle (m and rad)."""
    if not len(Q):
        return 0
    position, rotation = pose_error(model.fk(Q), np.broadcast_to(T, (len(Q), 4, 4)))
    return int(np.sum(np.maximum(position, rotation) > allowed))


def label_key(labels: object) -> tuple[tuple[str, str], ...]:
    return tuple(sorted(dict(labels).items()))  # type: ignore[call-overload]


class Branches:
    """The family's branch of a joint vector: the ideal model's closed form at the ideal model's
    pose of q gives q itself in one branch (the one whose solution is nearest q)."""

    def __init__(self, robot: Robot) -> None:
        self.ideal = Robot(robot.ik_solver.fit.ideal)
        self.labels = self.ideal.ik_solver.branch_labels

    def of(self, q: NDArray[np.float64]) -> tuple[tuple[str, str], ...]:
        found = self.ideal.ik_solver.branches(self.ideal.fk(q))
        d = np.abs(wrapped(found.q[0] - q)).max(axis=1)
        d[~found.valid[0]] = np.inf
        return label_key(self.labels[int(np.argmin(d))])


@dataclass
class Figures:
    poses: int = 0
    direct_poses: int = 0
    roots: list[int] = field(default_factory=lambda: [0, 0, 0])
    ik_missing: list[int] = field(default_factory=lambda: [0, 0, 0])
    general_missing: list[int] = field(default_factory=lambda: [0, 0, 0])
    missing_on_direct: int = 0
    slot_taken: int = 0
    slot_empty: int = 0
    poses_ik_missing: int = 0
    ik_wrong: int = 0
    general_wrong: int = 0
    ik_times: list[float] = field(default_factory=list)
    general_times: list[float] = field(default_factory=list)

    def row(self, arm: str, kind: str) -> str:
        def triple(values: list[int]) -> str:
            return " / ".join(str(v) for v in values)

        ik_us = 1e6 * np.asarray(self.ik_times)
        general_us = 1e6 * np.asarray(self.general_times)
        return (f"| {arm} | {kind} | {self.poses} ({self.direct_poses} direct) | "
                f"{triple(self.roots)} | {triple(self.ik_missing)} | "
                f"{self.slot_taken} / {self.slot_empty} | {self.missing_on_direct} | "
                f"{triple(self.general_missing)} | {self.ik_wrong} / {self.general_wrong} | "
                f"{np.median(ik_us):.0f} / {ik_us.mean():.0f} | "
                f"{np.median(general_us):.0f} / {general_us.mean():.0f} |")


HEADER = ("| arm | set | poses (direct path) | reference roots per sigma bin | missing, robot.ik | "
          "slot taken / empty | missing on direct-path poses | missing, general 6R | "
          "wrong ik / general | ik us median / mean | general us median / mean |\n"
          "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")


def timed(call: Callable[[], IKSolutions]) -> tuple[IKSolutions, float]:
    start = time.thread_time()
    result = call()
    return result, time.thread_time() - start


def measure(robot: Robot, Q: NDArray[np.float64], starts: int, verbose: bool,
            general: General6RSolver | None = None) -> Figures:
    """The figures of the module docstring on the joint vectors Q."""
    model = target_model(robot, "exact")
    reference = RootReference(robot, model, starts=starts)
    general = general or General6RSolver(robot.table)
    branches = Branches(robot)
    solver = robot.ik_solver
    targets = model.fk(Q)
    direct = np.zeros(len(Q), dtype=bool)
    solver.core.refined_direct_answers(np.ascontiguousarray(targets), np.zeros((len(Q), 6)),
                                       TOLERANCE, solver.frames, direct)
    figures = Figures(poses=len(Q), direct_poses=int(direct.sum()))
    allowed = TOLERANCE + model.deviation
    for index, T in enumerate(targets):
        answer, seconds = timed(partial(robot.ik, T))
        figures.ik_times.append(seconds)
        general_answer, seconds = timed(partial(general.solve_one, T))
        figures.general_times.append(seconds)
        figures.ik_wrong += wrong_rows(model, T, answer.q, allowed)
        figures.general_wrong += wrong_rows(model, T, general_answer.q, allowed)
        roots, sigma, bins = binned_roots(reference, model, T)
        if not len(roots):
            continue
        for b in bins:
            figures.roots[b] += 1
        lacking = missing(roots, answer.q)
        lacking_general = missing(roots, general_answer.q)
        for b in bins[lacking_general]:
            figures.general_missing[b] += 1
        if not lacking.any():
            continue
        figures.poses_ik_missing += 1
        returned = {label_key(c.labels) for c in answer.configurations}
        for root, s, b in zip(roots[lacking], sigma[lacking], bins[lacking], strict=True):
            figures.ik_missing[b] += 1
            figures.missing_on_direct += int(direct[index])
            branch = branches.of(root)
            taken = branch in returned
            figures.slot_taken += int(taken)
            figures.slot_empty += int(not taken)
            if verbose:
                print(f"  pose {index}: missing {np.round(root, 6).tolist()} sigma {s:.2e} "
                      f"branch {dict(branch)} slot {'taken' if taken else 'empty'}; "
                      f"{len(answer)} returned, {len(roots)} roots, general "
                      f"{len(general_answer)}", flush=True)
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", nargs="*", default=list(DEFAULT_ARMS))
    parser.add_argument("--sets", nargs="*", default=list(SETS), choices=SETS)
    parser.add_argument("--poses", type=int, default=100, help="poses per arm and set")
    parser.add_argument("--starts", type=int, default=2000, help="multistart starts per pose")
    parser.add_argument("--seed", type=int, default=25)
    parser.add_argument("--verbose", action="store_true", help="print every missing root")
    args = parser.parse_args()
    print(HEADER, flush=True)
    for arm in args.arms:
        robot = dhkin.load(arm)
        general = General6RSolver(robot.table)
        for kind in args.sets:
            rng = np.random.default_rng([args.seed, SETS.index(kind)])
            Q = samples(robot, kind, args.poses, rng)
            print(measure(robot, Q, args.starts, args.verbose, general).row(arm, kind),
                  flush=True)


if __name__ == "__main__":
    main()
