"""Seed 003's IK examples (4-1-1, 4-1-2, 4-2-1) reproduced, and its slips named.

The oracle is Pinocchio on the URDF generated from the built-in tables ``anthropomorphic_arm``
(L1 = L2 = L3 = 1, d2 = 0.1, tool d7 = 0.15 along z6) and ``stanford_arm`` (Spong's frames,
d1 = 0.4, d2 = 0.15, d6 = 0.1, stroke 0.3..1.0 m). Frame names in the generated URDF: with
standard DH, ``link_i`` is DH frame i-1 turned by joint i, so ``link_5`` (anthropomorphic arm)
and ``link_4`` (Stanford arm) have their origin at the wrist centre.

Slips found (Pinocchio decides):

* 4-1-2: the "other solution" (0, pi/4, -pi/2, -pi, -pi/4, pi/2) misses the pose by a half turn
  about the tool axis (same position, rotation error pi); the wrist flip is
  (q4 +- pi, -q5, q6 +- pi), i.e. (0, pi/4, -pi/2, -pi, -pi/4, -pi/2).
* 4-1-1 lists three arm solutions of the wrist point; there is a fourth,
  (-3.2828, 3pi/4, pi/2) (the other elbow of the righty arm).
* 4-2-1: "-d3 c2 = dz - d1" has the wrong sign: the wrist centre z is d1 + d3 c2, so
  d3 c2 = dz - d1 and theta2 = atan2(dx c1 + dy s1, dz - d1) (the seed's atan2(..., d1 - dz)
  gives pi - theta2, the arm mirrored about the horizontal).
* 4-2-1: theta4 = atan2(ax c1 c2 + ay s1 c2 - az s2, ax s1 - ay c1) is atan2(c4 s5, -s4 s5) =
  theta4 + pi/2 in these frames; theta4 = atan2(ay c1 - ax s1, ax c1 c2 + ay s1 c2 - az s2).
"""

from __future__ import annotations

import numpy as np

from dhkin.transforms import pose_error

from .test_ik_spherical_wrist import wrapped_difference

PI = np.pi
WRIST_POINT_4_1_1 = np.array([0.1, np.sqrt(2.0), 1.0])
ARM_SOLUTIONS_4_1_1 = [(0.0, PI / 4, -PI / 2), (0.0, -PI / 4, PI / 2), (-3.2828, -3 * PI / 4,
                                                                         -PI / 2)]
Q_4_1_2 = np.array([0.0, PI / 4, -PI / 2, 0.0, PI / 4, PI / 2])
SEED_OTHER_4_1_2 = np.array([0.0, PI / 4, -PI / 2, -PI, -PI / 4, PI / 2])
CORRECTED_OTHER_4_1_2 = np.array([0.0, PI / 4, -PI / 2, -PI, -PI / 4, -PI / 2])
STANFORD_D1, STANFORD_D2 = 0.4, 0.15


def wrist_point(robot, q: np.ndarray, frame: str) -> np.ndarray:
    return robot.reference().fk(np.asarray(q, dtype=float), frame=frame)[:3, 3]


# --------------------------------------------------------------------------------------------
# 4-1-1 and 4-1-2: the anthropomorphic arm


def test_4_1_1_three_arm_solutions_reach_one_wrist_point(load_robot):
    robot = load_robot("anthropomorphic_arm")
    for arm in ARM_SOLUTIONS_4_1_1:
        for wrist in ((0.0, 0.0, 0.0), (0.7, -1.1, 2.0)):  # the wrist point ignores q4..q6
            point = wrist_point(robot, np.r_[arm, wrist], "link_5")
            tolerance = 1e-12 if arm[0] == 0.0 else 5e-5  # -3.2828 is rounded to 4 decimals
            np.testing.assert_allclose(point, WRIST_POINT_4_1_1, atol=tolerance)


def test_4_1_1_solver_finds_the_three_and_a_fourth_arm_solution(load_robot):
    """The IK of the 4-1-2 pose has four arm solutions (q1, q2, q3): the seed's three, q1 =
    -3.2828 appearing as its 2pi copy 3.0004 (limits +-180 deg), and (-3.2828, 3pi/4, pi/2)."""
    robot = load_robot("anthropomorphic_arm")
    sols = robot.ik(robot.reference().fk(Q_4_1_2))
    assert len(sols) == 8  # one per branch: 4 arms x 2 wrists
    arms = np.unique(np.round(sols.q[:, :3], 9), axis=0)
    assert len(arms) == 4
    expected = [*ARM_SOLUTIONS_4_1_1, (-3.2828, 3 * PI / 4, PI / 2)]
    for arm in expected:
        gap = np.abs(wrapped_difference(arms, np.array(arm))).max(axis=1)
        assert gap.min() <= 5e-5, (arm, arms)
    righty = arms[arms[:, 0] > 1.0]
    np.testing.assert_allclose(righty[:, 0], 2 * PI - 3.2828, atol=5e-5)
    exact_q1 = righty[0, 0] - 2 * PI
    assert abs(exact_q1 - (-3.2828)) < 5e-5 and round(exact_q1, 4) == -3.2828
    assert len({(c.labels["shoulder"], c.labels["elbow"]) for c in sols.configurations}) == 4


