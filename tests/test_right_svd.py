"""The core's 6 x 6 SVD by one-sided Jacobi (cpp/dhkin/right_svd.hpp) against LAPACK's.

The general 6R solver's singular roots and curves of solutions are told apart by the smallest
singular value of the scaled Jacobian and walked along its right singular vectors; these come
from ``right_svd``. Checked against numpy's SVD (LAPACK) and on Pinocchio's Jacobians at
singular joint values: singular values to the rounding of the matrix (``ROUNDING`` times
eps |A|_2, the bound of any backward-stable SVD), V orthogonal to the rounding, the products
A V those of the matrix, and the exact answers of exact cases (zero columns, diagonal
matrices, values 1e300 apart).
"""

from __future__ import annotations

import numpy as np

import dhkin
from dhkin import _core
from dhkin.reference import Reference

EPS = np.finfo(float).eps
#: Rounding allowance in units of eps |A|_2: a backward-stable SVD is exact for a matrix within
#: c eps |A| of A (Weyl: each singular value moves at most that much), c growing as the square
#: root of the ~100 plane rotations of a 6 x 6 Jacobi SVD. Measured on the 10^4 matrices below:
#: values 8.3, V^T V 15 (LAPACK's own V: 10), A V 4.8.
ROUNDING = 16.0


def _random_matrices(count: int, seed: int) -> np.ndarray:
    """Random 6 x 6 matrices, a third of full rank, a third with one column a combination of two
    others plus 1e-12 of a third, a third with two such near-dependent columns (1e-15, 1e-9)."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(count, 6, 6))
    one = np.arange(count) % 3 == 1
    two = np.arange(count) % 3 == 2
    A[one, :, 5] = 0.5 * A[one, :, 4] - 2.0 * A[one, :, 1] + 1e-12 * A[one, :, 3]
    A[two, :, 5] = 0.5 * A[two, :, 4] + 1e-15 * A[two, :, 3]
    A[two, :, 2] = 2.0 * A[two, :, 1] + 1e-9 * A[two, :, 0]
    return A


def _svds(A: np.ndarray, starts: np.ndarray | None = None):
    """_core.right_svd of each matrix (from each start where given): values (N, 6), V and AV
    (N, 6, 6)."""
    out = [_core.right_svd(matrix) if starts is None else _core.right_svd(matrix, start)
           for matrix, start in zip(A, A if starts is None else starts, strict=True)]
    return tuple(np.stack([np.asarray(part[k]) for part in out]) for k in range(3))


def _worst(excess: np.ndarray) -> str:
    """Where a check fails: the matrix with the largest excess over its allowance."""
    flat = excess.reshape(len(excess), -1).max(axis=1)
    return f"matrix {int(np.argmax(flat))} exceeds its allowance by {flat.max():.3g}"


def test_singular_values_and_vectors_agree_with_lapack_to_the_rounding():
    A = _random_matrices(10_000, seed=31)
    values, V, AV = _svds(A)
    reference = np.linalg.svd(A, compute_uv=False)  # LAPACK, matrix by matrix
    scale = reference[:, :1]
    assert np.all(np.diff(values, axis=1) <= 0.0)
    excess = np.abs(values - reference) - ROUNDING * EPS * scale
    assert np.all(excess <= 0.0), _worst(excess)
    excess = np.abs(np.swapaxes(V, 1, 2) @ V - np.eye(6)) - ROUNDING * EPS
    assert np.all(excess <= 0.0), _worst(excess)
    excess = np.abs(AV - A @ V) - ROUNDING * EPS * scale[:, :, None]
    assert np.all(excess <= 0.0), _worst(excess)
    excess = np.abs(np.linalg.norm(AV, axis=1) - values) - 4 * EPS * np.abs(values)
    assert np.all(excess <= 0.0), _worst(excess)


def test_a_warm_start_from_a_nearby_matrix_gives_the_same_svd():
    """Started from the right singular vectors of a matrix a step away (as settle_across does
    from one Newton step to the next), the SVD is the same to the rounding: V carries the
    start's own departure from orthogonality, so twice the allowance."""
    A = _random_matrices(3_000, seed=33)
    rng = np.random.default_rng(34)
    _, starts, _ = _svds(A)
    sizes = np.tile([1e-1, 1e-3, 1e-8], 1_000)
    moved = A + sizes[:, None, None] * rng.normal(size=A.shape)
    values, V, AV = _svds(moved, starts)
    reference = np.linalg.svd(moved, compute_uv=False)
    scale = reference[:, :1]
    excess = np.abs(values - reference) - ROUNDING * EPS * scale
    assert np.all(excess <= 0.0), _worst(excess)
    excess = np.abs(np.swapaxes(V, 1, 2) @ V - np.eye(6)) - 2 * ROUNDING * EPS
    assert np.all(excess <= 0.0), _worst(excess)
    excess = np.abs(AV - moved @ V) - ROUNDING * EPS * scale[:, :, None]
    assert np.all(excess <= 0.0), _worst(excess)


