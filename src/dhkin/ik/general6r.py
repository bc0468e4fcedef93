"""Closed-form IK of any six-revolute chain: every solution, by algebraic elimination.

:class:`General6RSolver` solves a table of six revolute joints (either DH convention, offsets,
directions, base, tool, corrections) whatever its geometry. Poses are base_link -> tool0 (or a
TCP, ``tcp``: tool0 -> TCP) in metres; joint values are URDF joint values (rad).

1. The exact chain (:func:`dhkin.ik.plan.chain_array`) is written as a standard-DH model
   (:mod:`dhkin.ik.general6r_model`), forwards or tip to base (the reversed chain solves
   T^-1), lengths scaled to order one.
2. Raghavan and Roth's elimination (:mod:`dhkin.ik.general6r_elimination`) in one of three
   arrangements gives a 12 x 12 matrix polynomial of degree two in the half-angle tangent of
   the eliminated joint; its 24 eigenvalues (QZ on the companion pencil) hold every solution.
   The arrangement and direction are chosen per table (:func:`choose_arrangement`): the one
   whose matrix polynomial is regular (Raghavan and Roth's own arrangement is singular for
   every x3 on arms whose axes 1 and 2 meet, such as the UR5, CRX-10iA and xArm6) and best
   conditioned on sample poses.
3. Each candidate is refined by Newton on the exact chain (:func:`dhkin.ik.compiled.chain.refine`)
   and verified by FK at the tolerance; candidates that reach the same root are one (two roots
   are one when the midpoint of their joint values verifies too).
4. Joint limits and 2pi copies follow the families' rules (docs/ik_core.md, "The answer").
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.dh import DHTable
from dhkin.errors import FamilyError, InputError
from dhkin.ik.general6r_answer import copies as copies_within
from dhkin.ik.general6r_answer import (
    distinct_rows,
    onto_limits,
    pack,
    seed_members,
    singular_band,
)
from dhkin.ik.general6r_arrangement import (
    IMAGINARY_BAND,
    Arrangement,
    choose_arrangement,
    frames_at_zero,
)
from dhkin.ik.general6r_elimination import Elimination
from dhkin.ik.general6r_model import Model, _inverse, refit
from dhkin.ik.general6r_moves import fallback_starts, moves, perturbations
from dhkin.ik.inputs import TWO_PI, as_targets, check_tolerance, pose_error_message
from dhkin.ik.result import Configuration, IKBatch, IKSolutions
from dhkin.tolerances import DEFAULT_TOLERANCE

#: The free angles eliminated first: theta_k = shift + 2 atan(x3). An angle with no special
#: value (0, pi/2, pi), so that a pose at theta_k = shift + pi (an eigenvalue at infinity,
#: handled by QZ anyway) is unlikely.
SHIFT = 0.5772156649015329


class General6RSolver:
    """Every solution of a six-revolute table (see the module docstring)."""

    family = "general6r"

    def __init__(self, table: DHTable, arrangement: Arrangement | None = None) -> None:
        if table.dof != 6 or not all(j.is_revolute for j in table.joints):
            raise FamilyError(f"{table.name}: the general 6R solver needs six revolute joints")
        from dhkin.ik.plan import chain_array

        self.table = table
        self.dof = 6
        self.chain = chain_array(table)
        pre = np.tile(np.eye(4), (7, 1, 1))
        for j in range(7):
            pre[j, :3, :] = self.chain[j, :12].reshape(3, 4)
        self.pre = pre
        self.direction = self.chain[:6, 13].copy()
        self.offset = self.chain[:6, 14].copy()
        self._base_inverse = _inverse(table.base)
        self._tool_inverse = _inverse(table.tool)
        self.lever = max(1.0, float(np.max(np.abs(np.diff(
            frames_at_zero(pre)[:, :3, 3], axis=0)))))
        #: The exact chain to tool0 (the point verified; ``chain`` ends at DH frame 6).
        self.tip_chain = self.chain.copy()
        self.tip_chain[6, :12] = (pre[6] @ table.tool)[:3].ravel()
        self.tip_lever = self.lever + float(np.linalg.norm(table.tool[:3, 3]))
        #: The sum of the chain's link lengths (m): DH frame 6 never lies farther than this
        #: from DH frame 0 (a farther pose is out of reach before any elimination).
        self.links = float(sum(np.linalg.norm(self.chain[j, [3, 7, 11]]) for j in range(7)))
        if arrangement is None:
            arrangement = choose_arrangement(self)
        self.arrangement = arrangement
        self.model, self.elimination = self._eliminator(arrangement)
        self._data = self.kernel_data()
        #: The moved poses of an ill-conditioned pose (:mod:`dhkin.ik.general6r_moves`): the
        #: motions (1, 6) and their matrices (1, 4, 4).
        self.moves = moves(self.model.scale)
        self.perturbations = perturbations(self.model.scale)
        self.fallback = fallback_starts(table.lower, table.upper)
        from dhkin.ik.compiled.general6r_qz import DGGEV

        self._dggev = DGGEV
        self._configurations: dict[tuple[int, ...], Configuration] = {}
        self.branch_labels: tuple[MappingProxyType[str, str], ...] = (MappingProxyType({}),)
        self._zero_seed = np.zeros(6)
        self._buffers = threading.local()
        self._fast_constants: dict[float, tuple[Any, ...]] = {}

    def kernel_data(self, arrangement: Arrangement | None = None,
                    elimination: Elimination | None = None) -> tuple[NDArray[np.float64], ...]:
        """The compiled candidates' constant arguments (dhkin.ik.compiled.general6r)."""
        from dhkin.ik.general6r_elimination import _HALF2, _V_INV

        arrangement = arrangement or self.arrangement
        el = elimination or self.elimination
        model = el.model
        before, after = el.sample_factors()
        rows = np.array(el.rows)
        setup = np.array([el.shift, el.k, float(arrangement.reversed), model.scale,
                          IMAGINARY_BAND])
        right_inverse = np.asarray(np.kron(_V_INV, _V_INV), dtype=np.float64)
        return (np.ascontiguousarray(el.P), before, after, right_inverse,
                np.ascontiguousarray(el.mix), np.ascontiguousarray(_HALF2), rows,
                model.phi.copy(), _inverse(model.D0), _inverse(model.E), setup,
                self.direction, self.offset)

    def compiled_candidates(self, T_dh: NDArray[np.float64],
                            data: tuple[NDArray[np.float64], ...] | None = None
                            ) -> NDArray[np.float64]:
        """The starts of one elimination (:func:`dhkin.ik.compiled.general6r.candidates`) of
        the target T_dh (DH frame 0 -> DH frame 6 of the exact chain), before refinement:
        joint values (m, 6)."""
        from dhkin.ik.compiled.general6r import MAX_PER_POSE, candidates
        from dhkin.ik.compiled.general6r_qz import DGGEV

        out = np.empty((MAX_PER_POSE, 6))
        count = candidates(*(data or self._data), DGGEV, True, np.ascontiguousarray(T_dh), out,
                           np.empty(MAX_PER_POSE, np.int64), np.empty(2))
        return out[:count]

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
        tool_inverse = self._tool_inverse
        if tcp is not None:
            tool_inverse = _inverse(np.asarray(tcp, dtype=float)) @ tool_inverse
        return self._base_inverse @ target @ tool_inverse

    @staticmethod
    def _pose(T: ArrayLike, name: str) -> tuple[NDArray[np.float64], float]:
        """A pose checked and projected as the families do (docs/ik_core.md, "Input poses as
        they come"): the pose with its rotation block the nearest rotation, and how far that
        moved it (Frobenius norm); InputError naming ``name`` otherwise."""
        from dhkin.ik.compiled.pose import project, status

        try:
            target = np.ascontiguousarray(T, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(f"{name}: expected a (4, 4) pose of numbers ({exc})",
                             field=name) from exc
        if target.shape != (4, 4):
            raise InputError(f"{name}: expected a (4, 4) pose, got shape {np.shape(T)}",
                             field=name)
        code = int(status(target))
        if code:
            raise InputError(pose_error_message(name, target, code), field=name)
        out = np.eye(4)
        projection = float(project(target, out[:3]))
        return out, projection

    def _seed(self, q_seed: ArrayLike | None) -> NDArray[np.float64] | None:
        if q_seed is None:
            return None
        try:
            seed = np.asarray(q_seed, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InputError(f"q_seed: expected 6 finite numbers ({exc})",
                             field="q_seed") from exc
        if seed.shape == (1, 6):
            seed = seed[0]
        if seed.shape != (6,) or not np.all(np.isfinite(seed)):
            raise InputError(field="q_seed", value=np.shape(seed), expected="6 finite values")
        return np.ascontiguousarray(seed)

    def _tip(self, tcp: ArrayLike | None) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                   float]:
        """The exact chain to the point verified (tool0, or the TCP), (tool @ tcp)^-1, and the
        verification tolerance's lever (see :meth:`verification_tolerance`)."""
        if tcp is None:
            return self.tip_chain, self._tool_inverse, self.tip_lever
        frame, _ = self._pose(tcp, "tcp")
        tool = self.table.tool @ frame
        chain = self.chain.copy()
        chain[6, :12] = (self.pre[6] @ tool)[:3].ravel()
        lever = max(self.tip_lever, self.lever + float(np.linalg.norm(tool[:3, 3])))
        return chain, _inverse(tool), lever

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
        roots, errors, failed, _ = self._settled(T_dh, T_dh, self.chain, tolerance, self.lever)
        return roots, errors, failed

    def _settled(self, T_dh: NDArray[np.float64], tip_target: NDArray[np.float64],
                 chain: NDArray[np.float64], tolerance: float, lever: float
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], int, NDArray[np.bool_]]:
        """The roots of T_dh refined and verified on ``chain`` against ``tip_target`` (DH frame
        0 -> the chain's last frame), their residuals, the candidates that did not verify, and
        whether each root is singular (:func:`singular_band`)."""
        from dhkin.ik.compiled.general6r import MAX_CANDIDATES, all_candidates, settle
        from dhkin.ik.compiled.general6r_qz import DGGEV

        starts = np.empty((MAX_CANDIDATES, 6))
        origin = np.empty(MAX_CANDIDATES, np.int64)
        info = np.empty(2)
        count = all_candidates(*self._data, self.perturbations, self.fallback, DGGEV,
                               np.ascontiguousarray(T_dh), starts, origin, info)
        roots = np.empty((count, 6))
        errors = np.empty((count, 2))
        sigmas = np.empty(count)
        band = singular_band(tolerance)
        found, failed = settle(chain, np.ascontiguousarray(tip_target), starts, origin, count,
                               self.moves, tolerance, lever, band, roots, errors, sigmas)
        return roots[:found], errors[:found], failed, sigmas[:found] <= band

    def reach(self, tolerance: float, tool: NDArray[np.float64]) -> float:
        """How far DH frame 6 may lie from DH frame 0 (m) for a pose of the point verified
        (``tool``: DH frame 6 -> that point) within ``tolerance``: the chain's links, widened
        by the tolerance at the point and its rotation over the tool's length, and FK
        rounding."""
        from dhkin.ik.core import FK_ROUNDING

        return (self.links + tolerance * (1.0 + float(np.linalg.norm(tool[:3, 3])))
                + FK_ROUNDING * self.tip_lever)

    def solve_one(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                  tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                  copies: bool = False) -> IKSolutions:
        """Every solution of one pose within the joint limits: per root its in-limit 2pi copy
        nearest ``q_seed`` (nearest 0 without one), or every copy with ``copies``. Inputs are
        checked as by the families (:class:`dhkin.ik.solver.ClosedFormSolver`); solutions are
        verified by FK at the TCP (tool0, or ``tcp``)."""
        if tcp is None and copies is False:
            fast = self._solve_fast(T, q_seed, tolerance)
            if fast is not None:
                return fast
        tolerance = check_tolerance(tolerance)
        target, projection = self._pose(T, "T")
        return self._solve(target, projection, self._seed(q_seed), tolerance, self._tip(tcp),
                           copies)

    def _solve_fast(self, T: ArrayLike, q_seed: ArrayLike | None,
                    tolerance: float) -> IKSolutions | None:
        """:meth:`solve_one` without ``tcp`` or copies in one compiled call
        (:func:`dhkin.ik.compiled.general6r.solve_pose`, the same steps as :meth:`_solve`),
        or None where the Python path must answer (an input to reject, a singular root, no
        solution)."""
        tolerance = check_tolerance(tolerance)
        try:
            target = np.ascontiguousarray(T, dtype=np.float64)
            seed = (self._zero_seed if q_seed is None
                    else np.ascontiguousarray(q_seed, dtype=np.float64))
        except (TypeError, ValueError):
            return None
        if target.shape != (4, 4) or seed.shape != (6,):
            return None
        constants = self._fast_constants.get(tolerance)
        if constants is None:
            verify = self.verification_tolerance(tolerance, self.tip_lever)
            constants = (self.reach(tolerance, self.table.tool), verify, self.tip_lever,
                         singular_band(verify), self.table.lower, self.table.upper,
                         tolerance / self.tip_lever)
            self._fast_constants[tolerance] = constants
        try:
            buffers = self._buffers.arrays
        except AttributeError:
            buffers = self._fast_buffers()
        count = self._fast_kernel(*self._data, self.perturbations, self.moves, self.fallback,
                                  self._dggev, self._base_inverse, self._tool_inverse,
                                  self.tip_chain, target, seed, *constants, *buffers)
        from dhkin.ik.compiled.general6r import FAILED, FOUND, PROJECTION, SETTLED

        out_q, out_errors, info = buffers[5], buffers[6], buffers[8]
        if count == SETTLED:  # the roots are in the buffers: the Python path finishes
            found = int(info[FOUND])
            band = constants[3]
            projected, projection = self._pose(target, "T")
            return self._answer(projected, projection, None if q_seed is None else seed,
                                tolerance, self._tip(None), False, buffers[2][:found].copy(),
                                buffers[3][:found].copy(), int(info[FAILED]),
                                buffers[4][:found] <= band)
        if count < 0:
            return None
        q = out_q[:count].copy()
        turns = np.rint(q * (1.0 / TWO_PI)).astype(np.int64).tolist()
        return IKSolutions(q=q, configurations=tuple(map(self._configuration,
                                                         map(tuple, turns))),
                           flags=(_REGULAR,) * count, residuals=out_errors[:count].copy(),
                           family=self.family, dropped=int(info[FAILED]),
                           projection=float(info[PROJECTION]))

    def _fast_buffers(self) -> tuple[NDArray[Any], ...]:
        """Per-thread work arrays of :func:`dhkin.ik.compiled.general6r.solve_pose`: starts,
        origin, roots, errors, sigmas, out_q, out_errors, kept, info."""
        from dhkin.ik.compiled.general6r import MAX_CANDIDATES

        n = MAX_CANDIDATES
        arrays = (np.empty((n, 6)), np.empty(n, np.int64), np.empty((n, 6)), np.empty((n, 2)),
                  np.empty(n), np.empty((n, 6)), np.empty((n, 2)), np.empty(n, np.int64),
                  np.empty(3))
        self._buffers.arrays = arrays
        return arrays

    @functools.cached_property
    def _fast_kernel(self) -> Callable[..., int]:
        """:func:`dhkin.ik.compiled.general6r.solve_pose`'s compiled entry point for this
        solver's argument types (numba's per-call type resolution skipped)."""
        from dhkin.ik.compiled.general6r import solve_pose
        from dhkin.ik.compiled.general6r_qz import DGGEV
        from dhkin.ik.compiled.jit import entry_point

        args = (*self._data, self.perturbations, self.moves, self.fallback, DGGEV,
                self._base_inverse, self._tool_inverse, self.tip_chain, np.eye(4),
                self._zero_seed, 1.0, DEFAULT_TOLERANCE, 1.0, 1.0, self.table.lower,
                self.table.upper, 1.0, *self._fast_buffers())
        kernel: Callable[..., int] = entry_point(solve_pose, args)
        return kernel

    def _solve(self, target: NDArray[np.float64], projection: float,
               seed: NDArray[np.float64] | None, tolerance: float,
               tip: tuple[NDArray[np.float64], NDArray[np.float64], float],
               copies: bool) -> IKSolutions:
        """:meth:`solve_one` of a checked, projected pose. The roots do not depend on the seed:
        it only chooses each root's 2pi copy and, on a curve of solutions (a singular root),
        the member nearest it."""
        from dhkin.ik.compiled.general6r import within_reach

        chain, tool_inverse, lever = tip
        tip_target = self._base_inverse @ target
        T_dh = tip_target @ tool_inverse
        reach = self.reach(tolerance, _inverse(tool_inverse))
        if not within_reach(T_dh, reach):
            largest = float(np.abs(T_dh[:3, 3]).max())
            distance = largest * float(np.linalg.norm(T_dh[:3, 3] / largest))
            return IKSolutions(q=np.zeros((0, 6)), family=self.family, projection=projection,
                               reason=f"out of reach: DH frame 6 lies {distance:.6g} m from "
                                      f"DH frame 0, farther than the chain's links reach "
                                      f"({self.links:.6g} m)")
        verify = self.verification_tolerance(tolerance, lever)
        roots, errors, failed, singular = self._settled(T_dh, tip_target, chain, verify, lever)
        return self._answer(target, projection, seed, tolerance, tip, copies, roots, errors,
                            failed, singular)

    def _answer(self, target: NDArray[np.float64], projection: float,
                seed: NDArray[np.float64] | None, tolerance: float,
                tip: tuple[NDArray[np.float64], NDArray[np.float64], float], copies: bool,
                roots: NDArray[np.float64], errors: NDArray[np.float64], failed: int,
                singular: NDArray[np.bool_]) -> IKSolutions:
        """:meth:`solve_one` of a checked, projected pose from its settled roots: the seed's
        member of each singular root, the 2pi copies, the result."""
        chain, _, lever = tip
        tip_target = self._base_inverse @ target
        verify = self.verification_tolerance(tolerance, lever)
        if seed is None:  # as in the families: without a seed, free joints are chosen near 0
            seed = np.zeros(6)
        if np.any(singular):
            keep = seed_members(roots, errors, singular, seed, chain, tip_target, verify, lever,
                                (self.table.lower, self.table.upper, tolerance / lever))
            roots, errors, singular = roots[keep], errors[keep], singular[keep]
        if roots.shape[0] == 0:
            reason = ("no real solution: the elimination found no root that verifies on the "
                      f"exact chain at tolerance {tolerance:g}")
            if failed:
                reason += f" ({failed} candidate(s) did not converge)"
            return IKSolutions(q=np.zeros((0, 6)), family=self.family, reason=reason,
                               dropped=failed, projection=projection)
        flags = [_SINGULAR if flag else _REGULAR for flag in singular]
        reference = seed
        slack = tolerance / lever
        if copies:
            lower, upper = self.table.lower, self.table.upper
            blocks = [(np.array(copies_within(lower, upper, q, reference, True, slack)
                                ).reshape(-1, 6), error, flag)
                      for q, error, flag in zip(roots, errors, flags, strict=True)]
            q_out = np.concatenate([b for b, _, _ in blocks])
            residuals = np.concatenate([np.tile(e, (b.shape[0], 1)) for b, e, _ in blocks])
            out_flags = [f for b, _, f in blocks for _ in range(b.shape[0])]
            q_out, residuals, out_flags = onto_limits(
                lower, upper, q_out, residuals, out_flags, chain, tip_target,
                self.verification_tolerance(tolerance, lever), lever)
        else:
            from dhkin.ik.compiled.general6r import nearest_copies

            found = roots.shape[0]
            q_out, residuals = np.empty((found, 6)), np.empty((found, 2))
            kept = np.empty(found, np.int64)
            count = nearest_copies(chain, tip_target, roots, errors, found, reference,
                                   self.table.lower, self.table.upper, slack,
                                   verify, lever, np.ascontiguousarray(singular),
                                   singular_band(verify), q_out, residuals, kept)
            q_out, residuals = q_out[:count], residuals[:count]
            out_flags = [flags[k] for k in kept[:count].tolist()]
            if any(out_flags):  # singular members set onto a limit may meet: one root
                distinct = distinct_rows(q_out, [bool(f) for f in out_flags], chain,
                                         tip_target, verify)
                q_out, residuals = q_out[distinct], residuals[distinct]
                out_flags = [out_flags[k] for k in np.flatnonzero(distinct)]
        if q_out.shape[0] == 0:
            return IKSolutions(q=np.zeros((0, 6)), family=self.family, projection=projection,
                               dropped=failed,
                               reason=f"{roots.shape[0]} solution(s) verified, but no 2pi copy "
                                      "of any lies within the joint limits")
        turns = np.rint(q_out / TWO_PI).astype(np.int64).tolist()
        configurations = tuple(self._configuration(tuple(t)) for t in turns)
        return IKSolutions(q=q_out, configurations=configurations, flags=tuple(out_flags),
                           residuals=residuals, family=self.family, dropped=failed,
                           projection=projection)

    def solve_batch(self, T: ArrayLike, q_seed: ArrayLike | None = None,
                    tolerance: float = DEFAULT_TOLERANCE, tcp: ArrayLike | None = None,
                    copies: bool = False, chunk_size: int = 65536,
                    workers: int | None = None) -> IKBatch:
        """:meth:`solve_one` pose by pose (a loop: ``chunk_size`` and ``workers`` are accepted
        for the families' signature and checked, but do not apply), padded to the largest
        count; ``q_seed`` (6,) or (N, 6). ``branch`` is 0 for every solution (the general
        solver has one branch label set, empty: its roots have no family labels)."""
        from dhkin.ik.inputs import _check_chunk
        from dhkin.ik.workers import check_workers

        tolerance = check_tolerance(tolerance)
        _check_chunk(chunk_size)
        check_workers(workers)
        targets, _ = as_targets(T)
        n_poses = targets.shape[0]
        seeds: list[NDArray[np.float64] | None]
        if q_seed is None:
            seeds = [None] * n_poses
        else:
            array = np.asarray(q_seed, dtype=float)
            if array.shape == (6,):
                array = array[None]
            if array.shape not in ((1, 6), (n_poses, 6)) or not np.all(np.isfinite(array)):
                raise InputError(f"q_seed: expected finite values of shape (6,) or "
                                 f"({n_poses}, 6), got shape {np.shape(q_seed)}",
                                 field="q_seed")
            seeds = [array[0]] * n_poses if array.shape[0] == 1 else list(array)
        tip = self._tip(tcp)
        results = []
        fast = tcp is None and copies is False
        for index in range(n_poses):
            result = self._solve_fast(targets[index], seeds[index], tolerance) if fast else None
            if result is None:
                target, projection = self._pose(targets[index], f"T[{index}]")
                result = self._solve(target, projection, seeds[index], tolerance, tip, copies)
            results.append(result)
        return pack(results, self.branch_labels, self.family)

    def _configuration(self, turns: tuple[int, ...]) -> Configuration:
        found = self._configurations.get(turns)
        if found is None:
            found = Configuration(labels=self.branch_labels[0], turns=turns)
            self._configurations[turns] = found
        return found

_REGULAR: frozenset[str] = frozenset()
_SINGULAR: frozenset[str] = frozenset({"singular"})


