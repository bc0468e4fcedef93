"""The general 6R solver's per-pose work, compiled: elimination, eigenvalues, back-substitution,
Newton on the exact chain, merging (the math is documented in :mod:`dhkin.ik.general6r`,
:mod:`dhkin.ik.general6r_elimination` and :mod:`dhkin.ik.general6r_model`).

The eigenproblem is LAPACK's dgeev (through numba's own binding to scipy's LAPACK) on the
companion matrix [[0, I], [-A^-1 C, -A^-1 B]] (24 x 24). Its leading matrix A = M at
theta_k = shift + pi must be invertible: of the four angles shift + {0, 1, 2, 3} pi/2 the one
whose matrix is best conditioned becomes theta_k = that + pi (x3 -> infinity), so that no root
lies at infinity unless all four are roots.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.np.linalg import _LAPACK, ensure_lapack
from numpy.typing import NDArray

from dhkin.ik.compiled.general6r_roots import nearest_copies, settle
from dhkin.ik.compiled.jit import jit
from dhkin.ik.compiled.pose import project, status

ensure_lapack()
_rgeev = _LAPACK().numba_ez_rgeev(types.float64)

#: Most candidates one pose can give: 24 eigenvalues and the seed.
MAX_CANDIDATES = 25


#: Layout of the ``setup`` vector: shift, k, reversed, scale, imaginary band.
SHIFT, K, REVERSED, SCALE, BAND = 0, 1, 2, 3, 4


#: The leading matrix is accepted when its reciprocal condition (1-norm) is at least this: the
#: eigenvalues then lose at most ~1e-8 relative to rounding, well within Newton's basin.
LEAD_CONDITION = 1e-8


@jit
def _dh(theta: float, d: float, a: float, alpha: float, out: NDArray[np.float64]) -> None:
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = ct, -st * ca, st * sa, a * ct
    out[1, 0], out[1, 1], out[1, 2], out[1, 3] = st, ct * ca, -ct * sa, a * st
    out[2, 0], out[2, 1], out[2, 2], out[2, 3] = 0.0, sa, ca, d
    out[3, 0], out[3, 1], out[3, 2], out[3, 3] = 0.0, 0.0, 0.0, 1.0


@jit
def _rigid_inverse(T: NDArray[np.float64]) -> NDArray[np.float64]:
    out = np.eye(4)
    for r in range(3):
        for c in range(3):
            out[r, c] = T[c, r]
        out[r, 3] = -(T[0, r] * T[0, 3] + T[1, r] * T[1, 3] + T[2, r] * T[2, 3])
    return out


@jit
def _quantities(R: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    """p, l, p.p, p.l, p x l, (p.p) l - 2 (p.l) p of l = R[:3, 2], p = R[:3, 3]."""
    l0, l1, l2 = R[0, 2], R[1, 2], R[2, 2]
    p0, p1, p2 = R[0, 3], R[1, 3], R[2, 3]
    pp = p0 * p0 + p1 * p1 + p2 * p2
    pl = p0 * l0 + p1 * l1 + p2 * l2
    out[0], out[1], out[2], out[3], out[4], out[5] = p0, p1, p2, l0, l1, l2
    out[6], out[7] = pp, pl
    out[8], out[9], out[10] = p1 * l2 - p2 * l1, p2 * l0 - p0 * l2, p0 * l1 - p1 * l0
    out[11] = pp * l0 - 2.0 * pl * p0
    out[12] = pp * l1 - 2.0 * pl * p1
    out[13] = pp * l2 - 2.0 * pl * p2


@jit
def _sigma(Pc: NDArray[np.float64], Ps: NDArray[np.float64], P1: NDArray[np.float64],
           angle: float, half2: NDArray[np.float64]) -> NDArray[np.float64]:
    """M at theta_k = angle (times 1 + x^2 dropped: its 12 x 12 matrix), from the 6 x 9 rows."""
    S = Pc * math.cos(angle) + Ps * math.sin(angle) + P1
    W = S @ half2
    M = np.zeros((12, 12))
    M[:6, :9] = W
    M[6:, 3:] = W
    return M


@jit
def candidates(P: NDArray[np.float64], before: NDArray[np.float64], after: NDArray[np.float64],
               inv_right: NDArray[np.float64], mix: NDArray[np.float64],
               half2: NDArray[np.float64], rows: NDArray[np.float64],
               phi: NDArray[np.float64], D0_inverse: NDArray[np.float64],
               E_inverse: NDArray[np.float64], setup: NDArray[np.float64],
               direction: NDArray[np.float64], offset: NDArray[np.float64],
               T_dh: NDArray[np.float64], out: NDArray[np.float64],
               info: NDArray[np.float64]) -> int:
    """Joint values of every near-real eigenvalue for the target T_dh (4, 4), DH frame 0 ->
    DH frame 6 of the exact chain, into out (MAX_CANDIDATES, 6); returns their number.
    info[0]: the reciprocal condition (1-norm) of the leading matrix used (below
    LEAD_CONDITION: no angle gave a well-conditioned one, the pose's eigenproblem is
    ill-conditioned); info[1]: how many candidates come from real eigenvalues (they come
    first; then one per near-real complex pair, whose two members share their real part)."""
    shift, k, reverse = setup[SHIFT], int(setup[K]), setup[REVERSED] != 0.0
    target = _rigid_inverse(T_dh) if reverse else T_dh
    H = D0_inverse @ target @ E_inverse
    for r in range(3):
        H[r, 3] /= setup[SCALE]
    values = np.empty((9, 14))
    for s in range(9):
        _quantities(before[s] @ H @ after[s], values[s])
    G = inv_right @ values
    Q = np.ascontiguousarray(G[:8].T)
    r_vec = G[8].copy()
    U, sv, Vt = np.linalg.svd(Q)
    rank = 0
    for i in range(8):
        if sv[i] > sv[0] * 1e-10:
            rank += 1
    N = np.ascontiguousarray(U[:, rank:].T)
    if N.shape[0] > 6:
        N = np.ascontiguousarray(mix[:, :N.shape[0]]) @ N
    Pc, Ps, P1 = N @ P[0], N @ P[1], N @ P[2]
    constant = N @ r_vec
    for i in range(6):
        P1[i, 8] -= constant[i]
    # leading matrix: the first of M at four angles conditioned within LEAD_CONDITION
    # (else the best of them)
    best, lead = -1.0, shift
    A = np.empty((12, 12))
    A_inverse = np.empty((12, 12))
    for quarter in range(4):
        angle = shift + quarter * 0.5 * math.pi
        M = _sigma(Pc, Ps, P1, angle + math.pi, half2)
        inverse = _safe_inverse(M)
        ratio = 1.0 / (np.abs(M).sum(axis=0).max() * np.abs(inverse).sum(axis=0).max())
        if ratio > best:
            best, lead = ratio, angle
            A[:, :], A_inverse[:, :] = M, inverse
        if ratio >= LEAD_CONDITION:
            break
    info[0] = best
    # B and C of M(x) = A x^2 + B x + C with theta_k = lead + 2 atan(x)
    cs, sn = math.cos(lead), math.sin(lead)
    W = (Ps * cs - Pc * sn) @ half2
    Bm = np.zeros((12, 12))
    Bm[:6, :9] = 2.0 * W
    Bm[6:, 3:] = 2.0 * W
    C = _sigma(Pc, Ps, P1, lead, half2)
    AC, AB = A_inverse @ C, A_inverse @ Bm
    # companion, stored column-major (LAPACK): work[j, i] = K[i, j]
    work = np.zeros((24, 24))
    for i in range(12):
        work[12 + i, i] = 1.0
        for j in range(12):
            work[j, 12 + i] = -AC[i, j]
            work[12 + j, 12 + i] = -AB[i, j]
    wr, wi = np.empty(24), np.empty(24)
    vl = np.empty((1, 24))
    vr = np.empty((1, 24))  # not computed: eigenvalues only (null vectors below)
    status = _rgeev(ord("d"), ord("N"), ord("N"), 24, work.ctypes, 24, wr.ctypes, wi.ctypes,
                    vl.ctypes, 24, vr.ctypes, 24)
    if status != 0:
        info[1] = 0
        return 0
    count = 0
    Qpinv = np.zeros((8, 14))
    for i in range(rank):
        for c in range(14):
            for rr in range(8):
                Qpinv[rr, c] += Vt[i, rr] * U[c, i] / sv[i]
    m = np.empty((4, 3))
    theta = np.empty(6)
    x45 = np.empty(9)
    T1 = np.empty((4, 4))
    real_count = 0
    for order in range(48):  # real eigenvalues first, then one of each complex pair
        index = order % 24
        if order == 24:
            real_count = count
        if (order < 24) != (wi[index] == 0.0) or wi[index] < 0.0:
            continue  # a pair's second member (wi < 0) gives the same real part
        x = complex(wr[index], wi[index])
        if abs(x) > 1e150:
            continue
        angle = 2.0 * np.arctan(x)
        if not (abs(angle.imag) <= setup[BAND]):
            continue
        theta_k = lead + angle.real
        if not _null_vector(A, Bm, C, 0.5 * angle.real, m):
            continue
        theta_1 = _ratio_angle(m, 0)
        theta_2 = _ratio_angle(m, 1)
        theta[k], theta[k + 1], theta[k + 2] = theta_k, theta_1, theta_2
        b0 = (math.cos(theta_k), math.sin(theta_k), 1.0)
        b1 = (math.cos(theta_1), math.sin(theta_1), 1.0)
        b2 = (math.cos(theta_2), math.sin(theta_2), 1.0)
        for i in range(3):
            for j in range(3):
                x45[3 * i + j] = b1[i] * b2[j]
        rhs = (P[0] * b0[0] + P[1] * b0[1] + P[2]) @ x45 - r_vec
        y = Qpinv @ rhs
        first, second = -1, -1
        for j in range(6):
            if j < k or j > k + 3:
                if first < 0:
                    first = j
                else:
                    second = j
        theta[first] = math.atan2(y[5], y[2])
        theta[second] = math.atan2(y[7], y[6])
        g = k + 3
        pre = np.eye(4)
        for j in range(g):
            _dh(theta[j], rows[j, 0], rows[j, 1], rows[j, 2], T1)
            pre = pre @ T1
        post = np.eye(4)
        for j in range(g + 1, 6):
            _dh(theta[j], rows[j, 0], rows[j, 1], rows[j, 2], T1)
            post = post @ T1
        A_g = _rigid_inverse(pre) @ H @ _rigid_inverse(post)
        theta[g] = math.atan2(A_g[1, 0], A_g[0, 0])
        for j in range(6):
            v = theta[j] - phi[j]
            if reverse:
                out[count, 5 - j] = (-v - offset[5 - j]) / direction[5 - j]
            else:
                out[count, j] = (v - offset[j]) / direction[j]
        count += 1
    info[1] = real_count
    return count


@jit
def _null_vector(A: NDArray[np.float64], B: NDArray[np.float64], C: NDArray[np.float64],
                 half: float, out: NDArray[np.float64]) -> bool:
    """The null vector of M(x) = A x^2 + B x + C at x = tan(half) (a real eigenvalue, or the
    real part of a near-real pair), by two steps of inverse iteration on the 12 x 12 matrix
    (one LU with partial pivoting, :func:`_lu`), into out (4, 3): the monomials x_a^i x_b^j up
    to scale. Where |x| > 1 the reversed polynomial A + B y + C y^2, y = 1 / x, is used (the
    same null vector; x = infinity is y = 0). Returns False if the iteration breaks down (not
    finite)."""
    c, s = math.cos(half), math.sin(half)
    if abs(s) <= abs(c):
        t = s / c
        M = A * (t * t) + B * t + C
    else:
        y = c / s
        M = A + B * y + C * (y * y)
    pivots = np.empty(12, np.int64)
    _lu(M, pivots)
    v = np.ones(12)
    for _ in range(2):
        _lu_solve(M, pivots, v)
        size = 0.0
        for i in range(12):
            size = max(size, abs(v[i]))
        if not (size > 0.0 and size < math.inf):
            return False
        for i in range(12):
            v[i] /= size
    for i in range(4):
        for j in range(3):
            out[i, j] = v[3 * i + j]
    return True


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


@jit
def _safe_inverse(M: NDArray[np.float64]) -> NDArray[np.float64]:
    """M^-1, or infinities where M is exactly singular (its condition is then 0)."""
    try:
        return np.asarray(np.linalg.inv(M), dtype=np.float64)
    except Exception:
        return np.full((12, 12), np.inf)


@jit
def _ratio_angle(m: NDArray[np.float64], axis: int) -> float:
    """2 atan2(next, this) on the pair of consecutive monomials along ``axis`` of largest
    size (m[i, j] ~ x_a^i x_b^j)."""
    best, a, b = -1.0, 0.0, 1.0
    if axis == 0:
        for i in range(3):
            for j in range(3):
                size = m[i, j] ** 2 + m[i + 1, j] ** 2
                if size > best:
                    best, a, b = size, m[i, j], m[i + 1, j]
    else:
        for i in range(4):
            for j in range(2):
                size = m[i, j] ** 2 + m[i, j + 1] ** 2
                if size > best:
                    best, a, b = size, m[i, j], m[i, j + 1]
    return 2.0 * math.atan2(b, a)


#: Layout of :func:`solve_pose`'s ``info``: the pose's projection, candidates that did not
#: verify.
PROJECTION, FAILED = 0, 1


@jit
def solve_pose(P: NDArray[np.float64], before: NDArray[np.float64],
               after: NDArray[np.float64], inv_right: NDArray[np.float64],
               mix: NDArray[np.float64], half2: NDArray[np.float64], rows: NDArray[np.float64],
               phi: NDArray[np.float64], D0_inverse: NDArray[np.float64],
               E_inverse: NDArray[np.float64], setup: NDArray[np.float64],
               direction: NDArray[np.float64], offset: NDArray[np.float64],
               base_inverse: NDArray[np.float64], tool_inverse: NDArray[np.float64],
               chain: NDArray[np.float64], T: NDArray[np.float64], seed: NDArray[np.float64],
               tolerance: float, lever: float, band: float, lower: NDArray[np.float64],
               upper: NDArray[np.float64], slack: float, starts: NDArray[np.float64],
               roots: NDArray[np.float64], errors: NDArray[np.float64],
               sigmas: NDArray[np.float64], out_q: NDArray[np.float64],
               out_errors: NDArray[np.float64], kept: NDArray[np.int64],
               info: NDArray[np.float64]) -> int:
    """The general solver's single call in one kernel, for the common case (the Python path,
    :meth:`dhkin.ik.general6r.General6RSolver._solve`, does the same in steps): the pose T
    (base_link -> tool0) checked (:func:`dhkin.ik.compiled.pose.status`) and projected, its
    candidates (:func:`candidates`), refined, verified at ``tolerance`` (the verification
    tolerance) and merged (:func:`settle`, ``seed`` the seed's start), each root's in-limit
    copy nearest ``seed`` (:func:`nearest_copies`, ``slack``). Returns the number of rows
    written to out_q, out_errors (all regular), or -1 where the Python path must answer: a
    pose or seed not usable (it raises the error), a singular root or an ill-conditioned
    eigenproblem (the seed's member of a curve of solutions), or no solution (the reason)."""
    for j in range(6):
        if not abs(seed[j]) < math.inf:
            return -1
    if status(T) != 0:
        return -1
    target = np.eye(4)
    info[PROJECTION] = project(T, target[:3])
    tip_target = base_inverse @ target
    T_dh = tip_target @ tool_inverse
    eigen = np.empty(2)
    count = candidates(P, before, after, inv_right, mix, half2, rows, phi, D0_inverse,
                       E_inverse, setup, direction, offset, T_dh, starts, eigen)
    ill_conditioned = not eigen[0] >= LEAD_CONDITION
    if ill_conditioned:
        return -1
    for j in range(6):
        starts[count, j] = seed[j]
    found, failed = settle(chain, tip_target, starts, count + 1, count, tolerance, lever, band,
                           False, int(eigen[1]), roots, errors, sigmas)
    info[FAILED] = failed
    if found == 0:
        return -1
    for k in range(found):
        if sigmas[k] <= band:
            return -1
    count = nearest_copies(chain, tip_target, roots, errors, found, seed, lower, upper, slack,
                           tolerance, out_q, out_errors, kept)
    return count if count > 0 else -1
