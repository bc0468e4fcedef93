"""Pinocchio-backed reference (the oracle): forward kinematics, Jacobians and manipulability.

A :class:`Reference` wraps a Pinocchio model built from URDF text. Joint vectors are given in
*chain order*: the actuated joints on the path from the root to ``tip``, base to tip, one value
each (radians or metres). Continuous joints (Pinocchio stores cos/sin, nq = 2, nv = 1) and joints
off the chain are handled by the mapping, so a vendor URDF with other link names and fixed frames
can be driven with the same 6-vector as a DH table.

Poses are ``base -> frame`` 4x4 transforms, where ``base`` is a frame of the model (default: the
root link, which Pinocchio calls the universe).

:meth:`Reference.joint_properties` reads the chain's joints as Pinocchio parsed them: name, type
(revolute, continuous, prismatic), position limits and velocity limit, in chain order.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from dhkin.description import UrdfOutline, outline_urdf
from dhkin.dh import joint_batch, joint_vector
from dhkin.errors import InputError, URDFError

ReferenceFrameName = Literal["local", "world", "local_world_aligned"]
REFERENCE_FRAMES: dict[str, pin.ReferenceFrame] = {
    "local": pin.ReferenceFrame.LOCAL,
    "world": pin.ReferenceFrame.WORLD,
    "local_world_aligned": pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
}


#: Pinocchio joint models (``shortname()``) -> URDF joint type. A continuous joint is a revolute
#: joint without bounds ("RUB": nq 2, cos/sin). Any other model keeps its Pinocchio name.
JOINT_TYPES_BY_MODEL: dict[str, str] = {
    **{f"JointModelR{axis}": "revolute" for axis in "XYZ"},
    "JointModelRevoluteUnaligned": "revolute",
    **{f"JointModelRUB{axis}": "continuous" for axis in "XYZ"},
    "JointModelRevoluteUnboundedUnaligned": "continuous",
    **{f"JointModelP{axis}": "prismatic" for axis in "XYZ"},
    "JointModelPrismaticUnaligned": "prismatic",
}


@dataclass(frozen=True)
class JointProperties:
    """One actuated joint as a description states it (SI: rad or m, rad/s or m/s).

    ``type`` is "revolute", "continuous" or "prismatic" (another Pinocchio joint model keeps its
    name, e.g. "JointModelPlanar"). ``lower``/``upper`` are None where the joint has no position
    limits (continuous). ``velocity`` is None where none is stated: a URDF continuous joint
    without ``<limit>`` (Pinocchio: inf) or a velocity of 0, which no moving joint can have (a
    DH table without ``velocity`` writes 0 into its URDF).
    """

    name: str
    type: str
    lower: float | None
    upper: float | None
    velocity: float | None


def stated_velocity(value: float) -> float | None:
    """A velocity limit as stated, or None for "not stated" (0 or inf; see JointProperties)."""
    return None if value == 0.0 or not np.isfinite(value) else float(value)


@dataclass(frozen=True)
class Manipulability:
    """Manipulability measures of a 6xn Jacobian (in LOCAL_WORLD_ALIGNED at the frame origin).

    ``yoshikawa`` = sqrt(det(J J^T)) (= ``|det J|`` for a square J); ``translational`` and
    ``rotational`` use the linear (rows 0-2) and angular (rows 3-5) blocks. ``singular_values`` are
    sorted descending; ``condition`` = sigma_max / sigma_min (inf at a singularity). Linear rows
    are in m/rad (m per unit joint value) and angular rows in rad/rad, so the singular values mix
    units; they are meaningful for rank and distance-to-singularity, not as one physical quantity.
    """

    yoshikawa: float
    translational: float
    rotational: float
    singular_values: NDArray[np.float64]
    sigma_min: float
    condition: float


class Reference:
    """Pinocchio model of a URDF, driven through the actuated joints of one chain."""

    def __init__(self, urdf_text: str, tip: str = "tool0", base: str | None = None,
                 source: str = "<urdf>") -> None:
        if not isinstance(urdf_text, str):
            raise InputError(f"urdf_text: expected the URDF as text (str), got "
                             f"{type(urdf_text).__name__}", field="urdf_text",
                             value=type(urdf_text).__name__, expected="str")
        #: The links and joints as written (checked to form one tree before Pinocchio reads it).
        self.outline: UrdfOutline = outline_urdf(urdf_text, source)
        with _captured_stderr() as urdfdom_report:
            try:
                self.model = pin.buildModelFromXML(urdf_text)
            except Exception as exc:
                failure: Exception | None = exc
            else:
                failure = None
        if failure is not None:
            raise URDFError(f"{source}: Pinocchio cannot build a model "
                            f"({_urdfdom_cause(urdfdom_report) or failure})") from failure
        self.data = self.model.createData()
        self.source = source
        self.tip = tip
        self._tip_id = self.frame_id(tip)
        self.base = base
        self._base_id = None if base is None else self.frame_id(base)
        self.chain = self._chain_to(self._tip_id)
        joints = [self.model.joints[j] for j in self.chain]
        self.joint_names = [self.model.names[j] for j in self.chain]
        self._idx_q = [jm.idx_q for jm in joints]
        self._idx_v = [jm.idx_v for jm in joints]
        self._continuous = [jm.nq == 2 for jm in joints]
        # Fast path: the chain is the whole configuration, in order (true of generated URDFs).
        self._direct = (self.model.nq == self.dof and self._idx_q == list(range(self.dof))
                        and not any(self._continuous))

    @property
    def dof(self) -> int:
        return len(self.chain)

    def joint_properties(self) -> list[JointProperties]:
        """Name, type, position limits and velocity limit of each chain joint, base to tip, as
        Pinocchio read them from the URDF (``model.lowerPositionLimit``, ``upperPositionLimit``,
        ``velocityLimit``; continuous joints: no position limits)."""
        properties = []
        for j, name in zip(self.chain, self.joint_names, strict=True):
            joint = self.model.joints[j]
            kind = JOINT_TYPES_BY_MODEL.get(joint.shortname(), joint.shortname())
            bounded = kind != "continuous" and joint.nq == 1
            lower = float(self.model.lowerPositionLimit[joint.idx_q]) if bounded else None
            upper = float(self.model.upperPositionLimit[joint.idx_q]) if bounded else None
            velocity = stated_velocity(float(self.model.velocityLimit[joint.idx_v]))
            properties.append(JointProperties(name, kind, lower, upper, velocity))
        return properties

    def frame_id(self, name: str) -> int:
        """Pinocchio frame index of ``name``; URDFError listing the frames if it does not exist
        (InputError if ``name`` is not a string)."""
        if not isinstance(name, str):
            raise InputError(f"frame: expected a frame name (str), got {name!r}", field="frame",
                             value=name, expected="a frame name")
        if not self.model.existFrame(name):
            names = sorted({f.name for f in self.model.frames})
            raise URDFError(f"{self.source}: no frame named {name!r}; expected one of {names}")
        return self.model.getFrameId(name)

    def _chain_to(self, frame_id: int) -> list[int]:
        joint = self.model.frames[frame_id].parentJoint
        chain = []
        while joint > 0:
            if self.model.joints[joint].nv > 0:
                chain.append(joint)
            joint = self.model.parents[joint]
        if self._base_id is not None:
            base_joint = self.model.frames[self._base_id].parentJoint
            ancestors = set()
            j = base_joint
            while j > 0:
                ancestors.add(j)
                j = self.model.parents[j]
            chain = [j for j in chain if j not in ancestors]
        return chain[::-1]

    def configuration(self, q: ArrayLike) -> NDArray[np.float64]:
        """Chain-order joint vector (dof,) -> Pinocchio configuration (nq,); InputError unless
        ``q`` is ``dof`` finite numbers."""
        return self._configurations(joint_vector(q, self.dof)[None])[0]

    def configurations(self, q: ArrayLike) -> NDArray[np.float64]:
        """Chain-order joint vectors (N, dof) -> Pinocchio configurations (N, nq), checked once
        for the whole batch (a sweep's loop then calls Pinocchio on each row without checking
        it again); InputError unless ``q`` is (N, dof) or (dof,) finite numbers."""
        Q, _ = joint_batch(q, self.dof)
        return self._configurations(Q)

    def _configurations(self, Q: NDArray[np.float64]) -> NDArray[np.float64]:
        """Checked joint vectors (N, dof) -> configurations (N, nq): a continuous joint's value
        as (cos, sin), the others as they are, joints outside the chain at neutral."""
        if self._direct:
            return Q
        config = np.repeat(pin.neutral(self.model)[None], len(Q), axis=0)
        for column, (idx, continuous) in enumerate(zip(self._idx_q, self._continuous,
                                                       strict=True)):
            if continuous:
                config[:, idx] = np.cos(Q[:, column])
                config[:, idx + 1] = np.sin(Q[:, column])
            else:
                config[:, idx] = Q[:, column]
        return config

    def fk(self, q: ArrayLike, frame: str | None = None) -> NDArray[np.float64]:
        """Pose base -> ``frame`` (default: tip). q: (dof,) -> (4, 4); (N, dof) -> (N, 4, 4)."""
        frame_id = self._tip_id if frame is None else self.frame_id(frame)
        Q, single = joint_batch(q, self.dof)
        model, data, base_id = self.model, self.data, self._base_id
        # Joint placements, then only the frames asked for (not every frame of the model). The
        # loop runs once per row (millions of rows in the tests' oracle checks): Pinocchio's
        # functions bound once, each row's 4 x 4 collected in a list and stacked at the end
        # (one numpy copy instead of an indexed assignment per row); the same placements.
        forward_kinematics, frame_placement = pin.forwardKinematics, pin.updateFramePlacement
        poses: list[NDArray[np.float64]] = []
        keep = poses.append
        for config in self._configurations(Q):
            forward_kinematics(model, data, config)
            placement = frame_placement(model, data, frame_id)
            if base_id is not None:
                placement = frame_placement(model, data, base_id).inverse() * placement
            keep(placement.homogeneous)
        out = np.array(poses) if poses else np.empty((0, 4, 4))
        return out[0] if single else out

    def jacobian(self, q: ArrayLike, frame: str | None = None,
                 reference: ReferenceFrameName = "local_world_aligned") -> NDArray[np.float64]:
        """6 x dof frame Jacobian [linear; angular], columns in chain order.

        ``reference`` says in which frame the spatial velocity of ``frame`` is expressed:

        * ``"local"``: in the frame itself, at its origin (body velocity);
        * ``"world"``: in the world (root) frame, as the velocity of the point of the moving body
          that coincides with the world origin (spatial velocity);
        * ``"local_world_aligned"``: linear velocity of the frame's origin and angular velocity,
          both along the world axes (what a Cartesian controller usually wants).

        The "world" is the ``base`` frame when one was given (the frame :meth:`fk` poses are
        relative to), else the root link.
        """
        _check_reference_frame(reference)
        frame_id = self._tip_id if frame is None else self.frame_id(frame)
        return self._jacobian(self.configuration(q), frame_id, reference)

    def jacobians(self, q: ArrayLike, frame: str | None = None,
                  reference: ReferenceFrameName = "local_world_aligned") -> NDArray[np.float64]:
        """:meth:`jacobian` of each row of ``q`` (N, dof) -> (N, 6, dof), the joint values
        checked once for the whole batch."""
        _check_reference_frame(reference)
        frame_id = self._tip_id if frame is None else self.frame_id(frame)
        configs = self.configurations(q)
        out = np.empty((len(configs), 6, self.dof))
        for k, config in enumerate(configs):
            out[k] = self._jacobian(config, frame_id, reference)
        return out

    def _jacobian(self, config: NDArray[np.float64], frame_id: int,
                  reference: ReferenceFrameName) -> NDArray[np.float64]:
        """The Jacobian of :meth:`jacobian` at a Pinocchio configuration."""
        # Pinocchio hands a one-column Jacobian (nv = 1) back as a vector: keep it 6 x nv.
        J = np.reshape(pin.computeFrameJacobian(self.model, self.data, config, frame_id,
                                                REFERENCE_FRAMES[reference]),
                       (6, self.model.nv))[:, self._idx_v]
        if self._base_id is None or reference == "local":
            return J
        # Pinocchio's world is the root link: re-express in the base frame, like fk's poses.
        oMb = pin.updateFramePlacement(self.model, self.data, self._base_id)
        if reference == "world":
            return oMb.inverse().action @ J
        R_T = oMb.rotation.T
        return np.vstack([R_T @ J[:3], R_T @ J[3:]])

    def manipulability(self, q: ArrayLike, frame: str | None = None) -> Manipulability:
        """Yoshikawa measures and singular values of the LOCAL_WORLD_ALIGNED Jacobian."""
        J = self.jacobian(q, frame, "local_world_aligned")
        sigma = np.linalg.svd(J, compute_uv=False)
        sigma_min = float(sigma[-1]) if J.shape[1] >= 6 else 0.0
        return Manipulability(
            yoshikawa=_yoshikawa(J),
            translational=_yoshikawa(J[:3]),
            rotational=_yoshikawa(J[3:]),
            singular_values=np.asarray(sigma, dtype=np.float64),
            sigma_min=sigma_min,
            condition=float(sigma[0] / sigma_min) if sigma_min > 0 else float("inf"),
        )


def _check_reference_frame(reference: object) -> None:
    """InputError unless ``reference`` names one of :data:`REFERENCE_FRAMES`."""
    if not isinstance(reference, str) or reference not in REFERENCE_FRAMES:
        raise InputError(f"reference: expected one of {list(REFERENCE_FRAMES)}, "
                         f"got {reference!r}", field="reference", value=reference,
                         expected=f"one of {list(REFERENCE_FRAMES)}")


class _Report:
    """Text captured by :func:`_captured_stderr` (filled when the block ends)."""

    text = ""


@contextmanager
def _captured_stderr() -> Iterator[_Report]:
    """Capture what C++ code writes to file descriptor 2 during the block. urdfdom, which
    Pinocchio parses URDFs with, writes the cause of a failure there ("Joint [j] is of type
    REVOLUTE but it does not specify limits") and raises only "The XML stream does not contain
    a valid URDF model". Without a usable descriptor 2 the block runs uncaptured."""
    report = _Report()
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):
        yield report
        return
    with tempfile.TemporaryFile() as capture:
        os.dup2(capture.fileno(), 2)
        try:
            yield report
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            capture.seek(0)
            report.text = capture.read(65536).decode("utf-8", errors="replace")


def _urdfdom_cause(report: _Report) -> str | None:
    """urdfdom's first "Error:" line (the cause), or None."""
    for line in report.text.splitlines():
        if line.strip().startswith("Error:"):
            return line.strip().removeprefix("Error:").strip()
    return None


def _yoshikawa(J: NDArray[np.float64]) -> float:
    """sqrt(det(J J^T)) computed as the product of singular values (no squaring error)."""
    sigma = np.linalg.svd(J, compute_uv=False)
    if J.shape[0] > J.shape[1]:
        return 0.0
    return float(np.prod(sigma))
