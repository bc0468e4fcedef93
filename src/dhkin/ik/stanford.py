"""Placeholder while the stanford family is being written: fits no table."""

from __future__ import annotations

from dhkin.dh import DHTable


def fit_problems(table: DHTable) -> list[str]:
    return ["the stanford solver is not written yet"]


class Solver:
    family = "stanford"
    branch_labels: tuple = ()

    def __init__(self, table: DHTable) -> None:
        raise NotImplementedError("stanford")
