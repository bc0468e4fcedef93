"""Numerical IK: one task (target, mode, weights), the Pinocchio chain it is solved on (and its
parts for the compiled descent), and the banks of start configurations.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from dhkin import _core
from dhkin.errors import URDFError
from dhkin.ik.numerical.settings import _WARM_START_ROTATION_WEIGHT, Mode, _is_revolute
from dhkin.reference import Reference


@dataclass
class _Task:
    """One prepared target: what the descent evaluates, in the model's world frame."""

    mode: Mode
    rows: int                                   # task rows: 6 pose, 3 position, 2 planar
    world_target: pin.SE3                       # pose: world -> target frame
    target_inverse: pin.SE3                     # pose: its inverse
    world_point: NDArray[np.float64]            # position: target point in the world
    base_rotation_t: NDArray[np.float64] | None  # position: world -> base axes (None: same)
    tcp: pin.SE3 | None                         # tip -> TCP (None: the tip itself)
    preferred: NDArray[np.float64] | None = None  # null-space target, when redundant
    weights: NDArray[np.float64] | None = None    # null-space weights per joint
    compiled: _core.NumericalTask | None = None   # the above for the core, once preferred is set

    def core(self) -> _core.NumericalTask:
        """The task as the compiled descent takes it (built on first use, after
        ``preferred``/``weights`` are set)."""
        if self.compiled is None:
            tcp = None
            if self.mode == "position" and self.tcp is not None:
                tcp = np.array(self.tcp.translation)
            self.compiled = _core.NumericalTask(
                self.mode == "pose", self.rows, self.target_inverse.homogeneous,
                np.asarray(self.world_point, dtype=float), self.base_rotation_t, tcp,
                self.preferred, self.weights)
        return self.compiled


@dataclass
class _Chain:
    """Pinocchio model of the chain, with the fast mapping chain q -> configuration."""

    model: pin.Model
    data: pin.Data
    tip_id: int
    world_from_base: pin.SE3
    dof: int
    direct: bool
    neutral: NDArray[np.float64]
    index_q: NDArray[np.intp]                 # nq = 1 joints: config index, chain position
    chain_q: NDArray[np.intp]
    index_cos: NDArray[np.intp]               # continuous joints: cos/sin slots, chain position
    chain_continuous: NDArray[np.intp]
    index_v: NDArray[np.intp]
    velocity_direct: bool

    @classmethod
    def of(cls, reference: Reference) -> _Chain:
        model = reference.model
        data = model.createData()
        joints = [model.joints[j] for j in reference.chain]
        continuous = [jm.nq == 2 for jm in joints]
        neutral = pin.neutral(model)
        world_from_base = pin.SE3.Identity()
        if reference.base is not None:
            pin.framesForwardKinematics(model, data, neutral)
            world_from_base = pin.SE3(data.oMf[reference.frame_id(reference.base)])
        index_v = np.array([jm.idx_v for jm in joints], dtype=np.intp)
        dof = len(joints)
        plain = [k for k, c in enumerate(continuous) if not c]
        turning = [k for k, c in enumerate(continuous) if c]
        return cls(
            model=model, data=data, tip_id=reference.frame_id(reference.tip),
            world_from_base=world_from_base, dof=dof,
            direct=(model.nq == dof and not turning
                    and [jm.idx_q for jm in joints] == list(range(dof))),
            neutral=neutral,
            index_q=np.array([joints[k].idx_q for k in plain], dtype=np.intp),
            chain_q=np.array(plain, dtype=np.intp),
            index_cos=np.array([joints[k].idx_q for k in turning], dtype=np.intp),
            chain_continuous=np.array(turning, dtype=np.intp),
            velocity_direct=(model.nv == dof and index_v.tolist() == list(range(dof))),
            index_v=index_v,
        )

    def configuration(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """Chain q (dof,) -> Pinocchio configuration (nq,), joints off the chain at neutral."""
        if self.direct:
            return q
        config = self.neutral.copy()
        config[self.index_q] = q[self.chain_q]
        if self.index_cos.size:
            angles = q[self.chain_continuous]
            config[self.index_cos] = np.cos(angles)
            config[self.index_cos + 1] = np.sin(angles)
        return config

    def update(self, q: NDArray[np.float64]) -> pin.SE3:
        """Kinematics and joint Jacobians at q; returns the tip placement (a live reference)."""
        pin.computeJointJacobians(self.model, self.data, self.configuration(q))
        pin.updateFramePlacement(self.model, self.data, self.tip_id)
        return self.data.oMf[self.tip_id]

    def tip_jacobian(self, frame: pin.ReferenceFrame) -> NDArray[np.float64]:
        """6 x dof Jacobian of the tip after :meth:`update`, chain-order columns."""
        # Pinocchio hands a one-column Jacobian (nv = 1) back as a vector: keep it 6 x nv.
        J = np.reshape(pin.getFrameJacobian(self.model, self.data, self.tip_id, frame),
                       (6, self.model.nv))
        return J if self.velocity_direct else J[:, self.index_v]

    def parts(self, chain: list[int], source: str) -> dict[str, NDArray[Any]]:
        """The chain world -> tip as ``T(q) = P_1 Z_1(v_1) ... P_n Z_n(v_n) P_tail``
        (cpp/dhkin/chain.hpp) from the Pinocchio model: joint j's placement in its parent with a
        rotation A_j taking z to its axis appended (A_j^T of the previous joint prepended), Z_j a
        turn about / slide along z by ``v_j = direction_j q_j`` (direction -1 for an axis along a
        negative coordinate axis, so that A_j stays a permutation of the axes). The placement of
        the first joint's parent (joints off the chain at neutral) leads P_1; the tip frame's
        placement in the last joint ends P_tail. Arguments for ``_core.NumericalChain``.
        URDFError for a chain joint that neither turns about nor slides along one axis."""
        model, data = self.model, self.model.createData()
        pin.forwardKinematics(model, data, self.neutral)
        dof = len(chain)
        before = np.zeros((dof, 4, 4))
        revolute = np.zeros(dof, dtype=bool)
        direction = np.ones(dof)
        undo = pin.SE3.Identity()  # A^T of the previous joint
        for k, joint_id in enumerate(chain):
            joint = model.joints[joint_id]
            placement = model.jointPlacements[joint_id]
            if k == 0:
                placement = data.oMi[model.parents[joint_id]] * placement
            axis, revolute[k] = _joint_axis(joint, model.names[joint_id], source)
            align, direction[k] = _z_to(axis)
            before[k] = (undo * placement * pin.SE3(align, np.zeros(3))).homogeneous
            undo = pin.SE3(align.T.copy(), np.zeros(3))
        tail = (undo * model.frames[self.tip_id].placement).homogeneous
        return {"before": before, "revolute": revolute, "direction": direction,
                "offset": np.zeros(dof), "tail": tail}

    def compiled(self, reference: Reference, lower: NDArray[np.float64],
                 upper: NDArray[np.float64]) -> _core.NumericalChain:
        """The compiled descent's chain (:meth:`parts`) with the joint limits (dof,)."""
        parts = self.parts(reference.chain, reference.source)
        return _core.NumericalChain(parts["before"], parts["revolute"], parts["direction"],
                                    parts["offset"], parts["tail"], lower, upper)

    def tip_placement(self, q: NDArray[np.float64]) -> pin.SE3:
        """World -> tip at q (a copy)."""
        pin.forwardKinematics(self.model, self.data, self.configuration(q))
        return pin.SE3(pin.updateFramePlacement(self.model, self.data, self.tip_id))


def _joint_axis(joint: pin.JointModel, name: str, source: str) -> tuple[NDArray[np.float64], bool]:
    """(unit axis in the joint's frame, whether it turns) of a one-degree-of-freedom joint, from
    its motion subspace S = [v; w] at neutral: a turn about an axis through the joint's origin
    (v = 0) or a slide along one (w = 0)."""
    if joint.nv != 1:
        raise URDFError(f"{source}: joint {name!r} ({joint.shortname()}) moves in {joint.nv} "
                        f"directions; the numerical IK drives one-axis joints")
    data = joint.createData()
    configuration = np.zeros(joint.nq)
    configuration[0] = 1.0 if joint.nq == 2 else 0.0  # a continuous joint's (cos, sin) at 0
    joint.calc(data, configuration)
    motion = np.asarray(data.S, dtype=float).reshape(6)
    revolute = _is_revolute(joint)
    axis, rest = (motion[3:], motion[:3]) if revolute else (motion[:3], motion[3:])
    if rest.any() or not axis.any():
        raise URDFError(f"{source}: joint {name!r} ({joint.shortname()}) neither turns about nor "
                        f"slides along one axis; the numerical IK drives revolute, continuous "
                        f"and prismatic joints")
    return axis / np.linalg.norm(axis), revolute


#: Rotations whose third column is a coordinate axis (x, y, z): permutations, exact.
_AXIS_ALIGNMENTS = (np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
                    np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]),
                    np.eye(3))


