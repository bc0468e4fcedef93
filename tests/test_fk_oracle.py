"""Own numpy FK equals Pinocchio FK on the URDF generated through xacro, to 1e-12, every frame.

Per built-in robot (the package arms: a sample, conftest.PER_ROBOT_BUILTINS): 10^4 joint vectors
drawn uniformly within the limits (fixed seed), every combination of the special angles 0,
+-pi/2, +-pi that lies within the limits (a joint whose range holds fewer than three of them,
like a vendor's 1.5707 that stops just short of pi/2: its limits too; prismatic joints: lower,
middle, upper), and the lower and upper limit vectors. For each, every frame of the generated
URDF is compared: ``base_link``, ``base``, each joint's link, ``flange`` and ``tool0``. The other
package arms: the same comparison on 500 uniform joint vectors and each joint at each of its
special values.

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
from dhkin.vendors import PACKAGE_ARMS

from .conftest import PER_ROBOT_BUILTINS

ROBOTS = PER_ROBOT_BUILTINS
N_RANDOM = 10_000
TOLERANCE = 1e-12  # m and rad
SPECIAL_ANGLES = (0.0, math.pi / 2, -math.pi / 2, math.pi, -math.pi)


def special_values(table: DHTable) -> list[list[float]]:
    """Per joint, its special values within the limits: the special angles (a revolute joint
    whose range holds fewer than three of them takes its limits too), or a prismatic joint's
    lower, middle and upper values."""
    per_joint = []
    for joint in table.joints:
        if joint.is_revolute:
            values = [v for v in SPECIAL_ANGLES if joint.lower <= v <= joint.upper]
            if len(values) < 3:
                values = sorted({*values, joint.lower, joint.upper})
        else:
            values = [joint.lower, 0.5 * (joint.lower + joint.upper), joint.upper]
        per_joint.append(values)
    return per_joint


def special_grid(table: DHTable) -> NDArray[np.float64]:
    """Every combination of special joint values (special_values), plus both limit vectors."""
    grid = np.array(list(itertools.product(*special_values(table))), dtype=float)
    return np.vstack([grid, table.lower, table.upper])


def special_rows(table: DHTable) -> NDArray[np.float64]:
    """Each joint at each of its special values, the others at 0 (or the nearest limit), plus
    both limit vectors: the special values one joint at a time instead of every combination."""
    home = np.clip(np.zeros(table.dof), table.lower, table.upper)
    rows = [home]
    for i, values in enumerate(special_values(table)):
        for value in values:
            row = home.copy()
            row[i] = value
            rows.append(row)
    return np.vstack([*rows, table.lower, table.upper])


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
    for k, config in enumerate(reference.configurations(Q)):
        pin.framesForwardKinematics(model, data, config)
        for j, frame_id in enumerate(ids):
            out[j, k] = data.oMf[frame_id].homogeneous
    return {name: out[j] for j, name in enumerate(names)}


def sample(name: str, n_random: int, every_combination: bool = True) -> Sampled:
    """``n_random`` uniform joint vectors (seeded by the name), then the special grid (or, not
    ``every_combination``, the special values one joint at a time)."""
    robot = dhkin.load(name)
    rng = np.random.default_rng(zlib.crc32(robot.name.encode()))
    special = special_grid(robot.table) if every_combination else special_rows(robot.table)
    Q = np.vstack([robot.table.random_q(n_random, rng), special])
    names = ["base_link", "base", *[j.link for j in robot.table.joints], "flange", "tool0"]
    return Sampled(robot, Q, n_random, pinocchio_frames(robot, Q, names))


@pytest.fixture(scope="module", params=ROBOTS)
def sampled(request: pytest.FixtureRequest) -> Sampled:
    return sample(request.param, N_RANDOM)


def test_every_package_arm_fk_equals_pinocchio_in_every_frame() -> None:
    """The package arms outside ROBOTS, leaner: 500 uniform joint vectors and each joint at each
    of its special values, every frame of the generated URDF to 1e-12."""
    others = [name for name in PACKAGE_ARMS if name not in ROBOTS]
    assert len(others) == len(PACKAGE_ARMS) - 7
    for name in others:
        sampled = sample(name, 500, every_combination=False)
        assert len(sampled.q) - 500 >= 1 + 3 * sampled.robot.dof + 2
        for frame, T in expected_frames(sampled.robot.table, sampled.q).items():
            position, rotation = pose_error(T, sampled.pinocchio[frame])
            assert max(position.max(), rotation.max()) <= TOLERANCE, (name, frame)


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
