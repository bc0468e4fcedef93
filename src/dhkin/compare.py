"""Cross-check a DH table against another URDF (a vendor's): same joint values, same poses, same
joints?

Poses: both sides are evaluated with Pinocchio: ours on the URDF generated through xacro, theirs
on the given file. Joint vectors are sampled uniformly within the table's limits, plus the zero
vector, and fed to both in chain order (the actuated joints from the base frame to the tip), so
link and joint names may differ, continuous joints and fixed frames are fine.

Joints: in the same chain order, each joint's name, type, position limits and velocity limit as
the table states them are compared with the other URDF's as Pinocchio reads them
(:meth:`dhkin.reference.Reference.joint_properties`). Every difference is reported
(:class:`JointDifference`); none of them changes :attr:`CompareReport.ok`, which is the pose
verdict, while :attr:`CompareReport.strict_ok` also requires equal joints.

* A URDF continuous joint has no position limits: against a table's revolute joint this is a type
  difference (the note says whether the table's range covers every angle), not a limit one.
* A velocity of 0 or inf counts as "not stated" on either side (a table without ``velocity``
  writes 0 into its URDF); one side stating a velocity and the other not is a difference.
* Limits and velocities are equal within :data:`LIMIT_TOLERANCE`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dhkin.arm import Arm
from dhkin.description import read_urdf_file
from dhkin.dh import DHTable
from dhkin.errors import InputError, URDFError
from dhkin.ik.inputs import check_integer, check_tolerance
from dhkin.reference import JointProperties, Reference, stated_velocity
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import pose_error

# Pass threshold of `dhkin compare`: dhkin's one DEFAULT_TOLERANCE (m and rad). The UR vendor
# files round pi/2 to 1.570796327 and carry 2e-11 m residues, so they sit ~6e-10 from the exact
# DH: 1e-9 is also the tightest honest threshold for them.

#: Two limits (or velocities) are equal when they differ by at most this (rad or m; rad/s, m/s).
#: It allows for deg <-> rad rounding only. A table value v in deg becomes v * fl(pi/180): the
#: constant and the product are each rounded once, 2u relative with u = 2**-53; the generated
#: URDF writes repr() (exact), and parsing the other URDF's decimal text rounds once more (u).
#: So a table giving the other file's value in deg lands within ``3u |x| < 3.4e-16 |x|`` of
#: it: below 1e-12 for every ``|x| < 2900`` rad or m (real joints: ``|x| <= 4 pi``, velocities
#: < 30 rad/s).
#: Any rounding a person makes is far larger: 170 deg vs ABB's 2.967 rad is 6e-5, 3.1416 vs pi
#: is 7e-6, UR's 1.570796327 for pi/2 is 2e-10.
LIMIT_TOLERANCE = 1e-12

#: What each field of a joint means, for the report.
JOINT_FIELDS: tuple[str, ...] = ("name", "type", "lower", "upper", "velocity")


@dataclass(frozen=True)
class JointDifference:
    """One property of one chain joint that differs between the table and the other URDF.

    ``index`` is the joint's place in the chain (0 = nearest the base), ``joint`` the table's
    name for it, ``field`` one of :data:`JOINT_FIELDS`, ``ours``/``theirs`` the two values (SI;
    None: not stated, or no limits), ``note`` the difference in words.
    """

    index: int
    joint: str
    field: str
    ours: str | float | None
    theirs: str | float | None
    note: str

    def __str__(self) -> str:
        return f"joint {self.index + 1} ({self.joint}) {self.field}: {self.note}"


def table_joint_properties(table: DHTable) -> list[JointProperties]:
    """The table's joints as its generated URDF states them (SI, base to tip)."""
    return [JointProperties(j.name, j.type, j.lower, j.upper, stated_velocity(j.velocity))
            for j in table.joints]


def compare_joints(ours: list[JointProperties], theirs: list[JointProperties],
                   tolerance: float = LIMIT_TOLERANCE) -> tuple[JointDifference, ...]:
    """Every difference of name, type, limits and velocity between two chains of equal length
    (``ours``: the table's, ``theirs``: the other URDF's), joint by joint, base to tip."""
    if len(ours) != len(theirs):
        raise InputError(f"theirs: expected {len(ours)} joints like ours, got {len(theirs)}",
                         field="theirs", value=len(theirs), expected=f"{len(ours)} joints")
    return tuple(difference for index, (mine, other) in enumerate(zip(ours, theirs, strict=True))
                 for difference in _joint_differences(index, mine, other, tolerance))


