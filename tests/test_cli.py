"""The `dhkin` command line: each subcommand's output and exit status."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import dhkin
from dhkin.checks import longest_first
from dhkin.cli import main
from dhkin.validators import run_check_urdf
from dhkin.vendors import vendor_dir

from .conftest import PER_ROBOT_BUILTINS, REFERENCE_URDFS, REPO


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exit_:  # argparse's usage errors (one line, exit 2)
        code = int(exit_.code or 0)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_console_script_is_installed() -> None:
    """`dhkin --help` runs as a console script of the installed package."""
    exe = Path(sys.executable).parent / "dhkin"
    result = subprocess.run([str(exe), "--help"], capture_output=True, text=True, check=False)
    assert result.returncode == 0
    for command in ("robots", "export", "compare", "fk", "ik", "validate", "singularity", "map",
                    "check"):
        assert command in result.stdout


def test_robots_lists_every_builtin_by_vendor_and_family(capsys) -> None:
    """Each built-in once, under its vendor's heading (dhkin.vendors) and, for the per-robot
    sample (conftest.PER_ROBOT_BUILTINS), its IK family; the last line counts the real arms
    (>= 50, issue 28) and the textbook ones."""
    from dhkin.vendors import VENDOR_REFERENCES

    code, out, _ = run(capsys, "robots")
    assert code == 0
    heading, listed = "", {}
    for line in out.splitlines()[:-1]:
        if line.startswith("  "):
            family, name = line.split()[:2]
            listed[name] = (heading, family)
        else:
            heading = line.split(":")[0]
    names = dhkin.builtin_names()
    assert sorted(listed) == names
    for name in names:
        listed_vendor = VENDOR_REFERENCES[name].vendor if name in VENDOR_REFERENCES else ""
        vendor = listed_vendor or "textbook arms (no vendor)"
        assert listed[name][0] == vendor, name
        if name in PER_ROBOT_BUILTINS:
            assert listed[name][1] == dhkin.load(name).ik_family, name
    real = sum(1 for vendor, _ in listed.values() if vendor != "textbook arms (no vendor)")
    assert real >= 50
    assert out.splitlines()[-1].startswith(f"{real} real arms of ")


def test_export_writes_three_files_that_pass_check_urdf(capsys, tmp_path) -> None:
    """Acceptance: `dhkin export ur5 -o out` writes the three files; check_urdf passes."""
    code, _, _ = run(capsys, "export", "ur5", "-o", str(tmp_path / "out"))
    assert code == 0
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == ["ur5.urdf", "ur5.urdf.xacro", "ur5_macro.xacro"]
    verdict = run_check_urdf(tmp_path / "out" / "ur5.urdf")
    assert verdict.ok, verdict.detail


def test_export_of_a_table_file(capsys, tmp_path) -> None:
    """A table given by path exports under its own name."""
    table = Path(dhkin.__file__).resolve().parent
    source = next(p for p in [table / "robots" / "planar_2r.yaml",
                              table.parents[1] / "robots" / "planar_2r.yaml"] if p.is_file())
    code, _, _ = run(capsys, "export", str(source), "-o", str(tmp_path))
    assert code == 0
    assert (tmp_path / "planar_2r.urdf").is_file()


@pytest.mark.parametrize(("robot", "tip"), [("abb_irb1200_7_70", "tool0"), ("ur5", "tool0"),
                                            ("aubo_i10", "wrist3_Link")])
def test_compare_with_vendor_passes(capsys, robot: str, tip: str) -> None:
    code, out, _ = run(capsys, "compare", robot, str(REFERENCE_URDFS / f"{robot}.urdf"),
                       "--tip", tip, "-n", "200")
    assert code == 0, out
    assert out.startswith("OK:")


def test_compare_with_the_wrong_vendor_fails(capsys) -> None:
    """UR5 against the UR10 file: large deviation, exit status 1."""
    code, out, _ = run(capsys, "compare", "ur5", str(REFERENCE_URDFS / "ur10.urdf"), "-n", "50")
    assert code == 1
    assert out.startswith("FAIL:")


def test_compare_joint_differences_fail_only_with_strict(capsys) -> None:
    """UR3 against its vendor file: the poses agree, the vendor's wrist_3_joint is continuous.
    The difference is listed; exit 0, and 1 with --strict."""
    args = ("compare", "ur3", str(REFERENCE_URDFS / "ur3.urdf"), "-n", "50")
    code, out, _ = run(capsys, *args)
    assert code == 0, out
    assert out.startswith("OK:")
    assert "joint 6 (wrist_3_joint) type: revolute vs continuous" in out
    assert "--strict makes this a failure" in out
    code, out, _ = run(capsys, *args, "--strict")
    assert code == 1, out
    assert "joint 6 (wrist_3_joint) type: revolute vs continuous" in out
    assert "(--strict: FAIL)" in out


def test_compare_strict_passes_on_equal_joints(capsys) -> None:
    code, out, _ = run(capsys, "compare", "ur5", str(REFERENCE_URDFS / "ur5.urdf"), "-n", "50",
                       "--strict")
    assert code == 0, out
    assert "joints: the 6 chain joints have equal names, types, limits and velocities" in out


def test_compare_limit_difference_of_a_table_file(capsys, tmp_path) -> None:
    """A UR5 table file with elbow_joint's upper limit at 179 deg: listed, exit 0; --strict 1."""
    data = yaml.safe_load((REPO / "robots" / "ur5.yaml").read_text(encoding="utf-8"))
    data["joints"][2]["upper"] = 179
    table = tmp_path / "ur5_narrow.yaml"
    table.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    args = ("compare", str(table), str(REFERENCE_URDFS / "ur5.urdf"), "-n", "50")
    code, out, _ = run(capsys, *args)
    assert code == 0, out
    assert "joint 3 (elbow_joint) upper: 3.12413936106985 rad (179 deg) vs 3.141592653589793" in out
    code, _, _ = run(capsys, *args, "--strict")
    assert code == 1


