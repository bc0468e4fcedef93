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

from dhkin.ik.compiled.chain import (
    MAX_JOINT_STEP,
    SEED_DAMPING,
    _jacobian,
    check,
    fk_frames,
    refine,
)
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


#: Refinement budget (chain evaluations) per candidate, and the growth Newton may take.
BUDGET = 120
GROWTH = 1e6


#: Refinement budget of a candidate from a near-real complex pair of eigenvalues: a real root
#: of the chain that the model's rounding or its fold made complex lies within the imaginary
#: band (0.1 rad) of the start and converges in a few Newton steps (at a double root linearly,
#: halving per step: from 1e-8 to 1e-12 within ~15); a truly complex one never converges, and
#: the full budget spent on it was most of the refinement's time (0.8 such per pose on the
#: CRX-10iA and xArm6).
PAIR_BUDGET = 40


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
def _wrap(x: float) -> float:
    return -((-x + math.pi) % (2.0 * math.pi) - math.pi)


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


@jit
def smallest_singular(chain: NDArray[np.float64], q: NDArray[np.float64], lever: float,
                      band: float) -> float:
    """The smallest singular value of the exact chain's Jacobian at q, its linear rows divided
    by ``lever`` (m per rad of a point of the arm; rad and m/lever then weigh alike), where it
    is at most ``band``; above it a lower bound may come back instead: |det J| / |J|_F^5 <=
    sigma_min (the other five singular values are at most |J|_F), and the SVD (~20 times the
    cost) runs only where that bound is at most ``band``."""
    frames = np.empty((7, 12))
    fk_frames(chain, q, frames)
    J = np.empty((6, 6))
    _jacobian(chain, frames, J)
    size = 0.0
    for r in range(6):
        for c in range(6):
            if r < 3:
                J[r, c] /= lever
            size += J[r, c] * J[r, c]
    bound = abs(np.linalg.det(J)) / size ** 2.5 if size > 0.0 else 0.0
    if bound > band:
        return bound
    return float(np.linalg.svd(J)[1][5])


@jit
def settle(chain: NDArray[np.float64], T_dh: NDArray[np.float64], starts: NDArray[np.float64],
           n_starts: int, seeded: int, tolerance: float, lever: float, band: float,
           ill_conditioned: bool, paired: int, roots: NDArray[np.float64],
           errors: NDArray[np.float64], sigmas: NDArray[np.float64]) -> tuple[int, int]:
    """Refine every start on the exact chain, keep those that verify, merge those that are
    one root (close, and their midpoint verifies). The start at index ``seeded`` (the seed)
    is used on a singular pose (no candidate verified, a root is singular, sigma <= ``band``,
    or the eigenproblem is ``ill_conditioned``) and, as on the families' refined tables
    (docs/ik_core.md), where the seed is within one maximal Newton step of the pose (rotation
    error at most MAX_JOINT_STEP, position error at most MAX_JOINT_STEP x ``lever``); a seed
    farther from a regular pose is not a start. A seed starts damped, and its root, when it
    merges with a root found before, replaces it if nearer the seed (on a curve of solutions,
    the seed's member). Starts from ``paired`` to ``seeded`` (near-real complex pairs of
    eigenvalues) get PAIR_BUDGET. Returns (roots found, candidates that did not verify); sigmas:
    :func:`smallest_singular` of each root (``lever``, ``band``)."""
    target = np.ascontiguousarray(T_dh[:3])
    fixed = np.zeros(6, np.bool_)
    state = np.empty(12)
    q = np.empty(6)
    middle = np.empty(6)
    found, failed = 0, 0
    for index in range(n_starts):
        if index == seeded and found > 0 and not ill_conditioned:
            singular = False
            for other in range(found):
                singular = singular or sigmas[other] <= band
            for j in range(6):
                q[j] = starts[index, j]
            position, rotation = check(chain, q, target, state)
            near = rotation <= MAX_JOINT_STEP and position <= MAX_JOINT_STEP * lever
            if not (singular or near):
                break
        for j in range(6):
            q[j] = starts[index, j]
        damping = SEED_DAMPING if index >= seeded else 0.0
        budget = PAIR_BUDGET if paired <= index < seeded else BUDGET
        refine(chain, target, q, fixed, tolerance, budget, GROWTH, damping)
        position, rotation = check(chain, q, target, state)
        if not (position <= tolerance and rotation <= tolerance):
            if index < seeded:
                failed += 1
            continue
        for j in range(6):
            q[j] = _wrap(q[j])
        duplicate = -1
        for other in range(found):
            largest = 0.0
            for j in range(6):
                middle[j] = _wrap(q[j] - roots[other, j])
                largest = max(largest, abs(middle[j]))
            if largest > MAX_JOINT_STEP:
                continue
            for j in range(6):
                middle[j] = roots[other, j] + 0.5 * middle[j]
            p2, r2 = check(chain, middle, target, state)
            if p2 <= tolerance and r2 <= tolerance:
                duplicate = other
                break
        slot = found
        if duplicate >= 0:
            if index < seeded:
                continue
            mine, theirs = 0.0, 0.0
            for j in range(6):
                mine += _wrap(q[j] - starts[index, j]) ** 2
                theirs += _wrap(roots[duplicate, j] - starts[index, j]) ** 2
            if mine >= theirs:
                continue
            slot = duplicate
        for j in range(6):
            roots[slot, j] = q[j]
        errors[slot, 0], errors[slot, 1] = position, rotation
        sigmas[slot] = smallest_singular(chain, q, lever, band)
        if slot == found:
            found += 1
    return found, failed


@jit
def nearest_copies(chain: NDArray[np.float64], T: NDArray[np.float64],
                   roots: NDArray[np.float64], errors: NDArray[np.float64], found: int,
                   reference: NDArray[np.float64], lower: NDArray[np.float64],
                   upper: NDArray[np.float64], slack: float, tolerance: float,
                   out_q: NDArray[np.float64], out_errors: NDArray[np.float64],
                   kept: NDArray[np.int64]) -> int:
    """Per root, per joint its 2pi copy nearest ``reference`` within the limits widened by
    ``slack`` (a value that far outside a limit counts as on it: set onto it and verified
    again on ``chain`` against T (3 or 4 rows) at ``tolerance``, as in the families); roots
    without such a copy, or that no longer verify, are left out. Writes the kept rows in
    order into out_q, out_errors and their root indices into kept; returns their number."""
    two_pi = 2.0 * math.pi
    target = np.ascontiguousarray(T[:3])
    state = np.empty(12)
    q = np.empty(6)
    count = 0
    for k in range(found):
        inside, moved = True, False
        for j in range(6):
            value = roots[k, j] + two_pi * np.rint((reference[j] - roots[k, j]) / two_pi)
            if value < lower[j] - slack:
                value += two_pi * math.ceil((lower[j] - slack - value) / two_pi)
            if value > upper[j] + slack:
                value -= two_pi * math.ceil((value - upper[j] - slack) / two_pi)
            if value < lower[j] - slack or value > upper[j] + slack:
                inside = False
                break
            if value < lower[j]:
                value, moved = lower[j], True
            elif value > upper[j]:
                value, moved = upper[j], True
            q[j] = value
        if not inside:
            continue
        position, rotation = errors[k, 0], errors[k, 1]
        if moved:
            position, rotation = check(chain, q, target, state)
            if not (position <= tolerance and rotation <= tolerance):
                continue
        for j in range(6):
            out_q[count, j] = q[j]
        out_errors[count, 0], out_errors[count, 1] = position, rotation
        kept[count] = k
        count += 1
    return count


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
