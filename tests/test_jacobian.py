"""Jacobians and manipulability of the Pinocchio reference, checked against finite differences.

reference.py's docstring defines the three conventions of ``jacobian(q, frame, reference)``, a
6 x n matrix [linear; angular] with columns in chain order. With p(q) and R(q) the frame's pose
(from Pinocchio FK), dp/dq_i and the angular velocity w_i defined by [w_i]x = dR/dq_i R^T:

* ``local_world_aligned``: column i = [dp/dq_i; w_i] (origin velocity, world axes);
* ``world``: column i = [dp/dq_i - w_i x p; w_i] (velocity of the body point at the world origin);
* ``local``: column i = [R^T dp/dq_i; R^T w_i] (body velocity, the frame's own axes).

The derivatives come from a five-point central difference of Pinocchio FK with step h = 1e-3:
truncation ~ h^4/30 |f^(5)| ~ 3e-14 and round-off ~ 1.5 eps / h ~ 3e-13 per metre of reach, so
1e-10 leaves two orders of margin while a wrong sign, axis or reference point errs by ~0.1.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest
from numpy.typing import NDArray

import dhkin
from dhkin.reference import Reference

from .conftest import DATA, PER_ROBOT_BUILTINS, REFERENCE_URDFS

ROBOTS = PER_ROBOT_BUILTINS  # a sample of the package arms (see conftest)
SIX_AXIS = [name for name in ROBOTS if dhkin.load(name).dof == 6]
CONVENTIONS = ("local", "world", "local_world_aligned")
STEP = 1e-3
FD_TOLERANCE = 1e-10
N_SAMPLES = 300


def vee(S: NDArray[np.float64]) -> NDArray[np.float64]:
    """Vector of the skew-symmetric part of a 3x3 matrix."""
    return 0.5 * np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])


def finite_difference_jacobians(reference: Reference, q: NDArray[np.float64],
                                frame: str | None) -> dict[str, NDArray[np.float64]]:
    """The three Jacobians of ``frame`` at q, by five-point differences of Pinocchio FK."""
    n = len(q)
    rows = [q]
    for i in range(n):
        e = np.zeros(n)
        e[i] = STEP
        rows += [q + 2 * e, q + e, q - e, q - 2 * e]
    poses = reference.fk(np.array(rows), frame=frame)  # one call: Pinocchio row by row
    T = poses[0]
    R, p = T[:3, :3], T[:3, 3]
    dp = np.empty((3, n))
    w = np.empty((3, n))
    for i in range(n):
        Tp2, Tp1, Tm1, Tm2 = poses[1 + 4 * i:5 + 4 * i]
        dT = (-Tp2 + 8 * Tp1 - 8 * Tm1 + Tm2) / (12 * STEP)
        dp[:, i] = dT[:3, 3]
        w[:, i] = vee(dT[:3, :3] @ R.T)
    return {
        "local_world_aligned": np.vstack([dp, w]),
        "world": np.vstack([dp - np.cross(w.T, p).T, w]),
        "local": np.vstack([R.T @ dp, R.T @ w]),
    }


def samples(robot: dhkin.Robot, n: int = N_SAMPLES) -> NDArray[np.float64]:
    """Zero (clipped to the limits), n random q within the limits, and a special-angle vector."""
    rng = np.random.default_rng(zlib.crc32(robot.name.encode()))
    zero = np.clip(np.zeros(robot.dof), robot.lower, robot.upper)
    special = np.clip(np.resize([math.pi / 2, -math.pi / 2, math.pi, 0.0], robot.dof),
                      robot.lower, robot.upper)
    return np.vstack([zero, special, robot.table.random_q(n, rng)])


def frames_of(robot: dhkin.Robot) -> list[str]:
    """tool0, flange and the link moved by the middle joint."""
    return ["tool0", "flange", robot.table.joints[(robot.dof - 1) // 2].link]


@pytest.mark.parametrize("name", ROBOTS)
def test_jacobians_equal_finite_differences_of_pinocchio_fk(name: str) -> None:
    """Each of LOCAL, WORLD, LOCAL_WORLD_ALIGNED equals its finite-difference definition."""
    robot = dhkin.load(name)
    reference = robot.reference()
    worst = dict.fromkeys(CONVENTIONS, 0.0)
    for q in samples(robot):
        for frame in frames_of(robot):
            expected = finite_difference_jacobians(reference, q, frame)
            for convention in CONVENTIONS:
                J = reference.jacobian(q, frame=frame, reference=convention)
                assert J.shape == (6, robot.dof)
                worst[convention] = max(worst[convention],
                                        float(np.abs(J - expected[convention]).max()))
    assert max(worst.values()) <= FD_TOLERANCE, worst


@pytest.mark.parametrize("name", ROBOTS)
def test_conventions_are_related_by_the_frame_pose(name: str) -> None:
    """WORLD = Ad(T) LOCAL and LOCAL_WORLD_ALIGNED = diag(R, R) LOCAL, T = (R, p) the frame pose;
    the default convention is LOCAL_WORLD_ALIGNED and the default frame is tool0."""
    robot = dhkin.load(name)
    reference = robot.reference()
    for q in samples(robot, 20):
        T = reference.fk(q)
        R, p = T[:3, :3], T[:3, 3]
        local = reference.jacobian(q, reference="local")
        world = reference.jacobian(q, reference="world")
        aligned = reference.jacobian(q, reference="local_world_aligned")
        p_hat = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
        adjoint = np.block([[R, p_hat @ R], [np.zeros((3, 3)), R]])
        np.testing.assert_allclose(world, adjoint @ local, rtol=0, atol=1e-14)
        np.testing.assert_allclose(aligned[:3], R @ local[:3], rtol=0, atol=1e-14)
        np.testing.assert_allclose(aligned[3:], R @ local[3:], rtol=0, atol=1e-14)
        np.testing.assert_array_equal(reference.jacobian(q), aligned)
        np.testing.assert_array_equal(reference.jacobian(q, frame="tool0"), aligned)


def test_unknown_convention_is_an_error() -> None:
    """A misspelt reference frame raises InputError listing the three conventions."""
    reference = dhkin.load("ur5").reference()
    with pytest.raises(dhkin.InputError, match=r"reference: expected one of \['local', 'world'"):
        reference.jacobian(np.zeros(6), reference="global")  # type: ignore[arg-type]


@pytest.mark.parametrize(("robot_name", "urdf_name"),
                         [("ur5", None), (str(DATA / "custom_arm_modified.yaml"), None),
                          ("ur3", "ur3.urdf")],
                         ids=["ur5", "custom_arm_modified", "ur3-vendor"])
def test_jacobian_relative_to_a_base_frame(robot_name: str, urdf_name: str | None) -> None:
    """With Reference(base=...), fk is relative to that frame and so are the WORLD and
    LOCAL_WORLD_ALIGNED Jacobians (UR: base = base_link turned 180 deg; the custom arm's base is
    shifted and tilted; the vendor UR3 has a continuous wrist_3_joint, nq = 7, nv = 6)."""
    robot = dhkin.load(robot_name)
    text = robot.urdf() if urdf_name is None else (REFERENCE_URDFS / urdf_name).read_text("utf-8")
    reference = Reference(text, tip="tool0", base="base")
    for q in samples(robot, 10):
        expected = finite_difference_jacobians(reference, q, None)
        for convention in CONVENTIONS:
            J = reference.jacobian(q, reference=convention)
            np.testing.assert_allclose(J, expected[convention], rtol=0, atol=FD_TOLERANCE,
                                       err_msg=convention)


def test_vendor_urdf_with_continuous_joint_jacobian_in_chain_order() -> None:
    """The vendor UR3 (continuous wrist_3_joint: Pinocchio nq = 7, nv = 6) gives 6 columns in
    chain order that match finite differences and, to the vendor's 1e-9 rounding, our UR3."""
    path = REFERENCE_URDFS / "ur3.urdf"
    vendor = Reference(path.read_text(encoding="utf-8"), tip="tool0", source=str(path))
    assert (vendor.model.nq, vendor.model.nv, vendor.dof) == (7, 6, 6)
    ours = dhkin.load("ur3").reference()
    for q in samples(dhkin.load("ur3"), 20):
        expected = finite_difference_jacobians(vendor, q, None)
        for convention in CONVENTIONS:
            J = vendor.jacobian(q, reference=convention)
            np.testing.assert_allclose(J, expected[convention], rtol=0, atol=FD_TOLERANCE)
            np.testing.assert_allclose(J, ours.jacobian(q, reference=convention), rtol=0,
                                       atol=2e-9)