def test_compare_pose_failure_exits_1_with_or_without_strict(capsys) -> None:
    """UR5 against the UR10 file: poses and velocities differ; exit 1 either way."""
    for extra in ((), ("--strict",)):
        code, out, _ = run(capsys, "compare", "ur5", str(REFERENCE_URDFS / "ur10.urdf"), "-n",
                           "50", *extra)
        assert code == 1 and out.startswith("FAIL:"), out
        assert "joint 1 (shoulder_pan_joint) velocity:" in out


def test_compare_and_validate_find_the_shipped_vendor_urdf_from_anywhere(
        capsys, tmp_path, monkeypatch) -> None:
    """Without a URDF, `dhkin compare` uses the robot's vendor URDF shipped with dhkin and its
    frames (AUBO's tip is wrist3_Link), and `validate --reference vendor` the same file; a robot
    without one is a one-line error naming the argument."""
    monkeypatch.chdir(tmp_path)
    code, out, _ = run(capsys, "compare", "aubo_i10", "-n", "50")
    assert code == 0 and out.startswith("OK:"), out
    code, out, _ = run(capsys, "validate", "aubo_i10", "--reference", "vendor", "-n", "10")
    shipped = vendor_dir().resolve() / "aubo_i10.urdf"  # the installed package's copy
    assert code == 0, out
    assert f"reference: vendor {shipped} (base_link -> wrist3_Link)" in out
    for argv, named in ((["compare", "planar_2r"], "urdf: planar_2r has no vendor URDF"),
                        (["validate", "planar_2r", "--reference", "vendor"],
                         "reference (--reference): planar_2r has no vendor URDF")):
        code, _, err = run(capsys, *argv)
        assert code == 2 and named in err and err.count("\n") == 1, err


