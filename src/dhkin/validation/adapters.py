"""The IK under test as a callable ``ik(T) -> joint vectors``: adapters for degrees and other tool
frames, dhkin's own IK, and ``module:function`` specs (see :mod:`dhkin.validation.run`).
"""

from __future__ import annotations

import importlib
import inspect
import sys
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.arm import Arm
from dhkin.errors import InputError
from dhkin.validation.arguments import one_line, quoted
from dhkin.validation.calls import parameters as _parameters

IKCallable = Callable[..., Iterable[ArrayLike]]


def _in_radians(result: Any) -> Any:
    """An IK's answer in degrees -> radians, lazily; anything that is not a list of numeric
    vectors is handed on as it is, for the validator to report."""
    if isinstance(result, np.ndarray):
        return np.radians(result) if result.dtype.kind in "iuf" else result
    if result is None or isinstance(result, (str, bytes, Mapping)) or \
            not isinstance(result, Iterable):
        return result

    def radians(q: Any) -> Any:
        array = np.asarray(q)
        return np.radians(array) if array.dtype.kind in "iuf" else q

    return (radians(q) for q in result)


def adapt(ik: IKCallable, degrees: bool = False, tool: ArrayLike | None = None) -> IKCallable:
    """Wrap a user IK: ``degrees`` -> it returns degrees (revolute and prismatic alike are
    converted, so use it for all-revolute arms; a ``q_seed`` it takes is given in degrees);
    ``tool`` (4x4, tool0 -> the user's tool frame) -> it expects targets of that frame:
    T_user = T_tool0 @ tool. The wrapper declares the ``q_seed`` and ``robot`` parameters the
    wrapped IK declares (the validator's checks depend on them) and reads its answer lazily."""
    if not callable(ik):
        raise InputError(f"ik: expected a callable ik(T) -> joint vectors, got {quoted(ik)}",
                         field="ik", value=quoted(ik), expected="a callable")
    tool_frame = None
    if tool is not None:
        tool_frame = np.asarray(tool, dtype=float)
        if tool_frame.shape != (4, 4) or not np.all(np.isfinite(tool_frame)):
            raise InputError(f"tool: expected a finite 4x4 transform, got {quoted(tool)}",
                             field="tool", value=quoted(tool), expected="a finite 4x4 array")

    def adapted(T: NDArray[np.float64], **kwargs: Any) -> Any:
        if degrees and kwargs.get("q_seed") is not None:
            kwargs["q_seed"] = np.degrees(kwargs["q_seed"])
        target = T if tool_frame is None else T @ tool_frame
        result = ik(target, **kwargs)
        return _in_radians(result) if degrees else result

    declared = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=None)
                for name in ("q_seed", "robot") if name in _parameters(ik)]
    adapted.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
        [inspect.Parameter("T", inspect.Parameter.POSITIONAL_OR_KEYWORD), *declared])
    adapted.__name__ = str(getattr(ik, "__name__", "ik")) + ("[deg]" if degrees else "")
    return adapted


def own_ik(robot: Arm) -> IKCallable:
    """dhkin's own IK of ``robot`` as a validation callable.

    The closed-form IK and the general 6R solver take the sampled q as seed (they only use it
    at a singularity, to choose a free joint; the general solver's roots are checked unseeded
    against an independent reference too, :mod:`dhkin.validation.multistart`). The numerical
    IK gets no seed: starting at the answer would prove nothing.
    """
    if not robot.complete_ik:
        def numerical(T: NDArray[np.float64]) -> NDArray:
            return robot.ik(T).q

        numerical.__name__ = f"dhkin:{robot.name} (numerical)"
        return numerical

    def ik(T: NDArray[np.float64], q_seed: NDArray[np.float64] | None = None) -> NDArray:
        return robot.ik(T, q_seed=q_seed).q

    ik.__name__ = f"dhkin:{robot.name}"
    return ik


def load_ik(spec: str) -> IKCallable:
    """'package.module:function' (or 'module:Class.method') -> the callable; the working
    directory is importable. Any failure (no such module, the module raises or exits while
    importing, no such attribute, not callable) is a one-line InputError naming ``--ik``."""
    expected = "'module:function' naming a callable, e.g. tests.broken:sign_flip"
    if not isinstance(spec, str) or spec.count(":") != 1:
        raise InputError(f"--ik: expected {expected}, got {quoted(spec)}", field="--ik",
                         value=quoted(spec), expected=expected)
    module_name, function_name = spec.split(":", 1)
    names = function_name.split(".")
    if not all(part.isidentifier() for part in module_name.split(".") + names):
        raise InputError(f"--ik: expected {expected}, got {quoted(spec)}", field="--ik",
                         value=spec, expected=expected)
    if str(Path.cwd()) not in sys.path:
        sys.path.insert(0, str(Path.cwd()))
    try:
        target: Any = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        raise InputError(f"--ik {spec}: cannot import module {module_name!r} "
                         f"({one_line(str(exc))})", field="--ik", value=spec,
                         expected="an importable module") from exc
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # the module's own failure (SystemExit too): the user's input
        raise InputError(f"--ik {spec}: importing module {module_name!r} raised "
                         f"{type(exc).__name__}: {one_line(str(exc))}", field="--ik",
                         value=spec, expected="a module that imports") from exc
    for depth, name in enumerate(names):
        try:
            target = getattr(target, name)
        except Exception as exc:
            owner = ".".join([module_name, *names[:depth]])
            raise InputError(f"--ik {spec}: {owner!r} has no callable {name!r}",
                             field="--ik", value=spec, expected=expected) from exc
    if not callable(target):
        raise InputError(f"--ik {spec}: {module_name}.{function_name} is a "
                         f"{type(target).__name__}, not a callable", field="--ik", value=spec,
                         expected=expected)
    return cast(IKCallable, target)
