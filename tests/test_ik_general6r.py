"""The general 6R solver (dhkin.ik.general6r): every solution of arms outside the families.

Targets come from Pinocchio on the generated URDF (the oracle); every returned solution is
checked there at the verification tolerance. Sizes are CI-friendly; scripts/check_general6r.py
runs the issue's full sizes.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import dhkin
from dhkin.dh import DHTable, Joint
from dhkin.ik.general6r import General6RSolver
from dhkin.ik.general6r_arrangement import wrap as _wrap
from dhkin.robot import Robot
from dhkin.tolerances import DEFAULT_TOLERANCE

SPECIAL = np.array([0.0, math.pi / 2, -math.pi / 2, math.pi])


def ur5_tilted() -> Robot:
    """The UR5 with joint 2's alpha tilted by 10 degrees (no family fits)."""
    table = dhkin.load("ur5").table
    joints = list(table.joints)
    joints[1] = replace(joints[1], alpha=joints[1].alpha + math.radians(10.0))
    return Robot(replace(table, name="ur5_tilted", joints=tuple(joints)))


def random_table(rng: np.random.Generator, index: int) -> DHTable:
    """A random 6R table: lengths 0.05-1 m, alphas uniform, offsets random, limits +-2pi."""
    joints = tuple(Joint(name=f"joint_{i + 1}", link=f"link_{i + 1}", type="revolute",
                         a=rng.uniform(0.05, 1.0), alpha=rng.uniform(-math.pi, math.pi),
                         d=rng.uniform(0.05, 1.0) * rng.choice([-1.0, 1.0]), theta=0.0,
                         offset=rng.uniform(-math.pi, math.pi), direction=1,
                         lower=-2 * math.pi, upper=2 * math.pi, velocity=1.0, effort=1.0)
                   for i in range(6))
    return DHTable(name=f"random_{index}", convention="standard", joints=joints)


