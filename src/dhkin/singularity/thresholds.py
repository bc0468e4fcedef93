"""Singularity kinds, their distances' units, the joint that moves onto each, and the thresholds
that call a configuration singular (see :mod:`dhkin.singularity.model` for what the distances
mean).
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dhkin.errors import InputError

KINDS: tuple[str, ...] = ("wrist", "elbow", "shoulder")


#: Units of each kind's distance.
DISTANCE_UNITS: dict[str, str] = {"wrist": "|sin q5|", "elbow": "m", "shoulder": "m"}


#: The joint (1-based) whose value moves a configuration onto / off each singularity.
MOVING_JOINT: dict[str, int] = {"wrist": 5, "elbow": 3, "shoulder": 2}


Array = NDArray[np.float64]


@dataclass(frozen=True)
class Thresholds:
    """Distances at or below which a configuration counts as at or near each singularity.

    ``wrist`` is dimensionless (``|sin q5|``), ``elbow`` and ``shoulder`` are metres; see the module
    docstring for what each distance measures.
    """

    wrist: float = 1e-4
    elbow: float = 1e-4
    shoulder: float = 1e-4

    def __post_init__(self) -> None:
        for kind in KINDS:
            value = getattr(self, kind)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not 0 <= value <= sys.float_info.max:  # finite, even as a float
                raise InputError(f"thresholds.{kind}: expected a finite number >= 0, "
                                 f"got {value!r}")

    def of(self, kind: str) -> float:
        """The threshold of one kind ("wrist", "elbow" or "shoulder")."""
        if kind not in KINDS:
            raise InputError(f"kind: expected one of {list(KINDS)}, got {kind!r}", field="kind")
        return float(getattr(self, kind))


#: Thresholds of :func:`singularity_report`: about 0.006 deg of q5, 0.1 mm.
DEFAULT_THRESHOLDS = Thresholds()


#: Thresholds of :func:`analyse_path` for near misses ("grazes"): about 3 deg of q5, 2 cm.
GRAZE_THRESHOLDS = Thresholds(wrist=0.05, elbow=0.02, shoulder=0.02)


#: A path event's joints are said to race when its peak joint speed is this many times the
#: path's median.
RACE_FACTOR = 10.0


def as_thresholds(value: Thresholds | Mapping[str, float] | None,
                  default: Thresholds = DEFAULT_THRESHOLDS) -> Thresholds:
    """None -> ``default``; a mapping such as {"wrist": 1e-3} overrides some kinds of it."""
    if value is None:
        return default
    if isinstance(value, Thresholds):
        return value
    if not isinstance(value, Mapping):
        raise InputError(f"thresholds: expected Thresholds or a mapping of {list(KINDS)} "
                         f"to numbers, got {value!r}", field="thresholds")
    unknown = [k for k in value if k not in KINDS]
    if unknown:
        raise InputError(f"thresholds: unknown kind {unknown[0]!r}; expected keys among "
                         f"{list(KINDS)}", field="thresholds")
    merged = {kind: value.get(kind, default.of(kind)) for kind in KINDS}
    return Thresholds(**merged)
