"""Seed 000 (ABB IRB 1200-7/0.7): its closed-form forward kinematics, checked against Pinocchio.

The seed (tests/data/seeds/000_*.txt, Chinese, formulas in LaTeX) gives a standard DH table
(d, theta, r, alpha, offset) with offset -90 deg on joint 2 and +-180 deg on joint 6, the link
matrices A_1..A_6, and MATLAB-simplified symbolic entries n, o, a, p of 0_6T = A_1 ... A_6 in
terms of q_1..q_6; further on, 3_6T = A_4 A_5 A_6, the wrist centre e = p - D6 a, a second
("geometric") form of the wrist orientation, and the elbow threshold q3 = -atan(D4 / L3).

The oracle is Pinocchio on the URDF generated from robots/abb_irb1200_7_70.yaml (that table is
the seed's, with d1 = 0.3991 m from ABB's URDF; tool0 = DH frame 6), evaluated at joint values q
(what the URDF, the teach pendant and the rest of the seed, joint limits and configuration flags,
call q).

The slip. The twelve n, o, a, p entries are the exact product A_1 ... A_6 with theta_i = q_i:
MATLAB's algebra is right, but the offsets of the seed's own table were never substituted. The
formulas are functions of the DH angles theta_i = q_i + offset_i, labelled q_i. Evaluated at the
robot's joint values every one of them is wrong (at q = 0 they put the tool at (L2 + L3, 0,
D1 - D4 - D6), arm forward and wrist down; the robot stands upright with the tool at
(D4 + D6, 0, D1 + L2 + L3)). The corrected form substitutes theta_2 = q_2 - pi/2 and
theta_6 = q_6 + pi: sin(q2 + q3) -> -cos(q2 + q3), cos(q2 + q3) -> sin(q2 + q3), cos q2 -> sin q2,
sin q2 -> -cos q2, and sin q6, cos q6 change sign (so n and o change sign). The same slip affects
the "geometric" wrist form of section 4.1.4. The A matrices, 3_6T and e = p - D6 a are right.
(A smaller labelling slip: the table numbers its rows 0..5 with theta_0..theta_5, the matrices
A_1..A_6 use theta_1..theta_6.)
"""

from __future__ import annotations

import functools
import math
import zlib

import numpy as np
import pytest
from numpy import cos, sin
from numpy.typing import NDArray

import dhkin
from dhkin.transforms import invert, rot_z

from .conftest import SEED_DOCUMENTS
from .test_fk_oracle import special_grid

ROBOT = "abb_irb1200_7_70"
TOLERANCE = 1e-12
ENTRIES = ("nx", "ny", "nz", "ox", "oy", "oz", "ax", "ay", "az", "px", "py", "pz")
INDEX = {"n": 0, "o": 1, "a": 2, "p": 3, "x": 0, "y": 1, "z": 2}
Array = NDArray[np.float64]


def seed_text() -> str:
    files = sorted(SEED_DOCUMENTS.glob("000_*.txt"))
    assert len(files) == 1, f"expected one seed 000 file in {SEED_DOCUMENTS}, found {files}"
    return files[0].read_text(encoding="utf-8")


@functools.cache  # read once per test process: 240 tests ask, each load parses the table
def dimensions() -> tuple[float, float, float, float, float]:
    """D1, L2, L3, D4, D6 of the seed, read from the built-in table (the URDF's numbers)."""
    joints = dhkin.load(ROBOT).table.joints
    return joints[0].d, joints[1].a, joints[2].a, joints[3].d, joints[5].d


