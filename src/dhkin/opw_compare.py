"""Another OPW parameter file (a vendor's ``opw_parameters_*.yaml``) against a table:
``dhkin export --format opw --compare FILE.yaml``.

Two OPW files can describe the same arm in different forms: the spherical wrist reads the same
with axis 5 turned around (sign 5 negated with offset 5, offsets 4 and 6 shifted by pi), which
is how FANUC and Yaskawa files write what dhkin writes with sign 5 = +1. Fields alone therefore
cannot tell whether a file is right. :func:`compare_opw` compares by forward kinematics, with the
table's FK base_link -> tool0 as the truth (the table's FK equals its description's: the import
checks it): the file is **equivalent** when its FK (OPW base = base_link, OPW flange = tool0,
unless it has dhkin's ``dhkin_fixed_frames``) equals the table's to :data:`dhkin.opw.TOLERANCE`
in every matrix entry, on the joint vectors of :func:`dhkin.opw.check_joint_vectors` (every
combination of 0, +-pi/2, pi, and random ones). Otherwise it reports the largest difference (m,
rad, and where) and the field to blame: dhkin's own parameters, in the form nearest the file,
put into the file one field at a time, the field that brings the FK closest first, until the
FK agrees.

The file is read as MoveIt reads it: ``opw_kinematics_geometric_parameters`` (a1, a2, b, c1, c2,
c3, c4 in m), ``opw_kinematics_joint_offsets`` (rad; rosparam's ``deg(X)`` and ``rad(X)``, X a
number or a multiple or fraction of ``pi``) and ``opw_kinematics_joint_sign_corrections``, at
the top level or under one planning group. Faults are one line ``FILE: FIELD: expected ...,
got ...``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dhkin.dh import DHTable
from dhkin.errors import InputError
from dhkin.opw import OPWParameters, check_joint_vectors, opw_parameters
from dhkin.table_yaml import load_yaml
from dhkin.transforms import pose_error, xyz_rpy_to_matrix

GEOMETRY_KEY = "opw_kinematics_geometric_parameters"
OFFSETS_KEY = "opw_kinematics_joint_offsets"
SIGNS_KEY = "opw_kinematics_joint_sign_corrections"
FRAMES_KEY = "dhkin_fixed_frames"
LENGTHS = ("a1", "a2", "b", "c1", "c2", "c3", "c4")
#: Largest OPW file read (bytes): a real one is under 2 kB.
MAX_OPW_BYTES = 1 << 16

_PI_TERM = re.compile(r"([+-]?)(\d+(?:\.\d*)?(?:[eE][+-]?\d+)?)?\s*\*?\s*(pi)?\s*(?:/\s*"
                      r"(\d+(?:\.\d*)?))?")


@dataclass(frozen=True)
class Blame:
    """A field of the file, its value and dhkin's, and the largest FK matrix-entry difference
    left once dhkin's value of this field (and of the fields blamed before it) is put in."""

    field: str
    published: float
    dhkin: float
    remaining: float


@dataclass(frozen=True)
class OPWComparison:
    """The verdict of :func:`compare_opw` (see the module docstring). ``deviation``: the largest
    matrix-entry difference; ``position`` (m) and ``rotation`` (rad) the largest pose
    differences, ``worst_q`` a joint vector where the entry difference is largest; ``blamed``
    the fields to blame (empty when equivalent); ``form_differences`` the fields that differ
    from dhkin's own file although the FK is the same."""

    source: str
    tolerance: float
    deviation: float
    position: float
    rotation: float
    worst_q: NDArray[np.float64]
    blamed: tuple[Blame, ...]
    form_differences: tuple[Blame, ...]
    wrist_flipped: bool = False

    @property
    def equivalent(self) -> bool:
        return self.deviation <= self.tolerance

    def summary(self) -> str:
        if self.equivalent:
            text = f"{self.source}: equivalent (same FK to {self.tolerance:g})"
            if not self.form_differences:
                return text + ": the same parameters as dhkin's"
            fields = ", ".join(f"{b.field} {_shown(b.field, b.published)} (dhkin "
                               f"{_shown(b.field, b.dhkin)})" for b in self.form_differences)
            why = (" (axis 5 turned around: sign 5 negated, offsets 4 and 6 shifted by pi)"
                   if self.wrist_flipped else "")
            return text + f", written in another form{why}: {fields}"
        q = np.array2string(self.worst_q, precision=6, separator=", ")
        fields = "; ".join(f"{b.field}: {_shown(b.field, b.published)}, dhkin "
                           f"{_shown(b.field, b.dhkin)} (with dhkin's value: {b.remaining:.3g})"
                           for b in self.blamed)
        return (f"{self.source}: differs from the table's FK: largest difference "
                f"{self.position:.6g} m, {self.rotation:.6g} rad (matrix entry "
                f"{self.deviation:.3g}; tolerance {self.tolerance:g}) at q = {q}; field to "
                f"blame: {fields}")