def test_compare_missing_frame_is_a_clear_error(capsys) -> None:
    code, _, err = run(capsys, "compare", "aubo_i10", str(REFERENCE_URDFS / "aubo_i10.urdf"))
    assert code == 2
    assert "no frame named 'tool0'" in err and "aubo_i10.urdf" in err
    assert "Traceback" not in err


def test_fk_prints_the_pose(capsys) -> None:
    """`dhkin fk` prints base_link -> tool0 equal to Pinocchio's."""
    q = [0.1, -0.5, 0.7, 0.2, 0.3, -0.4]
    code, out, _ = run(capsys, "fk", "ur5", *map(str, q))
    assert code == 0
    robot = dhkin.load("ur5")
    expected = robot.reference().fk(np.array(q))[:3, 3]
    xyz_line = next(line for line in out.splitlines() if line.startswith("xyz"))
    printed = np.array(xyz_line.split("[")[1].split("]")[0].split(), dtype=float)
    assert np.allclose(printed, expected, atol=1e-9)


def test_fk_degrees(capsys) -> None:
    code_deg, out_deg, _ = run(capsys, "fk", "abb_irb1200_7_70", "0", "90", "0", "0", "0", "0",
                               "--deg")
    code_rad, out_rad, _ = run(capsys, "fk", "abb_irb1200_7_70", "0", str(np.pi / 2), "0", "0",
                               "0", "0")
    assert code_deg == code_rad == 0
    assert out_deg.splitlines()[1:5] == out_rad.splitlines()[1:5]


def test_fk_wrong_number_of_values_is_an_error(capsys) -> None:
    code, _, err = run(capsys, "fk", "ur5", "0", "0")
    assert code == 2
    assert "6 joints" in err


def test_unknown_robot_is_an_error_listing_builtins(capsys) -> None:
    code, _, err = run(capsys, "fk", "ur6", "0", "0", "0", "0", "0", "0")
    assert code == 2
    assert "ur6" in err and "ur5" in err


def test_check_named_robot_passes(capsys) -> None:
    """`dhkin check planar_2r` (no vendor, no closed form) prints a passing row."""
    code, out, _ = run(capsys, "check", "planar_2r")
    assert code == 0, out
    assert "planar_2r" in out and "PASS" in out


def test_check_needs_robots_or_all(capsys) -> None:
    code, _, err = run(capsys, "check")
    assert code == 2
    assert "--all" in err


def test_ik_json_round_trip(capsys) -> None:
    """`dhkin ik --json` solutions reproduce the target on Pinocchio."""
    robot = dhkin.load("ur5")
    q = np.array([0.3, -1.1, 1.2, -0.4, 0.9, 0.2])
    T = robot.reference().fk(q)
    from dhkin.transforms import matrix_to_rpy
    code, out, _ = run(capsys, "ik", "ur5", "--xyz", *map(str, T[:3, 3]),
                       "--rpy", *map(str, matrix_to_rpy(T)), "--json")
    assert code == 0
    data = json.loads(out)
    solutions = np.array([s["q"] for s in data["solutions"]])
    assert solutions.shape[0] == 8  # one per branch by default
    poses = robot.reference().fk(solutions)
    assert np.abs(poses - T).max() < 1e-9
    code, out, _ = run(capsys, "ik", "ur5", "--xyz", *map(str, T[:3, 3]),
                       "--rpy", *map(str, matrix_to_rpy(T)), "--json", "--all-copies")
    assert code == 0
    every = np.array([s["q"] for s in json.loads(out)["solutions"]])
    assert len(every) == len(robot.ik(T, copies=True)) > 8
    assert np.abs(robot.reference().fk(every) - T).max() < 1e-9


@pytest.mark.parametrize("command", ["robots", "export", "compare", "fk", "ik", "validate",
                                     "singularity", "map", "check"])
def test_every_subcommand_has_help(capsys, command: str) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    assert "usage: dhkin " + command in capsys.readouterr().out