# --------------------------------------------------------------------------------------------
# Manipulability


@pytest.mark.parametrize("name", SIX_AXIS)
def test_manipulability_measures(name: str) -> None:
    """For a 6-axis arm at random q: yoshikawa = |det J| (LOCAL_WORLD_ALIGNED, and LOCAL: the
    determinant does not depend on the axes), translational = sqrt(det(Jv Jv^T)), rotational =
    sqrt(det(Jw Jw^T)), singular values descending, sigma_min the smallest, condition
    sigma_max / sigma_min."""
    robot = dhkin.load(name)
    reference = robot.reference()
    for q in samples(robot, 100)[2:]:
        m = reference.manipulability(q)
        J = reference.jacobian(q)
        Jv, Jw = J[:3], J[3:]
        assert m.yoshikawa == pytest.approx(abs(np.linalg.det(J)), rel=1e-9, abs=1e-15)
        local_det = abs(np.linalg.det(reference.jacobian(q, reference="local")))
        assert m.yoshikawa == pytest.approx(local_det, rel=1e-9, abs=1e-15)
        assert m.translational == pytest.approx(math.sqrt(abs(np.linalg.det(Jv @ Jv.T))),
                                                rel=1e-9, abs=1e-15)
        assert m.rotational == pytest.approx(math.sqrt(abs(np.linalg.det(Jw @ Jw.T))),
                                             rel=1e-9, abs=1e-15)
        sigma = np.linalg.svd(J, compute_uv=False)
        assert m.singular_values.shape == (6,)
        assert np.all(np.diff(m.singular_values) <= 0)
        np.testing.assert_allclose(m.singular_values, sigma, rtol=1e-12, atol=1e-15)
        assert m.sigma_min == pytest.approx(sigma.min(), rel=1e-12)
        assert m.condition == pytest.approx(sigma.max() / sigma.min(), rel=1e-9)


