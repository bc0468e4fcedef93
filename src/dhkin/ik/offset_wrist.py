"""Placeholder while the offset_wrist family is being written: fits no table."""

from __future__ import annotations

from dhkin.dh import DHTable


def fit_problems(table: DHTable) -> list[str]:
    return ["the offset_wrist solver is not written yet"]


class Solver:
    family = "offset_wrist"
    branch_labels: tuple = ()

    def __init__(self, table: DHTable) -> None:
        raise NotImplementedError("offset_wrist")
