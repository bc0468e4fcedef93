"""Compile options shared by every kernel, and one version of each kernel per argument types.

numba compiles a function once per distinct tuple of argument types. A kernel called from another
kernel with a constant (``f(x, 0)``, ``f(x, True)``) gets that constant's *literal* type, a type of
its own, so every constant a call site passes made another copy of the callee and of everything
it calls: the family solvers were compiled three times, ``chain.refine`` six (a fresh install
spent 77 s compiling its first ``ik``). :func:`jit` and :func:`jit_fma` compile kernels for the
plain types of their arguments instead (int64, bool), which is what the code needs: no kernel
branches on a literal at compile time. Call sites also pass every argument (an omitted default is
a type of its own too). :data:`jit_literal` keeps the specialisation for a few tiny helpers
called with constant indices, where it is cheap and faster.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from numba import njit
from numba.core import types

from dhkin.ik.compiled.cache import caching_enabled

#: Whether kernels are cached on disk: False only where no folder can be written
#: (:mod:`dhkin.ik.compiled.cache`); they are then compiled in memory in every process.
CACHE = caching_enabled()


def _plain_types(dispatcher: Any) -> Any:
    """The numba dispatcher, typing calls from other kernels with unliteral argument types (see
    the module docstring). Where this numba has no ``get_call_template`` (a private hook), the
    dispatcher is left as it is: the kernels are correct either way, only compiled more often."""
    original = getattr(dispatcher, "get_call_template", None)
    if original is None:
        return dispatcher

    def get_call_template(args: tuple[Any, ...], kws: dict[str, Any]) -> Any:
        return original(tuple(types.unliteral(a) for a in args),
                        {k: types.unliteral(v) for k, v in kws.items()})

    dispatcher.get_call_template = get_call_template
    return dispatcher


def _compiler(**options: Any) -> Callable[[Callable[..., Any]], Any]:
    def decorate(function: Callable[..., Any]) -> Any:
        return _plain_types(njit(**options)(function))

    return decorate


#: Cached on disk (where :data:`CACHE`), IEEE division (no ZeroDivisionError checks), GIL released.
jit = _compiler(cache=CACHE, error_model="numpy", nogil=True)
#: The same, allowing a * b + c to contract into one fused multiply-add (more accurate, not
#: less); nothing else of fast-math. Used by the elementary functions.
jit_fma = _compiler(cache=CACHE, error_model="numpy", nogil=True, fastmath={"contract"})
#: The same options as :data:`jit`, keeping numba's literal specialisation: for the few tiny
#: helpers called with constant joint or row indices in hot loops, where a copy per constant
#: costs little to compile and runs faster (the offset-wrist solver's screw motions: the UR5's
#: batch rate was 6 % lower without it).
jit_literal = njit(cache=CACHE, error_model="numpy", nogil=True)


def entry_point(kernel: Any, args: tuple[Any, ...]) -> Callable[..., Any]:
    """The compiled entry point of a numba kernel for the types of ``args`` (compiled, or loaded
    from the cache, now); callers then pass exactly those types and skip numba's per-call type
    resolution."""
    from numba import typeof

    signature = tuple(typeof(arg) for arg in args)
    kernel.compile(signature)
    return kernel.overloads[signature].entry_point
