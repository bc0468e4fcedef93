"""The guide and the reference keep telling the truth: the README's and the docs' examples run
and print what they show, and the docs site builds with warnings as errors.

Every fenced block of README.md and docs/*.md names its kind, and each kind is either run or
says it is not an example:

* ``pycon``: Python with ``>>>`` prompts and the output, run by doctest;
* ``python``: Python without output, run as it stands;
* ``console``: ``$ dhkin ...`` commands, each followed by what it prints to stdout, run
  through ``dhkin.cli.main``; its exit status is 0 unless the line ends ``# exit N``;
* ``yaml``: a DH table file, loaded by ``dhkin.load_table``;
* ``text``: formulas, diagrams and recorded output of long runs (benchmarks): not examples;
* ``bash``: only the README's two set-up commands (tests/test_readme.py ties them to CI).

In expected output ``...`` stands for any text (doctest's ELLIPSIS): times, absolute paths,
rounding noise. The blocks of one file run in order from a scratch folder that looks like the
repository root (robots/, tests/ and docs/ linked), so files an example writes stay there.
"""

from __future__ import annotations

import contextlib
import doctest
import io
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

import dhkin
from dhkin.cli import main

from .conftest import REPO

PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
RUN = ("pycon", "python", "console", "yaml")
NOT_RUN = ("text",)
README_LINES = 150
_FENCE = re.compile(r"^(\s*)```(\S*)(?:\s.*)?$")
_EXIT = re.compile(r"#\s*exit (\d+)\s*$")
_CHECKER = doctest.OutputChecker()


@dataclass(frozen=True)
class Block:
    kind: str
    text: str
    line: int  # of the opening fence, 1-based


def blocks(path: Path) -> list[Block]:
    """The fenced blocks of a Markdown file (indented ones in lists too)."""
    found: list[Block] = []
    opened: tuple[str, str, int] | None = None
    body: list[str] = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        match = _FENCE.match(line)
        if opened is None:
            if match:
                opened, body = (match.group(1), match.group(2), number), []
            continue
        if match and line.strip() == "```" and line.startswith(opened[0]):
            indent = len(opened[0])
            found.append(Block(opened[1], "\n".join(b[indent:] for b in body) + "\n", opened[2]))
            opened = None
        else:
            body.append(line)
    assert opened is None, f"{path.name}:{opened[2] if opened else 0}: a block is never closed"
    return found


def _dhkin(argv: list[str]) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exit_:  # argparse's own exits
            code = int(exit_.code or 0)
    return code, out.getvalue() + (err.getvalue() if code == 2 else "")


def run_console(block: Block, where: str) -> None:
    commands: list[tuple[str, list[str]]] = []
    for line in block.text.splitlines():
        if line.startswith("$ "):
            commands.append((line[2:], []))
        else:
            assert commands, f"{where}: output before the first $ command"
            commands[-1][1].append(line)
    assert commands, f"{where}: a console block without a $ command"
    for command, expected in commands:
        argv = shlex.split(command, comments=True)
        assert argv[0] == "dhkin", f"{where}: only dhkin commands run here: {command}"
        status = _EXIT.search(command)
        code, got = _dhkin(argv[1:])
        want = "\n".join(expected) + "\n" if expected else ""
        assert code == (int(status.group(1)) if status else 0), (
            f"{where}: {command}: exit status {code}\n{got}")
        assert _CHECKER.check_output(want, got, doctest.ELLIPSIS), (
            f"{where}: {command}\n" + _CHECKER.output_difference(
                doctest.Example(command, want), got, doctest.ELLIPSIS))


def run_pycon(block: Block, where: str, namespace: dict[str, Any]) -> None:
    parser = doctest.DocTestParser()
    test = parser.get_doctest(block.text, namespace, where, where, block.line)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    report = io.StringIO()
    runner.run(test, out=report.write, clear_globs=False)
    namespace.update(test.globs)  # DocTest ran on a copy: the next block sees these names
    assert runner.failures == 0, report.getvalue()


def run_block(block: Block, where: str, namespace: dict[str, Any], folder: Path) -> None:
    if block.kind == "pycon":
        run_pycon(block, where, namespace)
    elif block.kind == "python":
        exec(compile(block.text, where, "exec"), namespace)
    elif block.kind == "console":
        run_console(block, where)
    elif block.kind == "yaml":
        path = folder / f"example_{block.line}.yaml"
        path.write_text(block.text, encoding="utf-8")
        assert dhkin.load_table(path).dof > 0


@pytest.fixture
def repository_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    for name in ("robots", "tests", "docs"):
        (tmp_path / name).symlink_to(REPO / name, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_every_example_runs_and_prints_what_it_shows(page: Path, repository_root: Path) -> None:
    namespace: dict[str, Any] = {"__name__": "__example__"}
    setup_commands = 0
    for block in blocks(page):
        where = f"{page.relative_to(REPO)}:{block.line}"
        if block.kind == "bash" and page.name == "README.md":
            setup_commands += 1  # tests/test_readme.py and .ci/run tie them
            continue
        if block.kind.startswith("{"):
            continue  # a MyST directive ({toctree}, {include}): Sphinx checks it
        assert block.kind in RUN + NOT_RUN, (
            f"{where}: a ```{block.kind or ''} block: write pycon, python, console or yaml to "
            "run it, text for what is not an example")
        if block.kind in RUN:
            run_block(block, where, namespace, repository_root)
    assert setup_commands == (2 if page.name == "README.md" else 0)


def test_the_block_reader_finds_indented_blocks_and_refuses_unknown_kinds(tmp_path) -> None:
    """The reader above can fail: it finds a block indented in a list, keeps its kind, and an
    unclosed block is an error."""
    page = tmp_path / "page.md"
    page.write_text("* item:\n\n  ```console\n  $ dhkin robots\n  ...\n  ```\n\n```sh\nls\n```\n")
    found = blocks(page)
    assert [(b.kind, b.text, b.line) for b in found] == [
        ("console", "$ dhkin robots\n...\n", 3), ("sh", "ls\n", 8)]
    page.write_text("```text\nnever closed\n")
    with pytest.raises(AssertionError, match="never closed"):
        blocks(page)


def test_a_console_example_that_prints_something_else_fails(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    wrong = Block("console", "$ dhkin export ur5 -o out\nout/ur6.urdf\n", 1)
    with pytest.raises(AssertionError, match="ur6"):
        run_console(wrong, "example")
    with pytest.raises(AssertionError, match="exit"):  # a failing command needs its # exit 1
        run_console(Block("console", f"$ dhkin compare ur5 {REPO}/robots/vendor/ur10.urdf -n 5"
                                     "\n...\n", 1), "example")


def test_readme_is_a_guide_not_a_dump() -> None:
    lines = (REPO / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_LINES, f"README.md has {len(lines)} lines (at most {README_LINES})"


def test_the_docs_site_builds_with_warnings_as_errors(tmp_path: Path) -> None:
    """Sphinx (with MyST and autodoc) builds docs/ to HTML; any warning fails the build: a
    broken link or reference, a docstring that is not valid reStructuredText, a page outside the
    table of contents."""
    build = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         "-d", str(tmp_path / "doctrees"), str(REPO / "docs"), str(tmp_path / "html")],
        capture_output=True, text=True, check=False)
    assert build.returncode == 0, build.stderr[-6000:]
    assert (tmp_path / "html" / "api.html").is_file()