def test_singularity_prints_the_report(capsys) -> None:
    """At q5 = 0 the IRB 1200 report names the wrist singularity."""
    code, out, _ = run(capsys, "singularity", "abb_irb1200_7_70", "0", "30", "-20", "0", "0", "0",
                       "--deg")
    assert code == 0
    assert "wrist" in out


def test_map_writes_a_png(capsys, tmp_path) -> None:
    path = tmp_path / "planar.png"
    code, _, _ = run(capsys, "map", "abb_irb1200_7_70", "-o", str(path), "--resolution", "12")
    assert code == 0
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------------------------
# validate and check


def test_cli_validate_catches_sign_flip_and_replays(capsys, tmp_path, monkeypatch) -> None:
    """Acceptance: `dhkin validate ur5 --ik tests.broken:sign_flip` exits non-zero with a
    non-zero wrong rate; the failure file reruns with --replay on the reference it records."""
    monkeypatch.chdir(REPO)
    failures = tmp_path / "f.json"
    code, out, _ = run(capsys, "validate", "ur5", "--ik", "tests.broken:sign_flip", "-n", "30",
                       "--reference", "exact", "--failures", str(failures),
                       "--json", str(tmp_path / "r.json"), "--report", str(tmp_path / "r.md"))
    assert code == 1
    assert "wrong 100.000%" in out or "wrong 9" in out
    assert "reference: exact (generated URDF)" in out
    assert json.loads((tmp_path / "r.json").read_text())["rates"]["wrong"] > 0.5
    assert (tmp_path / "r.md").read_text().startswith("# IK validation")
    code, out, _ = run(capsys, "validate", "ur5", "--ik", "tests.broken:sign_flip",
                       "--replay", str(failures), "--failures", str(tmp_path / "g.json"))
    assert code == 1 and "reference: exact" in out
    code, out, _ = run(capsys, "validate", "ur5", "--replay", str(failures))
    assert code == 0, out
    assert "reference: exact" in out


def test_cli_validate_own_ik_passes(capsys) -> None:
    code, out, _ = run(capsys, "validate", "abb_irb1200_7_70", "-n", "50", "--reference", "exact")
    assert code == 0, out
    assert "PASS" in out


def test_cli_validate_defaults_to_the_rounded_reference(capsys, monkeypatch) -> None:
    monkeypatch.chdir(REPO)
    code, out, _ = run(capsys, "validate", "ur5", "--ik", "tests.broken:sign_flip", "-n", "10",
                       "--failures", "/dev/null")
    assert code == 1
    assert "reference: rounded (generated URDF, 10 significant digits)" in out
    for outcome in ("missing_branch", "discontinuous"):
        assert outcome in out


def test_cli_validate_vendor_reference_round_trip(capsys, tmp_path, monkeypatch) -> None:
    """--reference VENDOR.urdf: the report, JSON, Markdown and failure file name it (path and
    frames) and carry the new outcomes; --replay uses the recorded vendor file again."""
    monkeypatch.chdir(REPO)
    files = {name: tmp_path / name for name in ("r.json", "r.md", "f.json", "g.json")}
    code, out, _ = run(capsys, "validate", "ur5", "--ik", "tests.broken:branch_dropped_off_seed",
                       "--reference", "robots/vendor/ur5.urdf", "-n", "50",
                       "--json", str(files["r.json"]), "--report", str(files["r.md"]),
                       "--failures", str(files["f.json"]))
    assert code == 1
    vendor = str((REFERENCE_URDFS / "ur5.urdf").resolve())
    assert f"reference: vendor {vendor} (base_link -> tool0)" in out
    report = json.loads(files["r.json"].read_text())
    assert report["reference"]["kind"] == "vendor" and report["reference"]["path"] == vendor
    assert report["counts"]["missing_branch"] > 0
    assert {"missing_branch", "discontinuous"} <= set(report["rates"])
    assert report["branch_checked"] > 0 and report["continuity_checked"] > 0
    markdown = files["r.md"].read_text()
    assert "| missing_branch |" in markdown and "| discontinuous |" in markdown
    assert f"vendor {vendor} (base_link -> tool0)" in markdown
    failures = json.loads(files["f.json"].read_text())
    assert failures["reference"] == report["reference"]
    recorded = sorted(f["outcome"] for f in failures["failures"])
    assert "missing_branch" in recorded
    code, out, _ = run(capsys, "validate", "ur5", "--ik", "tests.broken:branch_dropped_off_seed",
                       "--replay", str(files["f.json"]), "--json", str(files["g.json"]),
                       "--failures", str(tmp_path / "h.json"))
    assert code == 1
    assert f"reference: vendor {vendor}" in out
    again = json.loads(files["g.json"].read_text())
    assert again["reference"] == report["reference"]
    assert sorted(f["outcome"] for f in again["failures"]) == recorded


