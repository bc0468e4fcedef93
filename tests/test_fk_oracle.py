"""Own numpy FK equals Pinocchio FK on the URDF generated through xacro, to 1e-12, every frame.

Per built-in robot: 10^4 joint vectors drawn uniformly within the limits (fixed seed), every
combination of the special angles 0, +-pi/2, +-pi that lies within the limits (prismatic joints:
lower, middle, upper), and the lower and upper limit vectors. For each, every frame of the
generated URDF is compared: ``base_link``, ``base``, each joint's link, ``flange`` and ``tool0``.

The expected link frames follow urdf.py's definitions, derived here from the DH frames of
:meth:`DHTable.fk_frames` (F_0 = base, F_i = F_{i-1} A_i):

* modified DH: link_i = F_i;
* standard DH: link_i = F_{i-1} Rz(theta_i) (revolute) or F_{i-1} Rz(theta_i) Tz(d_i) (prismatic),
  the frame joint i moves, placed at the start of row i;
* base = F_0, flange = F_n @ table.flange, tool0 = F_n @ table.tool.
"""

from __future__ import annotations

import itertools
import math
import zlib
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import pytest
from numpy.typing import NDArray

import dhkin
from dhkin.dh import DHTable
from dhkin.transforms import pose_error

ROBOTS = dhkin.builtin_names()
N_RANDOM = 10_000
TOLERANCE = 1e-12  # m and rad
SPECIAL_ANGLES = (0.0, math.pi / 2, -math.pi / 2, math.pi, -math.pi)


def special_grid(table: DHTable) -> NDArray[np.float64]:
    """Every combination of special joint values within the limits, plus both limit vectors."""
    per_joint = []
    for joint in table.joints:
        if joint.is_revolute:
            values = [v for v in SPECIAL_ANGLES if joint.lower <= v <= joint.upper]
        else:
            values = [joint.lower, 0.5 * (joint.lower + joint.upper), joint.upper]
        per_joint.append(values)
    grid = np.array(list(itertools.product(*per_joint)), dtype=float)
    return np.vstack([grid, table.lower, table.upper])


