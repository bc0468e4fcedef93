"""Hostile and sloppy input (issue 15): API arguments, URDF input and the command line.

Every bad input is a one-line :class:`dhkin.DhkinError` naming the argument, file or field and
what was expected, or a correct answer; never another exception type, never a traceback from the
command line. The reproducers of the issue come first, then fuzzing with fixed seeds: hostile
arguments to the public API, and mutated, truncated and invented URDFs fed to compare and import.
"""

from __future__ import annotations

import errno
import math
import os
import random
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import dhkin
from dhkin.cli import main
from dhkin.cli_input import EXIT_BROKEN_PIPE, input_error_text
from dhkin.compare import compare_with_urdf
from dhkin.description import MAX_DESCRIPTION_JOINTS, outline_urdf, read_description
from dhkin.errors import DhkinError, FamilyError, InputError, URDFError
from dhkin.vendors import VENDOR_REFERENCES

from .conftest import REFERENCE_URDFS, REPO

NAN = float("nan")
UR5_URDF = REFERENCE_URDFS / "ur5.urdf"


def one_line_error(error: BaseException) -> str:
    """The error's message, checked to be a dhkin error on one line."""
    assert isinstance(error, DhkinError), f"{type(error).__name__}: {error}"
    text = str(error)
    assert "\n" not in text and "\r" not in text, text
    return text


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """`dhkin ARGV` in this process: exit status (argparse's SystemExit too), stdout, stderr."""
    try:
        code = main(list(argv))
    except SystemExit as exit_:
        code = int(exit_.code or 0)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def assert_one_line_usage_error(code: int, err: str, *named: str) -> None:
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for text in named:
        assert text in err, err


def table_file(folder: Path, joints: int) -> Path:
    """A planar table of ``joints`` unit links (name one_r, two_r...)."""
    path = folder / f"chain_{joints}r.yaml"
    rows = "\n".join("  - {a: 1, alpha: 0, d: 0, lower: -180, upper: 180}"
                     for _ in range(joints))
    path.write_text(f"name: chain_{joints}r\nconvention: standard\n"
                    f"units: {{length: m, angle: deg}}\njoints:\n{rows}\n", encoding="utf-8")
    return path


# --------------------------------------------------------------------------------------------
# Reproducers: joint values and other arguments of the public API


@pytest.mark.parametrize("call", ["fk", "jacobian", "manipulability"])
def test_reference_refuses_nan_joint_values(call: str) -> None:
    reference = dhkin.load("ur5").reference()
    with pytest.raises(InputError, match=r"^q: expected .*finite") as caught:
        getattr(reference, call)([0.1, NAN, 0, 0, 0, 0])
    assert caught.value.field == "q"
    one_line_error(caught.value)


@pytest.mark.parametrize("bad", ["0 0 0 0 0 0", ["a"] * 6, [None] * 6, [True] * 6, [1j] * 6,
                                 [[0.0] * 6, [0.0] * 5], {"q": 1}])
@pytest.mark.parametrize("call", ["robot.fk", "fk", "jacobian", "manipulability", "singularity"])
def test_joint_values_that_are_not_real_numbers_are_refused(call: str, bad: Any) -> None:
    robot = dhkin.load("ur5")
    target: Callable[[Any], Any] = (robot.fk if call == "robot.fk" else robot.singularity
                                    if call == "singularity" else
                                    getattr(robot.reference(), call))
    with pytest.raises(InputError) as caught:
        target(bad)
    text = one_line_error(caught.value)
    assert text.startswith("q: expected") and "finite" in text, text


@pytest.mark.parametrize("shape", [(5,), (7,), (2, 5), (2, 2, 6), ()])
def test_joint_values_of_the_wrong_shape_name_the_shape_expected(shape: tuple[int, ...]) -> None:
    robot = dhkin.load("ur5")
    for target in (robot.fk, robot.reference().fk):
        with pytest.raises(InputError, match=r"q: expected shape \(6,\) or \(N, 6\), got "
                                             + re.escape(str(shape))):
            target(np.zeros(shape))
    for single in (robot.reference().jacobian, robot.reference().manipulability,
                   robot.singularity):
        with pytest.raises(InputError, match=r"q: expected 6 finite joint values \(shape "
                                             r"\(6,\)\), got shape"):
            single(np.zeros(shape))


