#!/usr/bin/env python
"""Batched and single-pose closed-form IK: dhkin against the peer libraries, on the same poses.

    pip install -e '.[bench]'    # EAIK, py-opw-kinematics, ik-geo, roboticstoolbox-python[ik]
    python scripts/bench_ik.py --poses 10000 --runs 5 --output bench.md

A peer that is not installed (or that does not cover a robot) is skipped, and the report says so.

For each robot, one run draws ``--poses`` joint vectors uniformly within the limits (fixed seed)
and makes tool0 poses of them with Pinocchio; a second set has q5 = 0. Every library solves the
same poses: dhkin takes base_link -> tool0 poses as they are; each peer gets them converted to its
own conventions beforehand (untimed): DH frame 0 -> 6 for EAIK (its DH rows take no theta offsets:
its joint values are converted back), the POE axes of the table for IK-Geo (its Python binding
reads the rotation transposed), OPW parameters (dhkin.opw) and radians for py-opw-kinematics, a
DHRobot of the table for the Robotics Toolbox. Every returned solution is converted to URDF
joint values and put through Pinocchio (``robot.reference().fk``).

Reported per library, single thread (EAIK's and py-opw's batch calls are given one thread):

* single: median latency of one-pose calls (each call timed, median over the poses, median of
  the runs' medians; the libraries' calls interleaved pose by pose, so that their ratio is
  taken in one machine state); the peers return principal solutions only, like
  ``ik(copies=False)``. dhkin's ``copies=False`` call is also timed in a loop of its own (a
  user's sweep of single calls: no other library's call evicting its caches between two of
  its calls), reported below the table;
* batch: poses per second of the library's batch call over all poses (a Python loop where it
  has none; that is said), median of the runs; runs go round-robin over the libraries;
* sols/pose, the largest residual against Pinocchio (position m / rotation rad), exact: the share
  of returned solutions within 1e-9 m and rad, complete: the share of poses whose original q is
  among the returned solutions (mod 2pi, 1e-6 rad);
* q5 = 0: the share of poses with at least one exact solution, and exact solutions per pose;
* speed-up of dhkin: the peer's time per pose over dhkin's, single and batch (above 1: dhkin
  is faster), like for like (against dhkin ``copies=False``, which returns principal solutions
  as the peers do).

Arms without a closed-form family (FANUC CRX-10iA, xArm6) are solved by the general 6R solver
(dhkin.ik.general6r, in the compiled core; its batch call runs the pose loop there); their target
is a median of at most GENERAL_TARGET_US per single call, and ``--profile`` splits it into the
elimination, the roots, the answer and the Python around the core.

``--profile`` adds where dhkin's time goes (kernel stages and Python overhead); ``--memory`` a
10^6-pose batch's traced peak memory. Timing is sensitive to other load on the machine: the
report states the CPU and the load average.
"""

from __future__ import annotations

import argparse
import gc
import importlib.metadata
import math
import os
import platform
import statistics
import sys
import time
import tracemalloc
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

import dhkin
from dhkin import _core
from dhkin.errors import FamilyError
from dhkin.ik.core import EXTRA_ROOTS
from dhkin.ik.workers import default_workers
from dhkin.opw import opw_parameters
from dhkin.transforms import invert, pose_error

EXACT = 1e-9
COMPLETE = 1e-6
TWO_PI = 2.0 * math.pi
DEFAULT_ROBOTS = ("abb_irb1200_7_70", "ur5", "ur5e", "ur5e_calibrated", "tm5_900",
                  "kinova_gen3_6dof", "fanuc_crx10ia", "xarm6")
#: Single-pose median target of the general 6R solver (issue 26), us.
GENERAL_TARGET_US = 50.0
#: Targets of the closed-form families (issue 25), per core: single call median (us) and its
#: ratio to EAIK's in the same run; batch rate (poses/s) and its ratio to EAIK's single-thread
#: batch; a refined table within this factor of an exact table of its family.
SINGLE_TARGET_US, SINGLE_EAIK_RATIO = 2.5, 0.6
BATCH_TARGET, BATCH_EAIK_RATIO = 2e6, 6.0
REFINED_FACTOR = 2.0
PEERS = ("eaik", "opw", "ikgeo", "rtb")


# --------------------------------------------------------------------------------------------
# Poses


@dataclass
class PoseSet:
    """Joint vectors q (N, 6), their tool0 poses T (N, 4, 4) and DH-flange poses (N, 4, 4)."""

    q: NDArray[np.float64]
    T: NDArray[np.float64]
    T_dh: NDArray[np.float64]


def pose_sets(robot: dhkin.Robot, n: int, seed: int) -> tuple[PoseSet, PoseSet]:
    """Random poses within the limits, and the same with q5 = 0 (Pinocchio FK)."""
    rng = np.random.default_rng(seed)
    sets = []
    for singular in (False, True):
        q = robot.table.random_q(n, rng)
        if singular:
            q[:, 4] = 0.0
        T = np.ascontiguousarray(robot.reference().fk(q))
        T_dh = invert(robot.table.base) @ T @ invert(robot.table.tool)
        sets.append(PoseSet(q, T, np.ascontiguousarray(T_dh)))
    return sets[0], sets[1]


