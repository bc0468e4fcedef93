"""Cross-validation of IK callables against Pinocchio: our IK passes, broken IKs are caught."""

from __future__ import annotations

import json

import numpy as np
import pytest

import dhkin
from dhkin.cli import main
from dhkin.transforms import invert
from dhkin.validate import (
    OUTCOMES,
    ValidationInputError,
    adapt,
    load_ik,
    replay,
    sample_joint_vectors,
    validate,
    write_failures,
)

from . import broken

N = 200  # uniform samples per run, plus 20 special-angle and 20 near-singular ones


@pytest.fixture(scope="module")
def ur5() -> dhkin.Robot:
    return dhkin.load("ur5")


@pytest.fixture(scope="module")
def abb() -> dhkin.Robot:
    return dhkin.load("abb_irb1200_7_70")


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


@pytest.mark.parametrize("name", ["ur5", "aubo_i10", "abb_irb1200_7_70", "anthropomorphic_arm"])
def test_our_ik_passes(name: str) -> None:
    """dhkin's own IK: zero wrong, zero missing, zero without solution on every set."""
    report = validate(dhkin.load(name), n=N, seed=1)
    assert report.ok, report.summary()
    assert report.counts["success"] == report.samples == N + 2 * (N // 10)
    assert set(report.by_set) == {"uniform", "special", "near_singular"}
    assert report.residuals["position_max"] <= 1e-9
    assert report.residuals["rotation_max"] <= 1e-9
    assert report.solution_counts["min"] >= 1
    assert report.by_configuration, "samples are labelled with their configuration"


def test_sign_flip_is_caught_as_wrong(ur5: dhkin.Robot) -> None:
    report = validate(ur5, broken.sign_flip, n=N, seed=2)
    assert not report.ok
    assert report.rate("wrong") > 0.5
    assert report.residuals["position_max"] > 1e-3


def test_dropped_branch_is_caught_as_missing(ur5: dhkin.Robot) -> None:
    """Every returned solution is exact, so nothing is wrong, but some samples are missing."""
    report = validate(ur5, broken.dropped_branch, n=N, seed=2)
    assert report.counts["wrong"] == 0
    assert report.rate("missing") > 0.02
    # Away from singularities the missing samples are exactly those on the dropped branch (at
    # special angles and near q5 = 0 branches merge, so their labels are not unique there).
    missing_labels = {f.configuration for f in report.failures if f.sample_set == "uniform"}
    first = " ".join(f"{k}={v}" for k, v in ur5.ik_solver.branch_labels[0].items())
    assert missing_labels == {first}


@pytest.mark.parametrize("name", ["ur5", "abb_irb1200_7_70"])
def test_wrong_wrist_split_is_caught_only_at_the_singularity(name: str) -> None:
    report = validate(dhkin.load(name), broken.wrong_wrist_split, n=N, seed=2)
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
                      n=N, seed=2)
    assert report.ok, report.summary()


def test_tool_frame_adapter(ur5: dhkin.Robot) -> None:
    """An IK that solves for the flange frame passes once adapted with tool0 -> flange."""
    reference = ur5.reference()
    tool0_to_flange = invert(reference.fk(np.zeros(6), "tool0")) @ reference.fk(np.zeros(6),
                                                                                 "flange")

    def flange_ik(T_flange: np.ndarray, q_seed: np.ndarray | None = None) -> np.ndarray:
        return ur5.ik(T_flange @ invert(tool0_to_flange), q_seed=q_seed).q

    assert not validate(ur5, flange_ik, n=20, seed=4).ok
    assert validate(ur5, adapt(flange_ik, tool=tool0_to_flange), n=N, seed=4).ok


def test_failure_file_replays_the_same_failures(ur5: dhkin.Robot, tmp_path) -> None:
    report = validate(ur5, broken.dropped_branch, n=N, seed=5)
    path = write_failures(report, tmp_path / "failures.json")
    data = json.loads(path.read_text())
    assert data["robot"] == "ur5" and len(data["failures"]) == len(report.failures)
    first = data["failures"][0]
    assert {"q_sampled", "target", "returned", "position_errors", "outcome"} <= set(first)
    again = replay(ur5, broken.dropped_branch, path)
    assert again.samples == len(report.failures)
    assert [f.outcome for f in again.failures] == [f.outcome for f in report.failures]
    assert again.counts["missing"] > 0
    fixed = replay(ur5, lambda T: ur5.ik(T).q, path)
    assert fixed.ok


