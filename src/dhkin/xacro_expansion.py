"""A xacro file expanded to URDF without ROS: ``$(find NAME)`` resolved, every element's source
line kept.

:func:`expand_xacro` is the one call: a vendor's top-level xacro (``kr10r1420.xacro``, which
includes ``$(find kuka_kr10_support)/urdf/kr10r1420_macro.xacro`` and
``$(find kuka_resources)/urdf/common_materials.xacro``) and the folders of the packages it names
(or none: :class:`dhkin.ros_packages.PackageFinder` also reads the environment and the checkout
around the file) -> the URDF text::

    from dhkin.xacro_expansion import expand_xacro
    urdf = expand_xacro("kuka_kr10_support/urdf/kr10r1420.xacro",
                        packages={"kuka_resources": "path/to/kuka_resources"})

:func:`expand_xacro_located` also returns, for every element of the URDF, the line of the
user's file it was written on (the macro file's line for an element a macro made), so that a
fault found in the expanded text (a kinematic loop, a bad axis) names the line the user edits.

How: the xacro package does the expansion. For its duration (under :data:`XACRO_LOCK`: xacro
keeps its state in module globals) three of its functions are replaced: ``$(find)``'s lookup
(``xacro.substitution_args._eval_find``, which imports ROS's ``ament_index_python``) asks the
finder; the file parser (``xacro.parse``) reads each file with :mod:`dhkin.xml_file` (BOM and
declared encodings) and marks each non-xacro element with an attribute :data:`PLACE_ATTRIBUTE`
holding an index into the list of (file, line) places, removed again from the result;
``xacro.eval_all`` notes the innermost marked element a failure happened in. Every failure is
one :class:`URDFError` naming the file and line: an unresolved package (and the ways to give
it), an unset ``$(arg)``, a missing include, XML that is not well-formed, any other xacro error
(with the macro it happened in).
"""

from __future__ import annotations

import os
import re
import threading
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.parsers import expat

from dhkin.errors import DhkinError, URDFError, one_line
from dhkin.ros_packages import PackageFinder, PackageNotFoundError
from dhkin.xml_file import read_xml_file

#: Held while xacro runs (its state is module-global, so one expansion at a time per process).
XACRO_LOCK = threading.RLock()
#: The attribute that carries an element's place through xacro (removed from the result).
PLACE_ATTRIBUTE = "dhkin-place"
#: The comment lines of xacro's banner (" ===...=== ", " |    This document ...   | ").
_BANNER = re.compile(r" (?:=+|\|.*\|) ")
#: The namespace declarations that make a file xacro (besides a name ending in ``.xacro``).
XACRO_NAMESPACES = ("http://www.ros.org/wiki/xacro", "http://ros.org/wiki/xacro",
                    "http://wiki.ros.org/xacro")


@dataclass(frozen=True)
class XacroExpansion:
    """A URDF made by xacro: its ``text``, and for each of its elements in document order the
    place it was written ("line L of FILE"; None for an element xacro made from nothing)."""

    text: str
    places: tuple[str | None, ...]


def is_xacro(path: str | Path, text: str) -> bool:
    """Whether a description is xacro: its name ends in ``.xacro`` or its text declares the
    xacro namespace."""
    return str(path).endswith(".xacro") or any(uri in text for uri in XACRO_NAMESPACES)


def expand_xacro(path: str | Path, packages: Mapping[str, str | Path] | None = None,
                 args: Mapping[str, str] | None = None,
                 environ: Mapping[str, str] | None = None) -> str:
    """The URDF text of the xacro file ``path``: ``packages`` {NAME: folder} for
    ``$(find NAME)`` (else the environment and the checkout around ``path``:
    :mod:`dhkin.ros_packages`), ``args`` its ``name:=value`` arguments, ``environ`` the
    environment to read (default ``os.environ``). The text does not depend on where the files
    lie (xacro's banner, which names the input's path, is left out). URDFError naming the file
    and line when it cannot be expanded."""
    finder = PackageFinder.for_description(path, packages, environ)
    return expand_xacro_located(path, finder, args).text


def expand_xacro_located(path: str | Path, finder: PackageFinder,
                         args: Mapping[str, str] | None = None) -> XacroExpansion:
    """:func:`expand_xacro` with the place of every element (see :class:`XacroExpansion`)."""
    import xacro

    run = _Run(finder, str(path))
    with XACRO_LOCK, run.patched():
        try:
            document = xacro.process_file(str(path), mappings=dict(args or {}))
        except BaseException as exc:  # xacro raises XacroException, XML errors and SystemExit
            if isinstance(exc, KeyboardInterrupt):
                raise
            raise run.error(exc) from exc
        finally:
            del xacro.all_includes[:]  # xacro's list of every file it ever included
    _drop_banner(document)
    places = run.collect(document)
    return XacroExpansion(text=str(document.toxml()), places=places)