def test_joint_values_that_are_fine_still_work() -> None:
    """Integers, float32, Decimal-like objects, batches and an empty batch are real input."""
    from fractions import Fraction

    robot = dhkin.load("ur5")
    reference = robot.reference()
    expected = robot.fk(np.zeros(6))
    np.testing.assert_allclose(robot.fk([0, 0, 0, 0, 0, 0]), expected, atol=1e-15)
    np.testing.assert_allclose(robot.fk(np.zeros(6, dtype=np.float32)), expected, atol=1e-15)
    np.testing.assert_allclose(robot.fk([Fraction(0)] * 6), expected, atol=1e-15)
    np.testing.assert_allclose(reference.fk(np.zeros((3, 6))), np.stack([expected] * 3),
                               atol=1e-12)
    assert robot.fk(np.zeros((0, 6))).shape == (0, 4, 4)
    assert reference.jacobian(np.zeros(6)).shape == (6, 6)


def test_other_arguments_of_the_reference_are_input_errors() -> None:
    reference = dhkin.load("ur5").reference()
    with pytest.raises(InputError, match=r"frame: expected a frame name \(str\), got 3"):
        reference.fk(np.zeros(6), frame=3)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="reference: expected one of"):
        reference.jacobian(np.zeros(6), reference=None)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="urdf_text: expected the URDF as text"):
        dhkin.reference.Reference(b"<robot/>")  # type: ignore[arg-type]


def test_ik_arguments_are_checked() -> None:
    robot = dhkin.load("ur5")
    T = robot.fk([0.1, -0.5, 0.7, 0.2, 0.4, 0.3])
    cases: list[tuple[Callable[[], Any], str]] = [
        (lambda: robot.ik_batch(T[None], chunk_size=2.5), "chunk_size: expected a positive "
                                                          "integer, got 2.5"),
        (lambda: robot.ik_batch(T[None], chunk_size=True), "chunk_size"),
        (lambda: robot.ik_batch(T[None], workers=-1), "workers"),
        (lambda: robot.ik(T, copies="no"), "copies: expected True or False, got 'no'"),
        (lambda: robot.ik_batch(T[None], copies=1), "copies: expected True or False"),
        (lambda: robot.ik(T, tolerance=NAN), "tolerance: expected a positive finite number"),
        (lambda: robot.ik(T, q_seed="zero"), "q_seed"),
        (lambda: robot.ik(T, q_seed=[NAN] * 6), "q_seed: expected finite values"),
        (lambda: robot.ik(np.full((4, 4), NAN)), "T: expected finite numbers"),
        (lambda: robot.ik("pose"), "T: expected a (4, 4) pose"),
        (lambda: robot.ik(T).nearest([NAN] * 6), "q_now: expected 6 finite joint values"),
    ]
    for call, message in cases:
        with pytest.raises(InputError) as caught:
            call()
        assert message in one_line_error(caught.value)


def test_compare_arguments_are_checked() -> None:
    robot = dhkin.load("ur5")
    for keyword, value, message in (("n", 1.5, "n: expected a positive integer, got 1.5"),
                                    ("n", 0, "n: expected a positive integer, got 0"),
                                    ("seed", -1, "seed: expected a non-negative integer"),
                                    ("tolerance", -1.0, "tolerance: expected a positive"),
                                    ("limit_tolerance", NAN, "limit_tolerance: expected")):
        with pytest.raises(InputError) as caught:
            compare_with_urdf(robot, UR5_URDF, **{keyword: value})
        assert message in one_line_error(caught.value)


# --------------------------------------------------------------------------------------------
# Reproducers: short chains


def test_ik_on_a_one_joint_table_answers(tmp_path: Path) -> None:
    """Numerical IK on a 1-joint arm (no closed form): a reachable pose is solved exactly, an
    unreachable one is empty with its reason (it raised LinAlgError)."""
    robot = dhkin.load(table_file(tmp_path, 1))
    q = np.array([0.3])
    solutions = robot.ik(robot.fk(q))
    assert solutions.numerical and len(solutions) >= 1
    np.testing.assert_allclose(solutions.nearest(q), q, atol=1e-9)
    assert not robot.ik(np.eye(4)) and "did not converge" in robot.ik(np.eye(4)).reason
    _, valid = robot.ik_batch(robot.fk(np.array([[0.3], [-1.0]])))
    assert valid.any(axis=1).all()
    assert robot.reference().jacobian(q).shape == (6, 1)
    with pytest.raises(FamilyError) as caught:
        robot.singularity(q)
    assert "expected 6 joints, got 1" in one_line_error(caught.value)


