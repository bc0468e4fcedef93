"""Hostile and sloppy table files (issue 15): every bad input a one-line DHError, bounded cost.

Covers the issue's reproducers (an alias bomb, YAML 1.1 readings, unreadable and non-UTF-8 files,
an empty ``flange:``, absurd joint counts and joint ranges), every named limit at its edge (the
limit accepted, one past it rejected), the switch to YAML 1.2 (every table file in the repository
reads back bit for bit) and a seeded fuzz of the built-in tables.
"""

from __future__ import annotations

import copy
import itertools
import math
import random
import struct
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import dhkin
from dhkin import cli
from dhkin.builtin import builtin_names, resolve_table_path
from dhkin.dh import (
    DEFAULT_FLANGE_RPY_DEG,
    MAX_JOINT_TURNS,
    MAX_JOINTS,
    MAX_LENGTH,
    DHTable,
    check_table_limits,
)
from dhkin.errors import DHError, RobotNotFoundError
from dhkin.table_file import load_table, parse_table, read_back, table_to_yaml
from dhkin.table_yaml import (
    MAX_TABLE_BYTES,
    MAX_YAML_DEPTH,
    MAX_YAML_NODES,
    PARSED_TEXTS_KEPT,
    load_yaml,
    read_table_text,
)
from dhkin.transforms import xyz_rpy_to_matrix

from .conftest import DATA, REPO

ROBOTS = REPO / "robots"
DEG = math.pi / 180.0

#: A small valid table; tests put one defect into it.
PLANAR = """\
name: planar
convention: standard
units: {length: m, angle: deg}
joints:
  - {a: 0.5, alpha: 0, d: 0, lower: -170, upper: 170}
  - {a: 0.4, alpha: 0, d: 0, lower: -170, upper: 170}
"""


def one_line_error(error: BaseException, source: str | Path) -> str:
    """The message of a dhkin error, checked to be one line that starts with the file's name
    and names a field."""
    message = str(error)
    assert "\n" not in message and "\r" not in message, message
    assert message.startswith(f"{source}: "), message
    assert isinstance(error, dhkin.DhkinError) and error.field, message
    return message


def table_error(text: str, tmp_path: Path, name: str = "t.yaml") -> str:
    """Write ``text`` to a file, load it, and return the one-line DHError's message."""
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DHError) as info:
        load_table(path)
    return one_line_error(info.value, path)


def joint_line(k: int, lower: str = "-170", upper: str = "170", a: str = "0.1") -> str:
    return f"  - {{a: {a}, alpha: 0, d: 0, lower: {lower}, upper: {upper}}}\n"


def table_text(joints: int, **row: str) -> str:
    """A valid planar table of ``joints`` rows (each row's values overridable)."""
    head = "name: arm\nconvention: standard\nunits: {length: m, angle: deg}\njoints:\n"
    return head + "".join(joint_line(k, **row) for k in range(joints))


# -- the reproducers ------------------------------------------------------------------

def alias_bomb() -> str:
    """Billion laughs under ``name:``: 9 levels of 9 aliases, 10^9 strings when expanded."""
    lines = ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    names = "abcdefghi"
    for previous, current in itertools.pairwise(names):
        lines.append(f"{current}: &{current} [" + ",".join([f"*{previous}"] * 9) + "]")
    body = "\n".join(f"  {line}" for line in lines)
    return f"name:\n{body}\nconvention: standard\n"


