"""Long shots of a refined table at the edge of the reach bound (cpp/dhkin/reach_bound.hpp).

A long shot is a branch that the ideal model clamps onto a reach boundary violated by more than
the clamp band; the refined pipeline does not chase one whose reach margin cannot climb to the
boundary within the tolerance plus the model deviation, except at a fold of the ideal model (a
valid branch within the band of its own boundary), where a chase can land on a double root.

Targets: Pinocchio FK on each robot's generated URDF (``robot.reference()``) of sampled q, so the
exact chain reaches every target at the sampled q.
"""

from __future__ import annotations

import numpy as np
import pytest

import dhkin

# tm5_900 (rounded constants) sampled with the elbow exactly stretched (q3 = 0): on the exact
# chain's elbow fold, a double root. The ideal model misses the other wrist side's elbow by
# centimetres (long shots that the bound excludes) while this side's elbow is within the clamp
# band of its boundary (the fold exception). Answering without the long shots' chase gave two
# roots 2.2e-6 rad apart, neither flagged, in place of the one double root.
TM5_STRETCHED = [
    [3.7702328811461285, 1.106199433925159, 0.0, -1.2959653727079032, -0.15077114391256075,
     1.4249228459269965],
    [4.613203053843199, 1.7644467534460198, 0.0, 0.6308032575352471, 0.09507517068457716,
     -2.626248790039901],
    [4.285709476639491, 0.1387032376606192, 0.0, -1.8433888027762857, -0.08637782312974362,
     4.134787875825623],
    [-4.281125861491121, 2.6482457480779917, 0.0, -1.540982533116407, -0.03048285799111783,
     2.5352481243793994],
]
# Two roots of one pose closer than this (rad) are copies of one double root here: ten times the
# core's merge angle (kMergeAngle, 1e-6 rad, cpp/dhkin/bands.hpp); the copies seen were 2.2e-6
# apart, the next root of these poses is 0.03 rad away or more.
DOUBLE_ROOT = 1e-5


def joint_distance(Q: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Largest wrapped joint difference of each row of Q from q (rad)."""
    return np.abs(np.angle(np.exp(1j * (np.atleast_2d(Q) - q)))).max(axis=1)


@pytest.mark.parametrize("q", TM5_STRETCHED)
def test_stretched_elbow_double_root_is_one_flagged_solution(q: list[float]) -> None:
    robot = dhkin.load("tm5_900")
    q = np.asarray(q)
    T = robot.reference().fk(q[None])[0]
    solutions = robot.ik(T, copies=False)
    near = joint_distance(np.asarray(solutions.q), q) < DOUBLE_ROOT
    assert near.sum() == 1, joint_distance(np.asarray(solutions.q), q)
    assert "elbow" in solutions.flags[int(np.argmax(near))]


@pytest.mark.parametrize("folded", [False, True])
def test_sampled_q_back_across_the_elbow_reach_boundary(folded: bool) -> None:
    """ur5e_calibrated (the widest clamp band, 1.57 cm): q3 swept across the stretched (0) or
    folded (pi) elbow, where the ideal model's margin on the sampled branch crosses the band and
    other branches of the pose are long shots; the sampled q comes back within 1e-9 rad."""
    robot = dhkin.load("ur5e_calibrated")
    rng = np.random.default_rng(31)
    q = rng.uniform(robot.lower, robot.upper, size=(120, 6))
    offsets = np.concatenate([np.zeros(20), rng.uniform(-0.02, 0.02, 100)])
    q[:, 2] = np.pi - np.abs(offsets) if folded else offsets
    T = robot.reference().fk(q)
    missed = []
    for i in range(len(q)):
        Q = np.asarray(robot.ik(T[i], copies=False).q)
        if not (len(Q) and joint_distance(Q, q[i]).min() <= 1e-9):
            missed.append(i)
    assert not missed, q[missed]
