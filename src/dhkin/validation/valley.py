"""Whether a near-root of the multistart reference is tied to a returned solution along the
valley of near-solutions between them (see :mod:`dhkin.validation.multistart`).

A near-root is a point where Newton stalls inside the tolerance without converging: the floor of
a valley of near-solutions, such as a rounded target leaves where it breaks a curve of solutions
into nearly singular roots (the xArm6's validate sample 10510, docs/general6r.md). The straight
chord between it and the root the IK returned on the same valley can leave the tolerance where
the valley bends; the walk here follows the valley instead: a segment is tied when its quarter
points verify (the chord rule of :func:`~dhkin.validation.multistart.missing_roots`), else its
midpoint is projected back onto the valley's floor (Gauss-Newton on the reference description
across every direction but the weakest one, the valley's own) and, if that point verifies, both
halves are tied in turn. Every point judged verifies on the reference description (the oracle);
the projection only proposes points.

Joint values are URDF joint values (rad, chain order); poses are base_link -> tool0, metres.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dhkin.transforms import pose_error
from dhkin.validation.references import TargetModel

#: Joint step (rad) of the central differences that give the projection's Jacobian: their
#: truncation (step^2 x the third derivative, ~1e-12 of a unit pose) and rounding
#: (1e-16 / step = 1e-10 relative) both leave the Gauss-Newton direction exact to far better
#: than the tolerance needs (the projection only proposes points: the oracle judges them).
DIFFERENCE_STEP = 1e-6

#: Gauss-Newton steps of one projection at most; it stops earlier once the error stops falling
#: (a step is kept only while it lowers the error: the floor of the valley, at the arithmetic).
PROJECTION_STEPS = 8

#: A projected midpoint may move off the chord's midpoint by at most this fraction of the
#: segment (max joint difference): each half is then at most 3/4 of its segment, so the walk
#: shortens; a larger move means the valley does not follow this chord, and the walk fails.
PROJECTION_REACH = 0.25

#: Projected points of one walk at most (its cost bound): a valley that needs more, bending at
#: a finer scale than 1/1024 of the way, is not followed, and the walk fails (the strict side:
#: the near-root is then reported, never dropped).
WALK_POINTS = 1024


def _error(model: TargetModel, T: NDArray[np.float64],
           q: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, 6) pose errors of the rows q on the reference: the target's position minus the
    point's (m), and the rotation vector taking the point's orientation to the target's (rad,
    base axes)."""
    # imported here: scipy costs `import dhkin` ~0.25 s (scripts/cold_start.py), and only a
    # near-root's walk needs it
    from scipy.spatial.transform import Rotation

    pose = model.fk(q)
    position = T[:3, 3] - pose[..., :3, 3]
    rotation = Rotation.from_matrix(T[:3, :3] @ np.swapaxes(pose[..., :3, :3], -1, -2))
    return np.hstack([position, rotation.as_rotvec()])


def project(model: TargetModel, T: NDArray[np.float64],
            q: NDArray[np.float64]) -> NDArray[np.float64]:
    """q moved onto the floor of its valley: Gauss-Newton steps on the pose error across the
    five strongest directions of its Jacobian (central differences on the reference), the
    weakest (the valley's) left alone, while the error falls."""
    dof = len(q)
    offsets = DIFFERENCE_STEP * np.eye(dof)
    current = _error(model, T, q[None])[0]
    for _ in range(PROJECTION_STEPS):
        around = _error(model, T, np.vstack([q + offsets, q - offsets]))
        jacobian = ((around[:dof] - around[dof:]) / (2.0 * DIFFERENCE_STEP)).T  # d error / d q
        u, s, vt = np.linalg.svd(jacobian)
        strong = len(s) - 1
        step = -vt[:strong].T @ ((u[:, :strong].T @ current) / s[:strong])
        moved = q + step
        error = _error(model, T, moved[None])[0]
        if np.linalg.norm(error) >= np.linalg.norm(current):
            break
        q, current = moved, error
    return q


def verifies(model: TargetModel, T: NDArray[np.float64], points: NDArray[np.float64],
             allowed: float) -> bool:
    """Whether every row of ``points`` (n, dof) reaches the pose T on the reference within
    ``allowed`` (m and rad)."""
    position, rotation = pose_error(model.fk(points), np.broadcast_to(T, (len(points), 4, 4)))
    return bool(np.all(position <= allowed) and np.all(rotation <= allowed))


def chord_verifies(model: TargetModel, T: NDArray[np.float64], start: NDArray[np.float64],
                   step: NDArray[np.float64], allowed: float) -> bool:
    """The chord rule: whether the points a quarter, a half and three quarters of the way from
    ``start`` along ``step`` (to the other end) all verify (:func:`verifies`)."""
    return verifies(model, T, start + np.outer([0.25, 0.5, 0.75], step), allowed)


def tied_along_valley(model: TargetModel, T: NDArray[np.float64], start: NDArray[np.float64],
                      end: NDArray[np.float64], allowed: float,
                      joint_tolerance: float) -> bool:
    """Whether a walk from ``start`` to ``end`` (both verifying at ``allowed``; ``end`` the
    2pi copy nearest ``start``) stays within ``allowed`` on the reference: each segment's
    quarter points verify, or its midpoint projected onto the valley verifies (within
    :data:`PROJECTION_REACH` of the segment of the chord's midpoint) and both halves are tied.
    Segments no longer than ``joint_tolerance`` are tied (their ends verify and are one point
    by the validator's joint tolerance); at most :data:`WALK_POINTS` projections."""
    pending = [(start, end)]
    projections = 0
    while pending:
        a, b = pending.pop()
        length = float(np.abs(b - a).max())
        if length <= joint_tolerance:
            continue
        if chord_verifies(model, T, a, b - a, allowed):
            continue
        projections += 1
        if projections > WALK_POINTS:
            return False
        middle = 0.5 * (a + b)
        projected = project(model, T, middle)
        if (np.abs(projected - middle).max() > PROJECTION_REACH * length
                or not verifies(model, T, projected[None], allowed)):
            return False
        pending += [(a, projected), (projected, b)]
    return True