def _joint_differences(index: int, mine: JointProperties, other: JointProperties,
                       tolerance: float) -> list[JointDifference]:
    """The differences of one joint (``mine``: the table's, ``other``: the other URDF's)."""
    found: list[JointDifference] = []
    unit = "m" if mine.type == "prismatic" else "rad"
    if mine.name != other.name:
        found.append(JointDifference(index, mine.name, "name", mine.name, other.name,
                                     f"{mine.name!r} vs {other.name!r}"))
    if mine.type != other.type:
        found.append(JointDifference(index, mine.name, "type", mine.type, other.type,
                                     _type_note(mine, other)))
    if other.lower is not None and other.upper is not None:
        for field, a, b in (("lower", mine.lower, other.lower),
                            ("upper", mine.upper, other.upper)):
            if a is not None and abs(a - b) > tolerance:
                note = (f"{_value(a, unit, mine.type)} vs {_value(b, unit, mine.type)} "
                        f"(differ by {abs(a - b):.3g} {unit})")
                found.append(JointDifference(index, mine.name, field, a, b, note))
    velocity_note = _velocity_note(mine.velocity, other.velocity, f"{unit}/s", tolerance)
    if velocity_note is not None:
        found.append(JointDifference(index, mine.name, "velocity", mine.velocity,
                                     other.velocity, velocity_note))
    return found


def _value(x: float, unit: str, kind: str) -> str:
    """A limit in SI with enough digits to show any difference above LIMIT_TOLERANCE (and in deg
    for angles)."""
    text = f"{x!r} {unit}"
    return text if kind == "prismatic" else text + f" ({np.degrees(x):.10g} deg)"


def _type_note(mine: JointProperties, other: JointProperties) -> str:
    note = f"{mine.type} vs {other.type}"
    if other.type == "continuous" and mine.type == "revolute" and mine.lower is not None \
            and mine.upper is not None:
        covers = mine.upper - mine.lower >= 2 * np.pi
        note += (f" (the other URDF's continuous joint has no limits; the table's "
                 f"{np.degrees(mine.lower):.10g}..{np.degrees(mine.upper):.10g} deg "
                 + ("covers every angle)" if covers else "does not cover every angle)"))
    return note


def _velocity_note(mine: float | None, other: float | None, unit: str,
                   tolerance: float) -> str | None:
    """Why two velocity limits differ, or None if they do not."""
    if mine is None and other is None:
        return None
    if mine is None:
        return f"the table gives none (its URDF writes 0) vs {other!r} {unit}"
    if other is None:
        return f"{mine!r} {unit} vs none stated in the other URDF"
    if abs(mine - other) <= tolerance:
        return None
    return f"{mine!r} vs {other!r} {unit} (differ by {abs(mine - other):.3g} {unit})"


@dataclass(frozen=True)
class CompareReport:
    """Largest deviations between the table's URDF and the other URDF over ``samples`` q, and
    the differences of their joints (chain order; see the module docstring).

    ``ok`` is the pose verdict (deviations within ``tolerance``); ``strict_ok`` also requires no
    joint difference; ``limit_differences`` are the differences of lower, upper and velocity
    limits (what `dhkin check` fails on).
    """

    robot: str
    other: str
    base_frame: str
    tip: str
    robot_tip: str
    samples: int
    max_position: float
    max_rotation: float
    worst_q: NDArray[np.float64]
    tolerance: float
    joints: tuple[JointProperties, ...] = ()
    other_joints: tuple[JointProperties, ...] = ()
    joint_differences: tuple[JointDifference, ...] = ()
    limit_tolerance: float = LIMIT_TOLERANCE

    @property
    def ok(self) -> bool:
        """The poses agree within ``tolerance`` (joint differences do not count here)."""
        return self.max_position <= self.tolerance and self.max_rotation <= self.tolerance

    @property
    def joints_ok(self) -> bool:
        """Names, types, limits and velocities of the chain joints all agree."""
        return not self.joint_differences

    @property
    def strict_ok(self) -> bool:
        """The poses agree and so do the joints."""
        return self.ok and self.joints_ok

    @property
    def limit_differences(self) -> tuple[JointDifference, ...]:
        """The differences of position limits and velocity limits."""
        return tuple(d for d in self.joint_differences
                     if d.field in ("lower", "upper", "velocity"))

    def summary(self) -> str:
        """First line: the pose verdict; then the joint comparison, one line per difference."""
        verdict = "OK" if self.ok else "FAIL"
        lines = [f"{verdict}: {self.robot} ({self.robot_tip}) vs {self.other} "
                 f"({self.base_frame} -> {self.tip}) over {self.samples} joint vectors: "
                 f"max position {self.max_position:.3e} m, max rotation "
                 f"{self.max_rotation:.3e} rad (tolerance {self.tolerance:.0e})"]
        count = len(self.joints)
        if self.joints_ok:
            lines.append(f"joints: the {count} chain joints have equal names, types, limits and "
                         f"velocities (limits within {self.limit_tolerance:.0e})")
        else:
            lines.append(f"joints: {len(self.joint_differences)} difference(s) in the {count} "
                         f"chain joints (table vs other URDF; limits compared within "
                         f"{self.limit_tolerance:.0e}):")
            lines += [f"  {difference}" for difference in self.joint_differences]
        return "\n".join(lines)


