"""Exceptions raised by dhkin.

Every error dhkin raises on bad input derives from :class:`DhkinError`, so callers can catch one
type. Messages name the file, the field or the value at fault and say what was expected.
"""

from __future__ import annotations


class DhkinError(Exception):
    """Base class of all dhkin errors."""


class DHError(DhkinError, ValueError):
    """A DH table file or value is invalid (unknown key, missing key, wrong unit, bad limit...)."""


class URDFError(DhkinError, ValueError):
    """A URDF cannot be used as asked (missing frame, joints that do not match a table...)."""


class RobotNotFoundError(DhkinError, LookupError):
    """A robot name is neither a built-in robot nor a path to a table file."""


class FamilyError(DhkinError, ValueError):
    """A DH table does not fit the closed-form IK family that was asked for."""


class IKInputError(DhkinError, ValueError):
    """An IK call got an input of the wrong shape or a non-finite value."""