def pose_errors(T: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and rotation angle (rad) of T against targets, (N,) each."""
    position = np.linalg.norm(T[:, :3, 3] - targets[:, :3, 3], axis=1)
    E = np.einsum("nji,njk->nik", T[:, :3, :3], targets[:, :3, :3])
    cos = np.clip((np.trace(E, axis1=1, axis2=2) - 1) / 2, -1, 1)
    skew = np.stack([E[:, 2, 1] - E[:, 1, 2], E[:, 0, 2] - E[:, 2, 0],
                     E[:, 1, 0] - E[:, 0, 1]], axis=1)
    return position, np.arctan2(np.linalg.norm(skew, axis=1) / 2, cos)


#: Two solutions are the same when every joint agrees within this (rad), mod 2pi.
SAME = 1e-6


def same_solution_sets(reference: object, T: np.ndarray, first: np.ndarray,
                       second: np.ndarray, tolerance: float = DEFAULT_TOLERANCE) -> bool:
    """Whether two solution sets (k, 6) of the pose T are the same, mod 2pi: every solution of
    each is within SAME of one of the other, or is one root with its nearest there at the
    tolerance: the segment between them verifies on the oracle (``reference``: its ``fk``) at
    its midpoint and quarter points. That is the solvers' own merging rule (two roots are one
    when their midpoint verifies): on a fold a double root splits, by rounding, into two
    verified joint vectors up to ~sqrt(tolerance / curvature) apart (3e-5 rad at 1e-9), all
    between them verifying too; one solver may return both, the other their merge."""
    if len(first) == 0 or len(second) == 0:
        return len(first) == len(second)
    d = np.abs(_wrap(first[:, None, :] - second[None, :, :])).max(axis=2)

    def covered(a: np.ndarray, b: np.ndarray, distance: np.ndarray) -> bool:
        for i in range(len(a)):
            j = int(np.argmin(distance[i]))
            if distance[i, j] < SAME:
                continue
            step = _wrap(b[j] - a[i])
            points = a[i] + np.outer([0.25, 0.5, 0.75], step)
            targets = np.repeat(np.asarray(T)[None], 3, axis=0)
            position, rotation = pose_errors(reference.fk(points), targets)  # type: ignore[attr-defined]
            if np.any(position > tolerance) or np.any(rotation > tolerance):
                return False
        return True

    return covered(first, second, d) and covered(second, first, d.T)


def run(robot: Robot, Q: np.ndarray, seeded: bool = True) -> tuple[int, float, int]:
    """Solve the Pinocchio poses of Q: (poses whose q came back, worst oracle error, total
    solutions); asserts every solution verifies on the oracle."""
    solver = General6RSolver(robot.table)
    reference = robot.reference()
    targets = reference.fk(Q)
    recovered, worst, total = 0, 0.0, 0
    for q, T in zip(Q, targets, strict=True):
        result = solver.solve_one(T, q if seeded else None)
        total += len(result)
        if len(result) == 0:
            continue
        position, rotation = pose_errors(reference.fk(result.q), np.repeat(T[None], len(result),
                                                                            axis=0))
        worst = max(worst, float(position.max()), float(rotation.max()))
        if np.min(np.max(np.abs(_wrap(result.q - q)), axis=1)) < 1e-6:
            recovered += 1
    return recovered, worst, total


@pytest.mark.parametrize("name", ["fanuc_crx10ia", "xarm6", "ur5_tilted"])
def test_arms_outside_the_families(name: str) -> None:
    robot = ur5_tilted() if name == "ur5_tilted" else dhkin.load(name)
    Q = robot.table.random_q(300, np.random.default_rng(16))
    # unseeded: a seed near the pose is a Newton start and would return q by itself
    recovered, worst, _ = run(robot, Q, seeded=False)
    assert worst <= DEFAULT_TOLERANCE
    assert recovered == len(Q)


@pytest.mark.parametrize("name", ["fanuc_crx10ia", "xarm6", "ur5_tilted"])
def test_special_angles_give_no_wrong_solution(name: str) -> None:
    robot = ur5_tilted() if name == "ur5_tilted" else dhkin.load(name)
    rng = np.random.default_rng(17)
    Q = SPECIAL[rng.integers(0, 4, size=(100, 6))]
    Q = np.clip(Q, robot.lower, robot.upper)
    _, worst, _ = run(robot, Q, seeded=False)
    assert worst <= DEFAULT_TOLERANCE


def test_random_tables_counts_even_and_complete() -> None:
    rng = np.random.default_rng(1616)
    for index in range(8):
        table = random_table(rng, index)
        solver = General6RSolver(table)
        Q = rng.uniform(-math.pi, math.pi, size=(40, 6))
        for q in Q:
            T_dh = solver.target_dh(table.fk(q))
            roots, _, _ = solver.roots(T_dh, DEFAULT_TOLERANCE)
            assert roots.shape[0] % 2 == 0 and roots.shape[0] <= 16
            assert np.min(np.max(np.abs(_wrap(roots - q)), axis=1)) < 1e-6
        recovered, worst, _ = run(Robot(table), Q[:20], seeded=False)
        assert worst <= DEFAULT_TOLERANCE and recovered == 20


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70"])
def test_same_solutions_as_the_family_solver(name: str) -> None:
    robot = dhkin.load(name)
    solver = General6RSolver(robot.table)
    Q = robot.table.random_q(200, np.random.default_rng(18))
    for q, T in zip(Q, robot.fk(Q), strict=True):
        family = robot.ik(T, q)
        general = solver.solve_one(T, q)
        assert len(family) == len(general)
        a = np.array(sorted(map(tuple, np.round(_wrap(family.q), 6))))
        b = np.array(sorted(map(tuple, np.round(_wrap(general.q), 6))))
        assert np.max(np.abs(_wrap(a - b))) < 1e-5


#: Poses where the general solver differed from the family solvers (docs/general6r.md,
#: "Family comparison"): on the UR5 a singular root's walk towards the seed landed on a
#: distinct root (one returned twice, one missing); on the IRB 1200 at its elbow fold
#: (q3 ~ -1.4517) the family solver returns both halves of split double roots, the general
#: solver their merge.
FOLD_POSES = [
    ("ur5", [-3.252387982883345, -1.053639403215774, 0.07609505681789974, -0.9362144455129,
             7.089000885063257e-05, 6.1425375765005406]),
    ("ur5", [-1.238359335778073, 1.6294023632269043, 0.10909308489182123, 2.68424864631441,
             -0.08882898896787594, 0.2752394413102559]),
    ("ur5", [-5.679352429331699, 2.511709784806481, -1.7425258796991514, 4.804336919440017,
             -3.6192198717047104, -2.5668103471879857]),
    ("abb_irb1200_7_70", [1.6405603327216025, -0.8838010115632696, -1.4517135236099183,
                          -1.9563537897801755, -1.6895842917012456, 4.823492612891864]),
    ("abb_irb1200_7_70", [-0.8552602574261665, 0.00671795510482065, -1.4516857048649237,
                          1.5711474664358045, 0.007410945160732929, 4.858669102322916]),
]


@pytest.mark.parametrize(("name", "q"), FOLD_POSES)
def test_near_fold_poses_match_the_family_solver(name: str, q: list[float]) -> None:
    robot = dhkin.load(name)
    solver = General6RSolver(robot.table)
    reference = robot.reference()
    T = robot.fk(np.array(q))
    family, general = robot.ik(T, q), solver.solve_one(T, q)
    distinct = np.abs(_wrap(general.q[:, None, :] - general.q[None, :, :])).max(axis=2)
    assert np.all(distinct[~np.eye(len(general), dtype=bool)] >= SAME)  # no root twice
    assert same_solution_sets(reference, T, family.q, general.q)


# --------------------------------------------------------------------------------------------
# robot.ik: the general solver answers six-revolute arms without a family


def test_robot_ik_uses_the_general_solver() -> None:
    """CRX-10iA and xArm6 (no family): robot.ik, ik_batch and ik_batch_detailed answer with
    every solution (family "general6r", not numerical), the same pose by pose; rounded
    rotations are projected; a TCP is verified at the TCP; bad inputs raise InputError."""
    from dhkin.errors import InputError

    for name in ("fanuc_crx10ia", "xarm6"):
        robot = dhkin.load(name)
        assert robot.ik_family == "general6r" and robot.complete_ik and not robot.has_closed_form
        Q = robot.table.random_q(5, np.random.default_rng(19))
        targets = robot.fk(Q)
        batch = robot.ik_batch_detailed(targets, Q)
        for k, (q, T) in enumerate(zip(Q, targets, strict=True)):
            result = robot.ik(T, q)
            assert result.family == "general6r" and not result.numerical and len(result) >= 2
            assert np.abs(result.nearest(q) - q).max() <= 1e-6
            assert np.array_equal(batch.q[k, batch.valid[k]], result.q)
            rounded = np.round(T, 6)
            projected = robot.ik(rounded, q)
            assert projected.projection > 0 and len(projected) > 0
        tcp = np.eye(4)
        tcp[:3, 3] = [0.05, -0.02, 0.3]
        q = Q[0]
        result = robot.ik(robot.fk(q) @ tcp, q, tcp=tcp)
        position, rotation = pose_errors(robot.reference().fk(result.q) @ tcp,
                                         np.repeat((robot.fk(q) @ tcp)[None], len(result), 0))
        assert max(position.max(), rotation.max()) <= DEFAULT_TOLERANCE
        with pytest.raises(InputError, match="bottom row"):
            robot.ik(np.zeros((4, 4)))
        with pytest.raises(InputError, match="q_seed"):
            robot.ik(robot.fk(q), [0.0] * 5)
    far = np.eye(4)
    far[:3, 3] = [1.0, 0.0, 0.0]  # within the links' length (1.149 m), beyond the arm's reach
    empty = dhkin.load("xarm6").ik(far)
    assert len(empty) == 0 and "no real solution" in empty.reason


def _fold(robot: Robot, sigma: float) -> np.ndarray:
    """A joint vector of the CRX-10iA whose Jacobian's scaled smallest singular value is
    ``sigma`` (joint 2 moved towards a fold by bisection)."""
    solver = robot.general_solver
    assert solver is not None

    def measure(value: float) -> float:
        return solver.smallest_singular(np.array([0.3, value, 1.1, 0.2, 0.8, -0.5]))

    low, high = -0.2285349, 0.0  # the fold (sigma 0) lies at q2 = -0.228535 (measured)
    assert measure(low) < sigma < measure(high)
    for _ in range(80):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if measure(middle) < sigma else (low, middle)
    return np.array([0.3, high, 1.1, 0.2, 0.8, -0.5])


@pytest.mark.parametrize("factor", [0.8, 1.25])
def test_singular_flag_at_the_edge_of_its_band(factor: float) -> None:
    """A root is flagged "singular" exactly when its Jacobian's smallest singular value is
    within the band sqrt(tolerance) (dhkin.ik.general6r.singular_band): at 0.8 and 1.25 times
    the band, near a fold of the CRX-10iA."""
    from dhkin.ik.general6r import singular_band

    robot = dhkin.load("fanuc_crx10ia")
    q = _fold(robot, factor * singular_band(DEFAULT_TOLERANCE))
    result = robot.ik(robot.fk(q), q)
    nearest = int(np.argmin(np.abs(_wrap(result.q - q)).max(axis=1)))
    assert np.abs(result.q[nearest] - q).max() <= 1e-6
    assert ("singular" in result.flags[nearest]) == (factor < 1.0)


def _free_pose(robot: Robot, start: np.ndarray) -> np.ndarray:
    """Joint values where axis 6 lies on axis 1 (q1 and q6 then move one rotation): found by
    least squares on joints 2-5 (fixed seed). Two joints turn about one line when their
    columns of the Jacobian (Pinocchio's, at tool0: the twist of each joint's line) are equal
    up to the sign of their directions."""
    import scipy.optimize

    reference = robot.reference()

    def residual(x: np.ndarray) -> np.ndarray:
        J = reference.jacobian(np.array([start[0], *x, start[5]]))
        return J[:, 0] - np.sign(J[3:, 0] @ J[3:, 5]) * J[:, 5]

    fit = scipy.optimize.least_squares(residual, start[1:5], xtol=1e-15, ftol=1e-15, gtol=1e-15)
    q = np.array([start[0], *fit.x, start[5]])
    assert fit.cost < 1e-28 and robot.table.in_limits(q[None])[0]
    return q


@pytest.mark.parametrize(("name", "start"), [
    ("fanuc_crx10ia", [0.3, 0.2, 1.9, 1.5, 0.1, -0.5]),
    ("xarm6", [0.3, 0.4, 0.1, 0.1, 2.7, -0.5]),
])
def test_a_free_joint_follows_the_seed(name: str, start: list[float]) -> None:
    """Axis 6 on axis 1: only q1 -/+ q6 is determined. The answer nearest the seed is the
    member of that family nearest the seed (q1 and q6 each move by half the seed's offset on
    q1, one way or the other), exact and flagged "singular", continuous in the seed."""
    robot = dhkin.load(name)
    q = _free_pose(robot, np.array(start))
    T = robot.fk(q)
    for shift in (0.0, 0.2, -0.3, 0.25):
        seed = q.copy()
        seed[0] += shift
        result = robot.ik(T, seed)
        nearest = int(np.argmin(np.linalg.norm(result.q - seed, axis=1)))
        chosen = result.q[nearest]
        assert "singular" in result.flags[nearest]
        assert chosen[0] - q[0] == pytest.approx(shift / 2, abs=1e-9)
        assert abs(chosen[5] - q[5]) == pytest.approx(abs(shift) / 2, abs=1e-9)
        assert np.abs(chosen[1:5] - q[1:5]).max() <= 1e-9
        position, rotation = pose_errors(robot.reference().fk(result.q),
                                         np.repeat(T[None], len(result), axis=0))
        assert max(position.max(), rotation.max()) <= DEFAULT_TOLERANCE


# --------------------------------------------------------------------------------------------
# issue 26: every root at special angles, seed-independent; far poses answered before LAPACK

#: Poses where the solver lost regular, isolated roots (reproducer d06 and issue 26): roots
#: sharing the eliminated joint's value (four CRX-10iA roots at theta_2 = 90 deg), a matrix
#: polynomial singular at the pose itself (tilted UR5), q5 = 0 of the tilted UR5.
LOST_ROOT_POSES = [
    ("fanuc_crx10ia", [0.0, 0.0, 0.0, -90.0, 90.0, 180.0]),
    ("fanuc_crx10ia", [-90.0, -90.0, 0.0, 90.0, 90.0, -180.0]),
    ("fanuc_crx10ia", [180.0, 90.0, 90.0, 90.0, -90.0, 90.0]),
    ("xarm6", [-90.0, 90.0, 0.0, 0.0, 0.0, 0.0]),
    ("ur5_tilted", [0.0, 90.0, 90.0, 90.0, 90.0, 0.0]),
    ("ur5_tilted", [219.6, 221.7, 5.5, -154.2, 0.0, -84.0]),
    # a nearly defective triple eigenvalue on which Francis's QR stalls (its window is split)
    ("fanuc_crx10ia", [90.0, -90.0, 0.0, 180.0, 179.9, 180.0]),
    # a moved pose whose companion's eigenvalues depend on rounding (solved by QZ)
    ("ur5_tilted", [180.0, 90.0, -90.0, 90.0, -90.0, 0.0]),
]


@pytest.mark.parametrize(("name", "degrees"), LOST_ROOT_POSES)
def test_every_isolated_root_at_special_angles(name: str, degrees: list[float]) -> None:
    """Unseeded, the answer holds the sampled q and every isolated root a multistart on the
    exact chain finds (verified and classified on Pinocchio: dhkin.validation.multistart);
    seeded with q, the same regular roots (the seed chooses, it does not find)."""
    from dhkin.validation.multistart import RootReference, missing_roots
    from dhkin.validation.references import ReferenceSpec, TargetModel

    robot = ur5_tilted() if name == "ur5_tilted" else dhkin.load(name)
    solver = General6RSolver(robot.table)
    q = np.radians(degrees)
    model = TargetModel(ReferenceSpec(kind="exact"), robot.reference())
    T = model.fk(q)
    unseeded, seeded = solver.solve_one(T), solver.solve_one(T, q)
    roots = RootReference(robot, model, starts=256).roots(T, DEFAULT_TOLERANCE)
    assert len(roots) >= 2
    assert not missing_roots(model, T, np.vstack([roots, q]), unseeded.q, DEFAULT_TOLERANCE,
                             SAME)
    regular = [np.asarray(r.q)[["singular" not in f for f in r.flags]] for r in (unseeded,
                                                                              seeded)]
    assert len(regular[0]) == len(regular[1])
    d = np.abs(_wrap(regular[0][:, None] - regular[1][None])).max(axis=2)
    assert np.all(d.min(axis=1) <= 1e-9)


#: Poses of `dhkin check` (seed 0: CRX-10iA uniform sample 2326, HC10DT near-singular sample
#: 11016) whose root lies 1.8e-5 rad (CRX-10iA) and 1e-6 rad (HC10DT) in theta_2 from another
#: root's: a nearly double eigenvalue of the companion, which a QR iteration resolves only to
#: its backward error over the gap. Deflating the eigenvalues +-i by a constant orthogonal basis
#: undid the companion's balancing (the deflated matrix's norm ~1e6 against ~50 balanced on the
#: HC10DT pose) and scattered the pair by 3e-4 to 6e-4 rad: the root was lost.
NEAR_DOUBLE_POSES = [
    ("fanuc_crx10ia", [-1.3252076916882785, -1.9031331755445116, 2.2318910050791123,
                       -1.8376890649785715, 3.1176090779758727, 3.0909496408603063]),
    ("motoman_hc10dt", [2.023436611934426, -2.659816867168698, 3.62328207806369,
                        -1.4919549505431418, -0.0, 1.0721349745253512]),
]


@pytest.mark.parametrize(("name", "q"), NEAR_DOUBLE_POSES)
def test_nearly_double_eigenvalue_keeps_both_roots(name: str, q: list[float]) -> None:
    """Unseeded, the answer at a pose made by Pinocchio from q (generated URDF) holds q."""
    from dhkin.validation.multistart import missing_roots
    from dhkin.validation.references import ReferenceSpec, TargetModel

    robot = dhkin.load(name)
    model = TargetModel(ReferenceSpec(kind="exact"), robot.reference())
    T = model.fk(np.array(q))
    answer = robot.ik(T)
    assert not missing_roots(model, T, np.array([q]), answer.q, DEFAULT_TOLERANCE, SAME)
    assert len(answer) % 2 == 0


@pytest.mark.parametrize("kind", ["exact", "vendor"])
def test_companion_kept_off_at_the_leading_condition(kind: str) -> None:
    """At an HC10 pose (scripts/compare_builds.py's sample 4445) every leading matrix is
    conditioned at 1e-8 .. 3e-8 and four eigenvalues are nearly double (roots 3e-5 to 9e-5 rad
    apart in q2): the companion with its spurious eigenvalues +-i deflated put one pair's
    copies 2.4e-3 rad apart, beyond kCluster, and lost a root; undeflated, the AVX-512 build's
    put two pairs' copies 2.0e-3 and 3.6e-3 apart and lost two. QZ on the pencil is used below
    kCompanionCondition (candidates.hpp); unseeded, every root of the multistart reference
    comes back. The target by Pinocchio on the generated URDF and on Yaskawa's."""
    from dhkin.validation.multistart import RootReference, missing_roots
    from dhkin.validation.references import target_model

    robot = dhkin.load("motoman_hc10")
    model = target_model(robot, kind)
    q = np.array([1.7237244375179364, 1.7191605905125185, 6.07845360793609,
                  -1.9076647940283957, 2.8273094626327593, 0.5648040965542207])
    T = model.fk(q)
    roots = RootReference(robot, model, starts=2000).roots(T, DEFAULT_TOLERANCE)
    answer = robot.ik(T)
    assert len(roots) == 8
    assert not missing_roots(model, T, roots, answer.q, DEFAULT_TOLERANCE, SAME)
    # the pose lies in the band where QZ replaces the companion (kLeadCondition = 1e-8 <= the
    # best leading matrix's reciprocal condition < kCompanionCondition = 1e-5), and its starts
    # are the roots themselves, each nearly double eigenvalue split into its two roots (within
    # kCluster = 1e-3 rad; the companion's starts were 0.5-1 rad off four of them)
    solver = robot.general_solver
    assert solver is not None
    starts, _, lead_condition, _ = solver.core.candidates(
        np.ascontiguousarray(solver.target_dh(T)))
    assert 1e-8 <= lead_condition < 1e-5
    offsets = np.abs(_wrap(np.asarray(roots)[:, None] - np.asarray(starts)[None])).max(axis=2)
    assert offsets.min(axis=1).max() <= 1e-3


def test_arrangement_ranked_by_what_its_starts_cost() -> None:
    """A near-spherical arm forced through the general solver (the Kinova Gen3 6-DoF's table,
    as a user's arm just outside the spherical-wrist band would be): every arrangement returns
    every sample root, but the reversed k = 1 one's raw starts happened to lie within 1e-6 rad of
    one sample more, and it was chosen, though ~5 of its starts a pose verify nothing and each
    runs Newton's whole budget. Ranked by verified roots, then by the chain evaluations its
    starts cost, the arrangement chosen drops fewer starts than every other regular one, with
    the same roots (general6r_arrangement.rank_arrangements)."""
    from dhkin.ik.general6r_arrangement import Arrangement

    robot = dhkin.load("kinova_gen3_6dof")
    chosen = General6RSolver(robot.table)
    rng = np.random.default_rng(7)
    lower, upper = np.maximum(robot.table.lower, -math.pi), np.minimum(robot.table.upper, math.pi)
    T = robot.reference().fk(rng.uniform(lower, upper, size=(40, 6)))
    answer = chosen.solve_batch(T, workers=1)
    for other in chosen.other_arrangements:
        alone = General6RSolver(robot.table, Arrangement(other.reversed, other.k))
        theirs = alone.solve_batch(T, workers=1)
        assert int(np.sum(answer.valid)) == int(np.sum(theirs.valid))
        assert np.sum(answer.dropped) < np.sum(theirs.dropped)


def test_shared_eigenvalues_are_split_into_each_root() -> None:
    """The cause of the lost roots: at q = (0, 0, 0, -90, 90, 180) deg four of the CRX-10iA's
    eight roots share the eliminated joint's value; the null space of M there is split into
    one monomial vector per root, so that the elimination's starts are the roots themselves
    (before any Newton step)."""
    robot = dhkin.load("fanuc_crx10ia")
    solver = robot.general_solver
    assert solver is not None
    q = np.radians([0.0, 0.0, 0.0, -90.0, 90.0, 180.0])
    T_dh = solver.target_dh(robot.reference().fk(q))
    starts = solver.compiled_candidates(T_dh)
    roots = robot.ik(robot.reference().fk(q)).q
    assert len(roots) == 8
    d = np.abs(_wrap(roots[:, None] - starts[None])).max(axis=2)
    assert d.min(axis=1).max() <= 1e-8


@pytest.mark.parametrize("name", ["fanuc_crx10ia", "xarm6"])
def test_far_poses_are_out_of_reach_before_the_elimination(name: str) -> None:
    """Reproducer d04: a finite pose far out of reach (1e8 .. 1e300 m) is answered empty with
    a true reason; one such row in a batch leaves the others' answers alone."""
    robot = dhkin.load(name)
    home = robot.fk(np.zeros(6))
    for x in (1e8, 1e10, 1e12, 1e15, 1e100, 1e154, 1e300):
        far = home.copy()
        far[0, 3] = x
        result = robot.ik(far)
        assert len(result) == 0 and result.reason.startswith("out of reach")
    batch = np.repeat(home[None], 3, axis=0)
    batch[1, 0, 3] = 1e300
    _, valid = robot.ik_batch(batch)
    counts = valid.sum(axis=1)
    assert counts[1] == 0 and counts[0] == counts[2] == len(robot.ik(home)) > 0


def test_reach_at_its_edge() -> None:
    """DH frame 6 within the links' length (plus the tolerance's widening) is within reach (no
    solution there: the elimination says so), a hair beyond is not (answered before it)."""
    robot = dhkin.load("xarm6")
    solver = robot.general_solver
    assert solver is not None
    reach = solver.reach(DEFAULT_TOLERANCE, solver.table.tool)
    pose = np.eye(4)
    for factor, inside in ((1.0 - 1e-12, True), (1.0 + 1e-12, False)):
        pose[:3, 3] = np.array([0.6, 0.0, 0.8]) * reach * factor
        result = robot.ik(robot.table.base @ pose @ robot.table.tool)
        assert len(result) == 0 and result.reason.startswith("out of reach") != inside


def test_far_pose_on_the_command_line_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    """`dhkin ik fanuc_crx10ia --xyz 1e300 0 0 --rpy 0 0 0`: one line saying why, no
    traceback (issue 26)."""
    from tests.test_cli import run

    code, out, err = run(capsys, "ik", "fanuc_crx10ia", "--xyz", "1e300", "0", "0", "--rpy",
                         "0", "0", "0")
    assert code == 1 and err == ""
    assert out.count("\n") == 1 and "out of reach" in out


def test_general_solver_imports_no_jit_compiler() -> None:
    """Issue 26: the general 6R solver runs in the compiled core; neither ``import dhkin`` nor
    its first answer imports numba (nothing is compiled at run time)."""
    import subprocess
    import sys

    code = ("import sys, numpy as np, dhkin\n"
            "robot = dhkin.load('xarm6')\n"
            "assert len(robot.ik(robot.fk(np.full(6, 0.3)))) > 0\n"
            "print('numba' in sys.modules)\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "False"


def test_batch_is_the_single_calls_in_the_core() -> None:
    """ik_batch of a general 6R arm runs its pose loop in the compiled core: the same rows as
    one ik per pose (seeded per pose, every copy too), whatever the chunks and worker threads
    (each pose is solved alone); a bad pose raises naming its index."""
    from dhkin.errors import InputError
    from dhkin.ik.workers import POSES_PER_WORKER

    robot = dhkin.load("xarm6")
    rng = np.random.default_rng(26)
    Q = robot.table.random_q(2 * POSES_PER_WORKER + 3, rng)
    T = robot.fk(Q)
    seeds = Q + 0.01
    one = [robot.ik(t, q) for t, q in zip(T, seeds, strict=True)]
    for workers, chunk in ((1, 65536), (2, 700)):
        q, valid = robot.ik_batch(T, seeds, workers=workers, chunk_size=chunk)
        for k, result in enumerate(one):
            assert np.array_equal(q[k][valid[k]], result.q)
    every, valid = robot.ik_batch(T[:20], copies=True)
    for k in range(20):
        assert np.array_equal(every[k][valid[k]], robot.ik(T[k], copies=True).q)
    bad = T[:5].copy()
    bad[3, 0, 0] = np.nan
    with pytest.raises(InputError, match=r"T\[3\]"):
        robot.ik_batch(bad)


def test_several_seed_sets_share_each_poses_roots() -> None:
    """solve_batch_seeds finds each pose's roots once and answers every seed set from them:
    each set's rows, flags, residuals and counts are those of one solve_one per pose with that
    seed (unseeded, the sampled q, q moved by up to 0.05 rad, one seed for all), bit for bit,
    on HC10 poses at special angles (curves of solutions, where the seed picks each member and
    the members differ between the sets) and random ones; every copy too; a bad pose raises
    naming its index."""
    from dhkin.errors import InputError
    from dhkin.ik.result import FLAG_SETS
    from dhkin.validation.references import target_model

    robot = dhkin.load("motoman_hc10")
    solver = robot.general_solver
    assert solver is not None
    rng = np.random.default_rng(2611)
    special = np.radians(rng.choice([-180.0, -90.0, 0.0, 90.0, 180.0], size=(16, 6)))
    lower, upper = np.maximum(robot.table.lower, -math.pi), np.minimum(robot.table.upper, math.pi)
    Q = np.concatenate([special, rng.uniform(lower, upper, size=(8, 6))])
    T = target_model(robot, "vendor").fk(Q)  # Pinocchio on Yaskawa's URDF
    sets = [None, Q, Q + rng.uniform(-0.05, 0.05, size=Q.shape), Q[1]]
    members_differ = False
    for copies in (False, True):
        answers = solver.solve_batch_seeds(T, sets, copies=copies, workers=1)
        assert len(answers) == len(sets)
        for seeds, answer in zip(sets, answers, strict=True):
            for k in range(len(T)):
                seed = None if seeds is None else (seeds if seeds.ndim == 1 else seeds[k])
                one = solver.solve_one(T[k], seed, copies=copies)
                valid = answer.valid[k]
                assert np.array_equal(answer.q[k][valid], one.q)
                assert np.array_equal(answer.residuals[k][valid], one.residuals)
                assert tuple(FLAG_SETS[b] for b in answer.flags[k][valid].tolist()) == one.flags
                assert answer.dropped[k] == one.dropped
        unseeded, seeded = answers[0], answers[2]
        members_differ = members_differ or not np.array_equal(unseeded.q, seeded.q)
    assert members_differ  # the seeds chose: the test compares answers that differ
    bad = T[:5].copy()
    bad[3, 0, 0] = np.nan
    with pytest.raises(InputError, match=r"T\[3\]"):
        solver.solve_batch_seeds(bad, [None, Q[:5]])


@pytest.mark.parametrize("name", ["motoman_hc10", "ur5"])
def test_robot_answers_several_seed_sets_as_one_batch_each(name: str) -> None:
    """Robot.ik_batch_seeds: one IKBatch per seed set, each ik_batch_detailed's with that set
    (the general solver's from roots found once, a closed-form family's batch by batch), at
    special angles (singular sets: the seed picks members), q5 = 0 and random poses, targets by
    Pinocchio on the vendor's URDF; no seed set is an InputError."""
    from dhkin.errors import InputError
    from dhkin.validation.references import target_model

    robot = dhkin.load(name)
    rng = np.random.default_rng(2612)
    wrist_singular = robot.table.random_q(5, rng)
    wrist_singular[:, 4] = 0.0
    Q = np.concatenate([np.radians(rng.choice([-180.0, -90.0, 0.0, 90.0, 180.0], size=(10, 6))),
                        wrist_singular, robot.table.random_q(10, rng)])
    T = target_model(robot, "vendor").fk(Q)
    sets = [None, Q + rng.uniform(-0.05, 0.05, size=Q.shape)]
    for seeds, answer in zip(sets, robot.ik_batch_seeds(T, sets), strict=True):
        alone = robot.ik_batch_detailed(T, seeds)
        for field in ("q", "valid", "flags", "branch", "residuals", "projection", "dropped"):
            assert np.array_equal(getattr(answer, field), getattr(alone, field)), field
    with pytest.raises(InputError, match="q_seeds"):
        robot.ik_batch_seeds(T, [])


#: A regular root of the tilted UR5 at q5 = 0 (sigma_min 0.03; check_general6r's q5 sample 812)
#: that the damped Newton left 5.7e-13 m off: its polishing stopped at a step still damped after
#: rejections on the way, which gained less than twofold (docs/general6r.md, "Speed, third pass").
DAMPED_POLISH_Q = [0.8529931074876274, 5.021299881550304, -0.5638740117981649,
                   6.119514491888445, 0.0, -5.37695798182409]


def test_regular_roots_are_polished_to_the_rounding() -> None:
    from dhkin.ik.core import FK_ROUNDING

    robot = ur5_tilted()
    solver = General6RSolver(robot.table)
    model = robot.reference()
    T = model.fk(np.array([DAMPED_POLISH_Q]))[0]
    result = solver.solve_one(T)
    regular = np.array(["singular" not in flag for flag in result.flags])
    assert regular.any()
    F = model.fk(result.q[regular])
    position, rotation = pose_errors(F, np.repeat(T[None], len(F), axis=0))
    # the oracle's FK and ours each round by at most FK_ROUNDING per metre of lever
    assert np.all(position <= 2 * FK_ROUNDING * solver.tip_lever)
    assert np.all(rotation <= 2 * FK_ROUNDING)
    assert np.min(np.abs(_wrap(result.q - np.array(DAMPED_POLISH_Q))).max(axis=1)) < SAME
