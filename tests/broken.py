"""Deliberately broken IKs, each wrong in one way a real IK goes wrong, for `dhkin validate`.

Use them as ``dhkin validate ur5 --ik tests.broken:sign_flip`` (from the repository root). Each
takes the target T (base_link -> tool0) and the robot under test (and, for the seed-aware ones,
``q_seed``), and returns joint vectors in radians, as the validation contract says.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Iterator
from functools import cache
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

import dhkin
from dhkin.robot import Robot

if TYPE_CHECKING:
    from dhkin.ik.result import IKSolutions

#: |sin q5| under which a solution counts as on the wrist singularity here.
WRIST_SINGULAR = 1e-6


@cache
def _robot_with_flipped_d4(name: str) -> Robot:
    """The named built-in robot with the sign of d4 (the row of joint 4) flipped."""
    table = dhkin.load(name).table
    joints = list(table.joints)
    joints[3] = dataclasses.replace(joints[3], d=-joints[3].d)
    return Robot(dataclasses.replace(table, joints=tuple(joints)))


def sign_flip(T: NDArray[np.float64], robot: Robot) -> NDArray[np.float64]:
    """Solves a table whose d4 has the wrong sign: its answers miss the real pose."""
    return _robot_with_flipped_d4(robot.name).ik(T).q


def dropped_branch(T: NDArray[np.float64], robot: Robot) -> NDArray[np.float64]:
    """Correct solutions, except that one branch (the solver's first) is never returned."""
    solutions = robot.ik(T)
    first = dict(robot.ik_solver.branch_labels[0])
    keep = [k for k, c in enumerate(solutions.configurations) if dict(c.labels) != first]
    return solutions.q[keep]


def wrong_wrist_split(T: NDArray[np.float64], robot: Robot) -> NDArray[np.float64]:
    """At q5 = 0, moves q4 and q6 the same way (only a split keeping the pose is right)."""
    q = robot.ik(T).q.copy()
    singular = np.abs(np.sin(q[:, 4])) < WRIST_SINGULAR
    q[singular, 3] += 0.1
    q[singular, 5] += 0.1
    return q


def degrees_as_radians(T: NDArray[np.float64], robot: Robot) -> NDArray[np.float64]:
    """Correct solutions, returned in degrees where radians are expected."""
    return np.degrees(robot.ik(T).q)


def seed_ignored(T: NDArray[np.float64], robot: Robot,
                 q_seed: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Declares q_seed but ignores it: at q5 = 0 the free joint always comes from a seed of
    zeros, so the answer does not follow the caller's seed (caught as "discontinuous"; exact at
    q5 = 0, where the pose cannot tell which q4/q6 split was sampled)."""
    return robot.ik(T, q_seed=np.zeros(robot.dof)).q


def _branch_of_seed(robot: Robot, solutions: IKSolutions,
                    q_seed: NDArray[np.float64]) -> dict[str, str]:
    """Labels of the solution nearest q_seed (joint differences mod 2pi)."""
    revolute = np.array([j.is_revolute for j in robot.table.joints])
    difference = solutions.q - q_seed
    difference = np.where(revolute, np.pi - np.mod(np.pi - difference, 2 * np.pi), difference)
    nearest = int(np.argmin(np.abs(difference).max(axis=1)))
    return dict(solutions.configurations[nearest].labels)


def branch_dropped_off_seed(T: NDArray[np.float64], robot: Robot,
                            q_seed: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Exact solutions, and the seed's own branch always among them, but the solver's first
    branch is dropped whenever the seed is not on it: the sampled q is never missing, the
    branch is (caught as "missing_branch" only)."""
    solutions = robot.ik(T, q_seed=q_seed)
    if not solutions:
        return solutions.q
    first = dict(robot.ik_solver.branch_labels[0])
    if q_seed is not None and _branch_of_seed(robot, solutions, np.asarray(q_seed)) == first:
        return solutions.q
    keep = [k for k, c in enumerate(solutions.configurations) if dict(c.labels) != first]
    return solutions.q[keep]


# ---------------------------------------------------------------------------------------------
# Hostile IKs (issue 15): each misbehaves in a way the validator must report as a failure of the
# pose, never as its own crash, exit, hang or a PASS.


def garbage_row(T: NDArray[np.float64], robot: Robot) -> NDArray[np.float64]:
    """Every correct solution, plus one row of garbage (caught as "wrong" by any tolerance)."""
    q = robot.ik(T).q
    return np.vstack([q, np.full((1, robot.dof), 0.123)])


def writes_its_answer_into_the_seed(T: NDArray[np.float64], robot: Robot,
                                    q_seed: NDArray[np.float64] | None = None
                                    ) -> NDArray[np.float64]:
    """Returns only the first solution, after writing it into ``q_seed`` (a validator that
    handed over its own sample would then find the sample among the answers)."""
    first = robot.ik(T).q[:1]
    if q_seed is not None and len(first):
        with contextlib.suppress(ValueError):  # a read-only copy: carry on regardless
            q_seed[:] = first[0]
    return first


def shifts_the_target(T: NDArray[np.float64], robot: Robot) -> NDArray[np.float64]:
    """Moves the target 10 cm along x in place, then solves the moved target."""
    T[0, 3] += 0.1
    return robot.ik(T).q


def exits(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """Calls sys.exit(0) (a script's IK that ends the process)."""
    import sys

    sys.exit(0)


def endless(T: NDArray[np.float64], robot: Robot) -> Iterator[NDArray[np.float64]]:
    """A generator that yields the first solution for ever."""
    first = robot.ik(T).q[0]
    while True:
        yield first


def sleeps(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """Never answers in time (sleeps a minute)."""
    import time

    time.sleep(60)
    return np.zeros((0, 6))


def crashes(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """Crashes the process as a broken C extension does (a segmentation fault)."""
    import ctypes

    ctypes.string_at(0)
    return np.zeros((0, 6))


def raises(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """Raises a plain exception."""
    raise ZeroDivisionError("the solver divided by zero\nsecond line of the message")


def returns_none(T: NDArray[np.float64]) -> None:
    """Returns None."""
    return None


def returns_a_scalar(T: NDArray[np.float64]) -> float:
    """Returns one number."""
    return 0.5


def returns_strings(T: NDArray[np.float64], robot: Robot) -> list[list[str]]:
    """Returns the solutions as strings."""
    return [[f"{v:.17g}" for v in row] for row in robot.ik(T).q]


def returns_the_wrong_shape(T: NDArray[np.float64], robot: Robot) -> NDArray[np.float64]:
    """Returns the solutions transposed, (6, k)."""
    return robot.ik(T).q.T


def general6r_one_root_per_eigenvalue(T: NDArray[np.float64], robot: Robot,
                                      q_seed: NDArray[np.float64] | None = None
                                      ) -> NDArray[np.float64]:
    """The general 6R solver as it was before issue 26, for arms without a family: one root
    per value of the eliminated joint (it took one null vector per eigenvalue, so of the roots
    that share that value, at special angles four of the CRX-10iA's eight, it found one), and
    the seed as a Newton start (seeded with the sampled q it returned q anyway). Reproduced
    from today's complete answer: of the roots whose eliminated joint (the solver's
    arrangement, model angle) agrees within 1e-3 rad, the first is kept; the seed's root, if
    the seed lies within 1e-3 rad of one, is added back."""
    solver = robot.general_solver
    assert solver is not None, "an arm without a closed-form family"
    roots = robot.ik(T).q
    v = roots * solver.direction + solver.offset
    if solver.arrangement.reversed:
        v = -v[:, ::-1]
    eliminated = v[:, solver.arrangement.k] + solver.model.phi[solver.arrangement.k]
    kept: list[int] = []
    for index, value in enumerate(eliminated):
        if all(abs(np.angle(np.exp(1j * (value - eliminated[k])))) > 1e-3 for k in kept):
            kept.append(index)
    if q_seed is not None and len(roots):
        distance = np.abs(np.angle(np.exp(1j * (roots - q_seed)))).max(axis=1)
        nearest = int(np.argmin(distance))
        if distance[nearest] <= 1e-3 and nearest not in kept:
            kept.append(nearest)
    return roots[sorted(kept)]
