"""Compile options shared by every kernel."""

from __future__ import annotations

from numba import njit

#: Cached on disk, IEEE division (no ZeroDivisionError checks), GIL released.
jit = njit(cache=True, error_model="numpy", nogil=True)
#: The same, allowing a * b + c to contract into one fused multiply-add (more accurate, not
#: less); nothing else of fast-math. Used by the elementary functions.
jit_fma = njit(cache=True, error_model="numpy", nogil=True, fastmath={"contract"})
