"""IK result types shared by every solver family.

Joint values are URDF joint values (rad for revolute, m for prismatic), base to tip. Poses are
base_link -> tool0 4x4 transforms in metres.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import joint_vector
from dhkin.errors import InputError

#: Singularity flags, stored as bits so that batches keep them in one uint8 array.
WRIST, ELBOW, SHOULDER = 1, 2, 4
#: The general 6R solver's flag (dhkin.ik.general6r): the solution's Jacobian or its pose's
#: eigenproblem is ill-conditioned (a singular pose of an arm without a family's named
#: singularities).
SINGULAR = 8
FLAG_NAMES: dict[int, str] = {WRIST: "wrist", ELBOW: "elbow", SHOULDER: "shoulder",
                              SINGULAR: "singular"}
#: The words of configuration labels, the same in every family: per label, its two values.
#: shoulder: which side of axis 1 the arm reaches to; elbow: the elbow above or below the line
#: from the shoulder to the wrist; wrist: the sign of q5 relative to the shoulder side; slide
#: (the Stanford arm's prismatic joint in place of an elbow): the two roots of the stroke. Each
#: family's module says how its geometry decides them.
LABEL_WORDS: dict[str, tuple[str, str]] = {"shoulder": ("lefty", "righty"), "elbow": ("up", "down"),
                                           "wrist": ("noflip", "flip"),
                                           "slide": ("forward", "backward")}


def flag_names(bits: int) -> frozenset[str]:
    """Bit mask -> names among {"wrist", "elbow", "shoulder", "singular"}."""
    return frozenset(name for bit, name in FLAG_NAMES.items() if int(bits) & bit)


#: The flag names of every bit mask (shared frozensets).
FLAG_SETS: tuple[frozenset[str], ...] = tuple(flag_names(bits) for bits in range(16))


@dataclass(frozen=True)
class Configuration:
    """Which branch a solution is on, and how many turns each joint has.

    ``labels`` come from the solver family, e.g. ``{"shoulder": "righty", "elbow": "up",
    "wrist": "noflip"}``. ``turns[k]`` is round(q_k / 2pi) for revolute joints (0 for prismatic):
    the 2pi-shifted copies of one branch differ only in their turns.
    """

    labels: Mapping[str, str]
    turns: tuple[int, ...]

    def __str__(self) -> str:
        parts = [f"{k}={v}" for k, v in self.labels.items()]
        parts.append("turns=(" + ", ".join(f"{t:+d}" for t in self.turns) + ")")
        return " ".join(parts)


class IKSolutions:
    """Every IK solution of one pose within the joint limits, each verified by FK.

    ``q`` has shape (k, n); ``configurations[i]`` and ``flags[i]`` describe ``q[i]``. An empty
    result carries the ``reason`` why (always a true statement). ``residuals`` are (position m,
    rotation rad) per solution. ``numerical`` is True when the solutions come from the numerical
    solver. ``projection``: how far the input's rotation block was moved onto the nearest
    rotation (Frobenius norm; the solutions are exact for the projected pose). ``dropped``:
    branches whose candidate did not converge or verify on the exact chain (never returned).

    Read-only. A closed-form answer keeps the compiled core's arrays and builds ``q``,
    ``configurations``, ``flags`` and ``residuals`` when they are first read.
    """

    __slots__ = (
        "_answer",
        "_configurations",
        "_configure",
        "_dropped",
        "_family",
        "_flags",
        "_numerical",
        "_projection",
        "_q",
        "_reason",
        "_residuals",
    )

    def __init__(self, q: NDArray[np.float64],
                 configurations: tuple[Configuration, ...] = (),
                 flags: tuple[frozenset[str], ...] = (),
                 residuals: NDArray[np.float64] | None = None, reason: str = "",
                 family: str = "", numerical: bool = False, projection: float = 0.0,
                 dropped: int = 0) -> None:
        self._q: NDArray[np.float64] | None = q
        self._configurations: tuple[Configuration, ...] | None = configurations
        self._flags: tuple[frozenset[str], ...] | None = flags
        self._residuals: NDArray[np.float64] | None = (np.zeros((0, 2)) if residuals is None
                                                       else residuals)
        self._reason, self._family, self._numerical = reason, family, numerical
        self._projection: float | None = projection  # None: read from _answer when asked for
        self._dropped: int | None = dropped
        self._answer: Any = None
        self._configure: Callable[[int, tuple[int, ...]], Configuration] | None = None

    @classmethod
    def from_core(cls, answer: Any, family: str,
                  configure: Callable[[int, tuple[int, ...]], Configuration]) -> IKSolutions:
        """The solutions of the compiled core's ``Answer`` (dhkin._core), read when asked for;
        ``configure(branch, turns)`` gives a solution's Configuration."""
        result = cls.__new__(cls)
        result._answer, result._configure, result._family = answer, configure, family
        result._q = result._configurations = result._flags = result._residuals = None
        result._reason, result._numerical = "", False
        result._projection = result._dropped = None  # read from the answer when asked for
        return result

    @property
    def q(self) -> NDArray[np.float64]:
        if self._q is None:
            self._q = self._answer.q()
        assert self._q is not None
        return self._q

    @property
    def configurations(self) -> tuple[Configuration, ...]:
        if self._configurations is None:
            assert self._configure is not None
            configure = self._configure
            self._configurations = tuple(configure(branch, turns) for branch, turns
                                         in self._answer.configuration_keys())
        return self._configurations

    @property
    def flags(self) -> tuple[frozenset[str], ...]:
        if self._flags is None:
            self._flags = tuple(FLAG_SETS[bits] for bits in self._answer.flags().tolist())
        return self._flags

    @property
    def residuals(self) -> NDArray[np.float64]:
        if self._residuals is None:
            self._residuals = self._answer.residuals()
        assert self._residuals is not None
        return self._residuals

    @property
    def reason(self) -> str:
        return self._reason

    @property
    def family(self) -> str:
        return self._family

    @property
    def numerical(self) -> bool:
        return self._numerical

    @property
    def projection(self) -> float:
        if self._projection is None:
            self._projection = float(self._answer.projection)
        return self._projection

    @property
    def dropped(self) -> int:
        if self._dropped is None:
            self._dropped = int(self._answer.dropped)
        return self._dropped

    def __len__(self) -> int:
        if self._q is None:
            return int(self._answer.count)
        return int(self._q.shape[0])

    def __iter__(self) -> Iterator[NDArray[np.float64]]:
        return iter(self.q)

    def __bool__(self) -> bool:
        return len(self) > 0

    def nearest(self, q_now: ArrayLike) -> NDArray[np.float64]:
        """The solution closest to ``q_now`` (Euclidean distance in joint space).

        The 2pi-shifted copies are distinct solutions here, so the plain difference is the real
        joint motion: a joint that may cross +-pi has a copy on the other side of the seam.
        Raises IKInputError when there is no solution.
        """
        current = joint_vector(q_now, self.q.shape[1], "q_now")
        if len(self) == 0:
            raise InputError(f"no solution to choose from: {self.reason}")
        return self.q[int(np.argmin(np.linalg.norm(self.q - current, axis=1)))].copy()

    def __repr__(self) -> str:
        if not self:
            return f"IKSolutions(0 solutions: {self.reason})"
        return f"IKSolutions({len(self)} solutions, family={self.family!r})"


