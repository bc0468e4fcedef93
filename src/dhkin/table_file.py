"""DH table files: parsing and validation of the YAML format (every value checked; a DHError names
the file, the field and what was expected), and writing a table back, exactly or in chosen units.
The table itself and its FK: :mod:`dhkin.dh`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from dhkin.dh import (
    ANGLE_UNITS,
    CONVENTIONS,
    JOINT_TYPES,
    LENGTH_UNITS,
    NO_CORRECTION,
    RESERVED_LINK_NAMES,
    DHTable,
    Joint,
    _default_flange,
    fixed_joint_names,
)
from dhkin.errors import DHError
from dhkin.files import write_file
from dhkin.transforms import rot_y, rot_z, xyz_rpy_to_matrix
from dhkin.xml_text import NAME_RULE, name_problem, text_problem

_TOP_KEYS_REQUIRED = ("name", "convention", "units", "joints")


_TOP_KEYS_OPTIONAL = ("description", "source", "base", "tool", "flange")


_JOINT_KEYS_COMMON = ("name", "link", "type", "a", "alpha", "offset", "direction", "lower",
                      "upper", "velocity", "effort", "correction")


_FRAME_KEYS = ("xyz", "rpy")


def load_table(path: str | Path) -> DHTable:
    """Read and validate a DH table file (YAML). Raises :class:`DHError` naming file and field."""
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as exc:
        raise DHError(f"{file}: cannot read DH table file ({exc.strerror})") from exc
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # SafeLoader that rejects duplicates
    except _DuplicateKeyError as exc:
        raise DHError(f"{file}: {exc.key}: given twice in one mapping (lines {exc.first_line} "
                      f"and {exc.line}); expected each key once") from exc
    except yaml.YAMLError as exc:
        raise DHError(f"{file}: not valid YAML ({exc})") from exc
    return parse_table(data, source=str(file), path=file)


def parse_table(data: Any, source: str = "<table>", path: Path | None = None) -> DHTable:
    """Validate a table given as a mapping (the parsed YAML) and convert it to SI units."""
    where = _Where(source)
    if not isinstance(data, Mapping):
        raise DHError(f"{source}: expected a mapping with keys {_TOP_KEYS_REQUIRED}, "
                      f"got {type(data).__name__}")
    _check_keys(data, _TOP_KEYS_REQUIRED, _TOP_KEYS_OPTIONAL, where, "")

    name = _name(data["name"], where, "name", macro=True)
    convention = data["convention"]
    if convention not in CONVENTIONS:
        raise DHError(where.msg("convention", f"expected one of {list(CONVENTIONS)}, "
                                              f"got {convention!r}"))
    length_scale, angle_scale = _units(data["units"], where)

    joints_data = data["joints"]
    if not isinstance(joints_data, Sequence) or isinstance(joints_data, str):
        raise DHError(where.msg("joints", "expected a list of joint entries, "
                                          f"got {type(joints_data).__name__}"))
    if len(joints_data) == 0:
        raise DHError(where.msg("joints", "expected at least one joint, got an empty list"))
    joints = tuple(
        _joint(entry, i, where, length_scale, angle_scale) for i, entry in enumerate(joints_data)
    )
    _check_unique([j.name for j in joints], where, "name")
    _check_unique([j.link for j in joints], where, "link")
    fixed = fixed_joint_names(joints[-1].link)
    for i, joint in enumerate(joints):
        if joint.name in fixed:
            raise where.error(f"joints[{i}].name", joint.name,
                              f"a name other than those of the generated fixed joints "
                              f"{list(fixed)}")

    base = _frame(data.get("base"), where, "base", length_scale, angle_scale)
    tool = _frame(data.get("tool"), where, "tool", length_scale, angle_scale)
    flange = (_frame(data["flange"], where, "flange", length_scale, angle_scale)
              if "flange" in data else _default_flange())
    description = _text(data.get("description", ""), where, "description")
    source_text = _text(data.get("source", ""), where, "source")
    return DHTable(name=name, convention=convention, joints=joints, base=base, tool=tool,
                   flange=flange, description=description, source=source_text, path=path)


class _DuplicateKeyError(yaml.YAMLError):
    """A key that appears twice in one YAML mapping (PyYAML would silently keep the last)."""

    def __init__(self, key: Any, first_line: int, line: int) -> None:
        super().__init__(f"duplicate key {key!r}")
        self.key, self.first_line, self.line = key, first_line, line


class _UniqueKeyLoader(yaml.SafeLoader):
    """yaml.SafeLoader that rejects duplicate keys instead of keeping the last value."""


def _construct_unique_mapping(loader: _UniqueKeyLoader, node: yaml.MappingNode,
                              deep: bool = False) -> dict[Any, Any]:
    first_lines: dict[Any, int] = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=True)
        line = key_node.start_mark.line + 1
        try:
            if key in first_lines:
                raise _DuplicateKeyError(key, first_lines[key], line)
            first_lines[key] = line
        except TypeError:  # unhashable key (a list or mapping): PyYAML reports it below
            continue
    return loader.construct_mapping(node, deep=deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG,
                                 _construct_unique_mapping)


class _Where:
    """Formats error messages as '<file>: <field>: <what was expected>'."""

    def __init__(self, source: str) -> None:
        self.source = source

    def msg(self, field_name: str, expected: str) -> str:
        return f"{self.source}: {field_name}: {expected}"

    def error(self, field_name: str, value: Any, expected: str,
              problem: str | None = None) -> DHError:
        """DHError '<file>: <field>: <problem>' (default 'expected <expected>, got <value>')
        carrying field, value and expected."""
        text = problem if problem is not None else f"expected {expected}, got {value!r}"
        return DHError(self.msg(field_name, text), field=field_name, value=value,
                       expected=expected)


def _check_keys(data: Mapping[str, Any], required: Sequence[str], optional: Sequence[str],
                where: _Where, prefix: str) -> None:
    allowed = list(required) + list(optional)
    for key in data:
        if key not in allowed:
            raise DHError(where.msg(f"{prefix}{key}", f"unknown key; expected one of {allowed}"))
    for key in required:
        if key not in data:
            raise DHError(where.msg(f"{prefix}{key}", "missing required key"))


def _number(value: Any, where: _Where, field_name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DHError(where.msg(field_name, f"expected a finite number, got {value!r}"))
    if not math.isfinite(value):
        raise DHError(where.msg(field_name, f"expected a finite number, got {value!r}"))
    return float(value)


def _text(value: Any, where: _Where, field_name: str) -> str:
    """Free text (description, source): any string XML can hold exactly (dhkin.xml_text)."""
    problem = text_problem(value)
    if problem is not None:
        raise where.error(field_name, value, "text without control characters other than tab "
                                             "and line feed", problem)
    return str(value)


def _name(value: Any, where: _Where, field_name: str, macro: bool = False) -> str:
    """A robot, joint or link name (dhkin.xml_text.NAME_RULE); ``macro``: the robot's name, which
    also names the xacro macro and so may not be one of xacro's directives."""
    problem = name_problem(value, macro=macro)
    if problem is not None:
        raise where.error(field_name, value, NAME_RULE, problem)
    return str(value)