def _refuse_mimic_joints(other: Reference, base_frame: str, tip: str) -> None:
    """URDFError when a joint on the compared chain mimics another: Pinocchio reads a mimic
    joint as an independent one (or drops it), so the poses compared would not be the other
    description's."""
    for joint in other.outline.joints_above(tip, base_frame):
        if joint.mimic is not None and joint.type != "fixed":
            raise URDFError(f"{other.source}: joint {joint.name!r} (line {joint.line}) on the "
                            f"chain {base_frame} -> {tip} mimics {joint.mimic!r}; a compared "
                            "joint needs its own value: expected no mimic joint on the chain",
                            field="joint", value=joint.name,
                            expected="no mimic joint on the chain")


def compare_with_urdf(robot: Arm, urdf_path: str | Path, base_frame: str = "base_link",
                      tip: str = "tool0", robot_tip: str = "tool0", n: int = 1000, seed: int = 0,
                      tolerance: float = DEFAULT_TOLERANCE,
                      limit_tolerance: float = LIMIT_TOLERANCE,
                      packages: Mapping[str, str | Path] | None = None) -> CompareReport:
    """Compare ``robot`` (base_link -> robot_tip) with ``urdf_path`` (base_frame -> tip): poses
    over ``n`` joint vectors (``tolerance``, m and rad) and the chain joints' names, types,
    limits and velocities (``limit_tolerance``). A xacro file is expanded (``packages``:
    {NAME: folder} for its ``$(find NAME)``, see :mod:`dhkin.ros_packages`)."""
    n = check_integer(n, "n", 1)
    seed = check_integer(seed, "seed", 0)
    tolerance = check_tolerance(tolerance)
    if isinstance(limit_tolerance, bool) or not isinstance(limit_tolerance, (int, float)) \
            or not 0 <= limit_tolerance < float("inf"):
        raise InputError(f"limit_tolerance: expected a number >= 0 (finite), got "
                         f"{limit_tolerance!r}", field="limit_tolerance", value=limit_tolerance,
                         expected="a finite number >= 0")
    path = Path(urdf_path)
    other = Reference(read_urdf_file(path, packages), tip=tip, base=base_frame, source=str(path))
    _refuse_mimic_joints(other, base_frame, tip)
    ours = robot.reference(tip=robot_tip)
    if other.dof != robot.dof:
        raise URDFError(f"{path}: the chain {base_frame} -> {tip} has {other.dof} actuated joints "
                        f"{other.joint_names}; expected {robot.dof} like {robot.name}")
    joints = table_joint_properties(robot.table)
    other_joints = other.joint_properties()
    rng = np.random.default_rng(seed)
    q = np.vstack([np.zeros(robot.dof), robot.table.random_q(n - 1, rng)])
    q = np.clip(q, robot.lower, robot.upper)
    position, rotation = pose_error(ours.fk(q), other.fk(q))
    worst = int(np.argmax(np.maximum(position, rotation)))
    return CompareReport(robot=robot.name, other=str(path), base_frame=base_frame, tip=tip,
                         robot_tip=robot_tip, samples=n, max_position=float(position.max()),
                         max_rotation=float(rotation.max()), worst_q=q[worst], tolerance=tolerance,
                         joints=tuple(joints), other_joints=tuple(other_joints),
                         joint_differences=compare_joints(joints, other_joints, limit_tolerance),
                         limit_tolerance=limit_tolerance)