def test_the_alias_bomb_stops_at_the_node_limit_at_once(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    text = alias_bomb()
    assert len(text.encode()) < 400  # the file is 376 bytes
    start = time.perf_counter()
    message = table_error(text, tmp_path)
    assert f"at most {MAX_YAML_NODES} YAML nodes with aliases expanded" in message
    path = tmp_path / "t.yaml"
    assert cli.main(["fk", str(path), "0", "0"]) == cli.EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "MAX_YAML_NODES" in err
    assert time.perf_counter() - start < 5.0  # was 30 s and 2.3 GB


def test_nesting_a_thousand_deep_is_a_depth_error_not_a_recursion_error(tmp_path: Path) -> None:
    message = table_error("name: " + "[" * 1000 + "]" * 1000 + "\n", tmp_path)
    assert f"nested at most {MAX_YAML_DEPTH} deep" in message
    message = table_error("name:" + "".join("\n" + "  " * k + "k:" for k in range(1, 1000)),
                          tmp_path)
    assert f"nested at most {MAX_YAML_DEPTH} deep" in message


def test_a_text_read_again_gives_a_fresh_copy_of_its_data(tmp_path: Path) -> None:
    """load_yaml keeps the data of texts it has read: a caller's change to the data it got does
    not reach the next read, a file changed on disk is read anew, a faulty text fails every
    time, and more texts than PARSED_TEXTS_KEPT are all read right."""
    text = (REPO / "robots" / "ur5.yaml").read_text()
    first = load_yaml(text, "ur5.yaml")
    first["name"] = "changed"
    first["joints"][0]["d"] = 123.0
    second = load_yaml(text, "ur5.yaml")
    assert second == load_yaml(text, "another source") == yaml.safe_load(text)
    assert second["name"] != "changed" and second["joints"][0]["d"] != 123.0
    path = tmp_path / "t.yaml"
    path.write_text(text)
    before = load_table(path)
    path.write_text(text.replace(f"name: {second['name']}", "name: renamed"))
    assert load_table(path).name == "renamed" != before.name
    bad = text + "\nname: twice\n"
    for _ in range(2):
        with pytest.raises(DHError, match=r"bad\.yaml: name: given twice in one mapping"):
            load_yaml(bad, "bad.yaml")
    texts = [f"value: {k}\n" for k in range(PARSED_TEXTS_KEPT + 10)]
    for _ in range(2):
        assert [load_yaml(t)["value"] for t in texts] == list(range(PARSED_TEXTS_KEPT + 10))


def test_built_in_tables_stay_kept_while_other_texts_are_read() -> None:
    """A built-in robot's table, once read, is not parsed again after more than
    PARSED_TEXTS_KEPT other texts (its own cache); its data is the file's, as a fresh copy."""
    from dhkin import table_yaml

    path = resolve_table_path("ur5")
    load_table(path)
    for k in range(PARSED_TEXTS_KEPT + 10):
        load_yaml(f"kept_test: {k}\n")
    before = table_yaml._parsed_builtin.cache_info()
    again = load_table(path)
    after = table_yaml._parsed_builtin.cache_info()
    assert (after.hits, after.misses) == (before.hits + 1, before.misses)
    fresh = read_back(path.read_text(encoding="utf-8"))
    assert again.name == fresh.name and again.joints == fresh.joints


def test_yaml_1_2_numbers_and_text(tmp_path: Path) -> None:
    """1e-1 is a number (YAML 1.1 read it as text); 6:00 is text (1.1: 360, base 60)."""
    path = tmp_path / "t.yaml"
    path.write_text(PLANAR.replace("a: 0.4", "a: 1e-1"), encoding="utf-8")
    assert load_table(path).joints[1].a == 0.1
    message = table_error(PLANAR.replace("upper: 170}\n  - ", "upper: 6:00}\n  - "), tmp_path)
    assert message.endswith("joints[0].upper: expected a finite number, got '6:00'")
    message = table_error("%YAML 1.1\n---\n" + PLANAR, tmp_path)
    assert "expected YAML 1.2" in message and "%YAML 1.1" in message


@pytest.mark.parametrize("word", ["yes", "no", "on", "off", "y", "n", "True", "false"])
def test_yaml_1_1_booleans(word: str, tmp_path: Path) -> None:
    """yes/no/on/off are text in YAML 1.2: a name like any other; where a number or a choice is
    expected the message shows the word. true/false stay booleans and are no numbers."""
    path = tmp_path / "t.yaml"
    path.write_text(PLANAR.replace("a: 0.5,", f"name: '{word}', a: 0.5,"), encoding="utf-8")
    assert load_table(path).joints[0].name == word
    path.write_text(PLANAR.replace("a: 0.5,", f"name: {word}, a: 0.5,"), encoding="utf-8")
    if word.lower() in ("true", "false"):
        message = table_error(path.read_text(), tmp_path)
        assert "joints[0].name: expected a name" in message
    else:
        assert load_table(path).joints[0].name == word
    message = table_error(PLANAR.replace("lower: -170, upper: 170}\n  - ",
                                         f"direction: {word}, lower: -170, upper: 170}}\n  - "),
                          tmp_path)
    assert "joints[0].direction: expected 1 or -1, got" in message
    message = table_error(PLANAR.replace("convention: standard", f"convention: {word}"),
                          tmp_path)
    assert "convention: expected one of ['standard', 'modified'], got" in message


def test_duplicate_keys_python_tags_and_merge_keys(tmp_path: Path) -> None:
    message = table_error(PLANAR + "convention: modified\n", tmp_path)
    assert message.endswith("convention: given twice in one mapping (lines 2 and 7); expected "
                            "each key once")
    message = table_error(PLANAR.replace("name: planar", "name: !!python/object/apply:os.system "
                                                         "['true']"), tmp_path)
    assert ": name: expected plain YAML data" in message and "python/object/apply" in message
    message = table_error(PLANAR.replace("name: planar", "name: !!python/name:os.system x"),
                          tmp_path)
    assert ": name: expected plain YAML data" in message
    message = table_error("defaults: &d {alpha: 0, d: 0}\n" + PLANAR.replace(
        "{a: 0.5, alpha: 0, d: 0,", "{<<: *d, a: 0.5,"), tmp_path)
    assert "joints[0]: YAML merge keys are not supported" in message
    message = table_error(PLANAR.replace("name: planar", "name: 2024-01-31"), tmp_path)
    assert ": name: expected plain YAML data" in message and "timestamp" in message


def test_unreadable_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Not UTF-8, a folder, no permission: one-line errors naming the file."""
    path = tmp_path / "latin1.yaml"
    path.write_bytes(PLANAR.replace("planar", "plan\xe4r").encode("latin-1"))
    with pytest.raises(DHError) as info:
        load_table(path)
    message = one_line_error(info.value, path)
    assert "line 1: expected UTF-8 text, got the byte 0xe4" in message
    with pytest.raises(DHError) as info:
        load_table(tmp_path)
    assert "cannot read DH table file" in one_line_error(info.value, tmp_path)
    with pytest.raises(RobotNotFoundError) as caught:
        dhkin.load(tmp_path)
    assert one_line_error(caught.value, tmp_path).endswith("is a folder, not a DH table file")
    folder = tmp_path / "folder.yaml"
    folder.mkdir()
    with pytest.raises(RobotNotFoundError, match="is a folder"):
        resolve_table_path(folder)

    good = tmp_path / "good.yaml"
    good.write_text(PLANAR, encoding="utf-8")

    def denied(self: Path, *args: Any, **kwargs: Any) -> Any:
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "open", denied)  # tests run as root: chmod would not stop them
    with pytest.raises(DHError) as info:
        dhkin.load(good)
    assert one_line_error(info.value, good).endswith(
        "cannot read DH table file (Permission denied)")


@pytest.mark.parametrize("key", ["base", "tool", "flange"])
def test_an_empty_frame_takes_its_documented_default(key: str, tmp_path: Path) -> None:
    """``flange:`` left empty (YAML null) was the identity; like every optional key left empty it
    now means the key's default: flange rpy (0, -90, 0) deg, base and tool the identity."""
    path = tmp_path / "t.yaml"
    path.write_text(PLANAR.replace("joints:", f"{key}:\njoints:"), encoding="utf-8")
    table = load_table(path)
    default = xyz_rpy_to_matrix((0, 0, 0), np.radians(DEFAULT_FLANGE_RPY_DEG))
    np.testing.assert_array_equal(table.flange, default)
    np.testing.assert_array_equal(table.base, np.eye(4))
    np.testing.assert_array_equal(table.tool, np.eye(4))


def test_optional_joint_keys_left_empty_take_their_defaults(tmp_path: Path) -> None:
    path = tmp_path / "t.yaml"
    path.write_text(PLANAR.replace("{a: 0.5,", "{name: , link: , direction: , offset: , "
                                                "velocity: , effort: , correction: , type: , "
                                                "a: 0.5,").replace("units:", "description:\n"
                                                                             "units:"),
                    encoding="utf-8")
    table = load_table(path)
    plain = parse_table(yaml.safe_load(PLANAR))
    assert table.joints == plain.joints and table.description == ""
    message = table_error(PLANAR.replace("a: 0.5,", "a: ,"), tmp_path)
    assert message.endswith("joints[0].a: expected a finite number, got None")


def test_hundreds_of_joints_are_rejected_before_any_work(tmp_path: Path) -> None:
    for joints in (500, 1000):
        message = table_error(table_text(joints), tmp_path)
        assert message.endswith(f"joints: expected at most {MAX_JOINTS} joints "
                                f"(dhkin.dh.MAX_JOINTS: an arm), got {joints}")
    message = table_error(table_text(10_000), tmp_path)  # stopped even earlier, by the YAML
    assert "YAML nodes" in message
    joint = load_table(DATA / "custom_arm_modified.yaml").joints[0]
    start = time.perf_counter()
    with pytest.raises(DHError, match=r"^joints: expected at most 32 joints .*got 10000$"):
        DHTable(name="many", convention="standard", joints=(joint,) * 10_000)
    assert time.perf_counter() - start < 0.5


@pytest.mark.parametrize("limit", ["36000", "1e308", "-1.0e+308", "99999999999999999999999"])
def test_absurd_joint_ranges_are_rejected(limit: str, tmp_path: Path) -> None:
    """+-36000 deg made the IK allocate 229 TiB for its 2pi copies; 1e308 overflowed."""
    upper = limit if not limit.startswith("-") else "170"
    lower = limit if limit.startswith("-") else "-170"
    message = table_error(table_text(2, lower=lower, upper=upper), tmp_path)
    field = "lower" if limit.startswith("-") else "upper"
    assert f"joints[0].{field}: expected a joint limit within +-720 deg (+-4pi rad, " \
           f"dhkin.dh.MAX_JOINT_TURNS = 2 turns), got" in message


# -- every limit at its edge ------------------------------------------------------------------

def test_file_size_limit(tmp_path: Path) -> None:
    path = tmp_path / "big.yaml"
    text = PLANAR + "#" * (MAX_TABLE_BYTES - len(PLANAR) - 1) + "\n"
    assert len(text.encode()) == MAX_TABLE_BYTES
    path.write_text(text, encoding="utf-8")
    assert load_table(path).dof == 2
    path.write_text(text + " ", encoding="utf-8")
    with pytest.raises(DHError) as info:
        load_table(path)
    assert f"at most {MAX_TABLE_BYTES} bytes" in one_line_error(info.value, path)


def nodes_text(total: int) -> str:
    """A YAML list of exactly ``total`` nodes, most of them through an alias of 9 scalars:
    the list (1) + the anchored list (10) + m aliases (10 each) + p single scalars."""
    aliases, pad = divmod(total - 11, 10)
    return ("[&x [0, 0, 0, 0, 0, 0, 0, 0, 0]" + ", *x" * aliases + ", 0" * pad + "]")


def test_node_limit_counts_aliases_expanded() -> None:
    assert len(load_yaml(nodes_text(MAX_YAML_NODES))) == 1 + (MAX_YAML_NODES - 11) // 10 \
        + (MAX_YAML_NODES - 11) % 10
    with pytest.raises(DHError, match=f"at most {MAX_YAML_NODES} YAML nodes"):
        load_yaml(nodes_text(MAX_YAML_NODES + 1))
    plain = "[" + ", ".join(["0"] * (MAX_YAML_NODES - 1)) + "]"
    assert len(load_yaml(plain)) == MAX_YAML_NODES - 1
    with pytest.raises(DHError, match="YAML nodes"):
        load_yaml(plain[:-1] + ", 0]")


def test_depth_limit_and_recursive_aliases() -> None:
    assert load_yaml("[" * MAX_YAML_DEPTH + "]" * MAX_YAML_DEPTH) is not None
    with pytest.raises(DHError, match=f"nested at most {MAX_YAML_DEPTH} deep"):
        load_yaml("[" * (MAX_YAML_DEPTH + 1) + "]" * (MAX_YAML_DEPTH + 1))
    with pytest.raises(DHError, match=r"got \*x inside its own anchor"):
        load_yaml("a: &x [1, *x]")
    with pytest.raises(DHError, match=r"got \*y without an anchor before it"):
        load_yaml("a: *y")


def test_joint_count_limit(tmp_path: Path) -> None:
    path = tmp_path / "t.yaml"
    path.write_text(table_text(MAX_JOINTS), encoding="utf-8")
    table = load_table(path)
    assert table.dof == MAX_JOINTS
    message = table_error(table_text(MAX_JOINTS + 1), tmp_path)
    assert f"at most {MAX_JOINTS} joints" in message
    with pytest.raises(DHError, match=f"at most {MAX_JOINTS} joints"):
        replace(table, joints=(*table.joints, table.joints[0]))


@pytest.mark.parametrize(("unit", "edge", "past"), [("deg", "720", "720.001"),
                                                    ("rad", repr(4 * math.pi), "12.5664")])
def test_joint_range_limit(unit: str, edge: str, past: str, tmp_path: Path) -> None:
    path = tmp_path / "t.yaml"
    text = table_text(2, lower=f"-{edge}", upper=edge).replace("angle: deg", f"angle: {unit}")
    path.write_text(text, encoding="utf-8")
    table = load_table(path)
    assert table.joints[0].upper == pytest.approx(MAX_JOINT_TURNS * 2 * math.pi, abs=1e-12)
    message = table_error(text.replace(f"upper: {edge}", f"upper: {past}", 1), tmp_path)
    assert message.endswith(f"joints[0].upper: expected a joint limit within +-720 deg (+-4pi "
                            f"rad, dhkin.dh.MAX_JOINT_TURNS = 2 turns), got {past} {unit}; are "
                            "units.angle right?")


def test_joint_range_limit_of_tables_built_in_python() -> None:
    table = dhkin.load("ur5").table
    turns = MAX_JOINT_TURNS * 2 * math.pi
    wide = replace(table, joints=tuple(replace(j, lower=-turns, upper=turns)
                                       for j in table.joints))
    check_table_limits(wide)
    for value in (turns + 1e-6, math.inf, math.nan, 1e308):
        joints = (replace(table.joints[0], upper=value), *table.joints[1:])
        with pytest.raises(DHError) as info:
            replace(table, joints=joints)
        assert info.value.field == "joints[0].upper", str(info.value)
        assert "\n" not in str(info.value)


def test_the_ik_copies_are_bounded_by_the_joint_range_limit() -> None:
    """Every joint at +-2 turns: at most 6 copies per joint, and copies=True answers."""
    table = dhkin.load("ur5").table
    turns = MAX_JOINT_TURNS * 2 * math.pi
    robot = dhkin.Robot(replace(table, joints=tuple(replace(j, lower=-turns, upper=turns)
                                                    for j in table.joints)))
    solver = robot.ik_solver
    assert solver.max_solutions <= solver.n_branches * (2 * MAX_JOINT_TURNS + 2) ** 6
    q = np.array([0.3, -1.1, 1.2, -0.4, 0.9, 2.0])
    sols = robot.ik(robot.fk(q), copies=True)
    assert 0 < len(sols) <= solver.max_solutions
    assert np.all(np.abs(sols.q) <= turns + 1e-9)


@pytest.mark.parametrize(("unit", "edge", "past"), [("m", "1000", "1000.001"),
                                                    ("mm", "1000000", "1000001")])
def test_length_limit(unit: str, edge: str, past: str, tmp_path: Path) -> None:
    path = tmp_path / "edge.yaml"
    text = table_text(2).replace("length: m", f"length: {unit}")
    path.write_text(text.replace("a: 0.1", f"a: {edge}", 1), encoding="utf-8")
    assert load_table(path).joints[0].a == MAX_LENGTH
    message = table_error(text.replace("a: 0.1", f"a: -{past}", 1), tmp_path)
    assert message.endswith(f"joints[0].a: expected a length within +-{edge} {unit} "
                            f"(dhkin.dh.MAX_LENGTH), got -{past} {unit}; are units.length right?")
    message = table_error(text.replace("joints:", f"base: {{xyz: [0, {past}, 0]}}\njoints:"),
                          tmp_path, "base.yaml")
    assert ": base.xyz[1]: expected a length within" in message
    table = load_table(path)
    with pytest.raises(DHError, match=r"^joints\[1\]\.d: expected a length within \+-1000 m"):
        replace(table, joints=(table.joints[0], replace(table.joints[1], d=1000.5)))


# -- YAML 1.2 reads every table in the repository as PyYAML did -------------------------------

def exact(data: Any) -> Any:
    """``data`` with every float as its bits (so that equality is bit-exact: -0.0 != 0.0)."""
    if isinstance(data, dict):
        return {key: exact(value) for key, value in data.items()}
    if isinstance(data, list):
        return [exact(value) for value in data]
    if isinstance(data, float):
        return ("float", struct.pack("<d", data))
    return data


TABLE_FILES = sorted(ROBOTS.glob("*.yaml")) + sorted(DATA.glob("*.yaml"))


@pytest.mark.parametrize("path", TABLE_FILES, ids=[p.name for p in TABLE_FILES])
def test_every_table_file_reads_as_before(path: Path) -> None:
    """Every built-in and test table (hand-written and generated) reads the same, bit for bit,
    under the new YAML 1.2 reader as under PyYAML; table_to_yaml's text of it too."""
    text = read_table_text(path)
    assert exact(load_yaml(text, str(path))) == exact(yaml.safe_load(text))
    table = load_table(path)
    for units in (None, {"length": "mm", "angle": "deg"}):
        written = table_to_yaml(table, units)
        assert exact(load_yaml(written)) == exact(yaml.safe_load(written))
    again = read_back(table_to_yaml(table))
    assert again.joints == table.joints
    for key in ("base", "tool", "flange"):
        np.testing.assert_allclose(getattr(again, key), getattr(table, key), atol=1e-15)


@pytest.mark.parametrize("text", ["1e3", "0o17", "0x1F", "6:00", "yes", "on", "~", "null",
                                  "2024-01-31", "1_000", ".inf", "-.NaN", "<<", "*x", "&y z",
                                  "!t v", "# not a comment", "a: b", "- item", "'quoted'",
                                  "\u00e9t\u00e9 \U0001f916", "line\nbreak", "  spaces  ", ""])
def test_written_text_reads_back_under_both_readers(text: str) -> None:
    """table_to_yaml quotes text that YAML 1.2 or 1.1 would read as something else."""
    table = dhkin.load("planar_2r").table
    written = table_to_yaml(replace(table, description=text, source=text))
    for data in (load_yaml(written), yaml.safe_load(written)):
        assert data.get("description", "") == text and data.get("source", "") == text
    assert read_back(written).description == text


# -- fuzz -------------------------------------------------------------------------------------

#: Values the fuzz puts anywhere: wrong types, non-finite, huge, negative, odd text, nesting.
def _nested(depth: int) -> Any:
    value: Any = 1
    for _ in range(depth):
        value = [value]
    return value


HOSTILE_VALUES: list[Any] = [
    None, True, False, 0, -1, 2, 1e308, -1e308, 10**400, math.nan, math.inf, -math.inf, 1e-320,
    "", "x", "0.35", "6:00", "yes", "\u00e9\U0001f916", "a\nb", "\x00", "x" * 100_000,
    [], [1, 2], [1, 2, 3], ["a", "b", "c"], [math.nan, 0, 0], {}, {"xyz": [0, 0, 0]},
    {"rpy": [1e9, 0, 0]}, {"x": 1}, _nested(200), [[[[[]]]]], -36000, 720, -720, 721, 1000.5,
]


def hostile(rng: random.Random) -> Any:
    """A fresh copy of one of :data:`HOSTILE_VALUES` (later mutations must not change them)."""
    return copy.deepcopy(rng.choice(HOSTILE_VALUES))


def mutate_data(data: Any, rng: random.Random) -> Any:
    """A copy of a parsed table with one to three random defects."""
    data = copy.deepcopy(data)
    for _ in range(rng.randint(1, 3)):
        containers: list[Any] = []
        stack = [data]
        while stack:
            node = stack.pop()
            if isinstance(node, (dict, list)):
                containers.append(node)
                stack.extend(node.values() if isinstance(node, dict) else node)
        target = rng.choice(containers)
        keys = list(target) if isinstance(target, dict) else list(range(len(target)))
        action = rng.random()
        if not keys or action < 0.1:
            if isinstance(target, dict):
                target[rng.choice(["tcp", "d", "theta", "correction", "xyz", 7, "", "name"])] = \
                    hostile(rng)
            else:
                target.append(hostile(rng))
        elif action < 0.3:
            del target[rng.choice(keys)]
        elif action < 0.9:
            target[rng.choice(keys)] = hostile(rng)
        else:  # swap two values
            a, b = rng.choice(keys), rng.choice(keys)
            target[a], target[b] = target[b], target[a]
    return data


def mutate_text(text: str, rng: random.Random) -> bytes:
    """A table file's bytes with a random textual defect."""
    raw = text.encode()
    action = rng.randrange(9)
    at = rng.randrange(len(raw))
    if action == 0:  # random bytes
        return raw[:at] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 8))) + raw[at:]
    if action == 1:  # delete a span
        return raw[:at] + raw[at + rng.randint(1, 40):]
    if action == 2:  # flip one byte
        return raw[:at] + bytes([raw[at] ^ (1 << rng.randrange(8))]) + raw[at + 1:]
    lines = text.splitlines()
    k = rng.randrange(len(lines))
    if action == 3:  # a line twice (duplicate keys, duplicate joints)
        lines.insert(k, lines[k])
    elif action == 4:  # YAML syntax: tags, anchors, aliases, merge keys, directives, flow
        token = rng.choice(["!!python/object:os.system", "&a", "*a", "<<: *a", "!!binary",
                            "%YAML 1.1", "---", "...", "{", "]", "? ", "|", ">-", "!!set",
                            "!custom", "&a [*a]", "'", '"', "\t", "#", ": "])
        column = rng.randrange(len(lines[k]) + 1)
        lines[k] = lines[k][:column] + token + " " + lines[k][column:]
    elif action == 5:  # deep nesting
        depth = rng.choice([MAX_YAML_DEPTH - 3, MAX_YAML_DEPTH, 200])
        lines.insert(k, "deep: " + "[" * depth + "]" * depth)
    elif action == 6:  # an alias bomb at a random place
        lines.insert(k, alias_bomb().replace("name:", "bomb:").rstrip())
    elif action == 7:  # a long string
        lines.insert(k, "description: " + "x" * rng.choice([100, 10_000]))
    else:  # a value replaced by odd text
        column = lines[k].find(": ")
        if column >= 0:
            lines[k] = lines[k][:column + 2] + rng.choice(
                ["6:00", "1e-1", "yes", "0o17", ".nan", "1e999", "~", "2024-01-01", "[]", "{}",
                 "'x'", "0x10", "1_0", "-.inf", "\u00e9", "*a", "&b 1"]) + lines[k][column + 2:]
    return ("\n".join(lines) + "\n").encode("utf-8", "surrogatepass")