def expected_frames(table: DHTable, Q: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    """Own-FK poses (base_link -> frame) of every frame of the generated URDF, (N, 4, 4) each."""
    F = table.fk_frames(Q)
    theta, d = table.dh_parameters(Q)
    N = Q.shape[0]
    frames = {"base_link": np.broadcast_to(np.eye(4), (N, 4, 4)),
              "base": np.broadcast_to(table.base, (N, 4, 4))}
    for i, joint in enumerate(table.joints):
        if table.convention == "modified":
            frames[joint.link] = F[:, i + 1]
            continue
        turn = np.zeros((N, 4, 4))
        c, s = np.cos(theta[:, i]), np.sin(theta[:, i])
        turn[:, 0, 0], turn[:, 0, 1], turn[:, 1, 0], turn[:, 1, 1] = c, -s, s, c
        turn[:, 2, 2] = turn[:, 3, 3] = 1.0
        if not joint.is_revolute:
            turn[:, 2, 3] = d[:, i]
        frames[joint.link] = F[:, i] @ turn
    frames["flange"] = F[:, -1] @ table.flange
    frames["tool0"] = F[:, -1] @ table.tool
    return frames


@dataclass(frozen=True)
class Sampled:
    """Joint vectors of one robot and the Pinocchio poses of every frame at each of them."""

    robot: dhkin.Robot
    q: NDArray[np.float64]
    n_random: int
    pinocchio: dict[str, NDArray[np.float64]]


def pinocchio_frames(robot: dhkin.Robot, Q: NDArray[np.float64],
                     names: list[str]) -> dict[str, NDArray[np.float64]]:
    """Pinocchio poses of the named frames of the generated URDF (one FK pass per q)."""
    reference = robot.reference()
    model, data = reference.model, reference.data
    ids = [reference.frame_id(name) for name in names]
    out = np.empty((len(names), Q.shape[0], 4, 4))
    for k, q in enumerate(Q):
        pin.framesForwardKinematics(model, data, reference.configuration(q))
        for j, frame_id in enumerate(ids):
            out[j, k] = data.oMf[frame_id].homogeneous
    return {name: out[j] for j, name in enumerate(names)}


@pytest.fixture(scope="module", params=ROBOTS)
def sampled(request: pytest.FixtureRequest) -> Sampled:
    robot = dhkin.load(request.param)
    rng = np.random.default_rng(zlib.crc32(robot.name.encode()))
    Q = np.vstack([robot.table.random_q(N_RANDOM, rng), special_grid(robot.table)])
    names = ["base_link", "base", *[j.link for j in robot.table.joints], "flange", "tool0"]
    return Sampled(robot, Q, N_RANDOM, pinocchio_frames(robot, Q, names))


def test_own_fk_equals_pinocchio_tool0(sampled: Sampled) -> None:
    """robot.fk (batched over all N at once) equals Pinocchio's base_link -> tool0 to 1e-12."""
    T = sampled.robot.fk(sampled.q)
    assert T.shape == (len(sampled.q), 4, 4)
    position, rotation = pose_error(T, sampled.pinocchio["tool0"])
    assert position.max() <= TOLERANCE, f"worst q {sampled.q[position.argmax()]}"
    assert rotation.max() <= TOLERANCE, f"worst q {sampled.q[rotation.argmax()]}"


def test_every_frame_equals_pinocchio(sampled: Sampled) -> None:
    """base_link, base, every link, flange and tool0 agree with Pinocchio to 1e-12."""
    expected = expected_frames(sampled.robot.table, sampled.q)
    assert set(expected) == set(sampled.pinocchio)
    for name, T in expected.items():
        position, rotation = pose_error(T, sampled.pinocchio[name])
        assert position.max() <= TOLERANCE, (name, sampled.q[position.argmax()])
        assert rotation.max() <= TOLERANCE, (name, sampled.q[rotation.argmax()])


def test_special_angles_are_sampled(sampled: Sampled) -> None:
    """The special grid is really there: the zero pose and each limit vector are among the q,
    and every joint whose range allows it takes the values +-pi/2 and pi."""
    table = sampled.robot.table
    grid = sampled.q[sampled.n_random:]
    assert len(grid) >= 3 ** table.dof
    assert np.any(np.all(grid == 0.0, axis=1)) or np.any(table.lower > 0)
    assert np.any(np.all(grid == table.lower, axis=1)) and np.any(np.all(grid == table.upper,
                                                                         axis=1))
    for i, joint in enumerate(table.joints):
        if joint.is_revolute:
            for value in SPECIAL_ANGLES:
                if joint.lower <= value <= joint.upper:
                    assert np.any(grid[:, i] == value), (joint.name, value)


def test_batched_fk_equals_one_by_one(sampled: Sampled) -> None:
    """fk on (N, n) gives the same poses as N calls on (n,) (batching changes nothing)."""
    Q = sampled.q[:200]
    batch = sampled.robot.fk(Q)
    single = np.array([sampled.robot.fk(q) for q in Q])
    assert single.shape == (200, 4, 4)
    np.testing.assert_allclose(batch, single, rtol=0, atol=1e-15)


def test_reference_fk_batched_equals_pinocchio_pass(sampled: Sampled) -> None:
    """robot.reference().fk(Q, frame) returns the same poses as the direct Pinocchio pass."""
    Q = sampled.q[:500]
    reference = sampled.robot.reference()
    for name in ("tool0", "flange", sampled.robot.table.joints[-1].link):
        np.testing.assert_array_equal(reference.fk(Q, frame=name), sampled.pinocchio[name][:500])


def test_base_frames_do_not_move(sampled: Sampled) -> None:
    """base_link is the root (identity) and base = table.base for every q."""
    base = sampled.pinocchio["base"]
    np.testing.assert_allclose(base, np.broadcast_to(sampled.robot.table.base, base.shape),
                               rtol=0, atol=1e-15)
    np.testing.assert_array_equal(sampled.pinocchio["base_link"],
                                  np.broadcast_to(np.eye(4), base.shape))
