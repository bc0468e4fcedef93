"""Closed-form IK of the Stanford arm class: R-R-P arm and a spherical wrist (seed 003, 4-2-1).

Conditions: joints revolute, revolute, prismatic, then three revolute joints; axis 1 perpendicular
to axis 2; the slide direction of joint 3 perpendicular to axis 2; axes 4, 5, 6 meeting in one
point (the wrist centre) with axis 4 perpendicular to 5 and 5 to 6. The slide line need not meet
axis 2, and axes 1 and 2 need not meet (shoulder offset); any joint offsets and directions,
standard or modified DH, any base and tool transform.

The method is that of :mod:`dhkin.ik.spherical_wrist` (product of exponentials from the table at
q = 0, all in DH frame 0, metres and radians) with the elbow replaced by the slide: in the arm
plane the wrist centre is ``A + t V`` turned about axis 2 (A: wrist centre at q = 0, V: the slide
direction, t = direction_3 * q3), so ``|A + t V| = |target|`` gives
``t = -A.V +- sqrt(|target|^2 - e^2)`` with e the distance of the slide line from axis 2: two
slide branches, "forward" (+) and "backward" (-). With Spong's frames (the built-in
``stanford_arm``) A = 0 and e = 0, so t = +-|target| and only "forward" fits a positive stroke.

Flags: ``wrist`` and ``shoulder`` as in the spherical-wrist family; ``elbow`` where the two slide
branches merge (the wrist centre at distance e from axis 2; with e = 0 on axis 2, where q2 is
free and comes from ``q_seed``). Labels: shoulder lefty/righty and wrist noflip/flip as in the
spherical-wrist family (seed 000 section 2), slide forward/backward.

Seed 003 writes the wrist-centre equations of 4-2-1 as ``d3 s2 = dx c1 + dy s1``,
``-d3 c2 = dz - d1``, ``d2 = dy c1 - dx s1``; with Spong's frames the second is
``d3 c2 = dz - d1`` (the wrist centre z is d1 + d3 c2), so theta2 = atan2(dx c1 + dy s1, dz - d1),
not atan2(..., d1 - dz). ``tests/test_ik_stanford.py`` checks this with Pinocchio.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.errors import FamilyError
from dhkin.ik.closed_form import Branches, CompiledSolver
from dhkin.ik.result import ELBOW
from dhkin.ik.spherical_wrist import (
    GEOMETRY_TOLERANCE,
    SINGULAR_FLAG_TOLERANCE,
    SNAP_TOLERANCE,
    Shoulder,
    Wrist,
    abs_cos,
    axis_rotation,
    compiled_geometry,
    explain_shoulder,
    frame_one_x_point,
    make_shoulder,
    make_wrist,
    shoulder_label,
    shoulder_problems,
    solve_shoulder,
    solve_wrist,
    table_scale,
    type_problems,
    wrist_centres,
    wrist_label,
    wrist_problems,
    wrist_rotations,
    zero_configuration,
)

FAMILY = "stanford"


def fit_problems(table: DHTable) -> list[str]:
    """The structural conditions of this family that ``table`` fails (empty list: it fits).

    Tolerance :data:`~dhkin.ik.spherical_wrist.GEOMETRY_TOLERANCE` (|cos|; distances times the
    table scale).
    """
    problems = type_problems(table, "RRPRRR")
    if problems:
        return problems
    axes, _ = zero_configuration(table)
    problems = wrist_problems(axes, table_scale(table)) + shoulder_problems(axes)
    cosine = abs_cos(axes[2].direction, axes[1].direction)
    if cosine > GEOMETRY_TOLERANCE:
        problems.append(f"the slide of joint 3 is not perpendicular to axis 2: |cos| = "
                        f"{cosine:.3g}, expected <= {GEOMETRY_TOLERANCE:g}")
    return problems


@dataclass(frozen=True)
class StanfordGeometry:
    """What the solver needs, derived from the table at q = 0 (DH frame 0)."""

    flange_zero: NDArray[np.float64]
    scale: float
    shoulder: Shoulder
    wrist: Wrist
    wrist_at_zero: complex  # A: wrist centre in the arm plane from axis 2 (height + 1j * reach)
    slide: complex  # V: unit slide direction in the arm plane
    arm_signs: tuple[float, float, float]  # turn1 = s1 q1, turn2 = s2 q2, t = s3 q3


def make_geometry(table: DHTable) -> StanfordGeometry:
    """The solver's geometry of a table that fits (see :func:`fit_problems`)."""
    axes, flange_zero = zero_configuration(table)
    scale = table_scale(table)
    wrist = make_wrist(table, axes, flange_zero)
    slide = axes[2].direction
    mid_stroke = 0.5 * (table.joints[2].lower + table.joints[2].upper)
    references = [wrist.centre, wrist.centre + table.joints[2].direction * mid_stroke * slide,
                  frame_one_x_point(table, axes)]
    shoulder = make_shoulder(axes, wrist.centre, references, scale)
    wrist_at_zero = shoulder.planar(wrist.centre)
    slide_planar = complex(float(np.dot(slide, shoulder.up)),
                           float(np.dot(slide, shoulder.forward)))
    directions = [table.joints[i].direction for i in range(3)]
    signs = (float(directions[0]),
             directions[1] * float(np.sign(np.dot(axes[1].direction, shoulder.lateral))),
             float(directions[2]))
    return StanfordGeometry(flange_zero, scale, shoulder, wrist, wrist_at_zero,
                            slide_planar / abs(slide_planar), signs)