def test_the_null_space_of_pinocchios_jacobian_at_singular_joint_values():
    """UR5 (Pinocchio on its generated URDF) at two q5 = 0 poses (one with the elbow stretched)
    and at (0, -90, 0, 90, 0, 90) deg, where its Jacobian has three null directions: the right
    singular vectors of the values at the rounding span LAPACK's null space (fixed to eps / gap,
    the gap to the next singular value)."""
    reference_model = Reference(dhkin.load("ur5").urdf(), tip="tool0")
    null_dimensions = []
    for q in ([0.3, -1.2, 0.8, -0.4, 0.0, 0.7], [1.0, -0.5, 0.0, 0.2, 0.0, -2.0],
              [0.0, -np.pi / 2, 0.0, np.pi / 2, 0.0, np.pi / 2]):
        J = reference_model.jacobian(q)
        values, V, _ = _core.right_svd(J)
        _, reference, Vt = np.linalg.svd(J)
        rounding = ROUNDING * EPS * reference[0]
        null = int(np.sum(reference <= rounding))
        null_dimensions.append(null)
        assert np.sum(values <= rounding) == null
        gap = reference[-null - 1]
        ours = V[:, 6 - null:] @ V[:, 6 - null:].T
        lapack = Vt[6 - null:].T @ Vt[6 - null:]
        assert np.abs(ours - lapack).max() <= ROUNDING * EPS * reference[0] / gap
        assert np.linalg.norm(J @ V[:, 6 - null:], axis=0).max() <= rounding
    assert null_dimensions == [1, 1, 3]


def test_exact_cases():
    zero_values, zero_V, zero_AV = _core.right_svd(np.zeros((6, 6)))
    assert np.array_equal(zero_values, np.zeros(6))
    assert np.array_equal(zero_V, np.eye(6)) and np.array_equal(zero_AV, np.zeros((6, 6)))
    for diagonal, order in (([3e290, 1e300, 0.0, 1e295, 2e290, 1e160], [1, 3, 0, 4, 5, 2]),
                            ([3e-300, 1e-300, 0.0, 5e-324, 2e-310, 2e-300], [0, 5, 1, 4, 3, 2])):
        values, V, AV = _core.right_svd(np.diag(diagonal))
        assert np.array_equal(values, np.array(diagonal)[order])
        assert np.array_equal(np.abs(V), np.eye(6)[:, order])
        assert np.array_equal(np.abs(AV), np.diag(diagonal)[:, order])
    # a held joint: its column zeroed, its value 0 with that joint's unit vector
    rng = np.random.default_rng(32)
    held = rng.normal(size=(6, 6))
    held[:, 3] = 0.0
    values, V, _ = _core.right_svd(held)
    assert values[-1] == 0.0
    assert np.array_equal(np.abs(V[:, -1]), np.eye(6)[3])
