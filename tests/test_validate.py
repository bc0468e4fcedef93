"""Cross-validation of IK callables against Pinocchio on a reference description: correct IKs
pass, broken IKs are caught, each by the outcome meant for its bug.

The validator itself is tested with an oracle IK that is correct by construction (it learns the
sampled q from the first call's seed), so these tests do not depend on dhkin's own IK passing on
vendor or rounded poses (it does not, until the IK core rewrite lands).
"""

from __future__ import annotations

import itertools
import json
import re
from decimal import Decimal

import numpy as np
import pinocchio as pin
import pytest

import dhkin
from dhkin.errors import InputError
from dhkin.reference import Reference
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import invert, pose_error
from dhkin.validation import (
    CONTINUITY_DISTANCE,
    CONTINUITY_SETS,
    OUTCOMES,
    SEED_PERTURBATION,
    ReferenceSpec,
    adapt,
    load_ik,
    perturbed_seeds,
    replay,
    rounded_urdf,
    sample_joint_vectors,
    target_model,
    validate,
    write_failures,
)

from . import broken
from .conftest import REFERENCE_URDFS

N = 200  # uniform samples per run, plus 20 special-angle and 20 near-singular ones
UR5_VENDOR = REFERENCE_URDFS / "ur5.urdf"


@pytest.fixture(scope="module")
def ur5() -> dhkin.Robot:
    return dhkin.load("ur5")


@pytest.fixture(scope="module")
def abb() -> dhkin.Robot:
    return dhkin.load("abb_irb1200_7_70")


def in_limit_copies(robot: dhkin.Robot, q: np.ndarray) -> np.ndarray:
    """q and every 2pi-shifted copy of it within the joint limits."""
    options = []
    for k, joint in enumerate(robot.table.joints):
        values = q[k] + 2 * np.pi * np.arange(-3, 4) if joint.is_revolute else np.array([q[k]])
        options.append(values[(values >= robot.lower[k]) & (values <= robot.upper[k])])
    return np.array(list(itertools.product(*options)))


class Oracle:
    """A correct, complete, seed-continuous IK for the validator's tests, independent of dhkin's
    IK being right: it learns the sampled q from the first call for a target (the validator
    passes it as q_seed) and returns it with its in-limit 2pi copies, plus the closed-form
    branches ``robot.ik(T, q_seed=q, copies=False)`` that verify on the table's own model (the
    validator allows them the reference's deviation from it)."""

    def __init__(self, robot: dhkin.Robot, reference: object = None, base: str | None = None,
                 tip: str | None = None, tolerance: float = 1e-9) -> None:
        self.robot, self.tolerance = robot, tolerance
        self.model = target_model(robot, reference, base, tip)
        self.known: dict[bytes, np.ndarray] = {}
        self.calls: list[tuple[np.ndarray, np.ndarray]] = []
        self.__name__ = "oracle"

    def __call__(self, T: np.ndarray, q_seed: np.ndarray | None = None) -> np.ndarray:
        T = np.asarray(T, dtype=float)
        self.calls.append((np.array(q_seed, dtype=float), T.copy()))
        q = self.known.setdefault(T.tobytes(), np.array(q_seed, dtype=float))
        branches = self.robot.ik(T, q_seed=q, copies=False).q
        if len(branches):
            position, rotation = pose_error(self.robot.reference().fk(branches),
                                            np.broadcast_to(T, (len(branches), 4, 4)))
            branches = branches[(position <= self.tolerance) & (rotation <= self.tolerance)]
        return np.vstack([in_limit_copies(self.robot, q), branches])


def first_calls(oracle: Oracle) -> tuple[np.ndarray, np.ndarray]:
    """The seeds (= sampled q) and targets of the oracle's first call for each target."""
    q = np.array(list(oracle.known.values()))
    T = np.array([np.frombuffer(key).reshape(4, 4) for key in oracle.known])
    return q, T


