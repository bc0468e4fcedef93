"""DH tables: the table and its joints, link transforms and batched forward kinematics (table
files are read and written by :mod:`dhkin.table_file`).

Conventions (the file format: README, "The DH table file"; :mod:`dhkin.table_file`):

* ``standard`` (distal, Denavit-Hartenberg 1955 / Spong):
  ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``; joint i turns about z_{i-1}.
* ``modified`` (proximal, Craig): ``A_i = Rx(alpha_i) Tx(a_i) Rz(theta_i) Tz(d_i)``, where the
  table's alpha_i and a_i of row i are Craig's alpha_{i-1} and a_{i-1}; joint i turns about z_i.
* Revolute joint: ``theta_i = direction_i * q_i + offset_i``. Prismatic joint:
  ``d_i = direction_i * q_i + offset_i`` with ``theta_i`` fixed (key ``theta``).
* Correction (optional, per joint): a constant transform ``C_i = Trans(xyz) Rz(y) Ry(p) Rx(r)``
  that follows row i in both conventions, ``A_i = (DH row i) @ C_i``. Calibrated or rounded
  descriptions are written exactly this way; the table without its corrections is the robot's
  *nominal* table (:meth:`DHTable.nominal`).
* ``T(q) = base @ A_1 ... A_n @ tool``: base_link -> DH frame 0 -> DH frame n -> tool0.
* ``flange`` (optional): DH frame n -> the URDF's ``flange`` frame; default rpy (0, -90, 0) deg,
  which puts the flange's x axis along the last joint axis (ROS-Industrial). Vendors differ in
  the flange's other axes (UR: rpy (0, -90, -90)), so a table may state it.

Inside a :class:`DHTable` everything is SI: metres and radians (m/s, rad/s for velocities).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.errors import DHError, InputError
from dhkin.transforms import xyz_rpy_to_matrix

Convention = Literal["standard", "modified"]


JointType = Literal["revolute", "prismatic"]


CONVENTIONS: tuple[str, ...] = ("standard", "modified")


JOINT_TYPES: tuple[str, ...] = ("revolute", "prismatic")


LENGTH_UNITS: dict[str, float] = {"m": 1.0, "mm": 1e-3}


ANGLE_UNITS: dict[str, float] = {"rad": 1.0, "deg": math.pi / 180.0}


#: Joint vectors :meth:`DHTable.fk` computes at a time: its temporaries (the link transforms and
#: their factors, a few dozen arrays of one value per joint and vector) stay near 10 MB, a small
#: part of the result (128 bytes per vector) of any batch large enough for memory to matter.
#: Measured by scripts/bench_fk.py on 10^6 UR5 vectors: 1.95 s and a peak of 1.48 x the result
#: (the input's float copy included), against 2.5 s (1024), 2.8 s (16384) and 3.9 s and 3.0 x
#: (65536); the whole batch at once took 9.8 s and 18 x.
FK_CHUNK = 4096

#: Names the generator uses for fixed frames; a table may not give them to its own links.
RESERVED_LINK_NAMES: tuple[str, ...] = ("base_link", "base", "flange", "tool0")


def fixed_joint_names(last_link: str) -> tuple[str, str, str]:
    """Names the generator gives its fixed joints (base_link -> base, the last joint's link ->
    flange, flange -> tool0); a table may not give them to its own joints."""
    return ("base_link-base", f"{last_link}-flange", "flange-tool0")


#: Default DH frame n -> flange: x along the last joint axis (ROS-Industrial), rpy (0, -90, 0) deg.
DEFAULT_FLANGE_RPY_DEG = (0.0, -90.0, 0.0)


#: Most joints a table may have. dhkin is for serial arms: industrial arms have 6 joints, redundant
#: arms 7, an arm on a linear track or a positioner a few more; 32 covers every real arm with room,
#: and keeps every per-joint cost bounded (FK frames, the URDF, Pinocchio's model, the IK's 2pi
#: copies): 500 joints made ``reference()`` peak at 8 GB and 10^4 crashed ``dhkin fk``.
MAX_JOINTS = 32


#: Largest magnitude of a revolute joint's limits, in turns (2 turns: +-720 deg, +-4pi rad). The
#: widest real joint in robots/ and in the vendor URDFs of robots/vendor turns +-360.6 deg
#: (Motoman GP7 joint 6), datasheets go to +-400 deg (ABB wrists) and continuous joints are imported
#: as +-360 deg. The IK lists every in-limit 2pi copy of a solution: within +-2 turns a joint has at
#: most 6 copies (a 6-joint branch at most 6^6), where +-36000 deg asked for 229 TiB.
MAX_JOINT_TURNS = 2


#: Largest magnitude of any length in a table, in metres (a, d, a prismatic joint's offset and
#: limits, the xyz of base, tool, flange and corrections). The largest arms reach about 4 m and
#: linear tracks tens of metres; 1 km covers any real machine, and keeps lengths where double
#: precision still resolves the IK's 1e-9 m verification tolerance with a margin of 1000
#: (1e3 m * 2.2e-16 = 2e-13 m) and where no FK or IK product of lengths can overflow.
MAX_LENGTH = 1000.0


#: Slack of the limit checks against rounding when a table's degrees or millimetres are
#: converted (720 deg * pi / 180 may differ from 4 pi by an ulp).
_LIMIT_SLACK = 1e-9


#: A joint without a correction: (x, y, z) m, (roll, pitch, yaw) rad, all zero.
NO_CORRECTION: tuple[float, float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Joint:
    """One DH row, in SI units (m, rad).

    ``d`` is the fixed offset along z for a revolute joint; ``theta`` the fixed angle for a
    prismatic one. ``offset`` is added to the joint variable (rad for revolute, m for prismatic).
    ``lower``/``upper`` bound the joint value q (URDF convention, before direction and offset).
    ``correction`` = (x, y, z, roll, pitch, yaw) in m and rad: the constant transform
    :attr:`correction_matrix` that follows the row's DH transform (all zero: none).
    """

    name: str
    link: str
    type: JointType
    a: float
    alpha: float
    d: float
    theta: float
    offset: float
    direction: int
    lower: float
    upper: float
    velocity: float
    effort: float
    correction: tuple[float, float, float, float, float, float] = NO_CORRECTION

    @property
    def is_revolute(self) -> bool:
        return self.type == "revolute"

    @property
    def has_correction(self) -> bool:
        """Whether any component of the correction is non-zero."""
        return any(value != 0.0 for value in self.correction)

    @property
    def correction_matrix(self) -> NDArray[np.float64]:
        """C_i = Trans(x, y, z) @ Rz(yaw) Ry(pitch) Rx(roll), 4x4 (identity without one)."""
        return xyz_rpy_to_matrix(self.correction[:3], self.correction[3:])


@dataclass(frozen=True)
class DHTable:
    """A robot described by a DH table. All values SI (m, rad); transforms 4x4."""

    name: str
    convention: Convention
    joints: tuple[Joint, ...]
    base: NDArray[np.float64] = field(default_factory=lambda: np.eye(4))
    tool: NDArray[np.float64] = field(default_factory=lambda: np.eye(4))
    flange: NDArray[np.float64] = field(default_factory=lambda: _default_flange())
    description: str = ""
    source: str = ""
    path: Path | None = None

    def __post_init__(self) -> None:
        check_table_limits(self)

    @property
    def dof(self) -> int:
        return len(self.joints)

    @property
    def lower(self) -> NDArray[np.float64]:
        return np.array([j.lower for j in self.joints])

    @property
    def upper(self) -> NDArray[np.float64]:
        return np.array([j.upper for j in self.joints])

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.joints]

    @property
    def corrected(self) -> bool:
        """Whether any joint carries a correction (the table is not a plain DH table)."""
        return any(j.has_correction for j in self.joints)

    def nominal(self) -> DHTable:
        """The same table with every correction removed (the robot's nominal DH table)."""
        joints = tuple(replace(j, correction=NO_CORRECTION) for j in self.joints)
        return replace(self, joints=joints)

    def dh_parameters(self, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """theta (N, n) and d (N, n) for joint values q of shape (N, n)."""
        Q = np.asarray(q, dtype=float)
        direction = np.array([j.direction for j in self.joints], dtype=float)
        offset = np.array([j.offset for j in self.joints])
        revolute = np.array([j.is_revolute for j in self.joints])
        variable = direction * Q + offset
        theta = np.where(revolute, variable, np.array([j.theta for j in self.joints]))
        d = np.where(revolute, np.array([j.d for j in self.joints]), variable)
        return theta, d

    def link_transforms(self, q: ArrayLike) -> NDArray[np.float64]:
        """A_i(q) @ C_i for every joint (C_i: the joint's correction, identity without one):
        (N, n) joint values -> (N, n, 4, 4)."""
        Q, _ = joint_batch(q, self.dof)
        theta, d = self.dh_parameters(Q)
        a = np.array([j.a for j in self.joints])
        alpha = np.array([j.alpha for j in self.joints])
        A = dh_matrices(self.convention, theta, d, a, alpha)
        for i, joint in enumerate(self.joints):
            if joint.has_correction:
                A[:, i] = A[:, i] @ joint.correction_matrix
        return A

    def fk_frames(self, q: ArrayLike, start: NDArray[np.float64] | None = None
                  ) -> NDArray[np.float64]:
        """base_link -> DH frames 0..n, shape (N, n + 1, 4, 4) for q of shape (N, n).

        Frame i is ``base @ A_1 C_1 ... A_i C_i``: it includes row i's correction. With
        ``start`` (4, 4) in place of ``base`` (the identity: DH frame 0 -> DH frame i)."""
        A = self.link_transforms(q)
        N = A.shape[0]
        frames = np.empty((N, self.dof + 1, 4, 4))
        frames[:, 0] = self.base if start is None else start
        for i in range(self.dof):
            frames[:, i + 1] = frames[:, i] @ A[:, i]
        return frames

    def fk(self, q: ArrayLike) -> NDArray[np.float64]:
        """base_link -> tool0. q: (n,) -> (4, 4); (N, n) -> (N, 4, 4).

        Computed :data:`FK_CHUNK` joint vectors at a time into the output, so that a large
        batch needs little more memory than its result (the same products, bit for bit)."""
        Q, single = joint_batch(q, self.dof)
        out = np.empty((Q.shape[0], 4, 4))
        for start in range(0, Q.shape[0], FK_CHUNK):
            A = self.link_transforms(Q[start:start + FK_CHUNK])
            T = np.broadcast_to(self.base, (A.shape[0], 4, 4))
            for i in range(self.dof):
                T = T @ A[:, i]
            np.matmul(T, self.tool, out=out[start:start + FK_CHUNK])
        return out[0] if single else out

    def in_limits(self, q: ArrayLike, tolerance: float = 0.0) -> NDArray[np.bool_]:
        """Whether each joint vector lies within [lower - tol, upper + tol] (last axis = joints)."""
        Q = np.asarray(q, dtype=float)
        return np.all((self.lower - tolerance <= Q) & (self.upper + tolerance >= Q), axis=-1)

    def random_q(self, n: int, rng: np.random.Generator) -> NDArray[np.float64]:
        """n joint vectors drawn uniformly within the limits, shape (n, dof)."""
        return rng.uniform(self.lower, self.upper, size=(n, self.dof))


def check_table_limits(table: DHTable) -> None:
    """Raise a :class:`DHError` naming the field when ``table`` exceeds a limit of this module:
    more than :data:`MAX_JOINTS` joints (checked first, before anything per joint), a revolute
    limit beyond :data:`MAX_JOINT_TURNS` turns, a length beyond :data:`MAX_LENGTH` metres, or a
    value that is not finite. Every :class:`DHTable` is checked when it is made."""
    count = len(table.joints)
    if count > MAX_JOINTS:
        raise DHError(field="joints", value=count,
                      expected=f"at most {MAX_JOINTS} joints (dhkin.dh.MAX_JOINTS)")
    for label, T in (("base", table.base), ("tool", table.tool), ("flange", table.flange)):
        matrix = np.asarray(T, dtype=float)
        if matrix.shape != (4, 4) or not np.all(np.isfinite(matrix)):
            raise DHError(field=label, value=f"shape {matrix.shape}",
                          expected="a finite (4, 4) transform")
        for k in range(3):
            _check_length(float(matrix[k, 3]), f"{label}.xyz[{k}]")
    for i, joint in enumerate(table.joints):
        label = f"joints[{i}]"
        for key in ("a", "alpha", "d", "theta", "offset", "velocity", "effort"):
            if not math.isfinite(getattr(joint, key)):
                raise DHError(field=f"{label}.{key}", value=getattr(joint, key),
                              expected="a finite number")
        for key in ("a", "d") + (() if joint.is_revolute else ("offset", "lower", "upper")):
            _check_length(getattr(joint, key), f"{label}.{key}")
        for k in range(3):
            _check_length(joint.correction[k], f"{label}.correction.xyz[{k}]")
        if joint.is_revolute:
            for key in ("lower", "upper"):
                value = getattr(joint, key)
                if not abs(value) <= MAX_JOINT_TURNS * 2 * math.pi + _LIMIT_SLACK:
                    raise DHError(field=f"{label}.{key}", value=value,
                                  expected=f"a revolute joint limit within "
                                           f"+-{MAX_JOINT_TURNS * 2 * math.pi:.6g} rad "
                                           f"(+-{MAX_JOINT_TURNS} turns, dhkin.dh.MAX_JOINT_TURNS)")


def _check_length(value: float, field_name: str) -> None:
    """Raise a DHError unless ``value`` (metres) lies within +-:data:`MAX_LENGTH`."""
    if not abs(value) <= MAX_LENGTH + _LIMIT_SLACK:
        raise DHError(field=field_name, value=value,
                      expected=f"a length within +-{MAX_LENGTH:g} m (dhkin.dh.MAX_LENGTH)")


def dh_matrices(
    convention: str,
    theta: NDArray[np.float64],
    d: NDArray[np.float64],
    a: NDArray[np.float64],
    alpha: NDArray[np.float64],
) -> NDArray[np.float64]:
    """DH link transforms for arrays of parameters (any common broadcast shape S) -> S + (4, 4)."""
    theta, d, a, alpha = np.broadcast_arrays(theta, d, a, alpha)
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    zero, one = np.zeros_like(ct), np.ones_like(ct)
    if convention == "standard":
        rows = [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [zero, sa, ca, d],
        ]
    elif convention == "modified":
        rows = [
            [ct, -st, zero, a],
            [st * ca, ct * ca, -sa, -sa * d],
            [st * sa, ct * sa, ca, ca * d],
        ]
    else:
        raise DHError(f"convention: expected one of {CONVENTIONS}, got {convention!r}")
    rows.append([zero, zero, zero, one])
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def _default_flange() -> NDArray[np.float64]:
    return xyz_rpy_to_matrix((0, 0, 0), np.radians(DEFAULT_FLANGE_RPY_DEG))


#: numpy kinds a joint value may have: signed and unsigned integers, floats, and Python objects
#: that convert to float (Decimal, Fraction). Booleans, complex numbers, text, bytes and dates
#: are refused rather than converted: numpy would read True as 1 and "1.5" as 1.5, hiding a
#: caller's mistake.
JOINT_VALUE_KINDS = "iufO"


def joint_batch(q: ArrayLike, dof: int, field: str = "q") -> tuple[NDArray[np.float64], bool]:
    """Joint values ``q`` of shape (dof,) or (N, dof) -> finite float64 (N, dof), and whether a
    single vector was given. The one check of joint values (robot, reference, singularity, maps):
    an InputError naming ``field`` unless ``q`` holds finite real numbers of one of those shapes
    (one line, naming the shape or type given, not every value)."""
    Q = real_array(q, field, f"finite numbers of shape ({dof},) or (N, {dof})")
    single = Q.ndim == 1
    if single:
        Q = Q[None, :]
    if Q.ndim != 2 or Q.shape[1] != dof:
        raise InputError(field=field, value=np.shape(q),
                         expected=f"shape ({dof},) or (N, {dof})")
    if not np.all(np.isfinite(Q)):
        raise InputError(f"{field}: expected finite joint values, got NaN or inf", field=field,
                         expected="finite joint values")
    return Q, single


def joint_vector(q: ArrayLike, dof: int, field: str = "q") -> NDArray[np.float64]:
    """One joint vector ``q`` -> finite float64 (dof,); InputError naming ``field`` otherwise
    (the single-configuration twin of :func:`joint_batch`)."""
    expected = f"{dof} finite joint values (shape ({dof},))"
    Q = real_array(q, field, expected)
    if Q.shape != (dof,):
        raise InputError(f"{field}: expected {expected}, got shape {Q.shape}", field=field,
                         value=Q.shape, expected=expected)
    if not np.all(np.isfinite(Q)):
        raise InputError(f"{field}: expected {expected}, got {Q.tolist()!r}", field=field,
                         value=Q.tolist(), expected=expected)
    return Q


def real_array(q: ArrayLike, field: str, expected: str) -> NDArray[np.float64]:
    """``q`` as a float64 array of any shape; InputError ("``field``: expected ``expected``, got
    ...") unless its values are real numbers of a kind in :data:`JOINT_VALUE_KINDS` (text, bool,
    complex, None, ragged lists are refused). Shape and finiteness are the caller's to check."""
    if isinstance(q, (str, bytes)):
        raise InputError(f"{field}: expected {expected}, got text {str(q)[:40]!r}", field=field,
                         value=type(q).__name__, expected=expected)
    try:
        raw = np.asarray(q)
        if raw.dtype.kind not in JOINT_VALUE_KINDS:
            raise TypeError(f"values of type {raw.dtype}")
        if raw.dtype.kind == "O" and any(value is None for value in raw.flat):
            raise TypeError("None among the values")  # numpy would read None as NaN
        return raw.astype(np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        what = " ".join(str(exc).split())[:100]
        raise InputError(f"{field}: expected {expected}, got {what}", field=field,
                         value=type(q).__name__, expected=expected) from exc