# --------------------------------------------------------------------------------------------
# Libraries: a uniform adapter per library


@dataclass
class Library:
    """One IK implementation as the benchmark sees it.

    ``single(k)`` solves pose k of the current set (inputs prepared beforehand); ``batch()``
    solves them all; ``solutions(result)`` turns a batch result into per-pose (m, 6) arrays of
    URDF joint values (untimed)."""

    name: str
    version: str
    note: str = ""
    batch_note: str = ""
    max_poses: int | None = None  # solve at most this many poses (slow libraries)
    single: Callable[[int], Any] = field(default=lambda k: None)
    batch: Callable[[], Any] = field(default=lambda: None)
    solutions: Callable[[Any], list[NDArray[np.float64]]] = field(default=lambda r: [])
    use: Callable[[PoseSet], None] = field(default=lambda poses: None)
    #: Share of returned rows the library itself flags as approximate (least squares), if any.
    flagged: Callable[[Any], float] | None = None


def version_of(distribution: str) -> str:
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return "?"


def dhkin_library(robot: dhkin.Robot, copies: bool, workers: int = 1) -> Library:
    state: dict[str, Any] = {}

    def use(poses: PoseSet) -> None:
        state["T"] = poses.T

    def solutions(result: tuple[NDArray[np.float64], NDArray[np.bool_]]) -> list:
        Q, valid = result
        return [Q[k][valid[k]] for k in range(Q.shape[0])]

    label = "dhkin" if not copies else "dhkin, every 2pi copy"
    note = ("one solution per branch (`copies=False`)" if not copies else
            "all in-limit 2pi copies (`copies=True`)")
    if workers > 1:
        label += f", {workers} threads"
        note += f"; the batch shared among {workers} threads"
    return Library(
        name=label, version=version_of("dhkin"), note=note,
        batch_note=f"`ik_batch`, {workers} thread{'s' if workers > 1 else ''}", use=use,
        single=lambda k: robot.ik(state["T"][k], copies=copies),
        batch=lambda: robot.ik_batch(state["T"], copies=copies, workers=workers),
        solutions=solutions)


def eaik_library(robot: dhkin.Robot, workers: int = 1) -> Library | str:
    try:
        from eaik.IK_DH import DhRobot
    except ImportError:
        return "not installed (pip install EAIK)"
    table = robot.table
    if table.convention != "standard" or not all(j.is_revolute for j in table.joints):
        return "its DH robot takes standard DH rows of revolute joints only"
    eaik = DhRobot(np.array([j.alpha for j in table.joints]), np.array([j.a for j in table.joints]),
                   np.array([j.d for j in table.joints]))
    if not eaik.hasKnownDecomposition():  # its IK would abort the process (std::terminate)
        return f"no subproblem decomposition known for this arm ({eaik.getKinematicFamily()})"
    offset = np.array([j.offset for j in table.joints])
    direction = np.array([j.direction for j in table.joints], dtype=float)
    state: dict[str, Any] = {}

    def use(poses: PoseSet) -> None:
        state["targets"] = [np.ascontiguousarray(T) for T in poses.T_dh]

    def solutions(result: Sequence[Any]) -> list:
        return [(np.asarray(s.Q).reshape(-1, 6) - offset) / direction for s in result]

    def flagged(result: Sequence[Any]) -> float:
        flags = np.concatenate([np.asarray(s.is_LS, dtype=bool).ravel() for s in result])
        return float(flags.mean()) if flags.size else 0.0

    return Library(
        name="EAIK" if workers == 1 else f"EAIK, {workers} threads", version=version_of("EAIK"),
        note=f"DH robot, family {eaik.getKinematicFamily()}; theta offsets converted",
        batch_note=f"`IK_batched`, {workers} thread{'s' if workers > 1 else ''}", use=use,
        single=lambda k: eaik.IK(state["targets"][k]),
        batch=lambda: eaik.IK_batched(state["targets"], num_worker_threads=workers),
        solutions=solutions, flagged=flagged)