def test_samples_cover_the_three_sets(ur5: dhkin.Robot) -> None:
    """Uniform, special-angle and near-singular samples, all inside the limits."""
    q, sets = sample_joint_vectors(ur5, N, seed=3)
    assert q.shape == (N + 2 * (N // 10), 6)
    assert sets.count("uniform") == N and sets.count("special") == sets.count("near_singular")
    assert np.all(ur5.table.in_limits(q))
    special = q[[s == "special" for s in sets]]
    on_special = np.isclose(special[..., None], [0, np.pi / 2, -np.pi / 2, np.pi]).any(axis=-1)
    assert on_special.all()
    near = q[[s == "near_singular" for s in sets], 4]
    assert np.all(np.abs(near) <= 1e-6) and np.count_nonzero(near == 0.0) >= len(near) // 4


def test_perturbed_seeds_move_every_joint_on_the_singular_sets(ur5: dhkin.Robot) -> None:
    q, sets = sample_joint_vectors(ur5, N, seed=3)
    seeds = perturbed_seeds(ur5, q, sets, seed=3)
    singular = np.array([s in CONTINUITY_SETS for s in sets])
    assert np.isnan(seeds[~singular]).all() and np.isfinite(seeds[singular]).all()
    moved = np.abs(seeds[singular] - q[singular])
    inside = (ur5.table.in_limits(q[singular] + SEED_PERTURBATION)  # not clipped by a limit
              & ur5.table.in_limits(q[singular] - SEED_PERTURBATION))
    assert inside.sum() > 30 and np.allclose(moved[inside], SEED_PERTURBATION)
    assert np.all(moved <= SEED_PERTURBATION + 1e-15)
    assert np.all(ur5.table.in_limits(seeds[singular]))
    assert np.array_equal(seeds, perturbed_seeds(ur5, q, sets, seed=3), equal_nan=True)
    signs = np.sign(seeds[singular] - q[singular])[inside]
    assert 0.3 < np.mean(signs > 0) < 0.7, "random signs"


# --------------------------------------------------------------------------------------------
# References


def significant_digits(token: str) -> int:
    return len(Decimal(token).normalize().as_tuple().digits)


def numbers_of(text: str, tags: str = "origin|axis|limit") -> list[str]:
    attributes = re.findall(rf"<(?:{tags})\b[^>]*>", text)
    return [n for a in attributes
            for n in " ".join(re.findall(r'"([^"]*)"', a)).split()
            if re.fullmatch(r"[-+0-9.eE]+", n)]


def test_rounded_urdf_rounds_every_number(ur5: dhkin.Robot) -> None:
    """<= 10 significant digits everywhere, pi/2 as UR writes it, Pinocchio loads it, and its FK
    differs from the exact URDF's by more than 0 and less than 1e-8."""
    exact = ur5.urdf()
    text = rounded_urdf(exact)
    assert max(significant_digits(n) for n in numbers_of(exact)) > 10
    assert max(significant_digits(n) for n in numbers_of(text)) <= 10
    assert len(numbers_of(text)) == len(numbers_of(exact))
    assert "1.570796327" in text and "1.5707963267948966" not in text
    assert "<!--" in text and text.count("\n") == exact.count("\n"), "layout and comments kept"
    model = pin.buildModelFromXML(text)
    assert model.nq == 6
    q = ur5.table.random_q(500, np.random.default_rng(0))
    position, rotation = pose_error(Reference(text).fk(q), Reference(exact).fk(q))
    deviation = max(position.max(), rotation.max())
    assert 0 < deviation < 1e-8
    coarse = Reference(rounded_urdf(exact, digits=3)).fk(q)
    assert pose_error(coarse, Reference(exact).fk(q))[1].max() > 1e-4
    with pytest.raises(InputError, match="digits"):
        rounded_urdf(exact, digits=0)


def test_default_reference_is_the_rounded_urdf(ur5: dhkin.Robot) -> None:
    """validate() makes its targets on the rounded URDF unless told otherwise; the report names
    it and how far it is from the table's own model."""
    oracle = Oracle(ur5)
    report = validate(ur5, oracle, n=20, seed=0)
    assert report.reference == ReferenceSpec("rounded").to_json()
    assert "rounded" in report.reference_name and "10 significant digits" in report.summary()
    q, T = first_calls(oracle)
    assert len(q) == report.samples
    rounded = Reference(rounded_urdf(ur5.urdf())).fk(q)
    assert np.array_equal(T, rounded)
    assert 0 < report.reference_deviation["rotation_max"] < 1e-8


def test_vendor_reference_makes_the_targets(ur5: dhkin.Robot) -> None:
    """--reference robots/vendor/ur5.urdf: the targets are Pinocchio's FK of the vendor
    file at the sampled q, ~1e-10 from the table's own FK (not 0); frames from VENDOR_REFERENCES."""
    oracle = Oracle(ur5, UR5_VENDOR)
    report = validate(ur5, oracle, n=40, seed=1, reference=UR5_VENDOR)
    assert report.ok, report.summary()
    assert report.reference["kind"] == "vendor"
    assert report.reference["path"] == str(UR5_VENDOR.resolve())
    assert (report.reference["base"], report.reference["tip"]) == ("base_link", "tool0")
    assert "ur5.urdf (base_link -> tool0)" in report.summary()
    q, T = first_calls(oracle)
    vendor = Reference(UR5_VENDOR.read_text(), tip="tool0", base="base_link")
    assert np.array_equal(T, vendor.fk(q))
    position, rotation = pose_error(T, ur5.reference().fk(q))
    assert 1e-12 < max(position.max(), rotation.max()) < 1e-8


def test_exact_reference_is_the_generated_urdf(ur5: dhkin.Robot) -> None:
    oracle = Oracle(ur5, "exact")
    report = validate(ur5, oracle, n=20, seed=0, reference="exact")
    assert report.ok and report.reference["kind"] == "exact" and not report.reference_deviation
    q, T = oracle.calls[0]
    assert np.array_equal(T, ur5.reference().fk(q))


@pytest.mark.parametrize(("name", "reference"), [
    ("ur5", None), ("ur5", "exact"), ("ur5", "vendor"), ("ur3", "vendor"),
    ("aubo_i10", "vendor"), ("abb_irb1200_7_70", "rounded")])
def test_a_correct_ik_passes_every_check(name: str, reference: str | None) -> None:
    """The oracle IK passes on every reference (UR3's vendor file has a continuous joint, AUBO's
    tip is wrist3_Link), with the branch and continuity checks run on every eligible sample."""
    robot = dhkin.load(name)
    if reference == "vendor":
        reference = str(REFERENCE_URDFS / f"{name}.urdf")
    report = validate(robot, Oracle(robot, reference), n=100, seed=3, reference=reference)
    assert report.ok, report.summary()
    assert report.counts["success"] == report.samples == 120
    assert report.branch_checked == report.samples
    assert report.continuity_checked == 20
    # on another description the table's exact branches are off by that description's
    # deviation from the table (the rounded URDF: ~1e-9 rad)
    allowed = 1e-9 + max(report.reference_deviation.values(), default=0.0)
    assert report.residuals["position_max"] <= allowed
    assert report.residuals["rotation_max"] <= allowed


@pytest.mark.parametrize("name", ["ur5", "aubo_i10", "abb_irb1200_7_70", "anthropomorphic_arm"])
@pytest.mark.parametrize("reference", ["exact", "rounded"])
def test_our_ik_passes_on_its_own_urdf(name: str, reference: str) -> None:
    """dhkin's own IK on the generated URDF, exact and rounded to 10 digits: every check passes
    (no wrong, missing, missing-branch or discontinuous sample; the stretched or folded elbow
    at q5 = 0 or pi, where a seed's q6 once moved q2 by 0.5 rad, included)."""
    robot = dhkin.load(name)
    report = validate(robot, n=N, seed=1, reference=reference)
    assert report.samples == N + 2 * (N // 10)
    assert report.ok and report.counts["success"] == report.samples, report.summary()
    assert set(report.by_set) == {"uniform", "special", "near_singular"}
    allowed = 1e-9 + max(report.reference_deviation.values(), default=0.0)
    assert report.residuals["position_max"] <= allowed
    assert report.residuals["rotation_max"] <= allowed
    assert report.solution_counts["min"] >= 1
    assert report.by_configuration, "samples are labelled with their configuration"


# --------------------------------------------------------------------------------------------
# Broken IKs, each caught by its outcome


def test_sign_flip_is_caught_as_wrong(ur5: dhkin.Robot) -> None:
    report = validate(ur5, broken.sign_flip, n=N, seed=2)
    assert not report.ok
    assert report.rate("wrong") > 0.5
    assert report.residuals["position_max"] > 1e-3


def test_dropped_branch_is_caught_as_missing(ur5: dhkin.Robot) -> None:
    """Every returned solution is exact, so nothing is wrong; samples on the dropped branch are
    missing, and every other pose lacks that branch."""
    report = validate(ur5, broken.dropped_branch, n=N, seed=2, reference="exact")
    assert report.counts["wrong"] == 0
    assert report.rate("missing") > 0.02
    assert report.rate("missing_branch") > 0.5
    # Away from singularities the missing samples are exactly those on the dropped branch (at
    # special angles and near q5 = 0 branches merge, so their labels are not unique there).
    first = " ".join(f"{k}={v}" for k, v in ur5.ik_solver.branch_labels[0].items())
    missing_labels = {f.configuration for f in report.failures
                      if f.sample_set == "uniform" and f.outcome == "missing"}
    assert missing_labels == {first}


def test_branch_dropped_off_seed_is_caught_as_missing_branch(ur5: dhkin.Robot) -> None:
    """The sampled q is always returned (no "missing"), but a branch is lacking on the poses not
    sampled on it: only the missing-branch check sees it; the oracle passes the same poses."""
    report = validate(ur5, broken.branch_dropped_off_seed, n=N, seed=2, reference="exact")
    assert report.counts["missing"] == report.counts["wrong"] == 0
    assert report.counts["no_solution"] == 0
    assert report.rate("missing_branch") > 0.5 and not report.ok
    first = dict(ur5.ik_solver.branch_labels[0])
    first_text = " ".join(f"{k}={v}" for k, v in first.items())
    for failure in report.failures:
        assert failure.outcome == "missing_branch"
        assert failure.missing_branches and all(b.startswith(first_text)
                                                for b in failure.missing_branches)
        assert first_text in failure.detail
        assert failure.configuration != first_text or failure.sample_set != "uniform"
    assert "missing_branch" in report.summary() and "missing_branch" in report.markdown()
    assert validate(ur5, Oracle(ur5, "exact"), n=N, seed=2, reference="exact").ok


def test_missing_branches_are_not_asked_of_one_solution_iks(ur5: dhkin.Robot) -> None:
    report = validate(ur5, broken.branch_dropped_off_seed, n=50, seed=2, reference="exact",
                      complete_expected=False)
    assert report.branch_checked == 0 and report.counts["missing_branch"] == 0
    assert report.ok and "not checked" in report.summary()


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70"])
def test_seed_ignored_is_caught_as_discontinuous(name: str) -> None:
    """An IK that takes q_seed but picks the free joint from zeros at q5 = 0: exact (nothing
    wrong, nothing missing: the pose cannot tell the sampled q4/q6 split), but its answer does
    not follow a perturbed seed; the oracle passes the same poses."""
    robot = dhkin.load(name)
    report = validate(robot, broken.seed_ignored, n=N, seed=2, reference="exact")
    assert report.counts["wrong"] == report.counts["no_solution"] == 0
    assert report.counts["discontinuous"] >= 3 and not report.ok
    assert report.by_set["uniform"].get("discontinuous", 0) == 0
    assert 0 < report.continuity_checked <= 2 * (N // 10)
    for failure in (f for f in report.failures if f.outcome == "discontinuous"):
        assert failure.sample_set in CONTINUITY_SETS
        assert abs(np.sin(failure.q_sampled[4])) <= 1e-6, "only at the wrist singularity"
        seed = np.array(failure.perturbed_seed)
        assert np.abs(seed - failure.q_sampled).max() == pytest.approx(SEED_PERTURBATION)
        distance = np.abs(np.angle(np.exp(1j * (np.array(failure.returned_perturbed) - seed))))
        assert distance.max(axis=1).min() > CONTINUITY_DISTANCE
        assert f"allowed {CONTINUITY_DISTANCE}" in failure.detail
    assert validate(robot, Oracle(robot, "exact"), n=N, seed=2, reference="exact").ok


def test_continuity_needs_a_seed(abb: dhkin.Robot) -> None:
    """An IK without q_seed is not asked for continuity (it cannot follow a seed)."""
    report = validate(abb, lambda T: abb.ik(T).q, n=50, seed=2, reference="exact")
    assert report.continuity_checked == 0 and report.ok


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70"])
def test_wrong_wrist_split_is_caught_only_at_the_singularity(name: str) -> None:
    report = validate(dhkin.load(name), broken.wrong_wrist_split, n=N, seed=2,
                      reference="exact")
    assert report.by_set["near_singular"].get("wrong", 0) > 0
    assert report.by_set["uniform"].get("wrong", 0) == 0
    assert all(f.sample_set in ("near_singular", "special") for f in report.failures
               if f.outcome == "wrong")


def test_degrees_as_radians_is_caught(abb: dhkin.Robot) -> None:
    report = validate(abb, broken.degrees_as_radians, n=N, seed=2)
    assert report.rate("wrong") > 0.9


def test_degree_adapter_repairs_degrees(abb: dhkin.Robot) -> None:
    """adapt(degrees=True) converts a degree-returning IK back: it then passes (this IK takes
    no seed, so at q5 = 0 only joints 1 and 5 are compared for the missing check)."""
    report = validate(abb, adapt(lambda T: broken.degrees_as_radians(T, abb), degrees=True),
                      n=N, seed=2, reference="exact")
    assert report.ok, report.summary()


def test_tool_frame_adapter(ur5: dhkin.Robot) -> None:
    """An IK that solves for the flange frame passes once adapted with tool0 -> flange."""
    reference = ur5.reference()
    tool0_to_flange = invert(reference.fk(np.zeros(6), "tool0")) @ reference.fk(np.zeros(6),
                                                                                 "flange")
    oracle = Oracle(ur5, "exact")

    def flange_ik(T_flange: np.ndarray, q_seed: np.ndarray | None = None) -> np.ndarray:
        return oracle(T_flange @ invert(tool0_to_flange), q_seed=q_seed)

    assert not validate(ur5, flange_ik, n=20, seed=4, reference="exact").ok
    assert validate(ur5, adapt(flange_ik, tool=tool0_to_flange), n=N, seed=4,
                    reference="exact").ok


# --------------------------------------------------------------------------------------------
# Reports, failure files, replay


def test_failure_file_replays_the_same_failures(ur5: dhkin.Robot, tmp_path) -> None:
    report = validate(ur5, broken.dropped_branch, n=N, seed=5, reference="exact")
    path = write_failures(report, tmp_path / "failures.json")
    data = json.loads(path.read_text())
    assert data["robot"] == "ur5" and len(data["failures"]) == len(report.failures)
    assert data["reference"]["kind"] == "exact"
    first = data["failures"][0]
    assert {"q_sampled", "target", "returned", "position_errors", "outcome", "perturbed_seed",
            "returned_perturbed", "missing_branches"} <= set(first)
    again = replay(ur5, broken.dropped_branch, path)
    assert again.samples == len(report.failures)
    assert [f.outcome for f in again.failures] == [f.outcome for f in report.failures]
    assert again.counts["missing"] > 0 and again.counts["missing_branch"] > 0
    fixed = replay(ur5, lambda T: ur5.ik(T).q, path)
    assert fixed.ok, fixed.summary()


def test_replay_uses_the_recorded_vendor_reference_and_seeds(ur5: dhkin.Robot,
                                                             tmp_path) -> None:
    """A failure file of a vendor run records the file and frames, and the perturbed seeds;
    replay makes its targets on that vendor file again and reuses the seeds."""
    report = validate(ur5, broken.seed_ignored, n=N, seed=2, reference=UR5_VENDOR)
    assert report.counts["discontinuous"] > 0
    path = write_failures(report, tmp_path / "vendor.json")
    data = json.loads(path.read_text())
    assert data["reference"] == {"kind": "vendor", "path": str(UR5_VENDOR.resolve()),
                                 "base": "base_link", "tip": "tool0", "robot_tip": "tool0",
                                 "digits": 10}
    again = replay(ur5, broken.seed_ignored, path)
    assert again.reference == report.reference
    assert [f.outcome for f in again.failures] == [f.outcome for f in report.failures]
    assert [f.target for f in again.failures] == [f.target for f in report.failures]
    assert [f.perturbed_seed for f in again.failures] == [f.perturbed_seed
                                                          for f in report.failures]
    assert replay(ur5, Oracle(ur5, UR5_VENDOR), path).ok
    exact = replay(ur5, broken.seed_ignored, path, reference="exact")
    assert exact.reference["kind"] == "exact"


def test_rates_add_up(ur5: dhkin.Robot) -> None:
    report = validate(ur5, broken.wrong_wrist_split, n=50, seed=6)
    assert sum(report.counts[o] for o in OUTCOMES) == report.samples
    assert "FAIL" in report.summary() and "# IK validation" in report.markdown()
    data = report.to_json()
    assert set(data["counts"]) == set(OUTCOMES) == set(data["rates"])
    assert "rounded" in data["reference_name"] and "continuity_checked" in data


def test_bad_arguments_are_clear_errors(ur5: dhkin.Robot, tmp_path) -> None:
    with pytest.raises(InputError, match="module:function"):
        load_ik("tests.broken.sign_flip")
    with pytest.raises(InputError, match="cannot import module"):
        load_ik("no_such_module_xyz:ik")
    with pytest.raises(InputError, match="no callable"):
        load_ik("tests.broken:no_such_function")
    with pytest.raises(InputError, match="n: expected at least 1 sample"):
        validate(ur5, n=0)
    with pytest.raises(InputError, match=r"reference \(--reference\).*no_such"):
        validate(ur5, n=5, reference=tmp_path / "no_such.urdf")
    with pytest.raises(InputError, match=r"tip \(--tip\).*no frame named 'nowhere'"):
        validate(ur5, n=5, reference=UR5_VENDOR, tip="nowhere")
    with pytest.raises(InputError, match=r"base \(--base\).*no frame named 'floor'"):
        validate(ur5, n=5, reference=UR5_VENDOR, base="floor")
    with pytest.raises(InputError, match="5 actuated joints"):
        validate(ur5, n=5, reference=UR5_VENDOR, tip="wrist_2_link")
    with pytest.raises(InputError, match="vendor URDF reference only"):
        validate(ur5, n=5, reference="exact", tip="tool0")
    not_urdf = tmp_path / "not.urdf"
    not_urdf.write_text("<robot")
    with pytest.raises(InputError, match=r"reference \(--reference\)"):
        validate(ur5, n=5, reference=not_urdf)
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    with pytest.raises(InputError, match="not a dhkin failure file"):
        replay(ur5, broken.sign_flip, bad)
    bad.write_text(json.dumps({"robot": "ur5", "tolerance": 1e-9, "joint_tolerance": 1e-6,
                               "reference": {"kind": "nonsense"},
                               "failures": [{"q_sampled": [0] * 6, "sample_set": "uniform"}]}))
    with pytest.raises(InputError, match="reference"):
        replay(ur5, broken.sign_flip, bad)


def test_seedless_ik_at_the_wrist_singularity(abb: dhkin.Robot) -> None:
    """Without q_seed, a correct IK passes at q5 = 0 (only q4 + q6 is determined there), and a
    dropped shoulder branch is still caught there."""
    report = validate(abb, lambda T: abb.ik(T).q, n=N, seed=7, reference="exact")
    assert report.ok, report.summary()

    def without_righty(T: np.ndarray) -> np.ndarray:
        solutions = abb.ik(T)
        keep = [k for k, c in enumerate(solutions.configurations)
                if c.labels["shoulder"] != "righty"]
        return solutions.q[keep]

    dropped = validate(abb, without_righty, n=N, seed=7, reference="exact")
    near = dropped.by_set["near_singular"]
    assert near.get("missing", 0) + near.get("missing_branch", 0) > 0


def test_joint_tolerance_follows_the_conditioning(abb: dhkin.Robot) -> None:
    """Away from singularities the missing check uses joint_tolerance; at |q5| = 1e-10 the pose
    resolves q only to ~1e-14 / sigma_min, and the check allows that much, no more."""
    from dhkin.validation import POSE_ROUNDING, _resolvable

    generic = np.array([0.3, 0.2, -0.4, 0.5, 0.9, -0.2])
    assert _resolvable(abb, generic, 1e-6) == pytest.approx(1e-6, rel=1e-6)
    near = generic.copy()
    near[4] = 1e-10
    sigma_min = np.linalg.svd(abb.reference().jacobian(near), compute_uv=False).min()
    assert sigma_min < 1e-9
    assert _resolvable(abb, near, 1e-6) == pytest.approx(1e-6 + POSE_ROUNDING / sigma_min)
    assert _resolvable(abb, near, 1e-6) < 1e-2


def test_general_6r_arms_are_validated_completely() -> None:
    """The FANUC CRX-10iA fits no family: dhkin's own IK is the general 6R solver, called
    unseeded and checked against the independent multistart reference on the samples
    reference_samples chooses (missing samples and missing branches counted), and passes every
    check; an IK that returns only the solution nearest its seed (as a numerical IK would),
    called unseeded too, loses the sampled q on most poses."""
    from dhkin.validation.samples import reference_samples, sample_joint_vectors

    robot = dhkin.load("fanuc_crx10ia")
    assert robot.complete_ik and robot.ik_family == "general6r"
    report = validate(robot, n=60, seed=1, reference="exact")
    _, sets = sample_joint_vectors(robot, 60, 1)
    assert report.complete_expected and report.branch_checked == reference_samples(sets).sum()
    assert report.ok and report.counts["success"] == report.samples, report.summary()

    def nearest_only(T: np.ndarray, q_seed: np.ndarray | None = None) -> np.ndarray:
        solutions = robot.ik(T, q_seed=q_seed)
        reference = np.zeros(6) if q_seed is None else q_seed
        return solutions.q[[int(np.argmin(np.linalg.norm(solutions.q - reference, axis=1)))]]

    lacking = validate(robot, nearest_only, n=60, seed=1, reference="exact")
    assert lacking.counts["wrong"] == 0
    assert lacking.rate("missing") > 0.5 and not lacking.ok


def test_validate_sees_the_roots_the_old_general_solver_lost() -> None:
    """Arms without a closed form are checked unseeded against an independent multistart
    reference (dhkin.validation.multistart): the general 6R solver as it was before issue 26
    (one root per eigenvalue, the seed a Newton start: broken.general6r_one_root_per_eigenvalue)
    is caught as missing at special angles; today's solver passes."""
    robot = dhkin.load("fanuc_crx10ia")
    report = validate(robot, broken.general6r_one_root_per_eigenvalue, n=100, seed=2,
                      reference="exact")
    assert report.branch_checked > 0 and not report.ok
    assert report.counts["missing_branch"] > 0 and report.counts["missing"] > 0
    lost = [f for f in report.failures if f.outcome == "missing_branch"]
    assert any(f.sample_set == "special" for f in lost)
    assert all(b.startswith("root q=(") for f in lost for b in f.missing_branches)
    own = validate(robot, n=100, seed=2, reference="exact")
    assert own.branch_checked >= report.branch_checked  # the broken IK fails some earlier
    assert own.ok and own.counts["missing_branch"] == 0 and own.counts["missing"] == 0



#: The xArm6's sample 10510 of ``dhkin validate xarm6 -n 10000`` (deg): q5 = 180 deg, where the
#: rounded reference breaks a curve of solutions into nearly singular roots and a valley of
#: near-solutions between them (docs/general6r.md, "Near-roots").
XARM6_BROKEN_CURVE = np.deg2rad([180.0, 90.0, -90.0, 180.0, 180.0, 180.0])


def test_near_root_of_a_broken_curve_is_tied_along_its_valley() -> None:
    """The multistart's point at the xArm6's sample 10510 (rounded reference) is a Newton
    stall inside the tolerance, not a root (its error on the exact URDF stays above
    CONVERGED): a near-root. The straight chord to the nearest returned row leaves the
    tolerance (the valley bends), the walk along the valley does not, so the IK's answer
    passes; without the rows on that valley the near-root is reported, never dropped."""
    from dhkin.validation.multistart import (
        CONVERGED,
        RootReference,
        check_reference,
        missing_roots,
    )

    robot = dhkin.load("xarm6")
    model = target_model(robot, "rounded")
    T = model.fk(XARM6_BROKEN_CURVE)
    # the deviation a run of this one sample sets (run.py: the largest over the samples)
    model.deviation = float(max(pose_error(robot.fk(XARM6_BROKEN_CURVE), T)))
    reference = RootReference(robot, model)
    points = reference.points(T, DEFAULT_TOLERANCE)
    assert len(points.roots) == 1 and len(points.near_roots) == 1
    near = points.near_roots
    error = max(pose_error(robot.reference().fk(near[0]), T))
    assert error > 100 * CONVERGED  # a stall, not a root
    Q = robot.ik(T).q
    assert len(Q) == 3
    assert missing_roots(model, T, near, Q, DEFAULT_TOLERANCE, 1e-6)  # the chord fails
    assert not missing_roots(model, T, near, Q, DEFAULT_TOLERANCE, 1e-6, along_valley=True)
    assert check_reference(model, reference, T, Q, DEFAULT_TOLERANCE, 1e-6)[0] == "success"
    regular = Q[[k for k, flag in enumerate(robot.ik(T).flags) if "singular" not in flag]]
    outcome, _, names = check_reference(model, reference, T, regular, DEFAULT_TOLERANCE, 1e-6)
    assert outcome == "missing_branch" and names and names[0].startswith("near-root q=(")


@pytest.mark.parametrize("side", [0.9, 1.1])
def test_a_missing_root_is_reported_on_either_side_of_the_convergence_line(
        side: float) -> None:
    """A root of the exact chain moved off it along its Jacobian's strongest direction until
    its error is just below (0.9 x CONVERGED: a root) or just above (1.1 x: a near-root) the
    line: either way, when the IK's answer lacks it, it is reported (the walk along a valley
    does not tie distinct roots); returned, it is matched."""
    from dhkin.validation.multistart import CONVERGED, converged, missing_roots

    robot = dhkin.load("xarm6")
    exact = robot.reference()
    model = target_model(robot, "exact")
    q = np.array([0.3, -0.4, -1.2, 0.5, 0.9, -0.2])
    T = exact.fk(q)
    Q = robot.ik(T).q
    nearest = int(np.argmin(np.abs(Q - q).max(axis=1)))
    root = Q[nearest]
    strongest = np.linalg.svd(exact.jacobian(root))[2][0]

    def error(d: float) -> float:
        return float(max(pose_error(exact.fk(root + d * strongest), T)))

    d = 1e-12 * side * CONVERGED / error(1e-12)
    moved = root + d * strongest
    assert (error(d) < CONVERGED) == (side < 1)
    assert bool(converged(exact, T, moved[None])[0]) == (side < 1)
    others = np.delete(Q, nearest, axis=0)
    along = side > 1  # a near-root is tied along a valley
    lacking = missing_roots(model, T, moved[None], others, DEFAULT_TOLERANCE, 1e-6,
                            along_valley=along)
    assert len(lacking) == 1
    assert not missing_roots(model, T, moved[None], Q, DEFAULT_TOLERANCE, 1e-6,
                             along_valley=along)
