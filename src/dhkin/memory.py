"""How much memory this process can still be given, to size a large result before allocating it.

:func:`available_memory` is the smaller of what the system has available (Linux:
``MemAvailable`` of ``/proc/meminfo``, the memory it can give without swapping; elsewhere the
free physical pages ``os.sysconf`` reports) and what this process's address-space limit
(``ulimit -v``, ``RLIMIT_AS``) leaves above its present size. None where neither is known: then
nothing is checked, and a result too large still ends in MemoryError.
"""

from __future__ import annotations

import os
from pathlib import Path

MEMINFO = Path("/proc/meminfo")
STATM = Path("/proc/self/statm")


def available_memory() -> int | None:
    """Bytes this process can still allocate (module docstring), or None if unknown."""
    known = [value for value in (_system_available(), _limit_left()) if value is not None]
    return min(known) if known else None


def _system_available() -> int | None:
    try:
        for line in MEMINFO.read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def _limit_left() -> int | None:
    """RLIMIT_AS less the present virtual size, or None without a limit (or where unknown)."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft == resource.RLIM_INFINITY:
            return None
        size = int(STATM.read_text().split()[0]) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ImportError, OSError, ValueError, IndexError):
        return None
    return max(0, soft - size)