def poe_of(robot: dhkin.Robot, meeting: Sequence[Sequence[int]]
           ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Product-of-exponentials model of the table at q = 0 (DH frame 0): axes h (6, 3) times
    each joint's direction, offsets p (7, 3) between points on consecutive axes (axes that meet
    share their meeting point), and the DH flange M (4, 4) at q = 0."""
    from dhkin.ik.geometry import common_point, zero_configuration

    axes, M = zero_configuration(robot.table)
    h = np.array([a.direction * j.direction for a, j in zip(axes, robot.table.joints,
                                                            strict=True)])
    points = np.array([a.point for a in axes])
    for group in meeting:
        points[list(group)] = common_point([axes[i] for i in group])
    p = np.zeros((7, 3))
    p[0], p[1:6], p[6] = points[0], points[1:] - points[:-1], M[:3, 3] - points[5]
    return h, p, M


def ikgeo_library(robot: dhkin.Robot) -> Library | str:
    try:
        import ik_geo
    except ImportError:
        return "not installed (pip install ik-geo)"
    family = robot.ik_solver.family if robot.has_closed_form else ""
    if family == "spherical_wrist":
        constructor, meeting = ik_geo.Robot.spherical_two_parallel, [(3, 4, 5)]
    elif family == "offset_wrist":
        constructor, meeting = ik_geo.Robot.three_parallel_two_intersecting, [(4, 5)]
    else:
        return f"no IK-Geo class chosen for the {family or 'numerical'} family here"
    h, p, M = poe_of(robot, meeting)
    solver = constructor(h, p)
    state: dict[str, Any] = {}

    def use(poses: PoseSet) -> None:
        # IK-Geo's frame n has the base's orientation at q = 0; its binding reads R transposed
        rotations = poses.T_dh[:, :3, :3] @ M[:3, :3].T
        state["R"] = [np.ascontiguousarray(R.T) for R in rotations]
        state["t"] = [np.ascontiguousarray(t) for t in poses.T_dh[:, :3, 3]]

    def solve(k: int) -> Any:
        return solver.get_ik(state["R"][k], state["t"][k])

    def batch() -> list:
        return [solver.get_ik(R, t) for R, t in zip(state["R"], state["t"], strict=True)]

    def solutions(result: Sequence[Any]) -> list:
        return [np.array([s[0] for s in sols], dtype=float).reshape(-1, 6) for sols in result]

    def flagged(result: Sequence[Any]) -> float:
        flags = [bool(s[1]) for sols in result for s in sols]
        return float(np.mean(flags)) if flags else 0.0

    return Library(name="IK-Geo", version=version_of("ik-geo"),
                   note=f"`{constructor.__name__}` from the table's POE axes; R passed transposed",
                   batch_note="no batch call: Python loop", use=use, single=solve, batch=batch,
                   solutions=solutions, flagged=flagged)


def opw_library(robot: dhkin.Robot) -> Library | str:
    try:
        from py_opw_kinematics._internal import KinematicModel
        from py_opw_kinematics._internal import Robot as OpwRobot
    except ImportError:
        return "not installed (pip install py-opw-kinematics)"
    try:
        params = opw_parameters(robot.table)  # checked against the table's FK to 1e-12
    except FamilyError as exc:
        return f"not an OPW arm ({str(exc).splitlines()[-1].strip()})"  # one line or several
    model = KinematicModel(**params.geometric, offsets=params.offsets,
                           flip_axes=tuple(sign < 0 for sign in params.sign_corrections))
    opw = OpwRobot(model, False)  # radians
    q = robot.table.random_q(5, np.random.default_rng(1))
    forward = np.array([opw.forward(tuple(row)) for row in q])
    if np.abs(params.base @ forward @ params.tool - robot.reference().fk(q)).max() > 1e-12:
        return "its FK with dhkin.opw's parameters differs from Pinocchio's"
    to_opw_base, from_tool0 = invert(params.base), invert(params.tool)
    state: dict[str, Any] = {}

    def use(poses: PoseSet) -> None:  # tool0 poses in OPW's frames (identity for the IRB 1200)
        T = np.ascontiguousarray(to_opw_base @ poses.T @ from_tool0)
        state["T"] = [np.ascontiguousarray(pose) for pose in T]
        state["flat"] = np.ascontiguousarray(T.reshape(-1, 16))

    def batch() -> NDArray[np.float64]:
        return opw.reach(state["flat"], None, None, 1)[0]

    def solutions(result: NDArray[np.float64]) -> list:
        return [rows[np.all(np.isfinite(rows), axis=1)] for rows in result]

    return Library(name="py-opw-kinematics", version=version_of("py-opw-kinematics"),
                   note="radians; parameters from dhkin.opw", use=use,
                   batch_note="`reach` (8 branches), 1 thread",
                   single=lambda k: opw.inverse(state["T"][k], None, None),
                   batch=batch, solutions=solutions)


def rtb_library(robot: dhkin.Robot, max_poses: int) -> Library | str:
    try:
        import roboticstoolbox as rtb
        import sympy  # noqa: F401  (analytic_ik needs it: the [ik] extra)
        from spatialmath import SE3
    except ImportError:
        return "not installed (pip install 'roboticstoolbox-python[ik]')"
    table = robot.table
    if table.convention != "standard" or not all(j.is_revolute for j in table.joints):
        return "its analytic IK takes standard DH revolute arms only"
    links = [rtb.RevoluteDH(d=j.d, a=j.a, alpha=j.alpha, offset=j.offset, flip=j.direction < 0,
                            qlim=[j.lower, j.upper]) for j in table.joints]
    arm = rtb.DHRobot(links, name=robot.name, base=SE3(table.base, check=False),
                      tool=SE3(table.tool, check=False))
    start = time.perf_counter()
    solver = arm.analytic_ik()
    derivation = time.perf_counter() - start
    state: dict[str, Any] = {}

    def use(poses: PoseSet) -> None:
        state["T"] = [np.ascontiguousarray(T) for T in poses.T[:max_poses]]

    def batch() -> list:
        return [solver.solve(T, joint_limits=False) for T in state["T"]]

    def solutions(result: Sequence[Any]) -> list:
        return [np.asarray(s.q, dtype=float).reshape(-1, 6) for s in result]

    return Library(name="Robotics Toolbox", version=version_of("roboticstoolbox-python"),
                   note=f"`analytic_ik().solve` (derived once in {derivation:.0f} s)",
                   batch_note=f"no batch call: Python loop over {max_poses} poses",
                   max_poses=max_poses, use=use,
                   single=lambda k: solver.solve(state["T"][k], joint_limits=False),
                   batch=batch, solutions=solutions)


# --------------------------------------------------------------------------------------------
# Measurements


@dataclass
class Quality:
    solutions_per_pose: float
    position: float
    rotation: float
    exact: float  # share of returned solutions
    complete: float  # share of poses


@dataclass
class Row:
    library: Library
    single_us: float
    batch_rate: float
    generic: Quality
    singular_found: float  # share of q5 = 0 poses with >= 1 exact solution
    singular_exact_per_pose: float
    singular_inexact: float  # share of returned q5 = 0 solutions that are not exact
    #: dhkin's first library only: the single call timed in a loop of its own (no other
    #: library's call between two of its calls), median of the runs.
    single_alone_us: float | None = None


def timed_single(library: Library, n: int, runs: int) -> float:
    """Median over runs of the median one-pose call time (us) over poses 0..n-1."""
    medians = []
    for _ in range(runs):
        gc.disable()
        try:
            times = []
            for k in range(n):
                start = time.perf_counter_ns()
                library.single(k)
                times.append(time.perf_counter_ns() - start)
        finally:
            gc.enable()
        medians.append(statistics.median(times) / 1000.0)
    return statistics.median(medians)


def timed_singles(libraries: Sequence[Library], counts: Sequence[int]) -> list[float]:
    """The median one-pose call time (us) of each library over its poses 0..counts[j]-1, the
    libraries' calls interleaved pose by pose (the first library of each pose rotates), so
    that every library is timed in the same machine state: the single-call ratios of one run
    compare like with like even when the machine's speed drifts during the run."""
    times: list[list[int]] = [[] for _ in libraries]
    order = list(range(len(libraries)))
    gc.disable()
    try:
        for k in range(max(counts)):
            for j in order[k % len(order):] + order[:k % len(order)]:
                if k < counts[j]:
                    call = libraries[j].single
                    start = time.perf_counter_ns()
                    call(k)
                    times[j].append(time.perf_counter_ns() - start)
    finally:
        gc.enable()
    return [statistics.median(library_times) / 1000.0 for library_times in times]


