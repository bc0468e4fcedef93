"""The joint vectors a validation samples (fixed seed): uniform, special angles and near-singular,
and the seeds perturbed for the continuity check.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.errors import InputError

SPECIAL_ANGLES = (0.0, np.pi / 2, -np.pi / 2, np.pi)


#: Wrist joint (0-based) whose zero is the wrist singularity of both closed-form families.
WRIST_JOINT = 4


NEAR_SINGULAR_MAX = 1e-6


#: Continuity check: each revolute joint of the seed moves by +- this much (rad, random signs).
SEED_PERTURBATION = 0.05


#: Continuity check: the solution nearest the perturbed seed lies within this of it on every
#: joint (rad, mod 2pi). Twice the perturbation plus margin: at q5 = 0 a free joint taken from
#: the perturbed seed moves its partner (q4 +- q6 fixed) by the same 0.05.
CONTINUITY_DISTANCE = 0.25


#: Sample sets on which the continuity check runs (the singular sets).
CONTINUITY_SETS: tuple[str, ...] = ("special", "near_singular")


#: Which samples the multistart reference of an arm without a closed form checks
#: (:mod:`dhkin.validation.multistart`, ~5 ms per pose): every other special-angle sample
#: (roots were lost there: several share a joint value), every REFERENCE_EVERY-th
#: near-singular one and every REFERENCE_EVERY^2-th uniform one (a run of 10,000 uniform
#: poses: 500 + 100 + 100); every sample is checked against its sampled q.
REFERENCE_EVERY = 10


def reference_samples(sets: list[str]) -> NDArray[np.bool_]:
    """Which samples the multistart reference checks (see :data:`REFERENCE_EVERY`)."""
    every = {"special": 2, "near_singular": REFERENCE_EVERY, "uniform": REFERENCE_EVERY ** 2}
    seen: dict[str, int] = {}
    chosen = []
    for name in sets:
        index = seen.get(name, 0)
        seen[name] = index + 1
        chosen.append(index % every.get(name, 1) == 0)
    return np.array(chosen, dtype=np.bool_)


def sample_joint_vectors(robot: Arm, n: int, seed: int) -> tuple[NDArray[np.float64],
                                                                    list[str]]:
    """n uniform + n/10 special-angle + n/10 near-singular joint vectors (at least 1 each)."""
    if n < 1:
        raise InputError(f"n: expected at least 1 sample, got {n}", field="n")
    rng = np.random.default_rng(seed)
    lower, upper = robot.lower, robot.upper
    extra = max(1, n // 10)
    uniform = robot.table.random_q(n, rng)
    special = robot.table.random_q(extra, rng)
    for k, joint in enumerate(robot.table.joints):
        choices = [a for a in SPECIAL_ANGLES if joint.is_revolute and lower[k] <= a <= upper[k]]
        if choices:
            special[:, k] = rng.choice(choices, size=extra)
    sets = ["uniform"] * n + ["special"] * extra
    parts = [uniform, special]
    if robot.dof > WRIST_JOINT and robot.table.joints[WRIST_JOINT].is_revolute:
        near = robot.table.random_q(extra, rng)
        magnitude = rng.uniform(0.0, NEAR_SINGULAR_MAX, size=extra)
        magnitude[: extra // 4] = 0.0
        sign = rng.choice([-1.0, 1.0], size=extra)
        near[:, WRIST_JOINT] = np.clip(sign * magnitude, lower[WRIST_JOINT], upper[WRIST_JOINT])
        parts.append(near)
        sets += ["near_singular"] * extra
    return np.vstack(parts), sets


def perturbed_seeds(robot: Arm, q: NDArray[np.float64], sets: list[str],
                    seed: int) -> NDArray[np.float64]:
    """Seeds of the continuity check: q with each revolute joint moved by +-SEED_PERTURBATION
    (random signs from ``seed``), clipped to the limits, for samples in CONTINUITY_SETS; NaN rows
    elsewhere."""
    rng = np.random.default_rng((seed, 1))
    signs = rng.choice([-1.0, 1.0], size=q.shape)
    revolute = np.array([j.is_revolute for j in robot.table.joints])
    seeds = np.clip(q + SEED_PERTURBATION * signs * revolute, robot.lower, robot.upper)
    seeds[[s not in CONTINUITY_SETS for s in sets]] = np.nan
    return seeds
