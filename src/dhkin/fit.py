"""Fit a nominal DH table to another description of the same arm: base, per-joint corrections
and tool such that the table's FK equals the description's for every q.

A vendor URDF with rounded constants (pi/2 written as 1.570796) or a calibrated robot has no
exact plain DH table, but it has an exact *corrected* one (README, "The DH table file":
``correction``): its nominal DH rows, each followed by a small constant transform C_i.
:func:`fit_corrections` finds the smallest such C_i in closed form.

The math. The URDF chain (read with Pinocchio at q = 0, in the frame ``base``) is
``T(q) = O_1 M_1(q_1) O_2 M_2(q_2) ... O_n M_n(q_n) O_tip``, with O_i the constant transform from
joint i-1's frame to joint i's frame (fixed joints folded in) and M_i the motion about (or along)
joint i's axis u_i. Every table row splits as ``A_i = B_i Mz_i(q_i) E_i`` around its motion
Mz_i = Rz(direction_i q_i) (revolute) or Tz(direction_i q_i) (prismatic)::

    standard, revolute:   B = I               E = Rz(offset) Tz(d) Tx(a) Rx(alpha)
    standard, prismatic:  B = I               E = Rz(theta) Tz(offset) Tx(a) Rx(alpha)
    modified, revolute:   B = Rx(alpha) Tx(a) E = Rz(offset) Tz(d)
    modified, prismatic:  B = Rx(alpha) Tx(a) E = Rz(theta) Tz(offset)

Both chains agree for every q exactly when the frame just before each table motion is the URDF
joint frame times a constant K_i that carries the table's motion onto the URDF's:
``K_i Mz_i(q) K_i^-1 = M_i(q)``, i.e. K_i turns z into direction_i * u_i and (revolute) has its
origin on the axis. K_i = K0_i Rz(phi_i) Tz(t_i) keeps two free parameters. Then::

    base = O_1 K_1 B_1^-1
    C_i  = (K_i E_i)^-1 O_{i+1} K_{i+1} B_{i+1}^-1          (i = 1 .. n-1)
    C_n  = I,  tool = (K_n E_n)^-1 O_tip

phi_1, t_1 make the base closest to the nominal table's base; phi_{i+1}, t_{i+1} make C_i
closest to the identity (phi from the rotation's twist about z, then t from the translation along
the axis), so each correction holds only what the nominal table cannot express. The flange keeps
its nominal relation to tool0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from dhkin.description import read_urdf_file
from dhkin.dh import DHTable, Joint
from dhkin.errors import DHError, URDFError
from dhkin.reference import Reference
from dhkin.table_file import exact_rpy
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import (
    invert,
    pose_error,
    rot_x,
    rot_z,
    rotation_angle,
    translation,
    xyz_rpy_to_matrix,
)

#: Largest correction :func:`fit_corrections` accepts before it blames the nominal table.
MAX_CORRECTION_TRANSLATION = 0.01  # m
MAX_CORRECTION_ROTATION = 0.1  # rad
#: The fitted table must reproduce the description to this (m and rad) on random joint values.
#: Components of fitted transforms below this (m or rad) are rounding noise and written as 0.
NOISE = 1e-15
_AXIS_TOLERANCE = 1e-9


@dataclass(frozen=True)
class URDFChain:
    """The actuated chain of a URDF from ``base`` to ``tip`` at q = 0.

    ``frames[i]``: joint i's frame (base -> joint frame, 4x4); ``axes[i]``: its unit axis in that
    frame; ``revolute[i]``: revolute (else prismatic); ``tip``: base -> tip (4x4).
    """

    source: str
    base: str
    tip_name: str
    joint_names: tuple[str, ...]
    frames: NDArray[np.float64]
    axes: NDArray[np.float64]
    revolute: tuple[bool, ...]
    tip: NDArray[np.float64]
    reference: Reference

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    def axis_lines(self, q: ArrayLike | None = None
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Points (n, 3) and unit directions (n, 3) of the joint axes at q (chain order, default
        0), in ``base``."""
        frames = self.frames if q is None else self._joint_frames(q)
        return frames[:, :3, 3].copy(), np.einsum("nij,nj->ni", frames[:, :3, :3], self.axes)

    def _joint_frames(self, q: ArrayLike) -> NDArray[np.float64]:
        reference = self.reference
        model, data = reference.model, reference.data
        pin.forwardKinematics(model, data, reference.configuration(np.asarray(q, dtype=float)))
        base = pin.updateFramePlacement(model, data, reference.frame_id(self.base)).inverse()
        return np.array([(base * data.oMi[joint_id]).homogeneous for joint_id in reference.chain])


