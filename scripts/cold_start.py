"""Cold start: the first ``robot.ik`` and the first ``robot.ik_batch`` of a process, in seconds;
then the first pose the direct path declines (a wrist-singular one, q5 = 0), which compiles the
pipeline (dhkin.ik.compiled.direct). ``python scripts/cold_start.py [ROBOT]`` (default ur5).

Run it in a fresh install (``python3 -m venv v && . v/bin/activate && pip install . && python
scripts/cold_start.py``) or with an empty numba cache (``NUMBA_CACHE_DIR=$(mktemp -d) python
scripts/cold_start.py``) to time the compilation of the kernels; run it again to time a process
that loads them from the cache. Figures: docs/architecture.md ("Cold start").
"""

from __future__ import annotations

import sys
import time

started = time.perf_counter()
import numpy as np  # noqa: E402 (the import is part of what is timed)

import dhkin  # noqa: E402


def main() -> None:
    imported = time.perf_counter() - started
    robot = dhkin.load(sys.argv[1] if len(sys.argv) > 1 else "ur5")
    pose = robot.fk(np.array([0.1, -1.0, 1.2, -0.5, 0.7, 0.3]))
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
    singular = robot.fk(np.array([0.1, -1.0, 1.2, -0.5, 0.0, 0.3]))
    t = time.perf_counter()
    robot.ik(singular)
    first_singular = time.perf_counter() - t
    print(f"import {imported:.1f} s, first ik {first_ik:.1f} s, first ik_batch {first_batch:.1f} s,"
          f" first ik + first ik_batch {first_ik + first_batch:.1f} s, second ik "
          f"{again * 1e6:.0f} us; then the first pose the pipeline answers (q5 = 0) "
          f"{first_singular:.1f} s")


if __name__ == "__main__":
    main()
