"""The exact chain: forward kinematics, pose errors, Jacobian and damped Newton refinement.

Any serial chain of a DH table, corrections included, is written as

    T(q) = P_1 Z_1(v_1) P_2 Z_2(v_2) ... P_n Z_n(v_n) P_tail,    v_j = direction_j q_j + offset_j

with P_j constant rigid transforms and Z_j = Rz(v_j) (revolute) or Tz(v_j) (prismatic): joint j
moves about / along the z axis of the frame P_1 Z_1 ... P_j. ``T`` is DH frame 0 -> DH frame n
(the pipeline turns targets into that frame). The ``chain`` array (n + 1, :data:`ROW`) holds per
joint j < n: P_j (3 x 4, row-major), then revolute (1.0) or prismatic (0.0), direction and offset
(:data:`JOINT`); row n holds P_tail. :func:`dhkin.ik.solver.chain_array` builds it from a table.

A frame (3 x 4) is kept as 12 floats, row-major: r00 r01 r02 p0 r10 r11 r12 p1 r20 r21 r22 p2.
Errors are measured against a target frame (3, 4): position |p - p_t| (m) and the rotation angle
of R^T R_t (rad), computed as atan2(s, c) with s = |vee(E - E^T)| / 2, c = (trace E - 1) / 2.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dhkin.ik.compiled.elementary import atan2, sincos
from dhkin.ik.compiled.jit import jit, jit_literal
from dhkin.ik.compiled.layout import layout

#: Columns of a ``chain`` row: the constant frame before the joint's motion, then the motion.
JOINT = layout("ChainRow", [("pre", 12), ("revolute", 1), ("direction", 1), ("offset", 1)])


ROW = JOINT.size


#: Refinement stops once both errors are below this fraction of the verification tolerance (a
#: thousandfold margin: the 2pi copies and the caller's check then pass without re-solving).
REFINE_FRACTION = 1e-3


#: At most this many Newton steps per refinement. The closed form starts within the model
#: deviation (millimetres on a calibrated arm); converging refinements take 3-8 steps, more when
#: the pose is near a singularity of the exact chain.
MAX_STEPS = 30


#: Largest change of one joint per step (rad or m): near a singularity a full Gauss-Newton step
#: can jump to another branch.
MAX_JOINT_STEP = 0.3


#: A step is taken when it leaves the error below this multiple of the current one. Newton's
#: iterates may first grow before they converge: from a start millimetres away (quadratic
#: convergence after a few steps), and near a singular root, where the first full step
#: overshoots by orders of magnitude (a residual of 1e-9 at sigma_min ~ 3e-8 became 1e-4 on
#: the TM5-900) and convergence is linear. Joint steps are bounded (MAX_JOINT_STEP) and the best
#: iterate is returned, so only a step that makes the error a million times larger is damped.
GROWTH = 1e6


#: Damping after a rejected step: this fraction of the diagonal of J^T J first, growing a
#: hundredfold per rejection (Levenberg-Marquardt); a taken step divides it by ten.
DAMPING_START = 1e-9


#: Damping to start from when the start is not a closed-form candidate but a seed (Marquardt's
#: start for a guess that may be far from a root: a hundredth of the diagonal of J^T J, decaying
#: tenfold per taken step). Near a singularity of the exact chain, undamped steps run along
#: its weak direction to another root; on the Kinova Gen3's near-singular poses where that
#: happened a start from 1e-4 to 1 reached the root nearest the seed, 1e-6 did not.
SEED_DAMPING = 1e-2


#: Largest damping before giving up (the step is then shorter than rounding).
DAMPING_LIMIT = 1e12


@jit
def _identity(state: NDArray[np.float64]) -> None:
    for k in range(12):
        state[k] = 0.0
    state[0] = state[5] = state[10] = 1.0


@jit
def _times_constant(state: NDArray[np.float64], P: NDArray[np.float64]) -> None:
    """state = state @ P for 3 x 4 rigid frames given as 12 floats each (row-major)."""
    for r in range(3):
        a0, a1, a2, a3 = state[4 * r], state[4 * r + 1], state[4 * r + 2], state[4 * r + 3]
        state[4 * r] = a0 * P[0] + a1 * P[4] + a2 * P[8]
        state[4 * r + 1] = a0 * P[1] + a1 * P[5] + a2 * P[9]
        state[4 * r + 2] = a0 * P[2] + a1 * P[6] + a2 * P[10]
        state[4 * r + 3] = a0 * P[3] + a1 * P[7] + a2 * P[11] + a3


@jit
def _times_motion(state: NDArray[np.float64], revolute: bool, value: float) -> None:
    """state = state @ Rz(value) (revolute) or state @ Tz(value) (prismatic)."""
    if revolute:
        s, c = sincos(value)
        for r in range(3):
            x, y = state[4 * r], state[4 * r + 1]
            state[4 * r] = c * x + s * y
            state[4 * r + 1] = c * y - s * x
    else:
        for r in range(3):
            state[4 * r + 3] += value * state[4 * r + 2]


@jit
def motion_value(chain: NDArray[np.float64], j: int, q: float) -> float:
    """The DH variable of joint j (theta or d) at joint value q."""
    return chain[j, JOINT.direction] * q + chain[j, JOINT.offset]


@jit
def fk(chain: NDArray[np.float64], q: NDArray[np.float64], state: NDArray[np.float64]) -> None:
    """state (12,) = T(q), DH frame 0 -> DH frame n."""
    n = chain.shape[0] - 1
    _identity(state)
    for j in range(n):
        _times_constant(state, chain[j, JOINT.pre:JOINT.pre + 12])
        _times_motion(state, chain[j, JOINT.revolute] != 0.0, motion_value(chain, j, q[j]))
    _times_constant(state, chain[n, 0:12])


@jit
def fk_frames(chain: NDArray[np.float64], q: NDArray[np.float64],
              frames: NDArray[np.float64]) -> None:
    """frames[j] (12,) = the frame joint j moves about (before its motion), j < n; frames[n] =
    T(q). frames: (n + 1, 12)."""
    n = chain.shape[0] - 1
    state = frames[n]
    _identity(state)
    for j in range(n):
        _times_constant(state, chain[j, JOINT.pre:JOINT.pre + 12])
        for k in range(12):
            frames[j, k] = state[k]
        _times_motion(state, chain[j, JOINT.revolute] != 0.0, motion_value(chain, j, q[j]))
    _times_constant(state, chain[n, 0:12])


@jit
def error_parts(state: NDArray[np.float64], T: NDArray[np.float64]) -> tuple[float, float, float]:
    """(position error, s, c) of a frame against the target T (3, 4): the rotation error is
    atan2(s, c) (see the module docstring)."""
    x0, x1, x2 = state[0], state[4], state[8]
    y0, y1, y2 = state[1], state[5], state[9]
    z0, z1, z2 = state[2], state[6], state[10]
    position = math.sqrt((state[3] - T[0, 3]) ** 2 + (state[7] - T[1, 3]) ** 2
                         + (state[11] - T[2, 3]) ** 2)
    e01 = x0 * T[0, 1] + x1 * T[1, 1] + x2 * T[2, 1]
    e02 = x0 * T[0, 2] + x1 * T[1, 2] + x2 * T[2, 2]
    e10 = y0 * T[0, 0] + y1 * T[1, 0] + y2 * T[2, 0]
    e12 = y0 * T[0, 2] + y1 * T[1, 2] + y2 * T[2, 2]
    e20 = z0 * T[0, 0] + z1 * T[1, 0] + z2 * T[2, 0]
    e21 = z0 * T[0, 1] + z1 * T[1, 1] + z2 * T[2, 1]
    trace = (x0 * T[0, 0] + x1 * T[1, 0] + x2 * T[2, 0] + y0 * T[0, 1] + y1 * T[1, 1]
             + y2 * T[2, 1] + z0 * T[0, 2] + z1 * T[1, 2] + z2 * T[2, 2])
    s = 0.5 * math.sqrt((e21 - e12) ** 2 + (e02 - e20) ** 2 + (e10 - e01) ** 2)
    return position, s, 0.5 * (trace - 1.0)


@jit
def pose_error(state: NDArray[np.float64], T: NDArray[np.float64]) -> tuple[float, float]:
    """(position error m, rotation error rad) of a frame against T (3, 4)."""
    position, s, c = error_parts(state, T)
    return position, atan2(s, c)


@jit
def within(position: float, rotation: float, tolerance: float) -> bool:
    """Both errors at most ``tolerance`` (False for NaN)."""
    return position <= tolerance and rotation <= tolerance


@jit_literal
def _row_dot(T: NDArray[np.float64], r: int, state: NDArray[np.float64], c: int) -> float:
    """(R_t R^T)[r, c]: row r of the target's rotation times row c of the frame's."""
    return T[r, 0] * state[4 * c] + T[r, 1] * state[4 * c + 1] + T[r, 2] * state[4 * c + 2]


@jit
def _error_vector(state: NDArray[np.float64], T: NDArray[np.float64],
                  e: NDArray[np.float64]) -> tuple[float, float]:
    """e (6,) = [p_t - p; rotation vector of R_t R^T] in DH frame 0; returns the two errors."""
    for r in range(3):
        e[r] = T[r, 3] - state[4 * r + 3]
    # M = R_t R^T: its skew part carries sin(angle) * axis, its trace 1 + 2 cos(angle)
    v0 = 0.5 * (_row_dot(T, 2, state, 1) - _row_dot(T, 1, state, 2))
    v1 = 0.5 * (_row_dot(T, 0, state, 2) - _row_dot(T, 2, state, 0))
    v2 = 0.5 * (_row_dot(T, 1, state, 0) - _row_dot(T, 0, state, 1))
    trace = _row_dot(T, 0, state, 0) + _row_dot(T, 1, state, 1) + _row_dot(T, 2, state, 2)
    s = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    angle = atan2(s, 0.5 * (trace - 1.0))
    scale = angle / s if s > 0.0 else 1.0
    e[3], e[4], e[5] = v0 * scale, v1 * scale, v2 * scale
    return math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), angle


@jit
def _jacobian(chain: NDArray[np.float64], frames: NDArray[np.float64],
              J: NDArray[np.float64]) -> None:
    """J (6, n): linear and angular velocity of DH frame n's origin per unit joint value, in DH
    frame 0, from :func:`fk_frames`' frames."""
    n = chain.shape[0] - 1
    p0, p1, p2 = frames[n, 3], frames[n, 7], frames[n, 11]
    for j in range(n):
        direction = chain[j, JOINT.direction]
        z0, z1, z2 = frames[j, 2], frames[j, 6], frames[j, 10]
        if chain[j, JOINT.revolute] != 0.0:
            d0, d1, d2 = p0 - frames[j, 3], p1 - frames[j, 7], p2 - frames[j, 11]
            J[0, j] = direction * (z1 * d2 - z2 * d1)
            J[1, j] = direction * (z2 * d0 - z0 * d2)
            J[2, j] = direction * (z0 * d1 - z1 * d0)
            J[3, j], J[4, j], J[5, j] = direction * z0, direction * z1, direction * z2
        else:
            J[0, j], J[1, j], J[2, j] = direction * z0, direction * z1, direction * z2
            J[3, j] = J[4, j] = J[5, j] = 0.0