def assert_valid_or_one_line_error(parse: Callable[[], DHTable], source: str | Path) -> None:
    """``parse()`` gives a table that works, or a one-line DHError naming the file and a field."""
    try:
        table = parse()
    except DHError as error:
        message = one_line_error(error, source)
        assert len(message) < 1000, message[:200]
        return
    check_table_limits(table)
    assert np.all(np.isfinite(table.fk((table.lower + table.upper) / 2)))


def test_fuzz_parsed_tables() -> None:
    """3,000 mutated built-in tables through the table checks (fixed seed)."""
    rng = random.Random(15)
    parsed = {name: yaml.safe_load(read_table_text(resolve_table_path(name)))
              for name in builtin_names()}
    for _ in range(3000):
        name = rng.choice(sorted(parsed))
        data = mutate_data(parsed[name], rng)
        assert_valid_or_one_line_error(lambda data=data: parse_table(data, "fuzz.yaml"),
                                       "fuzz.yaml")


def test_fuzz_table_files(tmp_path: Path) -> None:
    """800 mutated table files through load_table: bytes, syntax, aliases, nesting (fixed seed)."""
    rng = random.Random(1515)
    texts = [read_table_text(resolve_table_path(name)) for name in ("planar_2r", "planar_3r",
                                                                    "ur5", "stanford_arm")]
    path = tmp_path / "fuzz.yaml"
    for _ in range(800):
        path.write_bytes(mutate_text(rng.choice(texts), rng))
        assert_valid_or_one_line_error(lambda: load_table(path), path)
