"""Raghavan-Roth elimination for a standard-DH 6R model: every candidate (theta_1..theta_6).

The model (:mod:`dhkin.ik.general6r_model`, lengths in units of its scale) must reach the target
``H`` (model frame 0 -> model frame 6): ``A_1 ... A_6 = H``. Written as

    A_3 A_4 A_5 = A_2^-1 A_1^-1 H A_6^-1,

the third and fourth columns of both sides (a direction l and a point p) do not depend on
theta_6 (A_6 = Rz(theta_6)). Of l and p, the fourteen scalar quantities p, l, p.p, p.l, p x l
and (p.p) l - 2 (p.l) p are, on each side, trigonometric polynomials of order one in each
angle (Raghavan and Roth, 1990): on the left P(theta_3) x45 with x45 the nine products of
(cos, sin, 1) of theta_4 and theta_5; on the right Q y12 + r with y12 the eight non-constant
products of (cos, sin, 1) of theta_1 and theta_2. The coefficients are not derived by hand:
both sides are evaluated at the 3 x 3 x 3 (left, once per model) and 3 x 3 (right, per pose)
angles {0, 2pi/3, 4pi/3}, where the order-one trigonometric basis is interpolated exactly.

Rows N with N Q = 0 eliminate y12: N P(theta_3) x45 = N r, six equations (more where Q is rank
deficient: a generic combination of them is kept). With the half-angle tangents x4, x5 and the
equations also multiplied by x4, the twelve monomials x4^i x5^j (i <= 3, j <= 2) satisfy
M(x3) m = 0, M = A x3^2 + B x3 + C (12 x 12), x3 = tan((theta_3 - shift) / 2). Its 24
eigenvalues (a generalised eigenproblem of the companion pencil, solved by LAPACK's QZ, so that
eigenvalues at infinity, theta_3 = shift + pi, stay finite angles) hold every solution's
theta_3; eight at x3 = +-i are spurious. The eigenvector gives theta_4, theta_5; the point and
direction equations give theta_2 (least squares on four equations linear in cos, sin theta_2)
and theta_1 (a planar rotation); the orientation gives theta_6.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.general6r_model import Model, dh_row

#: The interpolation angles of an order-one trigonometric polynomial: (cos, sin, 1) at these
#: three angles are independent.
SAMPLES = np.array([0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0])
_V = np.stack([np.cos(SAMPLES), np.sin(SAMPLES), np.ones(3)], axis=1)  # [t, basis]
_V_INV = np.linalg.inv(_V)
#: (cos, sin, 1) of a half-angle x, times (1 + x^2), as coefficients of (1, x, x^2).
_HALF = np.array([[1.0, 0.0, -1.0], [0.0, 2.0, 0.0], [1.0, 0.0, 1.0]])
_HALF2 = np.kron(_HALF, _HALF)
#: Null vectors of M(+-i) at every pose: the extraneous factor (1 + x^2)^4 of the determinant.
SPURIOUS_NULL = 4


def quantities(axis: NDArray[np.float64], p: NDArray[np.float64]) -> NDArray[np.float64]:
    """The 14 quantities of (l, p) (..., 3), l = ``axis``: p, l, p.p, p.l, p x l,
    (p.p) l - 2 (p.l) p."""
    l = axis  # noqa: E741
    pp = np.sum(p * p, axis=-1, keepdims=True)
    pl = np.sum(p * l, axis=-1, keepdims=True)
    return np.concatenate([p, l, pp, pl, np.cross(p, l), pp * l - 2.0 * pl * p], axis=-1)


def _inverse_row(theta: float, d: float, a: float, alpha: float) -> NDArray[np.float64]:
    """(Rz(theta) Tz(d) Tx(a) Rx(alpha))^-1, 4x4."""
    T = dh_row(theta, d, a, alpha)
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


class Elimination:
    """The elimination of one model with eliminated joint ``k`` (0-based, 0..2) and a shift.

    Arrangement: ``A_k A_k+1 A_k+2 = [A_k-1^-1 ... A_0^-1] H [A_5^-1 ... A_k+3^-1]``; the
    third and fourth columns of the right side do not depend on theta_k+3, so the right side
    holds two joint angles (``right_joints``), the left side three: theta_k (the eigenvalue)
    and theta_k+1, theta_k+2 (the eigenvector). k = 2 is Raghavan and Roth's arrangement; the
    others suit arms whose consecutive axes around joints 1 and 2 meet or are parallel, where
    that arrangement's matrix polynomial is singular for every x3 (its determinant vanishes
    identically). ``shift`` (rad): theta_k = shift + 2 atan(x3).
    """

    def __init__(self, model: Model, k: int, shift: float) -> None:
        self.model, self.k, self.shift = model, k, shift
        self.right_joints = [j for j in range(6) if j < k or j > k + 3]
        self.dropped = k + 3
        m = model
        self.rows = [(m.d[j], m.a[j], m.alpha[j]) for j in range(6)]
        values = np.empty((27, 14))
        index = 0
        for t3 in SAMPLES:
            for t4 in SAMPLES:
                for t5 in SAMPLES:
                    L = (dh_row(t3, *self.rows[k]) @ dh_row(t4, *self.rows[k + 1])
                         @ dh_row(t5, *self.rows[k + 2]))
                    values[index] = quantities(L[:3, 2], L[:3, 3])
                    index += 1
        G = np.kron(np.kron(_V_INV, _V_INV), _V_INV) @ values  # (27 basis, 14)
        #: P_c, P_s, P_1 (3, 14, 9): P(theta_k) = P_c cos + P_s sin + P_1; columns over the
        #: products of (cos, sin, 1) of theta_k+1 and theta_k+2 (index 3 b1 + b2).
        self.P = np.ascontiguousarray(G.reshape(3, 9, 14).transpose(0, 2, 1))
        rng = np.random.default_rng(20240616)
        self.mix = rng.standard_normal((6, 14))
        self._inv_right = np.kron(_V_INV, _V_INV)
        # the right side's factors at the sample angles (joint -> 3 inverse rows)
        self._inverses = {j: [_inverse_row(t, *self.rows[j]) for t in SAMPLES]
                          for j in self.right_joints}
        self._dropped_inverse = _inverse_row(0.0, *self.rows[self.dropped])

    def spurious_subspace(self) -> NDArray[np.float64]:
        """An orthonormal basis (24, 8) of the companion's real invariant subspace for its eight
        eigenvalues x = +-i, the same at every pose; (0, 8) where the table has not exactly four
        null vectors there (its 24 x 24 companion is then solved whole).

        At x = i, M(i) = 2 e^(-i shift') N S with S the stacked (P_c + i P_s) half2 (28 x 12; P_1
        and the pose's right side drop out with the factor 1 + x^2), so each null vector z = X +
        i Y of S gives the companion [[0, I], [-A^-1 C, -A^-1 B]] the eigenvector [z; i z] at
        x = i and its conjugate at -i, whatever the pose and the lead: real invariant subspace
        [[X, Y], [-Y, X]] (Raghavan and Roth's extraneous factor (1 + x^2)^4: four null
        vectors). Null singular values are at the rounding (<= 3e-15 of |S| ~ 15 on the
        built-in arms), the others at least 0.04 |S|: the cut at sqrt(eps) |S| separates them.
        """
        S_half = (self.P[0] + 1j * self.P[1]) @ _HALF2  # (14, 9)
        S = np.zeros((28, 12), dtype=complex)
        S[:14, :9] = S_half
        S[14:, 3:] = S_half
        _, s, vh = np.linalg.svd(S)
        null = int(np.sum(s <= s[0] * math.sqrt(np.finfo(float).eps)))
        if null != SPURIOUS_NULL:
            return np.zeros((0, 2 * SPURIOUS_NULL))
        Z = vh[-null:].conj().T  # (12, 4)
        X, Y = Z.real, Z.imag
        U = np.block([[X, Y], [-Y, X]])  # (24, 8)
        basis, _ = np.linalg.qr(U)
        return np.ascontiguousarray(basis)

    def right_side(self, H: NDArray[np.float64], samples: tuple[int, int]) -> NDArray[np.float64]:
        """The right side at the sample angles of its two joints (indices into SAMPLES)."""
        before = np.eye(4)
        after = np.eye(4)
        for joint, sample in zip(self.right_joints, samples, strict=True):
            if joint < self.k:
                before = self._inverses[joint][sample] @ before
            else:
                after = self._inverses[joint][sample] @ after
        # joints come ascending: each higher joint's inverse goes first (before: A_1^-1 A_0^-1;
        # after: A_5^-1 A_4^-1)
        return before @ H @ after @ self._dropped_inverse

    def sample_factors(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(before, after) (9, 4, 4): the right side at sample (a, b), index 3 a + b, is
        before @ H @ after (the dropped joint's inverse at angle 0 included in after)."""
        before = np.empty((9, 4, 4))
        after = np.empty((9, 4, 4))
        for a in range(3):
            for b in range(3):
                left, right = np.eye(4), np.eye(4)
                for joint, sample in zip(self.right_joints, (a, b), strict=True):
                    if joint < self.k:
                        left = self._inverses[joint][sample] @ left
                    else:
                        right = self._inverses[joint][sample] @ right
                before[3 * a + b] = left
                after[3 * a + b] = right @ self._dropped_inverse
        return before, after

    def right(self, H: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Q (14, 8) and r (14,) of the target H (model frame 0 -> 6, scaled lengths)."""
        values = np.empty((9, 14))
        for a in range(3):
            for b in range(3):
                R = self.right_side(H, (a, b))
                values[3 * a + b] = quantities(R[:3, 2], R[:3, 3])
        G = self._inv_right @ values
        return G[:8].T, G[8]

    def pencil(self, H: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        """A, B, C (12, 12) of M(x3) = A x3^2 + B x3 + C for target H, then Q, r, N."""
        Q, r = self.right(H)
        U, s, _ = np.linalg.svd(Q)
        rank = int(np.sum(s > s[0] * 1e-10)) if s[0] > 0 else 0
        N = U[:, rank:].T  # rows with N Q = 0
        if N.shape[0] > 6:
            N = self.mix[:, :N.shape[0]] @ N
        Pc, Ps, P1 = (N @ P for P in self.P)
        P1 = P1.copy()
        P1[:, 8] -= N @ r
        cs, sn = math.cos(self.shift), math.sin(self.shift)
        out = []
        for S in (P1 - Pc * cs - Ps * sn, 2.0 * (Ps * cs - Pc * sn), P1 + Pc * cs + Ps * sn):
            W = S @ _HALF2  # (6, 9): x4^i x5^j at 3 i + j
            M = np.zeros((12, 12))
            M[:6, :9] = W
            M[6:, 3:] = W
            out.append(M)
        return (*out, Q, r)