@jit
def _least_squares(J: NDArray[np.float64], e: NDArray[np.float64], fixed: NDArray[np.bool_],
                   damping: float, A: NDArray[np.float64], b: NDArray[np.float64],
                   step: NDArray[np.float64]) -> bool:
    """The step minimising |J step - e|^2 + damping * sum_j (|J_j| step_j)^2 over the free
    joints (fixed ones get step 0), by Householder QR of the stacked system [J; sqrt(damping)
    diag(|J_j|)]: J itself is factored, not J^T J, so a near-singular chain (sigma_min ~1e-7)
    keeps its accuracy. False when the free columns are rank deficient. Work: A (6 + n, n),
    b (6 + n,)."""
    n = J.shape[1]
    m = 0
    for j in range(n):
        step[j] = 0.0
    rows = 6 + n
    for r in range(rows):
        for c in range(n):
            A[r, c] = 0.0
        b[r] = e[r] if r < 6 else 0.0
    for j in range(n):
        if fixed[j]:
            continue
        norm = 0.0
        for r in range(6):
            A[r, m] = J[r, j]
            norm += J[r, j] * J[r, j]
        A[6 + m, m] = math.sqrt(damping * norm)
        m += 1
    for k in range(m):  # Householder reflection of column k below the diagonal
        norm = 0.0
        for r in range(k, rows):
            norm += A[r, k] * A[r, k]
        norm = math.sqrt(norm)
        if norm == 0.0:
            return False
        alpha = -norm if A[k, k] >= 0.0 else norm
        A[k, k] -= alpha
        vnorm = 0.0
        for r in range(k, rows):
            vnorm += A[r, k] * A[r, k]
        if vnorm > 0.0:
            for c in range(k + 1, m):
                dot = 0.0
                for r in range(k, rows):
                    dot += A[r, k] * A[r, c]
                factor = 2.0 * dot / vnorm
                for r in range(k, rows):
                    A[r, c] -= factor * A[r, k]
            dot = 0.0
            for r in range(k, rows):
                dot += A[r, k] * b[r]
            factor = 2.0 * dot / vnorm
            for r in range(k, rows):
                b[r] -= factor * A[r, k]
        A[k, k] = alpha  # R's diagonal
    largest = 0.0
    for k in range(m):
        largest = max(largest, abs(A[k, k]))
    solution = np.empty(m)
    for k in range(m - 1, -1, -1):
        if not abs(A[k, k]) > 1e-15 * largest:
            return False
        total = b[k]
        for c in range(k + 1, m):
            total -= A[k, c] * solution[c]
        solution[k] = total / A[k, k]
    m = 0
    for j in range(n):
        if not fixed[j]:
            step[j] = solution[m]
            m += 1
    return True


