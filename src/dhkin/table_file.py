"""DH table files: parsing and validation of the YAML format (every value checked; a DHError names
the file, the field and what was expected), and writing a table back, exactly or in chosen units.
The table itself and its FK: :mod:`dhkin.dh`; reading the YAML, and its limits:
:mod:`dhkin.table_yaml`.

An optional key given without a value (YAML null, e.g. ``flange:`` left empty) means the same as
leaving it out: its documented default. Limits on the table itself (joints, joint ranges,
lengths) are those of :mod:`dhkin.dh`, reported here in the file's units.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np
import yaml
from numpy.typing import NDArray

from dhkin.builtin import builtin_dir
from dhkin.dh import (
    ANGLE_UNITS,
    CONVENTIONS,
    JOINT_TYPES,
    LENGTH_UNITS,
    MAX_JOINT_TURNS,
    MAX_JOINTS,
    NO_CORRECTION,
    RESERVED_LINK_NAMES,
    Convention,
    DHTable,
    Joint,
    JointType,
    _default_flange,
    fixed_joint_names,
)
from dhkin.errors import DHError
from dhkin.files import write_file
from dhkin.table_values import (
    Units,
    Where,
    angle_value,
    check_keys,
    check_unique,
    given,
    length_value,
    name_value,
    number_value,
    text_value,
    units_value,
    vector3,
)
from dhkin.table_yaml import load_yaml, read_table_text, shown
from dhkin.transforms import rot_y, rot_z, xyz_rpy_to_matrix

_TOP_KEYS_REQUIRED = ("name", "convention", "units", "joints")


_TOP_KEYS_OPTIONAL = ("description", "source", "base", "tool", "flange")


_JOINT_KEYS_COMMON = ("name", "link", "type", "a", "alpha", "offset", "direction", "lower",
                      "upper", "velocity", "effort", "correction")


_FRAME_KEYS = ("xyz", "rpy")


def load_table(path: str | Path) -> DHTable:
    """Read and validate a DH table file (YAML 1.2, :mod:`dhkin.table_yaml`). Raises
    :class:`DHError` naming the file and the field."""
    file = Path(path)
    data = load_yaml(read_table_text(file), source=str(file),
                     builtin=file.resolve().parent == builtin_dir())
    return parse_table(data, source=str(file), path=file)


def read_back(text: str, source: str = "<table>") -> DHTable:
    """The table that :func:`load_table` would read from a file holding ``text``."""
    return parse_table(load_yaml(text, source), source=source)


def parse_table(data: Any, source: str = "<table>", path: Path | None = None) -> DHTable:
    """Validate a table given as a mapping (the parsed YAML) and convert it to SI units."""
    where = Where(source)
    if not isinstance(data, Mapping):
        got = "an empty file" if data is None else type(data).__name__
        raise DHError(f"{source}: expected a mapping with keys {_TOP_KEYS_REQUIRED}, got {got}",
                      field="file", value=got, expected=f"a mapping with keys {_TOP_KEYS_REQUIRED}")
    data = given(data, _TOP_KEYS_OPTIONAL)
    check_keys(data, _TOP_KEYS_REQUIRED, _TOP_KEYS_OPTIONAL, where, "")

    name = name_value(data["name"], where, "name", macro=True)
    convention = data["convention"]
    if not isinstance(convention, str) or convention not in CONVENTIONS:
        raise where.error("convention", convention, f"one of {list(CONVENTIONS)}")
    units = units_value(data["units"], where)

    joints_data = data["joints"]
    if not isinstance(joints_data, Sequence) or isinstance(joints_data, str):
        raise where.error("joints", type(joints_data).__name__, "a list of joint entries",
                          f"expected a list of joint entries, got {type(joints_data).__name__}")
    if len(joints_data) == 0:
        raise where.error("joints", [], "at least one joint",
                          "expected at least one joint, got an empty list")
    if len(joints_data) > MAX_JOINTS:
        raise where.error("joints", len(joints_data), f"at most {MAX_JOINTS} joints",
                          f"expected at most {MAX_JOINTS} joints (dhkin.dh.MAX_JOINTS: an arm), "
                          f"got {len(joints_data)}")
    joints = tuple(_joint(entry, i, where, units) for i, entry in enumerate(joints_data))
    check_unique([j.name for j in joints], where, "name")
    check_unique([j.link for j in joints], where, "link")
    fixed = fixed_joint_names(joints[-1].link)
    for i, joint in enumerate(joints):
        if joint.name in fixed:
            raise where.error(f"joints[{i}].name", joint.name,
                              f"a name other than those of the generated fixed joints "
                              f"{list(fixed)}")

    base = _frame(data.get("base"), where, "base", units)
    tool = _frame(data.get("tool"), where, "tool", units)
    flange = (_frame(data["flange"], where, "flange", units)
              if "flange" in data else _default_flange())
    description = text_value(data.get("description", ""), where, "description")
    source_text = text_value(data.get("source", ""), where, "source")
    try:
        return DHTable(name=name, convention=cast(Convention, convention), joints=joints,
                       base=base, tool=tool, flange=flange, description=description,
                       source=source_text, path=path)
    except DHError as exc:  # a limit of dhkin.dh the checks above missed: name the file too
        raise DHError(f"{source}: {exc}", field=exc.field, value=exc.value,
                      expected=exc.expected) from exc


def _xyz_rpy(value: Any, where: Where, field_name: str,
             units: Units) -> tuple[list[float], list[float]]:
    """``{xyz: [x, y, z], rpy: [r, p, y]}`` (each optional, default zero; rpy within +-1 turn)
    -> xyz in m, rpy in rad."""
    if not isinstance(value, Mapping):
        raise where.error(field_name, value, "a mapping {xyz: [x, y, z], rpy: [r, p, y]}")
    value = given(value, _FRAME_KEYS)
    check_keys(value, (), _FRAME_KEYS, where, f"{field_name}.")
    xyz = [length_value(v, where, f"{field_name}.xyz[{k}]", units)
           for k, v in enumerate(vector3(value.get("xyz", [0, 0, 0]), where,
                                          f"{field_name}.xyz"))]
    rpy = [angle_value(v, where, f"{field_name}.rpy[{k}]", units)
           for k, v in enumerate(vector3(value.get("rpy", [0, 0, 0]), where,
                                          f"{field_name}.rpy"))]
    return xyz, rpy


def _frame(value: Any, where: Where, field_name: str, units: Units) -> NDArray[np.float64]:
    if value is None:
        return np.eye(4)
    xyz, rpy = _xyz_rpy(value, where, field_name, units)
    return xyz_rpy_to_matrix(np.array(xyz), np.array(rpy))


def _joint(entry: Any, index: int, where: Where, units: Units) -> Joint:
    label = f"joints[{index}]"
    if not isinstance(entry, Mapping):
        raise where.error(label, entry, "a mapping of DH values")
    joint_type = entry.get("type")
    joint_type = "revolute" if joint_type is None else joint_type
    if not isinstance(joint_type, str) or joint_type not in JOINT_TYPES:
        raise where.error(f"{label}.type", joint_type, f"one of {list(JOINT_TYPES)}")
    revolute = joint_type == "revolute"
    # The joint variable replaces theta (revolute) or d (prismatic): the other one is fixed.
    fixed_key = "d" if revolute else "theta"
    required = ("a", "alpha", "lower", "upper") + (("d",) if revolute else ())
    optional = tuple(k for k in _JOINT_KEYS_COMMON if k not in required)
    optional += () if revolute else ("theta",)
    entry = given(entry, optional)
    for wrong in (("theta",) if revolute else ("d",)):
        if wrong in entry:
            variable = "theta" if revolute else "d"
            raise where.error(f"{label}.{wrong}", entry[wrong], f"no '{wrong}'",
                              f"a {joint_type} joint's {variable} is its joint variable; "
                              f"give its constant part as 'offset' and the fixed "
                              f"{fixed_key} as '{fixed_key}'")
    check_keys(entry, required, optional, where, f"{label}.")

    def length(key: str) -> float:
        return length_value(entry.get(key, 0.0), where, f"{label}.{key}", units)

    def angle(key: str) -> float:
        return angle_value(entry.get(key, 0.0), where, f"{label}.{key}", units)

    def limit(key: str) -> float:
        if revolute:
            return angle_value(entry[key], where, f"{label}.{key}", units, turns=MAX_JOINT_TURNS,
                          what="a joint limit")
        return length(key)

    name = name_value(entry.get("name", f"joint_{index + 1}"), where, f"{label}.name")
    link = name_value(entry.get("link", f"link_{index + 1}"), where, f"{label}.link")
    if link in RESERVED_LINK_NAMES:
        raise where.error(f"{label}.link", link, f"a name other than {list(RESERVED_LINK_NAMES)}",
                          f"{link!r} is reserved for a fixed frame; expected a name other than "
                          f"{list(RESERVED_LINK_NAMES)}")
    direction = entry.get("direction", 1)
    if isinstance(direction, bool) or not isinstance(direction, (int, float)) \
            or direction not in (1, -1):
        raise where.error(f"{label}.direction", direction, "1 or -1")
    lower, upper = limit("lower"), limit("upper")
    if not lower < upper:
        raise where.error(f"{label}.lower", entry["lower"], "lower < upper",
                          f"expected lower < upper, got lower = {shown(entry['lower'])}, "
                          f"upper = {shown(entry['upper'])}")
    variable_scale = units.angle_scale if revolute else units.length_scale
    velocity = number_value(entry.get("velocity", 0.0), where, f"{label}.velocity") * variable_scale
    effort = number_value(entry.get("effort", 0.0), where, f"{label}.effort")
    for key, value in (("velocity", velocity), ("effort", effort)):
        if value < 0:
            raise where.error(f"{label}.{key}", entry[key], "a value >= 0")
    correction = (_correction(entry["correction"], where, f"{label}.correction", units)
                  if "correction" in entry else NO_CORRECTION)
    return Joint(
        name=name, link=link, type=cast(JointType, joint_type),
        a=length("a"), alpha=angle("alpha"),
        d=length("d") if revolute else 0.0,
        theta=0.0 if revolute else angle("theta"),
        offset=angle("offset") if revolute else length("offset"), direction=int(direction),
        lower=lower, upper=upper, velocity=velocity, effort=effort, correction=correction,
    )


def _correction(value: Any, where: Where, field_name: str,
                units: Units) -> tuple[float, float, float, float, float, float]:
    """A joint's ``correction: {xyz: [x, y, z], rpy: [r, p, y]}`` (table units) -> SI 6-tuple."""
    (x, y, z), (roll, pitch, yaw) = _xyz_rpy(value, where, field_name, units)
    return (x, y, z, roll, pitch, yaw)


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
    """A name as a plain YAML scalar when it reads back as the same text under YAML 1.2
    (:mod:`dhkin.table_yaml`, how tables are read) and 1.1 (PyYAML, how many other tools read
    them), else quoted."""
    return text if _reads_back({"key": text}, f"key: {text}") else json.dumps(text)


def _yaml_pair(key: str, text: str) -> str:
    """``key: text`` as YAML, folded and quoted by PyYAML as needed; double-quoted (JSON) where
    PyYAML's text would read back differently under YAML 1.2 (``1e3``, ``0o17`` are numbers)."""
    pair = yaml.safe_dump({key: text}, width=_WRITE_WIDTH - 8, allow_unicode=True,
                          sort_keys=False).rstrip("\n")
    if _reads_back({key: text}, pair):
        return pair
    return f"{key}: {json.dumps(text, ensure_ascii=False)}"


def _reads_back(data: dict[str, str], text: str) -> bool:
    """Whether YAML ``text`` reads back as ``data`` under both YAML 1.2 and PyYAML's 1.1."""
    try:
        return load_yaml(text) == data and yaml.safe_load(text) == data
    except (DHError, yaml.YAMLError):
        return False


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