def test_check_on_a_one_joint_table_reports_without_a_traceback(capsys, tmp_path: Path) -> None:
    path = table_file(tmp_path, 1)
    code, out, err = run(capsys, "check", str(path), "--ik-poses", "10", "--vendor-poses", "10",
                         "--reference-dir", str(tmp_path), "--details")
    assert "Traceback" not in err
    assert "numerical" in out and "wrong 0" in out
    # The table has no generated files next to it: the "generated" column fails, honestly.
    assert code == 1 and "stale" in out


def test_planar_2r_keeps_working(capsys) -> None:
    robot = dhkin.load("planar_2r")
    q = np.array([0.4, -0.9])
    assert np.min(np.linalg.norm(robot.ik(robot.fk(q)).q - q, axis=1)) < 1e-9
    code, out, err = run(capsys, "fk", "planar_2r", "0.4", "-0.9")
    assert code == 0 and "xyz (m)" in out, err
    code, _, err = run(capsys, "singularity", "planar_2r", "0", "0")
    assert code == 2 and err.count("\n") == 1 and "no analytic singularity family" in err


@pytest.mark.parametrize("name", ["planar_2r", "ur5", "stanford_arm"])
def test_family_errors_are_one_line(name: str) -> None:
    from dhkin.opw import opw_parameters

    robot = dhkin.load(name)
    failures: list[BaseException] = []
    for call in (lambda: opw_parameters(robot.table), lambda: robot.ik_solver,
                 lambda: robot.singularity(np.zeros(robot.dof))):
        try:
            call()
        except DhkinError as exc:
            failures.append(exc)
    assert failures or name == "ur5"
    for exc in failures:
        one_line_error(exc)


def test_errors_are_one_line_whatever_they_quote() -> None:
    error = URDFError("file.urdf: Pinocchio says:\n  line one\n\n  line two")
    assert str(error) == "file.urdf: Pinocchio says: line one line two"


# --------------------------------------------------------------------------------------------
# Reproducers: the command line


@pytest.mark.parametrize(("argv", "named"), [
    (["compare", "ur5", str(UR5_URDF), "--seed", "-1"], "--seed: expected an integer >= 0"),
    (["compare", "ur5", str(UR5_URDF), "-n", "1.5"], "-n: expected an integer >= 1"),
    (["compare", "ur5", str(UR5_URDF), "-n", "0"], "-n: expected an integer >= 1"),
    (["compare", "ur5", str(UR5_URDF), "--tolerance", "nan"], "--tolerance: expected a finite"),
    (["compare", "ur5", str(UR5_URDF), "--tolerance", "0"], "number > 0"),
    (["check", "ur5", "--seed", "-3"], "--seed"),
    (["check", "ur5", "--ik-poses", "ten"], "--ik-poses"),
    (["check", "ur5", "--vendor-poses", "-5"], "--vendor-poses"),
    (["fk", "ur5", "0", "0", "0", "0", "0", "inf"], "argument q: expected a finite number"),
    (["ik", "ur5", "--xyz", "0.3", "0.1", "nan"], "--xyz"),
    (["ik", "ur5", "--xyz", "0.3", "0.1", "0.4", "--seed", "0", "0", "0", "0", "0", "x"],
     "--seed"),
    (["singularity", "ur5", "0", "0", "0", "0", "0", "0", "--wrist", "-1"], "--wrist"),
    (["map", "ur5", "-o", "x.png", "--resolution", "0"], "--resolution"),
    (["map", "ur5", "-o", "x.png", "--offset", "inf"], "--offset"),
    (["ik", "ur5", "--xyz", "0.3", "0.1", "0.4", "--matrix", "pose.txt"],
     "--matrix: not allowed with argument --xyz"),
    (["ik", "ur5"], "one of the arguments --xyz --matrix is required"),
])
def test_cli_bad_numbers_and_options_are_one_line_usage_errors(capsys, argv: list[str],
                                                               named: str) -> None:
    code, out, err = run(capsys, *argv)
    assert_one_line_usage_error(code, err, named)
    assert out == ""


def test_cli_seed_zero_and_large_seeds_are_fine(capsys) -> None:
    code, out, err = run(capsys, "compare", "ur5", str(UR5_URDF), "-n", "3", "--seed",
                         str(2**64))
    assert code == 0 and out.startswith("OK"), err


