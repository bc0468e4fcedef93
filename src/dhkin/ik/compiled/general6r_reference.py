"""An independent reference for the roots of a six-revolute chain, compiled: Newton's method on
the exact chain from many fixed starts, no elimination (the validator's and the acceptance
script's check that the general 6R solver misses no root; docs/general6r.md, "Checking
completeness").

Joint values are URDF joint values (rad); ``chain`` is the exact chain to the point verified in
the layout of :func:`dhkin.ik.plan.chain_array`; the target is that point's pose in DH frame 0
(3 or 4 rows, metres).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.chain import MAX_JOINT_STEP, MAX_STEPS, check, refine
from dhkin.ik.compiled.jit import jit

#: Chain evaluations one start may spend: Newton's full budget (a random start needs up to
#: MAX_STEPS steps, some of them retried with more damping).
START_BUDGET = 4 * MAX_STEPS


#: Growth of the error a Newton step may take on its way (as the solver's refinement allows).
GROWTH = 1e6


@jit
def _wrap(x: float) -> float:
    return -((-x + math.pi) % (2.0 * math.pi) - math.pi)


@jit
def multistart(chain: NDArray[np.float64], T: NDArray[np.float64],
               starts: NDArray[np.float64], tolerance: float, patience: int,
               roots: NDArray[np.float64]) -> int:
    """Newton from every row of ``starts`` (k, 6) towards the target T; the distinct joint
    vectors (wrapped to (-pi, pi]) that verify at ``tolerance`` into the rows of roots (at most
    its length); returns their number. The starts stop early once ``patience`` of them in a
    row found no new root. Two are one root when they lie within MAX_JOINT_STEP of
    each other and their midpoint verifies too (the solver's merging rule). Each root is then
    polished by monotone Newton steps as far as the arithmetic allows: an isolated root does
    not move, but a point that verified in the cloud around a singular root (within
    ~sqrt(residual) of it along the weak direction, where the residual grows quadratically)
    moves onto the singular set, so that its Jacobian says what it is."""
    target = np.ascontiguousarray(T[:3])
    fixed = np.zeros(6, np.bool_)
    state = np.empty(12)
    q = np.empty(6)
    middle = np.empty(6)
    found = 0
    last_new = 0
    for index in range(starts.shape[0]):
        if index - last_new >= patience:
            break
        for j in range(6):
            q[j] = starts[index, j]
        refine(chain, target, q, fixed, tolerance, START_BUDGET, GROWTH, 0.0)
        position, rotation = check(chain, q, target, state)
        if not (position <= tolerance and rotation <= tolerance):
            continue
        for j in range(6):
            q[j] = _wrap(q[j])
        known = False
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
                known = True
                break
        if known or found >= roots.shape[0]:
            continue
        for j in range(6):
            roots[found, j] = q[j]
        found += 1
        last_new = index
    for index in range(found):
        for j in range(6):
            q[j] = roots[index, j]
        refine(chain, target, q, fixed, 0.0, START_BUDGET, 1.0, 0.0)
        for j in range(6):
            roots[index, j] = _wrap(q[j])
    return found
