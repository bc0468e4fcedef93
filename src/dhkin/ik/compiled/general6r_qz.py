"""LAPACK's QZ (dggev) for the general 6R solver's ill-conditioned eigenproblems, compiled.

Where no leading matrix of a pose's matrix polynomial is well conditioned (a pose moved off a
singular one, :func:`dhkin.ik.compiled.general6r.all_candidates`), the companion matrix
A^-1 [...] loses the eigenvalues to A's condition; QZ works on the pencil itself, backward
stable, and keeps the eigenvalues of its regular part.

numba binds no dggev of its own: :data:`DGGEV` is scipy's (scipy.linalg.cython_lapack), a
ctypes function that the kernels take as an argument (its address then stays a run-time value,
so that the kernels can be cached on disk).
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable

import numpy as np
from numba.extending import get_cython_function_address
from numpy.typing import NDArray

from dhkin.ik.compiled.jit import jit

_POINTER = ctypes.c_void_p

#: dggev(jobvl, jobvr, n, a, lda, b, ldb, alphar, alphai, beta, vl, ldvl, vr, ldvr, work,
#: lwork, info), every argument by address (Fortran).
DGGEV = ctypes.CFUNCTYPE(None, *([_POINTER] * 17))(
    get_cython_function_address("scipy.linalg.cython_lapack", "dggev"))


@jit
def pencil_eigenvalues(dggev: Callable[..., None], L: NDArray[np.float64], R: NDArray[np.float64],
                       real: NDArray[np.float64], imaginary: NDArray[np.float64]) -> bool:
    """The eigenvalues of the pencil L - x R (n x n, row-major; overwritten) into real,
    imaginary (n,): alpha / beta, an infinite one (beta = 0) as inf. False if LAPACK fails."""
    n = L.shape[0]
    a = np.asfortranarray(L)
    b = np.asfortranarray(R)
    job = np.array([ord("N")], np.uint8)
    size = np.array([n], np.int32)
    one = np.array([1], np.int32)
    alpha_real, alpha_imaginary, beta = np.empty(n), np.empty(n), np.empty(n)
    unused = np.empty(1)
    lwork = 8 * n + 16
    work = np.empty(lwork)
    work_size = np.array([lwork], np.int32)
    info = np.zeros(1, np.int32)
    dggev(job.ctypes, job.ctypes, size.ctypes, a.ctypes, size.ctypes, b.ctypes, size.ctypes,
          alpha_real.ctypes, alpha_imaginary.ctypes, beta.ctypes, unused.ctypes, one.ctypes,
          unused.ctypes, one.ctypes, work.ctypes, work_size.ctypes, info.ctypes)
    if info[0] != 0:
        return False
    for i in range(n):
        if beta[i] != 0.0:
            real[i], imaginary[i] = alpha_real[i] / beta[i], alpha_imaginary[i] / beta[i]
        else:
            real[i], imaginary[i] = np.inf, 0.0
    return True