def _irb_shoulder_q2() -> float:
    """q2 (q3 = 0) that puts the IRB 1200's wrist centre on axis 1: with theta2 = q2 - 90 deg the
    centre's distance from the axis is (a2 + a3) cos(theta2) - d4 sin(theta2) = 0."""
    table = dhkin.load("abb_irb1200_7_70").table
    a2, a3, d4 = table.joints[1].a, table.joints[2].a, table.joints[3].d
    return math.atan2(a2 + a3, d4) + math.pi / 2


#: (robot, a singular q, the joint whose 0.2 rad move leaves the singularity, what kind it is)
SINGULAR = [
    ("abb_irb1200_7_70", [0.3, 0.2, -0.4, 1.0, 0.0, 0.5], 4, "wrist: q5 = 0, axes 4 and 6 align"),
    ("abb_irb1200_7_70", [0.3, 0.2, -math.atan2(0.351, 0.042), 1.0, 0.7, 0.5], 2,
     "elbow: q3 = -atan(d4 / a3), arm stretched"),
    ("abb_irb1200_7_70", [0.3, _irb_shoulder_q2(), 0.0, 1.0, 0.7, 0.5], 1,
     "shoulder: wrist centre on axis 1"),
    ("ur5", [0.3, -1.2, 1.0, 0.4, 0.0, 0.5], 4, "wrist: q5 = 0, axes 4 and 6 parallel"),
    ("ur5", [0.3, -1.2, 0.0, 0.4, 0.9, 0.5], 2, "elbow: q3 = 0, arm stretched"),
    ("ur10", [-2.0, 0.7, 0.0, -1.1, 0.4, 2.5], 2, "elbow: q3 = 0, arm stretched"),
    ("aubo_i10", [0.3, -0.5, 1.0, 0.4, 0.0, 0.5], 4, "wrist: q5 = 0"),
    ("stanford_arm", [0.3, 0.5, 0.6, 0.4, 0.0, 0.5], 4, "wrist: q5 = 0, axes 4 and 6 align"),
    ("anthropomorphic_arm", [0.3, 0.5, 0.6, 0.4, 0.0, 0.5], 4, "wrist: q5 = 0"),
]


