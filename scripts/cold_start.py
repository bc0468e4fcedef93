"""Cold start: how long a fresh process takes to its first IK answers.

``python scripts/cold_start.py [ROBOT]`` (default ur5) times, in this process: ``import dhkin``,
the first ``robot.ik``, the first ``robot.ik_batch`` (100 poses), a second ``robot.ik`` and the
first wrist-singular pose (q5 = 0, the full pipeline); whether numba was imported; then, each in
a new process, the whole command ``dhkin ik ROBOT --xyz ...`` for a regular and for a singular
pose (wall time, interpreter start and import included). The closed-form IK runs in the compiled
core built by ``pip install .``: nothing is compiled at run time. Run it in a fresh install
(``python3 -m venv v && . v/bin/activate && pip install . && python scripts/cold_start.py``).
Figures: docs/architecture.md ("Cold start"). Target (issue 25): each command within 1.5 s.
"""

from __future__ import annotations

import subprocess
import sys
import time

started = time.perf_counter()
import numpy as np  # noqa: E402 (the import is part of what is timed)

import dhkin  # noqa: E402

#: Wall time within which the first answer of a new process must come (issue 25), s.
TARGET_SECONDS = 1.5


def _command(robot: dhkin.Robot, name: str, q: np.ndarray) -> float:
    """Wall time (s) of ``dhkin ik NAME`` for the pose of q, in a new process."""
    T = robot.fk(q)
    rpy = np.degrees([np.arctan2(T[2, 1], T[2, 2]), -np.arcsin(np.clip(T[2, 0], -1, 1)),
                      np.arctan2(T[1, 0], T[0, 0])])
    argv = [sys.executable, "-m", "dhkin.cli", "ik", name,
            "--xyz", *(repr(float(v)) for v in T[:3, 3]),
            "--rpy", *(repr(float(v)) for v in rpy), "--deg"]
    start = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    elapsed = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed: {done.stderr.strip()}")
    return elapsed


def main() -> None:
    imported = time.perf_counter() - started
    name = sys.argv[1] if len(sys.argv) > 1 else "ur5"
    robot = dhkin.load(name)
    regular = np.array([0.1, -1.0, 1.2, -0.5, 0.7, 0.3])
    singular = np.array([0.1, -1.0, 1.2, -0.5, 0.0, 0.3])
    pose = robot.fk(regular)
    t = time.perf_counter()
    robot.ik(pose)
    first_ik = time.perf_counter() - t
    poses = robot.fk(np.random.default_rng(0).uniform(-3.0, 3.0, (100, 6)))
    t = time.perf_counter()
    robot.ik_batch(poses)
    first_batch = time.perf_counter() - t
    t = time.perf_counter()
    robot.ik(pose)
    again = time.perf_counter() - t
    t = time.perf_counter()
    robot.ik(robot.fk(singular))
    first_singular = time.perf_counter() - t
    numba = "numba" in sys.modules
    commands = [_command(robot, name, q) for q in (regular, singular)]
    print(f"{name}: import {imported:.2f} s, first ik {first_ik * 1e3:.1f} ms, first ik_batch "
          f"{first_batch * 1e3:.1f} ms, second ik {again * 1e6:.0f} us, first singular pose "
          f"{first_singular * 1e3:.1f} ms; numba imported: {numba}")
    for what, seconds in zip(("regular", "singular (q5 = 0)"), commands, strict=True):
        verdict = "met" if seconds <= TARGET_SECONDS else "missed"
        print(f"`dhkin ik {name}` in a new process, {what} pose: {seconds:.2f} s wall (target "
              f"{TARGET_SECONDS} s: {verdict})")


if __name__ == "__main__":
    main()