def test_cli_validate_vendor_frames(capsys, monkeypatch) -> None:
    """A listed robot's vendor frames are the default (AUBO's file has no tool0); --base and
    --tip choose others, and a wrong one is a clear error naming the option."""
    monkeypatch.chdir(REPO)
    code, out, err = run(capsys, "validate", "aubo_i10", "--ik", "tests.broken:sign_flip",
                         "--reference", "robots/vendor/aubo_i10.urdf", "-n", "10",
                         "--failures", "/dev/null")
    assert code == 1, err
    assert "aubo_i10.urdf (base_link -> wrist3_Link)" in out
    code, out, err = run(capsys, "validate", "aubo_i10", "--ik", "tests.broken:sign_flip",
                         "--reference", "robots/vendor/aubo_i10.urdf", "--tip", "tool0",
                         "-n", "10")
    assert code == 2
    assert "--tip" in err and "no frame named 'tool0'" in err and "Traceback" not in err


@pytest.mark.parametrize(("args", "named"), [
    (["--reference", "no_such_vendor.urdf"], "--reference"),
    (["--reference", "robots/vendor/ur5.urdf", "--base", "floor"], "--base"),
    (["--reference", "exact", "--tip", "tool0"], "--tip"),
    (["-n", "0"], "argument -n: expected an integer >= 1"),
])
def test_cli_validate_bad_arguments(capsys, monkeypatch, args: list[str], named: str) -> None:
    monkeypatch.chdir(REPO)
    code, _, err = run(capsys, "validate", "ur5", *args)
    assert code == 2
    assert named in err and "Traceback" not in err


def test_check_runs_the_vendor_validation(capsys, tmp_path, monkeypatch) -> None:
    """`dhkin check` validates the IK with targets made and solutions checked on the vendor URDF
    too ("ik vs vendor", every failure kind counted), found by default from any directory."""
    monkeypatch.chdir(tmp_path)
    code, out, _ = run(capsys, "check", "abb_irb1200_7_70", "--ik-poses", "40",
                       "--vendor-poses", "40", "--details")
    assert code == 0, out
    lines = out.splitlines()
    assert lines[2].startswith("abb_irb1200_7_70 ") and " PASS " in lines[2]
    vendor = next(line for line in lines if line.startswith("  ik vs vendor"))
    assert "ok" in vendor and "abb_irb1200_7_70.urdf: 48 poses" in vendor
    details = out.split("abb_irb1200_7_70 (spherical_wrist): PASS", 1)[1]
    for count in ("wrong 0", "missing 0", "missing-branch 0", "discontinuous 0"):
        assert details.count(count) == 2, details
    assert max(len(line) for line in lines) <= 100