def read_chain(urdf: str | Path, base: str, tip: str, source: str | None = None) -> URDFChain:
    """Read the chain ``base`` -> ``tip`` of a URDF (a path, or the URDF text) with Pinocchio;
    ``source`` names the file in messages (default: the path, or "<urdf>" for text)."""
    text, default_source = _urdf_text(urdf)
    source = default_source if source is None else source
    reference = Reference(text, tip=tip, base=base, source=source)
    model, data = reference.model, reference.data
    config = reference.configuration(np.zeros(reference.dof))
    pin.computeJointJacobians(model, data, config)
    pin.updateFramePlacements(model, data)
    base_inverse = data.oMf[reference.frame_id(base)].inverse()
    frames, axes, revolute = [], [], []
    for joint_id, name in zip(reference.chain, reference.joint_names, strict=True):
        frames.append((base_inverse * data.oMi[joint_id]).homogeneous)
        column = model.joints[joint_id].idx_v
        jacobian = np.reshape(pin.getJointJacobian(model, data, joint_id,
                                                   pin.ReferenceFrame.LOCAL), (6, model.nv))
        motion = jacobian[:, column]  # (eigenpy hands a one-column Jacobian back as a vector)
        linear, angular = motion[:3], motion[3:]
        if np.linalg.norm(linear) <= _AXIS_TOLERANCE and np.linalg.norm(angular) > 0.5:
            axes.append(angular / np.linalg.norm(angular))
            revolute.append(True)
        elif np.linalg.norm(angular) <= _AXIS_TOLERANCE and np.linalg.norm(linear) > 0.5:
            axes.append(linear / np.linalg.norm(linear))
            revolute.append(False)
        else:
            raise URDFError(f"{source}: joint {name!r} is neither a revolute (or continuous) nor "
                            f"a prismatic joint (motion {motion.round(12).tolist()}); expected "
                            "one of those")
    tip_pose = reference.fk(np.zeros(reference.dof))
    return URDFChain(source=source, base=base, tip_name=tip,
                     joint_names=tuple(reference.joint_names), frames=np.array(frames),
                     axes=np.array(axes), revolute=tuple(revolute), tip=tip_pose,
                     reference=reference)


def fit_corrections(table: DHTable, urdf: str | Path, base: str, tip: str,
                    max_translation: float = MAX_CORRECTION_TRANSLATION,
                    max_rotation: float = MAX_CORRECTION_ROTATION) -> DHTable:
    """The table with base, per-joint corrections and tool that reproduce ``urdf`` exactly.

    ``table``: a nominal DH table (its corrections, if any, are ignored) whose joints match the
    URDF chain ``base`` -> ``tip`` in count, order and type; ``urdf``: a path or the URDF text.
    The result keeps every nominal DH value, the name, limits and flange -> tool0 relation of
    ``table``; its FK (base_link -> tool0) equals the URDF's base -> tip for every q, to ~1e-15
    per joint. Corrections are as small as the freedom allows (see the module docstring).

    Raises DHError when the chains do not match, or when a correction exceeds
    ``max_translation`` (m) or ``max_rotation`` (rad): the nominal table is then probably wrong
    (a sign, a twist, a length), and the message names the joint and the size.
    """
    return fit_to_chain(table, read_chain(urdf, base, tip), max_translation, max_rotation)