def test_cli_ik_matrix_file_faults(capsys, tmp_path: Path) -> None:
    binary = tmp_path / "pose.bin"
    binary.write_bytes(b"\xff\xfe\x00\x01")
    short = tmp_path / "pose.txt"
    short.write_text("1 0 0\n0 1 0\n0 0 1\n")
    for argv, named in (
            (["--matrix", str(binary)], "--matrix"),
            (["--matrix", str(short)], "expected a 4x4 matrix, got shape (3, 3)"),
            (["--matrix", str(tmp_path)], f"{tmp_path}: Is a directory"),
            (["--matrix", str(short), "--rpy", "0", "0", "0"], "--rpy: applies to --xyz")):
        code, _, err = run(capsys, "ik", "ur5", *argv)
        assert_one_line_usage_error(code, err, named)


def test_cli_broken_pipe_is_quiet(capsys, monkeypatch, tmp_path: Path) -> None:
    """`dhkin fk ... | head`: the reader went away; no traceback, Python's status for it."""

    class ClosedPipe:
        def __init__(self) -> None:
            self.file = (tmp_path / "stdout").open("w")

        def write(self, text: str) -> int:
            raise BrokenPipeError(errno.EPIPE, "Broken pipe")

        def flush(self) -> None:
            raise BrokenPipeError(errno.EPIPE, "Broken pipe")

        def fileno(self) -> int:
            return self.file.fileno()

    pipe = ClosedPipe()
    monkeypatch.setattr(sys, "stdout", pipe)
    code = main(["fk", "ur5", "0", "0", "0", "0", "0", "0"])
    pipe.file.close()
    assert code == EXIT_BROKEN_PIPE
    assert capsys.readouterr().err == ""


