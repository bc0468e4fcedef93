"""What `dhkin check` prints and writes: one line per robot, a summary, the details, the JSON.

Every printed line fits in :data:`WIDTH` columns. A robot's line gives its IK family, its
verdict, the worst residual of its IK validations (m or rad, the larger, over "ik vs pin" and
"ik vs vendor"), their lowest completeness (% of samples with the sampled joint vector and every
branch among the solutions) and the seconds its checks took; the summary counts robots, poses and
time. ``--details`` prints every check's figures (:func:`details`), ``--json FILE`` writes them
as data (:func:`to_json`), and a failing robot's failed checks are always printed below the table
(:func:`failure_lines`).
"""

from __future__ import annotations

import textwrap
from collections.abc import Iterable, Sequence
from dataclasses import asdict
from typing import Any

from dhkin.checks import COLUMNS, IK_COLUMNS, CheckOptions, RobotCheck

#: Columns of a terminal that every line of the report fits in.
WIDTH = 100

#: Longest robot name shown in full on a robot's line (longer ones are cut, ending in "~").
NAME_WIDTH = 24

_FAMILY_WIDTH = 15
_HEADER = ("robot", "IK family", "verdict", "worst residual", "complete", "time")


def _name_width(names: Iterable[str]) -> int:
    return min(NAME_WIDTH, max([len(_HEADER[0]), *(len(n) for n in names)]))


def _cut(text: str, width: int) -> str:
    return text if len(text) <= width else text[:width - 1] + "~"


def _row(cells: Sequence[str], name_width: int) -> str:
    name, family, verdict, residual, complete, seconds = cells
    return (f"{_cut(name, name_width):<{name_width}}  {_cut(family, _FAMILY_WIDTH):<15}  "
            f"{verdict:<7}  {residual:>14}  {complete:>9}  {seconds:>8}").rstrip()


def header_lines(names: Iterable[str]) -> list[str]:
    """The table's header and rule, for the robots ``names``."""
    width = _name_width(names)
    rule = ["-" * width, "-" * _FAMILY_WIDTH, "-" * 7, "-" * 14, "-" * 9, "-" * 8]
    return [_row(_HEADER, width), "  ".join(rule)]


def _ik_cells(result: RobotCheck) -> list[dict[str, Any]]:
    return [c.figures for k in IK_COLUMNS if (c := result.cells.get(k)) is not None
            and c.figures]


def worst_residual(result: RobotCheck) -> float | None:
    """Largest residual (m or rad) of the robot's IK validations, None without one."""
    figures = _ik_cells(result)
    return max((f["worst_residual"] for f in figures), default=None)


def completeness(result: RobotCheck) -> tuple[float | None, bool]:
    """Lowest completeness (%) of the robot's IK validations (None without one), and whether
    one of them is of an IK that returns one solution per call (completeness not required)."""
    figures = _ik_cells(result)
    lowest = min((f["completeness"] for f in figures), default=None)
    return lowest, any(not f["complete_expected"] for f in figures)


def robot_line(result: RobotCheck, names: Iterable[str]) -> str:
    """One robot's line of the table (``names``: every robot of the run, for the width)."""
    residual = worst_residual(result)
    complete, one_per_call = completeness(result)
    complete_text = "-" if complete is None else f"{complete:.2f}%" + ("*" if one_per_call
                                                                          else " ")
    return _row((result.name, result.family, "PASS" if result.ok else "FAIL",
                 "-" if residual is None else f"{residual:.1e}", complete_text,
                 f"{result.seconds:.1f} s"), _name_width(names))


def _wrapped(text: str, indent: str) -> list[str]:
    """``text`` after ``indent`` in lines of at most WIDTH columns, later lines indented two
    more: broken after a comma (a figure and its name stay together), a part longer than a line
    at its spaces."""
    hanging = " " * (len(indent) + 2)
    lines: list[str] = []
    line = ""
    for part in text.split(", "):
        prefix = hanging if lines else indent
        if line and len(prefix) + len(line) + 2 + len(part) > WIDTH:
            lines.append(f"{prefix}{line},")
            line = part
        else:
            line = f"{line}, {part}" if line else part
    lines.append((hanging if lines else indent) + line)
    return [short for long in lines
            for short in ([long] if len(long) <= WIDTH else
                          textwrap.wrap(long, WIDTH, subsequent_indent=hanging,
                                        break_on_hyphens=False))]


def failure_lines(results: Sequence[RobotCheck]) -> list[str]:
    """The failed checks of each failing robot, with their text."""
    lines: list[str] = []
    for result in results:
        for column, cell in result.cells.items():
            if cell is not None and not cell.ok:
                lines += _wrapped(f"{column}: {cell.text}", f"FAIL {result.name} ")
    return lines


def summary_lines(results: Sequence[RobotCheck], seconds: float) -> list[str]:
    """Robots passed and failed, poses validated, worst residual and time of the run."""
    failed = [r.name for r in results if not r.ok]
    poses = {column: sum(c.figures.get("samples", 0) for r in results
                         if (c := r.cells.get(column)) is not None)
             for column in IK_COLUMNS}
    residuals = [x for r in results if (x := worst_residual(r)) is not None]
    text = (f"{len(results)} robot(s) checked in {seconds:.0f} s: {len(results) - len(failed)} "
            f"passed, {len(failed)} failed{' (' + ', '.join(failed) + ')' if failed else ''}. "
            f"IK validated on {poses['ik vs pin']:,} poses against Pinocchio on the generated "
            f"URDFs and on {poses['ik vs vendor']:,} on the vendor URDFs"
            + (f"; worst residual {max(residuals):.1e} m / rad." if residuals else "."))
    notes = [text]
    if any(completeness(r)[1] for r in results):
        notes.append("* numerical IK, one solution per call: its completeness is reported, "
                     "not required.")
    return [line for note in notes
            for line in textwrap.wrap(note, WIDTH, break_on_hyphens=False)]


def details(results: Sequence[RobotCheck]) -> str:
    """Every check of every robot with its figures (``--details``)."""
    lines: list[str] = []
    for result in results:
        lines.append(f"{result.name} ({result.family}): {'PASS' if result.ok else 'FAIL'}, "
                     f"{result.seconds:.1f} s")
        for column in COLUMNS:
            cell = result.cells.get(column)
            text = ("does not apply" if cell is None
                    else f"{'ok' if cell.ok else 'FAIL'}, {cell.seconds:.1f} s: {cell.text}")
            lines += _wrapped(text, f"  {column:<13}")
    return "\n".join(lines)


def to_json(results: Sequence[RobotCheck], options: CheckOptions,
            seconds: float) -> dict[str, Any]:
    """The run as data (``--json FILE``): options, verdict, time and, per robot and check, the
    verdict, text, seconds and figures."""
    return {
        "passed": all(r.ok for r in results),
        "seconds": seconds,
        "options": {**asdict(options), "reference_dir": str(options.reference_dir)},
        "robots": [{"name": r.name, "family": r.family, "passed": r.ok, "seconds": r.seconds,
                    "worst_residual": worst_residual(r), "completeness": completeness(r)[0],
                    "checks": {column: None if cell is None else asdict(cell)
                               for column, cell in r.cells.items()}}
                   for r in results],
    }
