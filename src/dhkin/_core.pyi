"""Type information of dhkin._core, the compiled core (cpp/bindings.cpp)."""

from typing import Any

import numpy as np
from numpy.typing import NDArray

BRANCHES: int
WHY_SIZE: int
ORTHONORMALITY_GATE: float
BOTTOM_ROW_TOLERANCE: float
FLAG_BAND: float
MERGE_ANGLE: float
FK_ROUNDING: float

def pose_status(T: NDArray[np.float64]) -> int: ...
def project(T: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]: ...

class Chain:
    def __init__(self, before: NDArray[np.float64], revolute: NDArray[np.bool_],
                 direction: NDArray[np.float64], offset: NDArray[np.float64],
                 tail: NDArray[np.float64]) -> None: ...
    @property
    def dof(self) -> int: ...
    def fk(self, q: NDArray[np.float64], out: NDArray[np.float64]) -> None: ...

class ClosedForm:
    def __init__(self, plan: dict[str, Any], frames: NDArray[np.float64]) -> None: ...
    def solve_one(self, T: NDArray[np.float64], seed: NDArray[np.float64], tolerance: float,
                  frames: NDArray[np.float64], copies: bool
                  ) -> tuple[NDArray[np.float64], NDArray[np.int16], NDArray[np.uint8],
                             NDArray[np.float64],
                             tuple[int, float, int, int, int, float, float,
                                   NDArray[np.float64]]]: ...
    def principal(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
                  tolerance: float, frames: NDArray[np.float64], copies: bool,
                  q: NDArray[np.float64], ok: NDArray[np.bool_], flags: NDArray[np.uint8],
                  errors: NDArray[np.float64], totals: NDArray[np.int64],
                  why: NDArray[np.float64], info: NDArray[np.float64],
                  direct: bool = True) -> None: ...
    def direct_answers(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
                       tolerance: float, frames: NDArray[np.float64],
                       answered: NDArray[np.bool_]) -> None: ...
    def expand(self, targets: NDArray[np.float64], seeds: NDArray[np.float64],
               tolerance: float, frames: NDArray[np.float64], copies: bool,
               q: NDArray[np.float64], ok: NDArray[np.bool_], flags: NDArray[np.uint8],
               errors: NDArray[np.float64], out_q: NDArray[np.float64],
               out_valid: NDArray[np.bool_], out_branch: NDArray[np.int16],
               out_flags: NDArray[np.uint8], out_errors: NDArray[np.float64]) -> None: ...
