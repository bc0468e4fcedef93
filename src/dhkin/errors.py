"""Exceptions raised by dhkin, one class per fault.

Every error dhkin raises derives from :class:`DhkinError`, so callers can catch one type. The
class says *whose* fault it is, whatever the entry point:

============================  ============================================================
:class:`InputError`           an argument of a call is wrong (shape, type, range, a choice
                              among names): joint values, poses, seeds, tolerances, options
:class:`DHError`              a DH table (file or object) is invalid
:class:`URDFError`            a robot description (URDF, xacro) cannot be used as asked
:class:`RobotNotFoundError`   a name is neither a built-in robot nor a table file
:class:`FamilyError`          a table lacks the structure a family needs (closed-form IK,
                              analytic singularity factors)
:class:`UnreachableError`     what was asked does not exist for this robot: a singularity
                              its joint cannot reach within the limits, a path pose with no
                              IK solution
:class:`FileWriteError`       the system refused to write an output file (no space left, a
                              file size limit, no permission, a read-only file system); the
                              old file is left as it was
============================  ============================================================

Each error carries the parts of its message as attributes, None where they do not apply:
``field`` (the argument, table field or file entry at fault, e.g. "q_seed" or "joints[2].a"),
``value`` (what was given, or its shape), ``expected`` (what was expected, in words) and
``index`` (the pose or row of a batch at fault). Code that reacts to an error reads these,
never the message. The message names the file, field or value at fault and what was expected.

``IKInputError``, ``SingularityError`` and ``ValidationInputError`` are the names of
:class:`InputError` in earlier versions, kept so that existing ``except`` clauses still work.
"""

from __future__ import annotations

from typing import Any


class DhkinError(Exception):
    """Base class of all dhkin errors (see the module docstring for the attributes)."""

    def __init__(self, message: str | None = None, *, field: str | None = None,
                 value: Any = None, expected: str | None = None,
                 index: int | None = None) -> None:
        if message is None:
            message = describe(field, value, expected, index)
        super().__init__(one_line(message))
        self.field = field
        self.value = value
        self.expected = expected
        self.index = index


def one_line(message: str) -> str:
    """``message`` on one line: text quoted from elsewhere (a parser's, Pinocchio's, xacro's
    multi-line report) has its line breaks and their indentation turned into single spaces, so
    every dhkin error prints as one line (a log line, the CLI's ``dhkin: error: ...``)."""
    if "\n" not in message and "\r" not in message:
        return message
    return " ".join(part.strip() for part in message.splitlines() if part.strip())


def describe(field: str | None, value: Any, expected: str | None,
             index: int | None = None) -> str:
    """The standard message "field[index]: expected ..., got ..." from its parts."""
    where = field or "input"
    if index is not None:
        where += f"[{index}]"
    text = f"{where}: expected {expected}" if expected else where
    return f"{text}, got {value!r}" if value is not None else text


class InputError(DhkinError, ValueError):
    """An argument of a call is wrong: its shape, type, range or choice."""


class DHError(DhkinError, ValueError):
    """A DH table file or value is invalid (unknown key, missing key, wrong unit, bad limit...)."""


class URDFError(DhkinError, ValueError):
    """A URDF cannot be used as asked (missing frame, joints that do not match a table...)."""


class RobotNotFoundError(DhkinError, LookupError):
    """A robot name is neither a built-in robot nor a path to a table file."""


class FamilyError(DhkinError, ValueError):
    """A DH table lacks the structure of the family asked for (closed-form IK, analytic
    singularity factors)."""


class UnreachableError(DhkinError, ValueError):
    """What was asked does not exist for this robot (a singularity out of the joint's reach, a
    pose without an IK solution)."""


class FileWriteError(DhkinError, OSError):
    """The system refused to write an output file: no space left on device, a file size limit,
    no permission, a read-only file system. The message names the file and the system's reason;
    ``errno``, ``strerror`` and ``filename`` are those of the system's error. An OSError too, as
    the plain writes it replaces raised. (A destination that is wrong as given, such as an
    existing file without force or a symbolic link, is an :class:`InputError`.)"""

    def __str__(self) -> str:
        # dhkin's one-line message, not OSError's "[Errno N] reason: 'file'" built from errno
        return str(self.args[0]) if self.args else ""


#: Earlier names of :class:`InputError` (see the module docstring).
IKInputError = InputError
SingularityError = InputError
ValidationInputError = InputError

#: Every error class, for ``from dhkin.errors import *`` users and for the package's exports.
__all__ = ["DHError", "DhkinError", "FamilyError", "FileWriteError", "IKInputError",
           "InputError", "RobotNotFoundError", "SingularityError", "URDFError",
           "UnreachableError", "ValidationInputError", "describe", "one_line"]