@dataclass(frozen=True)
class SlideSolution:
    """Per pose and (shoulder, slide) branch (N, 2, 2): turn of axis 2 about ``lateral`` (rad),
    slide t along joint 3's axis (m), validity and the ELBOW flag."""

    turn2: NDArray[np.float64]
    slide: NDArray[np.float64]
    valid: NDArray[np.bool_]
    flags: NDArray[np.uint8]


def solve_slide(wrist_at_zero: complex, slide: complex, target: NDArray[np.complex128],
                seed_turn2: NDArray[np.float64], scale: float) -> SlideSolution:
    """Both slide branches reaching arm-plane targets (N, 2); ``seed_turn2`` (N, 1) is used
    where the wrist centre is on axis 2 (then q2 is free)."""
    along = (np.conj(slide) * wrist_at_zero).real  # A.V
    offset = abs((np.conj(slide) * wrist_at_zero).imag)  # e: slide line to axis 2
    distance = np.abs(target)
    gap = distance - offset
    snap = SNAP_TOLERANCE * scale
    reachable = gap >= -snap
    merged = np.abs(gap) <= snap
    root = np.where(merged, 0.0, np.sqrt(np.maximum(gap, 0.0) * (distance + offset)))
    t = -along + np.stack([root, -root], axis=-1)
    wrist_before_turn2 = wrist_at_zero + t * slide
    turn2 = np.angle(target[..., None] * np.conj(wrist_before_turn2))
    free = np.abs(wrist_before_turn2) <= snap
    turn2 = np.where(free, seed_turn2[..., None], turn2)
    valid = np.stack([reachable, reachable & ~merged], axis=-1)
    near = merged | (root <= SINGULAR_FLAG_TOLERANCE * scale)
    flags = np.repeat(np.where(near, ELBOW, 0)[..., None], 2, axis=-1).astype(np.uint8)
    return SlideSolution(turn2=turn2, slide=t, valid=valid, flags=flags)