# The clock of batch calls: wall time by default; --cpu-clock takes the process's CPU time
# (every thread's), which a shared machine's other jobs do not inflate.
BATCH_CLOCK: list[Callable[[], float]] = [time.perf_counter]


def timed_batch(library: Library, n: int, runs: int) -> tuple[float, Any]:
    """Median over runs of poses per second of the batch call; and its last result."""
    rates, result = [], None
    clock = BATCH_CLOCK[0]
    for _ in range(runs):
        gc.disable()
        try:
            start = clock()
            result = library.batch()
            elapsed = clock() - start
        finally:
            gc.enable()
        rates.append(n / elapsed)
    return statistics.median(rates), result


def quality(robot: dhkin.Robot, poses: PoseSet, solved: list[NDArray[np.float64]]) -> Quality:
    """Residuals against Pinocchio and completeness of the returned solutions."""
    n = len(solved)
    counts = np.array([len(s) for s in solved])
    if counts.sum() == 0:
        return Quality(0.0, math.nan, math.nan, 0.0, 0.0)
    values = np.concatenate([s for s in solved if len(s)])
    targets = np.repeat(poses.T[:n], counts, axis=0)
    finite = np.all(np.isfinite(values), axis=1)
    position = np.full(len(values), np.inf)
    rotation = np.full(len(values), np.inf)
    position[finite], rotation[finite] = pose_error(robot.reference().fk(values[finite]),
                                                    targets[finite])
    gap = np.abs(np.mod(values - np.repeat(poses.q[:n], counts, axis=0) + np.pi, TWO_PI)
                 - np.pi).max(axis=1)
    owner = np.repeat(np.arange(n), counts)
    found = np.zeros(n, bool)
    np.logical_or.at(found, owner, gap <= COMPLETE)
    return Quality(float(counts.mean()), float(position.max()), float(rotation.max()),
                   float(np.mean((position <= EXACT) & (rotation <= EXACT))), float(found.mean()))