@pytest.mark.parametrize(("name", "q", "joint", "kind"), SINGULAR,
                         ids=[f"{s[0]}-{s[3].split(':')[0]}" for s in SINGULAR])
def test_known_singular_configuration(name: str, q: list[float], joint: int, kind: str) -> None:
    """At a known singularity sigma_min ~ 0, yoshikawa ~ 0 and the condition number explodes;
    0.2 rad away along one joint the arm is well conditioned again."""
    reference = dhkin.load(name).reference()
    m = reference.manipulability(np.array(q))
    assert m.sigma_min <= 1e-12 * m.singular_values[0], kind
    assert m.yoshikawa <= 1e-12, kind
    assert m.condition >= 1e12, kind
    away = np.array(q)
    away[joint] += 0.2
    m_away = reference.manipulability(away)
    assert m_away.sigma_min >= 1e-3, kind
    assert m_away.condition <= 1e4, kind


def test_irb_shoulder_singularity_puts_the_wrist_centre_on_axis_1() -> None:
    """The shoulder-singular q of SINGULAR really has the wrist centre (link_5) on axis 1."""
    reference = dhkin.load("abb_irb1200_7_70").reference()
    centre = reference.fk(np.array([0.3, _irb_shoulder_q2(), 0.0, 1.0, 0.7, 0.5]), frame="link_5")
    assert math.hypot(centre[0, 3], centre[1, 3]) <= 1e-15


def _batch_references() -> list[tuple[str, Reference]]:
    """A generated URDF (configuration = joint vector), the same chain from a base link in its
    middle, and one with continuous joints (Pinocchio stores cos, sin)."""
    ur5 = dhkin.load("ur5").urdf()
    planar = dhkin.load("planar_2r").urdf().replace('type="revolute"', 'type="continuous"')
    return [("ur5", Reference(ur5)),
            ("ur5 from upper_arm_link", Reference(ur5, base="upper_arm_link")),
            ("continuous 2R", Reference(planar))]


@pytest.mark.parametrize(("label", "reference"), _batch_references(),
                         ids=lambda value: value if isinstance(value, str) else "")
def test_batch_configurations_and_jacobians_equal_the_single_ones(label: str,
                                                                  reference: Reference) -> None:
    """configurations(Q) and jacobians(Q) equal configuration(q) and jacobian(q) row by row, bit
    for bit, in each convention; a bad batch is refused as a whole, naming its shape or values."""
    rng = np.random.default_rng(zlib.crc32(label.encode()))
    Q = rng.uniform(-math.pi, math.pi, (50, reference.dof))
    Q[0] = 0.0
    Q[1] = np.resize([math.pi / 2, -math.pi / 2, math.pi], reference.dof)
    configs = reference.configurations(Q)
    assert configs.shape == (50, reference.model.nq)
    for q, config in zip(Q, configs, strict=True):
        np.testing.assert_array_equal(config, reference.configuration(q))
    for convention in CONVENTIONS:
        batch = reference.jacobians(Q, reference=convention)
        assert batch.shape == (50, 6, reference.dof)
        for q, J in zip(Q, batch, strict=True):
            np.testing.assert_array_equal(J, reference.jacobian(q, reference=convention))
    np.testing.assert_array_equal(reference.configurations(Q[3]), configs[3:4])
    bad = Q.copy()
    bad[7, -1] = np.nan
    with pytest.raises(dhkin.InputError, match="finite"):
        reference.jacobians(bad)
    with pytest.raises(dhkin.InputError, match=r"shape"):
        reference.configurations(Q[:, :-1])
    with pytest.raises(dhkin.InputError, match="reference: expected one of"):
        reference.jacobians(Q, reference="global")  # type: ignore[arg-type]
