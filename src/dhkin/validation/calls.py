"""Calling the IK under test as a guarded experiment: whatever it does is a result of that pose,
never the validator's crash, exit or hang.

* **Inputs**: the IK gets copies of the target and the seed, made read-only
  (``flags.writeable = False``); the validator keeps its own arrays for checking and for the
  failure file. An IK that writes into its input gets a ValueError, reported for that pose.
* **Exceptions**: anything raised in the call (``SystemExit`` included; ``KeyboardInterrupt``
  is the user's and still stops the run) is a failure of that pose, with the exception's text.
* **Output**: the return value is read lazily (a generator runs one item at a time) and must be
  an iterable of joint vectors of ``dof`` real numbers (a (k, dof) array or a list of (dof,)
  vectors). None, a number, a string, a mapping, a 1-D array, strings, complex numbers, ragged
  rows or more than :data:`MAX_SOLUTIONS_PER_CALL` solutions are a failure of the pose that says
  which, and reading stops there (a generator that never ends is not drained).
* **Time**: each call (reading its output included) has :data:`DEFAULT_CALL_TIMEOUT` seconds, or
  the run's ``timeout``. In the main thread of a Unix process a SIGALRM timer interrupts a
  pure-Python IK when its time is up (code in C or numba is interrupted when it returns to
  Python); elsewhere an overlong call is reported once it returns. An IK that swallows every
  exception (``except BaseException``) can outlive its timer: run it isolated.
* **Isolation** (``isolate=True``): every call runs in a child process (multiprocessing; fork
  where available, so the IK need not be picklable). A call that crashes the child (a
  segmentation fault in an extension, ``os._exit``) or outlives its time limit, whatever it
  swallows, is reported for that pose, the child is killed and a fresh one serves the next call.
"""

from __future__ import annotations

import contextlib
import faulthandler
import inspect
import multiprocessing
import signal
import threading
import time
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from types import FrameType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.arm import Arm
from dhkin.errors import InputError
from dhkin.validation.arguments import one_line

#: Most solutions read from one IK call. A 6R arm has at most 16 branches; with every in-limit
#: 2pi copy of each (3 per joint for a +-540 deg range: 3^6 = 729) that is 11,664 solutions.
#: 100,000 is far above any honest answer, and still small to hold and check (4.8 MB, well under
#: a second of FK); a generator that never ends is stopped here instead of filling the memory.
MAX_SOLUTIONS_PER_CALL = 100_000


#: Solutions kept of an answer that is not a list of joint vectors (too long, or with a bad item
#: after good ones), for the failure file: enough to see what came back, not 100,000 per pose.
KEPT_OF_A_BAD_ANSWER = 16


#: Time limit of one IK call (s), reading its output included. Generous: dhkin's own IK answers
#: in ~0.1 ms, but its first call compiles the numba kernels (15-41 s on an idle 2-core machine,
#: several times that on a loaded one), and a slow numerical IK in Python may take seconds; five
#: minutes covers those, while a hung call no longer hangs the run.
DEFAULT_CALL_TIMEOUT = 300.0


#: Seconds an isolated run waits for a new child process to be ready, before and apart from the
#: call's own time limit: a forked child is ready at once; a spawned one (where fork is not
#: available) starts Python and imports numpy, Pinocchio and the IK's module first.
CHILD_START_GRACE = 60.0


#: What an isolated child sends once it is ready for calls.
_READY = "ready"


@dataclass
class CallResult:
    """What one IK call gave: its joint vectors (each (dof,) float, copied), and ``problem``
    ('' when the call ran and returned a well-formed answer) with its ``outcome``: "no_solution"
    (it raised, exited, crashed or timed out: nothing usable came back) or "wrong" (it returned
    something that is not a list of joint vectors)."""

    solutions: list[NDArray[np.float64]] = field(default_factory=list)
    problem: str = ""
    outcome: str = ""


class _CallTimedOut(BaseException):
    """Raised by the SIGALRM handler inside an IK call whose time is up (a BaseException so that
    an IK's ``except Exception`` does not swallow it)."""