def singular_behaviour(robot: dhkin.Robot, poses: PoseSet,
                       solved: list[NDArray[np.float64]]) -> tuple[float, float, float]:
    """(share of poses with an exact solution, exact solutions per pose, share of returned
    solutions that are not exact) on the q5 = 0 set."""
    n = len(solved)
    counts = np.array([len(s) for s in solved])
    if counts.sum() == 0:
        return 0.0, 0.0, 0.0
    values = np.concatenate([s for s in solved if len(s)])
    targets = np.repeat(poses.T[:n], counts, axis=0)
    exact = np.zeros(len(values), bool)
    finite = np.all(np.isfinite(values), axis=1)
    position, rotation = pose_error(robot.reference().fk(values[finite]), targets[finite])
    exact[finite] = (position <= EXACT) & (rotation <= EXACT)
    per_pose = np.bincount(np.repeat(np.arange(n), counts), weights=exact, minlength=n)
    return float(np.mean(per_pose > 0)), float(per_pose.mean()), float(1 - exact.mean())


def measure(robot: dhkin.Robot, libraries: list[Library], generic: PoseSet, singular: PoseSet,
            runs: int, latency_poses: int) -> list[Row]:
    """Quality from one batch of each set per library; timing per run: the libraries' single
    calls interleaved pose by pose (:func:`timed_singles`), then each library's batch in turn,
    so that all see the same machine state."""
    singular_results, sizes = [], []
    for library in libraries:
        print(f"{robot.name}: {library.name} ...", file=sys.stderr, flush=True)
        library.use(singular)
        singular_results.append(library.batch())
        library.use(generic)
        library.single(0)  # warm up
        sizes.append(len(generic.q) if library.max_poses is None
                     else min(len(generic.q), library.max_poses))
    singles: list[list[float]] = [[] for _ in libraries]
    rates: list[list[float]] = [[] for _ in libraries]
    results: list[Any] = [None] * len(libraries)
    alone: list[float] = []
    for _ in range(runs):
        counts = [min(latency_poses, size) for size in sizes]
        for k, single in enumerate(timed_singles(libraries, counts)):
            singles[k].append(single)
        alone.append(timed_single(libraries[0], counts[0], 1))
        for k, library in enumerate(libraries):
            rate, results[k] = timed_batch(library, sizes[k], 1)
            rates[k].append(rate)
    rows = []
    for k, library in enumerate(libraries):
        if library.flagged is not None:
            library.note += (f"; rows it flags least-squares: {library.flagged(results[k]):.1%} "
                             f"(q5 = 0 set: {library.flagged(singular_results[k]):.1%})")
        found, per_pose, inexact = singular_behaviour(robot, singular,
                                                      library.solutions(singular_results[k]))
        rows.append(Row(library, statistics.median(singles[k]), statistics.median(rates[k]),
                        quality(robot, generic, library.solutions(results[k])), found, per_pose,
                        inexact, statistics.median(alone) if k == 0 else None))
    return rows


# --------------------------------------------------------------------------------------------
# Profile and memory of dhkin


def profile_dhkin(robot: dhkin.Robot, poses: PoseSet, runs: int) -> list[tuple[str, float]]:
    """Per pose (us): the compiled core's stages of ik_batch(copies=False) (every branch's
    verified solution by the direct path, or the full pipeline for the poses it declines; the
    in-limit copy nearest the seed of each) and the Python around them, and the single-pose call
    split into the core's call and the rest."""
    solver = robot.ik_solver
    core = solver.core
    n, B, dof = len(poses.T), solver.n_branches, robot.dof
    T = np.ascontiguousarray(poses.T)
    seeds = np.zeros((1, dof))
    q = np.empty((n, B, dof))
    ok = np.empty((n, B), np.bool_)
    flags = np.empty((n, B), np.uint8)
    errors = np.empty((n, B, 2))
    totals = np.empty((n, B), np.int64)
    why = np.empty((n, 6))
    info = np.empty((n, 7))
    E = EXTRA_ROOTS if solver.completed else 0
    extra = (np.empty((n, E, dof)), np.empty((n, E), np.int16), np.empty((n, E), np.uint8),
             np.empty((n, E, 2)))
    out = solver._batch_arrays(n, B)

    def best(call: Callable[[], object]) -> float:  # fastest of the runs: least disturbed
        call()
        times = []
        gc.disable()
        try:
            for _ in range(runs):
                start = time.perf_counter()
                call()
                times.append(time.perf_counter() - start)
        finally:
            gc.enable()
        return min(times) / n * 1e6

    done = np.empty(n, np.bool_)
    direct_only = best(lambda: core.direct_answers(T, seeds, 1e-9, solver.frames, done))
    taken = 100.0 * float(done.mean())
    branches = best(lambda: core.principal(T, seeds, 1e-9, solver.frames, False, q, ok, flags,
                                           errors, totals, why, info, *extra))
    pipeline = best(lambda: core.principal(T, seeds, 1e-9, solver.frames, False, q, ok, flags,
                                           errors, totals, why, info, *extra, direct=False))
    expand = best(lambda: core.expand(T, seeds, 1e-9, solver.frames, False, q, ok, flags, errors,
                                      *out))
    batch = best(lambda: robot.ik_batch(T, copies=False, workers=1))
    sample = T[:2000]
    core_one = best_single(lambda pose: core.solve(pose, None, 1e-9, None, False), sample, runs)
    whole_one = best_single(lambda pose: robot.ik(pose, copies=False), sample, runs)
    return [(f"direct path alone (closed form and the lanes' check; it answers {taken:.1f} % of "
             f"the poses)", direct_only),
            ("every branch's verified solution (direct path, else the pipeline)", branches),
            ("every branch's verified solution: the full pipeline, for comparison", pipeline),
            ("in-limit copy nearest the seed, packing", expand),
            ("ik_batch minus the core (Python, allocation)", batch - branches - expand),
            ("ik_batch(copies=False), total", batch),
            ("single pose: the core's solve (with argument passing)", core_one),
            ("single pose: Python around it (checks, result object)", whole_one - core_one),
            ("single pose: ik(copies=False), total", whole_one)]