def seed_formulas(q: Array) -> dict[str, Array]:
    """n, o, a, p exactly as the seed writes them, in q1..q6 (columns of q)."""
    D1, L2, L3, D4, D6 = dimensions()
    q1, q2, q3, q4, q5, q6 = q.T
    return {
        "nx": (sin(q6) * (cos(q4) * sin(q1) - sin(q4) * cos(q1) * cos(q2 + q3)) + cos(q6)
               * (cos(q5) * (sin(q1) * sin(q4) + cos(q4) * cos(q1) * cos(q2 + q3))
                  - sin(q5) * cos(q1) * sin(q2 + q3))),
        "ny": (-sin(q6) * (cos(q1) * cos(q4) + sin(q4) * sin(q1) * cos(q2 + q3)) - cos(q6)
               * (cos(q5) * (cos(q1) * sin(q4) - cos(q4) * sin(q1) * cos(q2 + q3))
                  + sin(q5) * sin(q1) * sin(q2 + q3))),
        "nz": (sin(q2 + q3) * sin(q4) * sin(q6) - cos(q6) * (cos(q2 + q3) * sin(q5) + sin(q2
               + q3) * cos(q4) * cos(q5))),
        "ox": (cos(q6) * (cos(q4) * sin(q1) - sin(q4) * cos(q1) * cos(q2 + q3)) - sin(q6)
               * (cos(q5) * (sin(q1) * sin(q4) + cos(q4) * cos(q1) * cos(q2 + q3))
                  - sin(q5) * cos(q1) * sin(q2 + q3))),
        "oy": (sin(q6) * (cos(q5) * (cos(q1) * sin(q4) - cos(q4) * sin(q1) * cos(q2 + q3))
               + sin(q5) * sin(q1) * sin(q2 + q3)) - cos(q6) * (cos(q1) * cos(q4)
               + sin(q4) * sin(q1) * cos(q2 + q3))),
        "oz": (sin(q6) * (cos(q2 + q3) * sin(q5) + sin(q2 + q3) * cos(q4) * cos(q5)) + sin(q2
               + q3) * cos(q6) * sin(q4)),
        "ax": (-sin(q5) * (sin(q1) * sin(q4) + cos(q4) * cos(q1) * cos(q2 + q3)) - cos(q5)
               * cos(q1) * sin(q2 + q3)),
        "ay": (sin(q5) * (cos(q1) * sin(q4) - cos(q4) * sin(q1) * cos(q2 + q3)) - cos(q5)
               * sin(q1) * sin(q2 + q3)),
        "az": sin(q2 + q3) * cos(q4) * sin(q5) - cos(q2 + q3) * cos(q5),
        "px": (L2 * cos(q1) * cos(q2) - D4 * sin(q2 + q3) * cos(q1) - D6 * sin(q2 + q3)
               * cos(q1) * cos(q5) + L3 * cos(q1) * cos(q2 + q3) - D6 * sin(q1)
               * sin(q4) * sin(q5) - D6 * cos(q1) * cos(q2) * cos(q3) * cos(q4) * sin(q5)
               + D6 * cos(q1) * cos(q4) * sin(q2) * sin(q3) * sin(q5)),
        "py": (L2 * cos(q2) * sin(q1) - D4 * sin(q2 + q3) * sin(q1) - D6 * sin(q2 + q3)
               * cos(q5) * sin(q1) + L3 * sin(q1) * cos(q2 + q3) + D6 * cos(q1) * sin(q4)
               * sin(q5) + D6 * cos(q4) * sin(q1) * sin(q2) * sin(q3) * sin(q5) - D6
               * cos(q2) * cos(q3) * cos(q4) * sin(q1) * sin(q5)),
        "pz": (D1 - D4 * cos(q2 + q3) - L3 * sin(q2 + q3) - L2 * sin(q2) + (D6 * sin(q2
               + q3) * sin(q4 + q5)) / 2 - D6 * cos(q2 + q3) * cos(q5) - (D6 * sin(q4
               - q5) * sin(q2 + q3)) / 2),
    }


def corrected_formulas(q: Array) -> dict[str, Array]:
    """n, o, a, p in the joint values q: the seed's entries with theta_2 = q_2 - pi/2 and
    theta_6 = q_6 + pi substituted (S = sin(q2 + q3), C = cos(q2 + q3))."""
    D1, L2, L3, D4, D6 = dimensions()
    q1, q2, q3, q4, q5, q6 = q.T
    s1, c1, s2, c2, s3, c3 = sin(q1), cos(q1), sin(q2), cos(q2), sin(q3), cos(q3)
    s4, c4, s5, c5, s6, c6 = sin(q4), cos(q4), sin(q5), cos(q5), sin(q6), cos(q6)
    S, C = sin(q2 + q3), cos(q2 + q3)
    return {
        "nx": -s6 * (c4 * s1 - s4 * c1 * S) - c6 * (c5 * (s1 * s4 + c4 * c1 * S) + s5 * c1 * C),
        "ny": s6 * (c1 * c4 + s4 * s1 * S) + c6 * (c5 * (c1 * s4 - c4 * s1 * S) - s5 * s1 * C),
        "nz": C * s4 * s6 + c6 * (S * s5 - C * c4 * c5),
        "ox": -c6 * (c4 * s1 - s4 * c1 * S) + s6 * (c5 * (s1 * s4 + c4 * c1 * S) + s5 * c1 * C),
        "oy": -s6 * (c5 * (c1 * s4 - c4 * s1 * S) - s5 * s1 * C) + c6 * (c1 * c4 + s4 * s1 * S),
        "oz": -s6 * (S * s5 - C * c4 * c5) + C * c6 * s4,
        "ax": -s5 * (s1 * s4 + c4 * c1 * S) + c5 * c1 * C,
        "ay": s5 * (c1 * s4 - c4 * s1 * S) + c5 * s1 * C,
        "az": -C * c4 * s5 - S * c5,
        "px": L2 * c1 * s2 + D4 * C * c1 + D6 * C * c1 * c5 + L3 * c1 * S - D6 * s1 * s4 * s5
        - D6 * c1 * s2 * c3 * c4 * s5 - D6 * c1 * c4 * c2 * s3 * s5,
        "py": L2 * s2 * s1 + D4 * C * s1 + D6 * C * c5 * s1 + L3 * s1 * S + D6 * c1 * s4 * s5
        - D6 * c4 * s1 * c2 * s3 * s5 - D6 * s2 * c3 * c4 * s1 * s5,
        "pz": D1 - D4 * S + L3 * C + L2 * c2 - D6 * C * sin(q4 + q5) / 2 - D6 * S * c5
        + D6 * sin(q4 - q5) * C / 2,
    }


