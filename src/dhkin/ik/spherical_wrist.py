"""Placeholder while the spherical_wrist family is being written: fits no table."""

from __future__ import annotations

from dhkin.dh import DHTable


def fit_problems(table: DHTable) -> list[str]:
    return ["the spherical_wrist solver is not written yet"]


class Solver:
    family = "spherical_wrist"
    branch_labels: tuple = ()

    def __init__(self, table: DHTable) -> None:
        raise NotImplementedError("spherical_wrist")
