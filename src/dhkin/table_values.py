"""The checks of a table file's values, each naming the file and the field at fault in a one-line
:class:`DHError`: numbers, lengths and angles in the table's units (within the limits of
:mod:`dhkin.dh`), names, free text, units, keys. Used by :mod:`dhkin.table_file`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

from dhkin.dh import ANGLE_UNITS, LENGTH_UNITS, MAX_JOINT_TURNS, MAX_LENGTH
from dhkin.errors import DHError
from dhkin.table_yaml import field_key, shown
from dhkin.xml_text import NAME_RULE, ROBOT_NAME_RULE, name_problem, text_problem

#: Slack of the range checks against the rounding of unit conversion (720 deg -> 4 pi rad).
_SLACK = 1e-9


class Units(NamedTuple):
    """A table's units: SI per unit, and the unit names for messages."""

    length_scale: float
    angle_scale: float
    length: str
    angle: str


class Where:
    """Formats error messages as '<file>: <field>: <what was expected>'."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, field_name: str, value: Any, expected: str,
              problem: str | None = None) -> DHError:
        """DHError '<file>: <field>: <problem>' (default 'expected <expected>, got <value>')
        carrying field, value and expected."""
        text = problem if problem is not None else f"expected {expected}, got {shown(value)}"
        return DHError(f"{self.source}: {field_name}: {text}", field=field_name, value=value,
                       expected=expected)


def given(data: Mapping[Any, Any], optional: Sequence[str]) -> dict[Any, Any]:
    """``data`` without the optional keys given no value (YAML null): those take their default."""
    return {key: value for key, value in data.items()
            if not (value is None and key in optional)}


def check_keys(data: Mapping[Any, Any], required: Sequence[str], optional: Sequence[str],
                where: Where, prefix: str) -> None:
    """Reject a key of ``data`` not in ``required`` or ``optional``, and a missing required one."""
    allowed = list(required) + list(optional)
    for key in data:
        if key not in allowed:
            raise where.error(f"{prefix}{field_key(key)}", key, f"one of {allowed}",
                              f"unknown key; expected one of {allowed}")
    for key in required:
        if key not in data:
            raise where.error(f"{prefix}{key}", None, "the key", "missing required key")


def number_value(value: Any, where: Where, field_name: str) -> float:
    """A finite number (an int or float of YAML; not a boolean) as a float."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise where.error(field_name, value, "a finite number")
    try:
        number = float(value)
    except OverflowError:  # an integer beyond float's range
        number = math.inf
    if not math.isfinite(number):
        raise where.error(field_name, value, "a finite number")
    return number


def length_value(value: Any, where: Where, field_name: str, units: Units) -> float:
    """A length in the table's unit, within +-MAX_LENGTH, in metres."""
    number = number_value(value, where, field_name)
    if not abs(number * units.length_scale) <= MAX_LENGTH + _SLACK:
        limit = MAX_LENGTH / units.length_scale
        raise where.error(field_name, value, f"a length within +-{limit:.15g} {units.length}",
                          f"expected a length within +-{limit:.15g} {units.length} "
                          f"(dhkin.dh.MAX_LENGTH), got {shown(value)} {units.length}; are "
                          f"units.length right?")
    return number * units.length_scale


def angle_value(value: Any, where: Where, field_name: str, units: Units, turns: float = 1.0,
           what: str = "an angle") -> float:
    """An angle in the table's unit, within +-``turns`` turns, in radians."""
    number = number_value(value, where, field_name)
    if not abs(number * units.angle_scale) <= turns * 2 * math.pi + _SLACK:
        limit = f"+-{turns * 360:g} deg (+-{turns * 2:g}pi rad"
        limit += f", dhkin.dh.MAX_JOINT_TURNS = {MAX_JOINT_TURNS} turns)" if turns != 1 else ")"
        raise where.error(field_name, value, f"{what} within {limit}",
                          f"expected {what} within {limit}, got {shown(value)} {units.angle}; "
                          f"are units.angle right?")
    return number * units.angle_scale


def text_value(value: Any, where: Where, field_name: str) -> str:
    """Free text (description, source): any string XML can hold exactly (dhkin.xml_text)."""
    problem = text_problem(value)
    if problem is not None:
        raise where.error(field_name, value, "text without control characters other than tab "
                                             "and line feed", bounded(problem, value))
    return str(value)


def name_value(value: Any, where: Where, field_name: str, macro: bool = False) -> str:
    """A robot, joint or link name (dhkin.xml_text.NAME_RULE); ``macro``: the robot's name, which
    also names the xacro macro and so may not be one of xacro's directives."""
    problem = name_problem(value, macro=macro)
    if problem is not None:
        raise where.error(field_name, value, ROBOT_NAME_RULE if macro else NAME_RULE,
                          bounded(problem, value))
    return str(value)


def bounded(problem: str, value: Any) -> str:
    """``problem`` with the full repr of ``value`` in it cut to :func:`shown`'s length."""
    full = repr(value)
    return problem.replace(full, shown(value)) if len(full) > len(shown(value)) else problem


def units_value(value: Any, where: Where) -> Units:
    """The ``units: {length: m|mm, angle: deg|rad}`` mapping as :class:`Units`."""
    if not isinstance(value, Mapping):
        raise where.error("units", value, "a mapping {length: m|mm, angle: deg|rad}")
    check_keys(value, ("length", "angle"), (), where, "units.")
    length, angle = value["length"], value["angle"]
    if not isinstance(length, str) or length not in LENGTH_UNITS:
        raise where.error("units.length", length, f"one of {list(LENGTH_UNITS)}")
    if not isinstance(angle, str) or angle not in ANGLE_UNITS:
        raise where.error("units.angle", angle, f"one of {list(ANGLE_UNITS)}")
    return Units(LENGTH_UNITS[length], ANGLE_UNITS[angle], length, angle)


def vector3(value: Any, where: Where, field_name: str) -> list[Any]:
    """A list of three values (each then checked by the caller)."""
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != 3:
        raise where.error(field_name, value, "a list of 3 numbers")
    return list(value)


def check_unique(names: list[str], where: Where, key: str) -> None:
    """Reject a joint name or link name given to two joints."""
    seen: dict[str, int] = {}
    for i, n in enumerate(names):
        if n in seen:
            raise where.error(f"joints[{i}].{key}", n, f"unique {key}s",
                              f"duplicate {key} {n!r} (also joints[{seen[n]}]); expected "
                              f"unique {key}s")
        seen[n] = i
