"""Family detection: which closed-form solver fits a DH table.

Each family module provides ``fit_problems(table) -> list[str]`` (the structural conditions the
table fails, in words with the offending values; empty when it fits) and ``Solver(table)``.
"""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType

from dhkin.dh import DHTable
from dhkin.errors import FamilyError
from dhkin.ik import offset_wrist, spherical_wrist, stanford
from dhkin.ik.closed_form import BranchSolver

#: Closed-form families, tried in this order.
FAMILIES: dict[str, ModuleType] = {
    "spherical_wrist": spherical_wrist,
    "stanford": stanford,
    "offset_wrist": offset_wrist,
}


def family_problems(table: DHTable) -> dict[str, list[str]]:
    """For every family, the structural conditions ``table`` fails (empty list: it fits)."""
    return {name: module.fit_problems(table) for name, module in FAMILIES.items()}


def solver_for(table: DHTable, family: str | None = None) -> BranchSolver:
    """The closed-form solver of the first family that fits (or of ``family``).

    Raises FamilyError naming, per family, the conditions the table fails.
    """
    if family is not None and family not in FAMILIES:
        raise FamilyError(f"family: expected one of {list(FAMILIES)}, got {family!r}")
    names = [family] if family is not None else list(FAMILIES)
    report = []
    for name in names:
        problems = FAMILIES[name].fit_problems(table)
        if not problems:
            make: Callable[[DHTable], BranchSolver] = FAMILIES[name].Solver
            return make(table)
        report.append(f"{name}: " + "; ".join(problems))
    raise FamilyError(f"{table.name}: no closed-form IK family fits this table:\n  "
                      + "\n  ".join(report))
