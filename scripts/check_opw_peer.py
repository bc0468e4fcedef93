#!/usr/bin/env python
"""An independent check of ``dhkin export ROBOT --format opw``: the exported YAML, read back as
MoveIt would read it, fed to py-opw-kinematics (a Rust implementation of opw_kinematics), and its
forward and inverse kinematics checked against Pinocchio on the robot's generated URDF.

    pip install py-opw-kinematics          # optional: the test suite does not need it
    python scripts/check_opw_peer.py [ROBOT ...] [-n N] [--seed S]

ROBOT: built-in names or table files (default: every built-in robot that is an OPW arm). Per
robot, on N random joint vectors within the limits (fixed seed) and every combination of 0,
+-pi/2 and pi:

* FK: py-opw-kinematics' ``batch_forward`` with the YAML's parameters, put between the fixed
  frames dhkin states (``base @ T @ tool``; identity for the built-ins), equals Pinocchio's
  base_link -> tool0 to 1e-12 (largest matrix entry);
* IK: py-opw-kinematics' ``inverse`` of Pinocchio's tool0 poses (random q only): every solution
  it returns reaches the pose through Pinocchio to 1e-9 m and rad, and the q the pose came from
  is among them (mod 2 pi, 1e-6 rad) unless that q is within 1e-3 rad of the wrist singularity.

Exit status 0: every check passed; 1: a check failed; 2: py-opw-kinematics is not installed or a
robot is not an OPW arm.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys

import numpy as np
import yaml
from numpy.typing import NDArray

import dhkin
from dhkin.opw import opw_parameters
from dhkin.opw_yaml import opw_yaml
from dhkin.transforms import invert, pose_error

FK_TOLERANCE = 1e-12
IK_TOLERANCE = 1e-9
SAME_Q = 1e-6
NEAR_WRIST_SINGULARITY = 1e-3


def opw_builtins() -> list[str]:
    names = []
    for name in dhkin.builtin_names():
        try:
            opw_parameters(dhkin.load(name).table)
        except dhkin.FamilyError:
            continue
        names.append(name)
    return names


def peer_model(text: str) -> tuple[object, NDArray[np.float64], NDArray[np.float64]]:
    """py-opw-kinematics' robot (radians) from the exported YAML text, and the fixed frames
    base_link -> OPW base and OPW flange -> tool0 the YAML states (identity when it states none)."""
    from py_opw_kinematics._internal import KinematicModel, Robot

    data = yaml.safe_load(text)
    geometric = data["opw_kinematics_geometric_parameters"]
    model = KinematicModel(
        **{key: float(geometric[key]) for key in ("a1", "a2", "b", "c1", "c2", "c3", "c4")},
        offsets=tuple(float(v) for v in data["opw_kinematics_joint_offsets"]),
        flip_axes=tuple(int(s) < 0 for s in data["opw_kinematics_joint_sign_corrections"]))
    frames = data.get("dhkin_fixed_frames", {})
    return (Robot(model, False), _frame(frames.get("base_link_to_opw_base")),
            _frame(frames.get("opw_flange_to_tool0")))


def _frame(origin: dict | None) -> NDArray[np.float64]:
    from dhkin.transforms import xyz_rpy_to_matrix

    return np.eye(4) if origin is None else xyz_rpy_to_matrix(origin["xyz"], origin["rpy"])


def check(name: str, n: int, seed: int) -> list[str]:
    """The failed checks of one robot, in words (empty: all passed)."""
    robot = dhkin.load(name)
    peer, base, tool = peer_model(opw_yaml(opw_parameters(robot.table)))
    rng = np.random.default_rng(seed)
    random_q = robot.table.random_q(n, rng)
    special = np.array(list(itertools.product((0.0, math.pi / 2, -math.pi / 2, math.pi),
                                              repeat=6)))
    q = np.vstack([random_q, special])
    reference = robot.reference()
    oracle = reference.fk(q)
    forward = np.asarray(peer.batch_forward(np.ascontiguousarray(q))).reshape(-1, 4, 4)
    failures = []
    fk_error = float(np.abs(base @ forward @ tool - oracle).max())
    print(f"{robot.name}: FK of py-opw-kinematics with the exported YAML against Pinocchio, "
          f"{len(q)} joint vectors: largest difference {fk_error:.2e}")
    if not fk_error <= FK_TOLERANCE:
        failures.append(f"FK differs by {fk_error:.3g} > {FK_TOLERANCE:g}")

    to_opw, from_tool = invert(base), invert(tool)
    worst, missing, count = 0.0, 0, 0
    for row, pose in zip(random_q, oracle[:n], strict=True):
        solutions = np.array(peer.inverse(np.ascontiguousarray(to_opw @ pose @ from_tool)))
        count += len(solutions)
        if len(solutions):
            position, rotation = pose_error(reference.fk(solutions), pose[None])
            worst = max(worst, float(position.max()), float(rotation.max()))
        wrapped = np.remainder(solutions - row + math.pi, 2 * math.pi) - math.pi
        found = len(solutions) and np.abs(wrapped).max(axis=1).min() <= SAME_Q
        if not found and abs(math.sin(row[4])) > NEAR_WRIST_SINGULARITY:
            missing += 1
    print(f"{robot.name}: IK of py-opw-kinematics, {n} poses, {count / n:.1f} solutions per "
          f"pose: largest residual through Pinocchio {worst:.2e}; poses whose own q is "
          f"missing: {missing}")
    if not worst <= IK_TOLERANCE:
        failures.append(f"an IK solution misses its pose by {worst:.3g} > {IK_TOLERANCE:g}")
    if missing:
        failures.append(f"{missing} poses without the q they came from among the solutions")
    return failures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robots", nargs="*", help="robots (default: the OPW built-ins)")
    parser.add_argument("-n", type=int, default=1000, help="random joint vectors per robot")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    try:
        import py_opw_kinematics  # noqa: F401
    except ImportError:
        print("py-opw-kinematics is not installed (pip install py-opw-kinematics): nothing "
              "checked", file=sys.stderr)
        return 2
    failed = False
    for name in args.robots or opw_builtins():
        try:
            failures = check(name, args.n, args.seed)
        except dhkin.DhkinError as exc:
            print(f"{name}: {exc}", file=sys.stderr)
            return 2
        for failure in failures:
            print(f"{name}: FAILED: {failure}")
        failed = failed or bool(failures)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
