"""Where ROS packages are, without ROS: the folder xacro's ``$(find NAME)`` stands for.

Vendor descriptions include their macros and their ``*_resources`` packages with
``$(find NAME)``; ROS answers from its package index, which a user without ROS does not have.
:class:`PackageFinder` answers instead, asking three sources in this order (the first that
knows NAME wins):

1. **given**: ``packages={"NAME": DIR}`` in Python, ``--package NAME=DIR`` on the command line
   (repeatable). DIR must be a folder; it need not hold a ``package.xml``.
2. **the environment**: ``ROS_PACKAGE_PATH`` (ROS 1: its folders, in order, each a package or
   searched below for folders holding a ``package.xml``; a package's own subfolders are not
   searched, nor hidden folders or folders with a ``CATKIN_IGNORE`` file), then
   ``AMENT_PREFIX_PATH`` (ROS 2: ``PREFIX/share/NAME`` for each prefix, in order, that lists
   NAME in ``PREFIX/share/ament_index/resource_index/packages``).
3. **the checkout around the description**: starting at the description's folder and going up
   one folder at a time to the file system's root, the folder itself when it holds a
   ``package.xml`` and each of its subfolders that does. The nearest level wins. This finds the
   description's own package and the packages beside it and above it, as a clone of a vendor
   repository lays them out (``fanuc/fanuc_m16ib_support/urdf/m16ib20.xacro`` finds
   ``fanuc/fanuc_resources``).

A package's name is the ``<name>`` of its ``package.xml`` (as ROS has it), not its folder's name;
a folder given explicitly (1) is the package whatever it holds. A name no source knows is a
one-line :class:`PackageNotFoundError` naming the package and the three ways to give it.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

from dhkin.errors import InputError, URDFError

#: The environment variables read (ROS 1, ROS 2).
ROS_PACKAGE_PATH = "ROS_PACKAGE_PATH"
AMENT_PREFIX_PATH = "AMENT_PREFIX_PATH"

#: The ways to tell dhkin where a package is, in words (every "not found" message says them).
HOW_TO_GIVE = ("give it with --package {name}=DIR (Python: packages={{'{name}': DIR}}), set "
               "ROS_PACKAGE_PATH or AMENT_PREFIX_PATH, or keep it beside or above the "
               "description's package (found by its package.xml)")


class PackageNotFoundError(URDFError):
    """``$(find NAME)`` names a package none of the sources knows (see the module docstring)."""


def package_name(folder: Path) -> str | None:
    """The ``<name>`` of ``folder/package.xml``, or None when there is none or it cannot be
    read (a broken package.xml of some other package must not stop a search)."""
    try:
        data = (folder / "package.xml").read_bytes()
    except OSError:
        return None
    names: list[str] = []
    depth = 0
    capture = False

    def start(tag: str, attributes: dict[str, str]) -> None:
        nonlocal depth, capture
        depth += 1
        capture = depth == 2 and tag == "name"

    def end(tag: str) -> None:
        nonlocal depth, capture
        depth -= 1
        capture = False

    def text(data: str) -> None:
        if capture:
            names.append(data)

    parser = expat.ParserCreate()
    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = text
    try:
        parser.Parse(data, True)
    except expat.ExpatError:
        return None
    name = "".join(names).strip()
    return name or None


def parse_package_option(text: str) -> tuple[str, Path]:
    """``NAME=DIR`` (the ``--package`` option) -> (NAME, DIR); InputError unless NAME is given
    and DIR is a folder."""
    name, separator, folder = text.partition("=")
    name = name.strip()
    if not separator or not name or not folder:
        raise InputError(f"--package {text!r}: expected NAME=DIR (a ROS package name and its "
                         "folder)", field="package", value=text, expected="NAME=DIR")
    return name, Path(folder)


def given_packages(options: list[str] | None) -> dict[str, Path]:
    """The ``--package NAME=DIR`` options -> {NAME: DIR}; InputError for a malformed one or a
    NAME given twice with different folders."""
    packages: dict[str, Path] = {}
    for option in options or ():
        name, folder = parse_package_option(option)
        if name in packages and packages[name] != folder:
            raise InputError(f"--package {name}: given twice ({packages[name]} and {folder}); "
                             "expected one folder per package", field="package", value=name,
                             expected="one folder per package")
        packages[name] = folder
    return packages


@dataclass
class PackageFinder:
    """Finds the folder of a ROS package by name (the three sources of the module docstring).

    ``given``: NAME -> folder; ``environ``: the environment to read (default ``os.environ``);
    ``start``: the folder the checkout search starts from (the description's; None: no checkout
    search). Each source is read once, when first needed.
    """

    given: Mapping[str, str | Path] = field(default_factory=dict)
    environ: Mapping[str, str] | None = None
    start: Path | None = None
    _environment: dict[str, Path] | None = field(default=None, repr=False)
    _checkout: dict[str, Path] | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        for name, folder in self.given.items():
            if not Path(folder).is_dir():
                raise InputError(f"--package {name}={folder}: {folder} is not a folder; expected "
                                 "the package's folder", field="package", value=str(folder),
                                 expected="a folder")

    @classmethod
    def for_description(cls, description: str | Path,
                        packages: Mapping[str, str | Path] | None = None,
                        environ: Mapping[str, str] | None = None) -> PackageFinder:
        """The finder for a description file: ``packages`` given, the environment, and the
        checkout around the file's folder."""
        return cls(given=dict(packages or {}), environ=environ,
                   start=Path(description).resolve().parent)

    def find(self, name: str) -> Path:
        """The folder of package ``name`` (absolute); PackageNotFoundError if no source knows
        it."""
        folder = self.given.get(name)
        if folder is not None:
            return Path(folder).resolve()
        if self._environment is None:
            self._environment = dict(self._from_environment())
        if name in self._environment:
            return self._environment[name]
        if self._checkout is None:
            self._checkout = dict(self._from_checkout())
        if name in self._checkout:
            return self._checkout[name]
        raise PackageNotFoundError(f"package {name!r} not found; {HOW_TO_GIVE.format(name=name)}",
                                   field="package", value=name, expected="a package folder")

    def _from_environment(self) -> Iterator[tuple[str, Path]]:
        """(name, folder) of the packages the environment lists, the first of a name first."""
        environ = os.environ if self.environ is None else self.environ
        seen: set[str] = set()
        for entry in _path_list(environ.get(ROS_PACKAGE_PATH, "")):
            for name, folder in _packages_below(entry):
                if name not in seen:
                    seen.add(name)
                    yield name, folder
        for prefix in _path_list(environ.get(AMENT_PREFIX_PATH, "")):
            index = prefix / "share" / "ament_index" / "resource_index" / "packages"
            try:
                names = sorted(entry.name for entry in index.iterdir())
            except OSError:
                continue
            for name in names:
                if name not in seen:
                    seen.add(name)
                    yield name, (prefix / "share" / name).resolve()

    def _from_checkout(self) -> Iterator[tuple[str, Path]]:
        """(name, folder) of the packages at and around each folder from ``start`` up, the
        nearest level first."""
        if self.start is None:
            return
        seen: set[str] = set()
        for level in (self.start, *self.start.parents):
            for folder in (level, *_subfolders(level)):
                name = package_name(folder)
                if name is not None and name not in seen:
                    seen.add(name)
                    yield name, folder.resolve()


def _path_list(value: str) -> list[Path]:
    return [Path(part) for part in value.split(os.pathsep) if part]


def _subfolders(folder: Path) -> list[Path]:
    try:
        return sorted(entry for entry in folder.iterdir()
                      if entry.is_dir() and not entry.name.startswith("."))
    except OSError:
        return []


def _packages_below(root: Path) -> Iterator[tuple[str, Path]]:
    """The packages at or below ``root`` (ROS 1 crawl: a package's folder is not entered, nor
    hidden folders or folders holding CATKIN_IGNORE; a folder reached twice through symbolic
    links is read once), in sorted order."""
    visited: set[Path] = set()
    pending = [root]
    while pending:
        folder = pending.pop()
        real = folder.resolve()
        if real in visited:
            continue
        visited.add(real)
        name = package_name(folder)
        if name is not None:
            yield name, real
        elif not (folder / "CATKIN_IGNORE").exists():
            pending.extend(reversed(_subfolders(folder)))
