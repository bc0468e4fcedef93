"""Poses as they come, bad input, true reasons, and the family band (issue "IK core v2").

* A pose printed with six digits or stored as float32 is answered with every branch, each exact
  (Pinocchio, 1e-9) for the *projected* pose (its rotation replaced by the nearest rotation), and
  the answer says how far the projection moved it. 10^4 random poses per robot. Where the exact
  pose's branch is missing from the rounded pose's answer, an independent oracle (Pinocchio-based
  numerical IK started at that branch's exact solution) must fail to reach the rounded pose too:
  rounding moved it across a workspace boundary (printed, never assumed).
* Bad input is a dhkin error naming the argument, with the gates at their edges.
* An empty answer's reason is true.
* The band (dhkin.ik.family.BAND): tables just inside it are in the family and solved exactly and
  completely, tables just outside are not; the calibrated UR5e's corrections scaled by 3 and 8
  stay inside and are solved exactly and completely.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dhkin
from dhkin.errors import FamilyError, InputError
from dhkin.ik.core import BOTTOM_ROW_TOLERANCE, ORTHONORMALITY_GATE
from dhkin.ik.family import BAND, fit_family
from dhkin.ik.numerical import NumericalIK
from dhkin.transforms import pose_error

POSES = 10_000
FUZZ_ROBOTS = ["ur5", "abb_irb1200_7_70", "aubo_i10", "stanford_arm", "tm5_900",
               "kinova_gen3_6dof", "ur5e_calibrated"]


def projected(T: np.ndarray) -> np.ndarray:
    """T (N, 4, 4) with each rotation block replaced by its orthogonal polar factor (SVD)."""
    out = np.array(T, dtype=float)
    U, _, Vt = np.linalg.svd(out[:, :3, :3])
    out[:, :3, :3] = U @ Vt
    out[:, 3] = (0.0, 0.0, 0.0, 1.0)
    return out


def wrapped(difference: np.ndarray) -> np.ndarray:
    return np.mod(difference + np.pi, 2.0 * np.pi) - np.pi


@pytest.mark.parametrize("name", FUZZ_ROBOTS)
@pytest.mark.parametrize("kind", ["six digits", "float32"])
def test_rounded_poses_get_every_branch_exact_for_the_projected_pose(name: str,
                                                                       kind: str) -> None:
    robot = dhkin.load(name)
    q = robot.table.random_q(POSES, np.random.default_rng(31))
    T = robot.reference().fk(q)
    given = np.round(T, 6) if kind == "six digits" else T.astype(np.float32)
    batch = robot.ik_batch_detailed(given)
    target = projected(given)
    pose, slot = np.nonzero(batch.valid)
    position, rotation = pose_error(robot.reference().fk(batch.q[pose, slot]), target[pose])
    assert position.max() <= 1e-9 and rotation.max() <= 1e-9
    # how far the projection moved the input: what the rounding did, and not 0
    moved = np.linalg.norm(target[:, :3, :3] - given[:, :3, :3].astype(float), axis=(1, 2))
    np.testing.assert_allclose(batch.projection, moved, rtol=1e-6, atol=1e-15)
    assert batch.projection.max() < (4e-6 if kind == "six digits" else 4e-7)
    # every branch of the exact pose, or the oracle cannot reach the rounded pose on it either
    exact = robot.ik_solver.branches(T)
    rounded = robot.ik_solver.branches(given)
    oracle = NumericalIK.from_robot(robot)
    crossed = 0
    for k, b in zip(*np.nonzero(exact.valid & ~rounded.valid), strict=True):
        found = oracle.solve(target[k], q_seed=exact.q[k, b], restarts=0, tolerance=1e-9)
        if len(found):  # reachable: then it must be one of the rounded pose's solutions
            gap = np.abs(wrapped(rounded.q[k][rounded.valid[k]] - found.q[0])).max(axis=1)
            # the same solution to within what the tolerance resolves there: at a fold
            # (sigma_min -> 0) points a tolerance apart in the pose are far apart in q
            sigma_min = np.linalg.svd(robot.reference().jacobian(found.q[0]),
                                      compute_uv=False)[-1]
            assert gap.size and gap.min() <= 1e-6 + 2e-9 / sigma_min, (k, b, found.q[0])
        else:
            crossed += 1
    print(f"\n{name}, {kind}: {POSES} poses, projection max {batch.projection.max():.1e}, "
          f"{crossed} branches moved across a workspace boundary by the rounding")
    assert crossed <= POSES // 500


def test_the_issues_rounded_example() -> None:
    """UR5 at q = (10, -80, 90, -30, 60, 0) deg: 8 branches for the exact pose, and the same 8
    for the pose rounded to 6 digits and for float32 (once: none, with a false reason)."""
    robot = dhkin.load("ur5")
    T = robot.fk(np.radians([10, -80, 90, -30, 60, 0]))
    exact = robot.ik(T)
    assert len(exact) == 8 and exact.projection < 1e-15
    for given in (np.round(T, 6), T.astype(np.float32)):
        sols = robot.ik(given)
        assert len(sols) == 8 and 0.0 < sols.projection < 2e-6
        assert np.abs(wrapped(sols.q - exact.q)).max() < 1e-5
    assert len(robot.ik(T, copies=True)) > 200  # every copy, on request


def test_bottom_row_and_rotation_gates_at_their_edges() -> None:
    robot = dhkin.load("abb_irb1200_7_70")
    T = robot.fk(np.array([0.3, 0.2, -0.4, 0.5, 0.6, -0.7]))
    for bad in ([0.0, 0.0, 0.0, 1.0 + 2 * BOTTOM_ROW_TOLERANCE], [1e-6, 0.0, 0.0, 1.0]):
        pose = T.copy()
        pose[3] = bad
        with pytest.raises(InputError, match=r"T: bottom row is .* expected \[0, 0, 0, 1\]"):
            robot.ik(pose)
    fine = T.copy()
    fine[3, 3] = 1.0 + 0.5 * BOTTOM_ROW_TOLERANCE
    assert len(robot.ik(fine))
    # a rotation scaled by 1 + e is e off orthonormal (|R R^T - I| ~ 2e)
    inside, outside = T.copy(), T.copy()
    inside[:3, :3] *= 1.0 + 0.45 * ORTHONORMALITY_GATE
    outside[:3, :3] *= 1.0 + 0.55 * ORTHONORMALITY_GATE
    sols = robot.ik(inside)
    assert len(sols) and sols.projection > 1e-4
    position, rotation = pose_error(robot.reference().fk(sols.q),
                                    np.broadcast_to(projected(inside[None])[0], (len(sols), 4, 4)))
    assert position.max() <= 1e-9 and rotation.max() <= 1e-9
    with pytest.raises(InputError, match="rotation block is not a rotation"):
        robot.ik(outside)
    mirrored = T.copy()
    mirrored[:3, 0] *= -1.0  # det = -1: orthonormal, but not a rotation
    with pytest.raises(InputError, match=r"det = -1"):
        robot.ik(mirrored)
    batch = np.stack([T, T, outside])
    with pytest.raises(InputError, match=r"T\[2\]: rotation block"):
        robot.ik_batch(batch)


@pytest.mark.parametrize("tolerance", [0.0, -1e-9, float("nan"), float("inf"), "1e-9", True,
                                       None])
def test_tolerance_must_be_a_positive_finite_number(tolerance: object) -> None:
    robot = dhkin.load("ur5")
    T = robot.fk(np.zeros(6))
    with pytest.raises(InputError, match="tolerance: expected a positive finite number"):
        robot.ik(T, tolerance=tolerance)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="tolerance: expected a positive finite number"):
        robot.ik_batch(T[None], tolerance=tolerance)  # type: ignore[arg-type]


def test_bad_seeds_and_tcp_name_the_argument() -> None:
    robot = dhkin.load("ur5")
    T = robot.fk(np.zeros(6))
    with pytest.raises(InputError, match=r"q_seed: expected shape \(6,\)"):
        robot.ik(T, q_seed=np.zeros(7))
    with pytest.raises(InputError, match="q_seed: expected finite values"):
        robot.ik(T, q_seed=[0, 0, np.nan, 0, 0, 0])
    with pytest.raises(InputError, match="q_seed: expected numbers"):
        robot.ik(T, q_seed=["a"] * 6)
    with pytest.raises(InputError, match="tcp: expected a finite"):
        robot.ik(T, tcp=np.eye(3))
    tilted = np.eye(4)
    tilted[3, 0] = 0.1
    with pytest.raises(InputError, match="tcp: bottom row"):
        robot.ik(T, tcp=tilted)


def test_empty_answers_have_true_reasons() -> None:
    """Beyond the reach: the geometry's numbers. Within reach, limits excluding every copy: the
    count of verified branches. An impossible tolerance: how close the candidates came."""
    irb = dhkin.load("abb_irb1200_7_70")
    far = np.eye(4)
    far[:3, 3] = (1.5, 0.0, 0.4)
    reason = irb.ik(far).reason
    assert reason.startswith("the wrist centre is 1.502") and "beyond the arm's reach" in reason
    narrow = dataclasses.replace(irb.table, joints=tuple(
        dataclasses.replace(j, lower=-0.01, upper=0.01) if i == 0 else j
        for i, j in enumerate(irb.table.joints)))
    turned = irb.reference().fk(np.array([1.0, 0.2, -0.3, 0.1, 0.5, 0.2]))
    empty = dhkin.Robot(narrow).ik(turned)
    assert len(empty) == 0
    assert empty.reason.endswith("verified, but no 2pi copy of any lies within the joint limits")
    verified = dhkin.Robot(narrow).ik_solver.branches(turned)
    assert f"{int(verified.valid.sum())} branch solution(s) verified" in empty.reason
    strict = irb.ik(turned, tolerance=1e-300)
    assert len(strict) == 0
    assert "did not verify on the exact chain at tolerance 1e-300" in strict.reason


# --------------------------------------------------------------------------------------------
# The band


def _ur5_with(alpha2_deg: float = 0.0, a5: float = 0.0) -> dhkin.DHTable:
    robot = dhkin.load("ur5")
    joints = list(robot.table.joints)
    joints[1] = dataclasses.replace(joints[1], alpha=np.radians(alpha2_deg))
    joints[4] = dataclasses.replace(joints[4], a=a5)
    return dataclasses.replace(robot.table, name="ur5_variant", joints=tuple(joints))


def _solved_exactly_and_completely(table: dhkin.DHTable, n: int, seed: int) -> None:
    robot = dhkin.Robot(table)
    q = table.random_q(n, np.random.default_rng(seed))
    T = robot.reference().fk(q)
    worst, missing = 0.0, 0
    for k in range(n):
        sols = robot.ik(T[k], q_seed=q[k])
        if len(sols):
            position, rotation = pose_error(robot.reference().fk(sols.q),
                                            np.broadcast_to(T[k], (len(sols), 4, 4)))
            worst = max(worst, position.max(), rotation.max())
        if not len(sols) or np.abs(wrapped(sols.q - q[k])).max(axis=1).min() > 1e-6:
            missing += 1
    assert worst <= 1e-9 and missing == 0, (worst, missing)


#: Band edges: (table change at the band's width, the condition named beyond it, seed).
BAND_EDGES = {
    "angle": (lambda scale: {"alpha2_deg": np.degrees(BAND.angle) * scale},  # axes 2, 3
              r"beyond the band: axes 2 and 3 parallel", 41),
    "length": (lambda scale: {"a5": BAND.length * scale}, r"axes 5 and 6 meet", 42),
}


@pytest.mark.parametrize("inside", [True, False])
@pytest.mark.parametrize("edge", sorted(BAND_EDGES))
def test_band_edge(edge: str, inside: bool) -> None:
    """alpha2 (axes 2 and 3 parallel) or a5 (axes 5 and 6 meet) off by just under / over the
    band: refined and exact inside; beyond it no family, and the general 6R solver answers
    (every solution, the pose's q among them)."""
    change, message, seed = BAND_EDGES[edge]
    table = _ur5_with(**change(0.95 if inside else 1.05))
    if inside:
        fit = fit_family(table)
        assert fit.family == "offset_wrist" and fit.refine
        _solved_exactly_and_completely(table, 1000, seed)
    else:
        with pytest.raises(FamilyError, match=message):
            fit_family(table)
        robot = dhkin.Robot(table)
        solutions = robot.ik(robot.fk(np.zeros(6)))
        assert solutions.family == "general6r" and not solutions.numerical
        assert np.abs(solutions.nearest(np.zeros(6))).max() <= 1e-6


@pytest.mark.parametrize("factor", [3.0, 8.0])
def test_calibration_several_times_larger_stays_exact_and_complete(factor: float) -> None:
    """The real calibrated UR5e's corrections (largest: 3.2e-4 m, 1.7e-3 rad; exact chain 1.7e-3
    from the ideal structure) scaled by 3 and 8: still in the family, every branch refined,
    10^3 random poses exact and complete."""
    table = dhkin.load("ur5e_calibrated").table
    scaled = dataclasses.replace(table, joints=tuple(
        dataclasses.replace(j, correction=tuple(factor * v for v in j.correction))
        for j in table.joints))
    fit = fit_family(scaled)
    assert fit.refine and fit.structural_deviation[0] > 0.8 * factor * 1.7e-3
    _solved_exactly_and_completely(scaled, 1000, int(factor))


def test_every_family_labels_its_branches_with_the_same_words(load_robot) -> None:
    """One vocabulary: the label words of every family's branches are LABEL_WORDS."""
    from dhkin.ik.result import LABEL_WORDS

    for name in ("abb_irb1200_7_70", "ur5", "aubo_i10", "stanford_arm", "anthropomorphic_arm"):
        labels = load_robot(name).ik_solver.branch_labels
        for branch in labels:
            for key, word in branch.items():
                assert word in LABEL_WORDS[key], (name, key, word)
