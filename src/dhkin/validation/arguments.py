"""Checks of the validator's arguments (API, command line and failure file alike): every number
finite, positive and of the right type, so that a NaN or a string can never turn a check off.

Each check raises :class:`~dhkin.errors.InputError` naming the argument (``name``: the keyword,
the command-line option or the failure file's field) and what was expected, in one line.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

from dhkin.errors import InputError

#: Most samples of one run (``n``, or the entries of a failure file). Each sample holds its
#: joint vector, target pose and perturbed seed (~230 bytes) before the run starts, and costs
#: at least one IK call and a Pinocchio FK: a million is ~230 MB and hours of IK calls, far
#: beyond the 10^4 default, while a mistyped 10^12 fails at once instead of exhausting memory.
MAX_SAMPLES = 1_000_000


#: Largest ``tolerance`` (m and rad) a run accepts. A solution within 1 cm / 10 mrad of its target
#: is not an IK solution of an industrial arm by any standard (dhkin's default is 1e-9), and a
#: larger value would let a plainly wrong row pass the "wrong" check.
MAX_TOLERANCE = 1e-2


#: Largest ``joint_tolerance`` (rad, m for prismatic joints) a run accepts. Two distinct branches
#: of a pose away from singularities differ by far more than 10 mrad on some joint, and the
#: missing checks widen the tolerance near singularities by themselves (pose noise / sigma_min),
#: so a larger value would only let a missing sample or branch match a different one.
MAX_JOINT_TOLERANCE = 1e-2


#: Longest text of a given value quoted in an error message (a replay file's value may be a
#: megabyte of nested lists).
QUOTED_VALUE_LENGTH = 80


def quoted(value: Any) -> str:
    """``repr(value)`` cut to :data:`QUOTED_VALUE_LENGTH` characters, on one line."""
    try:
        text = repr(value)
    except Exception:  # a hostile __repr__: say what it is instead
        text = f"<{type(value).__name__}>"
    text = " ".join(text.split())
    if len(text) > QUOTED_VALUE_LENGTH:
        text = text[: QUOTED_VALUE_LENGTH - 3] + "..."
    return text


def one_line(text: str, limit: int = 300) -> str:
    """``text`` with its whitespace runs (line feeds included) collapsed, cut to ``limit``."""
    flat = " ".join(str(text).split())
    return flat if len(flat) <= limit else flat[: limit - 3] + "..."


def _fail(name: str, value: Any, expected: str) -> InputError:
    return InputError(f"{name}: expected {expected}, got {quoted(value)}", field=name,
                      value=quoted(value), expected=expected)


def is_real(value: Any) -> bool:
    """A real number that is not a bool (True is 1 to Python, never a tolerance or joint value)
    and not a string."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def positive_number(value: Any, name: str, maximum: float | None = None,
                    unit: str = "") -> float:
    """``value`` as a float: a finite real number > 0 (and <= ``maximum``)."""
    expected = "a finite number > 0" + (f" ({unit})" if unit else "")
    if maximum is not None:
        expected = f"a finite number in (0, {maximum:g}]" + (f" ({unit})" if unit else "")
    if not is_real(value):
        raise _fail(name, value, expected)
    number = float(value)
    if not math.isfinite(number) or number <= 0.0 or (maximum is not None and number > maximum):
        raise _fail(name, value, expected)
    return number


def integer(value: Any, name: str, minimum: int, maximum: int | None = None,
            what: str = "") -> int:
    """``value`` as an int: an integral number (not a bool, not a float) in [minimum, maximum]."""
    expected = f"an integer >= {minimum}" if maximum is None else \
        f"an integer in [{minimum}, {maximum}]"
    if what:
        expected += f" ({what})"
    if not isinstance(value, numbers.Integral) or isinstance(value, bool):
        raise _fail(name, value, expected)
    number = int(value)
    if number < minimum or (maximum is not None and number > maximum):
        raise _fail(name, value, expected)
    return number


def sample_count(value: Any, name: str = "n") -> int:
    """The number of uniform samples (1 ... :data:`MAX_SAMPLES`)."""
    if is_real(value) and not isinstance(value, numbers.Integral):
        raise _fail(name, value, "a whole number of samples")
    if isinstance(value, numbers.Integral) and not isinstance(value, bool) and value < 1:
        raise InputError(f"{name}: expected at least 1 sample, got {value}", field=name,
                         value=int(value), expected="at least 1 sample")
    return integer(value, name, 1, MAX_SAMPLES, "samples")


def seed_value(value: Any, name: str = "seed") -> int:
    """A random seed: an integer >= 0 (numpy's generators take no negative seed)."""
    return integer(value, name, 0, what="random seed")


def tolerance_value(value: Any, name: str = "tolerance") -> float:
    """The pose tolerance (m and rad): finite, > 0, <= :data:`MAX_TOLERANCE`."""
    return positive_number(value, name, MAX_TOLERANCE, "m and rad")


def joint_tolerance_value(value: Any, name: str = "joint_tolerance") -> float:
    """The joint tolerance (rad / m): finite, > 0, <= :data:`MAX_JOINT_TOLERANCE`."""
    return positive_number(value, name, MAX_JOINT_TOLERANCE, "rad")


def timeout_value(value: Any, name: str = "timeout") -> float | None:
    """The per-call time limit (s): None (no limit) or a finite number > 0."""
    if value is None:
        return None
    return positive_number(value, name, unit="seconds")


def flag(value: Any, name: str, optional: bool = False) -> bool | None:
    """A bool (None too when ``optional``)."""
    if value is None and optional:
        return None
    if not isinstance(value, bool):
        raise _fail(name, value, "True or False" + (" or None" if optional else ""))
    return value


def optional_text(value: Any, name: str) -> str | None:
    """None or a string."""
    if value is not None and not isinstance(value, str):
        raise _fail(name, value, "a string or None")
    return value


def check_command_line(options: Any) -> None:
    """The options of ``dhkin validate`` (an argparse namespace), named as on the command line:
    --deg and --ik-frame need --ik; the numbers as :func:`validate` checks them (-n, --seed and
    the tolerances only without --replay, whose file records its own)."""
    if options.ik is None and (options.deg or options.ik_frame):
        given = " and ".join(o for o, v in (("--deg", options.deg),
                                            ("--ik-frame", options.ik_frame)) if v)
        raise InputError(f"{given}: apply only to --ik module:function (they say how that IK "
                         "answers); dhkin's own IK needs neither", field="--ik",
                         expected="--ik with --deg / --ik-frame")
    if options.replay is None:
        sample_count(options.n, "-n")
        seed_value(options.seed, "--seed")
        tolerance_value(options.tolerance, "--tolerance")
        joint_tolerance_value(options.joint_tolerance, "--joint-tolerance")
    timeout_value(options.timeout, "--timeout")