def parameters(ik: Any) -> Mapping[str, inspect.Parameter]:
    """The IK's parameters (empty when Python cannot tell, e.g. some builtins)."""
    try:
        return inspect.signature(ik).parameters
    except (TypeError, ValueError):
        return {}


def takes_seed(ik: Any) -> bool:
    """Whether the IK declares a ``q_seed`` parameter."""
    return "q_seed" in parameters(ik)


def read_only_copy(array: NDArray[np.float64]) -> NDArray[np.float64]:
    """A copy of ``array`` that cannot be written (what the IK under test gets)."""
    copy = np.array(array, dtype=float, copy=True)
    copy.flags.writeable = False
    return copy


def _joint_vector(item: Any, index: int, dof: int) -> tuple[NDArray[np.float64] | None, str]:
    """One returned solution as a (dof,) float array, or (None, what is wrong with it)."""
    if isinstance(item, (str, bytes)):
        return None, f"solution {index} is a string, not {dof} numbers"
    try:
        array = np.asarray(item)
    except Exception as exc:
        return None, f"solution {index} is not an array of numbers ({one_line(str(exc), 120)})"
    if array.dtype.kind not in "iuf":
        kind = {"c": "complex numbers", "b": "booleans", "U": "strings", "S": "bytes",
                "O": "objects"}.get(array.dtype.kind, f"dtype {array.dtype}")
        return None, f"solution {index} holds {kind}, not real numbers"
    if array.ndim != 1:
        squeezed = array.squeeze()
        array = squeezed if squeezed.ndim == 1 else array
    if array.shape != (dof,):
        return None, f"solution {index} has shape {array.shape}, expected ({dof},)"
    return np.array(array, dtype=float, copy=True), ""


def _items(result: Any, dof: int) -> Iterator[Any]:
    """The returned solutions one by one (raises TypeError for a value that is no list of
    solutions)."""
    if result is None:
        raise TypeError("returned None")
    if isinstance(result, (str, bytes)):
        raise TypeError("returned a string")
    if isinstance(result, Mapping):
        raise TypeError(f"returned a mapping ({type(result).__name__})")
    if isinstance(result, np.ndarray):
        if result.ndim != 2:
            raise TypeError(f"returned an array of shape {result.shape}")
        return iter(result)
    if not isinstance(result, Iterable):
        raise TypeError(f"returned {type(result).__name__} {one_line(repr(result), 60)}")
    return iter(result)


def collect(result: Any, dof: int, limit: int = MAX_SOLUTIONS_PER_CALL) -> CallResult:
    """Read what an IK returned, lazily, into a :class:`CallResult` (see the module docstring).
    Exceptions raised while iterating (a generator's body) propagate to the caller's guard."""
    expected = f"expected an iterable of joint vectors ({dof} numbers each)"
    if (isinstance(result, np.ndarray) and result.ndim == 2 and result.shape[1] == dof
            and result.dtype.kind in "iuf" and len(result) <= limit):
        # The common answer, a (k, dof) real array: the checks below, done for all rows at once.
        return CallResult(list(np.array(result, dtype=float, copy=True)))
    try:
        items = _items(result, dof)
    except TypeError as exc:
        return CallResult([], f"{exc}; {expected}", "wrong")
    solutions: list[NDArray[np.float64]] = []
    for index, item in enumerate(items):
        if index >= limit:
            return CallResult(solutions[:KEPT_OF_A_BAD_ANSWER],
                              f"returned more than {limit} solutions (MAX_SOLUTIONS_PER_CALL); "
                              "stopped reading", "wrong")
        vector, problem = _joint_vector(item, index, dof)
        if vector is None:
            return CallResult(solutions[:KEPT_OF_A_BAD_ANSWER], f"{problem}; {expected}",
                              "wrong")
        solutions.append(vector)
    return CallResult(solutions)


def wanted(ik: Any) -> frozenset[str]:
    """Which of the optional keywords ``q_seed`` and ``robot`` the IK declares."""
    return frozenset(("q_seed", "robot")) & frozenset(parameters(ik))