class Solver(CompiledSolver):
    """Closed-form IK of one Stanford-class table (the BranchSolver of ik/closed_form.py).

    Eight branches, index ``4 * shoulder + 2 * slide + wrist``: shoulder 0 = forward side,
    slide 0 = "forward" (larger t), wrist 0 = sin(t5 + tilt) >= 0.
    """

    family = FAMILY

    def __init__(self, table: DHTable) -> None:
        problems = fit_problems(table)
        if problems:
            raise FamilyError(f"{table.name}: not a {FAMILY} arm: " + "; ".join(problems))
        self.table = table
        self.geometry = make_geometry(table)
        q5_sign_of_first_wrist = self.geometry.wrist.directions[1] > 0
        labels: list[Mapping[str, str]] = []
        for front in (True, False):
            for slide in ("forward", "backward"):
                for q5_positive in (q5_sign_of_first_wrist, not q5_sign_of_first_wrist):
                    labels.append({"shoulder": shoulder_label(front), "slide": slide,
                                   "wrist": wrist_label(front, q5_positive)})
        self.branch_labels: tuple[Mapping[str, str], ...] = tuple(labels)

    @cached_property
    def _compiled(self) -> tuple[int, NDArray[np.float64]]:
        """The compiled twin of :meth:`solve` (dhkin.ik.kernels.solve_stanford): its family
        id and geometry vector."""
        from dhkin.ik import kernels

        g = self.geometry
        along_and_offset = np.conj(g.slide) * g.wrist_at_zero
        arm = (g.wrist_at_zero.real, g.wrist_at_zero.imag, g.slide.real, g.slide.imag,
               along_and_offset.real, abs(along_and_offset.imag))
        return kernels.STANFORD, compiled_geometry(g.shoulder, g.wrist, g.flange_zero,
                                                   g.arm_signs, g.scale, arm)

    def solve_reference(self, T_dh: NDArray[np.float64], q_seed: NDArray[np.float64]
                        ) -> Branches:
        """:meth:`solve` in numpy, vectorised over N: the reference the compiled kernel follows
        (tests compare the two; they differ by rounding, and where the pose leaves joints
        ill-conditioned, e.g. q4 and q6 near q5 = 0, by as much as it allows)."""
        g = self.geometry
        n_poses = T_dh.shape[0]
        centre = wrist_centres(g.wrist, T_dh)
        s1, s2, s3 = g.arm_signs
        shoulder = solve_shoulder(g.shoulder, centre, s1 * q_seed[:, 0], g.scale)
        slide = solve_slide(g.wrist_at_zero, g.slide, shoulder.target, s2 * q_seed[:, 1, None],
                            g.scale)
        turn1 = np.repeat(shoulder.turn[:, :, None], 2, axis=2)
        arm_rotation = (axis_rotation(g.shoulder.up, turn1)
                        @ axis_rotation(g.shoulder.lateral, slide.turn2)).reshape(n_poses, 4, 3, 3)
        required = wrist_rotations(arm_rotation, T_dh, g.flange_zero)
        wrist_q, wrist_flags = solve_wrist(g.wrist, required, np.repeat(q_seed[:, 3:4], 4, 1))
        q = np.empty((n_poses, 4, 2, 6))
        q[..., 0] = (s1 * turn1).reshape(n_poses, 4)[..., None]
        q[..., 1] = (s2 * slide.turn2).reshape(n_poses, 4)[..., None]
        q[..., 2] = (s3 * slide.slide).reshape(n_poses, 4)[..., None]
        q[..., 3:] = wrist_q
        arm_valid = (shoulder.valid[:, :, None] & slide.valid).reshape(n_poses, 4, 1)
        flags = (shoulder.flags[:, :, None] | slide.flags).reshape(n_poses, 4, 1) \
            | wrist_flags[..., None]
        return Branches(q=q.reshape(n_poses, 8, 6),
                        valid=np.repeat(arm_valid, 2, axis=2).reshape(n_poses, 8),
                        flags=np.repeat(flags, 2, axis=2).reshape(n_poses, 8).astype(np.uint8))

    def explain(self, T_dh: NDArray[np.float64]) -> str:
        """Why one flange target (4, 4) has no solution.

        Besides the geometry (too close to axis 1 or to axis 2), the stroke of joint 3 is the
        arm's reach, so it is named when no slide root lies within it; "" otherwise.
        """
        g = self.geometry
        centre = wrist_centres(g.wrist, T_dh[None])[0]
        reason = explain_shoulder(g.shoulder, centre, g.scale)
        if reason:
            return reason
        shoulder = solve_shoulder(g.shoulder, centre[None], np.zeros(1), g.scale)
        slide = solve_slide(g.wrist_at_zero, g.slide, shoulder.target, np.zeros((1, 1)), g.scale)
        distance = float(np.abs(shoulder.target[0]).min())
        if not np.any(slide.valid):
            offset = abs((np.conj(g.slide) * g.wrist_at_zero).imag)
            return (f"wrist centre {distance:.4g} m from axis 2, closer than the slide line's "
                    f"distance {offset:.4g} m from it")
        joint = self.table.joints[2]
        q3 = g.arm_signs[2] * slide.slide[0][slide.valid[0]]
        inside = (q3 >= joint.lower - 1e-10) & (q3 <= joint.upper + 1e-10)
        if np.any(inside):
            return ""
        needed = ", ".join(f"{v:.4g}" for v in sorted(set(np.round(q3, 6))))
        return (f"wrist centre {distance:.4g} m from axis 2 needs joint 3 at {needed} m, "
                f"outside its stroke {joint.lower:.4g}..{joint.upper:.4g} m")
