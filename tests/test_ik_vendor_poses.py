"""IK of poses made by the vendors' own URDFs, checked on those URDFs (issue "IK core v2").

Targets come from Pinocchio on ``robots/vendor`` (never from our own FK: a pose made by our
model is the one pose a bug in our model cannot miss), and every returned solution is put back
through the vendor's URDF. The IK is seeded with the sampled q.

* Exact-family tables (UR3, UR5, UR10, UR5e, IRB 1200): 10^4 random poses, and 10^3 each at
  q5 = 0, |q5| in [1e-12, 1e-6], special angles (0, +-pi/2, pi; q3 = 0 stretched elbows among
  them) and shoulder-singular poses (the wrist centre on axis 1 for the IRB 1200; the wrist
  point in the plane of axis 1 and n for the UR family). The UR vendor files write pi/2 as
  1.570796327, so their poses are ~2e-10 off our model's singular sets.
* Refined tables (TM5-900 and Kinova Gen3 with the vendors' rounded constants as corrections,
  the calibrated UR5e as nominal + corrections): 10^4 random poses.

Checked: every returned solution exact to 1e-9 on the vendor URDF, plus the vendor model's
measured deviation from the table's (UR: 6.2e-10 rad, the rounded pi/2; the others ~1e-15): the
IK verifies on the table's model, and at q5 = 0 the seed's choice may use the whole tolerance
there (measured: at most 9.4e-10 on our model, 1.05e-9 on UR5's URDF); the sampled q among the
solutions (mod 2pi) to 1e-6 rad, or to (vendor-vs-table deviation + residual) / sigma_min near
a singularity, where the pose fixes the joints no better; the answer at q5 = 0 flagged "wrist";
with the seed moved by +-0.05 rad on every joint, the solution nearest the seed within 0.25 rad
of it on every joint.
"""

from __future__ import annotations

import numpy as np
import pytest

import dhkin
from dhkin.ik import IKSolutions
from dhkin.ik.core import FLAG_BAND
from dhkin.ik.geometry import joint_axes
from dhkin.reference import Reference
from dhkin.transforms import pose_error
from dhkin.vendors import VENDOR_REFERENCES

from .conftest import REFERENCE_URDFS, oracle_sigma_min

TOLERANCE = 1e-9
JOINT_TOLERANCE = 1e-6
RANDOM = 10_000
SINGULAR = 1_000
PERTURBATION = 0.05
CONTINUITY = 0.25
EXACT_TABLES = ["ur3", "ur5", "ur10", "ur5e", "abb_irb1200_7_70",
                # imported from their vendor URDFs (scripts/import_vendor_tables.py)
                "kuka_kr6r900sixx", "fanuc_m10ia", "motoman_gp7", "staubli_tx2_60"]
REFINED_TABLES = ["tm5_900", "kinova_gen3_6dof", "ur5e_calibrated"]
SPECIAL_ANGLES = np.array([0.0, np.pi / 2, -np.pi / 2, np.pi])


def vendor(name: str) -> Reference:
    listed = VENDOR_REFERENCES[name]
    path = REFERENCE_URDFS / listed.file
    return Reference(path.read_text(encoding="utf-8"), tip=listed.tip, base=listed.base,
                     source=str(path))


def wrapped(difference: np.ndarray) -> np.ndarray:
    return np.mod(difference + np.pi, 2.0 * np.pi) - np.pi