def _arguments(robot: Arm, T: NDArray[np.float64], q_seed: NDArray[np.float64] | None,
               declared: frozenset[str]) -> tuple[NDArray[np.float64], dict[str, Any]]:
    kwargs: dict[str, Any] = {}
    if "q_seed" in declared and q_seed is not None:  # None: unseeded (the IK's own default)
        kwargs["q_seed"] = read_only_copy(q_seed)
    if "robot" in declared:
        kwargs["robot"] = robot
    return read_only_copy(T), kwargs


def _describe(exc: BaseException) -> str:
    if isinstance(exc, SystemExit):
        return f"called sys.exit({exc.code!r})"
    text = one_line(str(exc))
    return f"raised {type(exc).__name__}" + (f": {text}" if text else "")


def _run_guarded(ik: Any, robot: Arm, T: NDArray[np.float64],
                 q_seed: NDArray[np.float64] | None, limit: int,
                 declared: frozenset[str]) -> CallResult:
    """Call and read the IK; every exception but KeyboardInterrupt and the timer's becomes the
    pose's problem."""
    try:
        target, kwargs = _arguments(robot, T, q_seed, declared)
        return collect(ik(target, **kwargs), robot.dof, limit)
    except (KeyboardInterrupt, _CallTimedOut):
        raise
    except BaseException as exc:  # the IK's own failure, SystemExit included: that pose's
        return CallResult([], _describe(exc), "no_solution")


def _alarm_usable() -> bool:
    return (hasattr(signal, "setitimer") and hasattr(signal, "SIGALRM")
            and threading.current_thread() is threading.main_thread())


def _on_alarm(signum: int, frame: FrameType | None) -> None:
    raise _CallTimedOut


def _timed_out(timeout: float) -> CallResult:
    return CallResult([], f"timed out: no answer within {timeout:g} s (the per-call time limit, "
                          "--timeout)", "no_solution")


def call_in_process(ik: Any, robot: Arm, T: NDArray[np.float64],
                    q_seed: NDArray[np.float64] | None, timeout: float | None,
                    limit: int = MAX_SOLUTIONS_PER_CALL,
                    declared: frozenset[str] | None = None) -> CallResult:
    """One guarded call in this process (see the module docstring); ``declared``: the IK's
    :func:`wanted` keywords, if already known."""
    if declared is None:
        declared = wanted(ik)
    started = time.monotonic()
    if timeout is None or not _alarm_usable():
        result = _run_guarded(ik, robot, T, q_seed, limit, declared)
        if timeout is not None and time.monotonic() - started > timeout:
            return _timed_out(timeout)
        return result
    previous_handler = signal.signal(signal.SIGALRM, _on_alarm)
    previous_timer = (0.0, 0.0)
    try:
        try:
            previous_timer = signal.setitimer(signal.ITIMER_REAL, timeout)
            return _run_guarded(ik, robot, T, q_seed, limit, declared)
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
    except _CallTimedOut:
        return _timed_out(timeout)
    finally:
        signal.signal(signal.SIGALRM, previous_handler)
        if previous_timer[0] > 0.0:  # someone else's timer was running: give it back
            elapsed = time.monotonic() - started
            signal.setitimer(signal.ITIMER_REAL, max(previous_timer[0] - elapsed, 1e-3),
                             previous_timer[1])


def _child_main(connection: Any, ik: Any, robot: Arm, limit: int) -> None:
    """The isolated child: say it is ready, then answer (T, q_seed) requests until told to stop
    (None). Python's fault handler is off here, and Ctrl-C ignored: a crash is the parent's to
    report, as a failure of the pose, and an interrupt the parent's, not a stack dump on the
    terminal."""
    faulthandler.disable()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to report, once
    declared = wanted(ik)
    connection.send(_READY)
    while True:
        try:
            request = connection.recv()
        except (EOFError, OSError):
            return
        if request is None:
            return
        T, q_seed = request
        result = _run_guarded(ik, robot, T, q_seed, limit, declared)
        stacked = (np.array(result.solutions, dtype=float).reshape(-1, robot.dof)
                   if result.solutions else np.zeros((0, robot.dof)))
        connection.send((stacked, result.problem, result.outcome))