def _shown(field: str, value: float) -> str:
    """A field's value as the file writes it: signs as integers, frames as present/absent,
    numbers with every digit."""
    if field.startswith(SIGNS_KEY):
        return str(int(value))
    if field.startswith(FRAMES_KEY):
        return "given" if value else "none"
    return repr(value)


def compare_opw(table: DHTable, path: str | Path) -> OPWComparison:
    """The OPW file ``path`` against ``table`` (module docstring). FamilyError when the table
    is not an OPW arm, InputError or DHError naming the file and field for a file that is not
    one MoveIt reads."""
    from dhkin.opw import TOLERANCE

    ours = opw_parameters(table)
    published = read_opw_file(path, ours)
    q = check_joint_vectors(table)
    truth = table.fk(q)
    entries = np.abs(published.fk(q) - truth).max(axis=(1, 2))
    worst = int(np.argmax(entries))
    position, rotation = pose_error(published.fk(q), truth)
    theirs = _fields(published)
    if float(entries[worst]) <= TOLERANCE:
        form = tuple(Blame(f, theirs[f], v, 0.0) for f, v in _fields(ours).items()
                     if not _same(f, v, theirs[f]))
        flipped = all(_same(f, v, theirs[f]) for f, v in _fields(_wrist_flipped(ours)).items())
        return OPWComparison(str(path), TOLERANCE, float(entries[worst]), float(position.max()),
                             float(rotation.max()), q[worst], (), form, bool(form) and flipped)
    nearest = _nearest_form(ours, published, q)
    differing = [f for f, v in _fields(nearest).items() if not _same(f, v, theirs[f])]
    blamed = _blame(published, nearest, differing, table, q, TOLERANCE)
    return OPWComparison(str(path), TOLERANCE, float(entries[worst]), float(position.max()),
                         float(rotation.max()), q[worst], blamed, ())


def read_opw_file(path: str | Path, like: OPWParameters) -> OPWParameters:
    """The parameters of an OPW YAML file, named and ordered as ``like`` (dhkin's, for the
    joint names)."""
    file = Path(path)
    try:
        with file.open("rb") as stream:
            data = stream.read(MAX_OPW_BYTES + 1)
    except OSError as exc:
        raise InputError(f"{file}: cannot read the OPW file ({exc.strerror})", field="file",
                         value=str(file), expected="a readable OPW YAML file") from exc
    if len(data) > MAX_OPW_BYTES:
        raise InputError(f"{file}: expected an OPW file of at most {MAX_OPW_BYTES} bytes, got "
                         "more", field="file", value=str(file), expected="a small YAML file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{file}: expected UTF-8 text (byte {exc.start})", field="file",
                         value=str(file), expected="UTF-8 text") from exc
    content = _parameters_mapping(load_yaml(text, str(file)), file)
    geometry = content[GEOMETRY_KEY]
    if not isinstance(geometry, Mapping) or sorted(geometry) != sorted(LENGTHS):
        raise _error(file, GEOMETRY_KEY, f"a mapping of {list(LENGTHS)}", geometry)
    lengths = {key: _number(geometry[key], file, f"{GEOMETRY_KEY}.{key}") for key in LENGTHS}
    offsets = _six(content[OFFSETS_KEY], file, OFFSETS_KEY, _angle)
    signs = _six(content[SIGNS_KEY], file, SIGNS_KEY, _sign)
    base, tool = np.eye(4), np.eye(4)
    if FRAMES_KEY in content:
        frames = content[FRAMES_KEY]
        if not isinstance(frames, Mapping):
            raise _error(file, FRAMES_KEY, "a mapping", frames)
        base = _frame(frames.get("base_link_to_opw_base"), file, FRAMES_KEY)
        tool = _frame(frames.get("opw_flange_to_tool0"), file, FRAMES_KEY)
    return OPWParameters(name=file.stem, joint_names=like.joint_names, **lengths,
                         offsets=tuple(offsets),  # type: ignore[arg-type]
                         sign_corrections=tuple(int(s) for s in signs),  # type: ignore[arg-type]
                         base=base, tool=tool)


