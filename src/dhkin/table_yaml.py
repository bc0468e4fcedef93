"""Reading the YAML of a DH table file, with bounded cost: YAML 1.2 through ruamel.yaml's safe,
pure-Python loader, and every hostile or sloppy input turned into a one-line :class:`DHError`.

Why YAML 1.2 (not PyYAML's 1.1): in 1.1 ``6:00`` is the base-60 number 360, ``1e-1`` is text and
``yes``/``no``/``on``/``off`` are booleans; in 1.2 ``1e-1`` is a number and the others are text,
which the table checks then reject or accept by what the field expects.

What is read, and the limits checked before the structure is built (each named below):

* the file: at most :data:`MAX_TABLE_BYTES` bytes, read without reading more, decoded as UTF-8;
* the YAML: one document, nested at most :data:`MAX_YAML_DEPTH` deep, of at most
  :data:`MAX_YAML_NODES` nodes counted with every alias expanded (a "billion laughs" stops here,
  while the events are read, before any node exists), no alias inside its own anchor;
* only plain data: mappings, lists, strings, numbers, booleans and null (YAML's core schema);
  any other tag (``!!python/...``, ``!!binary``, ``!!set``, dates, custom ``!tags``) and merge
  keys (``<<:``) are rejected, as is a key given twice in one mapping (with both lines) and a key
  that is a list or a mapping.

Error messages read ``<file>: <field>: <what was expected>, got <value>``, where the field is the
path of the entry in the file (``joints[2].a``), or the line for a YAML syntax error.
"""

from __future__ import annotations

import copy
import functools
import reprlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ruamel.yaml import YAML
from ruamel.yaml.error import MarkedYAMLError, YAMLError
from ruamel.yaml.events import (
    AliasEvent,
    CollectionEndEvent,
    CollectionStartEvent,
    DocumentStartEvent,
    Event,
    ScalarEvent,
)
from ruamel.yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode
from ruamel.yaml.reader import ReaderError

from dhkin.errors import DHError

#: Largest table file read, in bytes (1 MiB). A table is a few KB (a 32-joint table with every
#: key and a correction per joint, as table_to_yaml writes it, is 12 KB); 1 MiB leaves room for
#: long descriptions and comments while bounding what reading costs (the pure-Python YAML reader
#: takes about a second per MiB).
MAX_TABLE_BYTES = 1 << 20


#: Most YAML nodes (mappings, lists and values) a table file may hold, counted with every alias
#: expanded. A table with the most joints (dhkin.dh.MAX_JOINTS) and every key and a correction per
#: joint has 1,173 nodes; 20,000 leaves a wide margin, and stops an alias bomb (376 bytes that
#: expand to 10^9 nodes) after 20,000 cheap steps.
MAX_YAML_NODES = 20_000


#: Deepest nesting of lists and mappings in a table file. A table nests 5 deep (the file, joints,
#: a joint, its correction, its xyz); 16 leaves room for sloppy input to reach the field checks,
#: and keeps the (recursive) composition of nodes far from Python's recursion limit.
MAX_YAML_DEPTH = 16


#: The tags of plain data (YAML 1.2 core schema): everything a table needs.
CORE_TAGS: frozenset[str] = frozenset(
    f"tag:yaml.org,2002:{name}" for name in ("map", "seq", "str", "int", "float", "bool", "null"))


_MERGE_TAG = "tag:yaml.org,2002:merge"


#: Longest text of the YAML reader's own complaint that a message repeats.
_MAX_PROBLEM = 200


#: Values in messages: at most 60 characters of a string, 6 items of a list (bounded, one line).
_SHORT = reprlib.Repr()
_SHORT.maxstring, _SHORT.maxother, _SHORT.maxlist, _SHORT.maxdict = 60, 60, 6, 4
_SHORT.maxtuple, _SHORT.maxset, _SHORT.maxlevel = 6, 6, 3


def field_key(key: Any) -> str:
    """A mapping key as part of a field's name in a message: as written when it is short,
    printable text, else its bounded repr."""
    if isinstance(key, str) and 0 < len(key) <= _SHORT.maxstring and key.isprintable() \
            and key.strip() == key:
        return key
    return shown(key)


def shown(value: Any) -> str:
    """``repr(value)`` cut to a bounded, one-line length for error messages."""
    return _SHORT.repr(value)


