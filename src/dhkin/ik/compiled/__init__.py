"""Compiled (numba) kernels of the general 6R solver (:mod:`dhkin.ik.general6r`), until it moves
into the C++ core (``dhkin._core``, which holds the closed-form families).

Modules (each one job): :mod:`.jit` (compile options), :mod:`.layout` (named offsets of the
constant vectors passed to kernels), :mod:`.elementary` (sin, cos, atan2), :mod:`.chain` (FK,
Jacobian and damped Newton refinement on the exact chain), :mod:`.pose` (input poses: checks and
projection onto a rotation), :mod:`.general6r` and :mod:`.general6r_roots` (the general 6R
solver's candidates and roots).

Cache: :mod:`.cache` chooses where numba caches the kernels (the package's ``__pycache__``, else
a user or temporary folder, else none: a read-only install still works) and guards the cache
against stale helpers; it runs when this package is imported, before any kernel is decorated.
"""

from __future__ import annotations

from dhkin.ik.compiled.cache import prepare

prepare()
