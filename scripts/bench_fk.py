"""Time and memory of ``robot.fk`` on a large batch, for chunk sizes around dhkin.dh.FK_CHUNK.

    python scripts/bench_fk.py [--n 1000000] [--robot ur5]

Prints, per chunk size, the wall time and the peak memory numpy allocated during the call
(tracemalloc traces numpy's allocations) beside the size of the result. Speed is measured
here, never asserted in tests (tests/test_reproducers.py checks the memory bound only).
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

import dhkin
import dhkin.dh


def measure(robot: dhkin.Robot, q: np.ndarray, chunk: int) -> tuple[float, float, float]:
    """(seconds, peak MB, result MB) of one fk call with ``chunk`` vectors at a time."""
    saved = dhkin.dh.FK_CHUNK
    dhkin.dh.FK_CHUNK = chunk
    try:
        tracemalloc.start()
        start = time.perf_counter()
        T = robot.fk(q)
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    finally:
        dhkin.dh.FK_CHUNK = saved
    return seconds, peak / 1e6, T.nbytes / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000, help="joint vectors (default 10^6)")
    parser.add_argument("--robot", default="ur5", help="built-in robot (default ur5)")
    args = parser.parse_args()
    robot = dhkin.load(args.robot)
    q = robot.table.random_q(args.n, np.random.default_rng(0))
    print(f"{robot.name}: fk of {args.n} joint vectors (input {q.nbytes / 1e6:.0f} MB)")
    for chunk in (1024, 4096, 16384, 65536):
        seconds, peak, result = measure(robot, q, chunk)
        mark = " (FK_CHUNK)" if chunk == dhkin.dh.FK_CHUNK else ""
        print(f"  chunk {chunk:6d}{mark}: {seconds:5.2f} s, peak {peak:6.0f} MB "
              f"({peak / result:.2f} x the result, {result:.0f} MB)")


if __name__ == "__main__":
    main()
