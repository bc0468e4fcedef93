"""The README's two set-up commands stay true: CI runs exactly the README's test command."""

from __future__ import annotations

from .conftest import REPO


def _readme_commands() -> list[str]:
    text = (REPO / "README.md").read_text(encoding="utf-8")
    setup = text.split("## Set-up", 1)[1].split("\n## ", 1)[0]
    blocks = setup.split("```bash\n")[1:]
    return [block.split("```", 1)[0].strip() for block in blocks]


def test_readme_has_exactly_two_setup_commands() -> None:
    commands = _readme_commands()
    assert len(commands) == 2
    assert commands[0].endswith("dhkin check --all")
    assert "pytest" in commands[1]


def test_ci_runs_the_readme_test_command() -> None:
    ci_lines = [line for line in (REPO / ".ci" / "run").read_text().splitlines()
                if line and not line.startswith("#")]
    assert ci_lines[-1] == _readme_commands()[1]


def test_readme_counts_the_builtin_robots() -> None:
    """The README's count of built-in robots, real arms, vendors' package arms and textbook arms
    is the library's (dhkin.vendors: a real arm has a vendor reference naming its maker)."""
    import re

    import dhkin
    from dhkin.vendors import PACKAGE_ARMS, VENDOR_REFERENCES

    text = " ".join((REPO / "README.md").read_text(encoding="utf-8").split())
    counts = re.search(r"(\d+) robots are built in .*?: (\d+) real arms of .*? \((\d+) of them "
                       r"imported from the ROS-Industrial support packages\) and (\d+) textbook",
                       text)
    assert counts is not None
    names = dhkin.builtin_names()
    real = [name for name in names if name in VENDOR_REFERENCES and VENDOR_REFERENCES[name].vendor]
    assert tuple(int(count) for count in counts.groups()) \
        == (len(names), len(real), len(PACKAGE_ARMS), len(names) - len(real))
