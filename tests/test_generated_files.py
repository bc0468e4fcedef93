"""The committed xacro/URDF artefacts in robots/ are exactly what regeneration gives."""

from __future__ import annotations

import subprocess
import sys

import pytest

import dhkin
from dhkin.urdf import generate

from .conftest import REPO

ROBOTS_DIR = REPO / "robots"
TABLES = sorted(p.stem for p in ROBOTS_DIR.glob("*.yaml"))


def test_every_table_is_a_builtin_robot() -> None:
    """The package finds the same built-in robots as the repository holds."""
    assert dhkin.builtin_names() == TABLES
    assert len(TABLES) >= 9


@pytest.mark.parametrize("name", TABLES)
def test_committed_files_equal_regeneration(name: str) -> None:
    """robots/<name>_macro.xacro, <name>.urdf.xacro and <name>.urdf equal a fresh generation."""
    table = dhkin.load_table(ROBOTS_DIR / f"{name}.yaml")
    generated = generate(table).as_dict()
    assert sorted(generated) == sorted([f"{name}_macro.xacro", f"{name}.urdf.xacro",
                                        f"{name}.urdf"])
    for file_name, text in generated.items():
        committed = (ROBOTS_DIR / file_name).read_text(encoding="utf-8")
        assert committed == text, f"{file_name} is stale: run python scripts/regenerate.py"


def test_no_stray_generated_files() -> None:
    """Every file in robots/ belongs to a table (no leftovers of renamed robots); vendor/ holds
    the vendor references the built-ins are checked against."""
    expected = {f"{n}{suffix}" for n in TABLES
                for suffix in (".yaml", "_macro.xacro", ".urdf.xacro", ".urdf")} | {"vendor"}
    assert {p.name for p in ROBOTS_DIR.iterdir()} == expected


def test_regenerate_script_check_mode_passes() -> None:
    """scripts/regenerate.py --check agrees that nothing is stale."""
    result = subprocess.run([sys.executable, str(REPO / "scripts" / "regenerate.py"), "--check"],
                            capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 file(s) stale" in result.stdout


def test_generation_is_deterministic_and_path_free(tmp_path) -> None:
    """Generating twice gives identical text, and no temporary path leaks into the URDF."""
    table = dhkin.load("ur5").table
    first, second = generate(table).urdf, generate(table).urdf
    assert first == second
    assert "/tmp" not in first and "dhkin-xacro-" not in first