def entry(T: Array, name: str) -> Array:
    """The n/o/a/p x/y/z element of poses T (N, 4, 4)."""
    return T[:, INDEX[name[1]], INDEX[name[0]]]


@pytest.fixture(scope="module")
def samples() -> tuple[Array, Array, Array]:
    """Joint values (10^4 random within the limits + the special-angle grid), the DH angles
    theta = q + offset, and Pinocchio's base_link -> tool0 poses."""
    robot = dhkin.load(ROBOT)
    rng = np.random.default_rng(zlib.crc32(b"seed000"))
    q = np.vstack([robot.table.random_q(10_000, rng), special_grid(robot.table)])
    theta, _ = robot.table.dh_parameters(q)
    return q, theta, robot.reference().fk(q)


def test_seed_document_is_transcribed() -> None:
    """Anchors of the transcription: the IRB 1200 document, its offsets (-90 on row 2, +-180 on
    row 6), the statement that the offset adds to theta, A_1 ... A_6, pz and e as written; and
    the built-in table carries the seed's twists and offsets."""
    text = seed_text()
    for anchor in ("IRB 1200-7/0.7", "1(2-1)\t0\tθ_1\tL2\t0\t-90", "5(6-5)\tD6\tθ_5\t0\t0\t± 180",
                   "**offset** 项是叠加在 θ 上面的偏置量", "{}^0_6T = A_1A_2A_3A_4A_5A_6",
                   r"p_z = D1 - D4 * \cos(q2 + q3) - L3 * \sin(q2 + q3) - L2 * \sin(q2)",
                   r"a_z &= \sin(q_2 + q_3) * \cos(q_4) * \sin(q_5) - \cos(q_2 + q_3) * \cos(q_5)",
                   "e_x = p_x - D6 * a_x"):
        assert anchor in text, anchor
    table = dhkin.load(ROBOT).table
    assert [round(math.degrees(j.alpha)) for j in table.joints] == [-90, 0, -90, 90, -90, 0]
    assert [round(math.degrees(j.offset)) for j in table.joints] == [0, -90, 0, 0, 0, 180]
    assert table.convention == "standard" and np.allclose(table.tool, np.eye(4))


@pytest.mark.parametrize("name", ENTRIES)
def test_seed_formula_as_written_is_wrong_for_joint_values(
        name: str, samples: tuple[Array, Array, Array]) -> None:
    """Slip: fed the robot's joint values q, the seed's entry misses Pinocchio by far more than
    rounding (each one of the twelve)."""
    q, _, T = samples
    error = np.abs(seed_formulas(q)[name] - entry(T, name))
    assert error.max() > 0.1, name


@pytest.mark.parametrize("name", ENTRIES)
def test_seed_formula_holds_for_dh_angles(name: str, samples: tuple[Array, Array, Array]) -> None:
    """Diagnosis: the same entry fed the DH angles theta = q + offset equals Pinocchio to 1e-12
    (the algebra is right; the offsets were not substituted)."""
    _, theta, T = samples
    error = np.abs(seed_formulas(theta)[name] - entry(T, name))
    assert error.max() <= TOLERANCE, name