def fit_to_chain(table: DHTable, chain: URDFChain,
                 max_translation: float = MAX_CORRECTION_TRANSLATION,
                 max_rotation: float = MAX_CORRECTION_ROTATION) -> DHTable:
    """:func:`fit_corrections` on a chain already read with :func:`read_chain`."""
    nominal = table.nominal()
    _check_matching_chain(nominal, chain)
    n = nominal.dof

    splits = [_row_motion_split(nominal.convention, joint) for joint in nominal.joints]
    carriers = [_axis_carrier(chain.axes[i], joint.direction)
                for i, joint in enumerate(nominal.joints)]
    # K_1: the base closest to the nominal base.
    first, _ = splits[0]
    left = invert(nominal.base) @ chain.frames[0] @ carriers[0]
    K = carriers[0] @ _closest_z_motion(left, invert(first))
    fitted_base = chain.frames[0] @ K @ invert(first)
    corrections = []
    for i in range(n - 1):
        _, after = splits[i]
        following, _ = splits[i + 1]
        step = invert(chain.frames[i]) @ chain.frames[i + 1]  # O_{i+1}
        left = invert(K @ after) @ step @ carriers[i + 1]
        Z = _closest_z_motion(left, invert(following))
        correction = left @ Z @ invert(following)
        corrections.append(correction)
        K = carriers[i + 1] @ Z
    _, after = splits[-1]
    fitted_tool = invert(K @ after) @ invert(chain.frames[-1]) @ chain.tip
    fitted_flange = fitted_tool @ invert(nominal.tool) @ nominal.flange

    joints = []
    for i, joint in enumerate(nominal.joints):
        if i < n - 1:
            _check_size(nominal, chain, i, corrections[i], max_translation, max_rotation)
            joint = replace(joint, correction=_as_correction(corrections[i]))
        joints.append(joint)
    fitted = replace(nominal, joints=tuple(joints), base=_snapped(fitted_base),
                     tool=_snapped(fitted_tool), flange=_snapped(fitted_flange), path=None)
    _verify(fitted, chain)
    return fitted


def largest_correction(table: DHTable) -> tuple[float, float]:
    """The largest correction of a table: (translation in m, rotation angle in rad)."""
    translation_sizes = [float(np.linalg.norm(j.correction[:3])) for j in table.joints]
    rotation_sizes = [float(rotation_angle(j.correction_matrix[:3, :3])) for j in table.joints]
    return max(translation_sizes, default=0.0), max(rotation_sizes, default=0.0)


# --------------------------------------------------------------------------------------------
# Structure of the axes


@dataclass(frozen=True)
class AxisRelation:
    """A relation between two joint axes (0-based ``i`` < ``j``) that the nominal table holds
    for every q, and how far the exact chain is from it.

    ``kind``: "parallel" (angle 0 or pi), "perpendicular" or "intersecting"; ``deviation``: the
    angle error (rad) or the distance between the two axes (m), measured at joint values ``q``
    (0 unless the nominal axes are parallel there: an intersection is measured where the two
    axes are furthest from parallel, e.g. q5 = 90 deg for axes 4 and 6 of a spherical wrist)."""

    i: int
    j: int
    kind: str
    deviation: float
    q: tuple[float, ...]


