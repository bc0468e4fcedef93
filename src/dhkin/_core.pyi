"""Type information of dhkin._core, the compiled core (cpp/bindings*.cpp)."""

from typing import Any

import numpy as np
from numpy.typing import NDArray

BRANCHES: int
WHY_SIZE: int
EXTRA_ROOTS: int
ORTHONORMALITY_GATE: float
BOTTOM_ROW_TOLERANCE: float
FLAG_BAND: float
MERGE_ANGLE: float
FK_ROUNDING: float
VECTOR_WIDTH: int

def pose_status(T: NDArray[np.float64]) -> int: ...
def project(T: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]: ...
def sincos(x: NDArray[np.float64]) -> NDArray[np.float64]: ...
def atan2(y: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]: ...
def wrap(x: NDArray[np.float64]) -> NDArray[np.float64]: ...
def right_svd(
    A: NDArray[np.float64], start: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]: ...

class Chain:
    def __init__(self, before: NDArray[np.float64], revolute: NDArray[np.bool_],
                 direction: NDArray[np.float64], offset: NDArray[np.float64],
                 tail: NDArray[np.float64]) -> None: ...
    @property
    def dof(self) -> int: ...
    def fk(self, q: NDArray[np.float64], out: NDArray[np.float64]) -> None: ...
    def refine(self, q: NDArray[np.float64], targets: NDArray[np.float64],
               fixed: NDArray[np.bool_], tolerance: float, budget: int, growth: float,
               damping_start: float, stop_on_stall: bool, lanes: bool,
               errors: NDArray[np.float64]) -> None: ...

NUMERICAL_LAMBDA_FLOOR: float

class NumericalTask:
    def __init__(self, pose: bool, rows: int, target_inverse: NDArray[np.float64],
                 world_point: NDArray[np.float64], base_rotation_t: NDArray[np.float64] | None,
                 tcp: NDArray[np.float64] | None, preferred: NDArray[np.float64] | None,
                 weights: NDArray[np.float64] | None) -> None: ...

class NumericalSettings:
    def __init__(self, method: str, tolerance: float, max_iterations: int, damping: float,
                 nullspace_gain: float, nullspace_tolerance: float, slide_iterations: int,
                 stall_window: int, stall_ratio: float) -> None: ...

class NumericalChain:
    def __init__(self, before: NDArray[np.float64], revolute: NDArray[np.bool_],
                 direction: NDArray[np.float64], offset: NDArray[np.float64],
                 tail: NDArray[np.float64], lower: NDArray[np.float64],
                 upper: NDArray[np.float64]) -> None: ...
    @property
    def dof(self) -> int: ...
    def project(self, q: NDArray[np.float64], out: NDArray[np.float64]) -> None: ...
    def descend(self, task: NumericalTask, settings: NumericalSettings,
                start: NDArray[np.float64], q_out: NDArray[np.float64],
                ) -> tuple[float, float, int, bool, float]: ...

class Answer:
    count: int
    found: int  # solutions stored; -1 when the pose or the seed was rejected
    status: int
    projection: float
    candidates: int
    verified: int
    dropped: int
    best_position: float
    best_rotation: float
    def q(self) -> NDArray[np.float64]: ...
    def branch(self) -> NDArray[np.int16]: ...
    def flags(self) -> NDArray[np.uint8]: ...
    def residuals(self) -> NDArray[np.float64]: ...
    def configuration_keys(self) -> list[tuple[int, tuple[int, ...]]]: ...
    def why(self) -> NDArray[np.float64]: ...

class ClosedForm:
    def __init__(self, plan: dict[str, Any], frames: NDArray[np.float64]) -> None: ...
    def solve(self, T: Any, seed: Any, tolerance: float, frames: NDArray[np.float64] | None,
              copies: bool) -> Answer: ...
    def bind_results(self, type: type, configure: Any, family: str) -> None: ...
    def solve_common(self, T: Any, seed: Any, tolerance: Any, tcp: Any,
                     copies: Any) -> Any: ...
    def principal(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
                  tolerance: float, frames: NDArray[np.float64], copies: bool,
                  q: NDArray[np.float64], ok: NDArray[np.bool_], flags: NDArray[np.uint8],
                  errors: NDArray[np.float64], totals: NDArray[np.int64],
                  why: NDArray[np.float64], info: NDArray[np.float64], *,
                  direct: bool = True) -> None: ...
    def nearest(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
                tolerance: float, frames: NDArray[np.float64], q: NDArray[np.float64],
                valid: NDArray[np.bool_], branch: NDArray[np.int16], flags: NDArray[np.uint8],
                errors: NDArray[np.float64], projection: NDArray[np.float64],
                dropped: NDArray[np.int64]) -> tuple[int, int, int]: ...
    def attach_exact_roots(self, general: General6R) -> None: ...
    def rows(self, targets: NDArray[np.float64], seeds: NDArray[np.float64], tolerance: float,
             frames: NDArray[np.float64], copies: bool) -> tuple[Any, ...]: ...
    def direct_answers(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
                       tolerance: float, frames: NDArray[np.float64],
                       answered: NDArray[np.bool_]) -> None: ...
    def refined_direct_answers(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
                               tolerance: float, frames: NDArray[np.float64],
                               answered: NDArray[np.bool_]) -> None: ...
    def expand(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
               tolerance: float, frames: NDArray[np.float64], copies: bool,
               q: NDArray[np.float64], ok: NDArray[np.bool_], flags: NDArray[np.uint8],
               errors: NDArray[np.float64], out_q: NDArray[np.float64],
               out_valid: NDArray[np.bool_], out_branch: NDArray[np.int16],
               out_flags: NDArray[np.uint8], out_errors: NDArray[np.float64]) -> None: ...

# The general 6R solver (cpp/bindings_general6r.cpp, cpp/dhkin/general6r/).
class General6R:
    def __init__(self, fields: dict[str, NDArray[np.float64]],
                 others: list[dict[str, NDArray[np.float64]]]) -> None: ...
    def candidates(self, T_dh: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.int64], float, bool]: ...
    def roots(self, T_dh: NDArray[np.float64], tolerance: float
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], int, NDArray[np.float64]]: ...
    def smallest_singular(self, q: NDArray[np.float64]) -> float: ...
    def solve(self, T: NDArray[np.float64], seed: NDArray[np.float64], tolerance: float,
              copies: bool, tcp: NDArray[np.float64] | None = None
              ) -> tuple[int, int, float, float, int, int,
                         tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.uint8]]]: ...
    def solve_batch_seeds(self, T: NDArray[np.float64], seeds: NDArray[np.float64],
                          tolerance: float, copies: bool, tcp: NDArray[np.float64] | None = None
                          ) -> list[tuple[tuple[NDArray[np.float64], NDArray[np.float64],
                                                NDArray[np.uint8]],
                                          NDArray[np.int64], NDArray[np.float64],
                                          NDArray[np.int64], int, int]]: ...

def general6r_multistart(before: NDArray[np.float64], direction: NDArray[np.float64],
                         offset: NDArray[np.float64], tail: NDArray[np.float64],
                         target: NDArray[np.float64], starts: NDArray[np.float64],
                         tolerance: float, patience: int, most: int) -> NDArray[np.float64]: ...
