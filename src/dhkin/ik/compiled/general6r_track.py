"""Following a root of a moved pose back to the pose itself, compiled (the general 6R solver's
ill-conditioned poses: :func:`dhkin.ik.compiled.general6r.all_candidates` solves the pose
moved by a small rigid motion; docs/general6r.md, "Every root").

A regular root of the pose lies within Newton's reach of the moved pose's root, and Newton
from there finds it at once. A singular one (a curve of solutions, a highly degenerate root)
need not: the moved pose's roots near it may lie ~e^(1 / k) away (e the motion, k the
degeneracy), beyond the basin of a Newton that converges slowly there. Those are followed along
the path of poses P(s) T, s = 1, 1/2, 1/4, ... 0, P(s) the motion scaled by s, by Newton at
each step from the previous one's root: the roots move continuously with s.

Joint values are URDF joint values (rad); ``chain`` is the exact chain; targets are 3 x 4
poses in DH frame 0 (metres); a motion ``move`` (6,) is a rotation vector (rad) and a
translation (m), applied on the left.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.chain import check, refine
from dhkin.ik.compiled.jit import jit

#: Halvings of the motion along the path before the last step to the pose itself: 2^-30 of a
#: motion of 1e-4 is ~1e-13, below any tolerance.
TRACK_STEPS = 30


#: Chain evaluations per step of the path (Newton from the previous step's root, which lies
#: close: a few steps).
STEP_BUDGET = 40


#: Growth of the error a Newton step may take (as in the solver's refinement).
GROWTH = 1e6


@jit
def moved_target(move: NDArray[np.float64], s: float, target: NDArray[np.float64],
                 out: NDArray[np.float64]) -> None:
    """out (3, 4) = P(s) target, P(s) the rotation by s times the rotation vector move[:3]
    and the translation s times move[3:]."""
    rx, ry, rz = s * move[0], s * move[1], s * move[2]
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    R = np.eye(3)
    if angle > 0.0:
        kx, ky, kz = rx / angle, ry / angle, rz / angle
        K = np.array([[0.0, -kz, ky], [kz, 0.0, -kx], [-ky, kx, 0.0]])
        R = R + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)
    for r in range(3):
        for c in range(4):
            value = 0.0
            for k in range(3):
                value += R[r, k] * target[k, c]
            out[r, c] = value + (s * move[3 + r] if c == 3 else 0.0)


@jit
def track(chain: NDArray[np.float64], target: NDArray[np.float64], q: NDArray[np.float64],
          move: NDArray[np.float64], goal: float, tolerance: float) -> bool:
    """q (in place), a start near a root of the moved pose P(1) target, followed along the
    path s = 1, 1/2, ..., 2^-TRACK_STEPS, 0 by Newton (``goal`` its tolerance) at each step;
    whether every step's root verified at ``tolerance`` (q is then a root of target)."""
    fixed = np.zeros(6, np.bool_)
    state = np.empty(12)
    moved = np.empty((3, 4))
    for step in range(TRACK_STEPS + 2):
        s = 0.0 if step > TRACK_STEPS else 0.5 ** step
        moved_target(move, s, target, moved)
        refine(chain, moved, q, fixed, goal, STEP_BUDGET, GROWTH, 0.0)
        position, rotation = check(chain, q, moved, state)
        if not (position <= tolerance and rotation <= tolerance):
            return False
    return True
