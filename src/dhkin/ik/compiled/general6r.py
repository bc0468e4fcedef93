"""The general 6R solver's per-pose work, compiled: elimination, eigenvalues, back-substitution,
Newton on the exact chain, merging (the math is documented in :mod:`dhkin.ik.general6r`,
:mod:`dhkin.ik.general6r_elimination` and :mod:`dhkin.ik.general6r_model`).

The eigenproblem is LAPACK's dgeev (through numba's own binding to scipy's LAPACK) on the
companion matrix [[0, I], [-A^-1 C, -A^-1 B]] (24 x 24). Its leading matrix A = M at
theta_k = shift + pi must be invertible: of the four angles shift + {0, 1, 2, 3} pi/2 the one
whose matrix is best conditioned becomes theta_k = that + pi (x3 -> infinity), so that no root
lies at infinity unless all four are roots. Eigenvalues shared by several roots are split
into one start per root (:mod:`dhkin.ik.compiled.general6r_null`); where no leading matrix is
well conditioned, the pose is solved slightly moved, twice (:func:`all_candidates`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.np.linalg import _LAPACK, ensure_lapack
from numpy.typing import NDArray

from dhkin.ik.compiled.general6r_back import back_substitute, rigid_inverse
from dhkin.ik.compiled.general6r_null import MAX_SPLIT, null_space, null_vector, split
from dhkin.ik.compiled.general6r_qz import pencil_eigenvalues
from dhkin.ik.compiled.general6r_roots import MOVED, PAIRED, SHARED, nearest_copies, settle
from dhkin.ik.compiled.jit import jit
from dhkin.ik.compiled.pose import project, status

ensure_lapack()
_rgeev = _LAPACK().numba_ez_rgeev(types.float64)

#: Layout of the ``setup`` vector: shift, k, reversed, scale, imaginary band.
SHIFT, K, REVERSED, SCALE, BAND = 0, 1, 2, 3, 4


#: The leading matrix is accepted when its reciprocal condition (1-norm) is at least this: the
#: eigenvalues then lose at most ~1e-8 relative to rounding, well within Newton's basin.
LEAD_CONDITION = 1e-8


#: Eigenvalues of the eliminated joint whose angles (rad, real parts) lie closer than this
#: are one cluster, split at each member into as many starts as the cluster has members
#: (:func:`candidates`). Taking two eigenvalues together costs starts, never roots (each
#: member's own null vector is in its split: the exact eigenvector of the shift operators);
#: taking apart the copies of an eigenvalue shared by two roots loses one. Rounding spreads
#: such copies by ~eps / (the leading matrix's condition) ~2e-8 at LEAD_CONDITION (a
#: defective double eigenvalue, a fold, by ~its square root, 1.5e-4, but there one vector
#: is the root's); a complex pair within it is such a shared real eigenvalue, split by
#: rounding. Each member is split at its own value, not at the cluster's mean: two roots
#: whose eliminated joints differ by 1e-7 rad and whose monomial vectors are nearly
#: parallel (a CRX-10iA pose near q5 = 0, roots 8e-3 rad apart) are exact at their own
#: members, mixed at the mean.
CLUSTER = 1e-3


#: Most starts one elimination gives: 24 eigenvalues, each in a cluster split MAX_SPLIT ways.
MAX_PER_POSE = 24 * MAX_SPLIT


#: Most candidates one pose can give: its own, the moved pose's and the fallback starts of
#: :func:`all_candidates` (at most FALLBACK_STARTS, :mod:`dhkin.ik.general6r_moves`).
MAX_CANDIDATES = 2 * MAX_PER_POSE + 32


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
               dggev: object, solve_ill: bool, T_dh: NDArray[np.float64],
               out: NDArray[np.float64], origin: NDArray[np.int64],
               info: NDArray[np.float64]) -> int:
    """Joint values of every root the eigenproblem of the target T_dh (4, 4), DH frame 0 ->
    DH frame 6 of the exact chain, holds, into the rows of out; returns their number (at most
    out's rows). The eigenvalues come from dgeev on the companion matrix where the leading
    matrix is well conditioned, else (``solve_ill``; none without it) from QZ on the pencil
    (``dggev``: :data:`dhkin.ik.compiled.general6r_qz.DGGEV`).
    origin[i]: bits of where row i comes from: PAIRED, a complex pair of eigenvalues (its
    imaginary angle beyond CLUSTER, within the band); SHARED, a cluster of eigenvalues (its
    root's fold partner is probed, :func:`dhkin.ik.compiled.general6r_roots.settle`).
    info[0]: the reciprocal condition (1-norm) of the leading matrix used (below
    LEAD_CONDITION: no angle gave a well-conditioned one, the pose's eigenproblem is
    ill-conditioned; NaN: the pose's quantities are not finite, no candidate). info[1]: 1
    where a cluster holds more than MAX_SPLIT eigenvalues (a curve of solutions with all its
    members at one value of the eliminated joint: a defective multiple eigenvalue whose
    computed copies scatter by eps^(1 / order), ~1e-3 at order 12 on the CRX-10iA, and whose
    null space holds the curve's vectors besides the roots'), else 0.

    Near-real eigenvalues (angle's imaginary part within the band) whose angles lie within
    CLUSTER of each other are one cluster of m: at each distinct member the m-dimensional
    null space of M is split into one monomial vector per root
    (:func:`dhkin.ik.compiled.general6r_null.split`; m = 1: inverse iteration), and each
    vector's joints are back-substituted
    (:func:`dhkin.ik.compiled.general6r_back.back_substitute`)."""
    shift, k, reverse = setup[SHIFT], int(setup[K]), setup[REVERSED] != 0.0
    target = rigid_inverse(T_dh) if reverse else T_dh
    H = D0_inverse @ target @ E_inverse
    for r in range(3):
        H[r, 3] /= setup[SCALE]
    values = np.empty((9, 14))
    for s in range(9):
        _quantities(before[s] @ H @ after[s], values[s])
    for s in range(9):
        for c in range(14):
            if not abs(values[s, c]) < math.inf:
                info[0] = math.nan
                return 0
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
    info[1] = 0.0
    # B and C of M(x) = A x^2 + B x + C with theta_k = lead + 2 atan(x)
    cs, sn = math.cos(lead), math.sin(lead)
    W = (Ps * cs - Pc * sn) @ half2
    Bm = np.zeros((12, 12))
    Bm[:6, :9] = 2.0 * W
    Bm[6:, 3:] = 2.0 * W
    C = _sigma(Pc, Ps, P1, lead, half2)
    wr, wi = np.empty(24), np.empty(24)
    if best >= LEAD_CONDITION:
        AC, AB = A_inverse @ C, A_inverse @ Bm
        # companion, stored column-major (LAPACK): work[j, i] = K[i, j]
        work = np.zeros((24, 24))
        for i in range(12):
            work[12 + i, i] = 1.0
            for j in range(12):
                work[j, 12 + i] = -AC[i, j]
                work[12 + j, 12 + i] = -AB[i, j]
        vl = np.empty((1, 24))
        vr = np.empty((1, 24))  # not computed: eigenvalues only (null vectors below)
        status = _rgeev(ord("d"), ord("N"), ord("N"), 24, work.ctypes, 24, wr.ctypes,
                        wi.ctypes, vl.ctypes, 24, vr.ctypes, 24)
        if status != 0:
            return 0
    else:
        if not solve_ill:
            return 0
        left = np.zeros((24, 24))
        right = np.eye(24)
        for i in range(12):
            left[i, 12 + i] = 1.0
            for j in range(12):
                left[12 + i, j] = -C[i, j]
                left[12 + i, 12 + j] = -Bm[i, j]
                right[12 + i, 12 + j] = A[i, j]
        if not pencil_eigenvalues(dggev, left, right, wr, wi):
            return 0
    # near-real eigenvalues as angles (real, imaginary part), sorted by the real part
    real = np.empty(24)
    imaginary = np.empty(24)
    kept = 0
    for index in range(24):
        x = complex(wr[index], wi[index])
        # x = infinity is theta_k = lead + pi (only QZ gives it: the leading matrix is
        # singular there); beyond 1e150 the angle is pi to the last bit
        angle = complex(math.pi, 0.0) if abs(x) > 1e150 else 2.0 * np.arctan(x)
        if not (abs(angle.imag) <= setup[BAND]):
            continue
        if not (abs(angle.real) < math.inf):
            continue
        if wi[index] < 0.0 and abs(angle.imag) > CLUSTER:
            continue  # a pair's second member gives the same real part
        position = kept
        while position > 0 and real[position - 1] > angle.real:
            real[position], imaginary[position] = real[position - 1], imaginary[position - 1]
            position -= 1
        real[position], imaginary[position] = angle.real, angle.imag
        kept += 1
    Qpinv = np.zeros((8, 14))
    for i in range(rank):
        for c in range(14):
            for rr in range(8):
                Qpinv[rr, c] += Vt[i, rr] * U[c, i] / sv[i]
    vectors = np.empty((MAX_SPLIT, 12))
    V = np.empty((12, MAX_SPLIT))
    count = 0
    first = 0
    while first < kept:
        last = first + 1
        while last < kept and real[last] - real[last - 1] < CLUSTER:
            last += 1
        m = min(last - first, MAX_SPLIT)
        if last - first > MAX_SPLIT:
            info[1] = 1.0  # more roots at one value than a split separates: a curve
        for member in range(first, last):
            if member > first and real[member] == real[member - 1]:
                continue  # the two members of a pair: one null space
            angle = real[member]
            half = 0.5 * angle
            if m == 1:
                if not null_vector(A, Bm, C, half, vectors[0]):
                    continue
            else:
                basis = np.ascontiguousarray(V[:, :m])
                if not null_space(A, Bm, C, half, m, basis):
                    continue
                split(basis, vectors[:m])
            for v in range(m):
                if count >= out.shape[0]:
                    return count
                back_substitute(P, Q, rank, Qpinv, r_vec, rows, phi, direction, offset, k,
                                reverse, H, lead + angle, vectors[v], out[count])
                origin[count] = ((PAIRED if abs(imaginary[member]) > CLUSTER else 0)
                                 | (SHARED if m > 1 else 0))
                count += 1
        first = last
    return count


@jit
def all_candidates(P: NDArray[np.float64], before: NDArray[np.float64],
                   after: NDArray[np.float64], inv_right: NDArray[np.float64],
                   mix: NDArray[np.float64], half2: NDArray[np.float64],
                   rows: NDArray[np.float64], phi: NDArray[np.float64],
                   D0_inverse: NDArray[np.float64], E_inverse: NDArray[np.float64],
                   setup: NDArray[np.float64], direction: NDArray[np.float64],
                   offset: NDArray[np.float64], perturbations: NDArray[np.float64],
                   fallback: NDArray[np.float64], dggev: object, T_dh: NDArray[np.float64],
                   out: NDArray[np.float64],
                   origin: NDArray[np.int64], info: NDArray[np.float64]) -> int:
    """:func:`candidates` of T_dh; where its eigenproblem is ill-conditioned (info[0] below
    LEAD_CONDITION: the matrix polynomial is singular, or nearly, at this pose) instead, and
    where an eigenvalue is degenerate (a curve of solutions at one value of the eliminated
    joint) as well, those of the poses ``perturbations[p] @ T_dh`` (small rigid motions in
    DH frame 0, :func:`dhkin.ik.general6r.perturbations`), whose eigenproblems are regular
    (solved by QZ where still ill-conditioned) with simple eigenvalues: every real root of a
    moved pose is among its eigenvalues, and
    every regular root of T_dh lies near one of them, within Newton's reach
    (docs/general6r.md, "Every root"). info[0]: the leading matrix's reciprocal condition at
    T_dh; info[1]: 1 where the moved poses were used, else 0. The starts of moved pose p have
    origin bit MOVED << p (their root is followed back to T_dh where Newton does not reach it
    at once, :func:`dhkin.ik.compiled.general6r_track.track`). With the moved poses, the
    ``fallback`` starts (fixed joint vectors, :data:`dhkin.ik.general6r_moves.FALLBACK_STARTS`)
    are starts too: near a highly degenerate singular set (a stretched arm with a free wrist)
    a moved pose's own eigenproblem can lose the roots it has there."""
    count = candidates(P, before, after, inv_right, mix, half2, rows, phi, D0_inverse,
                       E_inverse, setup, direction, offset, dggev, False, T_dh, out, origin,
                       info)
    if math.isnan(info[0]):
        return count
    if info[0] >= LEAD_CONDITION and info[1] == 0.0:
        return count
    info[1] = 1.0
    inner = np.empty(2)
    for p in range(perturbations.shape[0]):
        moved = np.ascontiguousarray(perturbations[p]) @ T_dh
        first = count
        count += candidates(P, before, after, inv_right, mix, half2, rows, phi, D0_inverse,
                            E_inverse, setup, direction, offset, dggev, True, moved,
                            out[count:], origin[count:], inner)
        for index in range(first, count):
            origin[index] |= MOVED << p
    for index in range(fallback.shape[0]):
        if count >= out.shape[0]:
            break
        for j in range(6):
            out[count, j] = fallback[index, j]
        origin[count] = 0
        count += 1
    return count


@jit
def _safe_inverse(M: NDArray[np.float64]) -> NDArray[np.float64]:
    """M^-1, or infinities where M is exactly singular (its condition is then 0)."""
    try:
        return np.asarray(np.linalg.inv(M), dtype=np.float64)
    except Exception:
        return np.full((12, 12), np.inf)


#: Layout of :func:`solve_pose`'s ``info``: the pose's projection, candidates that did not
#: verify, roots found (where it returns SETTLED).
PROJECTION, FAILED, FOUND = 0, 1, 2


#: :func:`solve_pose`'s answers other than a row count: the Python path answers (an input to
#: reject, a pose out of reach); the roots are settled in the buffers but the Python path
#: finishes (a singular root: the seed's member; no root, or no copy within the limits: the
#: reason).
REJECT, SETTLED = -1, -2


@jit
def solve_pose(P: NDArray[np.float64], before: NDArray[np.float64],
               after: NDArray[np.float64], inv_right: NDArray[np.float64],
               mix: NDArray[np.float64], half2: NDArray[np.float64], rows: NDArray[np.float64],
               phi: NDArray[np.float64], D0_inverse: NDArray[np.float64],
               E_inverse: NDArray[np.float64], setup: NDArray[np.float64],
               direction: NDArray[np.float64], offset: NDArray[np.float64],
               perturbations: NDArray[np.float64], moves: NDArray[np.float64],
               fallback: NDArray[np.float64], dggev: object,
               base_inverse: NDArray[np.float64],
               tool_inverse: NDArray[np.float64], chain: NDArray[np.float64],
               T: NDArray[np.float64], seed: NDArray[np.float64], reach: float,
               tolerance: float, lever: float, band: float, lower: NDArray[np.float64],
               upper: NDArray[np.float64], slack: float, starts: NDArray[np.float64],
               origin: NDArray[np.int64], roots: NDArray[np.float64],
               errors: NDArray[np.float64], sigmas: NDArray[np.float64],
               out_q: NDArray[np.float64], out_errors: NDArray[np.float64],
               kept: NDArray[np.int64], info: NDArray[np.float64]) -> int:
    """The general solver's single call in one kernel, for the common case (the Python path,
    :meth:`dhkin.ik.general6r.General6RSolver._solve`, does the same in steps): the pose T
    (base_link -> tool0) checked (:func:`dhkin.ik.compiled.pose.status`) and projected, its
    DH frame 6 within ``reach`` of DH frame 0, its candidates (:func:`all_candidates`),
    refined, verified at ``tolerance`` (the verification tolerance) and merged
    (:func:`settle`), each root's in-limit copy nearest ``seed`` (:func:`nearest_copies`,
    ``slack``). Returns the number of rows written to out_q, out_errors (all regular), or
    REJECT where the Python path must answer (a pose or seed not usable: it raises the error;
    out of reach: the reason), or SETTLED where the roots, their residuals and sigmas are in
    roots, errors, sigmas (info[FOUND] of them) and the Python path finishes (a singular root:
    the seed's member of a curve of solutions; no root or no in-limit copy: the reason)."""
    for j in range(6):
        if not abs(seed[j]) < math.inf:
            return REJECT
    if status(T) != 0:
        return REJECT
    target = np.eye(4)
    info[PROJECTION] = project(T, target[:3])
    tip_target = base_inverse @ target
    T_dh = tip_target @ tool_inverse
    if not within_reach(T_dh, reach):
        return REJECT
    eigen = np.empty(2)
    count = all_candidates(P, before, after, inv_right, mix, half2, rows, phi, D0_inverse,
                           E_inverse, setup, direction, offset, perturbations, fallback, dggev,
                           T_dh, starts, origin, eigen)
    found, failed = settle(chain, tip_target, starts, origin, count, moves, tolerance, lever,
                           band, roots, errors, sigmas)
    info[FAILED], info[FOUND] = failed, found
    if found == 0:
        return SETTLED
    for k in range(found):
        if sigmas[k] <= band:
            return SETTLED
    count = nearest_copies(chain, tip_target, roots, errors, found, seed, lower, upper, slack,
                           tolerance, lever, np.zeros(found, np.bool_), band, out_q,
                           out_errors, kept)
    return count if count > 0 else SETTLED


@jit
def within_reach(T_dh: NDArray[np.float64], reach: float) -> bool:
    """Whether DH frame 6's origin (T_dh, DH frame 0 -> 6, metres) lies within ``reach`` of DH
    frame 0's: no chain of rigid links and rotations places it farther than the sum of its
    links' lengths (:attr:`dhkin.ik.general6r.General6RSolver.reach`). Checked by the largest
    coordinate first, so that a far pose (1e300 m) does not overflow."""
    largest = max(abs(T_dh[0, 3]), abs(T_dh[1, 3]), abs(T_dh[2, 3]))
    if not largest <= reach:
        return False
    return math.sqrt(T_dh[0, 3] ** 2 + T_dh[1, 3] ** 2 + T_dh[2, 3] ** 2) <= reach
