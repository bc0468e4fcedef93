"""The validator's independent complete reference for six-revolute arms without a closed form:
every isolated root of a pose, found by Newton's method from many fixed starts, each verified
on the oracle (see :mod:`dhkin.validation.run`, ``missing_branch``).

An arm with a closed-form family is checked against its family's branches; an arm without one
(the CRX-10iA, the xArm6, tilted or calibrated six-revolute tables: ``robot.ik_family ==
"general6r"``) has no such branches, and the general 6R solver's own answer cannot be the
reference of the general 6R solver. This reference shares nothing with it but the exact chain:
Newton (``multistart``, cpp/dhkin/general6r/reference.hpp) runs on dhkin's exact chain
of the table (corrections included, equal to Pinocchio's FK to ~1e-15: ``dhkin check``'s "fk
vs pin"), from :data:`STARTS` joint vectors drawn once with a fixed seed, no elimination. Each
distinct root then verifies on the reference description (Pinocchio) at the tolerance plus its
deviation from the table, and its Jacobian there says whether it is isolated. Newton's own
error there, on the exact description, says whether it converged: a point where Newton stalls
inside the tolerance without converging is a near-root, the floor of a valley of near-solutions
(:data:`CONVERGED`), tied to the IK's solutions along that valley
(:mod:`dhkin.validation.valley`) instead of by a straight chord, and reported like a root when it
is not.

Joint values are URDF joint values (rad, chain order); poses are base_link -> tool0, metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.reference import Reference
from dhkin.transforms import pose_error
from dhkin.validation.references import TargetModel
from dhkin.validation.valley import chord_verifies, tied_along_valley

#: Starts per pose: the first points of a scrambled Halton sequence over the joint torus (fixed
#: seed), which covers it more evenly than random points. Measured (docs/general6r.md,
#: "Checking completeness") on 100 poses each of five sets (CRX-10iA random and special
#: angles, xArm6 special angles, tilted UR5 special angles and q5 = 0): of the 3,836 isolated
#: roots a 2,000-start random multistart found, 128 starts missed 15 (0.4 %), 256 missed 1;
#: 128 cost ~5 ms per pose.
STARTS = 128


#: A reference root is isolated, and must be returned, when the smallest singular value of
#: Pinocchio's Jacobian there (m and rad) is at least this. Below it a root is a fold's double
#: root or lies on a curve of solutions (a free joint): the pose fixes it only to about
#: sqrt(tolerance), and which member an IK returns is its (or its seed's) choice.
ISOLATED = 1e-6


#: A point Newton left (polished as far as the arithmetic allows) is a root when its error on
#: the exact description (Pinocchio on the generated URDF: the chain Newton solved, the target
#: made reachable or not by the reference's rounding) is at most this, m and rad: ISOLATED^2
#: = 1e-12, the issue's residual. By Kantorovich's theorem Newton from a point of error r
#: where the Jacobian's smallest singular value is sigma converges to a root once
#: r L / sigma^2 <= 1/2 (L, the Jacobian's Lipschitz constant, about the arm's reach, ~1 m):
#: at an isolated root (sigma >= ISOLATED) it then falls quadratically to the rounding, so
#: stopping above ISOLATED^2 means no root was in reach. Measured (docs/general6r.md,
#: "Near-roots"): on 400 poses each of four arms (300 special-angle, 100 random; rounded
#: reference), every converged point has an error of at most 1.4e-15 and every stall at least
#: 3.4e-11, four decades apart on either side (the exact reference leaves no stall).
CONVERGED = ISOLATED ** 2


#: Seed of the starts (fixed: a run is reproducible and the same starts serve every pose).
START_SEED = 26


#: Most distinct roots kept per pose: a six-revolute chain has at most 16 isolated roots;
#: the rest is room for the members of curves of solutions a multistart also lands on.
MAX_ROOTS = 64


def needs_reference(robot: Arm) -> bool:
    """Whether ``robot``'s completeness is judged by this reference: six revolute joints and
    no closed-form family (the general 6R solver's arms)."""
    return robot.ik_family == "general6r"


@dataclass(frozen=True)
class ReferencePoints:
    """The isolated points of a pose the multistart found, each verifying on the reference:
    ``roots`` (k, 6), where Newton converged (:data:`CONVERGED`), and ``near_roots`` (m, 6),
    where it stalled inside the tolerance."""

    roots: NDArray[np.float64]
    near_roots: NDArray[np.float64]


class RootReference:
    """Every isolated root of a pose of ``robot`` by Newton from ``starts`` fixed starts,
    verified on ``model`` (see the module docstring)."""

    def __init__(self, robot: Arm, model: TargetModel, starts: int = STARTS) -> None:
        from dhkin.ik.plan import chain_parts

        table = robot.table
        parts = chain_parts(table)
        #: The exact chain to tool0 (the point verified), by its parts (dhkin.ik.plan).
        self.before, self.direction, self.offset = (
            np.ascontiguousarray(parts[name], dtype=np.float64)
            for name in ("before", "direction", "offset"))
        self.tail = np.ascontiguousarray(parts["tail"] @ table.tool)
        self.robot = robot
        self.model = model
        #: Pinocchio on the exact generated URDF: Newton's error, whether it converged.
        self.exact = robot.reference()
        self.base_inverse = np.linalg.inv(table.base)
        from scipy.stats import qmc

        unit = qmc.Halton(robot.dof, scramble=True, seed=START_SEED).random(starts)
        self.starts = np.ascontiguousarray(np.pi * (2.0 * unit - 1.0))

    def roots(self, T: NDArray[np.float64], tolerance: float) -> NDArray[np.float64]:
        """The distinct roots (k, 6) of the pose T (base_link -> tool0): :meth:`points`'s
        ``roots``."""
        return self.points(T, tolerance).roots

    def points(self, T: NDArray[np.float64], tolerance: float) -> ReferencePoints:
        """The distinct points of the pose T (base_link -> tool0) that verify on the
        reference description at ``tolerance`` plus its deviation, are isolated
        (:data:`ISOLATED`) and have a 2pi copy within the joint limits (that copy): roots and
        near-roots (:data:`CONVERGED`)."""
        from dhkin._core import general6r_multistart

        target = np.ascontiguousarray(self.base_inverse @ T)
        allowed = tolerance + self.model.deviation
        found = np.asarray(general6r_multistart(self.before, self.direction, self.offset, self.tail,
                                                target, self.starts, allowed, len(self.starts),
                                                MAX_ROOTS))
        points = self._in_limits(found)
        if len(points):
            position, rotation = pose_error(self.model.fk(points),
                                            np.broadcast_to(T, (len(points), 4, 4)))
            points = points[(position <= allowed) & (rotation <= allowed)]
        if len(points):
            sigma = np.linalg.svd(self.model.reference.jacobians(points),
                                  compute_uv=False)[:, -1]
            points = points[sigma >= ISOLATED]
        if not len(points):
            return ReferencePoints(points, points)
        settled = converged(self.exact, T, points)
        return ReferencePoints(points[settled], points[~settled])

    def _in_limits(self, roots: NDArray[np.float64]) -> NDArray[np.float64]:
        """Each root's 2pi copy nearest the middle of the limits, those within them."""
        lower, upper = self.robot.lower, self.robot.upper
        middle = 0.5 * (lower + upper)
        shifted = roots + 2.0 * np.pi * np.rint((middle - roots) / (2.0 * np.pi))
        inside = np.all((shifted >= lower) & (shifted <= upper), axis=1)
        return shifted[inside]


def converged(exact: Reference, T: NDArray[np.float64],
              points: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether Newton converged at each point (k, 6) of the pose T: its error on ``exact``
    (Pinocchio on the generated URDF) at most :data:`CONVERGED` (m and rad)."""
    position, rotation = pose_error(exact.fk(points), np.broadcast_to(T, (len(points), 4, 4)))
    return np.asarray(np.maximum(position, rotation) <= CONVERGED)


def missing_roots(model: TargetModel, T: NDArray[np.float64], roots: NDArray[np.float64],
                  Q: NDArray[np.float64], tolerance: float, joint_tolerance: float,
                  along_valley: bool = False) -> list[tuple[NDArray[np.float64], float]]:
    """(root, distance to the closest row of Q) of each reference root (k, 6) of the pose T
    that no row of Q (the IK's solutions) is: within ``joint_tolerance`` of it (mod 2pi), or
    one root with it at the tolerance (every point a quarter, a half and three quarters of the
    way from the root to that row verifies on the reference description: the solver's merging
    rule, judged on the oracle; a double root split by rounding, or a member of the same curve
    of solutions, is one root with its halves; two distinct roots are not). With
    ``along_valley`` (near-roots: :class:`ReferencePoints`) a point the chord does not tie is
    tied to a row by a walk along the valley of near-solutions that stays within the tolerance
    (:func:`~dhkin.validation.valley.tied_along_valley`), the rows tried nearest first."""
    missing = []
    allowed = tolerance + model.deviation
    for root in roots:
        if not len(Q):
            missing.append((root, float("inf")))
            continue
        step = np.mod(Q - root + np.pi, 2.0 * np.pi) - np.pi
        distance = np.abs(step).max(axis=1)
        nearest = int(np.argmin(distance))
        if distance[nearest] <= joint_tolerance:
            continue
        if chord_verifies(model, T, root, step[nearest], allowed):
            continue
        if along_valley and any(
                tied_along_valley(model, T, root, root + step[k], allowed, joint_tolerance)
                for k in np.argsort(distance, kind="stable")):
            continue
        missing.append((root, float(distance[nearest])))
    return missing


def check_reference(model: TargetModel, reference: RootReference, T: NDArray[np.float64],
                    Q: NDArray[np.float64], tolerance: float,
                    joint_tolerance: float) -> tuple[str, str, list[str]]:
    """The IK's unseeded answer Q (its verified solutions of the pose T) against the
    multistart reference's isolated roots and near-roots: (outcome, detail, the points it
    lacks). A near-root no returned row is tied to along its valley is reported like a root,
    named as what it is."""
    points = reference.points(T, tolerance)
    lacking = [("root", *missing) for missing in missing_roots(
        model, T, points.roots, Q, tolerance, joint_tolerance)]
    lacking += [("near-root", *missing) for missing in missing_roots(
        model, T, points.near_roots, Q, tolerance, joint_tolerance, along_valley=True)]
    if not lacking:
        return "success", "", []
    names = [f"{kind} q=(" + ", ".join(f"{v:.6f}" for v in root) + ")"
             for kind, root, _ in lacking]
    return "missing_branch", (
        f"{len(lacking)} isolated point(s) of the multistart reference not returned unseeded: "
        + "; ".join(f"{name} (closest solution differs by {closest:.2e})"
                    for name, (_, _, closest) in zip(names, lacking, strict=True))), names