def axis_lines(table: DHTable, q: ArrayLike | None = None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points (n, 3) and unit directions (n, 3) of the joint axes of the table's exact chain
    (corrections included) at q (default 0), in base_link. Directions include ``direction``."""
    q = np.zeros(table.dof) if q is None else np.asarray(q, dtype=float)
    frames = table.fk_frames(q)[0]
    points, directions = [], []
    for i, joint in enumerate(table.joints):
        before, _ = _row_motion_split(table.convention, joint)
        axis_frame = frames[i] @ before
        points.append(axis_frame[:3, 3])
        directions.append(joint.direction * axis_frame[:3, 2])
    return np.array(points), np.array(directions)


def structural_relations(nominal: DHTable, exact: DHTable | URDFChain, samples: int = 20,
                         seed: int = 0, tolerance: float = DEFAULT_TOLERANCE) -> list[AxisRelation]:
    """Relations between joint axes that ``nominal`` (without its corrections) holds at every q
    (parallel, perpendicular, intersecting; checked at q = 0, at q = 90 deg on every revolute
    joint and at ``samples`` random q), with their deviation on ``exact`` (a corrected table or
    the URDF chain of the same arm). Angles are measured at q = 0."""
    ideal = nominal.nominal()
    rng = np.random.default_rng(seed)
    quarter = np.where([j.is_revolute for j in ideal.joints], math.pi / 2, 0.0)
    quarter = np.clip(quarter, ideal.lower, ideal.upper)
    Q = np.vstack([np.zeros(ideal.dof), quarter, ideal.random_q(samples, rng)])
    lines = [axis_lines(ideal, q) for q in Q]

    def exact_lines(q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return exact.axis_lines(q) if isinstance(exact, URDFChain) else axis_lines(exact, q)

    _, zero_directions = exact_lines(Q[0])
    relations = []
    for i in range(ideal.dof):
        for j in range(i + 1, ideal.dof):
            angles = np.array([_angle(d[i], d[j]) for _, d in lines])
            distances = [_line_distance(p[i], d[i], p[j], d[j]) for p, d in lines]
            if np.ptp(angles) <= tolerance:
                angle = _angle(zero_directions[i], zero_directions[j])
                for target, kind in ((0.0, "parallel"), (math.pi / 2, "perpendicular"),
                                     (math.pi, "parallel")):
                    if abs(angles[0] - target) <= tolerance:
                        relations.append(AxisRelation(i, j, kind, abs(angle - target),
                                                      tuple(Q[0])))
            if max(distances) <= tolerance and np.sin(angles).max() > 0.1:
                k = int(np.argmax(np.sin(angles)))
                points, directions = exact_lines(Q[k])
                distance = _line_distance(points[i], directions[i], points[j], directions[j])
                relations.append(AxisRelation(i, j, "intersecting", distance, tuple(Q[k])))
    return relations


def _angle(u: NDArray[np.float64], v: NDArray[np.float64]) -> float:
    return float(np.arctan2(np.linalg.norm(np.cross(u, v)), np.dot(u, v)))


def _line_distance(p: NDArray[np.float64], u: NDArray[np.float64], r: NDArray[np.float64],
                   v: NDArray[np.float64]) -> float:
    normal = np.cross(u, v)
    size = np.linalg.norm(normal)
    if size <= 1e-12:
        return float(np.linalg.norm(np.cross(r - p, u)))
    return float(abs(np.dot(r - p, normal)) / size)


# --------------------------------------------------------------------------------------------
# Helpers


def _urdf_text(urdf: str | Path) -> tuple[str, str]:
    if isinstance(urdf, str) and urdf.lstrip().startswith("<"):
        return urdf, "<urdf>"
    path = Path(urdf)
    return read_urdf_file(path), str(path)


def _check_matching_chain(table: DHTable, chain: URDFChain) -> None:
    where = table.path if table.path is not None else table.name
    if chain.dof != table.dof:
        raise DHError(f"{where}: the table has {table.dof} joints, the chain {chain.base} -> "
                      f"{chain.tip_name} of {chain.source} has {chain.dof} "
                      f"{list(chain.joint_names)}; expected the same joints")
    for i, (joint, revolute) in enumerate(zip(table.joints, chain.revolute, strict=True)):
        if joint.is_revolute != revolute:
            kind = "revolute" if revolute else "prismatic"
            raise DHError(f"{where}: joints[{i}] ({joint.name}) is {joint.type}, but joint "
                          f"{chain.joint_names[i]!r} of {chain.source} is {kind}; expected the "
                          "same joint types in the same order")


def _row_motion_split(convention: str, joint: Joint
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(B, E) of a row: A = B @ Mz(q) @ E, with Mz the joint's motion along/about z."""
    if joint.is_revolute:
        tail = rot_z(joint.offset) @ translation(0, 0, joint.d)
    else:
        tail = rot_z(joint.theta) @ translation(0, 0, joint.offset)
    if convention == "standard":
        return np.eye(4), tail @ translation(joint.a, 0, 0) @ rot_x(joint.alpha)
    return rot_x(joint.alpha) @ translation(joint.a, 0, 0), tail


def _axis_carrier(axis: NDArray[np.float64], direction: int) -> NDArray[np.float64]:
    """A transform at the joint frame's origin whose z axis is ``direction * axis``."""
    z = direction * axis / np.linalg.norm(axis)
    helper = np.eye(3)[int(np.argmin(np.abs(z)))]
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    K = np.eye(4)
    K[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    return K


def _closest_z_motion(left: NDArray[np.float64], right: NDArray[np.float64]
                      ) -> NDArray[np.float64]:
    """Rz(phi) Tz(t) that makes ``left @ Rz(phi) Tz(t) @ right`` closest to the identity: phi
    minimises its rotation angle (twist of (R_right R_left)^T about z), then t its translation."""
    W = left[:3, :3].T @ right[:3, :3].T
    phi = math.atan2(W[1, 0] - W[0, 1], W[0, 0] + W[1, 1])
    V = left @ rot_z(phi)
    t = -float(right[2, 3]) - float(V[:3, 2] @ V[:3, 3])
    return rot_z(phi) @ translation(0, 0, t)


def _as_correction(C: NDArray[np.float64]) -> tuple[float, float, float, float, float, float]:
    """xyz + rpy of a transform, rounding-noise components (|v| < NOISE) set to 0."""
    values = [*(float(v) for v in C[:3, 3]), *exact_rpy(C)]
    x, y, z, roll, pitch, yaw = (0.0 if abs(v) < NOISE else v for v in values)
    return (x, y, z, roll, pitch, yaw)


def _snapped(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """T rebuilt from its xyz + rpy without rounding noise (what a table file holds)."""
    values = _as_correction(T)
    return xyz_rpy_to_matrix(values[:3], values[3:])


def _check_size(table: DHTable, chain: URDFChain, index: int, C: NDArray[np.float64],
                max_translation: float, max_rotation: float) -> None:
    shift = float(np.linalg.norm(C[:3, 3]))
    turn = float(rotation_angle(C[:3, :3]))
    if shift > max_translation or turn > max_rotation:
        where = table.path if table.path is not None else table.name
        joint = table.joints[index]
        raise DHError(f"{where}: joints[{index}].correction ({joint.name}): matching "
                      f"{chain.source} needs a correction of {shift * 1000:.4g} mm and "
                      f"{turn:.4g} rad ({math.degrees(turn):.4g} deg) after row {index + 1}; "
                      f"expected at most {max_translation * 1000:.4g} mm and {max_rotation:.4g}"
                      f" rad: are rows {index + 1} and {index + 2} of the nominal table (a, "
                      "alpha, d, offset, direction) right?")


def chain_deviation(table: DHTable, chain: URDFChain, samples: int) -> tuple[float, float]:
    """Largest (position m, rotation rad) difference between the table's FK and Pinocchio on
    the chain, over q = 0 and ``samples`` joint vectors within the table's limits (seed 0)."""
    rng = np.random.default_rng(0)
    Q = np.vstack([np.zeros(table.dof), table.random_q(samples, rng)])
    position, rotation = pose_error(table.fk(Q), chain.reference.fk(Q))
    return float(position.max()), float(rotation.max())


def _verify(table: DHTable, chain: URDFChain) -> None:
    worst = max(chain_deviation(table, chain, 200))
    if worst > DEFAULT_TOLERANCE:  # a bug, not a user error: the construction is exact
        raise DHError(f"{table.name}: the fitted table deviates from {chain.source} by "
                      f"{worst:.3e} (m or rad); expected at most {DEFAULT_TOLERANCE:.0e}")