class IsolatedCaller:
    """Calls the IK in a child process (see the module docstring); :meth:`close` ends it."""

    def __init__(self, ik: Any, robot: Arm, timeout: float | None,
                 limit: int = MAX_SOLUTIONS_PER_CALL) -> None:
        methods = multiprocessing.get_all_start_methods()
        self._context: Any = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
        self._ik, self._robot, self._timeout, self._limit = ik, robot, timeout, limit
        self._process: Any = None
        self._connection: Any = None

    def _start(self) -> str:
        """Start a child and wait for it to be ready; '' or why it could not start."""
        parent, child = self._context.Pipe()
        self._process = self._context.Process(
            target=_child_main, args=(child, self._ik, self._robot, self._limit), daemon=True)
        try:
            self._process.start()
        except Exception as exc:  # spawn pickles the IK and the robot: a lambda cannot go
            parent.close()
            child.close()
            self._process = None
            method = self._context.get_start_method()
            raise InputError(
                f"isolate: cannot start the IK in a child process ({type(exc).__name__}: "
                f"{one_line(str(exc), 160)}); expected an IK the {method!r} start "
                "method can pass (a module-level function)", field="isolate",
                expected="an IK a child process can receive") from exc
        child.close()
        self._connection = parent
        try:
            if parent.poll(CHILD_START_GRACE) and parent.recv() == _READY:
                return ""
        except (EOFError, OSError):
            pass
        self._process.join(timeout=1.0)
        code = self._process.exitcode
        self._stop()
        return (f"the IK's process did not start within {CHILD_START_GRACE:g} s "
                f"({_exit_text(code)})")

    def _stop(self) -> None:
        if self._process is None:
            return
        if self._process.is_alive():
            self._process.kill()
        self._process.join()
        self._connection.close()
        self._process = self._connection = None

    def __call__(self, T: NDArray[np.float64], q_seed: NDArray[np.float64] | None
                 ) -> CallResult:
        if self._process is None:
            problem = self._start()
            if problem:
                return CallResult([], problem, "no_solution")
        try:
            self._connection.send((np.array(T, dtype=float),
                                   None if q_seed is None else np.array(q_seed, dtype=float)))
            if self._timeout is not None and not self._connection.poll(self._timeout):
                self._stop()
                return _timed_out(self._timeout)
            stacked, problem, outcome = self._connection.recv()
        except (EOFError, OSError):
            self._process.join(timeout=5.0)
            code = self._process.exitcode
            self._stop()
            return CallResult([], f"the IK's process died ({_exit_text(code)})", "no_solution")
        return CallResult(list(np.asarray(stacked, dtype=float)), problem, outcome)

    def close(self) -> None:
        if self._process is not None and self._process.is_alive():
            with contextlib.suppress(OSError, BrokenPipeError):
                self._connection.send(None)
            self._process.join(timeout=5.0)
        self._stop()


def _exit_text(code: int | None) -> str:
    if code is None:
        return "no exit code"
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


class IKCaller:
    """The IK under test, called guarded: ``caller(T, q_seed) -> CallResult``, in this process
    or (``isolate``) in a child process; ``q_seed`` None calls it unseeded (an IK that takes a
    seed gets none). Use as a context manager (the child is ended on exit)."""

    def __init__(self, ik: Any, robot: Arm, timeout: float | None = DEFAULT_CALL_TIMEOUT,
                 isolate: bool = False, limit: int = MAX_SOLUTIONS_PER_CALL) -> None:
        self.ik, self.robot, self.timeout, self.limit = ik, robot, timeout, limit
        self._declared = wanted(ik)
        self._isolated = IsolatedCaller(ik, robot, timeout, limit) if isolate else None

    def __call__(self, T: ArrayLike, q_seed: ArrayLike | None) -> CallResult:
        target = np.asarray(T, dtype=float)
        seed = None if q_seed is None else np.asarray(q_seed, dtype=float)
        if self._isolated is not None:
            return self._isolated(target, seed)
        return call_in_process(self.ik, self.robot, target, seed, self.timeout, self.limit,
                               self._declared)

    def close(self) -> None:
        if self._isolated is not None:
            self._isolated.close()

    def __enter__(self) -> IKCaller:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
