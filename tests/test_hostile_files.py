"""Issue 15: nothing lost or overwritten, and IK from a read-only install.

Files: every file dhkin writes goes through :mod:`dhkin.files` (atomic, no silent overwrite, no
writing through symbolic links, outputs checked before long runs). A full disk is simulated in
process (the write fails half-way with ENOSPC) and for real in a subprocess under a file size
limit (RLIMIT_FSIZE, SIGXFSZ ignored: the kernel's EFBIG).

Read-only install: the package is copied into a temporary folder and made read-only (chmod -R
a-w); a subprocess runs ``dhkin ik`` with an unusable HOME. As root (who writes anywhere) the
subprocess drops every capability first, so that the kernel enforces the permission bits for it
as for any user; where that is not possible, the subprocess is told the folders are read-only
instead (tempfile.TemporaryFile refuses them, which is how a program tests a folder). Nothing is
compiled at run time: the compiled core is built by ``pip install``.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import dhkin
import dhkin._core
import dhkin.files
import dhkin.maps.draw
from dhkin.builtin import builtin_dir
from dhkin.cli import main
from dhkin.errors import FileWriteError, InputError

from .conftest import REPO

#: A target the UR5 reaches with 8 solutions (the README's example pose): answered by the
#: compiled core, which needs no cache.
IK_ARGS = ("ik", "ur5", "--xyz", "0.4", "0.2", "0.3")
#: A target of the xArm6, answered by the general 6R solver (the compiled core too).
GENERAL_IK_ARGS = ("ik", "xarm6", "--xyz", "0.3", "0.1", "0.3", "--rpy", "180", "0", "0",
                   "--deg")
#: prctl(2) option dropping a capability from the bounding set (linux/prctl.h).
PR_CAPBSET_DROP = 24
#: Highest capability number tried when dropping them all (CAP_LAST_CAP is 40 in Linux 6.x).
LAST_CAPABILITY = 63


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def leftovers(folder: Path) -> list[str]:
    """Temporary files of dhkin.files left in ``folder`` (there must never be any)."""
    return [p.name for p in folder.iterdir() if p.name.endswith(dhkin.files.TEMPORARY_SUFFIX)]


def full_disk_after(monkeypatch: pytest.MonkeyPatch, writes_that_succeed: int,
                    failure: int = errno.ENOSPC) -> None:
    """Make dhkin.files' writes fail like a full disk: the first ``writes_that_succeed`` files
    are written whole, the next one half, then the system says ``failure``."""
    original = dhkin.files._write_all
    count = {"files": 0}

    def failing(fd: int, data: bytes) -> None:
        count["files"] += 1
        if count["files"] <= writes_that_succeed:
            original(fd, data)
            return
        original(fd, data[: len(data) // 2])
        raise OSError(failure, os.strerror(failure))

    monkeypatch.setattr(dhkin.files, "_write_all", failing)


# --------------------------------------------------------------------------------------------
# export


def test_export_keeps_a_hand_edited_file_and_is_idempotent(capsys, tmp_path) -> None:
    out = tmp_path / "out"
    assert run(capsys, "export", "ur5", "-o", str(out))[0] == 0
    urdf = out / "ur5.urdf"
    generated = urdf.read_text()
    written = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert run(capsys, "export", "ur5", "-o", str(out))[0] == 0  # identical: nothing rewritten
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == written
    urdf.write_text(generated + "<!-- hand-edited -->\n")
    code, out_text, err = run(capsys, "export", "ur5", "-o", str(out))
    assert code == 2 and out_text == ""
    assert err.count("\n") == 1 and str(urdf) in err and "--force" in err
    assert urdf.read_text().endswith("<!-- hand-edited -->\n")
    urdf.chmod(0o640)
    assert run(capsys, "export", "ur5", "-o", str(out), "--force")[0] == 0
    assert urdf.read_text() == generated
    assert stat.S_IMODE(urdf.stat().st_mode) == 0o640  # the replaced file's permissions kept
    assert leftovers(out) == []


def test_export_never_writes_through_a_symbolic_link(capsys, tmp_path) -> None:
    out, victim = tmp_path / "out", tmp_path / "victim.txt"
    out.mkdir()
    victim.write_text("precious\n")
    (out / "ur5.urdf").symlink_to(victim)
    for force in ((), ("--force",)):
        code, _, err = run(capsys, "export", "ur5", "-o", str(out), *force)
        assert code == 2 and "symbolic link" in err and str(victim) in err
    assert victim.read_text() == "precious\n"
    assert (out / "ur5.urdf").is_symlink()
    assert sorted(p.name for p in out.iterdir()) == ["ur5.urdf"]  # all or nothing


def test_export_on_a_full_disk_changes_nothing(capsys, tmp_path, monkeypatch) -> None:
    out = tmp_path / "out"
    assert run(capsys, "export", "ur5", "-o", str(out))[0] == 0
    for path in out.iterdir():
        path.write_text(f"earlier {path.name}\n")
    full_disk_after(monkeypatch, writes_that_succeed=1)
    code, _, err = run(capsys, "export", "ur5", "-o", str(out), "--force")
    assert code == 2 and err.count("\n") == 1
    assert "No space left on device" in err and "ur5.urdf.xacro" in err
    assert {p.name: p.read_text() for p in out.iterdir()} == {
        name: f"earlier {name}\n" for name in ("ur5_macro.xacro", "ur5.urdf.xacro", "ur5.urdf")}
    fresh = tmp_path / "new" / "robot"
    assert run(capsys, "export", "ur5", "-o", str(fresh))[0] == 2
    assert not (tmp_path / "new").exists()  # a failed export leaves no folder behind


def test_failed_export_creates_no_folder_and_empty_output_is_a_usage_error(
        capsys, tmp_path, monkeypatch) -> None:
    code, _, err = run(capsys, "export", "planar_2r", "--format", "opw", "-o",
                       str(tmp_path / "new" / "opw"))
    assert code == 2 and "not an OPW arm" in err
    assert list(tmp_path.iterdir()) == []
    monkeypatch.chdir(tmp_path)
    for argv in (["export", "ur5", "-o", ""], ["export", "ur5", "-o", " "],
                 ["map", "ur5", "-o", ""], ["validate", "ur5", "--json", ""],
                 ["validate", "ur5", "--failures", ""], ["import", "x.urdf", "-o", ""]):
        with pytest.raises(SystemExit) as raised:
            main(argv)
        assert raised.value.code == 2
        assert "expected a file or folder name, got an empty string" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(InputError, match="empty string"):
        dhkin.files.write_file("", "text")


def test_export_opw_follows_the_same_rules(capsys, tmp_path) -> None:
    name = "abb_irb1200_7_70"
    path = tmp_path / f"{name}_opw.yaml"
    path.write_text("hand-written\n")
    code, _, err = run(capsys, "export", name, "--format", "opw", "-o", str(tmp_path))
    assert code == 2 and "exists with other content" in err
    assert path.read_text() == "hand-written\n"
    assert run(capsys, "export", name, "--format", "opw", "-o", str(tmp_path), "--force")[0] == 0
    assert path.read_text().startswith("#")


# --------------------------------------------------------------------------------------------
# validate, map


def test_validate_checks_its_outputs_before_the_run(capsys, tmp_path, monkeypatch) -> None:
    def no_run(*args: object, **kwargs: object) -> None:
        raise AssertionError("validate ran although an output cannot be written")

    monkeypatch.setattr("dhkin.validation.validate", no_run)
    existing = tmp_path / "r.json"
    existing.write_text('{"earlier": true}\n')
    link = tmp_path / "r.md"
    link.symlink_to(tmp_path / "elsewhere.md")
    cases = [(["--json", str(tmp_path / "missing" / "r.json")], "does not exist"),
             (["--json", str(existing)], "the file exists"),
             (["--report", str(link)], "symbolic link"),
             (["--failures", str(tmp_path)], "is a folder")]
    for options, message in cases:
        code, _, err = run(capsys, "validate", "ur5", "-n", "10", *options)
        assert code == 2 and message in err and err.count("\n") == 1, err
    assert existing.read_text() == '{"earlier": true}\n'
    assert not (tmp_path / "elsewhere.md").exists()


def test_validate_writes_what_it_found_without_losing_earlier_files(capsys, tmp_path,
                                                                    monkeypatch) -> None:
    """A default failure file never replaces an earlier one (-2 is taken); --json replaces one
    only with --force; a full disk leaves the old failure file whole, and --replay takes it."""
    earlier = tmp_path / "ur5_ik_failures.json"
    earlier.write_text('{"earlier": true}\n')
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(REPO))
    argv = ["validate", "ur5", "--ik", "tests.broken:sign_flip", "-n", "10",
            "--reference", "exact"]
    code, out, _ = run(capsys, *argv, "--json", "r.json")
    assert code == 1 and "failures written to ur5_ik_failures-2.json" in out
    assert earlier.read_text() == '{"earlier": true}\n'
    good = (tmp_path / "ur5_ik_failures-2.json").read_bytes()
    assert json.loads(good)["failures"]
    assert run(capsys, *argv, "--json", "r.json")[0] == 2  # exists: not without --force
    full_disk_after(monkeypatch, writes_that_succeed=1, failure=errno.EFBIG)
    code, _, err = run(capsys, *argv, "--seed", "1", "--json", "r.json", "--force",
                       "--failures", "ur5_ik_failures-2.json")  # other samples: other content
    assert code == 2 and "ur5_ik_failures-2.json" in err and "File too large" in err
    assert (tmp_path / "ur5_ik_failures-2.json").read_bytes() == good
    monkeypatch.undo()
    monkeypatch.chdir(REPO)
    code, out, _ = run(capsys, "validate", "ur5", "--replay",
                       str(tmp_path / "ur5_ik_failures-2.json"))
    assert code == 0 and "reference: exact" in out
    assert leftovers(tmp_path) == []


def test_map_checks_its_output_first_and_needs_force(capsys, tmp_path, monkeypatch) -> None:
    png = tmp_path / "map.png"
    png.write_bytes(b"an earlier map")
    original = dhkin.maps.draw.workspace_slice

    def counted(*args: object, **kwargs: object) -> object:
        calls.append(1)
        return original(*args, **kwargs)

    calls: list[int] = []
    monkeypatch.setattr(dhkin.maps.draw, "workspace_slice", counted)
    argv = ["map", "abb_irb1200_7_70", "-o", str(png), "--resolution", "12",
            "--joint-resolution", "12"]
    code, _, err = run(capsys, *argv)
    assert code == 2 and "the file exists" in err and calls == []
    assert png.read_bytes() == b"an earlier map"
    assert run(capsys, *argv, "--force")[0] == 0
    assert png.read_bytes().startswith(b"\x89PNG") and calls == [1]


# --------------------------------------------------------------------------------------------
# dhkin.files itself


def test_write_table_and_write_file_rules(tmp_path) -> None:
    table = dhkin.load("planar_2r").table
    path = dhkin.write_table(table, tmp_path / "arm.yaml")
    text = path.read_text()
    assert dhkin.write_table(table, path) == path  # identical: fine
    path.write_text(text + "# a note\n")
    with pytest.raises(InputError, match="exists with other content"):
        dhkin.write_table(table, path)
    assert path.read_text().endswith("# a note\n")
    dhkin.write_table(table, path, force=True)
    assert path.read_text() == text
    dhkin.files.write_file(os.devnull, "discarded")  # a device is written into, not replaced
    assert stat.S_ISCHR(os.stat(os.devnull).st_mode)
    (tmp_path / "link.yaml").symlink_to(path)
    with pytest.raises(InputError, match="symbolic link"):
        dhkin.write_table(table, tmp_path / "link.yaml", force=True)
    with pytest.raises(InputError, match="does not exist"):
        dhkin.files.write_file(tmp_path / "missing" / "a.txt", "text")
    assert dhkin.files.unused_name(path, "other") == tmp_path / "arm-2.yaml"
    assert dhkin.files.unused_name(path, text) == path
    assert leftovers(tmp_path) == []


def _limited(limit: int) -> Callable[[], None]:
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


def test_a_file_size_limit_leaves_the_old_file_whole(tmp_path) -> None:
    """The reproducer for real: a 53 KB file, rewritten under a 20 KB file size limit."""
    target = tmp_path / "failures.json"
    good = json.dumps({"failures": ["x" * 100] * 500}).encode()
    target.write_bytes(good)
    script = ("import sys\nfrom dhkin.errors import DhkinError\nfrom dhkin.files import "
              "write_file\ntry:\n    write_file(sys.argv[1], 'y' * 60_000, force=True)\n"
              "except DhkinError as exc:\n    print(exc)\n    sys.exit(2)\n")
    result = subprocess.run([sys.executable, "-c", script, str(target)], capture_output=True,
                            text=True, preexec_fn=_limited(20_000), timeout=120,
                            env={**os.environ, "PYTHONPATH": str(Path(dhkin.__file__).parents[1])})
    assert result.returncode == 2, result.stderr
    assert f"{target}: cannot write the file (File too large)" in result.stdout
    assert target.read_bytes() == good and len(good) > 50_000
    assert leftovers(tmp_path) == []


def test_file_write_error_is_an_os_error_naming_the_file(tmp_path, monkeypatch) -> None:
    full_disk_after(monkeypatch, writes_that_succeed=0)
    with pytest.raises(FileWriteError) as raised:
        dhkin.files.write_file(tmp_path / "a.txt", "text")
    assert isinstance(raised.value, OSError) and raised.value.errno == errno.ENOSPC
    assert str(raised.value) == (f"{tmp_path / 'a.txt'}: cannot write the file (No space left "
                                 "on device); nothing was changed")
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------------------------
# IK from a read-only install, for real


def _drop_capabilities() -> None:
    """In the child, before exec: empty the capability bounding set, so that root keeps no
    capability across exec and the kernel checks permission bits for it as for anyone."""
    prctl = ctypes.CDLL(None, use_errno=True).prctl
    for capability in range(LAST_CAPABILITY + 1):
        prctl(PR_CAPBSET_DROP, capability, 0, 0, 0)


#: Run first in the child where the kernel does not enforce the read-only folders (see the
#: module docstring): tempfile.TemporaryFile, the usual test of a folder, refuses them.
SIMULATED_READ_ONLY = """
import sys, tempfile
read_only = tuple(sys.argv.pop(1).split("|"))
_temporary_file = tempfile.TemporaryFile
def refusing(*args, dir=None, **kwargs):
    if dir is not None and str(dir).startswith(read_only):
        raise PermissionError(13, "Permission denied", str(dir))
    return _temporary_file(*args, dir=dir, **kwargs)