def _drop_banner(document: Any) -> None:
    """Remove the banner xacro puts before the root (it names the input's absolute path, so the
    URDF would depend on where the package lies): its rule and "|...|" comment lines."""
    for node in list(document.childNodes):
        if node.nodeType == node.COMMENT_NODE and _BANNER.fullmatch(node.data):
            document.removeChild(node)


def shown_path(path: str) -> str:
    """``path`` relative to the working folder when it lies below it, else as given."""
    try:
        relative = os.path.relpath(path)
    except ValueError:  # another drive (Windows)
        return path
    return path if relative.startswith("..") else relative


def _start_lines(text: str) -> list[int]:
    """The line of every element's start tag, in document order."""
    lines: list[int] = []
    parser = expat.ParserCreate()
    parser.StartElementHandler = lambda tag, attributes: lines.append(
        parser.CurrentLineNumber)
    parser.Parse(text, True)
    return lines


class _Run:
    """The state of one expansion: the finder, the files read and the places marked."""

    def __init__(self, finder: PackageFinder, top: str) -> None:
        self.finder = finder
        self.top = top
        self.places: list[tuple[str, int]] = []
        self.texts: dict[str, str] = {}

    @contextmanager
    def patched(self) -> Iterator[None]:
        import xacro
        import xacro.substitution_args as substitution

        saved = (xacro.parse, xacro.eval_all, substitution._eval_find)
        original_parse, original_eval_all, _ = saved

        def parse(inp: Any, filename: str | None = None) -> Any:
            if inp is not None or filename is None:
                return original_parse(inp, filename)
            stack = xacro.filestack or [filename]
            try:
                text = read_xml_file(os.path.join(xacro.root_dir, filename), "xacro")
            except URDFError as exc:
                if len(stack) < 2:  # the top-level file: its own message
                    raise
                includer = stack[-2]
                line = self._line_of(includer, os.path.basename(filename), None)
                raise URDFError(f"{self._where(includer, line)}<xacro:include> of {filename}: "
                                f"{exc}", field="include", value=filename,
                                expected="a readable file") from exc
            self.texts[filename] = text
            document = original_parse(text)
            self._mark(document, filename, text)
            return document

        def eval_all(node: Any, macros: Any, symbols: Any) -> Any:
            try:
                return original_eval_all(node, macros, symbols)
            except Exception as exc:
                if getattr(exc, "_dhkin_place", None) is None and \
                        node.nodeType == node.ELEMENT_NODE and node.hasAttribute(PLACE_ATTRIBUTE):
                    exc._dhkin_place = int(node.getAttribute(PLACE_ATTRIBUTE))  # type: ignore[attr-defined]
                raise

        def find(name: str) -> str:
            return str(self.finder.find(name))

        xacro.parse, xacro.eval_all, substitution._eval_find = parse, eval_all, find
        try:
            yield
        finally:
            xacro.parse, xacro.eval_all, substitution._eval_find = saved

    def _mark(self, document: Any, file: str, text: str) -> None:
        """Mark every non-xacro element of a file just parsed with the index of its place (the
        elements and the start tags expat sees are the same, in the same order; where a
        document type's entities made them differ, the file's elements stay unmarked and
        messages name lines of the expanded text)."""
        elements = document.getElementsByTagName("*")
        lines = _start_lines(text)
        if len(elements) != len(lines):
            return
        for element, line in zip(elements, lines, strict=True):
            if not element.tagName.startswith("xacro:"):
                element.setAttribute(PLACE_ATTRIBUTE, str(len(self.places)))
                self.places.append((file, line))

    def place(self, index: int) -> str:
        file, line = self.places[index]
        return f"line {line} of {shown_path(file)}"

    def collect(self, document: Any) -> tuple[str | None, ...]:
        """The place of each element of the result (document order); the marks removed."""
        places: list[str | None] = []
        for element in document.getElementsByTagName("*"):
            if element.hasAttribute(PLACE_ATTRIBUTE):
                places.append(self.place(int(element.getAttribute(PLACE_ATTRIBUTE))))
                element.removeAttribute(PLACE_ATTRIBUTE)
            else:
                places.append(None)
        return tuple(places)

    # ----------------------------------------------------------------------------------------
    # Failures

    def error(self, exc: BaseException) -> URDFError:
        """One URDFError naming the file and line of a failure of xacro."""
        import xacro

        cause = _dhkin_cause(exc)
        reading = xacro.filestack[-1] if xacro.filestack else self.top
        if isinstance(cause, URDFError) and not isinstance(cause, PackageNotFoundError):
            return cause  # a file that cannot be read: it names itself
        if isinstance(exc, expat.ExpatError) or isinstance(cause, expat.ExpatError):
            failure = exc if isinstance(exc, expat.ExpatError) else cause
            assert isinstance(failure, expat.ExpatError)
            reason = expat.errors.messages[failure.code] if failure.code else str(failure)
            return URDFError(f"{shown_path(reading)}: not well-formed XML ({reason} at line "
                             f"{failure.lineno}, column {failure.offset + 1}); expected a xacro "
                             "file" + self._expanding(reading), field="xacro", value=reading,
                             expected="well-formed XML")
        index = getattr(exc, "_dhkin_place", None)
        file, line = self.places[index] if index is not None else (reading, None)
        if isinstance(cause, PackageNotFoundError):
            snippet = f"$(find {cause.value}"
            file, line = self._locate(snippet, file, line)
            return PackageNotFoundError(f"{self._where(file, line)}{snippet}): {cause}",
                                        field="package", value=cause.value,
                                        expected="a package folder")
        argument = _unset_argument(exc)
        if argument is not None:
            snippet = f"$(arg {argument}"
            file, line = self._locate(snippet, file, line)
            return URDFError(f"{self._where(file, line)}{snippet}): xacro argument {argument!r} "
                             f"is not set; expected --xacro-arg {argument}:=VALUE (Python: "
                             f"xacro_args={{'{argument}': VALUE}}) or a <xacro:arg "
                             f"name=\"{argument}\" default=...>", field="xacro_args",
                             value=argument, expected=f"a value for {argument}")
        detail = one_line(str(exc) or type(exc).__name__)
        expression = _expression(detail)
        if expression is not None:
            file, line = self._locate(expression, file, line)
        return URDFError(f"{self._where(file, line)}xacro failed ({detail}){self._macros()}"
                         + self._expanding(file), field="xacro", value=str(file),
                         expected="a xacro file that expands to a URDF")

    def _where(self, file: str, line: int | None) -> str:
        return f"{shown_path(file)}: " + (f"line {line}: " if line is not None else "")

    def _expanding(self, file: str) -> str:
        same = os.path.abspath(file) == os.path.abspath(self.top)
        return "" if same else f" (expanding {shown_path(self.top)})"

    def _line_of(self, file: str, snippet: str, near: int | None) -> int | None:
        """The line of ``file`` holding ``snippet`` (the first at or after ``near``, else the
        first), or ``near`` when none does."""
        found = self._lines_with(file, snippet)
        later = [k for k in found if near is None or k >= near]
        return later[0] if later else found[0] if found else near

    def _lines_with(self, file: str, snippet: str) -> list[int]:
        text = self.texts.get(file, "")
        return [k + 1 for k, line in enumerate(text.splitlines()) if snippet in line]

    def _locate(self, snippet: str, file: str, line: int | None) -> tuple[str, int | None]:
        """The file and line that hold ``snippet`` (a ``$(find NAME``, ``$(arg NAME`` or
        ``${expression``), looked for in the file of the macro being expanded, then in the file
        of the innermost element (``file``, from ``line`` on), then in the files being read;
        (``file``, ``line``) when none holds it."""
        import xacro

        candidates: list[tuple[str, int | None]] = []
        if xacro.macrostack:
            macro_file = xacro.macrostack[-1].history[-1][-1]
            candidates.append((macro_file, line if macro_file == file else None))
        candidates.append((file, line))
        candidates += [(name, None) for name in reversed(xacro.filestack or [])]
        for name, near in candidates:
            if self._lines_with(name, snippet):
                return name, self._line_of(name, snippet, near)
        return file, line

    @staticmethod
    def _macros() -> str:
        import xacro

        names = [macro.body.getAttribute("name") for macro in reversed(xacro.macrostack or [])]
        return f" in macro {' <- '.join(repr(n) for n in names)}" if names else ""


def _dhkin_cause(exc: BaseException) -> BaseException | None:
    """The dhkin error or XML error xacro wrapped (its ``exc`` chain), or None."""
    seen: set[int] = set()
    current: BaseException | None = exc
    while current is not None and id(current) not in seen:
        seen.add(id(current))
        if isinstance(current, DhkinError | expat.ExpatError):
            return current
        inner = getattr(current, "exc", None)
        current = inner if isinstance(inner, BaseException) else current.__cause__
    return None


def _unset_argument(exc: BaseException) -> str | None:
    """The name of the ``$(arg NAME)`` xacro found unset, or None."""
    from xacro.substitution_args import ArgException

    inner = getattr(exc, "exc", None)
    if isinstance(inner, ArgException):
        return str(inner.args[0]) if inner.args else str(inner)
    return None


def _expression(detail: str) -> str | None:
    """The ``${...}`` expression xacro names in "when evaluating expression 'X'", or None."""
    marker = "when evaluating expression '"
    start = detail.find(marker)
    if start < 0:
        return None
    body = detail[start + len(marker):]
    end = body.rfind("'")
    return "${" + body[:end] if end > 0 else None