class Run:
    """Solve and check one set of vendor poses; collects the figures the tests print."""

    def __init__(self, robot: dhkin.Robot, reference: Reference) -> None:
        self.robot, self.reference = robot, reference
        self.worst = 0.0
        self.deviation = 0.0  # largest pose difference between the vendor model and ours
        self.missing: list[tuple[np.ndarray, float]] = []
        self.discontinuous: list[tuple[np.ndarray, float]] = []
        self.unflagged: list[np.ndarray] = []
        self.empty: list[np.ndarray] = []

    def check(self, q: np.ndarray, wrist_singular: bool = False,
              continuity: bool = False, seed: int = 0, nudge: float = 0.0) -> None:
        """Solve the vendor's FK of q (moved by ``nudge`` metres in a random direction: a pose
        known to its source's rounding), seeded with q and, for ``continuity``, with q moved."""
        T = self.reference.fk(q)
        if nudge:
            directions = np.random.default_rng(seed).normal(size=(len(q), 3))
            T[:, :3, 3] += nudge * directions / np.linalg.norm(directions, axis=1)[:, None]
        position, rotation = pose_error(T, self.robot.reference().fk(q))
        self.deviation = max(self.deviation, float(position.max()), float(rotation.max()))
        rng = np.random.default_rng(seed)
        answered: list[int] = []
        found: list[IKSolutions] = []
        for k in range(len(q)):
            solutions = self.robot.ik(T[k], q_seed=q[k])
            if not len(solutions):
                self.empty.append(q[k])
                continue
            answered.append(k)
            found.append(solutions)
            if continuity:
                moved = q[k] + PERTURBATION * rng.choice([-1.0, 1.0], size=len(q[k]))
                moved = np.clip(moved, self.robot.lower, self.robot.upper)
                again = self.robot.ik(T[k], q_seed=moved)
                gap = (np.abs(wrapped(again.q - moved)).max(axis=1).min() if len(again)
                       else np.inf)
                if gap > CONTINUITY:
                    self.discontinuous.append((q[k], float(gap)))
        if not answered:
            return
        # The solutions of every pose at once (the same numbers, row by row, as pose by pose):
        # through the vendor's URDF in one call (Pinocchio still runs once per row), each pose's
        # residual the largest error of its own rows, its distance to q the smallest of them.
        counts = np.array([len(solutions) for solutions in found])
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        rows = np.concatenate([solutions.q for solutions in found])
        position, rotation = pose_error(self.reference.fk(rows),
                                        np.repeat(T[answered], counts, axis=0))
        residuals = np.maximum(np.maximum.reduceat(position, starts),
                               np.maximum.reduceat(rotation, starts))
        self.worst = max(self.worst, float(residuals.max()))
        distances = np.abs(wrapped(rows - np.repeat(q[answered], counts, axis=0))).max(axis=1)
        nearest = np.minimum.reduceat(distances, starts)
        for i in np.flatnonzero(nearest > JOINT_TOLERANCE):
            k = answered[i]
            sigma = self.robot.reference().manipulability(q[k]).sigma_min
            noise = max(TOLERANCE, residuals[i])  # vendor deviation (<= 6.2e-10) and residual
            if nearest[i] > JOINT_TOLERANCE + noise / max(sigma, 1e-300):
                self.missing.append((q[k], float(nearest[i])))
        if wrist_singular:  # the nearest solution (the first of equals) is flagged "wrist"
            for i, k in enumerate(answered):
                best = int(np.argmin(distances[starts[i]:starts[i] + counts[i]]))
                if "wrist" not in found[i].flags[best]:
                    self.unflagged.append(q[k])

    def assert_clean(self, label: str) -> None:
        print(f"\n{label}: max residual on the vendor URDF {self.worst:.2e} (vendor model vs "
              f"ours {self.deviation:.1e})")
        assert self.worst <= TOLERANCE + self.deviation
        assert not self.empty, f"{len(self.empty)} empty answers, e.g. q = {self.empty[0]}"
        assert not self.missing, (f"{len(self.missing)} poses without the sampled q, e.g. "
                                  f"{self.missing[0]}")
        assert not self.unflagged, f"{len(self.unflagged)} unflagged, e.g. {self.unflagged[0]}"
        assert not self.discontinuous, (f"{len(self.discontinuous)} discontinuous, e.g. "
                                        f"{self.discontinuous[0]}")