@pytest.mark.parametrize("name", ENTRIES)
def test_corrected_formula_holds_for_joint_values(
        name: str, samples: tuple[Array, Array, Array]) -> None:
    """Correction: the entry with theta_2 = q_2 - pi/2 and theta_6 = q_6 + pi substituted equals
    Pinocchio to 1e-12 at the joint values."""
    q, _, T = samples
    error = np.abs(corrected_formulas(q)[name] - entry(T, name))
    assert error.max() <= TOLERANCE, name


def test_zero_pose_shows_the_slip() -> None:
    """At q = 0 the seed's p is (L2 + L3, 0, D1 - D4 - D6); the IRB 1200 stands upright with the
    tool at (D4 + D6, 0, D1 + L2 + L3), z out of the flange along +x, as Pinocchio says."""
    D1, L2, L3, D4, D6 = dimensions()
    zero = np.zeros((1, 6))
    T = dhkin.load(ROBOT).reference().fk(zero)[0]
    np.testing.assert_allclose(T[:3, 3], [D4 + D6, 0, D1 + L2 + L3], atol=1e-15)
    np.testing.assert_allclose(T[:3, 2], [1, 0, 0], atol=1e-15)
    seed = seed_formulas(zero)
    np.testing.assert_allclose([seed["px"][0], seed["py"][0], seed["pz"][0]],
                               [L2 + L3, 0, D1 - D4 - D6], atol=1e-15)
    fixed = corrected_formulas(zero)
    np.testing.assert_allclose([fixed["px"][0], fixed["py"][0], fixed["pz"][0]], T[:3, 3],
                               atol=1e-15)


# --------------------------------------------------------------------------------------------
# The seed's other forward-kinematics statements


def seed_link_matrices(theta: Array) -> list[Array]:
    """A_1 ... A_6 exactly as the seed prints them (theta_i, D1, L2, L3, D4, D6), one q row."""
    D1, L2, L3, D4, D6 = dimensions()
    c, s = np.cos(theta), np.sin(theta)
    return [
        np.array([[c[0], 0, -s[0], 0], [s[0], 0, c[0], 0], [0, -1, 0, D1], [0, 0, 0, 1]]),
        np.array([[c[1], -s[1], 0, L2 * c[1]], [s[1], c[1], 0, L2 * s[1]], [0, 0, 1, 0],
                  [0, 0, 0, 1]]),
        np.array([[c[2], 0, -s[2], L3 * c[2]], [s[2], 0, c[2], L3 * s[2]], [0, -1, 0, 0],
                  [0, 0, 0, 1]]),
        np.array([[c[3], 0, s[3], 0], [s[3], 0, -c[3], 0], [0, 1, 0, D4], [0, 0, 0, 1]]),
        np.array([[c[4], 0, -s[4], 0], [s[4], 0, c[4], 0], [0, -1, 0, 0], [0, 0, 0, 1]]),
        np.array([[c[5], -s[5], 0, 0], [s[5], c[5], 0, 0], [0, 0, 1, D6], [0, 0, 0, 1]]),
    ]


def pinocchio_dh_frames(robot: dhkin.Robot, q: Array) -> list[Array]:
    """DH frames 0..6 of ``robot`` from Pinocchio: F_{i-1} = link_i Rz(-theta_i) (standard DH,
    urdf.py), and F_6 = tool0 (the table's tool is the identity)."""
    reference = robot.reference()
    theta, _ = robot.table.dh_parameters(q[None, :])
    frames = [reference.fk(q, frame=j.link) @ rot_z(-theta[0, i])
              for i, j in enumerate(robot.table.joints)]
    return [*frames, reference.fk(q)]


def test_seed_link_matrices_and_wrist_transform() -> None:
    """Each printed A_i equals F_{i-1}^-1 F_i from Pinocchio at theta = q + offset, and the
    printed 3_6T = A_4 A_5 A_6 (its p column D4 + D6 c5 included) equals F_3^-1 F_6."""
    D4, D6 = dimensions()[3:]
    robot = dhkin.load(ROBOT)
    table = robot.table
    for q in table.random_q(200, np.random.default_rng(4)):
        theta, _ = table.dh_parameters(q[None, :])
        A = seed_link_matrices(theta[0])
        F = pinocchio_dh_frames(robot, q)
        for i in range(6):
            np.testing.assert_allclose(A[i], invert(F[i]) @ F[i + 1], rtol=0, atol=TOLERANCE)
        c4, s4, c5, s5, c6, s6 = (f(theta[0, k]) for k in (3, 4, 5) for f in (np.cos, np.sin))
        T36 = np.array([[c4 * c5 * c6 - s4 * s6, -c6 * s4 - c4 * c5 * s6, -c4 * s5, -D6 * c4 * s5],
                        [c4 * s6 + c5 * c6 * s4, c4 * c6 - c5 * s4 * s6, -s4 * s5, -D6 * s4 * s5],
                        [c6 * s5, -s5 * s6, c5, D4 + D6 * c5], [0, 0, 0, 1]])
        np.testing.assert_allclose(T36, invert(F[3]) @ F[6], rtol=0, atol=TOLERANCE)


