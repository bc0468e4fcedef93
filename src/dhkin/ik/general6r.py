"""Closed-form IK of any six-revolute chain: every solution, by algebraic elimination.

:class:`General6RSolver` solves a table of six revolute joints (either DH convention, offsets,
directions, base, tool, corrections) whatever its geometry. Poses are base_link -> tool0 (or a
TCP, ``tcp``: tool0 -> TCP) in metres; joint values are URDF joint values (rad).

1. The exact chain (:func:`dhkin.ik.plan.chain_parts`) is written as a standard-DH model
   (:mod:`dhkin.ik.general6r_model`), forwards or tip to base (the reversed chain solves
   T^-1), lengths scaled to order one.
2. Raghavan and Roth's elimination (:mod:`dhkin.ik.general6r_elimination`) in one of three
   arrangements gives a 12 x 12 matrix polynomial of degree two in the half-angle tangent of
   the eliminated joint; its 24 eigenvalues hold every solution. The arrangement and direction
   are chosen per table (:func:`dhkin.ik.general6r_arrangement.choose_arrangement`).
3. Per pose, in the compiled core (``dhkin._core.General6R``, ``cpp/dhkin/general6r/``): the
   eigenvalues, one start per root, Newton on the exact chain, verification by FK at the
   tolerance, merging (two roots are one when the midpoint of their joint values verifies too),
   the seed's member of a curve of solutions, the joint limits and 2pi copies
   (docs/general6r.md). Python builds the constants once per table and the result types.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin import _core
from dhkin.dh import DHTable
from dhkin.errors import FamilyError, InputError
from dhkin.ik.general6r_arrangement import (
    IMAGINARY_BAND,
    Arrangement,
    frames_at_zero,
    rank_arrangements,
)
from dhkin.ik.general6r_elimination import _HALF2, _V_INV, Elimination
from dhkin.ik.general6r_model import Model, _inverse, refit
from dhkin.ik.general6r_moves import fallback_starts, moves
from dhkin.ik.inputs import TWO_PI, as_targets, check_flag, check_tolerance, pose_error_message
from dhkin.ik.result import SINGULAR, Configuration, IKBatch, IKSolutions
from dhkin.ik.workers import _in_slices, check_workers
from dhkin.tolerances import DEFAULT_TOLERANCE

#: The free angles eliminated first: theta_k = shift + 2 atan(x3). An angle with no special
#: value (0, pi/2, pi), so that a pose at theta_k = shift + pi (an eigenvalue at infinity,
#: handled by QZ anyway) is unlikely.
SHIFT = 0.5772156649015329


#: The core's outcomes of one pose (cpp/dhkin/general6r/solver.hpp, ``Outcome``).
SOLVED, REJECTED, OUT_OF_REACH, NO_ROOT, NO_COPY = 0, 1, 2, 3, 4


def singular_band(tolerance: float) -> float:
    """A root is flagged "singular" when the smallest singular value sigma of its Jacobian
    (linear rows divided by the lever, so that rad and m/lever weigh alike) is at most
    sqrt(tolerance): a step delta along the weakest direction moves the pose by about
    sigma delta + delta^2 / 2 (curvature ~1 per rad on the scaled chain), so with sigma <=
    sqrt(tolerance) every point within ~sqrt(tolerance) rad of the root along that direction
    verifies as well: at the tolerance the pose cannot be told from a singular one (a double
    root, or a curve of solutions where a joint is free). 3.2e-5 at the default 1e-9
    (cpp/dhkin/general6r/solver.hpp)."""
    return math.sqrt(tolerance)


def _fields(values: dict[str, Any]) -> dict[str, NDArray[np.float64]]:
    """Named values as the compiled solver takes them: flat C-contiguous float64 arrays."""
    return {name: np.ascontiguousarray(value, dtype=np.float64).ravel()
            for name, value in values.items()}


class General6RSolver:
    """Every solution of a six-revolute table (see the module docstring)."""

    family = "general6r"

    def __init__(self, table: DHTable, arrangement: Arrangement | None = None) -> None:
        if table.dof != 6 or not all(j.is_revolute for j in table.joints):
            raise FamilyError(f"{table.name}: the general 6R solver needs six revolute joints")
        from dhkin.ik.plan import chain_parts

        self.table = table
        self.dof = 6
        parts = chain_parts(table)
        self.parts = parts
        pre = np.tile(np.eye(4), (7, 1, 1))
        pre[:6] = parts["before"]
        pre[6] = parts["tail"]
        self.pre = pre
        self.direction = np.asarray(parts["direction"], dtype=np.float64)
        self.offset = np.asarray(parts["offset"], dtype=np.float64)
        self.lever = max(1.0, float(np.max(np.abs(np.diff(
            frames_at_zero(pre)[:, :3, 3], axis=0)))))
        self.tip_lever = self.lever + float(np.linalg.norm(table.tool[:3, 3]))
        #: The sum of the chain's link lengths (m): DH frame 6 never lies farther than this
        #: from DH frame 0 (a farther pose is out of reach before any elimination).
        self.links = float(sum(np.linalg.norm(pre[j, :3, 3]) for j in range(7)))
        self.fallback = fallback_starts(table.lower, table.upper)
        ranked = [arrangement] if arrangement is not None else rank_arrangements(self)
        self.arrangement = ranked[0]
        #: The other regular arrangements, solved too at a pose with a singular root.
        self.other_arrangements = tuple(ranked[1:])
        self.model, self.elimination = self._eliminator(self.arrangement)
        others = [(other, self._eliminator(other)[1]) for other in self.other_arrangements]
        #: The compiled solver (cpp/dhkin/general6r/): every pose's work.
        self.core = self.core_for(self.arrangement, self.elimination, others)
        self._configurations: dict[tuple[int, ...], Configuration] = {}
        self.branch_labels: tuple[MappingProxyType[str, str], ...] = (MappingProxyType({}),)
        self._zero_seed = np.zeros(6)

    def core_for(self, arrangement: Arrangement, elimination: Elimination,
                 others: Sequence[tuple[Arrangement, Elimination]] = ()) -> Any:
        """The compiled solver (``dhkin._core.General6R``) of one arrangement: the elimination's
        constants, the moved poses, the exact chain and limits, by name; ``others``: the
        arrangements also solved at a pose with a singular root."""
        values: dict[str, Any] = self._elimination_values(arrangement, elimination)
        values.update({
            "twist": moves(elimination.model.scale)[0], "fallback": self.fallback,
            "chain_before": self.parts["before"], "chain_direction": self.direction,
            "chain_offset": self.offset, "chain_tail": self.parts["tail"],
            "tool": self.table.tool, "base_inverse": _inverse(self.table.base),
            "lower": self.table.lower, "upper": self.table.upper, "lever": self.lever,
            "links": self.links})
        other_values = [_fields(self._elimination_values(*other)) for other in others]
        return _core.General6R(_fields(values), other_values)

    def _elimination_values(self, arrangement: Arrangement, elimination: Elimination
                            ) -> dict[str, Any]:
        """One arrangement's elimination constants, by name (cpp/bindings_general6r.cpp)."""
        model = elimination.model
        before, after = elimination.sample_factors()
        return {
            "P": elimination.P, "before": before, "after": after,
            "right_inverse": np.kron(_V_INV, _V_INV), "mix": elimination.mix, "half2": _HALF2,
            "rows": np.array(elimination.rows), "phi": model.phi,
            "D0_inverse": _inverse(model.D0), "E_inverse": _inverse(model.E),
            "shift": elimination.shift, "k": elimination.k,
            "reversed": float(arrangement.reversed), "scale": model.scale,
            "band": IMAGINARY_BAND, "direction": self.direction, "offset": self.offset,
            "spurious": elimination.spurious_subspace()}

    def compiled_candidates(self, T_dh: NDArray[np.float64], core: Any = None
                            ) -> NDArray[np.float64]:
        """The starts of one elimination of the target T_dh (DH frame 0 -> DH frame 6 of the
        exact chain), before refinement: joint values (m, 6)."""
        starts, _, _, _ = (core or self.core).candidates(
            np.ascontiguousarray(T_dh, dtype=np.float64))
        return np.asarray(starts)

    def _eliminator(self, arrangement: Arrangement) -> tuple[Model, Elimination]:
        pre = self.pre
        if arrangement.reversed:
            pre = np.stack([_inverse(pre[6 - i]) for i in range(7)])
        model = refit(pre)
        return model, Elimination(model, arrangement.k, SHIFT)

    # -- solutions ------------------------------------------------------------------------

    def target_dh(self, T: ArrayLike, tcp: ArrayLike | None = None) -> NDArray[np.float64]:
        """base_link -> tool0 (or TCP) pose -> DH frame 0 -> DH frame 6 of the exact chain."""
        target = np.asarray(T, dtype=float)
        if target.shape != (4, 4) or not np.all(np.isfinite(target)):
            raise InputError(f"T: expected a finite (4, 4) pose, got shape {target.shape}",
                             field="T")
        tool = self.table.tool if tcp is None else self.table.tool @ np.asarray(tcp, float)
        return np.asarray(_inverse(self.table.base) @ target @ _inverse(tool))

    @staticmethod
    def verification_tolerance(tolerance: float, lever: float) -> float:
        """The tolerance solutions are verified at on our FK: ``tolerance`` less the FK rounding
        margin (dhkin.ik.core.FK_ROUNDING per metre of lever), as in the families, so
        that a solution verified on our FK is within ``tolerance`` on the oracle's too."""
        from dhkin.ik.core import FK_ROUNDING

        return max(tolerance - FK_ROUNDING * lever, 0.5 * tolerance)

    def roots(self, T_dh: NDArray[np.float64], tolerance: float
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """The verified, distinct solutions (k, 6) wrapped to (-pi, pi] for the target T_dh (DH
        frame 0 -> DH frame 6), their residuals there (k, 2), and how many candidates did not
        verify. No seed: the roots do not depend on one."""
        roots, errors, failed, _ = self.core.roots(np.ascontiguousarray(T_dh, np.float64),
                                                   tolerance)
        return np.asarray(roots), np.asarray(errors), int(failed)

    def reach(self, tolerance: float, tool: NDArray[np.float64]) -> float:
        """How far DH frame 6 may lie from DH frame 0 (m) for a pose of the point verified
        (``tool``: DH frame 6 -> that point) within ``tolerance``: the chain's links, widened
        by the tolerance at the point and its rotation over the tool's length, and FK
        rounding (cpp/dhkin/general6r/solver.hpp)."""
        from dhkin.ik.core import FK_ROUNDING

        return (self.links + tolerance * (1.0 + float(np.linalg.norm(tool[:3, 3])))
                + FK_ROUNDING * self.tip_lever)

    def smallest_singular(self, q: ArrayLike) -> float:
        """The smallest singular value of the Jacobian at tool0 at q (linear rows divided by
        the lever): what the "singular" flag compares with :func:`singular_band`."""
        return float(self.core.smallest_singular(np.ascontiguousarray(q, dtype=np.float64)))

    @staticmethod
    def _pose(T: ArrayLike, name: str) -> NDArray[np.float64]:
        """A pose as a C-contiguous (4, 4) float64 array; InputError naming ``name`` otherwise
        (its values are checked by the core)."""
        try:
            target = np.ascontiguousarray(T, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(f"{name}: expected a (4, 4) pose of numbers ({exc})",
                             field=name) from exc
        if target.shape != (4, 4):
            raise InputError(f"{name}: expected a (4, 4) pose, got shape {np.shape(T)}",
                             field=name)
        return target

    def _tcp(self, tcp: ArrayLike | None) -> NDArray[np.float64] | None:
        """The TCP (tool0 -> TCP) checked and projected as a pose, or None."""
        if tcp is None:
            return None
        from dhkin.ik.core import pose_status, project

        frame = self._pose(tcp, "tcp")
        code = pose_status(frame)
        if code:
            raise InputError(pose_error_message("tcp", frame, code), field="tcp")
        projected, _ = project(frame)
        return np.ascontiguousarray(projected)

    def _seeds(self, q_seed: ArrayLike | None, n_poses: int | None = None
               ) -> NDArray[np.float64]:
        """The seed (6,), or seeds (1 or N, 6) of a batch, checked (zeros: no seed)."""
        if q_seed is None:
            return self._zero_seed if n_poses is None else self._zero_seed[None]
        try:
            seed = np.ascontiguousarray(q_seed, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(f"q_seed: expected 6 finite numbers ({exc})",
                             field="q_seed") from exc
        if n_poses is None:
            if seed.shape == (1, 6):
                seed = seed[0]
            if seed.shape != (6,) or not np.all(np.isfinite(seed)):
                raise InputError(field="q_seed", value=np.shape(seed),
                                 expected="6 finite values")
            return seed
        if seed.shape == (6,):
            seed = seed[None]
        if seed.shape not in ((1, 6), (n_poses, 6)) or not np.all(np.isfinite(seed)):
            raise InputError(f"q_seed: expected finite values of shape (6,) or "
                             f"({n_poses}, 6), got shape {np.shape(q_seed)}", field="q_seed")
        return seed

    def solve_one(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                  tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                  copies: bool = False) -> IKSolutions:
        """Every solution of one pose within the joint limits: per root its in-limit 2pi copy
        nearest ``q_seed`` (nearest 0 without one), or every copy with ``copies``. Inputs are
        checked as by the families (:class:`dhkin.ik.solver.ClosedFormSolver`); solutions are
        verified by FK at the TCP (tool0, or ``tcp``). The roots do not depend on the seed: it
        only chooses each root's 2pi copy and, on a curve of solutions (a singular root), the
        member nearest it."""
        tolerance = check_tolerance(tolerance)
        copies = check_flag(copies, "copies")
        target = self._pose(T, "T")
        seed = self._seeds(q_seed)
        outcome, status, projection, distance, failed, verified, rows = self.core.solve(
            target, seed, tolerance, copies, self._tcp(tcp))
        if outcome == REJECTED:
            raise InputError(pose_error_message("T", target, status), field="T")
        if outcome == SOLVED:
            q, residuals, singular = rows
            return IKSolutions.from_core(_Settled(q, residuals, singular, projection, failed),
                                         self.family, self._configure)
        return IKSolutions(q=np.zeros((0, 6)), family=self.family, projection=projection,
                           dropped=failed, reason=self._reason(outcome, distance, failed,
                                                               verified, tolerance))

    def _reason(self, outcome: int, distance: float, failed: int, verified: int,
                tolerance: float) -> str:
        """Why a pose has no solution (a true statement)."""
        if outcome == OUT_OF_REACH:
            return (f"out of reach: DH frame 6 lies {distance:.6g} m from DH frame 0, farther "
                    f"than the chain's links reach ({self.links:.6g} m)")
        if outcome == NO_ROOT:
            reason = ("no real solution: the elimination found no root that verifies on the "
                      f"exact chain at tolerance {tolerance:g}")
            if failed:
                reason += f" ({failed} candidate(s) did not converge)"
            return reason
        return (f"{verified} solution(s) verified, but no 2pi copy of any lies within the "
                "joint limits")

    def solve_batch(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                    tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                    copies: bool = False, chunk_size: int = 65536,
                    workers: int | None = None) -> IKBatch:
        """:meth:`solve_one` of N poses (N, 4, 4) in the compiled core, padded to the largest
        count; ``q_seed`` (6,) or (N, 6). Poses run in chunks of ``chunk_size``, each shared
        among ``workers`` threads (default: the CPUs this process may use; each pose is solved
        alone, so the answer does not depend on them). ``branch`` is 0 for every solution (the
        general solver has one branch label set, empty: its roots have no family labels)."""
        return self.solve_batch_seeds(T, [q_seed], tolerance, tcp, copies, chunk_size,
                                      workers)[0]

    def solve_batch_seeds(self, T: ArrayLike, q_seeds: Sequence[ArrayLike | None],
                          tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                          copies: bool = False, chunk_size: int = 65536,
                          workers: int | None = None) -> list[IKBatch]:
        """:meth:`solve_batch` of the same poses once per seed set of ``q_seeds`` (each None,
        (6,) or (N, 6)), each pose's roots found once: answer s equals
        ``solve_batch(T, q_seeds[s], ...)`` row for row, since the roots do not depend on the
        seed (it chooses copies and members only). For answers of one pose under several seeds
        (a validation's continuity check) at the cost of one."""
        from dhkin.ik.inputs import _check_chunk

        tolerance = check_tolerance(tolerance)
        copies = check_flag(copies, "copies")
        chunk_size = _check_chunk(chunk_size)
        workers = check_workers(workers)
        targets, _ = as_targets(T)
        n_poses = targets.shape[0]
        if not q_seeds:
            raise InputError("q_seeds: expected at least one seed set", field="q_seeds")
        seed_sets = [self._seeds(q_seed, n_poses) for q_seed in q_seeds]
        per_pose = any(seeds.shape[0] != 1 for seeds in seed_sets)
        # (S, 1 or N, 6): one seed broadcast to every pose where another set has one per pose
        seeds = np.ascontiguousarray(np.stack([
            np.broadcast_to(s, (n_poses, 6)) if per_pose else s for s in seed_sets]))
        frame = self._tcp(tcp)
        parts: dict[int, list[tuple[Any, ...]]] = {}
        for start in range(0, n_poses, chunk_size):
            stop = min(start + chunk_size, n_poses)

            def solve(a: int, b: int, start: int = start) -> None:
                first, last = start + a, start + b
                part = seeds if seeds.shape[1] == 1 else seeds[:, first:last]
                parts[first] = self.core.solve_batch_seeds(
                    targets[first:last], np.ascontiguousarray(part), tolerance, copies, frame)

            _in_slices(stop - start, workers, solve)
        firsts = sorted(parts)
        return [self._pack([parts[first][s] for first in firsts], targets, firsts)
                for s in range(len(seed_sets))]

    def _pack(self, parts: list[tuple[Any, ...]], targets: NDArray[np.float64],
              firsts: list[int]) -> IKBatch:
        """The core's batch answers (one per slice, in order) as an IKBatch padded to the
        largest count; InputError for the first pose the core rejected."""
        for first, part in zip(firsts, parts, strict=True):
            rejected, status = part[4], part[5]
            if rejected >= 0:
                index = first + int(rejected)
                raise InputError(pose_error_message(f"T[{index}]", targets[index], status),
                                 field="T", index=index)
        q = np.concatenate([np.asarray(p[0][0]) for p in parts]) if parts else np.zeros((0, 6))
        errors = (np.concatenate([np.asarray(p[0][1]) for p in parts]) if parts
                  else np.zeros((0, 2)))
        singular = (np.concatenate([np.asarray(p[0][2]) for p in parts]) if parts
                    else np.zeros(0, np.uint8))
        counts = (np.concatenate([np.asarray(p[1]) for p in parts]) if parts
                  else np.zeros(0, np.int64))
        projection = (np.concatenate([np.asarray(p[2]) for p in parts]) if parts
                      else np.zeros(0))
        dropped = (np.concatenate([np.asarray(p[3]) for p in parts]) if parts
                   else np.zeros(0, np.int64))
        return IKBatch.from_rows(q, np.where(singular != 0, SINGULAR, 0).astype(np.uint8),
                                 np.zeros(q.shape[0], np.int16), errors, counts,
                                 self.branch_labels, self.family, projection, dropped)

    def _configure(self, branch: int, turns: tuple[int, ...]) -> Configuration:
        """A solution's Configuration (one branch: the general solver has no labels)."""
        return self._configuration(turns)

    def _configuration(self, turns: tuple[int, ...]) -> Configuration:
        found = self._configurations.get(turns)
        if found is None:
            found = Configuration(labels=self.branch_labels[0], turns=turns)
            self._configurations[turns] = found
        return found


class _Settled:
    """One pose's solutions from the core, as :meth:`IKSolutions.from_core` reads them (its
    configurations, flags and residuals built when first asked for)."""

    __slots__ = ("_q", "_residuals", "_singular", "count", "dropped", "projection")

    def __init__(self, q: NDArray[np.float64], residuals: NDArray[np.float64],
                 singular: NDArray[np.uint8], projection: float, dropped: int) -> None:
        self._q, self._residuals, self._singular = q, residuals, singular
        self.count, self.projection, self.dropped = q.shape[0], projection, dropped

    def q(self) -> NDArray[np.float64]:
        return self._q

    def residuals(self) -> NDArray[np.float64]:
        return self._residuals

    def flags(self) -> NDArray[np.uint8]:
        return np.where(self._singular != 0, SINGULAR, 0).astype(np.uint8)

    def configuration_keys(self) -> list[tuple[int, tuple[int, ...]]]:
        turns = np.rint(self._q * (1.0 / TWO_PI)).astype(np.int64).tolist()
        return [(0, tuple(t)) for t in turns]