@dataclass(frozen=True)
class IKBatch:
    """IK of N poses: ``q`` (N, m, n), ``valid`` (N, m), ``flags`` (N, m) uint8 bits, ``branch``
    (N, m) index into ``branch_labels`` (-1 where not valid). Rows are padded to the largest m.
    ``residuals`` (N, m, 2): position (m) and rotation (rad) error per solution; ``projection``
    (N,) and ``dropped`` (N,) as in :class:`IKSolutions`."""

    q: NDArray[np.float64]
    valid: NDArray[np.bool_]
    flags: NDArray[np.uint8]
    branch: NDArray[np.int16]
    branch_labels: tuple[Mapping[str, str], ...]
    family: str
    residuals: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0, 2)))
    projection: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    dropped: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))

    def counts(self) -> NDArray[np.int64]:
        """Number of solutions of each pose, (N,)."""
        return self.valid.sum(axis=1)


@dataclass(frozen=True)
class BranchSolutions:
    """The closed form's verified solution per branch of N poses, before joint limits and 2pi
    copies: ``q`` (N, B, n) with revolute values in (-pi, pi] (zeros where not ``valid``),
    ``valid`` (N, B), ``flags`` (N, B) singularity bits, ``residuals`` (N, B, 2) position (m)
    and rotation (rad) errors, ``dropped`` (N,) branches that did not settle on the exact chain.
    Branches merged at a singularity (the two wrist branches at q5 = 0) are one valid row."""

    q: NDArray[np.float64]
    valid: NDArray[np.bool_]
    flags: NDArray[np.uint8]
    residuals: NDArray[np.float64]
    branch_labels: tuple[Mapping[str, str], ...]
    dropped: NDArray[np.int64]
