"""Inputs of the closed-form IK checked before the kernels see them (an InputError names the field),
and joint-value helpers (wrapping, turns).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import DHTable
from dhkin.errors import InputError

TWO_PI = 2.0 * math.pi


def check_tolerance(tolerance: Any) -> float:
    """``tolerance`` as a float; InputError unless it is a positive finite number."""
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float, np.floating,
                                                                 np.integer)):
        raise InputError(f"tolerance: expected a positive finite number (m and rad), got "
                         f"{tolerance!r}", field="tolerance")
    try:
        value = float(tolerance)
    except OverflowError:  # an int beyond any float
        value = math.inf
    if not (math.isfinite(value) and value > 0.0):
        raise InputError(f"tolerance: expected a positive finite number (m and rad), got "
                         f"{tolerance!r}", field="tolerance")
    return value


def check_flag(value: Any, field: str) -> bool:
    """``value`` as a bool; InputError unless it is one (a string such as "no" would read as
    True)."""
    if not isinstance(value, (bool, np.bool_)):
        raise InputError(field=field, value=value, expected="True or False")
    return bool(value)


def as_targets(T: ArrayLike) -> tuple[NDArray[np.float64], bool]:
    """Poses (4, 4) or (N, 4, 4) as C-contiguous float64 (N, 4, 4) and whether one was given."""
    try:
        targets = np.ascontiguousarray(T, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"T: expected a (4, 4) pose or (N, 4, 4) poses of numbers ({exc})"
                         , field="T") from exc
    single = targets.ndim == 2
    if single:
        targets = targets[None]
    if targets.ndim != 3 or targets.shape[1:] != (4, 4):
        raise InputError(field="T", value=np.shape(T),
                         expected="a (4, 4) pose or (N, 4, 4) poses")
    return targets, single


def pose_error_message(name: str, T: NDArray[np.float64], status: int) -> str:
    """The error message for a pose the kernels rejected with ``status``."""
    from dhkin.ik import core

    if status == core.STATUS_NOT_FINITE:
        return f"{name}: expected finite numbers, got NaN or inf"
    if status == core.STATUS_BOTTOM_ROW:
        return (f"{name}: bottom row is {T[3].tolist()}, expected [0, 0, 0, 1] (within "
                f"{core.BOTTOM_ROW_TOLERANCE:g})")
    R = T[:3, :3]
    orthonormality = float(np.abs(R @ R.T - np.eye(3)).max())
    return (f"{name}: rotation block is not a rotation (|R R^T - I| = {orthonormality:.2e}, "
            f"det = {np.linalg.det(R):.3g}); expected |R R^T - I| <= "
            f"{core.ORTHONORMALITY_GATE:g} and det > 0 (a rotation rounded to a few digits)")


def wrap_revolute(table: DHTable, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Revolute joint values wrapped to (-pi, pi]; prismatic values unchanged."""
    revolute = np.array([j.is_revolute for j in table.joints])
    wrapped = np.pi - np.mod(np.pi - q, TWO_PI)
    return np.where(revolute, wrapped, q)


def turns_of(table: DHTable, q: NDArray[np.float64]) -> NDArray[np.int64]:
    """round(q / 2pi) for revolute joints, 0 for prismatic ones; shape of q."""
    revolute = np.array([j.is_revolute for j in table.joints])
    return np.where(revolute, np.round(q / TWO_PI), 0).astype(np.int64)


def check_integer(value: Any, field: str, minimum: int = 0) -> int:
    """``value`` as an int; InputError naming ``field`` unless it is an integer (not a bool,
    not a float such as 2.5 or 1e3) of at least ``minimum``: counts (``minimum`` 1), random
    seeds (0: numpy refuses negative seeds)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or value < minimum:
        expected = {0: "a non-negative integer", 1: "a positive integer"}.get(
            minimum, f"an integer >= {minimum}")
        raise InputError(field=field, value=value, expected=expected)
    return int(value)


def _check_chunk(chunk_size: Any) -> int:
    return check_integer(chunk_size, "chunk_size", 1)