def read_table_text(path: str | Path) -> str:
    """The text of a table file: at most :data:`MAX_TABLE_BYTES` bytes, UTF-8. A file that cannot
    be read (missing, a folder, no permission), is too large or is not UTF-8 gives a DHError."""
    file = Path(path)
    try:
        with file.open("rb") as stream:
            data = stream.read(MAX_TABLE_BYTES + 1)
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise DHError(f"{file}: cannot read DH table file ({reason})", field="file",
                      value=str(file), expected="a readable DH table file") from exc
    if len(data) > MAX_TABLE_BYTES:
        raise DHError(f"{file}: expected a DH table file of at most {MAX_TABLE_BYTES} bytes "
                      f"(dhkin.table_yaml.MAX_TABLE_BYTES), got more", field="file",
                      value=str(file), expected=f"at most {MAX_TABLE_BYTES} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise DHError(f"{file}: line {line}: expected UTF-8 text, got the byte "
                      f"{data[exc.start]:#04x} (byte {exc.start} of the file)",
                      field=f"line {line}", value=data[exc.start:exc.start + 1],
                      expected="UTF-8 text") from exc


#: Texts whose data :func:`load_yaml` keeps (the most recently read), in each of two caches: the
#: built-in robots' table files (73; ``builtin=True``, from :func:`dhkin.table_file.load_table`),
#: and every other text. Apart, a session that reads many texts of its own (generated, written
#: back, fuzzed: the test suite reads ~2400 distinct ones per worker) does not push the built-in
#: tables out and parse them again (1390 such parses in one worker's run of the suite, ~12 ms
#: each). Each entry is a text of at most :data:`MAX_TABLE_BYTES` and its data.
PARSED_TEXTS_KEPT = 146


def load_yaml(text: str, source: str = "<table>", builtin: bool = False) -> Any:
    """The data of YAML ``text`` (one document, plain data only), within the limits of this
    module; any fault gives a one-line DHError that names ``source`` and the field or line.

    The data of a text read before is a copy of what its first read gave (the same text gives
    the same data: the parse is pure), without parsing it again: ruamel's pure-Python parser
    costs ~12 ms a table, a load of a built-in robot nearly all of it. ``builtin``: the text of
    a built-in robot's table file, kept apart from other texts (:data:`PARSED_TEXTS_KEPT`).
    Faults are not kept: a faulty text is parsed, and its error raised, each time."""
    return copy.deepcopy((_parsed_builtin if builtin else _parsed)(text, source))


def _parse(text: str, source: str) -> Any:
    """:func:`load_yaml` of a text not kept: the checks and the parse."""
    yaml = YAML(typ="safe", pure=True)
    yaml.version = (1, 2)
    try:
        _check_events(yaml.parse(text), source)
        node = yaml.compose(text)
    except YAMLError as exc:
        raise _syntax_error(exc, text, source) from exc
    if node is None:
        return None
    _check_nodes(node, source)
    try:
        return yaml.constructor.construct_document(node)
    except (YAMLError, ValueError, TypeError, OverflowError) as exc:  # e.g. a key twice as 1, 01
        raise _syntax_error(exc, text, source) from exc


#: The two caches of :data:`PARSED_TEXTS_KEPT` texts each (see :func:`load_yaml`).
_parsed = functools.lru_cache(maxsize=PARSED_TEXTS_KEPT)(_parse)
_parsed_builtin = functools.lru_cache(maxsize=PARSED_TEXTS_KEPT)(_parse)


def _check_events(events: Iterator[Event], source: str) -> None:
    """Depth and node count (aliases expanded) from the parser's events, before any node is made:
    each alias counts the nodes of its anchor; an alias inside its own anchor is rejected."""
    depth = 0
    total = 0
    open_anchors: list[tuple[str | None, int]] = []  # (anchor, total before the collection)
    sizes: dict[str, int] = {}  # expanded node count of every closed anchor
    for event in events:
        if isinstance(event, DocumentStartEvent) and event.version not in (None, (1, 2)):
            line = event.start_mark.line + 1
            version = ".".join(str(part) for part in event.version)
            raise DHError(f"{source}: line {line}: expected YAML 1.2 (dhkin reads table files "
                          f"as YAML 1.2), got the directive %YAML {version}", field=f"line {line}",
                          value=f"%YAML {version}", expected="YAML 1.2")
        if isinstance(event, CollectionStartEvent):
            depth += 1
            if depth > MAX_YAML_DEPTH:
                line = event.start_mark.line + 1
                raise DHError(f"{source}: line {line}: expected lists and mappings nested at "
                              f"most {MAX_YAML_DEPTH} deep (dhkin.table_yaml.MAX_YAML_DEPTH), "
                              f"got deeper", field=f"line {line}",
                              expected=f"nesting at most {MAX_YAML_DEPTH} deep")
            if event.anchor is not None:
                sizes.pop(event.anchor, None)  # redefined: not usable until it closes
            open_anchors.append((event.anchor, total))
            total += 1
        elif isinstance(event, CollectionEndEvent):
            depth -= 1
            anchor, before = open_anchors.pop()
            if anchor is not None:
                sizes[anchor] = total - before
        elif isinstance(event, ScalarEvent):
            total += 1
            if event.anchor is not None:
                sizes[event.anchor] = 1
        elif isinstance(event, AliasEvent):
            line = event.start_mark.line + 1
            if event.anchor not in sizes:
                inside = any(anchor == event.anchor for anchor, _ in open_anchors)
                what = "inside its own anchor" if inside else "without an anchor before it"
                raise DHError(f"{source}: line {line}: expected an alias of an earlier anchor, "
                              f"got *{event.anchor} {what}", field=f"line {line}",
                              value=f"*{event.anchor}", expected="an alias of an earlier anchor")
            total += sizes[event.anchor]
        if total > MAX_YAML_NODES:
            line = event.start_mark.line + 1
            raise DHError(f"{source}: line {line}: expected at most {MAX_YAML_NODES} YAML nodes "
                          f"with aliases expanded (dhkin.table_yaml.MAX_YAML_NODES), got more",
                          field=f"line {line}", expected=f"at most {MAX_YAML_NODES} nodes")


