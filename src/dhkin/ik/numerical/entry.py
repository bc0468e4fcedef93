"""Numerical IK in one call: :func:`numerical_ik` on a robot, a built-in robot name, a table file,
a URDF file, a :class:`~dhkin.reference.Reference` or a solver."""

from __future__ import annotations

from pathlib import Path

from numpy.typing import ArrayLike

from dhkin.builtin import resolve_table_path
from dhkin.errors import InputError
from dhkin.ik.numerical.solver import NumericalIK, RobotLike
from dhkin.ik.result import IKSolutions
from dhkin.reference import Reference
from dhkin.table_file import load_table


def numerical_ik(robot_or_urdf: RobotLike | Reference | NumericalIK | str | Path, target: ArrayLike,
                 q_seed: ArrayLike | None = None, *, tip: str | None = None,
                 base: str | None = None, **options: object) -> IKSolutions:
    """Numerical IK in one call.

    ``robot_or_urdf``: a :class:`~dhkin.Robot`, a built-in robot name or ``.yaml`` table path, a
    ``.urdf`` file path (then ``tip`` is required, ``base`` optional), a :class:`Reference` or a
    :class:`NumericalIK`. ``options`` are those of :meth:`NumericalIK.solve`.
    """
    solver = _solver_of(robot_or_urdf, tip, base)
    return solver.solve(target, q_seed, **options)  # type: ignore[arg-type]


def _solver_of(source: RobotLike | Reference | NumericalIK | str | Path, tip: str | None,
               base: str | None) -> NumericalIK:
    if isinstance(source, NumericalIK):
        return source
    if isinstance(source, Reference):
        return NumericalIK(source)
    if not isinstance(source, str | Path):  # a robot: its cached solver
        return source.numerical_solver(tip or "tool0")
    path = Path(source)
    if path.suffix == ".urdf":
        if tip is None:
            raise InputError(f"{path}: a URDF needs the tip frame (tip=...)", field="tip",
                             expected="the tip frame of the URDF's chain")
        return NumericalIK.from_urdf(path, tip, base)
    return NumericalIK.from_table(load_table(resolve_table_path(source)), tip or "tool0")
