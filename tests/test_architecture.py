"""The package's layers, read from its import statements (ast): no circles, no upward imports.

Layers, lowest first (docs/architecture.md): a module may import modules of its own layer or of
lower ones. Every import counts, at module level or inside a function, under ``TYPE_CHECKING`` or
not: an import hidden in a function is still a dependency. Every module of ``src/dhkin`` must be
placed in a layer, so a new module is placed on purpose.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

from .conftest import REPO

SOURCE = REPO / "src"
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("foundation", ("dhkin._core", "dhkin.errors", "dhkin.transforms", "dhkin.dh",
                    "dhkin.table_file",
                    "dhkin.table_yaml", "dhkin.table_values",
                    "dhkin.reference", "dhkin.urdf", "dhkin.validators", "dhkin.vendors",
                    "dhkin.fit", "dhkin.builtin", "dhkin.tolerances", "dhkin.description",
                    "dhkin.xml_text", "dhkin.axes_to_dh", "dhkin.files", "dhkin.xml_file",
                    "dhkin.ros_packages", "dhkin.urdf_outline", "dhkin.xacro_expansion",
                    "dhkin.memory")),
    ("kinematics", ("dhkin.ik", "dhkin.ik.*", "dhkin.arm", "dhkin.opw",
                    "dhkin.opw_yaml", "dhkin.opw_compare")),
    ("analysis", ("dhkin.singularity", "dhkin.singularity.*", "dhkin.maps", "dhkin.maps.*",
                  "dhkin.validation", "dhkin.validation.*", "dhkin.compare",
                  "dhkin.importer", "dhkin.import_names")),
    ("facade", ("dhkin.robot",)),
    ("application", ("dhkin", "dhkin.checks", "dhkin.check_report", "dhkin.cli",
                     "dhkin.cli_check", "dhkin.cli_describe", "dhkin.cli_input")),
)


def _modules() -> dict[str, Path]:
    """Every module of the package: its Python files, and the compiled core by its type stub
    (dhkin/_core.pyi; it imports nothing of the package)."""
    found = {}
    for path in sorted([*(SOURCE / "dhkin").rglob("*.py"), *(SOURCE / "dhkin").rglob("*.pyi")]):
        parts = path.relative_to(SOURCE).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        found[name] = path
    return found


def _imports(path: Path, modules: dict[str, Path]) -> Iterator[str]:
    """The dhkin modules ``path`` imports (``from dhkin.ik import family`` is dhkin.ik.family)."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in modules:
                    yield alias.name
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                inner = f"{node.module}.{alias.name}"
                if inner in modules:
                    yield inner
                elif node.module in modules:
                    yield node.module


def _layer(name: str) -> int:
    for index, (_, patterns) in enumerate(LAYERS):
        for pattern in patterns:
            if name == pattern or (pattern.endswith(".*") and name.startswith(pattern[:-1])):
                return index
    raise AssertionError(f"{name} is in no layer: add it to LAYERS (and docs/architecture.md)")


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: set(_imports(path, modules)) - {name} for name, path in modules.items()}


def test_every_module_is_in_a_layer() -> None:
    for name in _modules():
        _layer(name)


def test_no_module_imports_a_higher_layer() -> None:
    upward = [f"{name} ({LAYERS[_layer(name)][0]}) imports {target} "
              f"({LAYERS[_layer(target)][0]})"
              for name, targets in _graph().items() for target in sorted(targets)
              if _layer(target) > _layer(name)]
    assert not upward, "\n".join(upward)


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in sorted(graph[node]):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_no_import_cycles() -> None:
    assert _cycles(_graph()) == []


def test_the_cycle_finder_finds_a_cycle() -> None:
    """The check above can fail: a three-module circle and a self-contained pair are found."""
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"e"}, "e": set()}
    assert _cycles(graph) == [["a", "b", "c"]]


#: Longest module (lines) a module of one job should need (issue "Architecture": ~500).
MAX_LINES = 500


def test_modules_are_small() -> None:
    long = {name: len(path.read_text(encoding="utf-8").splitlines())
            for name, path in _modules().items()}
    over = {name: lines for name, lines in long.items() if lines > MAX_LINES}
    assert not over, f"modules over {MAX_LINES} lines (one job each): {over}"


#: Packages that `import dhkin` and a closed-form robot's first answer must not import: each
#: costs a new process tenths of a second (scipy ~0.25 s, matplotlib, yourdfpy with trimesh
#: ~3 s) or compiles at run time (numba). The cold start (README, scripts/cold_start.py) is
#: import plus first answer; the modules that need one import it where they use it.
HEAVY_IMPORTS = ("scipy", "matplotlib", "yourdfpy", "trimesh", "numba")


def test_import_and_a_first_answer_import_no_heavy_package() -> None:
    """A new process runs `import dhkin`, loads the UR5 and solves one pose: none of
    HEAVY_IMPORTS is in sys.modules afterwards."""
    import subprocess
    import sys

    code = ("import sys, numpy as np, dhkin\n"
            "robot = dhkin.load('ur5')\n"
            "assert len(robot.ik(robot.fk(np.full(6, 0.3)))) > 0\n"
            f"print(sorted(m for m in {HEAVY_IMPORTS!r} if m in sys.modules))\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "[]"