def _units(value: Any, where: _Where) -> tuple[float, float]:
    if not isinstance(value, Mapping):
        raise DHError(where.msg("units", "expected a mapping {length: m|mm, angle: deg|rad}, "
                                         f"got {value!r}"))
    _check_keys(value, ("length", "angle"), (), where, "units.")
    length, angle = value["length"], value["angle"]
    if length not in LENGTH_UNITS:
        raise DHError(where.msg("units.length", f"expected one of {list(LENGTH_UNITS)}, "
                                                f"got {length!r}"))
    if angle not in ANGLE_UNITS:
        raise DHError(where.msg("units.angle", f"expected one of {list(ANGLE_UNITS)}, "
                                               f"got {angle!r}"))
    return LENGTH_UNITS[length], ANGLE_UNITS[angle]


def _vector3(value: Any, where: _Where, field_name: str) -> list[float]:
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != 3:
        raise DHError(where.msg(field_name, f"expected a list of 3 numbers, got {value!r}"))
    return [_number(v, where, f"{field_name}[{k}]") for k, v in enumerate(value)]


def _frame(value: Any, where: _Where, field_name: str, length_scale: float,
           angle_scale: float) -> NDArray[np.float64]:
    if value is None:
        return np.eye(4)
    if not isinstance(value, Mapping):
        raise DHError(where.msg(field_name, "expected a mapping {xyz: [x, y, z], rpy: [r, p, y]}, "
                                            f"got {value!r}"))
    _check_keys(value, (), ("xyz", "rpy"), where, f"{field_name}.")
    xyz = np.array(_vector3(value.get("xyz", [0, 0, 0]), where, f"{field_name}.xyz"))
    rpy = np.array(_vector3(value.get("rpy", [0, 0, 0]), where, f"{field_name}.rpy"))
    return xyz_rpy_to_matrix(xyz * length_scale, rpy * angle_scale)