def profile_general(robot: dhkin.Robot, poses: PoseSet, runs: int) -> list[tuple[str, float]]:
    """Per pose (us, median over the poses, fastest of the runs) of the general 6R solver's
    single call, in the compiled core (cpp/dhkin/general6r/): one elimination (right side, left
    null space, leading matrix, the eigenproblem, splits, back-substitution), the roots (Newton
    on the exact chain, verification, merging, the singular measure, moved poses where
    ill-conditioned), the answer (seed's members, in-limit copies), and the Python around the
    core (input checks, the result)."""
    solver = robot.general_solver
    assert solver is not None
    core = solver.core
    n = min(len(poses.T), 2000)
    T_dh = [np.ascontiguousarray(solver.target_dh(T)) for T in poses.T[:n]]
    targets = [np.ascontiguousarray(T) for T in poses.T[:n]]
    seed = np.zeros(6)
    counts = [len(core.candidates(T)[0]) for T in T_dh]

    def median_of(call: Callable[[int], object]) -> float:
        best = math.inf
        for _ in range(runs):
            times = []
            for k in range(n):
                start = time.perf_counter_ns()
                call(k)
                times.append(time.perf_counter_ns() - start)
            best = min(best, statistics.median(times) / 1000.0)
        return best

    eliminate = median_of(lambda k: core.candidates(T_dh[k]))
    roots = median_of(lambda k: core.roots(T_dh[k], EXACT))
    solve = median_of(lambda k: core.solve(targets[k], seed, EXACT, False, None))
    single = median_of(lambda k: robot.ik(poses.T[k], copies=False))
    return [("elimination (eigenproblem included)", eliminate),
            ("roots (Newton, verification, merging)", roots - eliminate),
            ("answer (members, in-limit copies)", solve - roots),
            ("Python around the core", single - solve),
            ("single call, in all", single),
            ("candidates per pose (mean)", float(np.mean(counts)))]


def refined_against_ideal(robot: dhkin.Robot, poses: PoseSet, runs: int,
                          latency_poses: int) -> list[str]:
    """A refined table (closed form on its ideal model, then Newton on the exact chain)
    against its ideal model solved exactly, on the same poses: per-pose time ratios."""
    ideal = dhkin.Robot(robot.ik_solver.fit.ideal)
    rows = []
    for who in (robot, ideal):
        library = dhkin_library(who, copies=False)
        library.use(poses)
        rows.append((timed_single(library, latency_poses, runs),
                     timed_batch(library, len(poses.T), runs)[0]))
    (single, batch), (ideal_single, ideal_batch) = rows
    ratio_single, ratio_batch = single / ideal_single, ideal_batch / batch
    verdict = "met" if max(ratio_single, ratio_batch) <= REFINED_FACTOR else "missed"
    return [f"Refined table against its ideal model (same poses; target: within "
            f"{REFINED_FACTOR:g}x): single "
            f"{single:.1f} us vs {ideal_single:.1f} us (x{ratio_single:.2f}), batch "
            f"{batch:,.0f} vs {ideal_batch:,.0f} poses/s (x{ratio_batch:.2f}): {verdict}.", ""]


def best_single(call: Callable[[NDArray[np.float64]], object], poses: NDArray[np.float64],
                runs: int) -> float:
    """Fastest over the runs of the median (us) of one call per pose."""
    for T in poses:
        call(T)
    medians = []
    gc.disable()
    try:
        for _ in range(runs):
            times = []
            for T in poses:
                start = time.perf_counter_ns()
                call(T)
                times.append(time.perf_counter_ns() - start)
            medians.append(statistics.median(times) / 1000.0)
    finally:
        gc.enable()
    return min(medians)


