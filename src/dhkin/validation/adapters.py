"""The IK under test as a callable ``ik(T) -> joint vectors``: adapters for degrees and other tool
frames, dhkin's own IK, and ``module:function`` specs (see :mod:`dhkin.validation.run`).
"""

from __future__ import annotations

import importlib
import inspect
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.arm import Arm
from dhkin.errors import InputError

IKCallable = Callable[..., Iterable[ArrayLike]]


def adapt(ik: IKCallable, degrees: bool = False, tool: ArrayLike | None = None) -> IKCallable:
    """Wrap a user IK: ``degrees`` -> it returns degrees (revolute and prismatic alike are
    converted, so use it for all-revolute arms); ``tool`` (4x4, tool0 -> the user's tool frame)
    -> it expects targets of that frame: T_user = T_tool0 @ tool."""
    tool_frame = None if tool is None else np.asarray(tool, dtype=float)

    def convert(T: NDArray[np.float64], **kwargs: Any) -> list[NDArray[np.float64]]:
        target = T if tool_frame is None else T @ tool_frame
        solutions = [np.asarray(q, dtype=float) for q in ik(target, **kwargs)]
        return [np.radians(q) for q in solutions] if degrees else solutions

    def adapted_seeded(T: NDArray[np.float64],
                       q_seed: NDArray[np.float64] | None = None) -> list[NDArray[np.float64]]:
        seed = None if q_seed is None else (np.degrees(q_seed) if degrees else q_seed)
        return convert(T, q_seed=seed)

    def adapted_plain(T: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        return convert(T)

    # Offer q_seed only when the wrapped IK takes it: the validator's missing check depends on it.
    adapted = adapted_seeded if _takes_seed(ik) else adapted_plain
    adapted.__name__ = getattr(ik, "__name__", "ik") + ("[deg]" if degrees else "")
    return adapted


def own_ik(robot: Arm) -> IKCallable:
    """dhkin's own IK of ``robot`` as a validation callable.

    The closed-form IK takes the sampled q as seed (it only uses it for free joints at a
    singularity). The numerical IK gets no seed: starting at the answer would prove nothing.
    """
    if not robot.has_closed_form:
        def numerical(T: NDArray[np.float64]) -> NDArray:
            return robot.ik(T).q

        numerical.__name__ = f"dhkin:{robot.name} (numerical)"
        return numerical

    def ik(T: NDArray[np.float64], q_seed: NDArray[np.float64] | None = None) -> NDArray:
        return robot.ik(T, q_seed=q_seed).q

    ik.__name__ = f"dhkin:{robot.name}"
    return ik


def load_ik(spec: str) -> IKCallable:
    """'package.module:function' -> the callable (the working directory is importable)."""
    if ":" not in spec:
        raise InputError(f"--ik: expected 'module:function', got {spec!r}")
    module_name, function_name = spec.split(":", 1)
    if str(Path.cwd()) not in sys.path:
        sys.path.insert(0, str(Path.cwd()))
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise InputError(f"--ik: cannot import module {module_name!r} ({exc})") from exc
    function = getattr(module, function_name, None)
    if not callable(function):
        raise InputError(f"--ik: {module_name!r} has no callable {function_name!r}")
    return function


def _takes_seed(ik: IKCallable) -> bool:
    return "q_seed" in inspect.signature(ik).parameters


def _call(ik: IKCallable, robot: Arm, T: NDArray[np.float64],
          q_seed: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    parameters = inspect.signature(ik).parameters
    kwargs: dict[str, Any] = {}
    if "q_seed" in parameters:
        kwargs["q_seed"] = q_seed
    if "robot" in parameters:
        kwargs["robot"] = robot
    result = ik(T, **kwargs)
    if isinstance(result, np.ndarray) and result.ndim == 2:
        return list(result.astype(float, copy=False))
    return [np.asarray(q, dtype=float).reshape(-1) for q in result]