def _joint(entry: Any, index: int, where: _Where, length_scale: float,
           angle_scale: float) -> Joint:
    label = f"joints[{index}]"
    if not isinstance(entry, Mapping):
        raise DHError(where.msg(label, f"expected a mapping of DH values, got {entry!r}"))
    joint_type = entry.get("type", "revolute")
    if joint_type not in JOINT_TYPES:
        raise DHError(where.msg(f"{label}.type", f"expected one of {list(JOINT_TYPES)}, "
                                                 f"got {joint_type!r}"))
    revolute = joint_type == "revolute"
    # The joint variable replaces theta (revolute) or d (prismatic): the other one is fixed.
    fixed_key = "d" if revolute else "theta"
    required = ("a", "alpha", "lower", "upper") + (("d",) if revolute else ())
    optional = tuple(k for k in _JOINT_KEYS_COMMON if k not in required)
    optional += () if revolute else ("theta",)
    for wrong in (("theta",) if revolute else ("d",)):
        if wrong in entry:
            variable = "theta" if revolute else "d"
            raise DHError(where.msg(f"{label}.{wrong}",
                                    f"a {joint_type} joint's {variable} is its joint variable; "
                                    f"give its constant part as 'offset' and the fixed "
                                    f"{fixed_key} as '{fixed_key}'"))
    _check_keys(entry, required, optional, where, f"{label}.")

    def num(key: str, default: float = 0.0) -> float:
        return _number(entry.get(key, default), where, f"{label}.{key}")

    variable_scale = angle_scale if revolute else length_scale
    name = _name(entry.get("name", f"joint_{index + 1}"), where, f"{label}.name")
    link = _name(entry.get("link", f"link_{index + 1}"), where, f"{label}.link")
    if link in RESERVED_LINK_NAMES:
        raise DHError(where.msg(f"{label}.link", f"{link!r} is reserved for a fixed frame; "
                                                 f"expected a name other than "
                                                 f"{list(RESERVED_LINK_NAMES)}"))
    direction = entry.get("direction", 1)
    if isinstance(direction, bool) or direction not in (1, -1):
        raise DHError(where.msg(f"{label}.direction", f"expected 1 or -1, got {direction!r}"))
    lower = num("lower") * variable_scale
    upper = num("upper") * variable_scale
    if not lower < upper:
        raise DHError(where.msg(f"{label}.lower", "expected lower < upper, got lower = "
                                f"{entry['lower']!r}, upper = {entry['upper']!r}"))
    velocity = num("velocity") * variable_scale
    effort = num("effort")
    for key, value in (("velocity", velocity), ("effort", effort)):
        if value < 0:
            raise DHError(where.msg(f"{label}.{key}", f"expected a value >= 0, got {entry[key]!r}"))
    for key in ("alpha", "offset" if revolute else "theta"):
        if abs(num(key) * angle_scale) > 2 * math.pi + 1e-9:
            unit = "deg" if angle_scale != 1.0 else "rad"
            raise DHError(where.msg(f"{label}.{key}", f"expected an angle within +-360 deg "
                                    f"(+-2pi rad), got {entry[key]!r} {unit}; are units.angle "
                                    f"right?"))
    correction = (_correction(entry["correction"], where, f"{label}.correction", length_scale,
                              angle_scale) if "correction" in entry else NO_CORRECTION)
    return Joint(
        name=name, link=link, type=joint_type,
        a=num("a") * length_scale, alpha=num("alpha") * angle_scale,
        d=num("d") * length_scale if revolute else 0.0,
        theta=0.0 if revolute else num("theta") * angle_scale,
        offset=num("offset") * variable_scale, direction=int(direction),
        lower=lower, upper=upper, velocity=velocity, effort=effort, correction=correction,
    )


def _correction(value: Any, where: _Where, field_name: str, length_scale: float,
                angle_scale: float) -> tuple[float, float, float, float, float, float]:
    """A joint's ``correction: {xyz: [x, y, z], rpy: [r, p, y]}`` (table units) -> SI 6-tuple."""
    if not isinstance(value, Mapping):
        raise DHError(where.msg(field_name, "expected a mapping {xyz: [x, y, z], rpy: [r, p, y]}, "
                                            f"got {value!r}"))
    _check_keys(value, (), _FRAME_KEYS, where, f"{field_name}.")
    xyz = _vector3(value.get("xyz", [0, 0, 0]), where, f"{field_name}.xyz")
    rpy = _vector3(value.get("rpy", [0, 0, 0]), where, f"{field_name}.rpy")
    for k, angle in enumerate(rpy):
        if abs(angle * angle_scale) > 2 * math.pi + 1e-9:
            unit = "deg" if angle_scale != 1.0 else "rad"
            raise DHError(where.msg(f"{field_name}.rpy[{k}]", "expected an angle within +-360 deg "
                                    f"(+-2pi rad), got {value['rpy'][k]!r} {unit}; are "
                                    "units.angle right?"))
    x, y, z = (v * length_scale for v in xyz)
    roll, pitch, yaw = (v * angle_scale for v in rpy)
    return (x, y, z, roll, pitch, yaw)