def test_check_prints_one_line_per_robot_and_writes_every_figure(capsys, tmp_path) -> None:
    """One line per robot (robot, family, verdict, worst residual, completeness, time) within
    100 columns and a summary; --json holds the verdicts, texts, times and figures of every
    check (the validation's counts and residuals among them)."""
    path = tmp_path / "check.json"
    code, out, _ = run(capsys, "check", "planar_3r", "ur5", "--ik-poses", "30",
                       "--vendor-poses", "20", "--json", str(path), "--jobs", "2")
    assert code == 0, out
    lines = out.splitlines()
    assert lines[0].split() == ["robot", "IK", "family", "verdict", "worst", "residual",
                                "complete", "time"]
    planar, ur5 = lines[2].split(), lines[3].split()
    assert planar[:3] == ["planar_3r", "numerical", "PASS"] and planar[4].endswith("%*")
    assert ur5[:3] == ["ur5", "offset_wrist", "PASS"] and ur5[4] == "100.00%"
    assert lines[-1] == "all checks passed" and "2 robot(s) checked in" in out
    assert "2 passed, 0 failed" in out
    written = f"figures written to {path}"  # a path is as long as it is: not wrapped
    assert written in lines
    assert max(len(line) for line in lines if line != written) <= 100
    data = json.loads(path.read_text())
    assert data["passed"] and [r["name"] for r in data["robots"]] == ["planar_3r", "ur5"]
    checks = data["robots"][1]["checks"]
    assert set(checks) == {"generated", "validators", "fk vs pin", "vendor", "ik vs pin",
                           "ik vs vendor"}
    ik = checks["ik vs pin"]
    assert ik["ok"] and ik["seconds"] > 0 and ik["figures"]["samples"] == 36
    assert ik["figures"]["counts"]["wrong"] == 0 and ik["figures"]["completeness"] == 100
    assert ik["figures"]["worst_residual"] == max(ik["figures"]["residuals"]["position_max"],
                                                  ik["figures"]["residuals"]["rotation_max"])
    assert float(ur5[3]) == pytest.approx(data["robots"][1]["worst_residual"], rel=0.06)
    assert data["robots"][0]["checks"]["vendor"] is None  # does not apply: no vendor file
    code, _, err = run(capsys, "check", "planar_3r", "--json", str(path))
    assert code == 2 and "--force" in err  # an existing file with other content stays
    # --jobs 2 (above: a worker process per robot) and --jobs 1 (one by one in this process)
    # give the same lines and figures; only the seconds differ.
    one_by_one = tmp_path / "one_by_one.json"
    code, out_1, _ = run(capsys, "check", "planar_3r", "ur5", "--ik-poses", "30",
                         "--vendor-poses", "20", "--json", str(one_by_one), "--jobs", "1")
    assert code == 0
    assert [line.split()[:5] for line in out_1.splitlines()[2:4]] \
        == [line.split()[:5] for line in lines[2:4]]
    assert _without_seconds(json.loads(one_by_one.read_text())) == _without_seconds(data)


def test_check_starts_the_longest_checks_first_and_prints_in_the_order_named(capsys) -> None:
    """The pool starts the general 6R, numerical and refined robots' checks first
    (dhkin.checks.longest_first); the lines come in the order the robots were named."""
    robots = [dhkin.load(name) for name in ("ur5", "xarm6", "abb_irb1200_7_70",
                                            "ur5e_calibrated", "planar_2r")]
    assert longest_first(robots) == [1, 3, 4, 0, 2]
    code, out, _ = run(capsys, "check", "ur5", "planar_2r", "--ik-poses", "10",
                       "--vendor-poses", "10", "--jobs", "2")
    assert code == 0, out
    assert [line.split()[0] for line in out.splitlines()[2:4]] == ["ur5", "planar_2r"]


def _without_seconds(data: Any) -> Any:
    """``data`` (JSON) without its "seconds" entries, at any depth."""
    if isinstance(data, dict):
        return {key: _without_seconds(value) for key, value in data.items() if key != "seconds"}
    if isinstance(data, list):
        return [_without_seconds(value) for value in data]
    return data


def test_check_without_the_vendor_file_fails_its_columns(capsys, tmp_path) -> None:
    code, out, _ = run(capsys, "check", "ur5", "--reference-dir", str(tmp_path),
                       "--ik-poses", "10", "--vendor-poses", "10")
    assert code == 1
    assert out.count("missing ur5.urdf") == 2
