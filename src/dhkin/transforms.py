"""Homogeneous transforms and URDF roll-pitch-yaw, batched where it matters.

Conventions: 4x4 homogeneous matrices act on column vectors, ``T_a_b`` maps coordinates in frame b
to frame a. URDF ``rpy = (r, p, y)`` means ``R = Rz(y) @ Ry(p) @ Rx(r)`` (fixed axes x, y, z).
Angles are radians, lengths metres.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Below this ``|cos(pitch)|`` a rotation is treated as gimbal-locked when converted to rpy.
GIMBAL_LOCK_TOLERANCE = 1e-12


def rot_x(angle: float) -> NDArray[np.float64]:
    """4x4 rotation about x by ``angle`` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], dtype=float)


def rot_y(angle: float) -> NDArray[np.float64]:
    """4x4 rotation about y by ``angle`` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1]], dtype=float)


def rot_z(angle: float) -> NDArray[np.float64]:
    """4x4 rotation about z by ``angle`` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)


def translation(x: float, y: float, z: float) -> NDArray[np.float64]:
    """4x4 pure translation (m)."""
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def xyz_rpy_to_matrix(xyz: ArrayLike, rpy: ArrayLike) -> NDArray[np.float64]:
    """URDF origin (xyz in m, rpy in rad) -> 4x4 transform ``Trans(xyz) @ Rz(y) Ry(p) Rx(r)``."""
    r, p, y = np.asarray(rpy, dtype=float)
    T = rot_z(y) @ rot_y(p) @ rot_x(r)
    T[:3, 3] = np.asarray(xyz, dtype=float)
    return T


def matrix_to_rpy(R: ArrayLike) -> tuple[float, float, float]:
    """Rotation matrix (3x3 or the block of a 4x4) -> URDF (roll, pitch, yaw) in rad.

    At gimbal lock (``|cos pitch|`` < ``GIMBAL_LOCK_TOLERANCE``) roll absorbs the whole rotation
    about the locked axis and yaw is 0.
    """
    M = np.asarray(R, dtype=float)[:3, :3]
    cos_pitch = float(np.hypot(M[0, 0], M[1, 0]))
    pitch = float(np.arctan2(-M[2, 0], cos_pitch))
    if cos_pitch < GIMBAL_LOCK_TOLERANCE:
        if M[2, 0] < 0:  # pitch = +pi/2: M01 = sin(r - y), M11 = cos(r - y)
            return float(np.arctan2(M[0, 1], M[1, 1])), float(np.pi / 2), 0.0
        return float(np.arctan2(-M[0, 1], M[1, 1])), float(-np.pi / 2), 0.0
    roll = float(np.arctan2(M[2, 1], M[2, 2]))
    yaw = float(np.arctan2(M[1, 0], M[0, 0]))
    return roll, pitch, yaw


def invert(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """Inverse of a homogeneous transform (or of a stack of them, shape (..., 4, 4))."""
    R = T[..., :3, :3]
    Rt = np.swapaxes(R, -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def rotation_angle(R: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angle (rad) of rotation matrices (..., 3, 3), accurate for small angles too."""
    # angle = atan2(|vee(R - R^T)| / 2, (trace - 1) / 2): no loss of precision near 0 or pi.
    skew = np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]],
        axis=-1,
    )
    sin_part = 0.5 * np.linalg.norm(skew, axis=-1)
    cos_part = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(sin_part, cos_part)


def pose_error(
    T_a: NDArray[np.float64], T_b: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Position error (m) and rotation error (rad) between poses (..., 4, 4)."""
    position = np.linalg.norm(T_a[..., :3, 3] - T_b[..., :3, 3], axis=-1)
    relative = np.swapaxes(T_a[..., :3, :3], -1, -2) @ T_b[..., :3, :3]
    return position, rotation_angle(relative)
