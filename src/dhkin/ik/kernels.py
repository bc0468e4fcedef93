"""Compiled (numba) kernels of the closed-form IK pipeline and of the family solvers.

:mod:`dhkin.ik.closed_form` describes the pipeline and drives these kernels. The numpy solvers of
:mod:`dhkin.ik.spherical_wrist`, :mod:`dhkin.ik.stanford` and :mod:`dhkin.ik.offset_wrist` stay
the reference implementation: the scalar ports here follow them step by step (same branch order,
flags, snapping and seeding at singularities, same thresholds), evaluated per pose with cheaper
primitives (``tests/test_ik_batch.py`` compares the two branch by branch). Every solution the
pipeline returns is verified by FK here, from its returned joint values.

Why one module: numba's on-disk cache (``cache=True``, in ``__pycache__``) checks only the
source file of the function it compiled, so a kernel calling a helper defined in another file
would keep a stale copy of it after an edit. Every compiled function lives here, so any edit
recompiles them all. Kernels compile on the first call of a process that finds no cache (see
docs/benchmarks.md for the time) and load from the cache afterwards.

Kernels allocate nothing per pose: callers pass preallocated outputs, so memory is the inputs,
the outputs and a few scratch arrays per call. Every kernel releases the GIL (``nogil``).

Two forms of the same computation: the per-pose functions (the families' ``solve_*``,
:func:`_finish_pose`, used by :func:`solve_one`, :func:`solve_branches`, :func:`finish_principal`
for other chains) and the block functions of the batch path (:func:`solve_principal`): the
spherical-wrist and offset-wrist solvers (:func:`_spherical_block`, :func:`_offset_block`) and the
wrap and FK check (:func:`_finish_block`) run by blocks of :data:`BLOCK_POSES` poses, stage by
stage over lanes (a pose, or one of its branches; structure of arrays), in loops without branches
or calls that the compiler vectorises (4 lanes with AVX2). Both forms do the same floating-point
operations in the same order (atan2 and sincos: :func:`_atan2_lanes`, :func:`_sincos_lanes`), so
they give the same bits: ``tests/test_ik_batch.py`` checks ``ik_batch`` against ``ik``.

Layouts (built by :func:`chain_array`, :func:`arm_geometry` and :func:`offset_wrist_geometry`):

* ``chain`` (n, 8): per joint a, cos(alpha), sin(alpha), d, theta, direction, offset,
  revolute (1.0) or prismatic (0.0); ``modified`` selects the DH convention.
* ``limits`` (n, 2): lower, upper joint value.
* ``frames`` (2, 4, 4): base^-1 and (tool @ tcp)^-1, so ``T_dh = frames[0] @ T @ frames[1]``.
* ``tolerances`` (5,): tolerance, tan(tolerance), tolerance - COPY_MARGIN,
  tan(tolerance - COPY_MARGIN), LIMIT_TOLERANCE (a tan is NaN where the angle is outside
  [0, pi/2): the check then uses atan2).
* ``geometry`` (:data:`GEOMETRY_SIZE`,): the family's constants, indices ``G_*`` / ``O_*``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

#: Compile options of every kernel: cached on disk, IEEE division (no ZeroDivisionError checks),
#: GIL released.
_jit = njit(cache=True, error_model="numpy", nogil=True)
#: The elementary functions may contract a * b + c into one fused multiply-add (more accurate,
#: not less); nothing else of fast-math.
_jit_fma = njit(cache=True, error_model="numpy", nogil=True, fastmath={"contract"})

TWO_PI = 2.0 * math.pi
HALF_PI = 0.5 * math.pi
_INVERSE_TWO_PI = 1.0 / TWO_PI

# Family ids of the compiled solvers; 0 = none (the family's numpy solve runs instead).
NO_KERNEL = 0
SPHERICAL_WRIST = 1
STANFORD = 2
OFFSET_WRIST = 3
#: Branches of every compiled family.
BRANCHES = 8

# Singularity flag bits (the same as dhkin.ik.result: WRIST, ELBOW, SHOULDER).
_WRIST, _ELBOW, _SHOULDER = 1, 2, 4

# Pose status of the input check (0: fine).
STATUS_NOT_FINITE = 1
STATUS_NOT_ROTATION = 2
STATUS_BAD_SEED = 3
#: solve_one's answer when its output has too few rows.
NEEDS_MORE_ROWS = -100
#: Largest |R R^T - I| entry of a target's rotation block (the check of closed_form.as_targets).
ORTHOGONALITY_TOLERANCE = 1e-6

# chain columns
C_A, C_COS_ALPHA, C_SIN_ALPHA, C_D, C_THETA, C_DIRECTION, C_OFFSET, C_REVOLUTE = range(8)

# geometry of the spherical-wrist and Stanford families (shared shoulder and wrist)
G_CENTRE_IN_FLANGE = 0  # 3: wrist centre in DH frame n
G_ORIGIN = 3  # 3: shoulder origin
G_FORWARD = 6  # 3
G_LATERAL = 9  # 3
G_UP = 12  # 3
G_SHOULDER_OFFSET = 15
G_LATERAL_OFFSET = 16
G_SIGNS = 17  # 3: arm signs s1, s2, s3
G_WRIST_FRAME = 20  # 9: wrist frame F, row-major
G_TARGET_TO_WRIST = 29  # 9: M_R^T F Ry(tilt), row-major (M_R: flange rotation at q = 0)
G_TILT = 38
G_WRIST_DIRECTIONS = 39  # 3
G_SCALE = 42
G_SNAP = 43  # SNAP_TOLERANCE
G_WRIST_SNAP = 44  # WRIST_SNAP_TOLERANCE
G_FLAG = 45  # SINGULAR_FLAG_TOLERANCE
G_ARM = 46  # family specific:
#   spherical wrist: upper arm (re, im), forearm (re, im), |upper arm|, |forearm|, bend at q = 0
#   Stanford: wrist centre at q = 0 (re, im), slide direction (re, im), A.V, |e|

# geometry of the offset-wrist family
O_DIRECTIONS = 0  # 18: joint axis directions (6, 3), row-major, times each joint's direction
O_POINTS = 18  # 18: a point on each axis (6, 3)
O_N = 36  # 3: common direction of axes 2-4
O_SIDE = 39  # 3: axis 1 x n
O_PLANE_X = 42  # 3
O_PLANE_Y = 45  # 3: n x plane_x
O_WRIST_IN_FLANGE = 48  # 3
O_WRIST_POINT = 51  # 3
O_HOME_R = 54  # 9: DH flange rotation at q = 0, row-major
O_HOME_INVERSE = 63  # 12: its inverse transform, top 3 rows, row-major
O_UPPER_ARM = 75  # 3
O_FOREARM = 78  # 3
O_W3_X_FOREARM = 81  # 3: axis 3 x forearm
O_LATERAL = 84  # c (0 where |c| <= AXIS_TOLERANCE)
O_LEFT_SIGN = 85
O_LATERAL_SIGN = 86
O_UP_SIGN = 87
O_PSI = 88
O_SIGN3 = 89
O_SIGN4 = 90
O_UPPER_LENGTH = 91
O_FOREARM_LENGTH = 92
O_ELBOW_ALPHA = 93  # v . u
O_ELBOW_BASE = 94  # atan2(beta, alpha)
O_ELBOW_TURN = 95  # (v x u) . n
O_AXIS_TOLERANCE = 96
O_REACH_TOLERANCE = 97
O_TAN_MERGE = 98  # tan(MERGE_ANGLE)
O_WRIST_SINGULAR_SIN = 99
O_EXACT_BAND = 100

GEOMETRY_SIZE = 101


# --------------------------------------------------------------------------------------------
# Elementary functions: sin, cos and atan2 without the C library's call and branch costs

#: x + _ROUNDER - _ROUNDER rounds x to an integer (round half to even) for |x| < 2^51.
_ROUNDER = 6755399441055744.0


def _split_half_pi() -> tuple[float, float]:
    """pi/2 as head + tail: the head has 33 significant bits, so k * head is exact for
    |k| < 2^20, and tail = pi/2 - head to double precision (Cody and Waite's reduction)."""
    from decimal import Decimal

    half_pi = Decimal("1.57079632679489661923132169163975144209858469968755291048747")
    head = np.array([float(half_pi)]).view(np.int64)
    head &= ~np.int64((1 << 20) - 1)
    head_value = float(head.view(np.float64)[0])
    return head_value, float(half_pi - Decimal(head_value))


_HALF_PI_HEAD, _HALF_PI_TAIL = _split_half_pi()
_TWO_OVER_PI = 2.0 / math.pi
#: Above this |x| the reduction is not exact: sincos falls back on the C library.
_REDUCTION_LIMIT = float(2**19)
# Taylor coefficients of sin and cos; on |r| <= pi/4 the truncation error is below 1e-19.
_S3, _S5, _S7, _S9, _S11, _S13, _S15, _S17 = (
    (-1.0) ** k / math.factorial(2 * k + 1) for k in range(1, 9))
_C4, _C6, _C8, _C10, _C12, _C14, _C16, _C18 = (
    (-1.0) ** k / math.factorial(2 * k) for k in range(2, 10))
#: atan(k / 8), k = 0..8 (the C library's atan, correctly rounded to double here).
_ATAN_TABLE = np.array([math.atan(k / 8.0) for k in range(9)])
# Taylor coefficients of atan(u) - u; on |u| <= 1/16 the truncation error is below 1e-20.
_A3, _A5, _A7, _A9, _A11, _A13, _A15 = ((-1.0) ** k / (2 * k + 1) for k in range(1, 8))


@_jit_fma
def sincos(x: float) -> tuple[float, float]:
    """(sin x, cos x), each within ~2 ulp (measured: 2.3e-16 on [-8, 8]). Reduction by multiples
    of pi/2 (exact for |x| < 2^19), Taylor polynomials on [-pi/4, pi/4], the quadrant by
    selects, not branches; beyond 2^19, NaN and inf: the C library."""
    if not abs(x) < _REDUCTION_LIMIT:
        return math.sin(x), math.cos(x)
    k = (x * _TWO_OVER_PI + _ROUNDER) - _ROUNDER
    r = (x - k * _HALF_PI_HEAD) - k * _HALF_PI_TAIL
    r2 = r * r
    s = r + r * r2 * (_S3 + r2 * (_S5 + r2 * (_S7 + r2 * (_S9 + r2 * (
        _S11 + r2 * (_S13 + r2 * (_S15 + r2 * _S17)))))))
    c = 1.0 - 0.5 * r2 + r2 * r2 * (_C4 + r2 * (_C6 + r2 * (_C8 + r2 * (_C10 + r2 * (
        _C12 + r2 * (_C14 + r2 * (_C16 + r2 * _C18)))))))
    quadrant = int(k)
    odd = quadrant & 1
    sine = c if odd else s
    cosine = s if odd else c
    return sine * (1 - (quadrant & 2)), cosine * (1 - ((quadrant + 1) & 2))


@_jit_fma
def atan2(y: float, x: float) -> float:
    """atan2(y, x) within ~2 ulp (measured: 4.5e-16), with the C library's values at zeros,
    signed zeros, infinities and NaN (those inputs go to it). Reduction to t = min/max of
    |x|, |y| in [0, 1], then atan(t) = atan(k/8) + atan((t - k/8) / (1 + t k/8))."""
    ax, ay = abs(x), abs(y)
    denominator = ay if ay > ax else ax
    numerator = ax if ay > ax else ay
    if not (denominator > 0.0 and denominator < math.inf and numerator == numerator):
        return math.atan2(y, x)
    k = _atan_knot(numerator / denominator)
    return _atan2_finish(y, x, _ATAN_TABLE[int(k)], k, numerator / denominator)


@_jit_fma
def _atan_knot(t: float) -> float:
    """k of :func:`atan2`'s reduction: t * 8 rounded to an integer (0..8 for t in [0, 1])."""
    return (t * 8.0 + _ROUNDER) - _ROUNDER


@_jit_fma
def _atan2_finish(y: float, x: float, base: float, k: float, t: float) -> float:
    """atan2(y, x) from t = min/max of |x|, |y|, its knot k and base = atan(k / 8) (the one
    body of :func:`atan2` and :func:`_atan2_lane`)."""
    centre = k * 0.125
    u = (t - centre) / (1.0 + t * centre)
    u2 = u * u
    a = base + (u + u * u2 * (_A3 + u2 * (_A5 + u2 * (_A7 + u2 * (
        _A9 + u2 * (_A11 + u2 * (_A13 + u2 * _A15)))))))
    a = HALF_PI - a if abs(y) > abs(x) else a
    a = math.pi - a if x < 0.0 else a
    return math.copysign(a, y)


_ATAN_0, _ATAN_1, _ATAN_2, _ATAN_3, _ATAN_4, _ATAN_5, _ATAN_6, _ATAN_7, _ATAN_8 = (
    float(v) for v in _ATAN_TABLE)


@_jit_fma
def _atan2_lane(y: float, x: float) -> tuple[float, bool]:
    """(:func:`atan2` (y, x), False), or (anything, True) for the inputs atan2 passes to the C
    library; by selects, with the table of atan(k / 8) as constants (no gather): the compiler
    vectorises loops calling it (see :func:`_atan2_lanes`)."""
    ax, ay = abs(x), abs(y)
    denominator = ay if ay > ax else ax
    numerator = ax if ay > ax else ay
    special = not (denominator > 0.0 and denominator < math.inf and numerator == numerator)
    t = numerator / denominator
    k = _atan_knot(t)
    base = (_ATAN_0 if k < 0.5 else _ATAN_1 if k < 1.5 else _ATAN_2 if k < 2.5 else
            _ATAN_3 if k < 3.5 else _ATAN_4 if k < 4.5 else _ATAN_5 if k < 5.5 else
            _ATAN_6 if k < 6.5 else _ATAN_7 if k < 7.5 else _ATAN_8)
    return _atan2_finish(y, x, base, k, t), special


@_jit
def _atan2_lanes(y: NDArray[np.float64], x: NDArray[np.float64],
                 out: NDArray[np.float64]) -> None:
    """out = :func:`atan2` (y, x) elementwise (M,), in a loop the compiler vectorises; the rare
    inputs of the C library's atan2 are passed to it afterwards."""
    special = 0
    for k in range(out.shape[0]):
        value, odd = _atan2_lane(y[k], x[k])
        out[k] = value
        special += 1 if odd else 0
    if special > 0:
        for k in range(out.shape[0]):
            out[k] = atan2(y[k], x[k])


@_jit
def _sincos_lanes(theta: NDArray[np.float64], sine: NDArray[np.float64],
                  cosine: NDArray[np.float64]) -> None:
    """:func:`sincos` of every theta (M,): :func:`_sincos_map` (the same values), then
    sincos itself where |theta| >= 2^19, inf or NaN."""
    _sincos_map(theta, sine, cosine)
    far = 0
    for k in range(theta.shape[0]):
        far += 0 if abs(theta[k]) < _REDUCTION_LIMIT else 1
    if far > 0:
        for k in range(theta.shape[0]):
            if not abs(theta[k]) < _REDUCTION_LIMIT:
                sine[k], cosine[k] = sincos(theta[k])


@_jit
def sincos_array(x: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    """:func:`sincos` of every x (M,) into out (M, 2) (for tests and benchmarks)."""
    for i in range(x.shape[0]):
        out[i, 0], out[i, 1] = sincos(x[i])


@_jit
def atan2_array(y: NDArray[np.float64], x: NDArray[np.float64],
                out: NDArray[np.float64]) -> None:
    """:func:`atan2` elementwise (M,) (for tests and benchmarks)."""
    for i in range(x.shape[0]):
        out[i] = atan2(y[i], x[i])


@_jit_fma
def _sincos_map(theta: NDArray[np.float64], sine: NDArray[np.float64],
                cosine: NDArray[np.float64]) -> None:
    """sincos of every theta (M,) (|theta| < 2^19, as the pipeline's wrapped values are),
    in a loop the compiler vectorises."""
    for k in range(theta.shape[0]):
        x = theta[k]
        m = (x * _TWO_OVER_PI + _ROUNDER) - _ROUNDER
        r = (x - m * _HALF_PI_HEAD) - m * _HALF_PI_TAIL
        r2 = r * r
        s = r + r * r2 * (_S3 + r2 * (_S5 + r2 * (_S7 + r2 * (_S9 + r2 * (
            _S11 + r2 * (_S13 + r2 * (_S15 + r2 * _S17)))))))
        c = 1.0 - 0.5 * r2 + r2 * r2 * (_C4 + r2 * (_C6 + r2 * (_C8 + r2 * (_C10 + r2 * (
            _C12 + r2 * (_C14 + r2 * (_C16 + r2 * _C18)))))))
        quadrant = m - 4.0 * ((m * 0.25 + _ROUNDER) - _ROUNDER)
        odd = (quadrant == 1.0) | (quadrant == -1.0)
        sine_sign = -1.0 if (quadrant == 2.0) | (quadrant == -2.0) | (quadrant == -1.0) else 1.0
        cosine_sign = -1.0 if (quadrant == 1.0) | (quadrant == 2.0) | (quadrant == -2.0) else 1.0
        sine[k] = (c if odd else s) * sine_sign
        cosine[k] = (s if odd else c) * cosine_sign


# --------------------------------------------------------------------------------------------
# Poses


@_jit
def target_status(T: NDArray[np.float64]) -> int:
    """0 for a usable pose (4, 4); STATUS_NOT_FINITE, or STATUS_NOT_ROTATION when the rotation
    block is not orthonormal within ORTHOGONALITY_TOLERANCE or has det < 0."""
    return _status_of(_pose_entries(T))


@_jit
def _pose_entries(T: NDArray[np.float64]) -> tuple[float, ...]:
    """The 16 entries of a pose (4, 4), row by row."""
    return (T[0, 0], T[0, 1], T[0, 2], T[0, 3], T[1, 0], T[1, 1], T[1, 2], T[1, 3],
            T[2, 0], T[2, 1], T[2, 2], T[2, 3], T[3, 0], T[3, 1], T[3, 2], T[3, 3])


@_jit
def _status_of(t: tuple[float, ...]) -> int:
    """:func:`target_status` of a pose's 16 entries, row by row (by selects: no branches)."""
    t00, t01, t02, t03, t10, t11, t12, t13, t20, t21, t22, t23, t30, t31, t32, t33 = t
    finite = ((abs(t00) < math.inf) & (abs(t01) < math.inf) & (abs(t02) < math.inf)
              & (abs(t03) < math.inf) & (abs(t10) < math.inf) & (abs(t11) < math.inf)
              & (abs(t12) < math.inf) & (abs(t13) < math.inf) & (abs(t20) < math.inf)
              & (abs(t21) < math.inf) & (abs(t22) < math.inf) & (abs(t23) < math.inf)
              & (abs(t30) < math.inf) & (abs(t31) < math.inf) & (abs(t32) < math.inf)
              & (abs(t33) < math.inf))
    worst = max(abs(t00 * t00 + t01 * t01 + t02 * t02 - 1.0),
                abs(t00 * t10 + t01 * t11 + t02 * t12),
                abs(t00 * t20 + t01 * t21 + t02 * t22),
                abs(t10 * t10 + t11 * t11 + t12 * t12 - 1.0),
                abs(t10 * t20 + t11 * t21 + t12 * t22),
                abs(t20 * t20 + t21 * t21 + t22 * t22 - 1.0))
    det = (t00 * (t11 * t22 - t12 * t21) - t01 * (t10 * t22 - t12 * t20)
           + t02 * (t10 * t21 - t11 * t20))
    rotation = (worst <= ORTHOGONALITY_TOLERANCE) & (det >= 0.0)
    return 0 if finite and rotation else STATUS_NOT_FINITE if not finite else STATUS_NOT_ROTATION


@_jit
def check_targets(targets: NDArray[np.float64], status: NDArray[np.int8]) -> None:
    """:func:`target_status` of every pose (N, 4, 4) into status (N,)."""
    for i in range(targets.shape[0]):
        status[i] = target_status(targets[i])


@_jit
def dh_target(frames: NDArray[np.float64], T: NDArray[np.float64],
              out: NDArray[np.float64]) -> None:
    """out (3, 4) = top rows of frames[0] @ T @ frames[1] (T rigid): DH frame 0 -> n."""
    B, F = frames[0], frames[1]
    t = _pose_entries(T)
    f = _pose_entries(F)
    for r in range(3):
        out[r, 0], out[r, 1], out[r, 2], out[r, 3] = _dh_row(B[r, 0], B[r, 1], B[r, 2],
                                                             B[r, 3], f, t)


@_jit
def _dh_row(b0: float, b1: float, b2: float, b3: float, f: tuple[float, ...],
            t: tuple[float, ...]) -> tuple[float, float, float, float]:
    """Row (b0, b1, b2, b3) of frames[0] times the rigid pose t times frames[1] (f): entries of
    :func:`dh_target`'s output, row by row."""
    t00, t01, t02, t03, t10, t11, t12, t13, t20, t21, t22, t23 = t[:12]
    f00, f01, f02, f03, f10, f11, f12, f13, f20, f21, f22, f23 = f[:12]
    m0 = b0 * t00 + b1 * t10 + b2 * t20
    m1 = b0 * t01 + b1 * t11 + b2 * t21
    m2 = b0 * t02 + b1 * t12 + b2 * t22
    m3 = b0 * t03 + b1 * t13 + b2 * t23 + b3
    return (m0 * f00 + m1 * f10 + m2 * f20, m0 * f01 + m1 * f11 + m2 * f21,
            m0 * f02 + m1 * f12 + m2 * f22, m0 * f03 + m1 * f13 + m2 * f23 + m3)


@_jit
def _block_poses(frames: NDArray[np.float64], targets: NDArray[np.float64], start: int,
                 status: NDArray[np.int8], raw: NDArray[np.float64],
                 block_targets: NDArray[np.float64]) -> None:
    """:func:`target_status` (status (count,)) and :func:`dh_target` of poses targets[start:
    start + count] into block_targets (12, W) (rotation column by column, then position; an
    identity where the status is not 0), in a loop the compiler vectorises. raw: (17, W)."""
    count, W = status.shape[0], raw.shape[1]
    for k in range(count):
        for r in range(4):
            for c in range(4):
                raw[4 * r + c, k] = targets[start + k, r, c]
    B = frames[0]
    b0, b1, b2 = _pose_entries(B)[0:4], _pose_entries(B)[4:8], _pose_entries(B)[8:12]
    f = _pose_entries(frames[1])
    for k in range(W):
        t = (raw[0, k], raw[1, k], raw[2, k], raw[3, k], raw[4, k], raw[5, k], raw[6, k],
             raw[7, k], raw[8, k], raw[9, k], raw[10, k], raw[11, k], raw[12, k], raw[13, k],
             raw[14, k], raw[15, k])
        raw[16, k] = _status_of(t)
        o00, o01, o02, o03 = _dh_row(b0[0], b0[1], b0[2], b0[3], f, t)
        o10, o11, o12, o13 = _dh_row(b1[0], b1[1], b1[2], b1[3], f, t)
        o20, o21, o22, o23 = _dh_row(b2[0], b2[1], b2[2], b2[3], f, t)
        block_targets[0, k], block_targets[1, k], block_targets[2, k] = o00, o10, o20
        block_targets[3, k], block_targets[4, k], block_targets[5, k] = o01, o11, o21
        block_targets[6, k], block_targets[7, k], block_targets[8, k] = o02, o12, o22
        block_targets[9, k], block_targets[10, k], block_targets[11, k] = o03, o13, o23
    for k in range(count):
        status[k] = int(raw[16, k])
        if status[k] != 0:  # a harmless target for the block functions
            for row in range(12):
                block_targets[row, k] = 1.0 if row == 0 or row == 4 or row == 8 else 0.0


# --------------------------------------------------------------------------------------------
# FK verification


@_jit
def _pose_error(state: NDArray[np.float64], T: NDArray[np.float64]) -> tuple[float, float, float]:
    """(position error, s, c) of the FK state (x, y, z columns, p: 12 values) against T (3, 4):
    the rotation error is atan2(s, c), s = |vee(E - E^T)| / 2, c = (trace E - 1) / 2 for
    E = R_fk^T R_T."""
    return _state_error(state[0], state[1], state[2], state[3], state[4], state[5], state[6],
                        state[7], state[8], state[9], state[10], state[11],
                        T[0, 0], T[1, 0], T[2, 0], T[0, 1], T[1, 1], T[2, 1],
                        T[0, 2], T[1, 2], T[2, 2], T[0, 3], T[1, 3], T[2, 3])


@_jit
def _state_error(x0: float, x1: float, x2: float, y0: float, y1: float, y2: float, z0: float,
                 z1: float, z2: float, p0: float, p1: float, p2: float, t00: float, t10: float,
                 t20: float, t01: float, t11: float, t21: float, t02: float, t12: float,
                 t22: float, t03: float, t13: float, t23: float) -> tuple[float, float, float]:
    """:func:`_pose_error` on scalars: FK columns x, y, z and position p against the target's
    entries t_rc (one body for the per-pose and the block verification: the same rounding)."""
    position = math.sqrt((p0 - t03) ** 2 + (p1 - t13) ** 2 + (p2 - t23) ** 2)
    e01 = x0 * t01 + x1 * t11 + x2 * t21
    e02 = x0 * t02 + x1 * t12 + x2 * t22
    e10 = y0 * t00 + y1 * t10 + y2 * t20
    e12 = y0 * t02 + y1 * t12 + y2 * t22
    e20 = z0 * t00 + z1 * t10 + z2 * t20
    e21 = z0 * t01 + z1 * t11 + z2 * t21
    trace = (x0 * t00 + x1 * t10 + x2 * t20 + y0 * t01 + y1 * t11
             + y2 * t21 + z0 * t02 + z1 * t12 + z2 * t22)
    s = 0.5 * math.sqrt((e21 - e12) ** 2 + (e02 - e20) ** 2 + (e10 - e01) ** 2)
    return position, s, 0.5 * (trace - 1.0)


@_jit
def _dh_step(x0: float, x1: float, x2: float, y0: float, y1: float, y2: float, z0: float,
             z1: float, z2: float, p0: float, p1: float, p2: float, st: float, ct: float,
             d: float, a: float, ca: float, sa: float,
             modified: bool) -> tuple[float, float, float, float, float, float, float, float,
                                      float, float, float, float]:
    """One joint of the DH product: the frame (x, y, z columns, p) times the joint's transform
    with sin/cos theta st, ct, offset d, length a and cos/sin alpha ca, sa."""
    if not modified:  # Rz(theta) Tz(d) Tx(a) Rx(alpha)
        p0 += d * z0
        p1 += d * z1
        p2 += d * z2
        n0, n1, n2 = ct * x0 + st * y0, ct * x1 + st * y1, ct * x2 + st * y2
        u0, u1, u2 = ct * y0 - st * x0, ct * y1 - st * x1, ct * y2 - st * x2
        x0, x1, x2 = n0, n1, n2
        p0 += a * x0
        p1 += a * x1
        p2 += a * x2
        y0, y1, y2, z0, z1, z2 = (ca * u0 + sa * z0, ca * u1 + sa * z1, ca * u2 + sa * z2,
                                  ca * z0 - sa * u0, ca * z1 - sa * u1, ca * z2 - sa * u2)
    else:  # Rx(alpha) Tx(a) Rz(theta) Tz(d)
        p0 += a * x0
        p1 += a * x1
        p2 += a * x2
        u0, u1, u2 = ca * y0 + sa * z0, ca * y1 + sa * z1, ca * y2 + sa * z2
        z0, z1, z2 = ca * z0 - sa * y0, ca * z1 - sa * y1, ca * z2 - sa * y2
        x0, x1, x2, y0, y1, y2 = (ct * x0 + st * u0, ct * x1 + st * u1, ct * x2 + st * u2,
                                  ct * u0 - st * x0, ct * u1 - st * x1, ct * u2 - st * x2)
        p0 += d * z0
        p1 += d * z1
        p2 += d * z2
    return x0, x1, x2, y0, y1, y2, z0, z1, z2, p0, p1, p2


@_jit
def _fk_steps(chain: NDArray[np.float64], modified: bool, q: NDArray[np.float64],
              sine: NDArray[np.float64], cosine: NDArray[np.float64], first: int,
              states: NDArray[np.float64]) -> None:
    """Continue the DH product from states[first] (12 values: x, y, z columns and p after
    ``first`` joints) through joints first..n-1, storing each states[j + 1]; sine/cosine[j] of
    theta_j are given."""
    n = q.shape[0]
    start = states[first]
    x0, x1, x2, y0, y1, y2 = start[0], start[1], start[2], start[3], start[4], start[5]
    z0, z1, z2, p0, p1, p2 = start[6], start[7], start[8], start[9], start[10], start[11]
    for j in range(first, n):
        st, ct = sine[j], cosine[j]
        d = chain[j, C_D] if chain[j, C_REVOLUTE] != 0.0 else (chain[j, C_DIRECTION] * q[j]
                                                               + chain[j, C_OFFSET])
        ca, sa, a = chain[j, C_COS_ALPHA], chain[j, C_SIN_ALPHA], chain[j, C_A]
        x0, x1, x2, y0, y1, y2, z0, z1, z2, p0, p1, p2 = _dh_step(
            x0, x1, x2, y0, y1, y2, z0, z1, z2, p0, p1, p2, st, ct, d, a, ca, sa, modified)
        out = states[j + 1]
        out[0], out[1], out[2], out[3], out[4], out[5] = x0, x1, x2, y0, y1, y2
        out[6], out[7], out[8], out[9], out[10], out[11] = z0, z1, z2, p0, p1, p2


@_jit
def _theta(chain: NDArray[np.float64], j: int, value: float) -> float:
    """DH theta of joint j at joint value ``value``."""
    if chain[j, C_REVOLUTE] != 0.0:
        return chain[j, C_DIRECTION] * value + chain[j, C_OFFSET]
    return chain[j, C_THETA]


@_jit
def fk_error(chain: NDArray[np.float64], modified: bool, q: NDArray[np.float64],
             T: NDArray[np.float64], work: NDArray[np.float64]) -> tuple[float, float, float]:
    """(position error, s, c) of FK(q) (n,) against T (3, 4); see :func:`_pose_error`.
    work: (n + 3, 12) scratch (n <= 12)."""
    n = q.shape[0]
    sine, cosine, states = work[0], work[1], work[2:]
    for j in range(n):
        sine[j], cosine[j] = sincos(_theta(chain, j, q[j]))
    _start_state(states[0])
    first = 0 * n  # an int64 as in _verify_branches: a literal 0 would compile _fk_steps again
    _fk_steps(chain, modified, q, sine, cosine, first, states)
    return _pose_error(states[n], T)


@_jit
def _start_state(state: NDArray[np.float64]) -> None:
    for k in range(12):
        state[k] = 0.0
    state[0] = state[4] = state[8] = 1.0


@_jit
def _within(position: float, s: float, c: float, tolerance: float, tan_tolerance: float) -> bool:
    """position <= tolerance and atan2(s, c) <= tolerance, with s >= 0 (no atan2 needed when
    tan_tolerance is a number, i.e. 0 <= tolerance < pi/2)."""
    if not (position <= tolerance):
        return False
    if tan_tolerance == tan_tolerance:
        return c > 0.0 and s <= tan_tolerance * c
    return math.atan2(s, c) <= tolerance


@_jit
def _verify_branches(chain: NDArray[np.float64], modified: bool, q: NDArray[np.float64],
                     usable: NDArray[np.bool_], T: NDArray[np.float64],
                     tolerances: NDArray[np.float64], ok: NDArray[np.bool_],
                     recheck: NDArray[np.bool_], errors: NDArray[np.float64],
                     trig: NDArray[np.float64], states: NDArray[np.float64]) -> None:
    """FK check of the usable branches q (B, n) against T (3, 4): ok (B,), recheck (B,) (the
    error is within COPY_MARGIN of the tolerance: copies are verified themselves) and errors
    (B, 3) (position, s, c). A branch whose first k joint values equal the previous usable
    branch's (bit for bit) continues the product from there: the same floating-point result.
    Scratch: trig (3, B * n), states (n + 1, 12)."""
    n_branches, n = q.shape
    theta, sine, cosine = trig[0], trig[1], trig[2]
    for b in range(n_branches):
        for j in range(n):
            theta[b * n + j] = _theta(chain, j, q[b, j]) if usable[b] else 0.0
    _sincos_map(theta, sine, cosine)
    _start_state(states[0])
    previous = -1
    for b in range(n_branches):
        use = usable[b]  # read before ok is written: callers may pass one array for both
        ok[b] = False
        recheck[b] = False
        if not use:
            continue
        first = 0
        if previous >= 0:
            while first < n and q[b, first] == q[previous, first]:
                first += 1
        if first < n:
            _fk_steps(chain, modified, q[b], sine[b * n:(b + 1) * n],
                      cosine[b * n:(b + 1) * n], first, states)
        previous = b
        position, s, c = _pose_error(states[n], T)
        errors[b, 0], errors[b, 1], errors[b, 2] = position, s, c
        if _within(position, s, c, tolerances[0], tolerances[1]):
            ok[b] = True
            recheck[b] = not _within(position, s, c, tolerances[2], tolerances[3])


# --------------------------------------------------------------------------------------------
# Joint values: wrap and 2pi copies


@_jit
def _fmod_two_pi(x: float) -> float:
    """np.fmod(x, 2 pi), the same value, without the library call for |x| < 4 pi (there
    x - 2 pi is exact: Sterbenz)."""
    size = abs(x)
    if size < TWO_PI:
        return x
    if size < 2.0 * TWO_PI:
        return x - TWO_PI if x > 0.0 else -(size - TWO_PI)  # the sign of x, also for 0
    return np.fmod(x, TWO_PI)


@_jit
def wrap(value: float) -> float:
    """value wrapped to (-pi, pi], as ``pi - np.mod(pi - value, 2 pi)`` (unchanged inside)."""
    if -math.pi < value <= math.pi:
        return value
    return _wrap_angle(value)


@_jit
def copy_range(limits: NDArray[np.float64], revolute: bool, value: float,
               limit_tolerance: float) -> tuple[int, int]:
    """(first turn, number of copies) of one joint value: the 2pi-shifted copies
    value + 2pi (first + k), k < number, inside the limits (within limit_tolerance); a
    prismatic value has one copy (turn 0) when inside, none otherwise."""
    lower, upper = limits[0], limits[1]
    if revolute:
        lo = math.ceil((lower - limit_tolerance - value) * _INVERSE_TWO_PI)
        hi = math.floor((upper + limit_tolerance - value) * _INVERSE_TWO_PI)
        return lo, max(hi - lo + 1, 0)
    inside = lower - limit_tolerance <= value <= upper + limit_tolerance
    return 0, 1 if inside else 0


# --------------------------------------------------------------------------------------------
# Shared pieces of the spherical-wrist and Stanford families


@_jit
def _rotate(g: NDArray[np.float64], axis: int, c: float, s: float, v0: float, v1: float,
            v2: float) -> tuple[float, float, float]:
    """Rotation by the angle with cosine c and sine s about the unit vector g[axis:axis + 3],
    applied to v (Rodrigues)."""
    k0, k1, k2 = g[axis], g[axis + 1], g[axis + 2]
    along = (1.0 - c) * (k0 * v0 + k1 * v1 + k2 * v2)
    return (c * v0 + s * (k1 * v2 - k2 * v1) + along * k0,
            c * v1 + s * (k2 * v0 - k0 * v2) + along * k1,
            c * v2 + s * (k0 * v1 - k1 * v0) + along * k2)


@_jit
def _shoulder(g: NDArray[np.float64], T: NDArray[np.float64],
              seed_q1: float) -> tuple[int, bool, bool, float, float, float, float, float]:
    """Both q1 branches (spherical_wrist.solve_shoulder) for target T (3, 4): the SHOULDER
    flag, each branch's validity, turns about ``up`` and the arm-plane target (height, reach
    from axis 2) of each."""
    cif = G_CENTRE_IN_FLANGE
    d0 = T[0, 3] + T[0, 0] * g[cif] + T[0, 1] * g[cif + 1] + T[0, 2] * g[cif + 2] - g[G_ORIGIN]
    d1 = (T[1, 3] + T[1, 0] * g[cif] + T[1, 1] * g[cif + 1] + T[1, 2] * g[cif + 2]
          - g[G_ORIGIN + 1])
    d2 = (T[2, 3] + T[2, 0] * g[cif] + T[2, 1] * g[cif + 1] + T[2, 2] * g[cif + 2]
          - g[G_ORIGIN + 2])
    x = d0 * g[G_FORWARD] + d1 * g[G_FORWARD + 1] + d2 * g[G_FORWARD + 2]
    y = d0 * g[G_LATERAL] + d1 * g[G_LATERAL + 1] + d2 * g[G_LATERAL + 2]
    height = d0 * g[G_UP] + d1 * g[G_UP + 1] + d2 * g[G_UP + 2]
    b = g[G_LATERAL_OFFSET]
    snap = g[G_SNAP] * g[G_SCALE]
    radius = math.sqrt(x * x + y * y)
    gap = radius - abs(b)
    reachable = gap >= -snap
    merged = abs(gap) <= snap
    on_axis = radius <= snap
    forward_reach = 0.0 if merged else math.sqrt(max(gap, 0.0) * (radius + abs(b)))
    if on_axis:
        seed_turn = g[G_SIGNS] * seed_q1
        front_turn, back_turn = seed_turn, seed_turn + math.pi
    else:
        heading = atan2(y, x)
        front_turn = heading - atan2(b, forward_reach)
        back_turn = heading - atan2(b, -forward_reach)
    near = merged or abs(forward_reach) <= g[G_FLAG] * g[G_SCALE]
    shoulder_offset = g[G_SHOULDER_OFFSET]
    return (_SHOULDER if near else 0, reachable, reachable and (on_axis or not merged),
            front_turn, back_turn, height, forward_reach - shoulder_offset,
            -forward_reach - shoulder_offset)


@_jit
def _turn_to(target_re: float, target_im: float, point_re: float, point_im: float) -> float:
    """angle(target * conj(point)): the turn taking arm-plane ``point`` towards ``target``."""
    return atan2(target_re * -point_im + target_im * point_re,
                 target_re * point_re - target_im * -point_im)


@_jit
def _target_columns(g: NDArray[np.float64], T: NDArray[np.float64], turn1: float,
                    out: NDArray[np.float64]) -> None:
    """Columns 0 and 2 of K1 = R1^T R_target M_R^T F Ry(tilt) into out[0:3], out[3:6], with R1
    the turn by turn1 about ``up``."""
    Q = G_TARGET_TO_WRIST
    s1, c1 = sincos(turn1)
    for column in range(2):
        c = 2 * column
        k0 = T[0, 0] * g[Q + c] + T[0, 1] * g[Q + 3 + c] + T[0, 2] * g[Q + 6 + c]
        k1 = T[1, 0] * g[Q + c] + T[1, 1] * g[Q + 3 + c] + T[1, 2] * g[Q + 6 + c]
        k2 = T[2, 0] * g[Q + c] + T[2, 1] * g[Q + 3 + c] + T[2, 2] * g[Q + 6 + c]
        r0, r1, r2 = _rotate(g, G_UP, c1, -s1, k0, k1, k2)
        out[3 * column], out[3 * column + 1], out[3 * column + 2] = r0, r1, r2


@_jit
def _wrist(g: NDArray[np.float64], columns: NDArray[np.float64], turn23: float,
           seed_q4: float, out: NDArray[np.float64]) -> int:
    """q4, q5, q6 of both wrist branches (spherical_wrist.solve_wrist) into out[0:3], out[3:6]
    for an arm turned by turn23 about ``lateral`` on top of the columns of
    :func:`_target_columns`: H = F^T R23^T K1 = Rz(t4) Ry(t5 + tilt) Rz(t6). Returns the WRIST
    flag."""
    s23, c23 = sincos(turn23)
    F = G_WRIST_FRAME
    a0, a1, a2 = _rotate(g, G_LATERAL, c23, -s23, columns[0], columns[1], columns[2])
    b0, b1, b2 = _rotate(g, G_LATERAL, c23, -s23, columns[3], columns[4], columns[5])
    h00 = g[F] * a0 + g[F + 3] * a1 + g[F + 6] * a2
    h10 = g[F + 1] * a0 + g[F + 4] * a1 + g[F + 7] * a2
    h20 = g[F + 2] * a0 + g[F + 5] * a1 + g[F + 8] * a2
    h02 = g[F] * b0 + g[F + 3] * b1 + g[F + 6] * b2
    h12 = g[F + 1] * b0 + g[F + 4] * b1 + g[F + 7] * b2
    h22 = g[F + 2] * b0 + g[F + 5] * b1 + g[F + 8] * b2
    d4 = g[G_WRIST_DIRECTIONS]
    d5 = g[G_WRIST_DIRECTIONS + 1]
    d6 = g[G_WRIST_DIRECTIONS + 2]
    tilt = g[G_TILT]
    sine = math.sqrt(h02 * h02 + h12 * h12)
    flag = _WRIST if sine <= g[G_FLAG] else 0
    singular = sine <= g[G_WRIST_SNAP]
    if singular:
        sine = 0.0
    theta = atan2(sine, h22)
    alpha = d4 * seed_q4 if singular else atan2(h12, h02)
    sa, ca = sincos(alpha)
    st, ct = sincos(theta)
    gamma = atan2(-sa * h00 + ca * h10, ct * (ca * h00 + sa * h10) - st * h20)
    out[0] = d4 * alpha
    out[1] = d5 * (theta - tilt)
    out[2] = d6 * gamma
    out[3] = d4 * (alpha + math.pi)
    out[4] = d5 * (-theta - tilt)
    out[5] = d6 * (gamma + math.pi)
    return flag


# --------------------------------------------------------------------------------------------
# Family solvers: principal branch solutions of one pose


@_jit
def solve_spherical_wrist(g: NDArray[np.float64], T: NDArray[np.float64],
                          seed: NDArray[np.float64], q: NDArray[np.float64],
                          valid: NDArray[np.bool_], flags: NDArray[np.uint8],
                          scratch: NDArray[np.float64]) -> None:
    """spherical_wrist.Solver.solve for one flange target T (3, 4): q (8, 6), valid (8,),
    flags (8,); branch 4 * shoulder + 2 * elbow + wrist. scratch: (12,) floats."""
    shoulder_flag, front_valid, back_valid, front_turn, back_turn, height, front_reach, \
        back_reach = _shoulder(g, T, seed[0])
    columns, wrist_q = scratch[:6], scratch[6:12]
    u_re, u_im = g[G_ARM], g[G_ARM + 1]
    f_re, f_im = g[G_ARM + 2], g[G_ARM + 3]
    upper, fore = g[G_ARM + 4], g[G_ARM + 5]
    bend_at_zero = g[G_ARM + 6]
    s1, s2, s3 = g[G_SIGNS], g[G_SIGNS + 1], g[G_SIGNS + 2]
    snap = g[G_SNAP] * g[G_SCALE]
    for s in range(2):
        turn1 = front_turn if s == 0 else back_turn
        t_re, t_im = height, front_reach if s == 0 else back_reach
        _target_columns(g, T, turn1, columns)
        distance = math.sqrt(t_re * t_re + t_im * t_im)
        outer = (upper + fore) - distance
        inner = distance - abs(upper - fore)
        reachable = outer >= -snap and inner >= -snap
        merged = abs(outer) <= snap or abs(inner) <= snap
        sine_squared = (max(outer, 0.0) * (upper + fore + distance) * max(inner, 0.0)
                        * (distance + abs(upper - fore)))
        sine_scaled = 0.0 if merged else math.sqrt(sine_squared)
        cosine_scaled = distance ** 2 - upper ** 2 - fore ** 2
        near = merged or sine_scaled <= g[G_FLAG] * 2 * upper * fore
        elbow_flag = _ELBOW if near else 0
        for e in range(2):
            psi = atan2(sine_scaled if e == 0 else -sine_scaled, cosine_scaled)
            turn3 = psi - bend_at_zero
            s3t, c3t = sincos(turn3)
            w_re = u_re + (c3t * f_re - s3t * f_im)
            w_im = u_im + (c3t * f_im + s3t * f_re)
            turn2 = s2 * seed[1] if distance <= snap else _turn_to(t_re, t_im, w_re, w_im)
            arm_valid = ((front_valid if s == 0 else back_valid) and reachable
                         and (e == 0 or not merged))
            wrist_flag = _wrist(g, columns, turn2 + turn3, seed[3], wrist_q)
            for w in range(2):
                b = 4 * s + 2 * e + w
                q[b, 0] = s1 * turn1
                q[b, 1] = s2 * turn2
                q[b, 2] = s3 * turn3
                q[b, 3] = wrist_q[3 * w]
                q[b, 4] = wrist_q[3 * w + 1]
                q[b, 5] = wrist_q[3 * w + 2]
                valid[b] = arm_valid
                flags[b] = shoulder_flag | elbow_flag | wrist_flag


@_jit
def solve_stanford(g: NDArray[np.float64], T: NDArray[np.float64],
                   seed: NDArray[np.float64], q: NDArray[np.float64],
                   valid: NDArray[np.bool_], flags: NDArray[np.uint8],
                   scratch: NDArray[np.float64]) -> None:
    """stanford.Solver.solve for one flange target T (3, 4): q (8, 6), valid (8,), flags (8,);
    branch 4 * shoulder + 2 * slide + wrist. scratch: (12,) floats."""
    shoulder_flag, front_valid, back_valid, front_turn, back_turn, height, front_reach, \
        back_reach = _shoulder(g, T, seed[0])
    columns, wrist_q = scratch[:6], scratch[6:12]
    a_re, a_im = g[G_ARM], g[G_ARM + 1]
    v_re, v_im = g[G_ARM + 2], g[G_ARM + 3]
    along, offset = g[G_ARM + 4], g[G_ARM + 5]
    s1, s2, s3 = g[G_SIGNS], g[G_SIGNS + 1], g[G_SIGNS + 2]
    snap = g[G_SNAP] * g[G_SCALE]
    for s in range(2):
        turn1 = front_turn if s == 0 else back_turn
        t_re, t_im = height, front_reach if s == 0 else back_reach
        _target_columns(g, T, turn1, columns)
        distance = math.sqrt(t_re * t_re + t_im * t_im)
        gap = distance - offset
        reachable = gap >= -snap
        merged = abs(gap) <= snap
        root = 0.0 if merged else math.sqrt(max(gap, 0.0) * (distance + offset))
        near = merged or root <= g[G_FLAG] * g[G_SCALE]
        slide_flag = _ELBOW if near else 0
        for e in range(2):
            t = -along + (root if e == 0 else -root)
            w_re = a_re + t * v_re
            w_im = a_im + t * v_im
            free = math.sqrt(w_re * w_re + w_im * w_im) <= snap
            turn2 = s2 * seed[1] if free else _turn_to(t_re, t_im, w_re, w_im)
            arm_valid = ((front_valid if s == 0 else back_valid) and reachable
                         and (e == 0 or not merged))
            wrist_flag = _wrist(g, columns, turn2, seed[3], wrist_q)
            for w in range(2):
                b = 4 * s + 2 * e + w
                q[b, 0] = s1 * turn1
                q[b, 1] = s2 * turn2
                q[b, 2] = s3 * t
                q[b, 3] = wrist_q[3 * w]
                q[b, 4] = wrist_q[3 * w + 1]
                q[b, 5] = wrist_q[3 * w + 2]
                valid[b] = arm_valid
                flags[b] = shoulder_flag | slide_flag | wrist_flag


# --------------------------------------------------------------------------------------------
# The spherical-wrist family by blocks of poses: the same operations as solve_spherical_wrist,
# stage by stage over lanes (a pose, or a pose's shoulder or arm branch) in loops the compiler
# vectorises; atan2 and sincos by _atan2_lanes and _sincos_lanes (the same values).

# Rows of the per-pose scratch of _spherical_block
_P_HEIGHT, _P_FRONT_REACH, _P_BACK_REACH, _P_FRONT_TURN, _P_BACK_TURN, _P_FLAG, \
    _P_FRONT_VALID, _P_BACK_VALID, _P_ON_AXIS = range(9)
# Rows of the per-shoulder-branch scratch (lane s * W + k)
_S_TURN, _S_COLUMNS, _S_DISTANCE, _S_REACHABLE, _S_MERGED, _S_SINE, _S_COSINE, \
    _S_FLAG = 0, 1, 7, 8, 9, 10, 11, 12
# Rows of the per-arm-branch scratch (lane (2 s + e) * W + k)
_L_TURN2, _L_TURN3, _L_H00, _L_H10, _L_H20, _L_FLAG, _L_ALPHA, _L_THETA, \
    _L_GAMMA = range(9)


@_jit
def _block_target(targets: NDArray[np.float64], k: int) -> tuple[float, float, float, float,
                                                                  float, float, float, float,
                                                                  float, float, float, float]:
    """Entries t_rc of pose k's target from a block's targets (12, W) (rotation column by
    column, then position): t00, t01, t02, t03, t10, ..., t23 (row by row)."""
    return (targets[0, k], targets[3, k], targets[6, k], targets[9, k],
            targets[1, k], targets[4, k], targets[7, k], targets[10, k],
            targets[2, k], targets[5, k], targets[8, k], targets[11, k])


@_jit
def _spherical_block(g: NDArray[np.float64], targets: NDArray[np.float64],
                     seeds: NDArray[np.float64], q: NDArray[np.float64],
                     valid: NDArray[np.bool_], flags: NDArray[np.uint8],
                     pose: NDArray[np.float64], side: NDArray[np.float64],
                     arm: NDArray[np.float64], args: NDArray[np.float64]) -> None:
    """:func:`solve_spherical_wrist` for the ``count`` poses of a block: targets (12, W) (see
    :func:`_block_target`), seeds (6, W) -> q (count, 8, 6), valid (>= count, 8), flags
    (count, 8). The same values, computed stage by stage over lanes. Scratch (at least):
    pose (9, W), side (13, 2 W), arm (9, 4 W), args (3, 8 W)."""
    count = q.shape[0]
    W = targets.shape[1]
    cif = G_CENTRE_IN_FLANGE
    b_off = g[G_LATERAL_OFFSET]
    snap = g[G_SNAP] * g[G_SCALE]
    Y, X, A = args[0], args[1], args[2]
    for k in range(W):  # _shoulder up to its atan2 calls
        t00, t01, t02, t03, t10, t11, t12, t13, t20, t21, t22, t23 = _block_target(targets, k)
        d0 = t03 + t00 * g[cif] + t01 * g[cif + 1] + t02 * g[cif + 2] - g[G_ORIGIN]
        d1 = (t13 + t10 * g[cif] + t11 * g[cif + 1] + t12 * g[cif + 2]
              - g[G_ORIGIN + 1])
        d2 = (t23 + t20 * g[cif] + t21 * g[cif + 1] + t22 * g[cif + 2]
              - g[G_ORIGIN + 2])
        x = d0 * g[G_FORWARD] + d1 * g[G_FORWARD + 1] + d2 * g[G_FORWARD + 2]
        y = d0 * g[G_LATERAL] + d1 * g[G_LATERAL + 1] + d2 * g[G_LATERAL + 2]
        height = d0 * g[G_UP] + d1 * g[G_UP + 1] + d2 * g[G_UP + 2]
        radius = math.sqrt(x * x + y * y)
        gap = radius - abs(b_off)
        reachable = gap >= -snap
        merged = abs(gap) <= snap
        on_axis = radius <= snap
        forward_reach = 0.0 if merged else math.sqrt(max(gap, 0.0) * (radius + abs(b_off)))
        near = merged or abs(forward_reach) <= g[G_FLAG] * g[G_SCALE]
        Y[k], X[k] = y, x
        Y[W + k], X[W + k] = b_off, forward_reach
        Y[2 * W + k], X[2 * W + k] = b_off, -forward_reach
        pose[_P_HEIGHT, k] = height
        pose[_P_FRONT_REACH, k] = forward_reach - g[G_SHOULDER_OFFSET]
        pose[_P_BACK_REACH, k] = -forward_reach - g[G_SHOULDER_OFFSET]
        pose[_P_FLAG, k] = _SHOULDER if near else 0
        pose[_P_FRONT_VALID, k] = 1.0 if reachable else 0.0
        pose[_P_BACK_VALID, k] = 1.0 if reachable and (on_axis or not merged) else 0.0
        pose[_P_ON_AXIS, k] = 1.0 if on_axis else 0.0
    _atan2_lanes(Y[:3 * W], X[:3 * W], A[:3 * W])
    for k in range(W):
        seed_turn = g[G_SIGNS] * seeds[0, k]
        on_axis = pose[_P_ON_AXIS, k] != 0.0
        heading = A[k]
        pose[_P_FRONT_TURN, k] = seed_turn if on_axis else heading - A[W + k]
        pose[_P_BACK_TURN, k] = seed_turn + math.pi if on_axis else heading - A[2 * W + k]
    _spherical_sides(g, targets, pose, side, args)
    _spherical_arms(g, seeds, pose, side, arm, args)
    _spherical_wrists(g, seeds, side, arm, args)
    _spherical_store(g, pose, side, arm, count, q, valid, flags)


@_jit
def _spherical_sides(g: NDArray[np.float64], targets: NDArray[np.float64],
                     pose: NDArray[np.float64], side: NDArray[np.float64],
                     args: NDArray[np.float64]) -> None:
    """Per shoulder branch (lane s * W + k): turn1, :func:`_target_columns`, and the elbow's
    reach of solve_spherical_wrist."""
    W = pose.shape[1]
    upper, fore = g[G_ARM + 4], g[G_ARM + 5]
    snap = g[G_SNAP] * g[G_SCALE]
    Q = G_TARGET_TO_WRIST
    theta, sine, cosine = args[0, :2 * W], args[1, :2 * W], args[2, :2 * W]
    for s in range(2):
        for k in range(W):
            turn1 = pose[_P_FRONT_TURN, k] if s == 0 else pose[_P_BACK_TURN, k]
            side[_S_TURN, s * W + k] = turn1
            theta[s * W + k] = turn1
    _sincos_lanes(theta, sine, cosine)
    for s in range(2):
        for k in range(W):
            lane = s * W + k
            t00, t01, t02, _, t10, t11, t12, _, t20, t21, t22, _ = _block_target(targets, k)
            s1, c1 = sine[lane], cosine[lane]
            for column in range(2):
                c = 2 * column
                k0 = t00 * g[Q + c] + t01 * g[Q + 3 + c] + t02 * g[Q + 6 + c]
                k1 = t10 * g[Q + c] + t11 * g[Q + 3 + c] + t12 * g[Q + 6 + c]
                k2 = t20 * g[Q + c] + t21 * g[Q + 3 + c] + t22 * g[Q + 6 + c]
                r0, r1, r2 = _rotate(g, G_UP, c1, -s1, k0, k1, k2)
                side[_S_COLUMNS + 3 * column, lane] = r0
                side[_S_COLUMNS + 3 * column + 1, lane] = r1
                side[_S_COLUMNS + 3 * column + 2, lane] = r2
            t_re = pose[_P_HEIGHT, k]
            t_im = pose[_P_FRONT_REACH, k] if s == 0 else pose[_P_BACK_REACH, k]
            distance = math.sqrt(t_re * t_re + t_im * t_im)
            outer = (upper + fore) - distance
            inner = distance - abs(upper - fore)
            reachable = outer >= -snap and inner >= -snap
            merged = abs(outer) <= snap or abs(inner) <= snap
            sine_squared = (max(outer, 0.0) * (upper + fore + distance) * max(inner, 0.0)
                            * (distance + abs(upper - fore)))
            sine_scaled = 0.0 if merged else math.sqrt(sine_squared)
            near = merged or sine_scaled <= g[G_FLAG] * 2 * upper * fore
            side[_S_DISTANCE, lane] = distance
            side[_S_REACHABLE, lane] = 1.0 if reachable else 0.0
            side[_S_MERGED, lane] = 1.0 if merged else 0.0
            side[_S_SINE, lane] = sine_scaled
            side[_S_COSINE, lane] = distance ** 2 - upper ** 2 - fore ** 2
            side[_S_FLAG, lane] = _ELBOW if near else 0


@_jit
def _spherical_arms(g: NDArray[np.float64], seeds: NDArray[np.float64],
                    pose: NDArray[np.float64], side: NDArray[np.float64],
                    arm: NDArray[np.float64], args: NDArray[np.float64]) -> None:
    """Per arm branch (lane (2 s + e) * W + k): turn3 and turn2 of solve_spherical_wrist."""
    W = pose.shape[1]
    u_re, u_im = g[G_ARM], g[G_ARM + 1]
    f_re, f_im = g[G_ARM + 2], g[G_ARM + 3]
    bend_at_zero = g[G_ARM + 6]
    s2 = g[G_SIGNS + 1]
    snap = g[G_SNAP] * g[G_SCALE]
    n = 4 * W
    Y, X, A = args[0, :n], args[1, :n], args[2, :n]
    for group in range(4):
        s, e = group // 2, group % 2
        for k in range(W):
            lane = s * W + k
            sine_scaled = side[_S_SINE, lane]
            Y[group * W + k] = sine_scaled if e == 0 else -sine_scaled
            X[group * W + k] = side[_S_COSINE, lane]
    _atan2_lanes(Y, X, A)
    for i in range(n):
        arm[_L_TURN3, i] = A[i] - bend_at_zero
    theta, sine, cosine = args[0, n:2 * n], args[1, n:2 * n], args[2, n:2 * n]
    for i in range(n):
        theta[i] = arm[_L_TURN3, i]
    _sincos_lanes(theta, sine, cosine)
    for group in range(4):
        s = group // 2
        for k in range(W):
            i = group * W + k
            s3t, c3t = sine[i], cosine[i]
            w_re = u_re + (c3t * f_re - s3t * f_im)
            w_im = u_im + (c3t * f_im + s3t * f_re)
            t_re = pose[_P_HEIGHT, k]
            t_im = pose[_P_FRONT_REACH, k] if s == 0 else pose[_P_BACK_REACH, k]
            Y[i] = t_re * -w_im + t_im * w_re  # _turn_to
            X[i] = t_re * w_re - t_im * -w_im
    _atan2_lanes(Y, X, A)
    for group in range(4):
        s = group // 2
        for k in range(W):
            i = group * W + k
            free = side[_S_DISTANCE, s * W + k] <= snap
            arm[_L_TURN2, i] = s2 * seeds[1, k] if free else A[i]


@_jit
def _spherical_wrists(g: NDArray[np.float64], seeds: NDArray[np.float64],
                      side: NDArray[np.float64], arm: NDArray[np.float64],
                      args: NDArray[np.float64]) -> None:
    """Per arm branch: :func:`_wrist`'s alpha, theta, gamma and WRIST flag (arm rows)."""
    W = seeds.shape[1]
    n = 4 * W
    F = G_WRIST_FRAME
    d4 = g[G_WRIST_DIRECTIONS]
    theta, sine, cosine = args[0, :n], args[1, :n], args[2, :n]
    for i in range(n):
        theta[i] = arm[_L_TURN2, i] + arm[_L_TURN3, i]
    _sincos_lanes(theta, sine, cosine)
    Y, X, A = args[0, :2 * n], args[1, :2 * n], args[2, :2 * n]
    for group in range(4):
        s = group // 2
        for k in range(W):
            i = group * W + k
            lane = s * W + k
            s23, c23 = sine[i], cosine[i]
            a0, a1, a2 = _rotate(g, G_LATERAL, c23, -s23, side[_S_COLUMNS, lane],
                                 side[_S_COLUMNS + 1, lane], side[_S_COLUMNS + 2, lane])
            b0, b1, b2 = _rotate(g, G_LATERAL, c23, -s23, side[_S_COLUMNS + 3, lane],
                                 side[_S_COLUMNS + 4, lane], side[_S_COLUMNS + 5, lane])
            h00 = g[F] * a0 + g[F + 3] * a1 + g[F + 6] * a2
            h10 = g[F + 1] * a0 + g[F + 4] * a1 + g[F + 7] * a2
            h20 = g[F + 2] * a0 + g[F + 5] * a1 + g[F + 8] * a2
            h02 = g[F] * b0 + g[F + 3] * b1 + g[F + 6] * b2
            h12 = g[F + 1] * b0 + g[F + 4] * b1 + g[F + 7] * b2
            h22 = g[F + 2] * b0 + g[F + 5] * b1 + g[F + 8] * b2
            wrist_sine = math.sqrt(h02 * h02 + h12 * h12)
            arm[_L_FLAG, i] = _WRIST if wrist_sine <= g[G_FLAG] else 0
            singular = wrist_sine <= g[G_WRIST_SNAP]
            arm[_L_ALPHA, i] = 1.0 if singular else 0.0  # the alpha of a singular wrist: below
            Y[i], X[i] = 0.0 if singular else wrist_sine, h22
            Y[n + i], X[n + i] = h12, h02
            arm[_L_H00, i], arm[_L_H10, i], arm[_L_H20, i] = h00, h10, h20
    _atan2_lanes(Y, X, A)
    for group in range(4):
        for k in range(W):
            i = group * W + k
            singular = arm[_L_ALPHA, i] != 0.0
            arm[_L_ALPHA, i] = d4 * seeds[3, k] if singular else A[n + i]
            arm[_L_THETA, i] = A[i]
    theta, sine, cosine = args[0, :2 * n], args[1, :2 * n], args[2, :2 * n]
    for i in range(n):
        theta[i] = arm[_L_ALPHA, i]
        theta[n + i] = arm[_L_THETA, i]
    _sincos_lanes(theta, sine, cosine)
    Y, X, A = args[0, :n], args[1, :n], args[2, :n]
    for i in range(n):
        sa, ca = sine[i], cosine[i]
        st, ct = sine[n + i], cosine[n + i]
        h00, h10, h20 = arm[_L_H00, i], arm[_L_H10, i], arm[_L_H20, i]
        Y[i] = -sa * h00 + ca * h10
        X[i] = ct * (ca * h00 + sa * h10) - st * h20
    _atan2_lanes(Y, X, A)
    for i in range(n):
        arm[_L_GAMMA, i] = A[i]


@_jit
def _spherical_store(g: NDArray[np.float64], pose: NDArray[np.float64],
                     side: NDArray[np.float64], arm: NDArray[np.float64], count: int,
                     q: NDArray[np.float64], valid: NDArray[np.bool_],
                     flags: NDArray[np.uint8]) -> None:
    """The branches 4 s + 2 e + w of solve_spherical_wrist from the lanes, for poses < count."""
    W = pose.shape[1]
    s1, s2, s3 = g[G_SIGNS], g[G_SIGNS + 1], g[G_SIGNS + 2]
    d4 = g[G_WRIST_DIRECTIONS]
    d5 = g[G_WRIST_DIRECTIONS + 1]
    d6 = g[G_WRIST_DIRECTIONS + 2]
    tilt = g[G_TILT]
    for k in range(count):
        for group in range(4):
            s, e = group // 2, group % 2
            i = group * W + k
            lane = s * W + k
            shoulder_valid = pose[_P_FRONT_VALID if s == 0 else _P_BACK_VALID, k] != 0.0
            arm_valid = (shoulder_valid and side[_S_REACHABLE, lane] != 0.0
                         and (e == 0 or side[_S_MERGED, lane] == 0.0))
            flag = int(pose[_P_FLAG, k]) | int(side[_S_FLAG, lane]) | int(arm[_L_FLAG, i])
            alpha, theta, gamma = arm[_L_ALPHA, i], arm[_L_THETA, i], arm[_L_GAMMA, i]
            for w in range(2):
                b = 4 * s + 2 * e + w
                q[k, b, 0] = s1 * side[_S_TURN, lane]
                q[k, b, 1] = s2 * arm[_L_TURN2, i]
                q[k, b, 2] = s3 * arm[_L_TURN3, i]
                if w == 0:
                    q[k, b, 3] = d4 * alpha
                    q[k, b, 4] = d5 * (theta - tilt)
                    q[k, b, 5] = d6 * gamma
                else:
                    q[k, b, 3] = d4 * (alpha + math.pi)
                    q[k, b, 4] = d5 * (-theta - tilt)
                    q[k, b, 5] = d6 * (gamma + math.pi)
                valid[k, b] = arm_valid
                flags[k, b] = flag


# --------------------------------------------------------------------------------------------
# The offset-wrist family (UR, AUBO): scalar port of offset_wrist.Solver


@_jit
def _vec(g: NDArray[np.float64], at: int) -> tuple[float, float, float]:
    return g[at], g[at + 1], g[at + 2]


@_jit
def _dot3(a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> float:
    return a0 * b0 + a1 * b1 + a2 * b2


@_jit
def _axis_rotate(g: NDArray[np.float64], joint: int, angle: float, v0: float, v1: float,
                 v2: float) -> tuple[float, float, float]:
    """Rotation by angle about joint axis ``joint`` (0-based) applied to the direction v."""
    s, c = sincos(angle)
    return _rotate(g, O_DIRECTIONS + 3 * joint, c, s, v0, v1, v2)


@_jit
def _screw_apply(g: NDArray[np.float64], joint: int, c: float, s: float, v0: float, v1: float,
                 v2: float, point: bool) -> tuple[float, float, float]:
    """The rigid motion turning about the line of joint axis ``joint`` by the angle with cosine
    c and sine s (offset_wrist._screw), applied to v: a point, or a direction."""
    a = O_DIRECTIONS + 3 * joint
    if not point:
        return _rotate(g, a, c, s, v0, v1, v2)
    p0, p1, p2 = _vec(g, O_POINTS + 3 * joint)
    r0, r1, r2 = _rotate(g, a, c, s, v0 - p0, v1 - p1, v2 - p2)
    return r0 + p0, r1 + p1, r2 + p2


@_jit
def _motion_apply(g: NDArray[np.float64], T_home: NDArray[np.float64],
                  turns: tuple[float, float, float, float, float, float], v0: float, v1: float,
                  v2: float, point: bool) -> tuple[float, float, float]:
    """G v for the motion G = E1(-q1) T M^-1 E6(-q6) E5(-q5) of joints 2-4
    (offset_wrist.Solver._motions_2_to_4), with turns = cos, sin of -q5, -q6, -q1."""
    return _motion_apply_home(g, _home_entries(T_home), turns, v0, v1, v2, point)


@_jit
def _home_entries(T_home: NDArray[np.float64]) -> tuple[float, float, float, float, float, float,
                                                        float, float, float, float, float,
                                                        float]:
    """The entries of T_home (3, 4), row by row."""
    return (T_home[0, 0], T_home[0, 1], T_home[0, 2], T_home[0, 3],
            T_home[1, 0], T_home[1, 1], T_home[1, 2], T_home[1, 3],
            T_home[2, 0], T_home[2, 1], T_home[2, 2], T_home[2, 3])


@_jit
def _motion_apply_home(g: NDArray[np.float64],
                       home: tuple[float, float, float, float, float, float, float, float,
                                   float, float, float, float],
                       turns: tuple[float, float, float, float, float, float], v0: float,
                       v1: float, v2: float, point: bool) -> tuple[float, float, float]:
    """:func:`_motion_apply` with T_home given by its entries, row by row."""
    h00, h01, h02, h03, h10, h11, h12, h13, h20, h21, h22, h23 = home
    c5, s5, c6, s6, c1, s1 = turns
    x0, x1, x2 = _screw_apply(g, 4, c5, s5, v0, v1, v2, point)
    x0, x1, x2 = _screw_apply(g, 5, c6, s6, x0, x1, x2, point)
    y0 = h00 * x0 + h01 * x1 + h02 * x2
    y1 = h10 * x0 + h11 * x1 + h12 * x2
    y2 = h20 * x0 + h21 * x1 + h22 * x2
    if point:
        y0, y1, y2 = y0 + h03, y1 + h13, y2 + h23
    return _screw_apply(g, 0, c1, s1, y0, y1, y2, point)


@_jit
def _arm_point(g: NDArray[np.float64], T_home: NDArray[np.float64],
               turns: tuple[float, float, float, float, float, float]
               ) -> tuple[float, float, float]:
    """The arm's target: point 3 under the motion G of joints 2-4 (turns: cos, sin of -q5,
    -q6, -q1), from point 1, normal to n."""
    return _arm_point_home(g, _home_entries(T_home), turns)


@_jit
def _arm_point_home(g: NDArray[np.float64],
                    home: tuple[float, float, float, float, float, float, float, float, float,
                                float, float, float],
                    turns: tuple[float, float, float, float, float, float]
                    ) -> tuple[float, float, float]:
    """:func:`_arm_point` with T_home given by its entries, row by row."""
    p1 = _vec(g, O_POINTS + 3)
    p3 = _vec(g, O_POINTS + 9)
    a0, a1, a2 = _motion_apply_home(g, home, turns, p3[0], p3[1], p3[2], True)
    return _in_plane(g, a0 - p1[0], a1 - p1[1], a2 - p1[2])


@_jit
def _in_plane(g: NDArray[np.float64], v0: float, v1: float,
              v2: float) -> tuple[float, float, float]:
    """Component of v normal to n."""
    n0, n1, n2 = _vec(g, O_N)
    along = v0 * n0 + v1 * n1 + v2 * n2
    return v0 - along * n0, v1 - along * n1, v2 - along * n2


@_jit
def _plane_angle(g: NDArray[np.float64], v0: float, v1: float, v2: float) -> float:
    """Angle about n of v from plane_x (OffsetWristGeometry.plane_angle)."""
    return atan2(_dot3(v0, v1, v2, g[O_PLANE_Y], g[O_PLANE_Y + 1], g[O_PLANE_Y + 2]),
                 _dot3(v0, v1, v2, g[O_PLANE_X], g[O_PLANE_X + 1], g[O_PLANE_X + 2]))


@_jit
def _wrap_angle(angle: float) -> float:
    """angle wrapped to (-pi, pi] as ``pi - np.mod(pi - angle, 2 pi)``."""
    r = _fmod_two_pi(math.pi - angle)
    if r != 0.0:
        if r < 0.0:
            r += TWO_PI
    else:
        r = 0.0
    return math.pi - r


#: _kept_in_reach: |cos| up to 1 + this counts as reachable. A pose whose arm point reaches the
#: boundary only tangentially (stretched or folded arm at a singular wrist) computes |cos| = 1
#: to rounding, on either side; the moved q6 is verified by FK like every solution.
_REACH_COSINE_SLACK = 1e-12


@_jit
def _kept_in_reach(g: NDArray[np.float64], T_home: NDArray[np.float64],
                   turns: tuple[float, float, float, float, float, float],
                   arm: tuple[float, float, float], q5: float, q6: float, sine: float) -> float:
    """q6, turned onto the arm's reach where the arm point is out of it and the orientation
    allows (offset_wrist.Solver._keep_in_reach); q6 itself otherwise. turns: cos, sin of -q5,
    -q6, -q1; arm: :func:`_arm_point` of them."""
    p1 = _vec(g, O_POINTS + 3)
    arm0, arm1, arm2 = arm
    low = abs(g[O_UPPER_LENGTH] - g[O_FOREARM_LENGTH])
    high = g[O_UPPER_LENGTH] + g[O_FOREARM_LENGTH]
    span = math.sqrt(arm0 * arm0 + arm1 * arm1 + arm2 * arm2)
    tolerance = g[O_REACH_TOLERANCE]
    too_far = span > high + tolerance
    too_near = span < low - tolerance
    if not (too_far or too_near):
        return q6
    wp = _vec(g, O_WRIST_POINT)
    c0, c1, c2 = _motion_apply(g, T_home, turns, wp[0], wp[1], wp[2], True)
    centre0, centre1, centre2 = _in_plane(g, c0 - p1[0], c1 - p1[1], c2 - p1[2])
    boundary = high if too_far else low
    d0, d1, d2 = arm0 - centre0, arm1 - centre1, arm2 - centre2
    radius = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    distance = math.sqrt(centre0 * centre0 + centre1 * centre1 + centre2 * centre2)
    denominator = 2.0 * distance * radius
    if not denominator > g[O_AXIS_TOLERANCE]:
        return q6
    cos_needed = (boundary ** 2 - distance ** 2 - radius ** 2) / denominator
    if not abs(cos_needed) <= 1.0 + _REACH_COSINE_SLACK:
        return q6
    opening = math.acos(min(max(cos_needed, -1.0), 1.0))
    now = _plane_angle(g, d0, d1, d2) - _plane_angle(g, centre0, centre1, centre2)
    first, second = _wrap_angle(opening - now), _wrap_angle(-opening - now)
    turn = first if abs(first) <= abs(second) else second
    w6 = _vec(g, O_DIRECTIONS + 15)
    x0, x1, x2 = _axis_rotate(g, 4, q5, w6[0], w6[1], w6[2])
    axis6 = _motion_apply(g, T_home, turns, x0, x1, x2, False)
    along = _dot3(axis6[0], axis6[1], axis6[2], g[O_N], g[O_N + 1], g[O_N + 2])
    delta = -(1.0 if along >= 0.0 else -1.0) * turn
    if abs(delta) * sine <= g[O_EXACT_BAND]:
        return q6 + delta
    return q6


@_jit
def solve_offset_wrist(g: NDArray[np.float64], T: NDArray[np.float64],
                       seed: NDArray[np.float64], q: NDArray[np.float64],
                       valid: NDArray[np.bool_], flags: NDArray[np.uint8],
                       work: NDArray[np.float64]) -> None:
    """offset_wrist.Solver.solve for one target T (3, 4), DH frame 0 -> 6: q (8, 6), valid,
    flags (8,), branch 4 * shoulder + 2 * elbow + wrist. work: (6, 3, 4) floats."""
    T_home = work[0]
    H = O_HOME_INVERSE  # T_home = T @ M^-1
    for r in range(3):
        for c in range(4):
            T_home[r, c] = (T[r, 0] * g[H + c] + T[r, 1] * g[H + 4 + c]
                            + T[r, 2] * g[H + 8 + c])
        T_home[r, 3] += T[r, 3]
    # step 1: q1, both roots of n(q1) . (wrist - r1) = c
    wf = _vec(g, O_WRIST_IN_FLANGE)
    w0 = T[0, 0] * wf[0] + T[0, 1] * wf[1] + T[0, 2] * wf[2] + T[0, 3]
    w1 = T[1, 0] * wf[0] + T[1, 1] * wf[1] + T[1, 2] * wf[2] + T[1, 3]
    w2 = T[2, 0] * wf[0] + T[2, 1] * wf[1] + T[2, 2] * wf[2] + T[2, 3]
    r1 = _vec(g, O_POINTS)
    h0, h1, h2 = w0 - r1[0], w1 - r1[1], w2 - r1[2]
    along_n = _dot3(h0, h1, h2, g[O_N], g[O_N + 1], g[O_N + 2])
    along_side = _dot3(h0, h1, h2, g[O_SIDE], g[O_SIDE + 1], g[O_SIDE + 2])
    distance = math.sqrt(along_n * along_n + along_side * along_side)
    on_axis = distance <= g[O_AXIS_TOLERANCE]
    phase = seed[0] if on_axis else atan2(along_side, along_n)
    c = g[O_LATERAL]
    gap = distance - abs(c)
    shoulder_ok = gap >= -g[O_REACH_TOLERANCE]
    root = math.sqrt(max(gap, 0.0) * (distance + abs(c)))
    shoulder_singular = shoulder_ok and (root <= g[O_TAN_MERGE] * abs(c) or on_axis)
    if shoulder_singular:
        root = 0.0
    half = 0.0 if on_axis else atan2(root, c)
    left_sign, lateral_sign = g[O_LEFT_SIGN], g[O_LATERAL_SIGN]
    n0, n1, n2 = _vec(g, O_N)
    w6 = _vec(g, O_DIRECTIONS + 15)
    R = O_HOME_R
    for s in range(2):
        q1 = phase + left_sign * half if s == 0 else phase - left_sign * half
        reach_side = lateral_sign if s == 0 else -lateral_sign
        q1_valid = shoulder_ok and (s == 0 or not shoulder_singular)
        # steps 2 and 3: q5 from n(q1) . z6 = cos(q5 - psi), q6 from the rest
        m0, m1, m2 = _axis_rotate(g, 0, q1, n0, n1, n2)
        f0 = T[0, 0] * m0 + T[1, 0] * m1 + T[2, 0] * m2  # R_T^T n(q1)
        f1 = T[0, 1] * m0 + T[1, 1] * m1 + T[2, 1] * m2
        f2 = T[0, 2] * m0 + T[1, 2] * m1 + T[2, 2] * m2
        u0 = g[R] * f0 + g[R + 1] * f1 + g[R + 2] * f2  # u = M_R R_T^T n(q1)
        u1 = g[R + 3] * f0 + g[R + 4] * f1 + g[R + 5] * f2
        u2 = g[R + 6] * f0 + g[R + 7] * f1 + g[R + 8] * f2
        cosine = _dot3(u0, u1, u2, w6[0], w6[1], w6[2])
        x0 = w6[1] * u2 - w6[2] * u1
        x1 = w6[2] * u0 - w6[0] * u2
        x2 = w6[0] * u1 - w6[1] * u0
        sine = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        wrist_singular = sine <= g[O_WRIST_SINGULAR_SIN]
        if wrist_singular:
            sine = 0.0
        q5_half = atan2(sine, cosine)
        along_a = _dot3(u0, u1, u2, w6[0], w6[1], w6[2])
        a0, a1, a2 = u0 - along_a * w6[0], u1 - along_a * w6[1], u2 - along_a * w6[2]
        s1, c1 = sincos(-q1)
        for w in range(2):
            q5 = g[O_PSI] + (g[O_UP_SIGN] * q5_half if w == 0 else -g[O_UP_SIGN] * q5_half)
            s5, c5 = sincos(-q5)
            if wrist_singular:
                q6 = seed[5]
            else:
                t0, t1, t2 = _rotate(g, O_DIRECTIONS + 12, c5, s5, n0, n1, n2)  # R5^T n
                along_b = _dot3(t0, t1, t2, w6[0], w6[1], w6[2])
                b0, b1, b2 = t0 - along_b * w6[0], t1 - along_b * w6[1], t2 - along_b * w6[2]
                q6 = atan2(_dot3(w6[0], w6[1], w6[2], a1 * b2 - a2 * b1, a2 * b0 - a0 * b2,
                                 a0 * b1 - a1 * b0), _dot3(a0, a1, a2, b0, b1, b2))
            s6, c6 = sincos(-q6)
            turns = (c5, s5, c6, s6, c1, s1)
            arm = _arm_point(g, T_home, turns)
            kept = _kept_in_reach(g, T_home, turns, arm, q5, q6, sine)
            if kept != q6:
                q6 = kept
                s6, c6 = sincos(-q6)
                turns = (c5, s5, c6, s6, c1, s1)
                arm = _arm_point(g, T_home, turns)
            _elbow_branches(g, T_home, turns, arm, reach_side, seed[1], q1, q5, q6,
                            _SHOULDER * shoulder_singular | _WRIST * wrist_singular,
                            q1_valid and (w == 0 or not wrist_singular), s, w, q, valid, flags)
    for b in range(q.shape[0]):
        finite = True
        for j in range(6):
            finite = finite and math.isfinite(q[b, j])
        if not finite:
            for j in range(6):
                q[b, j] = 0.0
            valid[b] = False


@_jit
def _elbow_branches(g: NDArray[np.float64], T_home: NDArray[np.float64],
                    turns: tuple[float, float, float, float, float, float],
                    arm: tuple[float, float, float], reach_side: float,
                    seed_q2: float, q1: float, q5: float, q6: float, flag: int,
                    arm_valid: bool, s: int, w: int, q: NDArray[np.float64],
                    valid: NDArray[np.bool_], flags: NDArray[np.uint8]) -> None:
    """Step 4 (offset_wrist.Solver._elbow): q2, q3, q4 of both elbow branches for the motion
    G of joints 2-4 (turns: cos, sin of -q5, -q6, -q1; arm: :func:`_arm_point`), written with
    q1, q5, q6 into branches 4 s + 2 e + w."""
    t0, t1, t2 = arm
    span = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    L2, L3 = g[O_UPPER_LENGTH], g[O_FOREARM_LENGTH]
    low, high = abs(L2 - L3), L2 + L3
    outer = high - span
    inner = span - low
    tolerance = g[O_REACH_TOLERANCE]
    reach_ok = outer >= -tolerance and inner >= -tolerance
    disc = (max(outer, 0.0) * (high + span) * max(inner, 0.0) * (span + low)) / 4.0
    root = math.sqrt(disc)
    kappa = (span * span - L2 * L2 - L3 * L3) / 2.0
    singular = reach_ok and root <= g[O_TAN_MERGE] * abs(kappa)
    if singular:
        root = 0.0
    half = atan2(root, kappa)
    base = g[O_ELBOW_BASE]
    first, second = base + half, base - half
    sf, cf = sincos(first)
    ss, cs = sincos(second)
    turn = cf * g[O_ELBOW_TURN] + g[O_SIGN3] * sf * g[O_ELBOW_ALPHA]
    if (1.0 if turn >= 0.0 else -1.0) != reach_side:
        first, second, sf, cf, ss, cs = second, first, ss, cs, sf, cf
    n0, n1, n2 = _vec(g, O_N)
    v0, v1, v2 = _vec(g, O_UPPER_ARM)
    u0, u1, u2 = _vec(g, O_FOREARM)
    k0, k1, k2 = _vec(g, O_W3_X_FOREARM)
    px = _vec(g, O_PLANE_X)
    r0, r1, r2 = _motion_apply(g, T_home, turns, px[0], px[1], px[2], False)
    total = _plane_angle(g, r0, r1, r2)
    for e in range(2):
        q3, s3, c3 = (first, sf, cf) if e == 0 else (second, ss, cs)
        bent0, bent1, bent2 = v0 + c3 * u0 + s3 * k0, v1 + c3 * u1 + s3 * k1, v2 + c3 * u2 + s3 * k2
        if math.sqrt(bent0 * bent0 + bent1 * bent1 + bent2 * bent2) <= g[O_AXIS_TOLERANCE]:
            q2 = seed_q2
        else:
            q2 = atan2(_dot3(n0, n1, n2, bent1 * t2 - bent2 * t1, bent2 * t0 - bent0 * t2,
                             bent0 * t1 - bent1 * t0), _dot3(bent0, bent1, bent2, t0, t1, t2))
        q4 = g[O_SIGN4] * (total - q2 - g[O_SIGN3] * q3)
        b = 4 * s + 2 * e + w
        q[b, 0], q[b, 1], q[b, 2], q[b, 3], q[b, 4], q[b, 5] = q1, q2, q3, q4, q5, q6
        valid[b] = arm_valid and reach_ok and (e == 0 or not singular)
        flags[b] = flag | (_ELBOW if singular else 0)


# --------------------------------------------------------------------------------------------
# The offset-wrist family by blocks of poses: solve_offset_wrist stage by stage over lanes (a
# pose, a pose's shoulder branch, or its shoulder and wrist branch), as _spherical_block; the
# rare arm point out of reach (_kept_in_reach) is handled lane by lane.

# Rows of the per-pose scratch of _offset_block (T_home: rows 0-11, row by row)
_OP_PHASE, _OP_HALF, _OP_SHOULDER_OK, _OP_SHOULDER_SINGULAR, _OP_ON_AXIS = range(12, 17)
# Rows of the per-shoulder-branch scratch (lane s * W + k)
_OS_Q1, _OS_SINE, _OS_SINGULAR, _OS_A, _OS_Q5_HALF, _OS_S1, _OS_C1 = 0, 1, 2, 3, 6, 7, 8
# Rows of the per-arm scratch (lane (2 s + w) * W + k)
_OA_Q5, _OA_Q6, _OA_S5, _OA_C5, _OA_S6, _OA_C6, _OA_ARM, _OA_OUTSIDE, _OA_TOTAL, _OA_REACH_OK, \
    _OA_SINGULAR, _OA_Q3, _OA_S3, _OA_C3 = 0, 1, 2, 3, 4, 5, 6, 9, 10, 11, 12, 13, 15, 17


@_jit
def _block_home(pose: NDArray[np.float64], k: int) -> tuple[float, float, float, float, float,
                                                             float, float, float, float, float,
                                                             float, float]:
    """Pose k's T_home entries, row by row, from the per-pose scratch."""
    return (pose[0, k], pose[1, k], pose[2, k], pose[3, k], pose[4, k], pose[5, k],
            pose[6, k], pose[7, k], pose[8, k], pose[9, k], pose[10, k], pose[11, k])


@_jit
def _offset_block(g: NDArray[np.float64], targets: NDArray[np.float64],
                  seeds: NDArray[np.float64], q: NDArray[np.float64], valid: NDArray[np.bool_],
                  flags: NDArray[np.uint8], pose: NDArray[np.float64],
                  side: NDArray[np.float64], arm: NDArray[np.float64],
                  args: NDArray[np.float64], work: NDArray[np.float64]) -> None:
    """:func:`solve_offset_wrist` for the ``count`` poses of a block: targets (12, W) (see
    :func:`_block_target`), seeds (6, W) -> q (count, 8, 6), valid (>= count, 8), flags
    (count, 8). The same values, computed stage by stage over lanes. Scratch: pose (17, W),
    side (9, 2 W), arm (19, 4 W), args (3, 8 W), work (3, 4)."""
    W = targets.shape[1]
    H = O_HOME_INVERSE
    wf = _vec(g, O_WRIST_IN_FLANGE)
    r1 = _vec(g, O_POINTS)
    c = g[O_LATERAL]
    Y, X, A = args[0, :2 * W], args[1, :2 * W], args[2, :2 * W]
    for k in range(W):  # step 1 up to its atan2 calls
        T = _block_target(targets, k)
        for r in range(3):
            t0, t1, t2, t3 = T[4 * r], T[4 * r + 1], T[4 * r + 2], T[4 * r + 3]
            for col in range(4):
                pose[4 * r + col, k] = t0 * g[H + col] + t1 * g[H + 4 + col] + t2 * g[H + 8 + col]
            pose[4 * r + 3, k] += t3
        t00, t01, t02, t03, t10, t11, t12, t13, t20, t21, t22, t23 = T
        w0 = t00 * wf[0] + t01 * wf[1] + t02 * wf[2] + t03
        w1 = t10 * wf[0] + t11 * wf[1] + t12 * wf[2] + t13
        w2 = t20 * wf[0] + t21 * wf[1] + t22 * wf[2] + t23
        h0, h1, h2 = w0 - r1[0], w1 - r1[1], w2 - r1[2]
        along_n = _dot3(h0, h1, h2, g[O_N], g[O_N + 1], g[O_N + 2])
        along_side = _dot3(h0, h1, h2, g[O_SIDE], g[O_SIDE + 1], g[O_SIDE + 2])
        distance = math.sqrt(along_n * along_n + along_side * along_side)
        on_axis = distance <= g[O_AXIS_TOLERANCE]
        gap = distance - abs(c)
        shoulder_ok = gap >= -g[O_REACH_TOLERANCE]
        root = math.sqrt(max(gap, 0.0) * (distance + abs(c)))
        shoulder_singular = shoulder_ok and (root <= g[O_TAN_MERGE] * abs(c) or on_axis)
        Y[k], X[k] = along_side, along_n
        Y[W + k], X[W + k] = 0.0 if shoulder_singular else root, c
        pose[_OP_SHOULDER_OK, k] = 1.0 if shoulder_ok else 0.0
        pose[_OP_SHOULDER_SINGULAR, k] = 1.0 if shoulder_singular else 0.0
        pose[_OP_ON_AXIS, k] = 1.0 if on_axis else 0.0
    _atan2_lanes(Y, X, A)
    for k in range(W):
        on_axis = pose[_OP_ON_AXIS, k] != 0.0
        pose[_OP_PHASE, k] = seeds[0, k] if on_axis else A[k]
        pose[_OP_HALF, k] = 0.0 if on_axis else A[W + k]
    _offset_sides(g, targets, pose, side, args)
    _offset_wrists(g, seeds, pose, side, arm, args, work)
    _offset_elbows(g, pose, side, arm, args)
    _offset_store(g, seeds, pose, side, arm, args, q, valid, flags)


@_jit
def _offset_sides(g: NDArray[np.float64], targets: NDArray[np.float64],
                  pose: NDArray[np.float64], side: NDArray[np.float64],
                  args: NDArray[np.float64]) -> None:
    """Per shoulder branch (lane s * W + k): q1, and steps 2 and 3 of solve_offset_wrist up to
    q5_half."""
    W = pose.shape[1]
    left_sign = g[O_LEFT_SIGN]
    n0, n1, n2 = _vec(g, O_N)
    w6 = _vec(g, O_DIRECTIONS + 15)
    R = O_HOME_R
    theta, sine, cosine = args[0, :4 * W], args[1, :4 * W], args[2, :4 * W]
    for s in range(2):
        for k in range(W):
            phase, half = pose[_OP_PHASE, k], pose[_OP_HALF, k]
            q1 = phase + left_sign * half if s == 0 else phase - left_sign * half
            side[_OS_Q1, s * W + k] = q1
            theta[s * W + k] = q1
            theta[2 * W + s * W + k] = -q1
    _sincos_lanes(theta, sine, cosine)
    Y, X = args[0, :2 * W], args[0, 2 * W:4 * W]  # theta's row: read already
    for s in range(2):
        for k in range(W):
            lane = s * W + k
            t00, t01, t02, _, t10, t11, t12, _, t20, t21, t22, _ = _block_target(targets, k)
            m0, m1, m2 = _rotate(g, O_DIRECTIONS, cosine[lane], sine[lane], n0, n1, n2)
            side[_OS_S1, lane], side[_OS_C1, lane] = sine[2 * W + lane], cosine[2 * W + lane]
            f0 = t00 * m0 + t10 * m1 + t20 * m2  # R_T^T n(q1)
            f1 = t01 * m0 + t11 * m1 + t21 * m2
            f2 = t02 * m0 + t12 * m1 + t22 * m2
            u0 = g[R] * f0 + g[R + 1] * f1 + g[R + 2] * f2  # u = M_R R_T^T n(q1)
            u1 = g[R + 3] * f0 + g[R + 4] * f1 + g[R + 5] * f2
            u2 = g[R + 6] * f0 + g[R + 7] * f1 + g[R + 8] * f2
            cos5 = _dot3(u0, u1, u2, w6[0], w6[1], w6[2])
            x0 = w6[1] * u2 - w6[2] * u1
            x1 = w6[2] * u0 - w6[0] * u2
            x2 = w6[0] * u1 - w6[1] * u0
            sin5 = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
            wrist_singular = sin5 <= g[O_WRIST_SINGULAR_SIN]
            sin5 = 0.0 if wrist_singular else sin5
            side[_OS_SINE, lane] = sin5
            side[_OS_SINGULAR, lane] = 1.0 if wrist_singular else 0.0
            Y[lane], X[lane] = sin5, cos5
            along_a = _dot3(u0, u1, u2, w6[0], w6[1], w6[2])
            side[_OS_A, lane] = u0 - along_a * w6[0]
            side[_OS_A + 1, lane] = u1 - along_a * w6[1]
            side[_OS_A + 2, lane] = u2 - along_a * w6[2]
    A = args[1, :2 * W]
    _atan2_lanes(Y, X, A)
    for lane in range(2 * W):
        side[_OS_Q5_HALF, lane] = A[lane]


@_jit
def _arm_turns(arm: NDArray[np.float64], side: NDArray[np.float64], i: int,
               lane: int) -> tuple[float, float, float, float, float, float]:
    """The turns (cos, sin of -q5, -q6, -q1) of arm lane i on shoulder lane ``lane``."""
    return (arm[_OA_C5, i], arm[_OA_S5, i], arm[_OA_C6, i], arm[_OA_S6, i], side[_OS_C1, lane],
            side[_OS_S1, lane])


@_jit
def _offset_wrists(g: NDArray[np.float64], seeds: NDArray[np.float64],
                   pose: NDArray[np.float64], side: NDArray[np.float64],
                   arm: NDArray[np.float64], args: NDArray[np.float64],
                   work: NDArray[np.float64]) -> None:
    """Per arm lane (2 s + w) * W + k: q5, q6 (kept in reach), their turns and the arm
    point."""
    W = pose.shape[1]
    n = 4 * W
    n0, n1, n2 = _vec(g, O_N)
    w6 = _vec(g, O_DIRECTIONS + 15)
    up = g[O_UP_SIGN]
    theta, sine, cosine = args[0, :n], args[1, :n], args[2, :n]
    for group in range(4):
        s, w = group // 2, group % 2
        for k in range(W):
            i = group * W + k
            q5_half = side[_OS_Q5_HALF, s * W + k]
            q5 = g[O_PSI] + (up * q5_half if w == 0 else -up * q5_half)
            arm[_OA_Q5, i] = q5
            theta[i] = -q5
    _sincos_lanes(theta, sine, cosine)
    for i in range(n):
        arm[_OA_S5, i], arm[_OA_C5, i] = sine[i], cosine[i]
    Y, X, A = args[0, :n], args[1, :n], args[2, :n]
    for group in range(4):
        s = group // 2
        for k in range(W):
            i = group * W + k
            lane = s * W + k
            t0, t1, t2 = _rotate(g, O_DIRECTIONS + 12, arm[_OA_C5, i], arm[_OA_S5, i], n0, n1,
                                 n2)  # R5^T n
            along_b = _dot3(t0, t1, t2, w6[0], w6[1], w6[2])
            b0, b1, b2 = t0 - along_b * w6[0], t1 - along_b * w6[1], t2 - along_b * w6[2]
            a0, a1, a2 = side[_OS_A, lane], side[_OS_A + 1, lane], side[_OS_A + 2, lane]
            Y[i] = _dot3(w6[0], w6[1], w6[2], a1 * b2 - a2 * b1, a2 * b0 - a0 * b2,
                         a0 * b1 - a1 * b0)
            X[i] = _dot3(a0, a1, a2, b0, b1, b2)
    _atan2_lanes(Y, X, A)
    for group in range(4):
        s = group // 2
        for k in range(W):
            i = group * W + k
            singular = side[_OS_SINGULAR, s * W + k] != 0.0
            q6 = seeds[5, k] if singular else A[i]
            arm[_OA_Q6, i] = q6
            theta[i] = -q6
    _sincos_lanes(theta, sine, cosine)
    low = abs(g[O_UPPER_LENGTH] - g[O_FOREARM_LENGTH])
    high = g[O_UPPER_LENGTH] + g[O_FOREARM_LENGTH]
    tolerance = g[O_REACH_TOLERANCE]
    outside = 0
    for group in range(4):
        s = group // 2
        for k in range(W):
            i = group * W + k
            arm[_OA_S6, i], arm[_OA_C6, i] = sine[i], cosine[i]
            t0, t1, t2 = _arm_point_home(g, _block_home(pose, k),
                                         _arm_turns(arm, side, i, s * W + k))
            arm[_OA_ARM, i], arm[_OA_ARM + 1, i], arm[_OA_ARM + 2, i] = t0, t1, t2
            span = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)  # _kept_in_reach's test
            out = (span > high + tolerance) | (span < low - tolerance)
            arm[_OA_OUTSIDE, i] = 1.0 if out else 0.0
            outside += 1 if out else 0
    if outside > 0:
        _keep_lanes_in_reach(g, pose, side, arm, work)


@_jit
def _keep_lanes_in_reach(g: NDArray[np.float64], pose: NDArray[np.float64],
                         side: NDArray[np.float64], arm: NDArray[np.float64],
                         work: NDArray[np.float64]) -> None:
    """:func:`_kept_in_reach` for the lanes whose arm point is out of reach (q6, its turns and
    the arm point updated where it moves q6). work: (3, 4) for T_home."""
    W = pose.shape[1]
    for group in range(4):
        s = group // 2
        for k in range(W):
            i = group * W + k
            lane = s * W + k
            if arm[_OA_OUTSIDE, i] == 0.0:
                continue
            for r in range(3):
                for col in range(4):
                    work[r, col] = pose[4 * r + col, k]
            turns = _arm_turns(arm, side, i, lane)
            q6 = arm[_OA_Q6, i]
            kept = _kept_in_reach(g, work, turns, (arm[_OA_ARM, i], arm[_OA_ARM + 1, i],
                                                   arm[_OA_ARM + 2, i]), arm[_OA_Q5, i], q6,
                                  side[_OS_SINE, lane])
            if kept != q6:
                arm[_OA_Q6, i] = kept
                arm[_OA_S6, i], arm[_OA_C6, i] = sincos(-kept)
                t0, t1, t2 = _arm_point(g, work, _arm_turns(arm, side, i, lane))
                arm[_OA_ARM, i], arm[_OA_ARM + 1, i], arm[_OA_ARM + 2, i] = t0, t1, t2


@_jit
def _offset_elbows(g: NDArray[np.float64], pose: NDArray[np.float64],
                   side: NDArray[np.float64], arm: NDArray[np.float64],
                   args: NDArray[np.float64]) -> None:
    """Per arm lane: :func:`_elbow_branches` up to both elbows' q3 (ordered by reach side)
    and the plane angle ``total``."""
    W = pose.shape[1]
    n = 4 * W
    L2, L3 = g[O_UPPER_LENGTH], g[O_FOREARM_LENGTH]
    low, high = abs(L2 - L3), L2 + L3
    tolerance = g[O_REACH_TOLERANCE]
    px = _vec(g, O_PLANE_X)
    Y, X, A = args[0, :2 * n], args[1, :2 * n], args[2, :2 * n]
    for group in range(4):
        s = group // 2
        for k in range(W):
            i = group * W + k
            t0, t1, t2 = arm[_OA_ARM, i], arm[_OA_ARM + 1, i], arm[_OA_ARM + 2, i]
            span = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            outer = high - span
            inner = span - low
            reach_ok = outer >= -tolerance and inner >= -tolerance
            disc = (max(outer, 0.0) * (high + span) * max(inner, 0.0) * (span + low)) / 4.0
            root = math.sqrt(disc)
            kappa = (span * span - L2 * L2 - L3 * L3) / 2.0
            singular = reach_ok and root <= g[O_TAN_MERGE] * abs(kappa)
            arm[_OA_REACH_OK, i] = 1.0 if reach_ok else 0.0
            arm[_OA_SINGULAR, i] = 1.0 if singular else 0.0
            Y[i], X[i] = 0.0 if singular else root, kappa
            r0, r1, r2 = _motion_apply_home(g, _block_home(pose, k),
                                            _arm_turns(arm, side, i, s * W + k), px[0], px[1],
                                            px[2], False)
            Y[n + i] = _dot3(r0, r1, r2, g[O_PLANE_Y], g[O_PLANE_Y + 1], g[O_PLANE_Y + 2])
            X[n + i] = _dot3(r0, r1, r2, g[O_PLANE_X], g[O_PLANE_X + 1], g[O_PLANE_X + 2])
    _atan2_lanes(Y, X, A)
    base = g[O_ELBOW_BASE]
    theta, sine, cosine = args[0, :2 * n], args[1, :2 * n], args[2, :2 * n]
    for i in range(n):
        half = A[i]
        arm[_OA_TOTAL, i] = A[n + i]
        theta[i] = base + half
        theta[n + i] = base - half
    _sincos_lanes(theta, sine, cosine)
    lateral_sign = g[O_LATERAL_SIGN]
    for group in range(4):
        s = group // 2
        reach_side = lateral_sign if s == 0 else -lateral_sign
        for k in range(W):
            i = group * W + k
            first, second = theta[i], theta[n + i]
            sf, cf, ss, cs = sine[i], cosine[i], sine[n + i], cosine[n + i]
            turn = cf * g[O_ELBOW_TURN] + g[O_SIGN3] * sf * g[O_ELBOW_ALPHA]
            swap = (1.0 if turn >= 0.0 else -1.0) != reach_side
            arm[_OA_Q3, i], arm[_OA_Q3 + 1, i] = (second, first) if swap else (first, second)
            arm[_OA_S3, i], arm[_OA_S3 + 1, i] = (ss, sf) if swap else (sf, ss)
            arm[_OA_C3, i], arm[_OA_C3 + 1, i] = (cs, cf) if swap else (cf, cs)


@_jit
def _offset_store(g: NDArray[np.float64], seeds: NDArray[np.float64],
                  pose: NDArray[np.float64], side: NDArray[np.float64],
                  arm: NDArray[np.float64], args: NDArray[np.float64],
                  q: NDArray[np.float64], valid: NDArray[np.bool_],
                  flags: NDArray[np.uint8]) -> None:
    """q2 and q4 of both elbows of every arm lane (:func:`_elbow_branches`), and the branches
    4 s + 2 e + w of solve_offset_wrist for the poses < count."""
    W = pose.shape[1]
    n = 4 * W
    n0, n1, n2 = _vec(g, O_N)
    v0, v1, v2 = _vec(g, O_UPPER_ARM)
    u0, u1, u2 = _vec(g, O_FOREARM)
    k0, k1, k2 = _vec(g, O_W3_X_FOREARM)
    Y, X, A = args[0, :2 * n], args[1, :2 * n], args[2, :2 * n]
    for e in range(2):
        for i in range(n):
            t0, t1, t2 = arm[_OA_ARM, i], arm[_OA_ARM + 1, i], arm[_OA_ARM + 2, i]
            s3, c3 = arm[_OA_S3 + e, i], arm[_OA_C3 + e, i]
            bent0, bent1, bent2 = (v0 + c3 * u0 + s3 * k0, v1 + c3 * u1 + s3 * k1,
                                   v2 + c3 * u2 + s3 * k2)
            free = math.sqrt(bent0 * bent0 + bent1 * bent1 + bent2 * bent2) <= g[
                O_AXIS_TOLERANCE]
            Y[e * n + i] = _dot3(n0, n1, n2, bent1 * t2 - bent2 * t1, bent2 * t0 - bent0 * t2,
                                 bent0 * t1 - bent1 * t0)
            X[e * n + i] = _dot3(bent0, bent1, bent2, t0, t1, t2)
            arm[_OA_S3 + e, i] = 1.0 if free else 0.0  # s3 is used: the free flag from here
    _atan2_lanes(Y, X, A)
    for k in range(q.shape[0]):
        shoulder_singular = pose[_OP_SHOULDER_SINGULAR, k] != 0.0
        shoulder_ok = pose[_OP_SHOULDER_OK, k] != 0.0
        for group in range(4):
            s, w = group // 2, group % 2
            i = group * W + k
            lane = s * W + k
            wrist_singular = side[_OS_SINGULAR, lane] != 0.0
            q1_valid = shoulder_ok and (s == 0 or not shoulder_singular)
            arm_valid = q1_valid and (w == 0 or not wrist_singular)
            singular = arm[_OA_SINGULAR, i] != 0.0
            flag = (_SHOULDER * shoulder_singular | _WRIST * wrist_singular) | (
                _ELBOW if singular else 0)
            q1, q5, q6 = side[_OS_Q1, lane], arm[_OA_Q5, i], arm[_OA_Q6, i]
            for e in range(2):
                q3 = arm[_OA_Q3 + e, i]
                q2 = seeds[1, k] if arm[_OA_S3 + e, i] != 0.0 else A[e * n + i]
                q4 = g[O_SIGN4] * (arm[_OA_TOTAL, i] - q2 - g[O_SIGN3] * q3)
                b = 4 * s + 2 * e + w
                q[k, b, 0], q[k, b, 1], q[k, b, 2] = q1, q2, q3
                q[k, b, 3], q[k, b, 4], q[k, b, 5] = q4, q5, q6
                ok = (arm_valid and arm[_OA_REACH_OK, i] != 0.0 and (e == 0 or not singular))
                finite = True
                for j in range(6):
                    finite = finite and math.isfinite(q[k, b, j])
                if not finite:
                    for j in range(6):
                        q[k, b, j] = 0.0
                valid[k, b] = ok and finite
                flags[k, b] = flag


@_jit
def _solve_family(family: int, geometry: NDArray[np.float64], T: NDArray[np.float64],
                  seed: NDArray[np.float64], q: NDArray[np.float64], valid: NDArray[np.bool_],
                  flags: NDArray[np.uint8], work: NDArray[np.float64]) -> None:
    """The compiled family solver ``family`` for one target; work: (6, 3, 4) floats."""
    if family == SPHERICAL_WRIST:
        solve_spherical_wrist(geometry, T, seed, q, valid, flags, work[0].reshape(12))
    elif family == STANFORD:
        solve_stanford(geometry, T, seed, q, valid, flags, work[0].reshape(12))
    elif family == OFFSET_WRIST:
        solve_offset_wrist(geometry, T, seed, q, valid, flags, work)
    else:
        valid[:] = False


# --------------------------------------------------------------------------------------------
# The pipeline


@_jit
def _finish_pose(chain: NDArray[np.float64], modified: bool, limits: NDArray[np.float64],
                 T: NDArray[np.float64], tolerances: NDArray[np.float64],
                 q: NDArray[np.float64], valid: NDArray[np.bool_], ok: NDArray[np.bool_],
                 recheck: NDArray[np.bool_], totals: NDArray[np.int64],
                 errors: NDArray[np.float64], trig: NDArray[np.float64],
                 states: NDArray[np.float64]) -> None:
    """Wrap q (B, n) in place and verify each valid branch by FK against T (3, 4): ok,
    recheck, the number of in-limit copies (totals) and errors (B, 3) (position, s, c)."""
    n_branches, n = q.shape
    usable = ok  # ok doubles as the usable mask until _verify_branches sets it
    for b in range(n_branches):
        finite = valid[b]
        if finite:
            for j in range(n):
                if chain[j, C_REVOLUTE] != 0.0:
                    q[b, j] = wrap(q[b, j])
                finite = finite and math.isfinite(q[b, j])
        usable[b] = finite
    _verify_branches(chain, modified, q, usable, T, tolerances, ok, recheck, errors, trig,
                     states)
    for b in range(n_branches):
        total = 0
        if ok[b]:
            total = 1
            for j in range(n):
                _, count = copy_range(limits[j], chain[j, C_REVOLUTE] != 0.0, q[b, j],
                                      tolerances[4])
                total *= count
        totals[b] = total


#: Poses per block of :func:`solve_principal` (the block solvers and :func:`_finish_block`; their
#: lanes' arrays stay in the L1 cache).
BLOCK_POSES = 32
#: Joints of the chains the block functions handle (every compiled family); other chains take
#: the per-pose functions.
BLOCK_DOF = 6


@_jit
def _joint_constants(chain: NDArray[np.float64], j: int) -> tuple[float, float, float]:
    """a, cos(alpha), sin(alpha) of joint j."""
    return chain[j, C_A], chain[j, C_COS_ALPHA], chain[j, C_SIN_ALPHA]


@_jit
def _lane_errors(chain: NDArray[np.float64], modified: bool, sine: NDArray[np.float64],
                 cosine: NDArray[np.float64], offsets: NDArray[np.float64],
                 targets: NDArray[np.float64], lanes: NDArray[np.float64]) -> None:
    """(position, s, c) of :func:`_pose_error` for every lane (b, k) of a block, branch b of
    its pose k, into lanes[1:4] (7, B, W): FK of a 6-joint chain from sine, cosine and the DH
    offsets d (6, B, W) of each lane, against the pose's target (targets (12, W): rotation
    column by column, then position). The loop over poses is branch free and inlines
    everything: the compiler vectorises it."""
    n_branches, width = lanes.shape[1], lanes.shape[2]
    a0, ca0, sa0 = _joint_constants(chain, 0)
    a1, ca1, sa1 = _joint_constants(chain, 1)
    a2, ca2, sa2 = _joint_constants(chain, 2)
    a3, ca3, sa3 = _joint_constants(chain, 3)
    a4, ca4, sa4 = _joint_constants(chain, 4)
    a5, ca5, sa5 = _joint_constants(chain, 5)
    for b in range(n_branches):
        for k in range(width):
            state = _dh_step(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
                             sine[0, b, k], cosine[0, b, k], offsets[0, b, k], a0, ca0, sa0,
                             modified)
            state = _dh_step(*state, sine[1, b, k], cosine[1, b, k], offsets[1, b, k], a1, ca1,
                             sa1, modified)
            state = _dh_step(*state, sine[2, b, k], cosine[2, b, k], offsets[2, b, k], a2, ca2,
                             sa2, modified)
            state = _dh_step(*state, sine[3, b, k], cosine[3, b, k], offsets[3, b, k], a3, ca3,
                             sa3, modified)
            state = _dh_step(*state, sine[4, b, k], cosine[4, b, k], offsets[4, b, k], a4, ca4,
                             sa4, modified)
            state = _dh_step(*state, sine[5, b, k], cosine[5, b, k], offsets[5, b, k], a5, ca5,
                             sa5, modified)
            position, s, c = _state_error(
                *state, targets[0, k], targets[1, k], targets[2, k], targets[3, k],
                targets[4, k], targets[5, k], targets[6, k], targets[7, k], targets[8, k],
                targets[9, k], targets[10, k], targets[11, k])
            lanes[1, b, k] = position
            lanes[2, b, k] = s
            lanes[3, b, k] = c


@_jit
def _block_errors(chain: NDArray[np.float64], modified: bool, sine: NDArray[np.float64],
                  cosine: NDArray[np.float64], offsets: NDArray[np.float64],
                  targets: NDArray[np.float64], lanes: NDArray[np.float64]) -> None:
    """:func:`_lane_errors` with the DH convention a constant of each loop."""
    if modified:
        _lane_errors(chain, True, sine, cosine, offsets, targets, lanes)
    else:
        _lane_errors(chain, False, sine, cosine, offsets, targets, lanes)


@_jit
def _wrap_lane(value: float) -> float:
    """:func:`wrap` by selects (the compiler vectorises loops calling it): the same value where
    |pi - value| < 4 pi; ``value`` itself elsewhere (and for NaN), which callers wrap
    themselves (see :func:`_wrap_lanes`)."""
    x = math.pi - value
    size = abs(x)
    r = x if size < TWO_PI else (x - TWO_PI if x > 0.0 else -(size - TWO_PI))
    r = r + TWO_PI if r < 0.0 else r
    r = 0.0 if r == 0.0 else r
    inside = (-math.pi < value) & (value <= math.pi)
    reduced = size < 2.0 * TWO_PI
    return value if inside or not reduced else math.pi - r


@_jit
def _wrap_lanes(chain: NDArray[np.float64], values: NDArray[np.float64],
                lane: NDArray[np.float64]) -> None:
    """Revolute joint values (n, B, W) wrapped in place (:func:`wrap`) where ``lane`` (B, W)
    is 1.0 (the branch is valid); then lane = 0.0 where a value is not finite."""
    n, n_branches, width = values.shape
    far = 0  # an integer sum: a float one would not be vectorised (its order is fixed)
    for j in range(n):
        if chain[j, C_REVOLUTE] != 0.0:
            for b in range(n_branches):
                for k in range(width):
                    v = values[j, b, k]
                    w = _wrap_lane(v)
                    far += 0 if abs(math.pi - v) < 2.0 * TWO_PI else 1
                    values[j, b, k] = w if lane[b, k] != 0.0 else v
    if far > 0:  # |value| >= 3 pi, inf or NaN: rare
        for j in range(n):
            if chain[j, C_REVOLUTE] != 0.0:
                for b in range(n_branches):
                    for k in range(width):
                        if lane[b, k] != 0.0:
                            values[j, b, k] = wrap(values[j, b, k])
    for j in range(n):
        for b in range(n_branches):
            for k in range(width):
                finite = abs(values[j, b, k]) < math.inf
                lane[b, k] = lane[b, k] if finite else 0.0


@_jit
def _block_thetas(chain: NDArray[np.float64], values: NDArray[np.float64],
                  lane: NDArray[np.float64], theta: NDArray[np.float64],
                  offsets: NDArray[np.float64]) -> None:
    """DH theta (n, B, W) of every joint value (:func:`_theta`; 0 where lane (B, W) is 0.0)
    and the DH offset d of prismatic joints."""
    n, n_branches, width = values.shape
    for j in range(n):
        direction, offset = chain[j, C_DIRECTION], chain[j, C_OFFSET]
        if chain[j, C_REVOLUTE] != 0.0:
            for b in range(n_branches):
                for k in range(width):
                    theta[j, b, k] = (direction * values[j, b, k] + offset
                                      if lane[b, k] != 0.0 else 0.0)
        else:
            fixed = chain[j, C_THETA]
            for b in range(n_branches):
                for k in range(width):
                    theta[j, b, k] = fixed
                    offsets[j, b, k] = direction * (values[j, b, k] if lane[b, k] != 0.0
                                                    else 0.0) + offset


@_jit
def _block_verdicts(chain: NDArray[np.float64], limits: NDArray[np.float64],
                    tolerances: NDArray[np.float64], values: NDArray[np.float64],
                    lanes: NDArray[np.float64]) -> None:
    """ok, recheck (1.0 / 0.0) and the number of in-limit copies of every lane from its errors
    and joint values (n, B, W): :func:`_within` and :func:`copy_range` by selects. lanes
    (7, B, W): usable, position, s, c (inputs), ok, recheck, copies (outputs)."""
    n, n_branches, width = values.shape
    usable, position, s, c = lanes[0], lanes[1], lanes[2], lanes[3]
    ok, close, total = lanes[4], lanes[5], lanes[6]
    tolerance, tangent = tolerances[0], tolerances[1]
    inner, inner_tangent = tolerances[2], tolerances[3]
    if tangent == tangent and inner_tangent == inner_tangent:
        for b in range(n_branches):
            for k in range(width):
                cb = c[b, k]
                passed = ((usable[b, k] != 0.0) & (position[b, k] <= tolerance) & (cb > 0.0)
                          & (s[b, k] <= tangent * cb))
                within = ((position[b, k] <= inner) & (cb > 0.0)
                          & (s[b, k] <= inner_tangent * cb))
                ok[b, k] = 1.0 if passed else 0.0
                close[b, k] = 1.0 if passed and not within else 0.0
                total[b, k] = 1.0
    else:  # a tolerance outside [0, pi/2): atan2
        for b in range(n_branches):
            for k in range(width):
                passed = usable[b, k] != 0.0 and _within(position[b, k], s[b, k], c[b, k],
                                                         tolerance, tangent)
                ok[b, k] = 1.0 if passed else 0.0
                close[b, k] = 1.0 if passed and not _within(
                    position[b, k], s[b, k], c[b, k], inner, inner_tangent) else 0.0
                total[b, k] = 1.0
    slack = tolerances[4]
    for j in range(n):
        low, high = limits[j, 0] - slack, limits[j, 1] + slack
        if chain[j, C_REVOLUTE] != 0.0:
            for b in range(n_branches):
                for k in range(width):
                    v = values[j, b, k]
                    first = np.ceil((low - v) * _INVERSE_TWO_PI)  # floats: no conversions
                    last = np.floor((high - v) * _INVERSE_TWO_PI)
                    total[b, k] *= max(last - first + 1.0, 0.0)
        else:
            for b in range(n_branches):
                for k in range(width):
                    v = values[j, b, k]
                    total[b, k] *= 1.0 if (low <= v) & (v <= high) else 0.0


@_jit
def _finish_block(chain: NDArray[np.float64], modified: bool, limits: NDArray[np.float64],
                  targets: NDArray[np.float64], tolerances: NDArray[np.float64],
                  q: NDArray[np.float64], valid: NDArray[np.bool_], ok: NDArray[np.bool_],
                  recheck: NDArray[np.bool_], totals: NDArray[np.int64],
                  trig: NDArray[np.float64], lanes: NDArray[np.float64]) -> None:
    """:func:`_finish_pose` for a block of ``count`` <= W poses of a 6-joint chain: q
    (count, B, 6) (wrapped in place) and valid (count, B) -> ok, recheck, totals (count, B);
    targets (12, W) as in :func:`_lane_errors`. The same values as _finish_pose (the same
    operations in the same order), computed stage by stage over the block's lanes (branch b of
    pose k) in loops the compiler vectorises; lanes past ``count`` hold stale values, unused.

    Scratch: trig (5, 6, B, W) (values, theta, sine, cosine, d) whose d rows of revolute joints
    hold the joint's d; lanes (7, B, W) (see :func:`_block_verdicts`)."""
    count, n_branches, n = q.shape
    width = targets.shape[1]
    values, theta, sine, cosine, offsets = trig[0], trig[1], trig[2], trig[3], trig[4]
    usable = lanes[0]
    for k in range(count):
        for b in range(n_branches):
            usable[b, k] = 1.0 if valid[k, b] else 0.0
            for j in range(n):
                values[j, b, k] = q[k, b, j]
    for k in range(count, width):
        for b in range(n_branches):
            usable[b, k] = 0.0
    _wrap_lanes(chain, values, usable)
    _block_thetas(chain, values, usable, theta, offsets)
    size = theta.size
    _sincos_map(theta.reshape(size), sine.reshape(size), cosine.reshape(size))
    _block_errors(chain, modified, sine, cosine, offsets, targets, lanes)
    _block_verdicts(chain, limits, tolerances, values, lanes)
    passed, close, total = lanes[4], lanes[5], lanes[6]
    for k in range(count):
        for b in range(n_branches):
            for j in range(n):
                q[k, b, j] = values[j, b, k]
            ok[k, b] = passed[b, k] != 0.0
            recheck[k, b] = close[b, k] != 0.0
            totals[k, b] = int(total[b, k]) if passed[b, k] != 0.0 else 0


@_jit
def _block_scratch(chain: NDArray[np.float64], n_branches: int,
                   width: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """trig (5, n, B, W) and lanes (7, B, W) of :func:`_finish_block`, the d rows of revolute
    joints filled."""
    n = chain.shape[0]
    trig = np.zeros((5, n, n_branches, width))
    for j in range(n):
        if chain[j, C_REVOLUTE] != 0.0:
            trig[4, j] = chain[j, C_D]
    return trig, np.zeros((7, n_branches, width))


@_jit
def solve_principal(family: int, geometry: NDArray[np.float64], chain: NDArray[np.float64],
                    modified: bool, limits: NDArray[np.float64], frames: NDArray[np.float64],
                    targets: NDArray[np.float64], seeds: NDArray[np.float64],
                    tolerances: NDArray[np.float64], q: NDArray[np.float64],
                    ok: NDArray[np.bool_], flags: NDArray[np.uint8],
                    recheck: NDArray[np.bool_], totals: NDArray[np.int64],
                    status: NDArray[np.int8]) -> None:
    """Steps 1-3 of the pipeline for poses targets (N, 4, 4) with a compiled family: input
    check (status), target conversion, the family's principal solutions, wrap and FK check.
    6-joint chains run by blocks of BLOCK_POSES poses: the spherical-wrist and offset-wrist
    solvers by :func:`_spherical_block` and :func:`_offset_block` (other families pose by
    pose), then :func:`_finish_block`; other chains pose by pose.

    seeds: (N, n) or (1, n) for all. Outputs q (N, B, n), ok, flags, recheck, totals (N, B).
    """
    n_poses, n_branches, n = q.shape
    if n != BLOCK_DOF:
        _solve_principal_per_pose(family, geometry, chain, modified, limits, frames, targets,
                                  seeds, tolerances, q, ok, flags, recheck, totals, status)
        return
    width = BLOCK_POSES
    raw = np.zeros((17, width))
    T_dh = np.empty((3, 4))
    valid = np.empty((width, n_branches), np.bool_)
    work = np.zeros((6, 3, 4))
    block_targets = np.zeros((12, width))
    block_seeds = np.zeros((n, width))
    spherical, offset = family == SPHERICAL_WRIST, family == OFFSET_WRIST
    blocked = (spherical or offset) and n_branches == BRANCHES  # by the block solvers
    pose, side = np.zeros((17, width)), np.zeros((13, 2 * width))
    arm, args = np.zeros((19, 4 * width)), np.zeros((3, 8 * width))
    trig, lanes = _block_scratch(chain, n_branches, width)
    for start in range(0, n_poses, width):
        stop = min(start + width, n_poses)
        _block_poses(frames, targets, start, status[start:stop], raw, block_targets)
        for i in range(start, stop):
            k = i - start
            if status[i] != 0:
                continue
            row = i if seeds.shape[0] > 1 else 0
            if blocked:
                for j in range(n):
                    block_seeds[j, k] = seeds[row, j]
            else:
                for c in range(3):
                    for r in range(3):
                        T_dh[r, c] = block_targets[3 * c + r, k]
                    T_dh[c, 3] = block_targets[9 + c, k]
                _solve_family(family, geometry, T_dh, seeds[row], q[i], valid[k], flags[i],
                              work)
        if blocked and spherical:
            _spherical_block(geometry, block_targets, block_seeds, q[start:stop], valid,
                             flags[start:stop], pose, side, arm, args)
        elif blocked:
            _offset_block(geometry, block_targets, block_seeds, q[start:stop], valid,
                          flags[start:stop], pose, side, arm, args, work[0])
        for i in range(start, stop):
            if status[i] != 0:
                flags[i, :] = 0
                valid[i - start, :] = False
        _finish_block(chain, modified, limits, block_targets, tolerances, q[start:stop],
                      valid, ok[start:stop], recheck[start:stop], totals[start:stop], trig,
                      lanes)


@_jit
def _solve_principal_per_pose(family: int, geometry: NDArray[np.float64],
                              chain: NDArray[np.float64], modified: bool,
                              limits: NDArray[np.float64], frames: NDArray[np.float64],
                              targets: NDArray[np.float64], seeds: NDArray[np.float64],
                              tolerances: NDArray[np.float64], q: NDArray[np.float64],
                              ok: NDArray[np.bool_], flags: NDArray[np.uint8],
                              recheck: NDArray[np.bool_], totals: NDArray[np.int64],
                              status: NDArray[np.int8]) -> None:
    """:func:`solve_principal` pose by pose (chains of other than BLOCK_DOF joints)."""
    n_branches, n = q.shape[1], q.shape[2]
    T_dh = np.empty((3, 4))
    valid = np.empty(n_branches, np.bool_)
    work = np.zeros((6, 3, 4))
    errors = np.empty((n_branches, 3))
    trig = np.empty((3, n_branches * n))
    states = np.empty((n + 1, 12))
    for i in range(targets.shape[0]):
        status[i] = target_status(targets[i])
        if status[i] != 0:
            ok[i, :] = False
            totals[i, :] = 0
            flags[i, :] = 0
            continue
        dh_target(frames, targets[i], T_dh)
        seed = seeds[i] if seeds.shape[0] > 1 else seeds[0]
        _solve_family(family, geometry, T_dh, seed, q[i], valid, flags[i], work)
        _finish_pose(chain, modified, limits, T_dh, tolerances, q[i], valid, ok[i], recheck[i],
                     totals[i], errors, trig, states)


@_jit
def solve_branches(family: int, geometry: NDArray[np.float64], targets_dh: NDArray[np.float64],
                   seeds: NDArray[np.float64], q: NDArray[np.float64], valid: NDArray[np.bool_],
                   flags: NDArray[np.uint8]) -> None:
    """Step 2 alone: the compiled family's principal solutions of DH targets (N, 4, 4) into
    q (N, B, n), valid, flags (N, B); seeds (N, n) or (1, n) for all. The spherical-wrist and
    offset-wrist families by blocks (as in :func:`solve_principal`), others pose by pose."""
    work = np.zeros((6, 3, 4))
    n_poses, n_branches, n = q.shape
    spherical, offset = family == SPHERICAL_WRIST, family == OFFSET_WRIST
    if (spherical or offset) and n_branches == BRANCHES and n == BLOCK_DOF:
        width = BLOCK_POSES
        block_targets, block_seeds = np.zeros((12, width)), np.zeros((n, width))
        pose, side = np.zeros((17, width)), np.zeros((13, 2 * width))
        arm, args = np.zeros((19, 4 * width)), np.zeros((3, 8 * width))
        for start in range(0, n_poses, width):
            stop = min(start + width, n_poses)
            for i in range(start, stop):
                k = i - start
                for c in range(3):
                    for r in range(3):
                        block_targets[3 * c + r, k] = targets_dh[i, r, c]
                    block_targets[9 + c, k] = targets_dh[i, c, 3]
                row = i if seeds.shape[0] > 1 else 0
                for j in range(n):
                    block_seeds[j, k] = seeds[row, j]
            if spherical:
                _spherical_block(geometry, block_targets, block_seeds, q[start:stop],
                                 valid[start:stop], flags[start:stop], pose, side, arm, args)
            else:
                _offset_block(geometry, block_targets, block_seeds, q[start:stop],
                              valid[start:stop], flags[start:stop], pose, side, arm, args,
                              work[0])
        return
    for i in range(targets_dh.shape[0]):
        seed = seeds[i] if seeds.shape[0] > 1 else seeds[0]
        _solve_family(family, geometry, targets_dh[i], seed, q[i], valid[i], flags[i], work)


@_jit
def finish_principal(chain: NDArray[np.float64], modified: bool, limits: NDArray[np.float64],
                     targets_dh: NDArray[np.float64], tolerances: NDArray[np.float64],
                     q: NDArray[np.float64], valid: NDArray[np.bool_], ok: NDArray[np.bool_],
                     recheck: NDArray[np.bool_], totals: NDArray[np.int64]) -> None:
    """Step 3 for branch solutions of a family without a compiled solver: q (N, B, n) (wrapped
    in place) and valid (N, B) of DH targets (N, 4, 4) -> ok, recheck, totals (N, B); by
    blocks (:func:`_finish_block`) for 6-joint chains."""
    n_poses, n_branches, n = q.shape
    if n == BLOCK_DOF:
        width = BLOCK_POSES
        block_targets = np.zeros((12, width))
        trig, lanes = _block_scratch(chain, n_branches, width)
        for start in range(0, n_poses, width):
            stop = min(start + width, n_poses)
            for i in range(start, stop):
                for c in range(3):
                    for r in range(3):
                        block_targets[3 * c + r, i - start] = targets_dh[i, r, c]
                    block_targets[9 + c, i - start] = targets_dh[i, c, 3]
            _finish_block(chain, modified, limits, block_targets, tolerances, q[start:stop],
                          valid[start:stop], ok[start:stop], recheck[start:stop],
                          totals[start:stop], trig, lanes)
        return
    errors = np.empty((n_branches, 3))
    trig = np.empty((3, n_branches * n))
    states = np.empty((n + 1, 12))
    for i in range(q.shape[0]):
        _finish_pose(chain, modified, limits, targets_dh[i], tolerances, q[i], valid[i], ok[i],
                     recheck[i], totals[i], errors, trig, states)


@_jit
def _copy_value(q: NDArray[np.float64], lo: NDArray[np.int64], digits: NDArray[np.int64],
                limits: NDArray[np.float64], chain: NDArray[np.float64],
                out: NDArray[np.float64]) -> bool:
    """out = q + 2pi (lo + digits) clipped to the limits; True where clipping moved a value."""
    clipped = False
    for j in range(q.shape[0]):
        value = q[j] + TWO_PI * (lo[j] + digits[j]) if chain[j, C_REVOLUTE] != 0.0 else q[j]
        bounded = min(max(value, limits[j, 0]), limits[j, 1])
        clipped = clipped or bounded != value
        out[j] = bounded
    return clipped


@_jit
def _checked(chain: NDArray[np.float64], modified: bool, frames: NDArray[np.float64],
             target: NDArray[np.float64], tolerances: NDArray[np.float64],
             value: NDArray[np.float64], T_dh: NDArray[np.float64], have_target: bool,
             fk_work: NDArray[np.float64]) -> tuple[bool, float, float, float]:
    """FK check of one copy: (passed, position, s, c); T_dh is computed on first use."""
    if not have_target:
        dh_target(frames, target, T_dh)
    position, s, c = fk_error(chain, modified, value, T_dh, fk_work)
    return _within(position, s, c, tolerances[0], tolerances[1]), position, s, c


@_jit
def _expand_pose(chain: NDArray[np.float64], modified: bool, limits: NDArray[np.float64],
                 frames: NDArray[np.float64], target: NDArray[np.float64],
                 tolerances: NDArray[np.float64], copies: bool, q: NDArray[np.float64],
                 ok: NDArray[np.bool_], flags: NDArray[np.uint8], recheck: NDArray[np.bool_],
                 totals: NDArray[np.int64], errors: NDArray[np.float64],
                 out_q: NDArray[np.float64], out_branch: NDArray[np.int16],
                 out_flags: NDArray[np.uint8], out_errors: NDArray[np.float64],
                 T_dh: NDArray[np.float64],
                 indices: NDArray[np.int64], fk_work: NDArray[np.float64]) -> int:
    """Step 4 for one pose: the returned solutions, in order of branch, then of copy (mixed
    radix over the joints' copies, last joint fastest).

    copies=False keeps one copy per branch: the one with each joint nearest to 0 (if that copy
    fails its check: the passing copy with the least sum |q|). A copy is verified by FK itself
    only where clipping moved it onto a limit or its branch's error is within COPY_MARGIN of the
    tolerance (recheck); otherwise it has its branch's errors.

    Inputs: the pose's principal data q (B, n), ok, flags, recheck, totals (B,), errors (B, 3)
    (position, s, c). Outputs: rows of out_q (M, n), out_branch, out_flags (M,) and, if it has M
    rows too, out_errors (M, 2) = position, rotation error; rows past the count are left as they
    are. (No flag argument: a literal True or False would compile this function twice.)
    Returns the count, or -1 when M is too small. Scratch: T_dh (3, 4), indices (3, n) ints,
    fk_work (n + 3, 12).
    """
    n = q.shape[1]
    capacity = out_q.shape[0]
    with_errors = out_errors.shape[0] == capacity
    lo, counts, digits = indices[0], indices[1], indices[2]
    have_target = False
    slot = 0
    for b in range(q.shape[0]):
        if not ok[b] or totals[b] == 0:
            continue
        if not copies and not recheck[b]:  # fast path: the principal value is in the limits
            inside = True
            for j in range(n):
                inside = inside and limits[j, 0] <= q[b, j] <= limits[j, 1]
            if inside:
                if slot >= capacity:
                    return -1
                for j in range(n):
                    out_q[slot, j] = q[b, j]
                out_branch[slot] = b
                out_flags[slot] = flags[b]
                if with_errors:
                    out_errors[slot, 0] = errors[b, 0]
                    out_errors[slot, 1] = atan2(errors[b, 1], errors[b, 2])
                slot += 1
                continue
        for j in range(n):
            lo[j], counts[j] = copy_range(limits[j], chain[j, C_REVOLUTE] != 0.0, q[b, j],
                                          tolerances[4])
            if copies:  # odometer over the copies, last joint fastest
                digits[j] = 0
            else:  # the copy nearest to 0: turn clip(0, lo, lo + count - 1)
                digits[j] = min(max(0, lo[j]), lo[j] + counts[j] - 1) - lo[j]
        number = totals[b] if copies else 1
        for index in range(number):
            if index > 0:
                j = n - 1
                digits[j] += 1
                while digits[j] == counts[j]:
                    digits[j] = 0
                    j -= 1
                    digits[j] += 1
            if slot >= capacity:
                return -1
            value = out_q[slot]
            clipped = _copy_value(q[b], lo, digits, limits, chain, value)
            position, s, c = errors[b, 0], errors[b, 1], errors[b, 2]
            if clipped or recheck[b]:
                passed, position, s, c = _checked(chain, modified, frames, target, tolerances,
                                                  value, T_dh, have_target, fk_work)
                have_target = True
                if not passed and not copies and _best_copy(
                        chain, modified, limits, T_dh, tolerances, q[b], lo, counts, digits,
                        value, fk_work) >= 0.0:
                    passed, position, s, c = _checked(chain, modified, frames, target,
                                                      tolerances, value, T_dh, have_target,
                                                      fk_work)
                if not passed:
                    continue
            out_branch[slot] = b
            out_flags[slot] = flags[b]
            if with_errors:
                out_errors[slot, 0] = position
                out_errors[slot, 1] = atan2(s, c)
            slot += 1
    return slot


@_jit
def _best_copy(chain: NDArray[np.float64], modified: bool, limits: NDArray[np.float64],
               T_dh: NDArray[np.float64], tolerances: NDArray[np.float64],
               q: NDArray[np.float64], lo: NDArray[np.int64], counts: NDArray[np.int64],
               digits: NDArray[np.int64], value: NDArray[np.float64],
               fk_work: NDArray[np.float64]) -> float:
    """Among all copies of one branch, the passing one with the least sum |q|: into value and
    digits; returns that sum, or -1 when none passes (rare: see _expand_pose)."""
    n = q.shape[0]
    total = 1
    for j in range(n):
        total *= counts[j]
    best = -1.0
    best_digits = np.zeros(n, np.int64)
    for index in range(total):
        rest = index
        for j in range(n - 1, -1, -1):
            digits[j] = rest % counts[j]
            rest //= counts[j]
        _copy_value(q, lo, digits, limits, chain, value)
        position, s, c = fk_error(chain, modified, value, T_dh, fk_work)
        if not _within(position, s, c, tolerances[0], tolerances[1]):
            continue
        size = 0.0
        for j in range(n):
            size += abs(value[j])
        if best < 0.0 or size < best:
            best = size
            best_digits[:] = digits
    if best >= 0.0:
        digits[:] = best_digits
        _copy_value(q, lo, digits, limits, chain, value)
    return best


@_jit
def expand(chain: NDArray[np.float64], modified: bool, limits: NDArray[np.float64],
           frames: NDArray[np.float64], targets: NDArray[np.float64],
           tolerances: NDArray[np.float64], copies: bool, q: NDArray[np.float64],
           ok: NDArray[np.bool_], flags: NDArray[np.uint8], recheck: NDArray[np.bool_],
           totals: NDArray[np.int64], out_q: NDArray[np.float64], out_valid: NDArray[np.bool_],
           out_flags: NDArray[np.uint8], out_branch: NDArray[np.int16], aliased: bool) -> int:
    """Step 4 for N poses: principal data q (N, B, n), ok, flags, recheck, totals (N, B) ->
    padded outputs out_q (N, m, n), out_valid, out_flags, out_branch (N, m) (padding: q 0,
    valid False, flags 0, branch -1). ``aliased``: the outputs are the principal arrays
    themselves (copies=False, m = B); each pose is then copied before it is written, unless
    none of the copies it keeps needs an FK check of its own (:func:`_pack_principal`,
    :func:`_pack_nearest`, in place). Returns the widest row's count, or -1 when m is too
    small."""
    n_poses, n_branches, n = q.shape
    width = out_q.shape[1]
    pose_q = np.empty((n_branches, n))
    pose_ok = np.empty(n_branches, np.bool_)
    pose_flags = np.empty(n_branches, np.uint8)
    errors = np.zeros((n_branches, 3))
    no_errors = np.empty((1, 2))
    T_dh = np.empty((3, 4))
    indices = np.empty((3, n), np.int64)
    fk_work = np.empty((n + 3, 12))
    widest = 0
    for i in range(n_poses):
        if not copies and _principal_values_suffice(limits, q, ok, recheck, totals, i):
            count = _pack_principal(q, ok, flags, totals, out_q, out_branch, out_flags, i)
        elif not copies and _nearest_copies_suffice(chain, limits, tolerances, q, ok, recheck,
                                                    totals, i):
            count = _pack_nearest(chain, limits, tolerances, q, ok, flags, totals, out_q,
                                  out_branch, out_flags, i)
        elif aliased:
            for b in range(n_branches):
                for j in range(n):
                    pose_q[b, j] = q[i, b, j]
                pose_ok[b] = ok[i, b]
                pose_flags[b] = flags[i, b]
            count = _expand_pose(chain, modified, limits, frames, targets[i], tolerances,
                                 copies, pose_q, pose_ok, pose_flags, recheck[i], totals[i],
                                 errors, out_q[i], out_branch[i], out_flags[i], no_errors,
                                 T_dh, indices, fk_work)
        else:
            count = _expand_pose(chain, modified, limits, frames, targets[i], tolerances,
                                 copies, q[i], ok[i], flags[i], recheck[i], totals[i], errors,
                                 out_q[i], out_branch[i], out_flags[i], no_errors, T_dh,
                                 indices, fk_work)
        if count < 0:
            return -1
        widest = max(widest, count)
        for k in range(count):
            out_valid[i, k] = True
        for k in range(count, width):
            for j in range(n):
                out_q[i, k, j] = 0.0
            out_valid[i, k] = False
            out_flags[i, k] = 0
            out_branch[i, k] = -1
    return widest


@_jit
def _nearest_copy(chain: NDArray[np.float64], limits: NDArray[np.float64],
                  tolerances: NDArray[np.float64], j: int, value: float) -> float:
    """The copy of joint j's value ``value`` that _expand_pose keeps with copies=False before
    clipping: value + 2pi turn, the turn of :func:`copy_range`'s nearest to 0 (the same
    operations as :func:`_copy_value`); a prismatic value itself. The value must have a copy
    (its branch's total is not 0)."""
    if chain[j, C_REVOLUTE] == 0.0:
        return value
    lo = math.ceil((limits[j, 0] - tolerances[4] - value) * _INVERSE_TWO_PI)  # copy_range
    hi = math.floor((limits[j, 1] + tolerances[4] - value) * _INVERSE_TWO_PI)
    return value + TWO_PI * min(max(0, lo), hi)


@_jit
def _nearest_copies_suffice(chain: NDArray[np.float64], limits: NDArray[np.float64],
                            tolerances: NDArray[np.float64], q: NDArray[np.float64],
                            ok: NDArray[np.bool_], recheck: NDArray[np.bool_],
                            totals: NDArray[np.int64], i: int) -> bool:
    """Whether no passing branch of pose i needs an FK check of its own in _expand_pose with
    copies=False: none needs a recheck, and each copy kept (:func:`_nearest_copy` of each joint
    of a branch with a value outside the limits) is inside the limits, so not clipped. Then
    :func:`_pack_nearest` gives _expand_pose's answer."""
    for b in range(q.shape[1]):
        if ok[i, b] and totals[i, b] != 0:
            if recheck[i, b]:
                return False
            for j in range(q.shape[2]):
                value = q[i, b, j]
                if not limits[j, 0] <= value <= limits[j, 1]:
                    value = _nearest_copy(chain, limits, tolerances, j, value)
                    if not limits[j, 0] <= value <= limits[j, 1]:
                        return False
    return True


@_jit
def _pack_nearest(chain: NDArray[np.float64], limits: NDArray[np.float64],
                  tolerances: NDArray[np.float64], q: NDArray[np.float64], ok: NDArray[np.bool_],
                  flags: NDArray[np.uint8], totals: NDArray[np.int64],
                  out_q: NDArray[np.float64], out_branch: NDArray[np.int16],
                  out_flags: NDArray[np.uint8], i: int) -> int:
    """_expand_pose with copies=False for pose i of which :func:`_nearest_copies_suffice`: per
    passing branch, in order of branch, its principal values where they are all inside the
    limits, else the copies nearest 0 of all its joints (:func:`_nearest_copy`). In place as
    :func:`_pack_principal`. Returns the count, or -1 when out_q has too few rows."""
    slot = 0
    n = q.shape[2]
    for b in range(q.shape[1]):
        if ok[i, b] and totals[i, b] != 0:
            if slot >= out_q.shape[1]:
                return -1
            inside = True
            for j in range(n):
                value = q[i, b, j]
                inside = inside & (limits[j, 0] <= value) & (value <= limits[j, 1])
            for j in range(n):
                value = q[i, b, j]
                out_q[i, slot, j] = value if inside else _nearest_copy(chain, limits,
                                                                       tolerances, j, value)
            out_branch[i, slot] = b
            out_flags[i, slot] = flags[i, b]
            slot += 1
    return slot


@_jit
def _principal_values_suffice(limits: NDArray[np.float64], q: NDArray[np.float64],
                              ok: NDArray[np.bool_], recheck: NDArray[np.bool_],
                              totals: NDArray[np.int64], i: int) -> bool:
    """Whether every passing branch of pose i (q (N, B, n), ok, recheck, totals (N, B)) has
    its principal value inside the limits and needs no recheck: _expand_pose's fast path with
    copies=False, taken by every branch (see :func:`_pack_principal`). (Whole arrays and an
    index: a view per pose would cost its reference counting.)"""
    for b in range(q.shape[1]):
        if ok[i, b] and totals[i, b] != 0:
            if recheck[i, b]:
                return False
            for j in range(q.shape[2]):
                if not limits[j, 0] <= q[i, b, j] <= limits[j, 1]:
                    return False
    return True


@_jit
def _pack_principal(q: NDArray[np.float64], ok: NDArray[np.bool_], flags: NDArray[np.uint8],
                    totals: NDArray[np.int64], out_q: NDArray[np.float64],
                    out_branch: NDArray[np.int16], out_flags: NDArray[np.uint8], i: int) -> int:
    """_expand_pose with copies=False for pose i of which :func:`_principal_values_suffice`:
    the passing branches' principal values, in order of branch. The outputs may be the inputs
    themselves (row ``slot`` <= b is written after row b is read). Returns the count, or -1
    when out_q has too few rows."""
    slot = 0
    for b in range(q.shape[1]):
        if ok[i, b] and totals[i, b] != 0:
            if slot >= out_q.shape[1]:
                return -1
            for j in range(q.shape[2]):
                out_q[i, slot, j] = q[i, b, j]
            out_branch[i, slot] = b
            out_flags[i, slot] = flags[i, b]
            slot += 1
    return slot


# Layout of the ``plan`` of :func:`solve_one` (:func:`plan_array`): family id, DH convention
# (1.0: modified), branches B, joints n, then the geometry, chain (n, 8) and limits (n, 2).
P_FAMILY, P_MODIFIED, P_BRANCHES, P_DOF, P_GEOMETRY = range(5)


def one_scratch_size(n: int, n_branches: int) -> int:
    """Length of solve_one's float scratch for n joints and B branches."""
    return 12 + n_branches * n + 72 + 3 * n_branches + 3 * n_branches * n + 12 * (n + 1) + 12 \
        + 12 * (n + 3)


@_jit
def solve_one(plan: NDArray[np.float64], frames: NDArray[np.float64],
              target: NDArray[np.float64], seed: NDArray[np.float64],
              tolerances: NDArray[np.float64], copies: bool, out_q: NDArray[np.float64],
              out_errors: NDArray[np.float64], out_keys: NDArray[np.int64],
              scratch: NDArray[np.float64]) -> int:
    """The whole pipeline for one pose (4, 4) with a compiled family, in one call (few arguments:
    each costs time to pass).

    out_q (M, n): the solutions; out_errors (M, 2): position and rotation error; out_keys (M,):
    8 * configuration code (:func:`configuration_code`) + flags, or 8 * (branch - B) + flags
    when the code does not fit. scratch: (:func:`one_scratch_size`,) floats. Returns the number
    of solutions, -STATUS_* for a bad target or seed, or NEEDS_MORE_ROWS.
    """
    status = target_status(target)
    if status != 0:
        return -status
    family, modified = int(plan[P_FAMILY]), plan[P_MODIFIED] != 0.0
    n_branches, n = int(plan[P_BRANCHES]), int(plan[P_DOF])
    geometry = plan[P_GEOMETRY:P_GEOMETRY + GEOMETRY_SIZE]
    at = P_GEOMETRY + GEOMETRY_SIZE
    chain = plan[at:at + 8 * n].reshape(n, 8)
    limits = plan[at + 8 * n:at + 10 * n].reshape(n, 2)
    for j in range(n):
        if not math.isfinite(seed[j]):
            return -STATUS_BAD_SEED
    B = n_branches
    T_dh = scratch[0:12].reshape(3, 4)
    at = 12
    q = scratch[at:at + B * n].reshape(B, n)
    at += B * n
    work = scratch[at:at + 72].reshape(6, 3, 4)
    at += 72
    errors = scratch[at:at + 3 * B].reshape(B, 3)
    at += 3 * B
    trig = scratch[at:at + 3 * B * n].reshape(3, B * n)
    at += 3 * B * n
    states = scratch[at:at + 12 * (n + 1)].reshape(n + 1, 12)
    at += 12 * (n + 1)
    copy_target = scratch[at:at + 12].reshape(3, 4)
    at += 12
    fk_work = scratch[at:at + 12 * (n + 3)].reshape(n + 3, 12)
    valid = np.empty(B, np.bool_)
    ok = np.empty(B, np.bool_)
    recheck = np.empty(B, np.bool_)
    flags = np.zeros(B, np.uint8)
    totals = np.empty(B, np.int64)
    indices = np.empty((3, n), np.int64)
    rows = out_q.shape[0]
    out_branch = np.empty(rows, np.int16)
    out_flags = np.empty(rows, np.uint8)
    dh_target(frames, target, T_dh)
    _solve_family(family, geometry, T_dh, seed, q, valid, flags, work)
    _finish_pose(chain, modified, limits, T_dh, tolerances, q, valid, ok, recheck, totals,
                 errors, trig, states)
    count = _expand_pose(chain, modified, limits, frames, target, tolerances, copies, q, ok,
                         flags, recheck, totals, errors, out_q, out_branch, out_flags,
                         out_errors, copy_target, indices, fk_work)
    if count < 0:
        return NEEDS_MORE_ROWS
    for k in range(count):
        code = configuration_code(chain, out_q[k], out_branch[k], B)
        out_keys[k] = 8 * (code if code >= 0 else out_branch[k] - B) + out_flags[k]
    return count


#: Turns are stored with this offset in :func:`configuration_code` (|turns| < it).
TURN_OFFSET = 64


@_jit
def configuration_code(chain: NDArray[np.float64], q: NDArray[np.float64], branch: int,
                       n_branches: int) -> int:
    """One integer for (branch, turns): branch + B * sum_j (turn_j + 64) * 128^j, with
    turn_j = round(q_j / 2pi) for revolute joints (0 for prismatic); -1 when a turn is too
    large to encode."""
    code = 0
    place = 1
    for j in range(q.shape[0]):
        turn = np.rint(q[j] * _INVERSE_TWO_PI) if chain[j, C_REVOLUTE] != 0.0 else 0.0
        if not abs(turn) < TURN_OFFSET:
            return -1
        code += (int(turn) + TURN_OFFSET) * place
        place *= 2 * TURN_OFFSET
    return branch + n_branches * code


# --------------------------------------------------------------------------------------------
# Python-side helpers: layouts


def chain_array(a: NDArray[np.float64], alpha: NDArray[np.float64], d: NDArray[np.float64],
                theta: NDArray[np.float64], direction: NDArray[np.float64],
                offset: NDArray[np.float64], revolute: NDArray[np.bool_]) -> NDArray[np.float64]:
    """The ``chain`` layout (n, 8) from per-joint DH values (SI units)."""
    return np.ascontiguousarray(np.stack(
        [a, np.cos(alpha), np.sin(alpha), d, theta, direction, offset,
         revolute.astype(float)], axis=1), dtype=np.float64)


def arm_geometry(*, centre_in_flange: NDArray[np.float64], origin: NDArray[np.float64],
                 forward: NDArray[np.float64], lateral: NDArray[np.float64],
                 up: NDArray[np.float64], shoulder_offset: float, lateral_offset: float,
                 signs: tuple[float, float, float], wrist_frame: NDArray[np.float64],
                 flange_rotation: NDArray[np.float64], tilt: float,
                 wrist_directions: tuple[int, int, int], scale: float, snap: float,
                 wrist_snap: float, flag: float, arm: tuple[float, ...]) -> NDArray[np.float64]:
    """The ``geometry`` layout of the spherical-wrist and Stanford families."""
    g = np.zeros(GEOMETRY_SIZE)
    g[G_CENTRE_IN_FLANGE:G_CENTRE_IN_FLANGE + 3] = centre_in_flange
    g[G_ORIGIN:G_ORIGIN + 3] = origin
    g[G_FORWARD:G_FORWARD + 3] = forward
    g[G_LATERAL:G_LATERAL + 3] = lateral
    g[G_UP:G_UP + 3] = up
    g[G_SHOULDER_OFFSET] = shoulder_offset
    g[G_LATERAL_OFFSET] = lateral_offset
    g[G_SIGNS:G_SIGNS + 3] = signs
    g[G_WRIST_FRAME:G_WRIST_FRAME + 9] = np.asarray(wrist_frame).ravel()
    c, s = math.cos(tilt), math.sin(tilt)
    tilt_back = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    g[G_TARGET_TO_WRIST:G_TARGET_TO_WRIST + 9] = (
        np.asarray(flange_rotation).T @ wrist_frame @ tilt_back).ravel()
    g[G_TILT] = tilt
    g[G_WRIST_DIRECTIONS:G_WRIST_DIRECTIONS + 3] = wrist_directions
    g[G_SCALE] = scale
    g[G_SNAP] = snap
    g[G_WRIST_SNAP] = wrist_snap
    g[G_FLAG] = flag
    if len(arm) > GEOMETRY_SIZE - G_ARM:
        raise ValueError(f"arm: at most {GEOMETRY_SIZE - G_ARM} values, got {len(arm)}")
    g[G_ARM:G_ARM + len(arm)] = arm
    return g


def offset_wrist_geometry(*, directions: NDArray[np.float64], points: NDArray[np.float64],
                          up_1: NDArray[np.float64], n: NDArray[np.float64],
                          plane_x: NDArray[np.float64], wrist_in_flange: NDArray[np.float64],
                          wrist_point: NDArray[np.float64], home: NDArray[np.float64],
                          home_inverse: NDArray[np.float64], upper_arm: NDArray[np.float64],
                          forearm: NDArray[np.float64], lateral: float, psi: float,
                          q5_singular: float, sign3: float, sign4: float, upper_length: float,
                          forearm_length: float, axis_tolerance: float, reach_tolerance: float,
                          merge_angle: float, wrist_singular_sin: float,
                          exact_band: float) -> NDArray[np.float64]:
    """The ``geometry`` layout of the offset-wrist family (from OffsetWristGeometry)."""
    g = np.zeros(GEOMETRY_SIZE)
    g[O_DIRECTIONS:O_DIRECTIONS + 18] = np.asarray(directions).ravel()
    g[O_POINTS:O_POINTS + 18] = np.asarray(points).ravel()
    g[O_N:O_N + 3] = n
    g[O_SIDE:O_SIDE + 3] = np.cross(directions[0], n)
    g[O_PLANE_X:O_PLANE_X + 3] = plane_x
    g[O_PLANE_Y:O_PLANE_Y + 3] = np.cross(n, plane_x)
    g[O_WRIST_IN_FLANGE:O_WRIST_IN_FLANGE + 3] = wrist_in_flange
    g[O_WRIST_POINT:O_WRIST_POINT + 3] = wrist_point
    g[O_HOME_R:O_HOME_R + 9] = np.asarray(home)[:3, :3].ravel()
    g[O_HOME_INVERSE:O_HOME_INVERSE + 12] = np.asarray(home_inverse)[:3, :].ravel()
    g[O_UPPER_ARM:O_UPPER_ARM + 3] = upper_arm
    g[O_FOREARM:O_FOREARM + 3] = forearm
    g[O_W3_X_FOREARM:O_W3_X_FOREARM + 3] = np.cross(directions[2], forearm)
    c = lateral if abs(lateral) > axis_tolerance else 0.0
    g[O_LATERAL] = c
    lateral_sign = -1.0 if c < 0 else 1.0
    g[O_LEFT_SIGN] = lateral_sign * float(np.dot(directions[0], up_1))
    g[O_LATERAL_SIGN] = lateral_sign
    g[O_UP_SIGN] = 1.0 if math.cos(q5_singular - psi) > 0 else -1.0
    g[O_PSI] = psi
    g[O_SIGN3] = sign3
    g[O_SIGN4] = sign4
    g[O_UPPER_LENGTH] = upper_length
    g[O_FOREARM_LENGTH] = forearm_length
    alpha = float(np.dot(upper_arm, forearm))
    beta = float(np.dot(upper_arm, np.cross(directions[2], forearm)))
    g[O_ELBOW_ALPHA] = alpha
    g[O_ELBOW_BASE] = math.atan2(beta, alpha)
    g[O_ELBOW_TURN] = float(np.dot(np.cross(upper_arm, forearm), n))
    g[O_AXIS_TOLERANCE] = axis_tolerance
    g[O_REACH_TOLERANCE] = reach_tolerance
    g[O_TAN_MERGE] = math.tan(merge_angle)
    g[O_WRIST_SINGULAR_SIN] = wrist_singular_sin
    g[O_EXACT_BAND] = exact_band
    return g


def plan_array(family: int, modified: bool, n_branches: int, geometry: NDArray[np.float64],
               chain: NDArray[np.float64], limits: NDArray[np.float64]) -> NDArray[np.float64]:
    """The ``plan`` of :func:`solve_one` (layout P_*)."""
    n = chain.shape[0]
    head = np.array([family, 1.0 if modified else 0.0, n_branches, n], dtype=np.float64)
    geometry_part = np.zeros(GEOMETRY_SIZE)
    geometry_part[:geometry.shape[0]] = geometry
    return np.ascontiguousarray(np.concatenate([head, geometry_part, chain.ravel(),
                                                limits.ravel()]))