def special_q(robot: dhkin.Robot, n: int, rng: np.random.Generator) -> np.ndarray:
    q = robot.table.random_q(n, rng)
    for j in range(robot.dof):
        inside = SPECIAL_ANGLES[(robot.lower[j] <= SPECIAL_ANGLES)
                                & (robot.upper[j] >= SPECIAL_ANGLES)]
        q[:, j] = rng.choice(inside, size=n)
    q[: n // 4, 2] = 0.0  # stretched elbows on purpose (UR: q3 = 0)
    return q


def shoulder_singular_q(robot: dhkin.Robot, n: int, rng: np.random.Generator) -> np.ndarray:
    """Joint vectors where the two shoulder branches meet: q2 solved (bisection on Pinocchio's
    model) so that the wrist centre (IRB 1200: on axis 1) or the wrist point (UR: in the plane of
    axis 1 and the common direction of axes 2-4) has no reach left across axis 1.

    The candidates are drawn one at a time (the generator's draws as ever), each one's grid of q2
    goes through Pinocchio as one batch, and the accepted ones are bisected together, row by row
    the same steps (the sign at ``low`` never changes: ``low`` only moves to a point of its sign).
    """
    reference = robot.reference()
    spherical = robot.ik_solver.family == "spherical_wrist"
    frame = robot.table.joints[4].link  # DH frame 5: the wrist centre (spherical) or point

    def reach(rows: np.ndarray) -> np.ndarray:
        T = reference.fk(rows, frame=frame)
        cosine, sine = np.cos(rows[:, 0]), np.sin(rows[:, 0])
        if spherical:  # signed distance of the wrist centre from axis 1 along x of the arm
            return cosine * T[:, 0, 3] + sine * T[:, 1, 3]
        # UR: the wrist point's component along the reach direction (axis 1 x n), the heading
        # (cos q1, sin q1, 0); summed in the order of a dot product
        return T[:, 0, 3] * cosine + T[:, 1, 3] * sine + T[:, 2, 3] * 0.0

    def with_q2(rows: np.ndarray, q2: np.ndarray) -> np.ndarray:
        rows = rows.copy()
        rows[:, 1] = q2
        return rows

    grid = np.linspace(robot.lower[1], robot.upper[1], 49)
    out, lows, highs = [], [], []
    while len(out) < n:
        q = robot.table.random_q(1, rng)[0]
        values = reach(with_q2(np.repeat(q[None], len(grid), axis=0), grid))
        changes = np.flatnonzero(np.sign(values[1:]) != np.sign(values[:-1]))
        if not changes.size:
            continue
        lows.append(grid[changes[0]])
        highs.append(grid[changes[0] + 1])
        out.append(q)
    q, low, high = np.array(out), np.array(lows), np.array(highs)
    sign_at_low = np.sign(reach(with_q2(q, low)))
    for _ in range(100):
        middle = 0.5 * (low + high)
        same = np.sign(reach(with_q2(q, middle))) == sign_at_low
        low, high = np.where(same, middle, low), np.where(same, high, middle)
    q[:, 1] = 0.5 * (low + high)
    return q


@pytest.fixture(scope="module", params=EXACT_TABLES)
def exact_robot(request: pytest.FixtureRequest) -> tuple[dhkin.Robot, Reference]:
    robot = dhkin.load(request.param)
    assert not robot.ik_solver.fit.refine
    return robot, vendor(request.param)


def test_random_vendor_poses(exact_robot) -> None:
    robot, reference = exact_robot
    run = Run(robot, reference)
    run.check(robot.table.random_q(RANDOM, np.random.default_rng(101)))
    run.assert_clean(f"{robot.name}: {RANDOM} random vendor poses")


def test_vendor_poses_at_q5_zero_are_flagged_and_follow_the_seed(exact_robot) -> None:
    robot, reference = exact_robot
    rng = np.random.default_rng(102)
    q = robot.table.random_q(SINGULAR, rng)
    q[:, 4] = 0.0
    run = Run(robot, reference)
    run.check(q, wrist_singular=True, continuity=True, seed=1)
    run.assert_clean(f"{robot.name}: {SINGULAR} vendor poses at q5 = 0")


def test_vendor_poses_near_q5_zero(exact_robot) -> None:
    robot, reference = exact_robot
    rng = np.random.default_rng(103)
    q = robot.table.random_q(SINGULAR, rng)
    q[:, 4] = rng.choice([-1.0, 1.0], SINGULAR) * 10.0 ** rng.uniform(-12, -6, SINGULAR)
    run = Run(robot, reference)
    run.check(q, wrist_singular=True, continuity=True, seed=2)
    run.assert_clean(f"{robot.name}: {SINGULAR} vendor poses with |q5| in [1e-12, 1e-6]")


#: A FANUC M-10iA vendor pose at the elbow and the wrist singularity at once (sigma_min 1e-16):
#: the stretched elbow amplifies the pose's rounding, so the closed form's q5 comes out 5e-6 for
#: a q5 of 1e-12; the wrist's seed band widens by that much (spherical.hpp, elbow_uncertainty).
DOUBLE_SINGULAR_POSE = np.array([-1.06202807e+00, 1.38856209e+00, -1.87368177e+00,
                                 -2.00174982e+00, -1.38232808e-12, 5.06322454e-01])
#: How far (m) the double-singular targets are moved: a rounded description's pose error (the
#: 10-digit URDFs: ~1e-10), so that the stretched elbow's amplification shows (q5 ~ sqrt(1e-11))
NUDGE = 1e-11
SPHERICAL_TABLES = ["abb_irb1200_7_70", "kuka_kr6r900sixx", "fanuc_m10ia", "motoman_gp7",
                    "staubli_tx2_60"]


def test_double_singular_pose_keeps_the_seeds_wrist_split() -> None:
    robot = dhkin.load("fanuc_m10ia")
    run = Run(robot, vendor("fanuc_m10ia"))
    run.check(DOUBLE_SINGULAR_POSE[None, :], wrist_singular=True, continuity=True, seed=2)
    run.assert_clean("fanuc_m10ia: the elbow- and wrist-singular vendor pose")


def elbow_and_wrist_singular_q(robot: dhkin.Robot, n: int,
                               rng: np.random.Generator) -> np.ndarray:
    """Joint vectors of a spherical-wrist arm at the elbow and the wrist singularity at once: q3
    stretches or folds the arm (the wrist centre's distance from axis 2 at an extreme: with axis 3
    parallel to axis 2 its square is A + B cos(q3 - phi), solved from three values of q3) and q5
    is 0 (half of them) or +-10^u, u uniform in [-12, -6]."""
    out: list[np.ndarray] = []
    while len(out) < n:
        q = robot.table.random_q(1, rng)[0]
        trial = np.repeat(q[None], 3, axis=0)
        trial[:, 2] = [0.0, 2 * np.pi / 3, 4 * np.pi / 3]
        points, directions = joint_axes(robot.table, trial)
        squares = []
        for k in range(3):  # the wrist centre: where axes 4 and 5 meet
            centre = closest_point(points[k, 3], directions[k, 3], points[k, 4], directions[k, 4])
            across = np.cross(centre - points[k, 1], directions[k, 1])
            squares.append(float(across @ across))
        # squares[k] = A + c cos(t_k) + s sin(t_k)
        system = np.array([[1.0, np.cos(t), np.sin(t)] for t in trial[:, 2]])
        _, c, s = np.linalg.solve(system, np.array(squares))
        q[2] = np.arctan2(s, c) + rng.choice([0.0, np.pi])  # stretched or folded
        q[2] = (q[2] + np.pi) % (2 * np.pi) - np.pi
        if not robot.lower[2] <= q[2] <= robot.upper[2]:
            continue
        q[4] = 0.0 if len(out) % 2 else rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-12, -6)
        out.append(q)
    return np.array(out)


