"""Closed-form IK of offset-wrist arms (UR3, UR5, UR10, AUBO i10) against the oracle.

The oracle is Pinocchio on the URDF generated through xacro: targets are Pinocchio poses of joint
vectors drawn with fixed seeds, and every distinct principal solution the IK returns is put back
through Pinocchio. The 2*pi-shifted copies are checked as a set property: for each branch of each
pose the returned rows are exactly the in-limit copies of one principal solution.

Joint-space completeness tolerance: :data:`JOINT_TOL` = 1e-6 rad. Distinct solutions of one pose
are at least 2 * MERGE_ANGLE = 2e-6 rad apart (closer roots are merged into one), so a returned
solution within 1e-6 rad of the original is the original's own; generic poses are recovered to
~1e-11 rad. Near the wrist singularity q6 is only fixed to ~1e-16 / |sin q5| by the pose, so
there the well-conditioned joints (q1, q5) and the branch are compared instead.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import pytest

import dhkin
from dhkin.errors import FamilyError
from dhkin.ik.offset_wrist import (
    BRANCH_LABELS,
    MERGE_ANGLE,
    WRIST_SINGULAR_SIN,
    Solver,
    fit_problems,
)
from dhkin.ik.result import ELBOW, SHOULDER, WRIST
from dhkin.transforms import pose_error, xyz_rpy_to_matrix

ROBOTS = ("ur3", "ur5", "ur10", "aubo_i10")
RANDOM_SEEDS = {"ur3": 301, "ur5": 501, "ur10": 1001, "aubo_i10": 10}
N_RANDOM = 100_000
N_SPECIAL = 10_000
CHUNK = 500
TWO_PI = 2.0 * np.pi
#: Position (m) / rotation (rad) residual against Pinocchio, random poses and special sets.
RANDOM_TOL = 1e-10
SPECIAL_TOL = 1e-9
JOINT_TOL = 1e-6
#: A flagged solution sits on its singularity: its oracle measure is at most this.
FLAGGED_MAX = 1e-9
#: q5 where axis 6 is parallel to axis 4, nearest 0, for the built-in UR and AUBO tables.
Q5_SINGULAR_BUILTIN = 0.0


# --------------------------------------------------------------------------------------------
# Helpers: the oracle's geometry, labels and singularity measures


def wrap(q: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - q, TWO_PI)


@dataclass(frozen=True)
class OracleGeometry:
    """Pinocchio's view of configurations q (M, 6): tool0 poses (M, 4, 4) in base_link, joint
    axis directions (M, 6, 3) (signed: positive q turns right-handed about them) and one point
    of each axis (M, 6, 3) (its foot from the base_link origin)."""

    poses: np.ndarray
    axes: np.ndarray
    points: np.ndarray


def oracle_geometry(robot: dhkin.Robot, q: np.ndarray) -> OracleGeometry:
    ref = robot.reference()
    model, data = ref.model, ref.data
    tip = ref.frame_id("tool0")
    columns = [model.joints[j].idx_v for j in ref.chain]
    poses = np.empty((len(q), 4, 4))
    jacobians = np.empty((len(q), 6, model.nv))
    for k, row in enumerate(q):
        pin.computeJointJacobians(model, data, ref.configuration(row))
        poses[k] = pin.updateFramePlacement(model, data, tip).homogeneous
        jacobians[k] = data.J
    # world-frame joint twists: angular part = axis, linear part = -axis x (a point of the axis)
    axes = np.swapaxes(jacobians[:, 3:, columns], 1, 2)
    points = np.cross(axes, np.swapaxes(jacobians[:, :3, columns], 1, 2))
    return OracleGeometry(poses=poses, axes=axes, points=points)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def _closest_point(p1, w1, p2, w2):
    """Midpoints of the common perpendiculars of line pairs (rows)."""
    offset = p2 - p1
    b = _dot(w1, w2)
    denominator = 1.0 - b * b
    s = (_dot(offset, w1) - b * _dot(offset, w2)) / denominator
    t = (b * _dot(offset, w1) - _dot(offset, w2)) / denominator
    return 0.5 * ((p1 + s[:, None] * w1) + (p2 + t[:, None] * w2))


@dataclass(frozen=True)
class ArmState:
    """Labels and singularity measures of configurations, from the oracle's geometry, following
    the definitions in the offset_wrist module docstring."""

    left: np.ndarray
    elbow_up: np.ndarray
    wrist_sine: np.ndarray      # |axis 4 x axis 6|
    elbow_sine: np.ndarray      # |sin| of the angle at the elbow in the arm plane
    shoulder_sine: np.ndarray   # |reach component| / horizontal distance of the wrist point
    shoulder_floor: np.ndarray  # smallest shoulder_sine an unmerged shoulder can have


def arm_state(robot: dhkin.Robot, geo: OracleGeometry) -> ArmState:
    w, p = geo.axes, geo.points
    up = w[:, 0] * robot.table.joints[0].direction
    n = w[:, 1]
    wrist = _closest_point(p[:, 4], w[:, 4], p[:, 5], w[:, 5])
    h = wrist - p[:, 0]
    lateral = _dot(h, n)
    reach = _dot(h, np.cross(n, up))
    horizontal = np.linalg.norm(h - _dot(h, up)[:, None] * up, axis=1)
    upper, fore = p[:, 2] - p[:, 1], p[:, 3] - p[:, 2]
    upper_flat = upper - _dot(upper, n)[:, None] * n
    fore_flat = fore - _dot(fore, n)[:, None] * n
    turn = _dot(np.cross(upper, fore), n)
    return ArmState(
        left=np.where(np.abs(lateral) > 1e-12, lateral * reach > 0, reach > 0),
        elbow_up=np.where(reach >= 0, turn > 0, turn < 0),
        wrist_sine=np.linalg.norm(np.cross(w[:, 3], w[:, 5]), axis=1),
        elbow_sine=np.abs(turn) / (np.linalg.norm(upper_flat, axis=1)
                                   * np.linalg.norm(fore_flat, axis=1)),
        shoulder_sine=np.abs(reach) / horizontal,
        shoulder_floor=np.sin(MERGE_ANGLE) * np.abs(lateral) / horizontal,
    )


def label_arrays(branch: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(left, elbow up, wrist up) of branch indices."""
    labels = [BRANCH_LABELS[b] for b in range(len(BRANCH_LABELS))]
    left = np.array([lab["shoulder"] == "left" for lab in labels])
    elbow = np.array([lab["elbow"] == "up" for lab in labels])
    wrist = np.array([lab["wrist"] == "up" for lab in labels])
    return left[branch], elbow[branch], wrist[branch]