def test_4_1_2_second_wrist_solution_and_the_seed_slip_in_q6(load_robot):
    robot = load_robot("anthropomorphic_arm")
    reference = robot.reference()
    T = reference.fk(Q_4_1_2)
    np.testing.assert_allclose(T[:3, 3] - 0.15 * T[:3, 2],
                               wrist_point(robot, Q_4_1_2, "link_5"), atol=1e-12)  # d7 on z6
    position, rotation = pose_error(reference.fk(SEED_OTHER_4_1_2), T)
    assert position < 1e-12  # the tool sits on the axis of joint 6, so q6 cannot move it ...
    assert abs(rotation - PI) < 1e-12  # ... but the seed's q6 = pi/2 turns it by a half turn
    position, rotation = pose_error(reference.fk(CORRECTED_OTHER_4_1_2), T)
    assert position < 1e-12 and rotation < 1e-12
    sols = robot.ik(T, copies=True)  # every in-limit 2pi copy

    def distance(q: np.ndarray) -> float:
        return float(np.abs(sols.q - q).max(axis=1).min())

    assert distance(Q_4_1_2) < 1e-12
    assert distance(CORRECTED_OTHER_4_1_2) < 1e-12
    q4_turned = CORRECTED_OTHER_4_1_2 + np.array([0.0, 0.0, 0.0, 2 * PI, 0.0, 0.0])
    assert distance(q4_turned) < 1e-12  # its 2pi copy q4 = +pi is in the limits too
    assert distance(SEED_OTHER_4_1_2) > 1.0
    flip = [c.labels["wrist"] for q, c in zip(sols.q, sols.configurations, strict=True)
            if np.abs(q - CORRECTED_OTHER_4_1_2).max() < 1e-12]
    assert flip == ["flip"]
    # by default one solution per branch (8: 4 arms x 2 wrists), the copy nearest 0: the flip
    # once, with q4 = -pi or +pi (equally near 0); with the seed q4 = -pi, that copy
    default = robot.ik(T)
    assert len(default) == 8
    gaps = np.abs(wrapped_difference(default.q, CORRECTED_OTHER_4_1_2)).max(axis=1)
    assert np.sum(gaps < 1e-12) == 1
    seeded = robot.ik(T, q_seed=CORRECTED_OTHER_4_1_2)
    assert np.abs(seeded.q - CORRECTED_OTHER_4_1_2).max(axis=1).min() < 1e-12
    assert np.abs(seeded.q - Q_4_1_2).max(axis=1).min() < 1e-12


# --------------------------------------------------------------------------------------------
# 4-2-1: the Stanford arm


def _stanford_wrist_centres(robot, q: np.ndarray) -> np.ndarray:
    return np.stack([wrist_point(robot, row, "link_4") for row in q])


def test_4_2_1_wrist_centre_equations_and_the_sign_slip(load_robot):
    """Spong's p = (c1 s2 d3 - s1 d2, s1 s2 d3 + c1 d2, d1 + c2 d3) holds in Pinocchio; of the
    seed's three equations the first and third hold, the second needs the opposite sign."""
    robot = load_robot("stanford_arm")
    q = robot.table.random_q(200, np.random.default_rng(421))
    dx, dy, dz = _stanford_wrist_centres(robot, q).T
    c1, s1, c2, s2, d3 = np.cos(q[:, 0]), np.sin(q[:, 0]), np.cos(q[:, 1]), np.sin(q[:, 1]), q[:, 2]
    np.testing.assert_allclose(d3 * s2, dx * c1 + dy * s1, atol=1e-12)
    np.testing.assert_allclose(STANFORD_D2, dy * c1 - dx * s1, atol=1e-12)
    np.testing.assert_allclose(d3 * c2, dz - STANFORD_D1, atol=1e-12)  # corrected
    seed_residual = -d3 * c2 - (dz - STANFORD_D1)  # the seed's -d3 c2 = dz - d1
    assert np.abs(seed_residual).max() > 0.5
    np.testing.assert_allclose(seed_residual, -2 * d3 * c2, atol=1e-12)


def _seed_arm_solutions(centre: np.ndarray, corrected: bool) -> list[np.ndarray]:
    """theta1 = atan2(dy, dx) - atan2(d2, +-sqrt(dx^2 + dy^2 - d2^2)), theta2 = atan2(dx c1 +
    dy s1, dz - d1) (corrected) or atan2(..., d1 - dz) (seed), d3 = sqrt(...)."""
    dx, dy, dz = centre
    arms = []
    for sign in (1.0, -1.0):
        theta1 = np.arctan2(dy, dx) - np.arctan2(STANFORD_D2, sign * np.sqrt(
            dx**2 + dy**2 - STANFORD_D2**2))
        reach = dx * np.cos(theta1) + dy * np.sin(theta1)
        height = dz - STANFORD_D1 if corrected else STANFORD_D1 - dz
        arms.append(np.array([theta1, np.arctan2(reach, height), np.hypot(reach, height)]))
    return arms