def closest_point(point: np.ndarray, direction: np.ndarray, other: np.ndarray,
                  other_direction: np.ndarray) -> np.ndarray:
    """The point of line (point, direction) nearest line (other, other_direction)."""
    normal = np.cross(direction, other_direction)
    t = np.cross(other - point, other_direction) @ normal / (normal @ normal)
    return point + t * direction


def double_singular_run(name: str, nudge: float) -> Run:
    robot = dhkin.load(name)
    assert robot.ik_solver.family == "spherical_wrist"
    q = elbow_and_wrist_singular_q(robot, 200, np.random.default_rng(106))
    sigma = oracle_sigma_min(robot.reference(), q)
    assert np.median(sigma) < 1e-5  # both singular sets on purpose
    run = Run(robot, vendor(name))
    run.check(q, wrist_singular=True, continuity=True, seed=6, nudge=nudge)
    return run


@pytest.mark.parametrize("name", SPHERICAL_TABLES)
def test_vendor_poses_at_the_elbow_and_the_wrist_singularity(name: str) -> None:
    run = double_singular_run(name, 0.0)
    run.assert_clean(f"{name}: 200 vendor poses at the elbow and the wrist singularity")


@pytest.mark.parametrize("name", SPHERICAL_TABLES)
def test_nudged_poses_at_the_elbow_and_the_wrist_singularity(name: str) -> None:
    run = double_singular_run(name, NUDGE)
    run.assert_clean(f"{name}: 200 vendor poses at the elbow and the wrist singularity, "
                     f"moved by {NUDGE:g} m")


@pytest.mark.parametrize("name", ["abb_irb1200_7_70", "fanuc_m10ia"])
def test_nudged_double_singular_poses_at_the_wrist_bands_edge(name: str) -> None:
    """The widened wrist band at the edge of the seed band (exact tables: the flag band): the
    nudged double-singular targets with |q5| = half the band keep the seed's q4 / q6 split,
    flagged (the arm at its stretched or folded elbow leaves the wrist within the band); with
    |q5| = twice the band the wrist is regular there: the sampled q comes back, unflagged."""
    robot = dhkin.load(name)
    q = elbow_and_wrist_singular_q(robot, 50, np.random.default_rng(108))
    signs = np.random.default_rng(109).choice([-1.0, 1.0], len(q))
    inside, outside = Run(robot, vendor(name)), Run(robot, vendor(name))
    q[:, 4] = 0.5 * FLAG_BAND * signs
    inside.check(q, wrist_singular=True, continuity=True, seed=7, nudge=NUDGE)
    inside.assert_clean(f"{name}: 50 nudged double-singular poses, |q5| half the band")
    q[:, 4] = 2.0 * FLAG_BAND * signs
    outside.check(q, seed=7, nudge=NUDGE)
    outside.assert_clean(f"{name}: 50 nudged double-singular poses, |q5| twice the band")
    T = vendor(name).fk(q)
    directions = np.random.default_rng(7).normal(size=(len(q), 3))
    T[:, :3, 3] += NUDGE * directions / np.linalg.norm(directions, axis=1)[:, None]
    for k in range(len(q)):
        solutions = robot.ik(T[k], q_seed=q[k])
        nearest = int(np.argmin(np.abs(wrapped(solutions.q - q[k])).max(axis=1)))
        assert "wrist" not in solutions.flags[nearest], q[k]


