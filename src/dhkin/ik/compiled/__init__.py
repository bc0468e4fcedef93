"""Compiled (numba) kernels of the closed-form IK: one implementation of each family's math, of
forward kinematics on the exact chain, of the refinement and of the 2pi copies.

Modules (each one job): :mod:`.jit` (compile options), :mod:`.layout` (named offsets of the
constant vectors passed to kernels), :mod:`.elementary` (sin, cos, atan2), :mod:`.chain` (FK,
Jacobian and damped Newton refinement on the exact chain), :mod:`.pose` (input poses: checks and
projection onto a rotation), :mod:`.spherical` and :mod:`.offset` (the family solvers),
:mod:`.copies` (wrap and 2pi copies), :mod:`.continuation` (beyond Newton: continuation from the
ideal model, searches off a fold), :mod:`.pipeline` (one pose, start to end; batches are that
function in a loop) and its steps: :mod:`.plan` (the solver's constants), :mod:`.settle` (one
candidate refined and verified), :mod:`.members` (singular families), :mod:`.roots` (a refined
table's extra roots), :mod:`.expand` (2pi copies of the answers); :mod:`.direct` (the pipeline's
answer for a regular pose, with a fraction of its code: tried first, and compiled without the rest).

Cache guard: numba's on-disk cache (``cache=True``) checks only the source file of the function
it compiled, so a kernel calling a helper from another module of this package would keep a stale
copy of that helper after an edit. :func:`_guard_cache` hashes every module of the package and,
when the hash differs from the one stored beside the cache, deletes the package's cache files
before anything is compiled or loaded. Where the cache folder cannot be written, nothing is
deleted (numba then compiles in memory).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

#: File beside numba's cache files recording the hash of the sources they were compiled from.
STAMP_NAME = "dhkin-kernels.sha256"


def source_hash(folder: Path) -> str:
    """SHA-256 of the names and contents of every ``*.py`` file in ``folder``, sorted by name."""
    digest = hashlib.sha256()
    for path in sorted(folder.glob("*.py")):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _guard_cache(folder: Path) -> None:
    """Delete this package's numba cache files when its sources changed since they were made."""
    cache = folder / "__pycache__"
    stamp = cache / STAMP_NAME
    current = source_hash(folder)
    try:
        if stamp.is_file() and stamp.read_text(encoding="ascii").strip() == current:
            return
        if cache.is_dir():
            for pattern in ("*.nbi", "*.nbc"):
                for path in cache.glob(pattern):
                    path.unlink(missing_ok=True)
        cache.mkdir(exist_ok=True)
        stamp.write_text(current + "\n", encoding="ascii")
    except OSError:  # read-only install: leave the cache as it is
        return


_guard_cache(Path(__file__).resolve().parent)
