#!/usr/bin/env python
"""Do two builds of dhkin give the same IK answers? Run once per build, then compare.

    python scripts/compare_builds.py poses poses.npz [ROBOT ...]   # once, with either build
    /path/to/A/python scripts/compare_builds.py solve poses.npz a.npz   # from A's checkout
    /path/to/B/python scripts/compare_builds.py solve poses.npz b.npz   # from B's checkout
    python scripts/compare_builds.py compare a.npz b.npz

Poses: 10^4 per robot (default: ur5, abb_irb1200_7_70, stanford_arm, ur5e_calibrated) drawn
within the limits (seed 25; 500 with q5 = 0, 200 with q3 = 0),
tool0 poses by Pinocchio FK, and a random seed per pose. Solved: ``ik_batch_detailed`` with
copies False and True, unseeded and seeded, workers=1, and ``ik`` on the first 300 poses.
The comparison prints, per robot, whether every array is bit-identical, else whether the
solution sets (valid, branch, flags, dropped, projection) are, and the largest joint difference.
"""

from __future__ import annotations

import sys

import numpy as np

ROBOTS = ("ur5", "abb_irb1200_7_70", "stanford_arm", "ur5e_calibrated")
FIELDS = ("q", "valid", "flags", "branch", "residuals", "projection", "dropped")
SETS = ("valid", "branch", "flags", "dropped", "projection")


def robots_in(data: np.lib.npyio.NpzFile) -> list[str]:
    """The robots of a poses file (keys NAME_T) or of a solutions file (keys NAME/...)."""
    names = [k[:-2] for k in data.files if k.endswith("_T")]
    if not names:
        names = list(dict.fromkeys(k.split("/")[0] for k in data.files))
    return names


def make_poses(path: str, *robots: str) -> None:
    import dhkin

    data = {}
    for name in robots or ROBOTS:
        robot = dhkin.load(name)
        rng = np.random.default_rng(25)
        q = rng.uniform(robot.lower, robot.upper, size=(10_000, len(robot.lower)))
        q[:500, 4] = 0.0
        q[500:700, 2] = 0.0
        data[f"{name}_T"] = robot.reference().fk(q)
        data[f"{name}_seed"] = rng.uniform(robot.lower, robot.upper, size=q.shape)
    np.savez(path, **data)


def solve(poses_path: str, out_path: str) -> None:
    import dhkin

    poses = np.load(poses_path)
    out = {}
    for name in robots_in(poses):
        robot = dhkin.load(name)
        T, seeds = poses[f"{name}_T"], poses[f"{name}_seed"]
        for copies in (False, True):
            for tag, seed in (("s0", None), ("s1", seeds)):
                batch = robot.ik_batch_detailed(T, seed, copies=copies, workers=1)
                for field in FIELDS:
                    out[f"{name}/{int(copies)}{tag}/{field}"] = np.asarray(getattr(batch, field))
        for i in range(300):
            out[f"{name}/single{i}/q"] = np.asarray(robot.ik(T[i], seeds[i]).q)
    np.savez(out_path, **out)


def compare(a_path: str, b_path: str) -> None:
    a, b = np.load(a_path), np.load(b_path)
    for name in robots_in(a):
        keys = [k for k in a.files if k.startswith(name + "/")]
        same = all(a[k].shape == b[k].shape and np.array_equal(a[k], b[k], equal_nan=True)
                   for k in keys)
        sets = all(np.array_equal(a[k], b[k]) for k in keys if k.endswith(SETS))
        dq = max((float(np.max(np.abs(a[k] - b[k]))) for k in keys
                  if k.endswith("/q") and a[k].shape == b[k].shape and a[k].size), default=0.0)
        print(f"{name}: {'bit-identical' if same else 'differs'}; solution sets identical: "
              f"{sets}; largest joint difference {dq:.3g} rad")


if __name__ == "__main__":
    if len(sys.argv) < 2 or sys.argv[1] not in ("poses", "solve", "compare"):
        print(__doc__)
        sys.exit(0 if sys.argv[1:2] in (["-h"], ["--help"]) else 2)
    command, *paths = sys.argv[1:]
    {"poses": make_poses, "solve": solve, "compare": compare}[command](*paths)
