"""Benchmark of the numerical IK (issue 7, item 4): success, iterations, residuals and time.

For each robot, ``--count`` random joint vectors are drawn uniformly within the limits (fixed
``--seed``) and their Pinocchio poses are the targets, so every target is reachable. Each target
gets one seed-free call ``NumericalIK.solve(T)`` (random restarts, default settings). Measured:

* success: the call returned a solution (every returned solution is re-checked here by Pinocchio
  FK against the tolerance, and against the joint limits);
* iterations and starts per call (all starts together);
* residuals: position (m) and rotation (rad) of the returned solutions;
* time per call: wall clock (``time.perf_counter``) and CPU time of the calling thread
  (``time.thread_time``, which other processes on a busy machine do not inflate); the solver
  is warmed up by one call first;
* for the UR5 and the IRB 1200, whether each numerical answer is one of the closed-form
  solutions of ``dhkin.load(name).ik(T, copies=True)`` (every 2 pi-shifted copy within the
  limits): the largest joint difference to the nearest closed-form solution must be < 1e-6.

The table is printed and written into docs/numerical_ik.md between the benchmark markers, with
the command that produced it. Run: ``python scripts/bench_numerical.py`` (under a minute).
Exit status: 0 all well, 1 a wrong or inexact answer, 2 a closed-form solver was not available
(the comparison was skipped: rerun when it is).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from dataclasses import dataclass, field
from importlib.metadata import distribution, version
from pathlib import Path

import numpy as np

import dhkin
from dhkin.errors import FamilyError
from dhkin.ik.numerical import NumericalIK
from dhkin.transforms import pose_error

REPO = Path(__file__).resolve().parents[1]
#: The numerical IK issue's goal for residuals (m, rad): stricter than dhkin's default tolerance.
GOAL = 1e-10
DOC = REPO / "docs" / "numerical_ik.md"
START_MARKER = "<!-- bench_numerical:start -->"
END_MARKER = "<!-- bench_numerical:end -->"
PANDA_URDF = Path(str(distribution("example-robot-data").locate_file(
    "cmeel.prefix/share/example-robot-data/robots/panda_description/urdf/panda.urdf")))
#: A numerical answer "is" a closed-form solution when no joint differs by more than this (rad).
SAME_SOLUTION = 1e-6


@dataclass
class Measurement:
    """What one robot's run produced."""

    name: str
    targets: int
    solved: int = 0
    iterations: list[int] = field(default_factory=list)
    starts: list[int] = field(default_factory=list)
    seconds: list[float] = field(default_factory=list)
    cpu_seconds: list[float] = field(default_factory=list)
    position: list[float] = field(default_factory=list)
    rotation: list[float] = field(default_factory=list)
    exact_and_in_limits: int = 0
    closed_form_checked: bool = False
    closed_form_matches: int = 0
    closed_form_note: str = ""
    closed_form_seconds: list[float] = field(default_factory=list)

    def row(self) -> str:
        it = np.array(self.iterations)
        st = np.array(self.starts)
        ms = 1e3 * np.array(self.seconds)
        cpu_ms = 1e3 * np.array(self.cpu_seconds)
        solved = f"{self.solved}/{self.targets} ({100.0 * self.solved / self.targets:.2f} %)"
        if self.closed_form_checked:
            among = f"{self.closed_form_matches}/{self.solved}"
        else:
            among = self.closed_form_note or "n/a"
        cf_ms = (f"{1e3 * np.median(self.closed_form_seconds):.3f}"
                 if self.closed_form_seconds else "n/a")
        return (f"| {self.name} | {solved} | "
                f"{np.median(it):.0f} / {np.percentile(it, 90):.0f} / {it.max()} | "
                f"{st.mean():.2f} / {st.max()} | "
                f"{max(self.position, default=float('nan')):.2e} / "
                f"{max(self.rotation, default=float('nan')):.2e} | "
                f"{np.median(ms):.3f} / {np.percentile(ms, 90):.3f} / {ms.max():.1f} | "
                f"{np.median(cpu_ms):.3f} / {np.percentile(cpu_ms, 90):.3f} | "
                f"{among} | {cf_ms} |")


HEADER = ("| robot | solved | iterations median / p90 / max | starts mean / max "
          "| max residual m / rad | wall ms per solve median / p90 / max "
          "| CPU ms per solve median / p90 | answers among closed-form "
          "| closed-form wall ms median |\n"
          "|---|---|---|---|---|---|---|---|---|")


