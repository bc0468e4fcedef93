"""A hostile sweep over description files (issue 27): every case imports to a table whose FK
equals the description's (Pinocchio on the URDF text the case wrote) to DEFAULT_TOLERANCE, or
fails with one line naming a file of the case and the field at fault.

The cases are drawn with a fixed seed (case k from ``default_rng([SEED, k])``), and vary at once:
one to seven moving joints (every count in every block of seven), revolute, continuous and
prismatic, fixed joints between them, tool0 fixed after them or moved by the last one; origins
with cardinal or general rotations, axes cardinal or general and of any length Pinocchio
normalises exactly; names plain, with '-' or namespaced with '/'; XML declarations (with and
without encoding, standalone), byte-order marks and encodings (UTF-8, UTF-16, ISO-8859-1 with
non-ASCII comments), comments between and inside elements, a 2 MB comment; and xacro: a
property, ``$(arg)`` (declared with a default, or given), a macro in another package included with
``$(find)`` (given with ``packages`` or found beside). About a third of the cases carry one
fault the case knows the field of: a zero or overflowing axis, limits beyond two turns or the
wrong way round, no limits, a limit that is not a number, a name a table cannot hold, ``--`` in
a comment, an encoding Python does not know, a loop, a mimic joint on the chain, an unset
``$(arg)``, a package nobody gives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from dhkin.errors import DhkinError
from dhkin.importer import import_description
from dhkin.reference import Reference
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import pose_error

from .urdf_text import numbers

SEED = 27
CASES = 140
#: Faults a case may carry, and a word its message must hold (besides the file's name).
FAULTS = {
    "zero axis": "axis", "huge axis": "axis", "wide limits": "lower",
    "inverted limits": "lower", "no limits": "limits", "not a number": "limit lower",
    "bad name": "name", "double dash": "not well-formed XML", "unknown encoding": "encoding",
    "loop": "kinematic loop", "mimic": "mimics", "unset arg": "$(arg",
    "unknown package": "$(find",
}
XACRO_ONLY = ("unset arg", "unknown package")
PACKAGE = "sweep_support"


@dataclass
class Case:
    """The files of one case, the one to import, its arguments, its plain URDF (the oracle's
    text) and its fault (None: it must import)."""

    folder: Path
    files: dict[str, bytes] = field(default_factory=dict)
    entry: str = "arm.urdf"
    packages: dict[str, Path] = field(default_factory=dict)
    xacro_args: dict[str, str] = field(default_factory=dict)
    urdf: str = ""
    fault: str | None = None

    def write(self) -> Path:
        for name, data in self.files.items():
            path = self.folder / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
        return self.folder / self.entry


def _angle(rng: np.random.Generator) -> float:
    return float(rng.choice([0.0, math.pi / 2, -math.pi / 2, math.pi])) if rng.random() < 0.6 \
        else float(rng.uniform(-math.pi, math.pi))


def _axis(rng: np.random.Generator) -> str:
    if rng.random() < 0.6:
        direction = np.zeros(3)
        direction[rng.integers(3)] = rng.choice([1.0, -1.0])
    else:
        direction = rng.normal(size=3)
    return numbers(direction * float(rng.choice([1.0, 2.5, 1e-3, 1e100])))


def _chain(rng: np.random.Generator, n: int, fault: str | None) -> list[str]:
    """The <link> and <joint> lines of the chain (the fault in it, where it is a chain's)."""
    ns = "ns/" if rng.random() < 0.2 else ""
    dash = "-" if rng.random() < 0.2 else "_"
    last_moves_tool0 = rng.random() < 0.2
    faulty = int(rng.integers(n))
    lines = [f'<link name="{ns}base_link"/>']
    parent = f"{ns}base_link"
    for k in range(n):
        if rng.random() < 0.3:  # a fixed joint before it
            child = f"{ns}fixed{dash}{k}"
            lines.append(f'<link name="{child}"/>')
            lines.append(f'<joint name="{ns}fix{dash}{k}" type="fixed"><origin xyz="'
                         f'{numbers(rng.normal(0, 0.1, 3))}" rpy="{_angle(rng)} 0 0"/><parent '
                         f'link="{parent}"/><child link="{child}"/></joint>')
            parent = child
        kind = rng.choice(["revolute", "revolute", "revolute", "continuous", "prismatic"])
        name = f"{ns}joint{dash}{k + 1}"
        child = f"{ns}tool0" if k == n - 1 and last_moves_tool0 else f"{ns}link{dash}{k + 1}"
        span = float(rng.uniform(0.5, 6.0)) if kind == "revolute" else 0.5
        limit = f'lower="{-span!r}" upper="{span!r}" effort="10" velocity="2"'
        axis = _axis(rng)
        extra = ""
        if k == faulty:
            if fault == "zero axis":
                axis = "0 0 0"
            elif fault == "huge axis":
                axis = "0 1e300 0"
            elif fault == "wide limits":
                kind, limit = "revolute", 'lower="-20" upper="20" effort="1" velocity="1"'
            elif fault == "inverted limits":
                kind, limit = "revolute", 'lower="1" upper="-1" effort="1" velocity="1"'
            elif fault == "no limits":
                kind, limit = "revolute", ""
            elif fault == "not a number":
                kind, limit = "revolute", 'lower="-1,5" upper="1.5" effort="1" velocity="1"'
            elif fault == "bad name":
                name = f"joint {k + 1}"
            elif fault == "mimic":
                extra = f'<mimic joint="{ns}joint{dash}{k}"/>' if k else '<mimic joint="x"/>'
        body = (f'<origin xyz="{numbers(rng.normal(0, 0.3, 3))}" rpy="{_angle(rng)} '
                f'{_angle(rng)} {_angle(rng)}"/><!-- joint {k + 1} --><parent link="{parent}"/>'
                f'<child link="{child}"/><axis xyz="{axis}"/>')
        if limit and kind != "continuous":
            body += f"<limit {limit}/>"
        lines.append(f'<link name="{child}"/>')
        lines.append(f'<joint name="{name}" type="{kind}">{body}{extra}</joint>')
        parent = child
    if not last_moves_tool0:
        lines.append(f'<link name="{ns}tool0"/>')
        lines.append(f'<joint name="{ns}flange-tool0" type="fixed"><origin xyz="0 0 0.05" '
                     f'rpy="0 {math.pi / 2!r} 0"/><parent link="{parent}"/><child '
                     f'link="{ns}tool0"/></joint>')
    if fault == "loop":
        lines.append(f'<joint name="closing" type="fixed"><parent link="{parent}"/><child '
                     f'link="{ns}base_link"/></joint>')
    return lines


def _xacro(case: Case, rng: np.random.Generator, lines: list[str], declaration: str) -> None:
    """Write the chain as xacro: the first joint's origin through a property, its limit through
    $(arg), the last two lines in a macro of another package included with $(find)."""
    text = "\n".join(lines)
    first_origin = text.index('<origin xyz="') + len('<origin xyz="')
    value = text[first_origin:text.index('"', first_origin)].split()[0]
    text = text[:first_origin] + "${first_x}" + text[first_origin + len(value):]
    macro_lines, body = text.splitlines()[-2:], text.splitlines()[:-2]
    arg = '<xacro:arg name="note" default="_sweep"/>'
    if case.fault == "unset arg" or rng.random() < 0.5:  # no default: given, or not at all
        arg = ""
        if case.fault != "unset arg":
            case.xacro_args = {"note": "_given"}
    macro = ('<?xml version="1.0"?>\n<robot xmlns:xacro="http://wiki.ros.org/xacro">\n'
             '<xacro:macro name="last_link">\n' + "\n".join(macro_lines)
             + "\n</xacro:macro>\n</robot>\n")
    package = case.folder / "src" / PACKAGE
    case.files[f"src/{PACKAGE}/urdf/last_link.xacro"] = macro.encode()
    if case.fault != "unknown package":
        case.files[f"src/{PACKAGE}/package.xml"] = (
            f"<package format='2'><name>{PACKAGE}</name></package>").encode()
        if rng.random() < 0.5:
            case.packages = {PACKAGE: package}
    top = (f'{declaration}<robot name="arm" xmlns:xacro="http://wiki.ros.org/xacro">\n{arg}\n'
           '<material name="paint$(arg note)"><color rgba="1 0.5 0 1"/></material>\n'
           f'<xacro:property name="first_x" value="{value}"/>\n'
           f'<xacro:include filename="$(find {PACKAGE})/urdf/last_link.xacro"/>\n'
           + "\n".join(body) + "\n<xacro:last_link/>\n</robot>\n")
    case.entry = "src/arm_description/urdf/arm.urdf.xacro"
    case.files[case.entry] = top.encode()


def make_case(k: int, folder: Path) -> Case:
    rng = np.random.default_rng([SEED, k])
    n = 1 + k % 7
    fault = str(rng.choice(sorted(FAULTS))) if rng.random() < 0.35 else None
    xacro = fault in XACRO_ONLY or rng.random() < 0.25
    case = Case(folder=folder, fault=fault)
    lines = _chain(rng, n, fault)
    case.urdf = '<robot name="arm">\n' + "\n".join(lines) + "\n</robot>\n"
    declaration = str(rng.choice(["", '<?xml version="1.0"?>\n',
                                  '<?xml version="1.0" encoding="utf-8"?>\n',
                                  "<?xml version='1.0' encoding='UTF-8' standalone='yes'?>\n"]))
    if xacro:
        _xacro(case, rng, lines, declaration)
        return case
    encoding = str(rng.choice(["utf-8", "utf-8", "utf-8-sig", "utf-16", "latin-1"]))
    if encoding == "latin-1":
        declaration = '<?xml version="1.0" encoding="ISO-8859-1"?>\n'
    if encoding == "utf-16":
        declaration = '<?xml version="1.0" encoding="UTF-16"?>\n'
    if fault == "unknown encoding":
        declaration, encoding = '<?xml version="1.0" encoding="x-sweep-7"?>\n', "utf-8"
    comment = "<!-- Gr\u00f6\u00dfe: 5\u00b0 -->\n"
    if fault == "double dash":
        comment = "<!-- a -- b -->\n"
    if k % 16 == 5:
        comment += "<!-- " + "x" * 2_000_000 + " -->\n"
    text = declaration + '<robot name="arm">\n' + comment + "\n".join(lines) + "\n</robot>\n"
    case.files[case.entry] = text.encode(encoding)
    return case


@pytest.mark.parametrize("k", range(CASES))
def test_hostile_description(k: int, tmp_path: Path) -> None:
    case = make_case(k, tmp_path)
    path = case.write()
    try:
        result = import_description(path, xacro_args=case.xacro_args or None,
                                    packages=case.packages or None, environ={})
    except DhkinError as exc:
        text = str(exc)
        assert case.fault is not None, f"case {k}: {text}"
        assert "\n" not in text and text.startswith(str(tmp_path)), text
        assert FAULTS[case.fault] in text, f"case {k} ({case.fault}): {text}"
        return
    assert case.fault is None, f"case {k}: {case.fault} imported"
    table = result.table
    tip, base = result.table.description.rsplit("(", 1)[1].rstrip(")").split(" -> ")[::-1]
    q = np.vstack([np.zeros(table.dof), table.random_q(100, np.random.default_rng(k))])
    position, rotation = pose_error(table.fk(q), Reference(case.urdf, tip=tip, base=base).fk(q))
    assert position.max() <= DEFAULT_TOLERANCE and rotation.max() <= DEFAULT_TOLERANCE, k


def test_the_sweep_covers_what_it_says() -> None:
    """Every joint count, fault and file form occurs among the cases."""
    cases = [make_case(k, Path("/sweep")) for k in range(CASES)]
    assert {c.fault for c in cases} == {None, *FAULTS}
    assert sum(c.fault is None for c in cases) >= CASES // 2
    assert {1 + k % 7 for k in range(CASES)} == set(range(1, 8))
    assert any(c.entry.endswith(".xacro") and c.fault is None for c in cases)
    assert any(c.files[c.entry].startswith(b"\xff\xfe") for c in cases)
    assert any(c.files[c.entry].startswith(b"\xef\xbb\xbf") for c in cases)
