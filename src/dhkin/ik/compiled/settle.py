"""Step 3 of the pipeline for one candidate: wrap it, refine it on the exact chain (Newton, then
continuation where that fails) or polish an exact table's candidate, and measure its errors.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled import chain as exact
from dhkin.ik.compiled import continuation
from dhkin.ik.compiled.copies import wrap
from dhkin.ik.compiled.jit import jit
from dhkin.ik.compiled.plan import LONG_SHOT_BUDGET, PLAN, POLISH_BUDGET, _any, model_path


@jit
def _settle(plan: NDArray[np.float64], chain: NDArray[np.float64], T: NDArray[np.float64],
            values: NDArray[np.float64], fixed: NDArray[np.bool_], clamped: bool,
            long_shot: bool, tolerance: float, state: NDArray[np.float64],
            polish: bool = True) -> tuple[float, float]:
    """Wrap a candidate's revolute values, refine it on the exact chain if the plan says so
    (joints marked ``fixed`` keep their value; a candidate that is an exact solution of the
    ideal model, not ``clamped``, is followed by continuation where Newton fails), or polish it
    by Newton where an exact table's candidate does not verify; return its (position, rotation)
    errors."""
    n = values.shape[0]
    for j in range(n):
        if chain[j, exact.JOINT.revolute] != 0.0:
            values[j] = wrap(values[j])
    if plan[PLAN.refine] != 0.0:
        start = values.copy()
        budget = LONG_SHOT_BUDGET if long_shot else 4 * exact.MAX_STEPS
        position, rotation = exact.refine(chain, T, values, fixed, tolerance, budget,
                                          exact.GROWTH, 0.0)
        if _any(fixed) and not exact.within(position, rotation, tolerance):
            # the exact chain is not singular here (its singular set is shifted, or a
            # calibration leaves none): the seed's choice of the free joint is not exact, so
            # release it from where it got to (the caller sees ``fixed`` cleared)
            for j in range(n):
                fixed[j] = False
            # a monotone descent first: it stays in the basin of the root nearest the seed's
            # member, where Newton's first step can jump along the near-singular direction to
            # a far root (an exact chain a hair from a spherical wrist has a root at q5 ~ 0
            # beside the two the ideal model gives)
            held = values.copy()
            position, rotation = exact.refine(chain, T, values, fixed, tolerance, budget, 1.0,
                                              0.0)
            if not exact.within(position, rotation, tolerance):
                for j in range(n):
                    values[j] = held[j]
                position, rotation = exact.refine(chain, T, values, fixed, tolerance, budget,
                                                  exact.GROWTH, 0.0)
        if not clamped and not exact.within(position, rotation, tolerance):  # follow the branch
            ideal, path = model_path(plan)
            for j in range(n):
                values[j] = start[j]
            continuation.refine_along(ideal, chain, path, T, values, fixed, tolerance,
                                      np.empty_like(chain))
        elif clamped and not exact.within(position, rotation, tolerance):
            # a target a hair beyond a fold: its least-squares point may verify
            exact.refine(chain, T, values, fixed, tolerance, POLISH_BUDGET, 1.0, 0.0)
        for j in range(n):
            if chain[j, exact.JOINT.revolute] != 0.0:
                values[j] = wrap(values[j])
        return exact.check(chain, values, T, state)
    position, rotation = exact.check(chain, values, T, state)
    if not exact.within(position, rotation, tolerance) and polish:
        # a clamped or near-singular candidate of an exact table: the closed form's point is
        # not the best one the chain reaches; Newton's is, and verification decides (a seeded
        # candidate keeps its seeded joints; see solve_branches for when it is polished)
        exact.refine(chain, T, values, fixed, tolerance, POLISH_BUDGET, exact.GROWTH,
                     0.0)
        position, rotation = exact.check(chain, values, T, state)
        if clamped and not exact.within(position, rotation, tolerance):
            # clamped onto a fold: J is singular there. A target a hair beyond it: Newton
            # oscillates along the fold's weak direction, a monotone descent reaches the
            # least-squares point, which may verify; a target a hair inside it: the roots lie a
            # hair off the fold
            exact.refine(chain, T, values, fixed, tolerance, POLISH_BUDGET, 1.0, 0.0)
            position, rotation = exact.check(chain, values, T, state)
            if not exact.within(position, rotation, tolerance):
                position, rotation = continuation.off_fold(chain, T, values, fixed, tolerance,
                                                           POLISH_BUDGET)
        for j in range(n):
            if chain[j, exact.JOINT.revolute] != 0.0:
                values[j] = wrap(values[j])
        position, rotation = exact.check(chain, values, T, state)
    return position, rotation


@jit
def _settle_free(plan: NDArray[np.float64], chain: NDArray[np.float64], T: NDArray[np.float64],
                 start: NDArray[np.float64], candidate: NDArray[np.float64],
                 fixed: NDArray[np.bool_], clamped: bool, long_shot: bool,
                 tolerance: float, state: NDArray[np.float64]) -> tuple[float, float]:
    """:func:`_settle` of ``start`` copied into ``candidate`` with every joint free."""
    for j in range(start.shape[0]):
        candidate[j] = start[j]
        fixed[j] = False
    return _settle(plan, chain, T, candidate, fixed, clamped, long_shot, tolerance, state,
                   True)
