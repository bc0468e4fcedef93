"""Worker threads that share a batch: the kernels release the GIL and solve each pose alone, so the
result does not depend on the number of workers.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from dhkin.errors import InputError

#: A batch is shared among worker threads (the kernels release the GIL) only when each gets at
#: least this many poses: starting a slice costs ~30 us, the work of a few poses; each pose is
#: solved alone, so the result does not depend on the number of workers.
POSES_PER_WORKER = 512


#: Slices per worker thread of a shared batch (see :func:`_in_slices`).
SLICES_PER_WORKER = 4


def default_workers() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def check_workers(workers: Any) -> int:
    """``workers`` as a positive int (None: :func:`default_workers`); IKInputError otherwise."""
    if workers is None:
        return default_workers()
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise InputError(f"workers: expected a positive integer or None (the CPUs this "
                         f"process may use), got {workers!r}", field="workers")
    return int(workers)


def _in_slices(n: int, workers: int, work: Callable[[int, int], None]) -> None:
    """work(a, b) over contiguous slices of range(n), each of at least POSES_PER_WORKER poses,
    SLICES_PER_WORKER per worker thread (poses near singularities or on refined tables take
    longer: small slices keep the threads busy alike); one slice, in this thread, for a small n
    or one worker."""
    threads = max(1, min(workers, n // POSES_PER_WORKER))
    if threads == 1:
        work(0, n)
        return
    slices = max(threads, min(threads * SLICES_PER_WORKER, n // POSES_PER_WORKER))
    bounds = [n * k // slices for k in range(slices + 1)]
    futures = [_pool(threads).submit(work, bounds[k], bounds[k + 1]) for k in range(slices)]
    for future in futures:
        future.result()


_POOL: dict[int, ThreadPoolExecutor] = {}
_POOL_LOCK = threading.Lock()


def _pool(size: int) -> ThreadPoolExecutor:
    """A shared pool of ``size`` threads for batch slices (created on first use)."""
    with _POOL_LOCK:
        if size not in _POOL:
            _POOL[size] = ThreadPoolExecutor(max_workers=size, thread_name_prefix="dhkin-ik")
        return _POOL[size]