def _check_unique(names: list[str], where: _Where, key: str) -> None:
    seen: dict[str, int] = {}
    for i, n in enumerate(names):
        if n in seen:
            raise DHError(where.msg(f"joints[{i}].{key}", f"duplicate {key} {n!r} (also "
                                                          f"joints[{seen[n]}]); expected unique "
                                                          f"{key}s"))
        seen[n] = i


#: Units :func:`table_to_yaml` writes by default: metres and radians, so that every number
#: round-trips exactly (``repr`` of the float, read back with a scale of 1).
EXACT_UNITS: dict[str, str] = {"length": "m", "angle": "rad"}


_WRITE_WIDTH = 100


#: Below this cos(pitch), :func:`exact_rpy` sets yaw to 0 and lets roll take the whole turn.
_EXACT_GIMBAL = 1e-15


def table_to_yaml(table: DHTable, units: Mapping[str, str] | None = None,
                  header: str | None = None) -> str:
    """The text of a table file that :func:`load_table` reads back as ``table``.

    ``units`` = ``{"length": "m" | "mm", "angle": "rad" | "deg"}`` (default m and rad). In m/rad
    every joint value, limit and correction is written as ``repr(float)`` and read back bit for
    bit; base, tool and flange are written as xyz + rpy, whose matrices are rebuilt to ~1e-16,
    so the FK of the table read back equals the original's to ~1e-15. Other units write each
    number as the shortest decimal read back bit for bit where one exists (90 for pi/2 rad),
    else the nearest (exact to ~1 ulp). Corrections are written only for joints that have one;
    base, tool and flange always. ``header`` (optional) is written first as ``#`` comment lines.
    """
    units = dict(EXACT_UNITS if units is None else units)
    problem = units_problem(units)
    if problem is not None:
        raise DHError(f"units: {problem}", field="units", value=units, expected=UNITS_RULE)
    length_scale = LENGTH_UNITS[units["length"]]
    angle_scale = ANGLE_UNITS[units["angle"]]

    def length(value: float) -> str:
        return _scaled_number(value, length_scale)

    def angle(value: float) -> str:
        return _scaled_number(value, angle_scale)

    def vector(values: Sequence[float] | NDArray[np.float64], fmt: Any) -> str:
        return "[" + ", ".join(fmt(float(v)) for v in values) + "]"

    def frame(T: NDArray[np.float64]) -> str:
        return (f"{{xyz: {vector(T[:3, 3], length)}, "
                f"rpy: {vector(exact_rpy(T), angle)}}}")

    lines = [f"# {line}".rstrip() for line in (header or "").splitlines()]
    lines.append(_yaml_pair("name", table.name))
    if table.description:
        lines.append(_yaml_pair("description", table.description))
    if table.source:
        lines.append(_yaml_pair("source", table.source))
    lines += [
        f"convention: {table.convention}",
        f"units: {{length: {units['length']}, angle: {units['angle']}}}",
        f"base: {frame(table.base)}",
        f"tool: {frame(table.tool)}",
        f"flange: {frame(table.flange)}",
        "joints:",
    ]
    for joint in table.joints:
        variable = angle if joint.is_revolute else length
        items = [f"name: {_yaml_plain(joint.name)}", f"link: {_yaml_plain(joint.link)}"]
        if not joint.is_revolute:
            items.append("type: prismatic")
        items += [f"a: {length(joint.a)}", f"alpha: {angle(joint.alpha)}"]
        items.append(f"d: {length(joint.d)}" if joint.is_revolute
                     else f"theta: {angle(joint.theta)}")
        items += [f"offset: {variable(joint.offset)}", f"direction: {joint.direction}",
                  f"lower: {variable(joint.lower)}", f"upper: {variable(joint.upper)}",
                  f"velocity: {variable(joint.velocity)}", f"effort: {_yaml_number(joint.effort)}"]
        if joint.has_correction:
            items.append(f"correction: {{xyz: {vector(joint.correction[:3], length)}, "
                         f"rpy: {vector(joint.correction[3:], angle)}}}")
        lines += _wrap_flow(items, first="  - {", rest="     ")
    return "\n".join(lines) + "\n"


