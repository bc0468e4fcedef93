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

Cache: :mod:`.cache` chooses where numba caches the kernels (the package's ``__pycache__``, else
a user or temporary folder, else none: a read-only install still works) and guards the cache
against stale helpers; it runs when this package is imported, before any kernel is decorated.
"""

from __future__ import annotations

from dhkin.ik.compiled.cache import prepare

prepare()