def _seed_wrist_solutions(robot, arm: np.ndarray, R: np.ndarray) -> list[np.ndarray]:
    """Seed 003 section 4: 3R6 = (0R3)^T 0R6, theta5 = atan2(+-sqrt(r13^2 + r23^2), r33),
    theta4 = atan2(r23, r13), theta6 = atan2(r32, -r31) (with the sign of sin theta5)."""
    R03 = robot.reference().fk(np.r_[arm, 0.0, 0.0, 0.0], frame="link_4")[:3, :3]
    r = R03.T @ R
    solutions = []
    for sign in (1.0, -1.0):
        theta5 = np.arctan2(sign * np.hypot(r[0, 2], r[1, 2]), r[2, 2])
        theta4 = np.arctan2(sign * r[1, 2], sign * r[0, 2])
        theta6 = np.arctan2(sign * r[2, 1], -sign * r[2, 0])
        solutions.append(np.r_[arm, theta4, theta5, theta6])
    return solutions


def test_4_2_1_stanford_solution_reproduced(load_robot):
    """The seed's closed form with the sign slip corrected gives 4 solutions (2 theta1 x 2 wrist),
    each exact by Pinocchio and each among the solver's; with the seed's sign, theta2 becomes
    pi - theta2 and the arm misses the wrist centre."""
    robot = load_robot("stanford_arm")
    reference = robot.reference()
    rng = np.random.default_rng(4210)
    largest_miss = 0.0
    for q in robot.table.random_q(50, rng):
        T = reference.fk(q)
        centre = wrist_point(robot, q, "link_4")
        np.testing.assert_allclose(centre, T[:3, 3] - 0.1 * T[:3, 2], atol=1e-12)
        seed_solutions = [full for arm in _seed_arm_solutions(centre, corrected=True)
                          for full in _seed_wrist_solutions(robot, arm, T[:3, :3])]
        position, rotation = pose_error(reference.fk(np.array(seed_solutions)),
                                        np.broadcast_to(T, (4, 4, 4)))
        assert position.max() < 1e-12 and rotation.max() < 1e-12
        solver = robot.ik(T).q
        assert len(solver) == 4
        for solution in seed_solutions:
            assert np.abs(wrapped_difference(solver, solution)).max(axis=1).min() < 1e-9
        for arm in _seed_arm_solutions(centre, corrected=False):
            missed = wrist_point(robot, np.r_[arm, 0, 0, 0], "link_4") - centre
            np.testing.assert_allclose(missed[:2], 0, atol=1e-12)  # s2 is right ...
            height = centre[2] - STANFORD_D1  # ... c2 has the wrong sign: z = d1 - d3 c2
            np.testing.assert_allclose(missed[2], -2 * height, atol=1e-12)
            largest_miss = max(largest_miss, abs(missed[2]))
    assert largest_miss > 0.5


def test_4_2_1_seed_theta4_formula_is_a_quarter_turn_off(load_robot):
    """Every solution has the approach vector a (z6 = z5) perpendicular to axis 5 (z4): with the
    seed's theta4 it is not (no theta5, theta6 can finish the pose), with the corrected one it
    is; the seed's value is theta4 + pi/2."""
    robot = load_robot("stanford_arm")
    reference = robot.reference()
    rng = np.random.default_rng(4211)
    for q in robot.table.random_q(50, rng):
        T = reference.fk(q)
        ax, ay, az = T[:3, 2]
        c1, s1, c2, s2 = np.cos(q[0]), np.sin(q[0]), np.cos(q[1]), np.sin(q[1])
        seed_theta4 = np.arctan2(ax * c1 * c2 + ay * s1 * c2 - az * s2, ax * s1 - ay * c1)
        corrected_theta4 = np.arctan2(ay * c1 - ax * s1, ax * c1 * c2 + ay * s1 * c2 - az * s2)
        if np.sin(q[4]) > 0:  # the formulas pick the theta5 > 0 wrist
            assert abs(wrapped_difference(corrected_theta4, q[3])) < 1e-9
            assert abs(wrapped_difference(seed_theta4, q[3] + PI / 2)) < 1e-9
        for theta4, perpendicular in ((corrected_theta4, True), (seed_theta4, False)):
            J = reference.jacobian(np.r_[q[:3], theta4, 0.0, 0.0], reference="world")
            axis_5 = J[3:, 4]
            assert (abs(np.dot(axis_5, T[:3, 2])) < 1e-9) == perpendicular or (
                not perpendicular and abs(np.sin(q[4])) < 1e-3)
