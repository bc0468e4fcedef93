"""What the `dhkin` command line accepts and how it reports faults of its input, in one line each:
the exit statuses, the argument types every subcommand shares (each refuses what would fail or
mislead deeper down, so that argparse reports it as a usage error naming the option), the
parser class whose usage errors are one line, the one-line text of any input error that reaches
:func:`dhkin.cli.main`, and the readers of values the options carry (xacro arguments, angles,
the pose of `dhkin ik`). The parsers themselves live in :mod:`dhkin.cli`.
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable, Sequence
from typing import NoReturn

import numpy as np

from dhkin.errors import InputError, one_line
from dhkin.transforms import xyz_rpy_to_matrix

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2
#: Exit status after Ctrl-C (SIGINT): 128 + the signal's number, as shells report it.
EXIT_INTERRUPTED = 128 + 2
#: The options that name files or folders a command writes.
OUTPUT_OPTIONS = ("output", "json", "report", "failures")

#: Exit status when the reader of stdout goes away (``dhkin ik ... | head``): Python's own status
#: for a broken pipe (the recipe of the ``signal`` module's documentation), quietly.
EXIT_BROKEN_PIPE = 1


def _number(text: str, kind: Callable[[str], float], what: str,
            accept: Callable[[float], bool]) -> float:
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if not accept(value):
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
    return value


def non_negative_int(text: str) -> int:
    """An integer >= 0 (random seeds: numpy refuses negative ones)."""
    return int(_number(text, int, "an integer >= 0", lambda v: v >= 0))


def positive_int(text: str) -> int:
    """An integer >= 1 (counts of samples, poses, grid cells)."""
    return int(_number(text, int, "an integer >= 1", lambda v: v >= 1))


def finite_float(text: str) -> float:
    """A finite number (joint values, coordinates, angles): not nan or inf."""
    return _number(text, float, "a finite number", math.isfinite)


def positive_float(text: str) -> float:
    """A finite number > 0 (tolerances)."""
    return _number(text, float, "a finite number > 0", lambda v: math.isfinite(v) and v > 0)


def non_negative_float(text: str) -> float:
    """A finite number >= 0 (singularity thresholds)."""
    return _number(text, float, "a finite number >= 0", lambda v: math.isfinite(v) and v >= 0)


def output_name(text: str) -> str:
    """A file or folder to write: not empty (``Path("")`` is the current folder, so ``-o ""``
    would write there unasked)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a file or folder name, got an empty string")
    return text


def force_arg(parser: argparse.ArgumentParser) -> None:
    """The --force option of every subcommand that writes files."""
    parser.add_argument("--force", action="store_true",
                        help="replace existing output files whose content differs")


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are one line (then exit 2), like dhkin's own."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def input_error_text(exc: BaseException) -> str:
    """One line saying what went wrong with the input: a dhkin error as it is, an OSError with
    its file, the others with what they mean for the input."""
    if isinstance(exc, OSError):
        files = " -> ".join(str(name) for name in (exc.filename, exc.filename2)
                            if name is not None)
        reason = exc.strerror or type(exc).__name__
        return one_line(f"{files}: {reason}" if files else f"{reason} ({exc})")
    if isinstance(exc, UnicodeDecodeError):
        return (f"input is not UTF-8 text (byte {exc.object[exc.start:exc.start + 1]!r} at "
                f"offset {exc.start}); expected UTF-8 text")
    if isinstance(exc, RecursionError):
        return "input nested too deeply to read (RecursionError); expected a flatter file"
    if isinstance(exc, MemoryError):
        return "input too large to hold in memory (MemoryError)"
    return one_line(str(exc))


def output_paths(args: argparse.Namespace) -> list[str]:
    """The files and folders a command line writes (-o, --json, --report, --failures given as
    names; ``dhkin ik --json`` is a flag, not a file)."""
    return [value for key in OUTPUT_OPTIONS
            if isinstance(value := getattr(args, key, None), str)]


def path_states(paths: Sequence[str]) -> list[tuple[int, int] | None]:
    """(modification time ns, size) of each path, or None where nothing exists."""
    states: list[tuple[int, int] | None] = []
    for path in paths:
        try:
            status = os.stat(path)
        except OSError:
            states.append(None)
        else:
            states.append((status.st_mtime_ns, status.st_size))
    return states


def interrupted_text(paths: Sequence[str], before: Sequence[tuple[int, int] | None]) -> str:
    """The one line after Ctrl-C: which outputs are left as they were and which were written
    before the interrupt (dhkin writes each file whole or not at all: dhkin.files)."""
    after = path_states(paths)
    kept = [path for path, old, new in zip(paths, before, after, strict=True) if old == new]
    written = [path for path in paths if path not in kept]
    parts = []
    if written:
        parts.append(f"{', '.join(written)} written")
    if kept:
        parts.append(f"{', '.join(kept)} left as {'it was' if len(kept) == 1 else 'they were'}")
    return "interrupted" + (f"; {'; '.join(parts)}" if parts else "")


def xacro_arguments(values: Sequence[str] | None) -> dict[str, str]:
    """``NAME:=VALUE`` strings -> {NAME: VALUE} (InputError naming a malformed one)."""
    arguments = {}
    for value in values or ():
        name, separator, text = value.partition(":=")
        if not separator or not name:
            raise InputError(f"--xacro-arg {value!r}: expected NAME:=VALUE", field="xacro-arg",
                             value=value, expected="NAME:=VALUE")
        arguments[name] = text
    return arguments


def angles(values: Sequence[float], degrees: bool) -> np.ndarray:
    """Angles given on the command line -> radians (``degrees``: they are in degrees)."""
    array = np.asarray(values, dtype=float)
    return np.radians(array) if degrees else array


def ik_target(args: argparse.Namespace) -> np.ndarray:
    """The target of `dhkin ik`: --matrix FILE or --xyz [--rpy] (argparse allows one of them)."""
    if args.matrix is not None:
        if args.rpy is not None:
            raise InputError("--rpy: applies to --xyz, not to --matrix (whose pose has its own "
                             "rotation); expected --xyz X Y Z --rpy R P Y or --matrix FILE alone",
                             field="rpy", value=args.rpy, expected="no --rpy with --matrix")
        try:
            T = np.loadtxt(args.matrix, dtype=float, ndmin=2)
        except ValueError as exc:  # includes a file that is not UTF-8 text
            raise InputError(f"--matrix {args.matrix}: expected a 4x4 matrix of numbers "
                             f"({exc})", field="matrix", value=args.matrix,
                             expected="a 4x4 matrix of numbers") from exc
        if T.shape != (4, 4):
            raise InputError(f"--matrix {args.matrix}: expected a 4x4 matrix, got shape "
                             f"{T.shape}", field="matrix", value=args.matrix,
                             expected="a 4x4 matrix")
        return T
    rpy = angles(args.rpy if args.rpy is not None else [0, 0, 0], args.deg)
    return xyz_rpy_to_matrix(args.xyz, rpy)