def write_table(table: DHTable, path: str | Path, units: Mapping[str, str] | None = None,
                header: str | None = None, force: bool = False) -> Path:
    """Write :func:`table_to_yaml` of ``table`` to ``path``; return the path. Written as
    :mod:`dhkin.files` says: atomically, an existing file with other content only with
    ``force``, never through a symbolic link."""
    return write_file(path, table_to_yaml(table, units, header), field="table", force=force)


def _yaml_number(value: float) -> str:
    """A float as YAML text that PyYAML reads back as the same value (integers without '.0')."""
    if value == 0.0:
        return "0"
    if float(value).is_integer() and abs(value) < 1e15:
        return str(int(value))
    text = repr(float(value))
    if "e" in text and "." not in text:  # YAML 1.1 floats need a dot: 1e-05 -> 1.0e-05
        mantissa, exponent = text.split("e")
        text = f"{mantissa}.0e{exponent}"
    return text


#: What :func:`units_problem` accepts.
UNITS_RULE = "{'length': m|mm, 'angle': rad|deg}"


def units_problem(units: Mapping[str, str]) -> str | None:
    """What is wrong with a units mapping for :func:`table_to_yaml` (``"expected ..., got
    ..."``), or None when it is {"length": m|mm, "angle": rad|deg}."""
    if set(units) != {"length", "angle"} or units["length"] not in LENGTH_UNITS \
            or units["angle"] not in ANGLE_UNITS:
        return f"expected {UNITS_RULE}, got {dict(units)!r}"
    return None


def _scaled_number(value: float, scale: float) -> str:
    """``value`` (SI) in a unit of ``scale`` SI per unit, as YAML: the shortest decimal that
    :func:`load_table` (which multiplies by ``scale``) reads back as ``value`` bit for bit, else
    the nearest one (exact to ~1 ulp)."""
    if scale == 1.0:
        return _yaml_number(value)
    in_unit = value / scale
    for digits in range(18):
        candidate = round(in_unit, digits)
        if candidate * scale == value:
            return _yaml_number(candidate)
    return _yaml_number(in_unit)


def _yaml_plain(text: str) -> str:
    """A name as a plain YAML scalar when it reads back as the same text, else quoted."""
    try:
        plain = yaml.safe_load(text) == text
    except yaml.YAMLError:
        plain = False
    return text if plain else json.dumps(text)


def _yaml_pair(key: str, text: str) -> str:
    """``key: text`` as YAML, folded and quoted by PyYAML as needed."""
    return yaml.safe_dump({key: text}, width=_WRITE_WIDTH - 8, allow_unicode=True,
                          sort_keys=False).rstrip("\n")


def _wrap_flow(items: list[str], first: str, rest: str) -> list[str]:
    """``first`` + items joined by ', ' + '}', broken into lines of at most _WRITE_WIDTH."""
    lines: list[str] = []
    current = first
    for k, item in enumerate(items):
        piece = item + ("}" if k == len(items) - 1 else ",")
        fresh = current in (first, rest)
        candidate = current + ("" if fresh else " ") + piece
        if len(candidate) > _WRITE_WIDTH and not fresh:
            lines.append(current)
            current = rest + piece
        else:
            current = candidate
    lines.append(current)
    return lines


def exact_rpy(T: NDArray[np.float64]) -> tuple[float, float, float]:
    """URDF rpy of a rotation, with roll recomputed from pitch and yaw so that the rebuilt matrix
    equals the given one to ~1e-16, also near gimbal lock (where
    :func:`dhkin.transforms.matrix_to_rpy` snaps the pitch to +-pi/2 within 1e-12)."""
    M = np.asarray(T, dtype=float)[:3, :3]
    cos_pitch = float(np.hypot(M[0, 0], M[1, 0]))
    pitch = float(np.arctan2(-M[2, 0], cos_pitch))
    yaw = float(np.arctan2(M[1, 0], M[0, 0])) if cos_pitch > _EXACT_GIMBAL else 0.0
    rest = (rot_y(pitch)[:3, :3].T @ rot_z(yaw)[:3, :3].T) @ M
    roll = float(np.arctan2(rest[2, 1] - rest[1, 2], rest[1, 1] + rest[2, 2]))
    return roll, pitch, yaw
