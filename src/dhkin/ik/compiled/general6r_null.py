"""The monomial vectors of the general 6R elimination at one eigenvalue, compiled: the joints
theta_k+1, theta_k+2 of every root whose eliminated joint is that eigenvalue (the math is in
:mod:`dhkin.ik.general6r_elimination` and docs/general6r.md, "Every root").

At a root, ``M(x) m = 0`` with ``m`` (12,) the monomials ``x_a^i x_b^j`` (i <= 3, j <= 2, index
3 i + j) of the half-angle tangents of theta_k+1 (a) and theta_k+2 (b). Written
homogeneously, ``m_ij = c_a^(3-i) s_a^i c_b^(2-j) s_b^j`` with (c, s) the cosine and sine of
the half angle, so theta = pi (x infinite) is an ordinary vector. Where several roots share the
eigenvalue (at special angles: four roots of the CRX-10iA share theta_2 = 90 deg), the null
space of M(x) has one dimension per root, and any one null vector is a mixture of their
monomial vectors, the root of none: :func:`split` recovers each from the null space.

Monomial vectors have a shift structure: the rows with i >= 1 are (s_a / c_a) times the rows
with i <= 2 (one row lower), and likewise along j. So in a basis V (12, m) of the null space,
every root's coordinates c (V c = m) are an eigenvector of X = (R0 V)^+ (R1 V), R0 and R1 the
row selections (rotated by a half-angle delta, so that no root sits at X's infinity): exactly,
whatever else the basis holds (rounding's near-null directions, a second Jordan vector), as
long as R0 V has full column rank. Roots sharing theta_k+1 too share X's eigenvalue; the
eigenvectors of X + gamma Y (Y: the same along j) separate every pair for all but one gamma,
so of m (m - 1) / 2 + 1 distinct gammas the one whose eigenvalues lie farthest apart separates
them all.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.jit import jit

#: Largest null space split (:func:`split`): the eight rows j <= 1 of the shift along j must
#: hold m independent vectors. A larger cluster of equal eigenvalues is split in its eight
#: smallest directions (more than eight roots sharing one joint value is a curve of solutions).
MAX_SPLIT = 8


#: Half-angle rotations tried for the shift operators (:func:`_shift_operator`): a root makes
#: one rotation singular (its half angle at delta + pi / 2); with up to MAX_SPLIT roots,
#: MAX_SPLIT + 1 rotations spread over pi leave one at least pi / 18 (10 deg) from all of them.
ROTATIONS = MAX_SPLIT + 1


#: The gammas of :func:`split` are tried until the eigenvalues of X + gamma Y lie at least
#: this far apart relative to their size: an eigenvector is then accurate to about
#: eps / this (sqrt(eps), ~1.5e-8: a start well within Newton's reach).
SEPARATED = math.sqrt(2.220446049250313e-16)


@jit
def null_vector(A: NDArray[np.float64], B: NDArray[np.float64], C: NDArray[np.float64],
                half: float, out: NDArray[np.float64]) -> bool:
    """The null vector of M(x) = A x^2 + B x + C at x = tan(half) (a simple eigenvalue), by
    two steps of inverse iteration on the 12 x 12 matrix (one LU with partial pivoting,
    :func:`_lu`), into out (12,), up to scale. M is evaluated homogeneously, A s^2 + B s c +
    C c^2 (c, s the cosine and sine of ``half``: the same null vector; x = infinity is c = 0).
    Returns False if the iteration breaks down (not finite)."""
    M = np.empty((12, 12))
    _homogeneous(A, B, C, half, M)
    pivots = np.empty(12, np.int64)
    _lu(M, pivots)
    for i in range(12):
        out[i] = 1.0
    for _ in range(2):
        _lu_solve(M, pivots, out)
        size = 0.0
        for i in range(12):
            size = max(size, abs(out[i]))
        if not (size > 0.0 and size < math.inf):
            return False
        for i in range(12):
            out[i] /= size
    return True


@jit
def _homogeneous(A: NDArray[np.float64], B: NDArray[np.float64], C: NDArray[np.float64],
                 half: float, out: NDArray[np.float64]) -> None:
    """M at the half angle ``half``, homogeneously: A s^2 + B s c + C c^2 (c, s its cosine and
    sine), scaled so that its largest weight is one."""
    c, s = math.cos(half), math.sin(half)
    if abs(s) <= abs(c):
        t = s / c
        out[:, :] = A * (t * t) + B * t + C
    else:
        y = c / s
        out[:, :] = A + B * y + C * (y * y)


@jit
def null_space(A: NDArray[np.float64], B: NDArray[np.float64], C: NDArray[np.float64],
               half: float, m: int, out: NDArray[np.float64]) -> bool:
    """The m right singular vectors of M at the half angle ``half`` with the smallest singular
    values, into the columns of out (12, m): the null space of an eigenvalue shared by m roots
    (its computed copies lie within rounding of each other). False if M is not finite."""
    M = np.empty((12, 12))
    _homogeneous(A, B, C, half, M)
    for i in range(12):
        for j in range(12):
            if not abs(M[i, j]) < math.inf:
                return False
    _, _, Vt = np.linalg.svd(M)
    for c in range(m):
        for r in range(12):
            out[r, c] = Vt[12 - m + c, r]
    return True


@jit
def _shift_operator(V: NDArray[np.float64], along_b: bool) -> NDArray[np.float64]:
    """X (m, m) with X c = t c for the coordinates c of every monomial vector V c in the span
    of V (12, m), t = tan(half angle - delta) of joint a (``along_b`` False: rows i <= 2 and
    i >= 1) or joint b (rows j <= 1 and j >= 1), delta the first rotation of
    :data:`ROTATIONS` whose low rows R0 V have a reciprocal condition of at least
    :data:`SEPARATED` (X is then accurate to ~sqrt(eps)), else the best conditioned (see the
    module docstring)."""
    m = V.shape[1]
    n_rows = 8 if along_b else 9
    low = np.empty((n_rows, m))
    high = np.empty((n_rows, m))
    row = 0
    for i in range(4):
        for j in range(3):
            if along_b:
                if j <= 1:
                    low[row] = V[3 * i + j]
                    high[row] = V[3 * i + j + 1]
                    row += 1
            elif i <= 2:
                low[row] = V[3 * i + j]
                high[row] = V[3 * i + j + 3]
                row += 1
    best = -1.0
    result = np.zeros((m, m))
    for k in range(ROTATIONS):
        delta = k * math.pi / ROTATIONS
        cd, sd = math.cos(delta), math.sin(delta)
        R0 = np.ascontiguousarray(cd * low + sd * high)
        R1 = cd * high - sd * low
        U, sv, Wt = np.linalg.svd(R0)
        if not sv[0] > 0.0:
            continue
        score = sv[m - 1] / sv[0]
        if score > best:
            best = score
            # X = R0^+ R1 = W diag(1 / sv) U^T R1
            projected = np.ascontiguousarray(U[:, :m].T) @ R1
            for r in range(m):
                for c in range(m):
                    projected[r, c] /= sv[r] if sv[r] > 0.0 else 1.0
            result = np.ascontiguousarray(Wt.T) @ projected
        if score >= SEPARATED:
            break
    return result


@jit
def split(V: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    """The monomial vector of every root whose null vectors span V (12, m), m >= 2, into the
    rows of out (m, 12), each up to scale (see the module docstring): eigenvectors of
    X + gamma Y for the first gamma whose eigenvalues lie :data:`SEPARATED` apart, else the
    one among m (m - 1) / 2 + 1 whose eigenvalues are farthest apart.
    A complex eigenvector (a direction of V that is no real root) gives the real part of its
    vector, phase-aligned on its largest entry: a start that Newton may reject."""
    m = V.shape[1]
    X = _shift_operator(V, False)
    Y = _shift_operator(V, True)
    tries = m * (m - 1) // 2 + 1
    best = -1.0
    vectors = np.zeros((m, m), np.complex128)
    for k in range(tries):
        gamma = (k + 1) * (0.6180339887498949 if k % 2 == 0 else -0.6180339887498949)
        Z = (X + gamma * Y).astype(np.complex128)
        values, candidates = np.linalg.eig(Z)
        gap = math.inf
        size = 0.0
        for a in range(m):
            size = max(size, abs(values[a]))
            for b in range(a):
                gap = min(gap, abs(values[a] - values[b]))
        if gap > best:
            best = gap
            vectors[:, :] = candidates
        if gap >= SEPARATED * max(size, 1.0):
            break
    Vc = V.astype(np.complex128)
    for r in range(m):
        v = Vc @ np.ascontiguousarray(vectors[:, r])
        top = 0
        for i in range(12):
            if abs(v[i]) > abs(v[top]):
                top = i
        phase = np.conj(v[top]) / abs(v[top]) if abs(v[top]) > 0.0 else 1.0 + 0.0j
        for i in range(12):
            out[r, i] = (v[i] * phase).real


@jit
def ratio_angle(v: NDArray[np.float64], along_b: bool) -> float:
    """The angle of joint a (``along_b`` False) or b from a monomial vector v (12,), index
    3 i + j: 2 atan2(next, this) on the pair of consecutive monomials along that joint of
    largest size (homogeneous: right at x = infinity too)."""
    best, low, high = -1.0, 0.0, 1.0
    for i in range(4):
        for j in range(3):
            if along_b:
                if j == 2:
                    continue
                a, b = v[3 * i + j], v[3 * i + j + 1]
            else:
                if i == 3:
                    continue
                a, b = v[3 * i + j], v[3 * i + j + 3]
            size = a * a + b * b
            if size > best:
                best, low, high = size, a, b
    return 2.0 * math.atan2(high, low)


@jit
def _lu(M: NDArray[np.float64], pivots: NDArray[np.int64]) -> None:
    """LU factorisation with partial pivoting of the square M, in place (L unit lower, U
    upper; row i was swapped with pivots[i]). A pivot of exactly zero (M singular in the
    arithmetic: the eigenvalue exact) is replaced by rounding's size, eps |M|, as inverse
    iteration does, so that the solve below amplifies the null direction instead of
    failing."""
    n = M.shape[0]
    tiny = 0.0
    for i in range(n):
        for j in range(n):
            tiny = max(tiny, abs(M[i, j]))
    tiny = max(tiny * 2.220446049250313e-16, 1e-300)
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(M[i, k]) > abs(M[p, k]):
                p = i
        pivots[k] = p
        if p != k:
            for j in range(n):
                M[k, j], M[p, j] = M[p, j], M[k, j]
        if M[k, k] == 0.0:
            M[k, k] = tiny
        for i in range(k + 1, n):
            factor = M[i, k] / M[k, k]
            M[i, k] = factor
            for j in range(k + 1, n):
                M[i, j] -= factor * M[k, j]


@jit
def _lu_solve(LU: NDArray[np.float64], pivots: NDArray[np.int64], v: NDArray[np.float64]) -> None:
    """v <- M^-1 v from :func:`_lu`'s factors, in place."""
    n = LU.shape[0]
    for k in range(n):
        p = pivots[k]
        if p != k:
            v[k], v[p] = v[p], v[k]
    for i in range(n):
        for j in range(i):
            v[i] -= LU[i, j] * v[j]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            v[i] -= LU[i, j] * v[j]
        v[i] /= LU[i, i]