def test_cli_broken_pipe_in_a_real_pipe() -> None:
    """The same through a pipe whose reader closed before dhkin wrote (deterministic EPIPE)."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        result = subprocess.run([sys.executable, "-m", "dhkin.cli", "fk", "ur5", "0", "0", "0",
                                 "0", "0", "0"], stdout=write_end, stderr=subprocess.PIPE,
                                text=True, check=False, cwd=REPO)  # the installed dhkin
    finally:
        os.close(write_end)
    assert result.returncode == EXIT_BROKEN_PIPE
    assert result.stderr == ""


@pytest.mark.parametrize(("raised", "expected"), [
    (PermissionError(errno.EACCES, "Permission denied", "/root/table.yaml"),
     "/root/table.yaml: Permission denied"),
    (OSError(errno.ENOSPC, "No space left on device", "out.yaml"),
     "out.yaml: No space left on device"),
    (OSError(errno.EXDEV, "Invalid cross-device link", "a.yaml", None, "b.yaml"),
     "a.yaml -> b.yaml: Invalid cross-device link"),
    (UnicodeDecodeError("utf-8", b"ab\xff", 2, 3, "invalid start byte"),
     "input is not UTF-8 text (byte b'\\xff' at offset 2)"),
    (RecursionError("maximum recursion depth exceeded"), "input nested too deeply"),
    (MemoryError(), "input too large to hold in memory"),
])
def test_cli_input_faults_are_one_line(capsys, monkeypatch, raised: BaseException,
                                       expected: str) -> None:
    def failing(args: Any) -> int:
        raise raised

    monkeypatch.setattr(dhkin.cli, "cmd_fk", failing)
    code, _, err = run(capsys, "fk", "ur5", "0", "0", "0", "0", "0", "0")
    assert code == 2
    assert err == f"dhkin: error: {expected}" + err[len(f"dhkin: error: {expected}"):]
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "\n" not in input_error_text(raised)


# --------------------------------------------------------------------------------------------
# Reproducers: URDF input


def ur5_text() -> str:
    return UR5_URDF.read_text(encoding="utf-8")


def write(folder: Path, name: str, content: str | bytes) -> Path:
    path = folder / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return path


def chain_urdf(joints: int, mimic_at: int | None = None) -> str:
    """A serial chain of ``joints`` revolute joints (link_0 .. link_n)."""
    parts = ["<robot name='chain'>", "<link name='link_0'/>"]
    for i in range(joints):
        mimic = "<mimic joint='joint_0'/>" if i == mimic_at else ""
        parts.append(f"<link name='link_{i + 1}'/><joint name='joint_{i}' type='revolute'>"
                     f"<parent link='link_{i}'/><child link='link_{i + 1}'/>"
                     f"<origin xyz='0 0 0.1'/><axis xyz='0 0 1'/><limit lower='-1' upper='1' "
                     f"effort='1' velocity='1'/>{mimic}</joint>")
    parts.append("</robot>")
    return "\n".join(parts)


URDF_FAULTS: dict[str, tuple[Callable[[str], str | bytes], str]] = {
    "binary": (lambda t: b"\x89PNG\r\n\x1a\n" + bytes(range(256)),
               r"not UTF-8 text \(byte b'\\x89' at offset 0\)"),
    "not XML": (lambda t: "solid robot\nfacet normal 0 0 1\n",
                r"not well-formed XML \(syntax error at line 1, column 1\)"),
    "truncated": (lambda t: t[:t.index("<joint name=\"elbow_joint\"")],
                  r"not well-formed XML \(no element found at line \d+"),
    "no robot": (lambda t: t.replace("<robot name=\"ur5\">", "<model>").replace("</robot>",
                                                                                "</model>"),
                 r"the root element is <model> \(line \d+\); expected <robot>"),
    "no parent": (lambda t: t.replace("<parent link=\"base_link\" />", "", 1),
                  r"joint '[^']+' \(line \d+\) has no <parent link=...>"),
    "no child": (lambda t: t.replace("<child link=\"tool0\" />", "<child/>"),
                 r"joint 'flange-tool0' \(line \d+\) has no <child link=...>"),
    "link twice": (lambda t: t.replace("<link name=\"tool0\" />",
                                       "<link name=\"tool0\" />\n<link name=\"tool0\" />"),
                   r"link 'tool0' is defined twice \(line \d+, column \d+ and line \d+"),
    "joint twice": (lambda t: t.replace("<joint name=\"wrist_3_joint\"",
                                        "<joint name=\"wrist_2_joint\""),
                    r"joint 'wrist_2_joint' \(line \d+\) is defined twice"),
    "unknown link": (lambda t: t.replace("<child link=\"tool0\" />", "<child link=\"tool9\" />"),
                     r"names child link 'tool9', which no <link> defines"),
    "unknown type": (lambda t: t.replace("type=\"revolute\"", "type=\"hinge\"", 1),
                     r"has type 'hinge'; expected one of"),
    "loop": (lambda t: t.replace("</robot>", "<joint name=\"closing\" type=\"fixed\"><parent "
                                 "link=\"wrist_3_link\"/><child link=\"base_link\"/></joint>"
                                 "</robot>"),
             r"kinematic loop closed by joint 'closing' \(line \d+\)"),
    "cycle": (lambda t: t.replace("<child link=\"base_link_inertia\" />",
                                  "<child link=\"base_link\" />"),
              r"kinematic loop closed by joint"),
    "no limit": (lambda t: re.sub(r"<limit [^>]*/>", "", t, count=1),
                 r"Pinocchio cannot build a model \(Joint \[shoulder_pan_joint\] is of type "
                 r"REVOLUTE but it does not specify limits\)"),
    "bad number": (lambda t: t.replace("lower=\"-6.283185307179586\"", "lower=\"abc\"", 1),
                   r"joint 'shoulder_pan_joint' \(line \d+\) limit lower: expected a number, "
                   r"got 'abc'"),
}


@pytest.mark.parametrize("fault", sorted(URDF_FAULTS))
def test_malformed_urdfs_name_their_fault(tmp_path: Path, fault: str) -> None:
    mutate, pattern = URDF_FAULTS[fault]
    content = mutate(ur5_text())
    assert content != ur5_text()
    path = write(tmp_path, "vendor.urdf", content)
    with pytest.raises(URDFError) as caught:
        compare_with_urdf(dhkin.load("ur5"), path, n=3)
    text = one_line_error(caught.value)
    assert text.startswith(f"{path}: ")
    assert re.search(pattern, text), text
    assert "does not contain a valid URDF model" not in text


@pytest.mark.parametrize("fault", ["binary", "not XML", "no parent", "link twice", "loop",
                                   "unknown link"])
def test_import_reports_the_same_faults(tmp_path: Path, fault: str) -> None:
    mutate, pattern = URDF_FAULTS[fault]
    path = write(tmp_path, "vendor.urdf", mutate(ur5_text()))
    with pytest.raises(URDFError) as caught:
        read_description(path)
    text = one_line_error(caught.value)
    assert text.startswith(str(path))
    assert "not UTF-8" in text or "not a URDF (no <robot> element)" in text \
        or re.search(pattern, text), text


def test_urdf_faults_from_the_command_line_are_one_line(capsys, tmp_path: Path) -> None:
    for fault in ("binary", "loop", "no limit"):
        path = write(tmp_path, f"{fault.replace(' ', '_')}.urdf", URDF_FAULTS[fault][0](ur5_text()))
        code, _, err = run(capsys, "compare", "ur5", str(path), "-n", "3")
        assert_one_line_usage_error(code, err, str(path))
        code, _, err = run(capsys, "import", str(path), "-o", str(tmp_path / "out.yaml"))
        assert_one_line_usage_error(code, err, str(path))


def test_the_joint_limit_of_a_description_at_its_edge(tmp_path: Path) -> None:
    """MAX_DESCRIPTION_JOINTS joints are read; one more is refused before Pinocchio builds
    anything (a 1,000-joint file raised MemoryError in compare)."""
    at_limit = outline_urdf(chain_urdf(MAX_DESCRIPTION_JOINTS), "at_limit.urdf")
    assert len(at_limit.joints) == MAX_DESCRIPTION_JOINTS
    reference = dhkin.reference.Reference(chain_urdf(MAX_DESCRIPTION_JOINTS),
                                          tip=f"link_{MAX_DESCRIPTION_JOINTS}")
    assert reference.dof == MAX_DESCRIPTION_JOINTS
    for joints in (MAX_DESCRIPTION_JOINTS + 1, 1000):
        path = write(tmp_path, f"chain_{joints}.urdf", chain_urdf(joints))
        with pytest.raises(URDFError, match=rf"more than {MAX_DESCRIPTION_JOINTS} joints "
                                            rf"\(joint {MAX_DESCRIPTION_JOINTS + 1}, "
                                            rf"'joint_{MAX_DESCRIPTION_JOINTS}', at line \d+\)"):
            compare_with_urdf(dhkin.load("ur5"), path, tip=f"link_{joints}")
        with pytest.raises(URDFError, match="MAX_DESCRIPTION_JOINTS"):
            read_description(path)


def test_a_mimic_joint_on_the_compared_chain_is_refused(tmp_path: Path) -> None:
    text = ur5_text().replace(
        "<joint name=\"wrist_2_joint\" type=\"revolute\">",
        "<joint name=\"wrist_2_joint\" type=\"revolute\">"
        "<mimic joint=\"wrist_1_joint\" multiplier=\"1\"/>")
    path = write(tmp_path, "mimic.urdf", text)
    with pytest.raises(URDFError, match=r"joint 'wrist_2_joint' \(line \d+\) on the chain "
                                        r"base_link -> tool0 mimics 'wrist_1_joint'") as caught:
        compare_with_urdf(dhkin.load("ur5"), path, n=3)
    one_line_error(caught.value)
    # A mimic joint off the compared chain (a gripper finger) is fine.
    finger = text.replace("<mimic joint=\"wrist_1_joint\" multiplier=\"1\"/>", "").replace(
        "</robot>", "<link name=\"finger\"/><joint name=\"finger_joint\" type=\"prismatic\">"
        "<parent link=\"tool0\"/><child link=\"finger\"/><axis xyz=\"1 0 0\"/><limit lower=\"0\" "
        "upper=\"0.04\" effort=\"1\" velocity=\"1\"/><mimic joint=\"wrist_1_joint\"/></joint>"
        "</robot>")
    report = compare_with_urdf(dhkin.load("ur5"), write(tmp_path, "finger.urdf", finger), n=20)
    assert report.ok


def test_reference_urdfs_pass_the_outline() -> None:
    for path in sorted(REFERENCE_URDFS.glob("*.urdf")) + sorted((REPO / "robots").glob("*.urdf")):
        outline = outline_urdf(path.read_text(encoding="utf-8"), str(path))
        assert 1 <= len(outline.joints) <= MAX_DESCRIPTION_JOINTS


# --------------------------------------------------------------------------------------------
# Fuzz: hostile arguments to the public API

HOSTILE_SCALARS: list[Any] = [NAN, math.inf, -math.inf, "abc", "1.5", b"\x00", None, True,
                              False, 1j, 1e308, -1e308, 10**400, -1, 0, 2.5, np.int64(-3),
                              [], {}, object(), np.float64(NAN)]


def hostile_value(rng: random.Random, size: int) -> Any:
    """A random hostile argument: a scalar, a vector of mixed scalars, a wrong shape, a ragged
    list, or (sometimes) a fine value."""
    kind = rng.randrange(7)
    if kind == 0:
        return rng.choice(HOSTILE_SCALARS)
    if kind == 1:
        return [rng.choice(HOSTILE_SCALARS) for _ in range(size)]
    if kind == 2:
        shape = tuple(rng.randrange(0, 8) for _ in range(rng.randrange(0, 4)))
        return np.full(shape, rng.choice([0.0, NAN, 1e300]))
    if kind == 3:
        return [[0.0] * size, [0.0] * (size - 1)]
    if kind == 4:
        return [rng.uniform(-1e3, 1e3) for _ in range(size)]  # fine, if large
    if kind == 5:
        return np.array([rng.choice([0.1, NAN, math.inf])] * size)
    return "".join(rng.choice("0123456789 ,.-[]") for _ in range(rng.randrange(12)))


def outcome(check: Callable[[Any], Any], function: Callable[..., Any], *args: Any,
            **keywords: Any) -> str:
    """``function(*args, **keywords)``: a one-line dhkin error ("error"), or a result that passes
    ``check`` ("result"); any other exception fails the test."""
    try:
        result = function(*args, **keywords)
    except DhkinError as exc:
        one_line_error(exc)
        return "error"
    except Exception as exc:  # the point of the fuzz: nothing else may escape
        raise AssertionError(f"{type(exc).__name__} escaped: {exc}") from exc
    assert check(result) is not False
    return "result"


def no_check(result: Any) -> None:
    """Any result will do (an error would have been one line)."""


def finite_poses(result: Any) -> None:
    assert np.all(np.isfinite(result)) and np.shape(result)[-2:] == (4, 4)


def test_fuzz_joint_value_arguments() -> None:
    rng = random.Random(15)
    robot = dhkin.load("ur5")
    reference = robot.reference()
    outcomes = []
    for _ in range(200):
        q = hostile_value(rng, robot.dof)
        outcomes += [
            outcome(finite_poses, robot.fk, q),
            outcome(finite_poses, reference.fk, q),
            outcome(lambda J: np.all(np.isfinite(J)), reference.jacobian, q),
            outcome(lambda m: math.isfinite(m.yoshikawa), reference.manipulability, q),
            outcome(lambda r: r.sigma_min >= 0, robot.singularity, q),
            outcome(lambda r: r.sigma_min >= 0, robot.singularity, np.full(6, 0.1),
                    rng.choice([hostile_value(rng, 3),
                                {rng.choice(["wrist", "elbow", "knee", 3, None]):
                                 rng.choice(HOSTILE_SCALARS)}])),
        ]
    assert {"error", "result"} <= set(outcomes)


def test_fuzz_ik_and_compare_arguments() -> None:
    rng = random.Random(16)
    robot = dhkin.load("ur5")
    T = robot.fk([0.3, -1.1, 1.2, 0.1, 0.8, -0.4])
    outcomes = []

    def solutions_exact(result: Any) -> None:
        for q in result.q:
            assert np.abs(robot.fk(q) - T).max() < 1e-6

    for _ in range(60):
        seed, tolerance, copies = (hostile_value(rng, 6), rng.choice(HOSTILE_SCALARS),
                                   rng.choice([*HOSTILE_SCALARS, True, False]))
        outcomes.append(outcome(solutions_exact, robot.ik, T, q_seed=seed, tolerance=tolerance,
                                copies=copies))
        pose = hostile_value(rng, 4) if rng.random() < 0.5 else \
            np.where(rng.random() < 0.5, T, np.full((4, 4), rng.choice([NAN, 1e308])))
        outcomes.append(outcome(no_check, robot.ik, pose))
        chunk, workers = rng.choice(HOSTILE_SCALARS), rng.choice([*HOSTILE_SCALARS, None])
        outcomes.append(outcome(no_check, robot.ik_batch, T[None], chunk_size=chunk,
                                workers=workers))
    for _ in range(25):
        keywords = {rng.choice(["n", "seed", "tolerance", "limit_tolerance", "base_frame",
                                "tip"]): rng.choice([*HOSTILE_SCALARS, "", "no_frame"])}
        outcomes.append(outcome(no_check, compare_with_urdf, robot, UR5_URDF,
                                **{"n": 3, **keywords}))
    assert {"error", "result"} <= set(outcomes)


def test_fuzz_map_arguments() -> None:
    from dhkin.maps import joint_slice, workspace_slice

    rng = random.Random(17)
    robot = dhkin.load("ur5")
    outcomes = []
    for _ in range(30):
        keyword = rng.choice(["offset", "rpy", "extent", "plane", "resolution"])
        value = hostile_value(rng, {"rpy": 3, "extent": 2}.get(keyword, 1))
        arguments = {"resolution": 8, keyword: value}
        outcomes.append(outcome(no_check, workspace_slice, robot, **arguments))
        outcomes.append(outcome(no_check, joint_slice, robot, q_fixed=hostile_value(rng, 6),
                                resolution=8))
    assert {"error", "result"} <= set(outcomes)


# --------------------------------------------------------------------------------------------
# Fuzz: hostile URDFs to compare and import


def mutated_urdf(rng: random.Random, text: str) -> str | bytes:
    """One random mutation of a URDF text (see the module docstring)."""
    kind = rng.randrange(9)
    if kind == 0:  # truncated
        return text[:rng.randrange(len(text))]
    if kind == 1:  # random bytes flipped
        data = bytearray(text.encode())
        for _ in range(rng.randrange(1, 6)):
            data[rng.randrange(len(data))] = rng.randrange(256)
        return bytes(data)
    if kind == 2:  # an attribute dropped
        attributes = list(re.finditer(r'\s(name|link|type|joint|lower|upper|xyz|rpy)="[^"]*"',
                                      text))
        drop = rng.choice(attributes)
        return text[:drop.start()] + text[drop.end():]
    if kind == 3:  # an element dropped
        elements = list(re.finditer(r"<(parent|child|limit|axis|origin|link)\b[^>]*/>", text))
        drop = rng.choice(elements)
        return text[:drop.start()] + text[drop.end():]
    if kind == 4:  # a line duplicated
        lines = text.splitlines()
        k = rng.randrange(len(lines))
        return "\n".join(lines[:k + 1] + lines[k:])
    if kind == 5:  # random bytes
        return bytes(rng.randrange(256) for _ in range(rng.randrange(1, 400)))
    if kind == 6:  # deep nesting
        depth = rng.choice([100, 10_000, 100_000])
        return text.replace("</robot>", "<a>" * depth + "</a>" * depth + "</robot>")
    if kind == 7:  # a loop: a joint from a random link to another
        links = re.findall(r'<link name="([^"]+)"', text)
        parent, child = rng.choice(links), rng.choice(links)
        return text.replace("</robot>", f'<joint name="extra" type="fixed"><parent '
                            f'link="{parent}"/><child link="{child}"/></joint></robot>')
    return chain_urdf(rng.choice([0, 1, 6, MAX_DESCRIPTION_JOINTS + 5]),
                      mimic_at=rng.choice([None, 2]))


def test_fuzz_urdfs_in_compare_and_import(tmp_path: Path) -> None:
    rng = random.Random(1515)
    names = ["ur5", "abb_irb1200_7_70", "kuka_kr6r900sixx"]
    texts = {name: (REFERENCE_URDFS / VENDOR_REFERENCES[name].file).read_text(encoding="utf-8")
             for name in names}
    robots = {name: dhkin.load(name) for name in names}
    outcomes = []
    for k in range(200):
        name = rng.choice(names)
        path = write(tmp_path, f"fuzz_{k}.urdf", mutated_urdf(rng, texts[name]))
        vendor = VENDOR_REFERENCES[name]
        outcomes.append(outcome(no_check, compare_with_urdf, robots[name], path,
                                base_frame=vendor.base, tip=vendor.tip, n=3))
        if k % 3 == 0:
            outcomes.append(outcome(no_check, read_description, path))
    assert outcomes.count("error") > 100 and "result" in outcomes


def test_fuzz_urdfs_through_import(tmp_path: Path) -> None:
    """The whole import (fit included) on a few mutations: an error or a table."""
    rng = random.Random(77)
    text = UR5_URDF.read_text(encoding="utf-8")
    outcomes = [outcome(no_check, dhkin.import_description,
                        write(tmp_path, f"import_{k}.urdf", mutated_urdf(rng, text)), tip="tool0")
                for k in range(16)]
    assert {"error", "result"} <= set(outcomes)