def memory_of_a_million(robot: dhkin.Robot) -> list[tuple[str, float, float]]:
    """(mode, seconds, traced peak MiB) for 10^6 poses: streamed with every copy, and dense with
    one solution per branch. The 128 MiB input exists before tracing starts."""
    unique = robot.fk(robot.table.random_q(1000, np.random.default_rng(3)))
    T = np.tile(unique, (1000, 1, 1))
    results = []
    tracemalloc.start()
    try:
        start = time.perf_counter()
        for _ in robot.ik_batch_chunks(T):
            pass
        results.append(("ik_batch_chunks, every copy", time.perf_counter() - start,
                        tracemalloc.get_traced_memory()[1] / 2**20))
        tracemalloc.reset_peak()
        start = time.perf_counter()
        Q, _ = robot.ik_batch(T, copies=False)
        results.append((f"ik_batch(copies=False), result {Q.shape}", time.perf_counter() - start,
                        tracemalloc.get_traced_memory()[1] / 2**20))
        del Q
    finally:
        tracemalloc.stop()
    return results


# --------------------------------------------------------------------------------------------
# Report


def fmt(value: float, digits: int = 3) -> str:
    if value != value:
        return "n/a"
    return f"{value:.{digits}g}"


def report(robot: dhkin.Robot, rows: list[Row], skipped: list[tuple[str, str]],
           n: int) -> list[str]:
    like = next(r for r in rows if r.library.name == "dhkin")
    lines = [f"### {robot.name} ({robot.ik_family}), {n} poses", "",
             "| library | single (us) | batch (poses/s) | sols/pose | max residual (m / rad) "
             "| exact | complete | q5 = 0: poses solved exactly, exact sols/pose, inexact share "
             "| dhkin speed-up, single | dhkin speed-up, batch |",
             "|---|---:|---:|---:|---:|---:|---:|---|---:|---:|"]
    for row in rows:
        lib = row.library
        single_ratio = row.single_us / like.single_us
        batch_ratio = like.batch_rate / row.batch_rate
        lines.append(
            f"| {lib.name} {lib.version} | {row.single_us:.1f} | {row.batch_rate:,.0f} | "
            f"{row.generic.solutions_per_pose:.1f} | {fmt(row.generic.position)} / "
            f"{fmt(row.generic.rotation)} | {row.generic.exact:.1%} | "
            f"{row.generic.complete:.1%} | {row.singular_found:.1%}, "
            f"{row.singular_exact_per_pose:.1f}, {row.singular_inexact:.1%} | "
            f"{single_ratio:.2f} | {batch_ratio:.2f} |")
    lines.append("")
    for row in rows:
        lines.append(f"* {row.library.name}: {row.library.note}; batch: "
                     f"{row.library.batch_note}.")
    for name, reason in skipped:
        lines.append(f"* {name}: skipped, {reason}.")
    lines.append("")
    return lines


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as info:
            for line in info:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    load = ", ".join(f"{v:.2f}" for v in os.getloadavg()) if hasattr(os, "getloadavg") else "?"
    width = _core.VECTOR_WIDTH
    vectors = {8: "AVX-512", 4: "AVX"}.get(width, "SSE2 / portable")
    return (f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, numpy "
            f"{np.__version__}, dhkin {version_of('dhkin')} (compiled core, built for {vectors}: "
            f"{width} doubles a vector); load average {load}")


