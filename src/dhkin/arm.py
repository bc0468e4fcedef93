"""What analysis code needs of a robot: the :class:`Arm` protocol.

Singularity analysis, maps, validation and comparison work on any object with a DH table, FK,
IK and a Pinocchio reference; :class:`dhkin.robot.Robot` is the one dhkin provides. Typing them
against this protocol (kinematics layer) instead of importing ``Robot`` (the facade above them)
keeps the layers free of circles: see docs/architecture.md.

Frames and units as everywhere in dhkin: poses base_link -> tool0 (4x4, metres), joint values
URDF joint values (rad, m), base to tip.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import DHTable
from dhkin.ik.result import IKBatch, IKSolutions
from dhkin.reference import Reference

if TYPE_CHECKING:
    from dhkin.ik.numerical import NumericalIK
    from dhkin.ik.solver import ClosedFormSolver


@runtime_checkable
class Arm(Protocol):
    """A robot as analysis code uses it (see the module docstring)."""

    table: DHTable

    @property
    def name(self) -> str: ...

    @property
    def dof(self) -> int: ...

    @property
    def lower(self) -> NDArray[np.float64]: ...

    @property
    def upper(self) -> NDArray[np.float64]: ...

    @property
    def has_closed_form(self) -> bool: ...

    @property
    def complete_ik(self) -> bool: ...

    @property
    def ik_family(self) -> str: ...

    @property
    def ik_solver(self) -> ClosedFormSolver: ...

    def fk(self, q: ArrayLike) -> NDArray[np.float64]: ...

    def urdf(self, prefix: str = "") -> str: ...

    def reference(self, tip: str = "tool0") -> Reference: ...

    def numerical_solver(self, tip: str = "tool0") -> NumericalIK: ...

    def ik(self, T: ArrayLike, q_seed: ArrayLike | None = None, tolerance: float = ...,
           tcp: ArrayLike | None = None, copies: bool = False) -> IKSolutions: ...

    def ik_batch_detailed(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                          tolerance: float = ..., tcp: ArrayLike | None = None,
                          copies: bool = False, chunk_size: int = ...,
                          workers: int | None = None) -> IKBatch: ...

    def ik_batch_seeds(self, T: ArrayLike, q_seeds: Sequence[ArrayLike | None],
                       tolerance: float = ..., tcp: ArrayLike | None = None,
                       copies: bool = False, chunk_size: int = ...,
                       workers: int | None = None) -> list[IKBatch]: ...