def _check_nodes(root: Node, source: str) -> None:
    """Plain data only (:data:`CORE_TAGS`), no merge keys, every key a value given once: walks
    the composed nodes (each once, without recursion), naming each entry by its path."""
    stack: list[tuple[Node, str]] = [(root, "")]
    seen: set[int] = set()
    while stack:
        node, path = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        field = path or "the file"
        line = node.start_mark.line + 1
        if node.tag not in CORE_TAGS:
            raise DHError(f"{source}: {field}: expected plain YAML data (a mapping, list, text, "
                          f"number, boolean or null), got the tag {shown(node.tag)} (line "
                          f"{line}; quote a value to make it text)",
                          field=field, value=node.tag, expected="plain YAML data")
        if isinstance(node, SequenceNode):
            stack.extend((child, f"{path}[{k}]") for k, child in enumerate(node.value))
        elif isinstance(node, MappingNode):
            first_marks: dict[tuple[str, str], tuple[int, int]] = {}
            for key_node, value_node in node.value:
                key_line = key_node.start_mark.line + 1
                key_column = key_node.start_mark.column + 1
                if key_node.tag == _MERGE_TAG:
                    raise DHError(f"{source}: {field}: YAML merge keys are not supported, got "
                                  f"'<<' (line {key_line}); expected every key written out",
                                  field=field, value="<<", expected="every key written out")
                if not isinstance(key_node, ScalarNode) or key_node.tag not in CORE_TAGS:
                    kind = "a list" if isinstance(key_node, SequenceNode) else (
                        "a mapping" if isinstance(key_node, MappingNode) else shown(key_node.tag))
                    raise DHError(f"{source}: {field}: expected keys that are plain values, got "
                                  f"{kind} as a key (line {key_line})", field=field,
                                  expected="keys that are plain values")
                key = (key_node.tag, key_node.value)
                name = field_key(key_node.value)
                child = f"{path}.{name}" if path else name
                if key in first_marks:
                    first_line, first_column = first_marks[key]
                    where = (f"line {key_line}, columns {first_column} and {key_column}"
                             if first_line == key_line else f"lines {first_line} and {key_line}")
                    raise DHError(f"{source}: {child}: given twice in one mapping ({where}); "
                                  f"expected each key once", field=child, value=key_node.value,
                                  expected="each key once")
                first_marks[key] = (key_line, key_column)
                stack.append((value_node, child))


def _syntax_error(exc: Exception, text: str, source: str) -> DHError:
    """A one-line DHError for what the YAML reader rejected, naming the line where known."""
    line: int | None = None
    if isinstance(exc, MarkedYAMLError):
        mark = exc.problem_mark or exc.context_mark
        problem = str(exc.problem or exc.context or "invalid YAML")
        line = mark.line + 1 if mark is not None else None
    elif isinstance(exc, ReaderError):
        character = chr(exc.character) if isinstance(exc.character, int) else exc.character
        problem = f"the character {shown(character)}, which YAML does not allow"
        if isinstance(exc.position, int):
            line = text.count("\n", 0, exc.position) + 1
    else:
        problem = str(exc)
    problem = " ".join(problem.split())
    if len(problem) > _MAX_PROBLEM:
        problem = problem[:_MAX_PROBLEM] + "..."
    where = f"line {line}" if line is not None else "YAML"
    return DHError(f"{source}: {where}: not valid YAML ({problem})", field=where,
                   expected="valid YAML")