tempfile.TemporaryFile = refusing
"""
#: The child: optionally a temporary folder of its own (tempfile.tempdir), then dhkin's CLI.
CHILD = """
import sys, tempfile
tempfile.tempdir = sys.argv.pop(1) or None
from dhkin.cli import main
sys.exit(main(sys.argv[1:]))
"""


class ReadOnlyInstall:
    """A copy of the package made read-only, and how to run a restricted process on it."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.site = root / "site"
        shutil.copytree(Path(dhkin.__file__).parent, self.site / "dhkin",
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        core = Path(dhkin._core.__file__)  # beside the sources, or in an editable install's build
        if not (self.site / "dhkin" / core.name).exists():
            shutil.copy2(core, self.site / "dhkin" / core.name)
        shutil.copytree(builtin_dir(), self.site / "dhkin" / "robots", dirs_exist_ok=True)
        self.no_home = root / "read-only" / "home"  # in a folder nobody may write
        self.temporary = root / "tmp"
        self.temporary.mkdir(mode=0o777)
        (root / "read-only").mkdir()
        for path in (root / "read-only", self.site):
            subprocess.run(["chmod", "-R", "a-w", str(path)], check=True)
        root.chmod(0o755)
        self.enforced = self._enforced()

    def _restrict(self) -> Callable[[], None] | None:
        return _drop_capabilities if os.geteuid() == 0 else None

    def _enforced(self) -> bool:
        probe = subprocess.run([sys.executable, "-c", "import sys; open(sys.argv[1], 'w')",
                                str(self.site / "probe")], preexec_fn=self._restrict(),
                               capture_output=True, timeout=60)
        return probe.returncode != 0

    def run(self, *argv: str, temporary: Path | None = None,
            env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
        code = CHILD
        args = [str(temporary or self.temporary), *argv]
        if not self.enforced:
            code = SIMULATED_READ_ONLY + CHILD
            args.insert(0, f"{self.site}|{self.root / 'read-only'}")
        environment = {"PATH": os.environ.get("PATH", ""), "PYTHONPATH": str(self.site),
                       "HOME": str(self.no_home), **(env or {})}
        return subprocess.run([sys.executable, "-c", code, *args], env=environment,
                              capture_output=True, text=True, preexec_fn=self._restrict(),
                              timeout=900)


@contextlib.contextmanager
def _removable(root: Path) -> Iterator[Path]:
    try:
        yield root
    finally:
        subprocess.run(["chmod", "-R", "u+w", str(root)], check=False)
        shutil.rmtree(root, ignore_errors=True)


@pytest.fixture
def read_only_root() -> Iterator[Path]:
    with _removable(Path(tempfile.mkdtemp(prefix="dhkin-read-only-"))) as root:
        yield root


def test_ik_from_a_read_only_install(read_only_root) -> None:
    """`dhkin ik` from a read-only package with no usable HOME: the closed-form IK and the
    general 6R solver (both in the compiled core) answer, and write nothing anywhere."""
    install = ReadOnlyInstall(read_only_root / "first")
    first = install.run(*IK_ARGS)
    assert first.returncode == 0, first.stderr
    assert first.stdout.startswith("8 solutions") and first.stderr == ""
    general = install.run(*GENERAL_IK_ARGS)
    assert general.returncode == 0 and "solutions" in general.stdout, general.stderr
    assert general.stderr == ""
    assert list(install.temporary.iterdir()) == []  # nothing compiled, nothing cached