def test_wrist_centre_is_p_minus_d6_a(samples: tuple[Array, Array, Array]) -> None:
    """e = p - D6 a (the seed's wrist centre) is where axes 4, 5, 6 meet: the origin of link_5
    in Pinocchio (the seed's statement holds as written)."""
    q, _, T = samples
    D6 = dimensions()[4]
    centre = dhkin.load(ROBOT).reference().fk(q[:2000], frame="link_5")[:, :3, 3]
    e = T[:2000, :3, 3] - D6 * T[:2000, :3, 2]
    np.testing.assert_allclose(e, centre, rtol=0, atol=TOLERANCE)


def _rot_y(t: float) -> Array:
    return np.array([[math.cos(t), 0, math.sin(t)], [0, 1, 0], [-math.sin(t), 0, math.cos(t)]])


def _rot_z(t: float) -> Array:
    return np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1]])


def seed_geometric_wrist(t4: float, t5: float, t6: float) -> Array:
    """Section 4.1.4's matrix, as printed (c_i, s_i of the wrist angles)."""
    c4, s4, c5, s5 = math.cos(t4), math.sin(t4), math.cos(t5), math.sin(t5)
    c6, s6 = math.cos(t6), math.sin(t6)
    return np.array([[c4 * c5 * c6 - s4 * s6, -c6 * s4 - c4 * c5 * s6, -c4 * s5],
                     [-c4 * s6 - c5 * c6 * s4, c5 * s4 * s6 - c4 * c6, s4 * s5],
                     [-c6 * s5, s5 * s6, -c5]])


def test_seed_geometric_wrist_form_has_the_same_slip() -> None:
    """Rot(y, -q2 - q3) Rot(z, -q1) R = the printed matrix of q4, q5, q6: true for the DH angles
    theta, wrong as written for joint values; corrected, Rot(y, pi/2 - q2 - q3) Rot(z, -q1) R
    equals the printed matrix with c6 and s6 negated (theta_6 = q_6 + pi)."""
    robot = dhkin.load(ROBOT)
    Q = robot.table.random_q(500, np.random.default_rng(8))
    theta, _ = robot.table.dh_parameters(Q)
    R = robot.reference().fk(Q)[:, :3, :3]
    worst_written = 0.0
    for q, t, rotation in zip(Q, theta, R, strict=True):
        in_theta = _rot_y(-t[1] - t[2]) @ _rot_z(-t[0]) @ rotation
        np.testing.assert_allclose(in_theta, seed_geometric_wrist(t[3], t[4], t[5]), rtol=0,
                                   atol=TOLERANCE)
        written = _rot_y(-q[1] - q[2]) @ _rot_z(-q[0]) @ rotation
        worst_written = max(worst_written,
                            float(np.abs(written - seed_geometric_wrist(q[3], q[4], q[5])).max()))
        corrected = _rot_y(math.pi / 2 - q[1] - q[2]) @ _rot_z(-q[0]) @ rotation
        flipped = seed_geometric_wrist(q[3], q[4], q[5] + math.pi)
        np.testing.assert_allclose(corrected, flipped, rtol=0, atol=TOLERANCE)
    assert worst_written > 0.5


def test_seed_elbow_threshold_is_the_elbow_singularity() -> None:
    """The seed's elbow up/down threshold q3 = -atan(D4 / L3) (joint 3 has no offset, so q and
    theta agree here) is where Pinocchio's Jacobian loses rank: the arm is stretched."""
    _, _, L3, D4, _ = dimensions()
    reference = dhkin.load(ROBOT).reference()
    q = np.array([0.4, 0.3, -math.atan(D4 / L3), 0.8, 0.6, -0.2])
    assert reference.manipulability(q).sigma_min <= 1e-12
    q[2] += 0.1
    assert reference.manipulability(q).sigma_min >= 1e-3