@jit
def refine(chain: NDArray[np.float64], T: NDArray[np.float64], q: NDArray[np.float64],
           fixed: NDArray[np.bool_], tolerance: float,
           budget: int = 4 * MAX_STEPS, growth: float = GROWTH,
           damping_start: float = 0.0) -> tuple[float, float]:
    """Newton's method on the exact chain from q (n,), in place, towards the target T (3, 4),
    DH frame 0 -> n; joints marked ``fixed`` keep their value (the seed's choice of a free joint
    at a singularity). q ends as the best iterate; returns its (position, rotation) errors.

    Each step minimises |J dq - e|^2 + lambda sum_j (|J_j| dq_j)^2 over the free joints by QR
    (:func:`_least_squares`; lambda = 0 is Gauss-Newton), shortened to MAX_JOINT_STEP per
    joint. A step is taken
    unless it makes |e| more than ``growth`` times larger (GROWTH: Newton may cross a hump on its
    way to a far root; 1: a monotone Levenberg-Marquardt descent to the least-squares point, for
    targets a hair beyond a fold); then lambda grows (DAMPING_START, x100) and the step is solved
    again; ``damping_start`` (default: none) damps the first steps. Stops when both errors are
    below REFINE_FRACTION *
    tolerance, after MAX_STEPS, after ``budget`` evaluations of the chain, or when lambda passes
    DAMPING_LIMIT.
    """
    n = chain.shape[0] - 1
    frames = np.empty((n + 1, 12))
    trial_frames = np.empty((n + 1, 12))
    e = np.empty(6)
    trial_e = np.empty(6)
    J = np.empty((6, n))
    A = np.empty((6 + n, n))
    b = np.empty(6 + n)
    step = np.empty(n)
    trial = np.empty(n)
    best = q.copy()
    goal = REFINE_FRACTION * tolerance
    fk_frames(chain, q, frames)
    position, rotation = _error_vector(frames[n], T, e)
    size = position * position + rotation * rotation
    best_position, best_rotation, best_size = position, rotation, size
    # Directions along which even a maximal joint step moves the pose by less than the goal
    # (singular values below goal / MAX_JOINT_STEP, e.g. the free joint of an exactly singular
    # wrist) carry no information: this damping floor suppresses them, keeping the step the
    # minimum-norm one, while sigma ~ 1e-8 (a chain a hair from singular) stays fully active.
    floor = (goal / MAX_JOINT_STEP) ** 2
    damping = max(floor, damping_start)
    evaluations = 1
    for _ in range(MAX_STEPS):
        if (position <= goal and rotation <= goal) or evaluations >= budget:
            break
        _jacobian(chain, frames, J)
        taken = False
        while not taken:
            if _least_squares(J, e, fixed, damping, A, b, step):
                longest = 0.0
                for a in range(n):
                    longest = max(longest, abs(step[a]))
                shrink = MAX_JOINT_STEP / longest if longest > MAX_JOINT_STEP else 1.0
                for a in range(n):
                    trial[a] = q[a] + shrink * step[a]
                fk_frames(chain, trial, trial_frames)
                evaluations += 1
                trial_position, trial_rotation = _error_vector(trial_frames[n], T, trial_e)
                trial_size = trial_position * trial_position + trial_rotation * trial_rotation
                taken = trial_size <= growth * growth * size
            if not taken:
                damping = max(100.0 * damping, DAMPING_START + floor)
                if damping > DAMPING_LIMIT or evaluations >= budget:
                    break
        if not taken:
            break
        for a in range(n):
            q[a] = trial[a]
        for r in range(6):
            e[r] = trial_e[r]
        for j in range(n + 1):
            for k in range(12):
                frames[j, k] = trial_frames[j, k]
        position, rotation, size = trial_position, trial_rotation, trial_size
        damping = max(0.1 * damping, floor) if damping > DAMPING_START else floor
        if size < best_size:
            best_position, best_rotation, best_size = position, rotation, size
            for a in range(n):
                best[a] = q[a]
    for a in range(n):
        q[a] = best[a]
    return best_position, best_rotation


@jit
def check(chain: NDArray[np.float64], q: NDArray[np.float64], T: NDArray[np.float64],
          state: NDArray[np.float64]) -> tuple[float, float]:
    """(position, rotation) error of T(q) against the target T (3, 4)."""
    fk(chain, q, state)
    return pose_error(state, T)
