"""The factors of det J (shoulder, elbow, wrist) of N configurations (computed by each family's
module, :mod:`dhkin.ik.family`; the mathematics: :mod:`dhkin.singularity.model`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dhkin.errors import InputError
from dhkin.singularity.thresholds import KINDS, Array


@dataclass(frozen=True)
class Factors:
    """Signed factors of det J for N configurations: ``det J = constant * shoulder * elbow *
    wrist`` (for the Stanford arm ``elbow`` holds the extension e, m, and is no singularity).

    All arrays have shape (N,). ``*_distance`` are the distances of the module docstring
    (``elbow_distance`` is NaN for the Stanford arm, which has no elbow).
    """

    family: str
    constant: Array
    shoulder: Array
    elbow: Array
    wrist: Array
    shoulder_distance: Array
    elbow_distance: Array

    @property
    def determinant(self) -> Array:
        """det J of the 6x6 joint Jacobian (any frame, any point on the last body)."""
        return self.constant * self.shoulder * self.elbow * self.wrist

    @property
    def wrist_distance(self) -> Array:
        return np.abs(self.wrist)

    def distance(self, kind: str) -> Array:
        """The distance of one kind, (N,)."""
        if kind == "wrist":
            return self.wrist_distance
        if kind == "elbow":
            return self.elbow_distance
        if kind == "shoulder":
            return self.shoulder_distance
        raise InputError(f"kind: expected one of {list(KINDS)}, got {kind!r}", field="kind")

    def signed(self, kind: str) -> Array:
        """The signed factor whose zero is that singularity, (N,)."""
        if kind == "wrist":
            return self.wrist
        if kind == "elbow":
            return self.elbow
        if kind == "shoulder":
            return self.shoulder
        raise InputError(f"kind: expected one of {list(KINDS)}, got {kind!r}", field="kind")

    def __getitem__(self, index: int | slice | NDArray[np.int64]) -> Factors:
        return Factors(self.family, *(np.atleast_1d(getattr(self, name)[index]) for name in
                                      ("constant", "shoulder", "elbow", "wrist",
                                       "shoulder_distance", "elbow_distance")))
