"""Joint values: wrapping and the 2pi-shifted copies inside the joint limits.

A revolute joint's value q and q + 2pi k reach the same pose; the limits decide which copies
exist. A value that lies within ``slack`` outside a limit counts as on it: it is set onto the
limit (and the solution is verified again by the caller). Prismatic joints have one value.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.jit import jit

TWO_PI = 2.0 * math.pi
_INVERSE_TWO_PI = 1.0 / TWO_PI


@jit
def wrap(value: float) -> float:
    """value wrapped to (-pi, pi]."""
    if -math.pi < value <= math.pi:
        return value
    r = np.fmod(math.pi - value, TWO_PI)
    if r < 0.0:
        r += TWO_PI
    wrapped = math.pi - r
    return wrapped + TWO_PI if wrapped <= -math.pi else wrapped  # -pi itself belongs to pi


@jit
def turn_range(lower: float, upper: float, revolute: bool, value: float,
               slack: float) -> tuple[int, int]:
    """(first turn, number of copies): the copies value + 2pi (first + k), k < number, inside
    [lower - slack, upper + slack]; a prismatic value has one copy (turn 0) when inside."""
    if revolute:
        lo = math.ceil((lower - slack - value) * _INVERSE_TWO_PI)
        hi = math.floor((upper + slack - value) * _INVERSE_TWO_PI)
        return lo, max(hi - lo + 1, 0)
    inside = lower - slack <= value <= upper + slack
    return 0, 1 if inside else 0


@jit
def nearest_turn(lower: float, upper: float, revolute: bool, value: float, slack: float,
                 aim: float) -> tuple[int, bool]:
    """(turn k, exists): the in-limit copy value + 2pi k nearest to ``aim`` (the seed's value of
    this joint), or exists False when the value has no in-limit copy."""
    first, count = turn_range(lower, upper, revolute, value, slack)
    if count == 0:
        return 0, False
    if not revolute:
        return 0, True
    wanted = round((aim - value) * _INVERSE_TWO_PI)
    return min(max(wanted, first), first + count - 1), True


@jit
def placed(lower: float, upper: float, revolute: bool, value: float, turn: int) -> float:
    """value + 2pi turn (revolute), set onto the nearer limit when it lies outside."""
    shifted = value + TWO_PI * turn if revolute else value
    return min(max(shifted, lower), upper)


@jit
def turns_of(revolute: NDArray[np.bool_], q: NDArray[np.float64]) -> NDArray[np.int64]:
    """round(q / 2pi) per revolute joint, 0 for prismatic ones, for q (..., n)."""
    flat = q.reshape(-1, q.shape[-1])
    out = np.zeros(flat.shape, np.int64)
    for i in range(flat.shape[0]):
        for j in range(flat.shape[1]):
            if revolute[j]:
                out[i, j] = round(flat[i, j] * _INVERSE_TWO_PI)
    return out.reshape(q.shape)