def test_rates_add_up(ur5: dhkin.Robot) -> None:
    report = validate(ur5, broken.wrong_wrist_split, n=50, seed=6)
    assert sum(report.counts[o] for o in OUTCOMES) == report.samples
    assert "FAIL" in report.summary() and "# IK validation" in report.markdown()


def test_bad_arguments_are_clear_errors(ur5: dhkin.Robot, tmp_path) -> None:
    with pytest.raises(ValidationInputError, match="module:function"):
        load_ik("tests.broken.sign_flip")
    with pytest.raises(ValidationInputError, match="cannot import module"):
        load_ik("no_such_module_xyz:ik")
    with pytest.raises(ValidationInputError, match="no callable"):
        load_ik("tests.broken:no_such_function")
    with pytest.raises(ValidationInputError, match="at least 1 sample"):
        validate(ur5, n=0)
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    with pytest.raises(ValidationInputError, match="not a dhkin failure file"):
        replay(ur5, broken.sign_flip, bad)


def test_cli_validate_catches_sign_flip_and_replays(capsys, tmp_path, monkeypatch) -> None:
    """Acceptance: `dhkin validate ur5 --ik tests.broken:sign_flip` exits non-zero with a
    non-zero wrong rate; the failure file reruns with --replay."""
    from .conftest import REPO

    monkeypatch.chdir(REPO)
    failures = tmp_path / "f.json"
    code = main(["validate", "ur5", "--ik", "tests.broken:sign_flip", "-n", "30",
                 "--failures", str(failures), "--json", str(tmp_path / "r.json"),
                 "--report", str(tmp_path / "r.md")])
    out = capsys.readouterr().out
    assert code == 1
    assert "wrong 100.000%" in out or "wrong 9" in out
    assert json.loads((tmp_path / "r.json").read_text())["rates"]["wrong"] > 0.5
    assert (tmp_path / "r.md").read_text().startswith("# IK validation")
    code = main(["validate", "ur5", "--ik", "tests.broken:sign_flip", "--replay", str(failures),
                 "--failures", str(tmp_path / "g.json")])
    assert code == 1
    code = main(["validate", "ur5", "--replay", str(failures)])
    assert code == 0


def test_cli_validate_own_ik_passes(capsys) -> None:
    code = main(["validate", "abb_irb1200_7_70", "-n", "50"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "PASS" in out


def test_seedless_ik_at_the_wrist_singularity(abb: dhkin.Robot) -> None:
    """Without q_seed, a correct IK passes at q5 = 0 (only q4 + q6 is determined there), and a
    dropped shoulder branch is still caught there."""
    report = validate(abb, lambda T: abb.ik(T).q, n=N, seed=7)
    assert report.ok, report.summary()

    def without_righty(T: np.ndarray) -> np.ndarray:
        solutions = abb.ik(T)
        keep = [k for k, c in enumerate(solutions.configurations)
                if c.labels["shoulder"] != "righty"]
        return solutions.q[keep]

    dropped = validate(abb, without_righty, n=N, seed=7)
    assert dropped.by_set["near_singular"].get("missing", 0) > 0


def test_joint_tolerance_follows_the_conditioning(abb: dhkin.Robot) -> None:
    """Away from singularities the missing check uses joint_tolerance; at |q5| = 1e-10 the pose
    resolves q only to ~1e-14 / sigma_min, and the check allows that much, no more."""
    from dhkin.validate import POSE_ROUNDING, _resolvable

    generic = np.array([0.3, 0.2, -0.4, 0.5, 0.9, -0.2])
    assert _resolvable(abb, generic, 1e-6) == pytest.approx(1e-6, rel=1e-6)
    near = generic.copy()
    near[4] = 1e-10
    sigma_min = np.linalg.svd(abb.reference().jacobian(near), compute_uv=False).min()
    assert sigma_min < 1e-9
    assert _resolvable(abb, near, 1e-6) == pytest.approx(1e-6 + POSE_ROUNDING / sigma_min)
    assert _resolvable(abb, near, 1e-6) < 1e-2