def _z_to(axis: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
    """(A, sign): a rotation A with A z = sign axis. For +-a coordinate axis A permutes the axes
    and sign is +-1 (no rounding); otherwise A is an orthonormal frame built around the axis and
    sign is 1."""
    for k in range(3):
        if axis[k] in (1.0, -1.0) and not np.delete(axis, k).any():
            return _AXIS_ALIGNMENTS[k].copy(), float(axis[k])
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    x = np.cross(helper, axis)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(axis, x), axis]), 1.0


class _StartBank:
    """Random starts of one int seed, drawn once and kept (grows on demand)."""

    def __init__(self, generator: np.random.Generator, low: NDArray[np.float64],
                 high: NDArray[np.float64]) -> None:
        self._generator, self._low, self._high = generator, low, high
        self.starts: list[NDArray[np.float64]] = []
        self.grow(16)

    def grow(self, count: int) -> None:
        draws = self._generator.uniform(self._low, self._high, size=(count, self._low.size))
        self.starts.extend(draws)


class _WarmStarts:
    """A fixed table of configurations with their tip poses (world frame), to pick a start
    near a target: distance |p - p_target|^2 + L^2 (3 - trace(R^T R_target)), where
    3 - trace = 2 (1 - cos angle) ~ angle^2 and L = 0.3 x the largest tip distance seen."""

    def __init__(self, q: NDArray[np.float64], positions: NDArray[np.float64],
                 rotations: NDArray[np.float64]) -> None:
        self.q, self.positions = q, positions
        self.rotations = rotations.reshape(len(q), 9)
        reach = float(np.sqrt((positions * positions).sum(axis=1)).max())
        self.weight = (_WARM_START_ROTATION_WEIGHT * reach) ** 2

    def nearest(self, task: _Task) -> NDArray[np.float64]:
        if task.mode == "pose":
            target = task.world_target
            offset = self.positions - target.translation
            distance = (offset * offset).sum(axis=1)
            distance += self.weight * (3.0 - self.rotations @ target.rotation.reshape(9))
        else:
            offset = self.positions - task.world_point
            if task.base_rotation_t is not None:
                offset = offset @ task.base_rotation_t.T
            offset = offset[:, :task.rows]
            distance = (offset * offset).sum(axis=1)
        return self.q[int(np.argmin(distance))]