def test_vendor_poses_at_special_angles(exact_robot) -> None:
    robot, reference = exact_robot
    q = special_q(robot, SINGULAR, np.random.default_rng(104))
    run = Run(robot, reference)
    run.check(q, continuity=True, seed=3)
    run.assert_clean(f"{robot.name}: {SINGULAR} vendor poses at special angles")


def test_vendor_poses_at_the_shoulder_singularity(exact_robot) -> None:
    robot, reference = exact_robot
    q = shoulder_singular_q(robot, 200, np.random.default_rng(105))
    run = Run(robot, reference)
    run.check(q, continuity=True, seed=4)
    run.assert_clean(f"{robot.name}: 200 shoulder-singular vendor poses")


def test_the_issues_examples() -> None:
    """The poses of the issue: UR3 at q5 = 0 (q4/q6 once came back 0.87 rad from the seed,
    unflagged) and UR5 poses once answered empty (stretched arm at q5 = 0; wrist point at the
    shoulder boundary with q5 = pi)."""
    ur3 = dhkin.load("ur3")
    q = np.array([2.013345, 1.175705, 2.885498, 3.653452, 0.0, 2.352991])
    solutions = ur3.ik(vendor("ur3").fk(q), q_seed=q)
    distance = np.abs(wrapped(solutions.q - q)).max(axis=1)
    assert distance.min() <= JOINT_TOLERANCE
    assert "wrist" in solutions.flags[int(np.argmin(distance))]
    ur5 = dhkin.load("ur5")
    for q in (np.array([np.pi / 2, np.pi, 0, -np.pi / 2, 0, np.pi / 2]),
              np.array([np.pi, np.pi / 2, 0, np.pi / 2, np.pi, 0])):
        solutions = ur5.ik(vendor("ur5").fk(q), q_seed=q)
        assert len(solutions), solutions.reason
        assert np.abs(wrapped(solutions.q - q)).max(axis=1).min() <= JOINT_TOLERANCE


@pytest.mark.parametrize("name", REFINED_TABLES)
def test_refined_tables_on_random_vendor_poses(name: str) -> None:
    """Real descriptions as nominal + corrections: a closed-form family, not the numerical
    fallback; every branch refined on the exact chain."""
    robot = dhkin.load(name)
    assert robot.has_closed_form and robot.ik_solver.fit.refine
    run = Run(robot, vendor(name))
    run.check(robot.table.random_q(RANDOM, np.random.default_rng(106)))
    run.assert_clean(f"{name}: {RANDOM} random vendor poses")


@pytest.mark.parametrize("name", REFINED_TABLES)
def test_refined_tables_near_the_wrist_singularity(name: str) -> None:
    """q5 = 0 and |q5| in [1e-12, 1e-6] on the vendor's model: the exact chain is a hair from
    singular there (its roots are isolated, q4 and q6 no longer free) and has roots the ideal
    model lacks; the sampled q comes back, flagged "wrist", and with the seed moved by +-0.05 rad
    the nearest solution stays within 0.25 rad of it (the Kinova Gen3 once jumped 0.4-1 rad)."""
    robot = dhkin.load(name)
    rng = np.random.default_rng(107)
    for label, q5 in (("q5 = 0", np.zeros(SINGULAR)),
                      ("|q5| in [1e-12, 1e-6]", rng.choice([-1.0, 1.0], SINGULAR)
                       * 10.0 ** rng.uniform(-12, -6, SINGULAR))):
        q = robot.table.random_q(SINGULAR, rng)
        q[:, 4] = q5
        run = Run(robot, vendor(name))
        run.check(q, wrist_singular=True, continuity=True, seed=5)
        run.assert_clean(f"{name}: {SINGULAR} vendor poses at {label}")