def copies_in_limits(table, principal: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """How many 2*pi-shifted copies of each principal row (K, 6) lie within the limits."""
    low = np.ceil((table.lower - tol - principal) / TWO_PI)
    high = np.floor((table.upper + tol - principal) / TWO_PI)
    return np.prod(np.maximum(high - low + 1, 0), axis=1).astype(int)


@dataclass(frozen=True)
class Principal:
    """Distinct principal solutions of a batch: pose index, branch index, q (K, 6), flags."""

    pose: np.ndarray
    branch: np.ndarray
    q: np.ndarray
    flags: np.ndarray


def principal_solutions(table, batch) -> Principal:
    """Check that the returned rows are exactly the in-limit 2*pi copies of one principal
    solution per (pose, branch), and return those principal solutions."""
    pose, slot = np.nonzero(batch.valid)
    q = batch.q[pose, slot]
    branch = batch.branch[pose, slot].astype(int)
    assert np.all(np.isfinite(q))
    assert np.all((q >= table.lower) & (q <= table.upper)), "a solution outside the limits"
    key = pose * len(batch.branch_labels) + branch
    _, first, inverse, counts = np.unique(key, return_index=True, return_inverse=True,
                                          return_counts=True)
    principal = wrap(q[first])
    shift = q - principal[inverse]
    turns = np.round(shift / TWO_PI)
    assert np.abs(shift - TWO_PI * turns).max() <= 1e-9, "copies differ by more than 2*pi turns"
    assert np.array_equal(counts, copies_in_limits(table, principal)), \
        "the copies of a branch are not exactly its in-limit 2*pi copies"
    radix = int(np.abs(turns).max()) * 2 + 1
    code = key.astype(np.int64)
    for column in (turns + radix // 2).astype(np.int64).T:
        code = code * radix + column
    code.sort()
    assert np.all(np.diff(code) != 0), "a copy is returned twice"
    assert np.all(batch.flags[pose, slot] == batch.flags[pose, slot][first][inverse])
    return Principal(pose=pose[first], branch=branch[first], q=principal,
                     flags=batch.flags[pose, slot][first])


def assert_flags_match_geometry(state: ArmState, flags: np.ndarray) -> None:
    """Each flag is set exactly when the oracle sees the solution on that singularity."""
    wrist, elbow, shoulder = flags & WRIST > 0, flags & ELBOW > 0, flags & SHOULDER > 0
    assert np.all(state.wrist_sine[wrist] <= FLAGGED_MAX)
    assert np.all(state.wrist_sine[~wrist] > 0.5 * WRIST_SINGULAR_SIN)
    assert np.all(state.elbow_sine[elbow] <= FLAGGED_MAX)
    assert np.all(state.elbow_sine[~elbow] > 0.5 * np.sin(MERGE_ANGLE))
    assert np.all(state.shoulder_sine[shoulder] <= FLAGGED_MAX)
    assert np.all(state.shoulder_sine[~shoulder] > 0.5 * state.shoulder_floor[~shoulder])


def assert_labels_match_geometry(state: ArmState, q: np.ndarray, branch: np.ndarray,
                                 flags: np.ndarray, q5_singular: float) -> None:
    """Branch labels agree with the geometry (skipped where a merge makes a label moot)."""
    left, elbow, wrist = label_arrays(branch)
    clear = flags == 0
    assert np.array_equal(left[clear], state.left[clear])
    assert np.array_equal(elbow[clear], state.elbow_up[clear])
    assert np.array_equal(wrist[clear], np.sin(q[clear, 4] - q5_singular) > 0)


def joint_distance(batch, q0: np.ndarray) -> np.ndarray:
    """Per pose, the smallest max-abs joint difference between q0 and a returned solution."""
    d = np.abs(batch.q - q0[:, None, :]).max(axis=2)
    return np.where(batch.valid, d, np.inf).min(axis=1)


def dh_targets(table, T: np.ndarray) -> np.ndarray:
    """base_link -> tool0 poses to DH frame 0 -> DH frame 6."""
    return np.linalg.inv(table.base) @ T @ np.linalg.inv(table.tool)


def within_principal_range(robot: dhkin.Robot) -> dhkin.Robot:
    """The same kinematics with every joint limited to [-180, 180] deg: each branch then appears
    once (twice at +-180), which keeps the special sets about the solver, not the 2*pi copies."""
    joints = tuple(dataclasses.replace(j, lower=-np.pi, upper=np.pi) for j in robot.table.joints)
    return dhkin.Robot(dataclasses.replace(robot.table, joints=joints))


# --------------------------------------------------------------------------------------------
# 10^5 random joint vectors per robot


@pytest.mark.parametrize("name", ROBOTS)
def test_random_poses_all_solutions_exact_and_complete(name, load_robot):
    robot = load_robot(name)
    rng = np.random.default_rng(RANDOM_SEEDS[name])
    q0 = robot.table.random_q(N_RANDOM, rng)
    T = robot.reference().fk(q0)
    worst_position = worst_rotation = worst_joint = 0.0
    solutions = principal_count = 0
    for start in range(0, N_RANDOM, CHUNK):
        part = slice(start, start + CHUNK)
        batch = robot.ik_batch_detailed(T[part])
        principal = principal_solutions(robot.table, batch)
        geo = oracle_geometry(robot, principal.q)
        position, rotation = pose_error(geo.poses, T[part][principal.pose])
        worst_position = max(worst_position, position.max())
        worst_rotation = max(worst_rotation, rotation.max())
        state = arm_state(robot, geo)
        assert_flags_match_geometry(state, principal.flags)
        assert_labels_match_geometry(state, principal.q, principal.branch, principal.flags,
                                     Q5_SINGULAR_BUILTIN)
        distance = joint_distance(batch, q0[part])
        worst_joint = max(worst_joint, distance.max())
        solutions += int(batch.valid.sum())
        principal_count += principal.pose.size
    print(f"\n{name}: {N_RANDOM} poses, {principal_count} principal / {solutions} solutions, "
          f"max residual {worst_position:.2e} m / {worst_rotation:.2e} rad, "
          f"max joint distance to the original {worst_joint:.2e} rad")
    assert worst_position <= RANDOM_TOL
    assert worst_rotation <= RANDOM_TOL
    assert worst_joint <= JOINT_TOL  # completeness: every original recovered


# --------------------------------------------------------------------------------------------
# 10^4 targets each: q5 = 0 exactly, 1e-12 <= |q5| <= 1e-6, special angles


def _special_set(kind: str, rng: np.random.Generator) -> np.ndarray:
    q = rng.uniform(-np.pi, np.pi, size=(N_SPECIAL, 6))
    if kind == "q5_zero":
        q[:, 4] = 0.0
    elif kind == "q5_tiny":
        q[:, 4] = rng.choice([-1.0, 1.0], N_SPECIAL) * 10.0 ** rng.uniform(-12, -6, N_SPECIAL)
    else:  # multiples of 45 deg, with 0 and +-180 (stretched / folded elbow, wrist singular)
        q = np.radians(45.0 * rng.integers(-4, 5, size=(N_SPECIAL, 6)))
    return q


@pytest.mark.parametrize("kind", ["q5_zero", "q5_tiny", "special"])
@pytest.mark.parametrize("name", ROBOTS)
def test_singular_near_singular_and_special_poses(name, kind, load_robot):
    robot = load_robot(name)
    limited = within_principal_range(robot)
    rng = np.random.default_rng(RANDOM_SEEDS[name] * 10 + len(kind))
    q0 = _special_set(kind, rng)
    T = robot.reference().fk(q0)
    # branches of the solver itself: none may be lost by the FK check, none may hold NaN
    raw = limited.ik_solver.solve(dh_targets(robot.table, T), q0)
    assert np.all(np.isfinite(raw.q))
    batch = limited.ik_batch_detailed(T, q_seed=q0)
    principal = principal_solutions(limited.table, batch)
    found = np.zeros_like(raw.valid)
    found[principal.pose, principal.branch] = True
    assert np.array_equal(found, raw.valid), "a branch of the solver was not exact"

    geo = oracle_geometry(robot, principal.q)
    position, rotation = pose_error(geo.poses, T[principal.pose])
    print(f"\n{name} {kind}: {N_SPECIAL} poses, {principal.pose.size} solutions, "
          f"max residual {position.max():.2e} m / {rotation.max():.2e} rad, flags "
          f"wrist {np.count_nonzero(principal.flags & WRIST)} elbow "
          f"{np.count_nonzero(principal.flags & ELBOW)} shoulder "
          f"{np.count_nonzero(principal.flags & SHOULDER)}")
    assert position.max() <= SPECIAL_TOL
    assert rotation.max() <= SPECIAL_TOL
    state = arm_state(robot, geo)
    assert_flags_match_geometry(state, principal.flags)
    assert_labels_match_geometry(state, principal.q, principal.branch, principal.flags,
                                 Q5_SINGULAR_BUILTIN)
    assert np.all(np.bincount(principal.pose, minlength=N_SPECIAL) > 0)

    if kind == "q5_tiny":
        _assert_near_singular_branches(robot, q0, principal)
    else:
        assert joint_distance(batch, wrap(q0)).max() <= JOINT_TOL
    if kind == "q5_zero":
        # the original's own branch is wrist-singular, its free q6 is the seed's
        nearest = np.argmin(np.abs(batch.q - wrap(q0)[:, None]).max(2)
                            + np.where(batch.valid, 0, np.inf), axis=1)
        assert np.all(batch.flags[np.arange(N_SPECIAL), nearest] & WRIST)
        _assert_free_q6_from_seed(limited, T, q0)


def _assert_near_singular_branches(robot, q0, principal: Principal) -> None:
    """For 1e-12 <= |q5| <= 1e-6: the original's shoulder branch is present with q1 recovered.
    Below WRIST_SINGULAR_SIN the wrist is treated as singular (flagged, q5 = 0, q6 from the
    seed); above it the original's wrist branch is present with q5 recovered to 1e-10 rad (an
    arccos would lose it at ~1e-8) and its elbow branch unless the elbow pair merged on the
    reach boundary. The threshold is met with a factor 2 of slack either way."""
    state = arm_state(robot, oracle_geometry(robot, q0))
    left, elbow, wrist = label_arrays(principal.branch)
    flagged = principal.flags & WRIST > 0
    for k in range(len(q0)):  # per-pose bookkeeping of a few rows: cheap, and readable
        rows = np.flatnonzero(principal.pose == k)
        rows = rows[(left[rows] == state.left[k])
                    & (np.abs(wrap(principal.q[rows, 0] - q0[k, 0])) <= JOINT_TOL)]
        assert rows.size > 0, f"pose {k}: the original's shoulder branch is missing"
        size = abs(np.sin(q0[k, 4]))
        if np.any(flagged[rows]):
            assert size <= 2 * WRIST_SINGULAR_SIN, f"pose {k}: |q5| = {size:.3g} flagged"
            assert np.all(np.abs(principal.q[rows, 4] - q0[k, 4]) <= size + 1e-10)
            continue
        assert size >= 0.5 * WRIST_SINGULAR_SIN, f"pose {k}: |q5| = {size:.3g} not flagged"
        same = rows[wrist[rows] == (np.sin(q0[k, 4]) > 0)]
        assert same.size > 0, f"pose {k}: the original's wrist branch is missing"
        assert np.all(np.abs(principal.q[same, 4] - q0[k, 4]) <= 1e-10)
        merged = np.any(principal.flags[same] & ELBOW)
        assert merged or np.any(elbow[same] == state.elbow_up[k])


def _assert_free_q6_from_seed(limited: dhkin.Robot, T: np.ndarray, q0: np.ndarray) -> None:
    """Without a seed the free q6 is 0; with one it is the seed's (when the arm reaches)."""
    for seed, expected in ((None, np.zeros(len(q0))), (q0, wrap(q0[:, 5]))):
        batch = limited.ik_batch_detailed(T, q_seed=seed)
        singular = (batch.flags & WRIST > 0) & batch.valid
        pose, slot = np.nonzero(singular)
        shifted = wrap(batch.q[pose, slot, 5] - expected[pose])
        elbow_at_limit = batch.flags[pose, slot] & ELBOW > 0
        assert np.all(np.abs(shifted[~elbow_at_limit]) <= 1e-12)


# --------------------------------------------------------------------------------------------
# Tables of other layouts: negative directions, odd offsets, a1 and a4, modified DH


def _odd_table(convention: str) -> dict:
    """A UR-like arm with every twist the family allows. Standard: axis 3 antiparallel to axis 2
    (alpha2 = 180, like the AUBO), a1 = 0.03, a4 = 0.02, d2, d3 != 0. Modified: the same idea in
    Craig's convention. Joint 5's offset is 40 deg with direction -1, so q5s = 40 deg."""
    if convention == "standard":
        rows = [(0.03, 90, 0.20, 17, -1), (-0.40, 180, 0.05, -33, 1), (0.35, 0, -0.02, 71, -1),
                (0.02, -90, 0.11, 5, -1), (0.0, 90, 0.09, 40, -1), (0.0, 0, 0.08, -120, -1)]
    else:
        rows = [(0.0, 0, 0.10, 25, -1), (0.02, 90, 0.03, -60, 1), (0.42, 180, -0.01, 10, -1),
                (0.39, 0, 0.10, -95, 1), (0.015, -90, 0.09, 40, -1), (0.0, 90, 0.08, 33, 1)]
    joints = [{"a": a, "alpha": alpha, "d": d, "offset": offset, "direction": direction,
               "lower": -360, "upper": 360} for a, alpha, d, offset, direction in rows]
    joints[2].update(lower=-200, upper=70)  # off-centre, like the IRB 1200's joint 3
    return {"name": f"odd_{convention}", "convention": convention,
            "units": {"length": "m", "angle": "deg"},
            "base": {"xyz": [0.1, -0.2, 0.3], "rpy": [10, -20, 30]},
            "tool": {"xyz": [0.01, 0.02, 0.15], "rpy": [5, 15, -25]}, "joints": joints}


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_tables_with_negative_directions_odd_offsets_and_tool(convention):
    robot = dhkin.Robot(dhkin.parse_table(_odd_table(convention)))
    assert fit_problems(robot.table) == []
    assert robot.ik_solver.family == "offset_wrist"
    n = 4000
    q0 = robot.table.random_q(n, np.random.default_rng(7 if convention == "standard" else 8))
    T = robot.reference().fk(q0)
    batch = robot.ik_batch_detailed(T)
    principal = principal_solutions(robot.table, batch)
    geo = oracle_geometry(robot, principal.q)
    position, rotation = pose_error(geo.poses, T[principal.pose])
    assert position.max() <= RANDOM_TOL
    assert rotation.max() <= RANDOM_TOL
    state = arm_state(robot, geo)
    assert_flags_match_geometry(state, principal.flags)
    assert_labels_match_geometry(state, principal.q, principal.branch, principal.flags,
                                 np.radians(40.0))
    assert joint_distance(batch, q0).max() <= JOINT_TOL


def test_odd_table_singular_wrist_is_flagged_and_exact():
    robot = dhkin.Robot(dhkin.parse_table(_odd_table("standard")))
    rng = np.random.default_rng(11)
    q0 = robot.table.random_q(2000, rng)
    q0[:, 4] = np.radians(40.0) + np.pi * rng.integers(-1, 1, 2000)  # axis 6 // axis 4
    T = robot.reference().fk(q0)
    batch = robot.ik_batch_detailed(T, q_seed=q0)
    principal = principal_solutions(robot.table, batch)
    geo = oracle_geometry(robot, principal.q)
    position, rotation = pose_error(geo.poses, T[principal.pose])
    assert max(position.max(), rotation.max()) <= SPECIAL_TOL
    assert_flags_match_geometry(arm_state(robot, geo), principal.flags)
    assert joint_distance(batch, q0).max() <= JOINT_TOL
    assert np.any(principal.flags & WRIST)


# --------------------------------------------------------------------------------------------
# Family detection


def test_builtin_offset_wrist_tables_fit(load_robot):
    for name in ROBOTS:
        assert fit_problems(load_robot(name).table) == []


@pytest.mark.parametrize("name, expected", [
    ("abb_irb1200_7_70", "axes 3 and 4 must be parallel"),
    ("stanford_arm", "prismatic"),
    ("planar_3r", "expected 6 joints, got 3"),
])
def test_other_arms_do_not_fit_with_reasons(name, expected, load_robot):
    problems = fit_problems(load_robot(name).table)
    assert any(expected in p for p in problems), problems


def test_a_table_fitting_no_family_gives_a_clear_error():
    joints = [{"a": 0.1 * (i + 1), "alpha": 30, "d": 0.05, "lower": -180, "upper": 180}
              for i in range(6)]
    table = dhkin.parse_table({"name": "skewed", "convention": "standard",
                               "units": {"length": "m", "angle": "deg"}, "joints": joints})
    problems = fit_problems(table)
    assert "axes 2 and 3 must be parallel: |sin(angle)| = 0.5 > 1e-09" in problems
    with pytest.raises(FamilyError, match="not an offset-wrist arm"):
        Solver(table)
    with pytest.raises(FamilyError, match=r"offset_wrist: .*must be parallel"):
        dhkin.Robot(table).ik_solver  # noqa: B018 (the property raises)


def test_wrist_axes_that_miss_each_other_do_not_fit(load_robot):
    data = {"name": "missing_wrist", "convention": "standard",
            "units": {"length": "m", "angle": "deg"},
            "joints": [{"a": j.a, "alpha": np.degrees(j.alpha), "d": j.d,
                        "lower": -360, "upper": 360} for j in load_robot("ur5").table.joints]}
    data["joints"][4]["a"] = 0.01  # a5 != 0: axes 5 and 6 no longer meet
    problems = fit_problems(dhkin.parse_table(data))
    assert problems == ["axes 5 and 6 must intersect: 0.01 m apart > 1e-09 m"]


# --------------------------------------------------------------------------------------------
# robot.ik: configurations, nearest across the seam, unreachable targets, the reach boundary


def test_ik_single_pose_carries_configurations_turns_and_residuals(load_robot):
    robot = load_robot("ur5")
    q0 = np.radians([30.0, -70.0, 100.0, -120.0, 60.0, 200.0])
    sols = robot.ik(robot.reference().fk(q0))
    assert sols.family == "offset_wrist"
    assert len(sols) == 256  # 8 branches x 2^5 copies (the elbow runs +-180 only)
    assert len(sols.configurations) == len(sols.flags) == len(sols)
    assert np.all(sols.residuals <= 1e-12)
    k = int(np.argmin(np.abs(sols.q - q0).max(1)))
    assert np.abs(sols.q[k] - q0).max() <= JOINT_TOL
    config = sols.configurations[k]
    assert config.labels == {"shoulder": "left", "elbow": "up", "wrist": "up"}
    assert config.turns == (0, 0, 0, 0, 0, 1)
    labels = {tuple(c.labels.values()) for c in sols.configurations}
    assert len(labels) == 8


def test_nearest_is_correct_across_the_pi_seam(load_robot):
    robot = load_robot("ur10")
    q0 = np.radians([179.9, -80.0, 60.0, -70.0, -179.95, 90.0])
    T = robot.reference().fk(q0)
    sols = robot.ik(T)
    q_now = q0.copy()
    q_now[0] -= np.radians(359.75)  # -179.85 deg: just across the seam from q0
    q_now[4] += np.radians(359.8)   # 179.85 deg
    chosen = sols.nearest(q_now)
    expected = q0 + np.array([-TWO_PI, 0, 0, 0, TWO_PI, 0])
    assert np.abs(chosen - expected).max() <= JOINT_TOL
    assert np.abs(chosen - q_now).max() < np.radians(0.3)


def test_unreachable_targets_give_an_empty_result_with_a_reason(load_robot):
    robot = load_robot("ur5")
    far = robot.fk(np.zeros(6))
    far[:3, 3] += [2.0, 0.0, 0.0]
    sols = robot.ik(far)
    assert len(sols) == 0
    assert "from axis 2" in sols.reason and "reach [0.03275, 0.81725] m" in sols.reason
    # the wrist point inside the cylinder of radius d4 about axis 1
    near = np.eye(4)
    near[:3, 3] = [0.0, 0.0, 0.5]
    near[:3, :3] = np.diag([1.0, -1.0, -1.0])  # tool pointing down: wrist point at 0.0823 above
    sols = robot.ik(near)
    assert len(sols) == 0
    assert "from axis 1; the lateral offset needs at least 0.10915 m" in sols.reason
    with pytest.raises(dhkin.DhkinError):
        sols.nearest(np.zeros(6))


def test_reach_boundary_clamps_only_within_its_tolerance(load_robot):
    robot = load_robot("ur5")
    q0 = np.radians([20.0, -50.0, 0.0, -40.0, 70.0, 10.0])  # elbow stretched
    T = robot.reference().fk(q0)
    geo = oracle_geometry(robot, q0[None])
    along_arm = geo.points[0, 3] - geo.points[0, 1]
    along_arm /= np.linalg.norm(along_arm)
    for push, reached in ((0.0, True), (5e-11, True), (1e-8, False), (1e-5, False)):
        target = T.copy()
        target[:3, 3] += push * along_arm
        sols = robot.ik(target)
        assert np.all(np.isfinite(sols.q))
        distance = np.abs(sols.q - q0).max(1).min() if len(sols) else np.inf
        assert (distance <= 1e-4) == reached, push
        if reached:
            k = int(np.argmin(np.abs(sols.q - q0).max(1)))
            assert "elbow" in sols.flags[k]
            position, rotation = pose_error(robot.reference().fk(sols.q[k]), target)
            assert max(position, rotation) <= SPECIAL_TOL


def test_tcp_and_base_frames_are_honoured(load_robot):
    robot = load_robot("aubo_i10")
    tcp = xyz_rpy_to_matrix([0.0, 0.05, 0.2], np.radians([0.0, 30.0, 0.0]))
    q0 = np.radians([10.0, 20.0, -30.0, 40.0, -50.0, 60.0])
    T = robot.reference().fk(q0) @ tcp
    sols = robot.ik(T, tcp=tcp)
    assert np.abs(sols.q - q0).max(1).min() <= JOINT_TOL
    position, rotation = pose_error(robot.reference().fk(sols.q) @ tcp, T)
    assert max(position.max(), rotation.max()) <= RANDOM_TOL


def test_wrist_point_on_axis_1_takes_q1_from_the_seed(load_robot):
    """With no lateral offset (d4 = 0 on a UR5 table) the wrist point can lie on axis 1; then
    q1 is free: it comes from the seed, and the solution is flagged 'shoulder'."""
    ur5 = load_robot("ur5").table
    data = {"name": "ur5_no_offset", "convention": "standard",
            "units": {"length": "m", "angle": "rad"},
            "joints": [{"a": j.a, "alpha": j.alpha, "d": j.d, "lower": j.lower, "upper": j.upper}
                       for j in ur5.joints]}
    data["joints"][3]["d"] = 0.0
    robot = dhkin.Robot(dhkin.parse_table(data))
    assert fit_problems(robot.table) == []
    q0 = np.array([0.3, -np.pi / 2, 0.0, np.pi / 2, 0.7, 0.2])  # arm up, wrist point on axis 1
    T = robot.reference().fk(q0)
    for seed_q1 in (0.3, -1.2):
        seed = q0.copy()
        seed[0] = seed_q1
        sols = robot.ik(T, q_seed=seed)
        assert len(sols) > 0 and all("shoulder" in f for f in sols.flags)
        assert np.all(np.abs(wrap(sols.q[:, 0] - seed_q1)) <= 1e-12)
        position, rotation = pose_error(robot.reference().fk(sols.q),
                                        np.broadcast_to(T, (len(sols), 4, 4)))
        assert max(position.max(), rotation.max()) <= SPECIAL_TOL
    assert np.abs(robot.ik(T, q_seed=q0).q - q0).max(1).min() <= JOINT_TOL


# --------------------------------------------------------------------------------------------
# Completeness beyond the original: a numerical search finds no solution we miss


def numerical_solutions(robot: dhkin.Robot, T: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Distinct principal solutions of pose T found by damped least squares on Pinocchio's FK
    and Jacobian from each start (rows of ``starts``): independent of the closed form."""
    ref = robot.reference()
    found: list[np.ndarray] = []
    for q in starts:
        for _ in range(200):
            F = ref.fk(q)
            error = np.concatenate([T[:3, 3] - F[:3, 3], pin.log3(T[:3, :3] @ F[:3, :3].T)])
            if np.abs(error).max() < 1e-13:
                break
            J = ref.jacobian(q, reference="local_world_aligned")
            damping = 1e-6 * min(1.0, float(np.linalg.norm(error)))  # Newton near the end
            q = q + J.T @ np.linalg.solve(J @ J.T + damping * np.eye(6), error)
        position, rotation = pose_error(ref.fk(q), T)
        if max(position, rotation) <= 1e-12:
            principal = wrap(q)
            if not any(np.abs(wrap(principal - other)).max() <= 1e-6 for other in found):
                found.append(principal)
    return np.array(found)


@pytest.mark.parametrize("name", ROBOTS)
def test_a_numerical_search_finds_no_solution_the_closed_form_misses(name, load_robot):
    robot = load_robot(name)
    rng = np.random.default_rng(RANDOM_SEEDS[name] + 7)
    for q0 in robot.table.random_q(3, rng):
        T = robot.reference().fk(q0)
        ours = wrap(robot.ik(T).q)
        searched = numerical_solutions(robot, T, rng.uniform(-np.pi, np.pi, (200, 6)))
        for row in searched:
            assert np.abs(wrap(ours - row)).max(1).min() <= 1e-6, "a solution was missed"
        distinct = {tuple(np.round(row, 6)) for row in ours}
        assert len(searched) == len(distinct)