# --------------------------------------------------------------------------------------------
# Reading


def _error(file: Path, field: str, expected: str, got: Any) -> InputError:
    return InputError(f"{file}: {field}: expected {expected}, got {got!r}", field=field,
                      value=got, expected=expected)


def _parameters_mapping(data: Any, file: Path) -> Mapping[str, Any]:
    """The mapping holding the three keys: the document, or its one planning group's entry."""
    keys = (GEOMETRY_KEY, OFFSETS_KEY, SIGNS_KEY)
    if isinstance(data, Mapping) and all(key in data for key in keys):
        return data
    if isinstance(data, Mapping):
        groups = [value for value in data.values()
                  if isinstance(value, Mapping) and all(key in value for key in keys)]
        if len(groups) == 1:
            return groups[0]
    raise _error(file, "file", f"the keys {list(keys)} at the top level or under one planning "
                               "group", sorted(data) if isinstance(data, Mapping) else data)


def _number(value: Any, file: Path, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or \
            not math.isfinite(value):
        raise _error(file, field, "a finite number", value)
    return float(value)


def _sign(value: Any, file: Path, field: str) -> float:
    if isinstance(value, bool) or value not in (1, -1):
        raise _error(file, field, "1 or -1", value)
    return float(value)


def _angle(value: Any, file: Path, field: str) -> float:
    """A number (rad), or rosparam's ``deg(X)`` / ``rad(X)`` with X a number or ``N*pi/M``."""
    if not isinstance(value, str):
        return _number(value, file, field)
    found = re.fullmatch(r"\s*(deg|rad)\s*\((.*)\)\s*", value)
    amount = _pi_expression(found.group(2)) if found else None
    if found is None or amount is None:
        raise _error(file, field, "a number (rad), deg(X) or rad(X) with X a number or N*pi/M",
                     value)
    return math.radians(amount) if found.group(1) == "deg" else amount


def _pi_expression(text: str) -> float | None:
    found = _PI_TERM.fullmatch(text.strip())
    if found is None or (found.group(2) is None and found.group(3) is None):
        return None
    sign, number, pi, divisor = found.groups()
    value = float(number) if number is not None else 1.0
    value *= math.pi if pi else 1.0
    if divisor is not None:
        if pi is None or float(divisor) == 0.0:
            return None
        value /= float(divisor)
    return -value if sign == "-" else value


def _six(value: Any, file: Path, field: str, read: Any) -> list[float]:
    if not isinstance(value, list) or len(value) != 6:
        raise _error(file, field, "a list of 6 values", value)
    return [read(item, file, f"{field}[{k}]") for k, item in enumerate(value)]


def _frame(value: Any, file: Path, field: str) -> NDArray[np.float64]:
    if value is None:
        return np.eye(4)
    if not isinstance(value, Mapping) or sorted(value) != ["rpy", "xyz"]:
        raise _error(file, field, "{xyz: [x, y, z], rpy: [r, p, y]}", value)
    xyz = [_number(v, file, f"{field}.xyz") for v in value["xyz"]]
    rpy = [_number(v, file, f"{field}.rpy") for v in value["rpy"]]
    if len(xyz) != 3 or len(rpy) != 3:
        raise _error(file, field, "3 values each in xyz and rpy", value)
    return xyz_rpy_to_matrix(np.array(xyz), np.array(rpy))


# --------------------------------------------------------------------------------------------
# Fields, forms and blame


def _fields(params: OPWParameters) -> dict[str, float]:
    """Every scalar of a parameter set by its name in the file, plus the fixed frames."""
    fields = {f"{GEOMETRY_KEY}.{key}": value for key, value in params.geometric.items()}
    fields |= {f"{OFFSETS_KEY}[{k}]": v for k, v in enumerate(params.offsets)}
    fields |= {f"{SIGNS_KEY}[{k}]": float(s) for k, s in enumerate(params.sign_corrections)}
    fields[f"{FRAMES_KEY} (base)"] = 0.0 if params.base_is_identity else 1.0
    fields[f"{FRAMES_KEY} (tool)"] = 0.0 if params.tool_is_identity else 1.0
    return fields


def _with(target: OPWParameters, source: OPWParameters, names: list[str]) -> OPWParameters:
    """``target`` with the named fields of ``source``."""
    geometric = dict(target.geometric)
    offsets, signs = list(target.offsets), list(target.sign_corrections)
    base, tool = target.base, target.tool
    for name in names:
        if name.startswith(GEOMETRY_KEY):
            key = name.split(".")[1]
            geometric[key] = source.geometric[key]
        elif name.startswith(OFFSETS_KEY):
            k = int(name[len(OFFSETS_KEY) + 1])
            offsets[k] = source.offsets[k]
        elif name.startswith(SIGNS_KEY):
            k = int(name[len(SIGNS_KEY) + 1])
            signs[k] = source.sign_corrections[k]
        elif name.endswith("(base)"):
            base = source.base
        else:
            tool = source.tool
    return replace(target, **geometric, offsets=tuple(offsets),  # type: ignore[arg-type]
                   sign_corrections=tuple(signs), base=base, tool=tool)  # type: ignore[arg-type]


def _same(field: str, a: float, b: float) -> bool:
    """Equal values of a field (offsets modulo 2 pi), to the FK tolerance's scale."""
    from dhkin.opw import TOLERANCE

    if field.startswith(OFFSETS_KEY):
        return abs(math.remainder(a - b, 2.0 * math.pi)) <= TOLERANCE
    return abs(a - b) <= TOLERANCE


def _wrist_flipped(params: OPWParameters) -> OPWParameters:
    """The same arm with axis 5 turned around: sign 5 and offset 5 negated, offsets 4 and 6
    less pi (Rz(t4 + pi) Ry(-t5) Rz(t6 + pi) = Rz(t4) Ry(t5) Rz(t6))."""
    o = list(params.offsets)
    s = list(params.sign_corrections)
    o[3] = math.remainder(o[3] - math.pi, 2.0 * math.pi)
    o[4] = -o[4]
    o[5] = math.remainder(o[5] - math.pi, 2.0 * math.pi)
    s[4] = -s[4]
    return replace(params, offsets=tuple(o), sign_corrections=tuple(s))  # type: ignore[arg-type]


def _nearest_form(ours: OPWParameters, published: OPWParameters,
                  q: NDArray[np.float64]) -> OPWParameters:
    """dhkin's parameters, or their wrist-flipped form (checked to give the same FK), whichever
    has fewer fields unlike the file's."""
    from dhkin.opw import TOLERANCE

    flipped = _wrist_flipped(ours)
    if float(np.abs(flipped.fk(q) - ours.fk(q)).max()) > TOLERANCE:
        return ours

    def unlike(form: OPWParameters) -> int:
        theirs = _fields(published)
        return sum(not _same(f, v, theirs[f]) for f, v in _fields(form).items())

    return min((ours, flipped), key=unlike)


def _blame(published: OPWParameters, ours: OPWParameters, differing: list[str],
           table: DHTable, q: NDArray[np.float64], tolerance: float) -> tuple[Blame, ...]:
    """Greedy: dhkin's value of the field that brings the file's FK closest to the table's,
    then the next, until the FK agrees or no field is left."""
    truth = table.fk(q)
    chosen: list[str] = []
    blamed: list[Blame] = []
    remaining = list(differing)
    while remaining:
        trials = {name: float(np.abs(_with(published, ours, [*chosen, name]).fk(q)
                                     - truth).max()) for name in remaining}
        name = min(trials, key=lambda n: trials[n])
        chosen.append(name)
        remaining.remove(name)
        blamed.append(Blame(name, _fields(published)[name], _fields(ours)[name], trials[name]))
        if trials[name] <= tolerance:
            break
    return tuple(blamed)