def build_libraries(robot: dhkin.Robot, peers: Sequence[str], rtb_poses: int
                    ) -> tuple[list[Library], list[tuple[str, str]]]:
    libraries = [dhkin_library(robot, copies=False), dhkin_library(robot, copies=True)]
    cores = default_workers()
    if cores > 1:  # the batch on every core, dhkin's and EAIK's
        libraries.append(dhkin_library(robot, copies=False, workers=cores))
        shared_eaik = eaik_library(robot, cores) if "eaik" in peers else "not asked for"
        if not isinstance(shared_eaik, str):
            libraries.append(shared_eaik)
    skipped: list[tuple[str, str]] = []
    makers: dict[str, tuple[str, Callable[[], Library | str]]] = {
        "eaik": ("EAIK", lambda: eaik_library(robot)),
        "opw": ("py-opw-kinematics", lambda: opw_library(robot)),
        "ikgeo": ("IK-Geo", lambda: ikgeo_library(robot)),
        "rtb": ("Robotics Toolbox", lambda: rtb_library(robot, rtb_poses)),
    }
    for key in peers:
        name, make = makers[key]
        made = make()
        if isinstance(made, str):
            skipped.append((name, made))
        else:
            libraries.append(made)
    return libraries, skipped


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", nargs="+", default=list(DEFAULT_ROBOTS))
    parser.add_argument("--poses", type=int, default=10_000)
    parser.add_argument("--latency-poses", type=int, default=2000,
                        help="poses timed one by one per run (default 2000)")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--peers", default=",".join(PEERS),
                        help=f"comma-separated subset of {','.join(PEERS)}, or 'none'")
    parser.add_argument("--rtb-poses", type=int, default=100,
                        help="poses for the Robotics Toolbox (about 1 ms each)")
    parser.add_argument("--profile", action="store_true", help="where dhkin's time goes")
    parser.add_argument("--memory", action="store_true", help="a 10^6-pose batch's memory")
    parser.add_argument("--seed", type=int, default=2024)
    parser.add_argument("--output", help="also write the report (markdown) to this file")
    parser.add_argument("--cpu-clock", action="store_true",
                        help="time batch calls by the process's CPU time, not wall time "
                             "(for a shared machine; the multi-thread rows then add the threads)")
    args = parser.parse_args(argv)
    if args.cpu_clock:
        BATCH_CLOCK[0] = time.process_time
    peers = [] if args.peers == "none" else [p.strip() for p in args.peers.split(",") if p]
    unknown = set(peers) - set(PEERS)
    if unknown:
        parser.error(f"--peers: unknown {sorted(unknown)}; expected a subset of {PEERS}")

    command = "python scripts/bench_ik.py " + " ".join(sys.argv[1:] if argv is None else argv)
    lines = ["## Results", "", f"Command: `{command.strip()}`", "", f"Machine: {machine()}", ""]
    for name in args.robots:
        robot = dhkin.load(name)
        generic, singular = pose_sets(robot, args.poses, args.seed)
        libraries, skipped = build_libraries(robot, peers, args.rtb_poses)
        rows = measure(robot, libraries, generic, singular, args.runs, args.latency_poses)
        lines += report(robot, rows, skipped, args.poses)
        shared = [r for r in rows if r.library.name.startswith("dhkin, ")
                  and r.library.name.endswith("threads")]
        eaik = next((r for r in rows if r.library.name == "EAIK"), None)
        if robot.has_closed_form:
            row = rows[0]
            verdict = "met" if row.batch_rate >= BATCH_TARGET else "missed"
            lines.append(f"Batch, one thread: {row.batch_rate:,.0f} poses/s (target "
                         f"{BATCH_TARGET:,.0f}: {verdict}); single call {row.single_us:.2f} us "
                         f"(target {SINGLE_TARGET_US} us: "
                         f"{'met' if row.single_us <= SINGLE_TARGET_US else 'missed'}).")
            assert row.single_alone_us is not None
            lines.append(f"Single call in a loop of its own (no other library's call between "
                         f"two of dhkin's): {row.single_alone_us:.2f} us (target "
                         f"{SINGLE_TARGET_US} us: "
                         f"{'met' if row.single_alone_us <= SINGLE_TARGET_US else 'missed'}).")
            if eaik is not None:
                batch_ratio = row.batch_rate / eaik.batch_rate
                single_ratio = row.single_us / eaik.single_us
                batch_verdict = "met" if batch_ratio >= BATCH_EAIK_RATIO else "missed"
                single_verdict = "met" if single_ratio <= SINGLE_EAIK_RATIO else "missed"
                lines.append(
                    f"Against EAIK in the same run: batch x{batch_ratio:.2f} (target "
                    f"x{BATCH_EAIK_RATIO:g}: {batch_verdict}), single call x{single_ratio:.2f} "
                    f"of EAIK's time (target x{SINGLE_EAIK_RATIO:g}: {single_verdict}).")
        for row in shared:
            lines.append(f"{row.library.batch_note}: {row.batch_rate:,.0f} poses/s.")
        lines.append("")
        general = robot.general_solver
        if general is not None:
            verdict = "met" if rows[0].single_us <= GENERAL_TARGET_US else "missed"
            lines.append(f"General 6R solver: single pose median {rows[0].single_us:.1f} us "
                         f"(target {GENERAL_TARGET_US:.0f} us: {verdict}).")
        if robot.has_closed_form and robot.ik_solver.fit.refine:
            lines += refined_against_ideal(robot, generic, args.runs, args.latency_poses)
        if args.profile:
            lines += [f"Where dhkin's time goes ({robot.name}, per pose, us; each stage timed on "
                      f"its own, fastest of {args.runs} runs):", "",
                      "| stage | us/pose |", "|---|---:|"]
            stages = (profile_general(robot, generic, args.runs) if general is not None
                      else profile_dhkin(robot, generic, args.runs))
            lines += [f"| {stage} | {value:.3f} |" for stage, value in stages]
            lines.append("")
        if args.memory:
            lines += [f"10^6 poses ({robot.name}): traced peak memory (numpy arrays; the "
                      f"128 MiB input excluded)", "", "| call | s | peak MiB |", "|---|---:|---:|"]
            lines += [f"| {mode} | {seconds:.1f} | {peak:.0f} |"
                      for mode, seconds, peak in memory_of_a_million(robot)]
            lines.append("")
    text = "\n".join(lines)
    print(text)
    if args.output:
        with open(args.output, "w", encoding="utf-8") as out:
            out.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
