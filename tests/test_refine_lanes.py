"""Newton in SIMD lanes gives every lane the bits of the scalar Newton.

``refine_lanes_exact`` (cpp/dhkin/refine_lanes_exact.hpp) runs refine() (cpp/dhkin/newton.hpp)
on eight starts at once; the twin search and the valley scan of a refined table's pipeline take
it for refine(), so their answers are those of the scalar code only if each lane's iterates, its
damping, its budget and its stops are refine()'s to the bit. ``_core.Chain.refine`` runs either
road on the same rows; the rows of one target go through the lanes eight at a time, the last
group with spare lanes. Held to that on the exact chains of the calibrated UR5e (corrections on
every joint) and the Kinova Gen3, with the settings refine()'s call sites use.
"""

from __future__ import annotations

import numpy as np
import pytest

import dhkin
from dhkin import _core
from dhkin.ik.plan import chain_parts

#: refine()'s settings as its call sites pass them (newton.hpp, plan.hpp): (budget of chain
#: evaluations, growth a taken step may have, starting damping, stop at a stall), joints held.
SETTINGS = {
    "Newton (the twin search, settle)": ((120, 1e6, 0.0, False), ()),
    "held wrist, stop at a stall (the valley grid)": ((12, 1e6, 0.0, True), (5,)),
    "monotone descent from a seed": ((120, 1.0, 1e-2, False), ()),
    "a budget spent early": ((5, 1e6, 0.0, False), (0, 3)),
}
#: Distances (rad) of the starts from the sampled joint values, each along a random direction.
OFFSETS = (0.0, 1e-6, 1e-3, 0.02, 0.3, 1.0, 3.0)
TOLERANCE = 1e-9


def rows_and_targets(robot: dhkin.Robot, chain: _core.Chain,
                     rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Starts (one group of len(OFFSETS) + 4 per target) and their targets: random joint values
    within the limits and special angles (0, +-pi/2, pi, the wrist at q5 = 0) with the chain's FK
    of them as the target; the starts at OFFSETS from them, a start beyond 1e7 rad and a NaN, an
    infinite and a zero vector."""
    special = np.array([[0, 0, 0, 0, 0, 0], [0, -np.pi / 2, 0, -np.pi / 2, 0, 0],
                        [np.pi / 2, -np.pi / 2, np.pi / 2, 0, np.pi / 2, np.pi],
                        [np.pi, 0, -np.pi / 2, np.pi / 2, 0, -np.pi / 2]])
    q = np.vstack([robot.table.random_q(1000, rng), special])
    T = np.empty((len(q), 4, 4))
    chain.fk(np.ascontiguousarray(q), T)
    starts, targets = [], []
    for sampled, target in zip(q, T, strict=True):
        direction = rng.normal(size=6)
        group = [sampled + offset * direction / np.abs(direction).max() for offset in OFFSETS]
        group += [sampled + 1e7, np.full(6, np.nan), np.full(6, np.inf), np.zeros(6)]
        starts += group
        targets += [target] * len(group)
    return np.array(starts), np.ascontiguousarray(targets)


@pytest.mark.parametrize("name", ["ur5e_calibrated", "kinova_gen3_6dof"])
@pytest.mark.parametrize("setting", list(SETTINGS))
def test_each_lane_takes_the_scalar_refinement_bit_for_bit(name: str, setting: str) -> None:
    robot = dhkin.load(name)
    chain = _core.Chain(**chain_parts(robot.table))
    starts, targets = rows_and_targets(robot, chain, np.random.default_rng(46))
    (budget, growth, damping, stall), held = SETTINGS[setting]
    fixed = np.zeros(6, np.bool_)
    fixed[list(held)] = True
    results = []
    for lanes in (False, True):
        q = starts.copy()
        errors = np.empty((len(q), 2))
        chain.refine(q, targets, fixed, TOLERANCE, budget, growth, damping, stall, lanes, errors)
        results.append((q, errors))
    (q_scalar, e_scalar), (q_lanes, e_lanes) = results
    differ = ~np.all(q_scalar.view(np.uint64) == q_lanes.view(np.uint64), axis=1)
    differ |= ~np.all(e_scalar.view(np.uint64) == e_lanes.view(np.uint64), axis=1)
    assert not differ.any(), (
        f"{differ.sum()} of {len(q_scalar)} rows differ, first: start {starts[differ][0]}, "
        f"scalar {q_scalar[differ][0]} {e_scalar[differ][0]}, "
        f"lanes {q_lanes[differ][0]} {e_lanes[differ][0]}")
    # what was compared is refinement: a start at its root stays exact, and the starts away
    # from it move
    group = len(OFFSETS) + 4
    at_root = np.arange(len(starts)) % group == 0
    assert (e_scalar[at_root].max(axis=1) <= TOLERANCE).all()
    finite = np.isfinite(starts).all(axis=1) & ~at_root
    moved = np.any(q_scalar[finite] != starts[finite], axis=1)
    assert moved.mean() > 0.5


def test_the_lanes_refine_rows_in_place_and_check_their_shapes() -> None:
    chain = _core.Chain(**chain_parts(dhkin.load("ur5e_calibrated").table))
    T = np.empty((1, 4, 4))
    chain.fk(np.zeros((1, 6)), T)
    with pytest.raises(ValueError, match="q \\(N, 6\\)"):
        chain.refine(np.zeros((1, 5)), T, np.zeros(6, np.bool_), TOLERANCE, 120, 1e6, 0.0,
                     False, True, np.empty((1, 2)))