def random_targets(solver: NumericalIK, count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    Q = rng.uniform(solver.lower, solver.upper, size=(count, solver.dof))
    return solver.reference.fk(Q)


def closed_form_of(name: str) -> tuple[dhkin.Robot | None, str]:
    """The robot whose ``ik`` is closed-form, or None and why not."""
    robot = dhkin.load(name)
    try:
        robot.ik_solver  # noqa: B018 -- raises FamilyError when no family fits yet
        robot.ik(robot.fk(np.zeros(robot.dof)))
    except (FamilyError, NotImplementedError) as exc:
        return None, f"closed form unavailable: {type(exc).__name__}: {str(exc).splitlines()[0]}"
    return robot, ""


def measure(name: str, solver: NumericalIK, targets: np.ndarray,
            closed_form: dhkin.Robot | None, note: str) -> Measurement:
    result = Measurement(name, len(targets), closed_form_checked=closed_form is not None,
                         closed_form_note=note)
    solver.solve(targets[0])  # warm-up: builds the warm-start table once
    for target in targets:
        began, began_cpu = time.perf_counter(), time.thread_time()
        report = solver.solve_detailed(target, tolerance=GOAL)
        result.cpu_seconds.append(time.thread_time() - began_cpu)
        result.seconds.append(time.perf_counter() - began)
        result.iterations.append(report.iterations)
        result.starts.append(report.starts)
        solutions = report.solutions
        if not solutions:
            continue
        result.solved += 1
        q = solutions.q[0]
        position, rotation = pose_error(solver.reference.fk(q), target)
        result.position.append(float(position))
        result.rotation.append(float(rotation))
        inside = bool(np.all((q >= solver.lower) & (q <= solver.upper)))
        if position <= GOAL and rotation <= GOAL and inside:
            result.exact_and_in_limits += 1
        if closed_form is not None:
            began = time.perf_counter()
            reference_solutions = closed_form.ik(target, copies=True)
            result.closed_form_seconds.append(time.perf_counter() - began)
            if len(reference_solutions):
                gap = np.abs(reference_solutions.q - q).max(axis=1).min()
                result.closed_form_matches += bool(gap < SAME_SOLUTION)
    return result


def write_doc(table: str, command: str, environment: str) -> None:
    block = (f"{START_MARKER}\n"
             f"Produced by `{command}` ({environment}).\n\n{table}\n{END_MARKER}")
    text = DOC.read_text() if DOC.exists() else f"# Numerical IK\n\n{START_MARKER}\n{END_MARKER}\n"
    if START_MARKER in text and END_MARKER in text:
        before = text.split(START_MARKER)[0]
        after = text.split(END_MARKER, 1)[1]
        text = before + block + after
    else:
        text = text.rstrip("\n") + "\n\n" + block + "\n"
    DOC.parent.mkdir(parents=True, exist_ok=True)
    DOC.write_text(text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1000, help="targets per robot")
    parser.add_argument("--seed", type=int, default=2024, help="seed of the random targets")
    parser.add_argument("--no-write", action="store_true", help="print only")
    args = parser.parse_args(argv)

    runs: list[tuple[str, NumericalIK, dhkin.Robot | None, str]] = []
    for name in ("ur5", "abb_irb1200_7_70"):
        robot, note = closed_form_of(name)
        if robot is None:
            print(f"{name}: {note} -- numerical answers are not compared; rerun later",
                  file=sys.stderr)
        runs.append((name, NumericalIK.from_robot(dhkin.load(name)), robot, note))
    panda = NumericalIK.from_urdf(PANDA_URDF, "panda_hand")
    runs.append(("panda (7 axes, panda_hand)", panda, None, "no closed form (7 axes)"))

    results = []
    for index, (name, solver, robot, note) in enumerate(runs):
        targets = random_targets(solver, args.count, args.seed + index)
        results.append(measure(name, solver, targets, robot, note))
        print(f"{name}: done", file=sys.stderr)

    table = HEADER + "\n" + "\n".join(r.row() for r in results)
    problems = [f"{r.name}: {r.solved - r.exact_and_in_limits} answers not exact or out of "
                f"limits" for r in results if r.exact_and_in_limits != r.solved]
    problems += [f"{r.name}: {r.solved - r.closed_form_matches} answers not among the "
                 f"closed-form solutions" for r in results
                 if r.closed_form_checked and r.closed_form_matches != r.solved]
    print(table)
    for problem in problems:
        print("PROBLEM:", problem)
    arguments = sys.argv[1:] if argv is None else argv
    command = " ".join(["python scripts/bench_numerical.py", *arguments])
    environment = (f"Python {platform.python_version()}, pin {version('pin')}, "
                   f"numpy {np.__version__}, {platform.machine()}, {os.cpu_count()} cores, "
                   f"load average {os.getloadavg()[0]:.2f} at the end")
    if not args.no_write:
        write_doc(table, command, environment)
        print(f"written to {DOC.relative_to(REPO)}")
    if problems:
        return 1
    return 2 if any(not r.closed_form_checked for r in results[:2]) else 0


if __name__ == "__main__":
    raise SystemExit(main())
