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

    _q: NDArray[np.float64]
    _configurations: tuple[Configuration, ...]
    _flags: tuple[frozenset[str], ...]
    _residuals: NDArray[np.float64]
    _reason: str
    _family: str
    _numerical: bool
    _projection: float
    _dropped: int

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
        self._q = q
        self._configurations = configurations
        self._flags = flags
        self._residuals = np.zeros((0, 2)) if residuals is None else residuals
        self._reason, self._family, self._numerical = reason, family, numerical
        self._projection = projection
        self._dropped = dropped
        self._answer: Any = None
        self._configure: Callable[[int, tuple[int, ...]], Configuration] | None = None

    @classmethod
    def from_core(cls, answer: Any, family: str,
                  configure: Callable[[int, tuple[int, ...]], Configuration]) -> IKSolutions:
        """The solutions of the compiled core's ``Answer`` (dhkin._core), read when asked for;
        ``configure(branch, turns)`` gives a solution's Configuration.

        Only the answer, the family and ``configure`` are stored: every other slot stays unset
        until its property first reads it from the answer (a single call's result costs three
        stores)."""
        result = _new_solutions(cls)
        result._answer, result._configure, result._family = answer, configure, family
        return result

    @property
    def q(self) -> NDArray[np.float64]:
        try:
            return self._q
        except AttributeError:
            self._q = q = self._answer.q()
            return q

    @property
    def configurations(self) -> tuple[Configuration, ...]:
        try:
            return self._configurations
        except AttributeError:
            configure = self._configure
            assert configure is not None
            self._configurations = configurations = tuple(
                configure(branch, turns) for branch, turns in self._answer.configuration_keys())
            return configurations

    @property
    def flags(self) -> tuple[frozenset[str], ...]:
        try:
            return self._flags
        except AttributeError:
            self._flags = flags = tuple(FLAG_SETS[bits] for bits in self._answer.flags().tolist())
            return flags

    @property
    def residuals(self) -> NDArray[np.float64]:
        try:
            return self._residuals
        except AttributeError:
            self._residuals = residuals = self._answer.residuals()
            return residuals

    @property
    def reason(self) -> str:
        try:
            return self._reason
        except AttributeError:  # a core answer with solutions
            return ""

    @property
    def family(self) -> str:
        return self._family

    @property
    def numerical(self) -> bool:
        try:
            return self._numerical
        except AttributeError:  # a core answer
            return False

    @property
    def projection(self) -> float:
        try:
            return self._projection
        except AttributeError:
            self._projection = projection = float(self._answer.projection)
            return projection

    @property
    def dropped(self) -> int:
        try:
            return self._dropped
        except AttributeError:
            self._dropped = dropped = int(self._answer.dropped)
            return dropped

    def __len__(self) -> int:
        answer = self._answer
        if answer is not None:
            return answer.count
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


#: A new IKSolutions with no slot set (IKSolutions.from_core).
_new_solutions = object.__new__


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

    @classmethod
    def from_rows(cls, q: NDArray[np.float64], flags: NDArray[np.uint8],
                  branch: NDArray[np.int16], residuals: NDArray[np.float64],
                  counts: NDArray[np.int64], branch_labels: tuple[Mapping[str, str], ...],
                  family: str, projection: NDArray[np.float64],
                  dropped: NDArray[np.int64]) -> IKBatch:
        """The batch of N poses whose R solutions come as rows, pose after pose: q (R, n),
        flags, branch (R,), residuals (R, 2), ``counts`` (N,) rows per pose; padded to the
        largest count."""
        n_poses = counts.shape[0]
        width = int(counts.max()) if n_poses else 0
        pose = np.repeat(np.arange(n_poses), counts)
        slot = np.arange(q.shape[0]) - np.repeat(np.cumsum(counts) - counts, counts)
        out_q = np.zeros((n_poses, width, q.shape[1]))
        valid = np.zeros((n_poses, width), np.bool_)
        out_flags = np.zeros((n_poses, width), np.uint8)
        out_branch = np.full((n_poses, width), -1, np.int16)
        out_residuals = np.zeros((n_poses, width, 2))
        out_q[pose, slot] = q
        valid[pose, slot] = True
        out_flags[pose, slot] = flags
        out_branch[pose, slot] = branch
        out_residuals[pose, slot] = residuals
        return cls(q=out_q, valid=valid, flags=out_flags, branch=out_branch,
                   branch_labels=branch_labels, family=family, residuals=out_residuals,
                   projection=projection, dropped=dropped)


@dataclass(frozen=True)
class BranchSolutions:
    """The closed form's verified solution per branch of N poses, before joint limits and 2pi
    copies: ``q`` (N, B, n) with revolute values in (-pi, pi] (zeros where not ``valid``),
    ``valid`` (N, B), ``flags`` (N, B) singularity bits, ``residuals`` (N, B, 2) position (m)
    and rotation (rad) errors, ``dropped`` (N,) branches that did not settle on the exact chain.
    Branches merged at a singularity (the two wrist branches at q5 = 0) are one valid row.

    A refined table's pose can have more isolated roots than branches (near the ideal model's
    singular sets): those beyond the slots are ``extra_q`` (N, E, n), ``extra_branch`` (N, E)
    (the branch whose configuration the ideal model gives the root; -1 past a pose's last),
    ``extra_flags`` and ``extra_residuals`` (E = 0 on every other table)."""

    q: NDArray[np.float64]
    valid: NDArray[np.bool_]
    flags: NDArray[np.uint8]
    residuals: NDArray[np.float64]
    branch_labels: tuple[Mapping[str, str], ...]
    dropped: NDArray[np.int64]
    extra_q: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0, 6)))
    extra_branch: NDArray[np.int16] = field(default_factory=lambda: np.zeros((0, 0), np.int16))
    extra_flags: NDArray[np.uint8] = field(default_factory=lambda: np.zeros((0, 0), np.uint8))
    extra_residuals: NDArray[np.float64] = field(
        default_factory=lambda: np.zeros((0, 0, 2)))
