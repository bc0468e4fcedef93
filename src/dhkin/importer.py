"""Import a URDF or xacro description as a DH table (``dhkin import``).

The table keeps the description's zero pose, joint names, child link names, limits, velocities
and efforts, and its FK (base_link -> tool0) equals the description's ``base -> tip`` for every
q. How the rows are found, in either convention (DESIGN.md, "The DH table file"):

1. **Axes.** Pinocchio reads the chain at q = 0 (:func:`dhkin.fit.read_chain`, fixed joints
   folded in): each joint's axis as a line (point, unit direction u_i) in the base frame. The
   table's z_i = direction_i * u_i, with direction_i = +1 except where the axis runs opposite
   to the previous one (or, for joint 1, points down the base's z): there -1, so that parallel
   axes share one z and q keeps the URDF's positive sense either way.
2. **Common normals.** Between consecutive axes k, k + 1: the common normal (skew or
   intersecting axes), or, for parallel axes, the normal from the previous normal's foot (so
   d_k = 0). Its x direction is the sign of the normal nearest the previous x (offsets only
   where needed; a ties towards a >= 0). Before axis 1: the foot nearest the base origin, x
   along the base's x (so base is the identity when axis 1 is the base's z through its
   origin). After axis n: the foot nearest the tip's origin, x as before (offset_n = 0).
3. **Rows.** theta (offset) and d of joint i are the angle and distance about and along axis i
   from the normal before it to the normal after it; a and alpha are the length and twist of
   the normal after axis i (standard) or before it (modified). base = base -> DH frame 0,
   tool = DH frame n -> tip; both frames are the same in the two conventions.
4. **Parallel within the band.** Axes whose angle is within :data:`dhkin.ik.family.BAND`
   (0.02 rad) of parallel but not parallel to :data:`PARALLEL_NOISE` have no usable exact DH
   row (the common normal runs off by their offset / the angle: metres or kilometres). Such a
   table is written as the nominal table (those axes parallel; the closed-form family's ideal
   model when one fits within the band) plus per-joint ``correction`` transforms fitted by
   :func:`dhkin.fit.fit_corrections`: corrections appear only where no exact DH exists.
5. **Datasheet numbers.** Every DH value, base and tool component is written as the shortest
   decimal (in the table's units) within :data:`CLEAN` of the exact value (lengths in metres;
   angles in radians divided by the chain's reach in metres, at least 1, so that a rounded
   angle moves no point of a 300 m chain more than a short arm's); limits, velocities
   and efforts are copied as they are. The written table, read back, is checked against the
   description on :data:`VERIFY_SAMPLES` random joint vectors: at most DEFAULT_TOLERANCE.

Steps 1-3 are :mod:`dhkin.axes_to_dh`; :data:`CLEAN` (a thousandth of the tolerance) is both
the rounding of step 5 and the parallel test of step 4.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dhkin.axes_to_dh import CLEAN, AxisRows, rows_from_axes
from dhkin.description import (
    CONTINUOUS_LIMIT,
    UNSUPPORTED_TYPES,
    Description,
    DescriptionJoint,
    read_description,
)
from dhkin.dh import DHTable, Joint
from dhkin.errors import DHError, FamilyError, InputError, URDFError
from dhkin.fit import URDFChain, chain_deviation, fit_to_chain, read_chain
from dhkin.ik.family import BAND
from dhkin.import_names import IMPORTED_TABLE, described_error, table_link_names
from dhkin.table_file import (
    ANGLE_UNITS,
    LENGTH_UNITS,
    UNITS_RULE,
    exact_rpy,
    read_back,
    table_to_yaml,
    units_problem,
)
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import invert, rot_y, xyz_rpy_to_matrix
from dhkin.xml_text import ROBOT_NAME_RULE, name_problem

#: Random joint vectors (plus q = 0) on which the written table is checked (fixed seed 0).
VERIFY_SAMPLES = 1000
#: tool0 -> flange when the description has no ``flange`` link: ROS-Industrial's flange has its x
#: axis along tool0's z.
TOOL0_TO_FLANGE = rot_y(-math.pi / 2)

CONVENTIONS = ("standard", "modified")
#: The tip among several leaf links when none is given (ROS-Industrial's tool frame).
DEFAULT_TIP = "tool0"
#: ROS-Industrial's base frame (a fixed frame below base_link): a leaf that is never the tip.
ROS_INDUSTRIAL_BASE = "base"


@dataclass(frozen=True)
class ImportResult:
    """An imported table and what was found on the way.

    ``deviation``: largest (position m, rotation rad) difference between the written table and
    the description over ``samples`` joint vectors. ``family``: the closed-form family that fits
    (None: none; ``family_reason`` says why). ``ignored``: joints of the description the table
    does not hold (off the chain, mimic joints). ``notes``: what the import decided, also
    written into the table's ``source``.
    """

    table: DHTable
    units: Mapping[str, str]
    deviation: tuple[float, float]
    samples: int
    family: str | None
    family_reason: str
    refined: bool
    ignored: tuple[str, ...]
    notes: tuple[str, ...]

    def yaml(self) -> str:
        """The table file's text (in ``units``), headed by the import summary."""
        return table_to_yaml(self.table, self.units, header=self.summary())

    def summary(self) -> str:
        family = (f"{self.family}" + (" (refined on the exact chain)" if self.refined else "")
                  if self.family else f"none ({self.family_reason})")
        lines = [f"{self.table.name}: {self.table.dof} joints, {self.table.convention} DH"
                 + (", with corrections" if self.table.corrected else ""),
                 f"closed-form family: {family}",
                 f"FK deviation from the description over {self.samples} joint vectors: "
                 f"{self.deviation[0]:.3e} m, {self.deviation[1]:.3e} rad "
                 f"(tolerance {DEFAULT_TOLERANCE:.0e})"]
        if self.ignored:
            lines.append("ignored: " + "; ".join(self.ignored))
        return "\n".join(lines)


def import_description(path: str | Path, base: str | None = None, tip: str | None = None,
                       convention: str = "standard", units: Mapping[str, str] | None = None,
                       xacro_args: Mapping[str, str] | None = None, name: str | None = None,
                       packages: Mapping[str, str | Path] | None = None,
                       environ: Mapping[str, str] | None = None) -> ImportResult:
    """Import the chain ``base`` -> ``tip`` of a URDF or xacro file as a DH table.

    ``base`` defaults to the root link, ``tip`` to the single leaf (ROS-Industrial's ``base``
    frame not counted), or to ``tool0`` among several leaves (the ROS-Industrial tip;
    URDFError listing the leaves otherwise). ``units``:
    the table file's {"length": "m"|"mm", "angle": "deg"|"rad"} (default m and deg).
    ``xacro_args``, ``packages`` ({NAME: folder} for ``$(find NAME)``) and ``environ``: see
    :func:`dhkin.description.read_description`. Raises URDFError naming the file (and the joint
    and its line) for a description that cannot be read, has a floating, planar or mimic joint
    on the chain, or a value a table cannot hold, and DHError when the written table would
    deviate from the description by more than DEFAULT_TOLERANCE (a bug: the construction is
    exact).
    """
    if convention not in CONVENTIONS:
        raise InputError(f"convention: expected one of {list(CONVENTIONS)}, got {convention!r}",
                         field="convention", value=convention, expected=f"one of {CONVENTIONS}")
    units = _check_units(units)
    description = read_description(path, xacro_args, packages, environ)
    base = description.root if base is None else base
    tip = _default_tip(description) if tip is None else tip
    joints, ignored = _chain_joints(description, base, tip)
    chain = read_chain(description.text, base, tip, source=description.source)
    if list(chain.joint_names) != [joint.name for joint in joints]:  # Pinocchio and the outline
        raise URDFError(f"{description.source}: Pinocchio reads the chain {base} -> {tip} as "
                        f"{list(chain.joint_names)}, the XML as {[j.name for j in joints]}; "
                        "expected the same joints")
    links, notes = table_link_names(description.source, joints, tip)
    continuous = [joint.name for joint in joints if joint.type == "continuous"]
    if continuous:
        notes.append(f"continuous joints {continuous} limited to +-360 deg")
    points, axes = chain.axis_lines()
    rows = rows_from_axes(points, axes, chain.revolute, chain.tip, convention, BAND.angle)
    table = _table(description, chain, joints, links, rows, convention, name, base, tip)
    if rows.near_parallel:
        pairs = ", ".join(f"{k + 1}-{k + 2}" for k in rows.near_parallel)
        notes.append(f"axes {pairs} are within the band of parallel but not parallel: nominal "
                     "DH rows with fitted corrections")
        table = _corrected(table, chain)
    table = _clean(table, units, _reach(chain))
    table = replace(table, source=_source(description, base, tip, notes))
    try:
        written = read_back(table_to_yaml(table, units), source=IMPORTED_TABLE)
    except DHError as exc:  # lower >= upper, a velocity < 0: named as the description has it
        raise described_error(exc, description.source, joints) from exc
    deviation = chain_deviation(written, chain, VERIFY_SAMPLES)
    if max(deviation) > DEFAULT_TOLERANCE:
        raise DHError(f"{description.source}: the imported table deviates from the description "
                      f"by {deviation[0]:.3e} m / {deviation[1]:.3e} rad over {VERIFY_SAMPLES} "
                      f"joint vectors; expected at most {DEFAULT_TOLERANCE:.0e}",
                      field="table", value=max(deviation),
                      expected=f"at most {DEFAULT_TOLERANCE:.0e}")
    family, reason, refined = _family(written)
    return ImportResult(table=written, units=units, deviation=deviation,
                        samples=VERIFY_SAMPLES + 1, family=family, family_reason=reason,
                        refined=refined, ignored=tuple(ignored), notes=tuple(notes))


# --------------------------------------------------------------------------------------------
# The chain


def _check_units(units: Mapping[str, str] | None) -> dict[str, str]:
    chosen = {"length": "m", "angle": "deg"} if units is None else dict(units)
    problem = units_problem(chosen)
    if problem is not None:
        raise InputError(f"units: {problem}", field="units", value=chosen,
                         expected=UNITS_RULE)
    return chosen


def _default_tip(description: Description) -> str:
    """The single leaf link (ROS-Industrial's ``base`` frame, a leaf below base_link, not
    counted), else tool0 when it is a leaf (ROS-Industrial's tip)."""
    leaves = description.leaves()
    candidates = [leaf for leaf in leaves if leaf != ROS_INDUSTRIAL_BASE] or leaves
    if len(candidates) == 1:
        return candidates[0]
    if DEFAULT_TIP in candidates:
        return DEFAULT_TIP
    raise URDFError(f"{description.source}: several leaf links {leaves} and none is "
                    f"{DEFAULT_TIP}; expected --tip naming one of them", field="tip", value=None,
                    expected=f"one of {leaves}")


def _chain_joints(description: Description, base: str, tip: str
                  ) -> tuple[list[DescriptionJoint], list[str]]:
    """The actuated joints on the path base -> tip, and the description's joints left out
    (with why). URDFError for a floating, planar or mimic joint on the path."""
    path = description.path(base, tip)
    for joint in path:
        if joint.type in UNSUPPORTED_TYPES:
            raise URDFError(f"{description.source}: joint {joint.name!r} on the chain {base} -> "
                            f"{tip} is {joint.type}; expected revolute, continuous, prismatic "
                            "or fixed joints", field="joint", value=joint.name,
                            expected="revolute, continuous, prismatic or fixed")
        if joint.mimic is not None:
            raise URDFError(f"{description.source}: joint {joint.name!r} on the chain {base} -> "
                            f"{tip} mimics {joint.mimic!r}; a DH row needs its own joint value: "
                            "expected no mimic joint on the chain", field="joint",
                            value=joint.name, expected="no mimic joint on the chain")
    actuated = [joint for joint in path if joint.actuated]
    if not actuated:
        raise URDFError(f"{description.source}: the chain {base} -> {tip} has no moving joint; "
                        "expected at least one revolute, continuous or prismatic joint")
    on_path = {joint.name for joint in path}
    ignored = []
    for joint in description.joints:
        if joint.name in on_path:
            continue
        if joint.mimic is not None:
            ignored.append(f"{joint.name} (mimics {joint.mimic})")
        elif joint.actuated:
            ignored.append(f"{joint.name} ({joint.type}, off the chain)")
    return actuated, ignored


# --------------------------------------------------------------------------------------------
# The table


def _table(description: Description, chain: URDFChain, joints: list[DescriptionJoint],
           links: list[str], rows: AxisRows, convention: str, name: str | None, base: str,
           tip: str) -> DHTable:
    table_joints = []
    for i, joint in enumerate(joints):
        revolute = chain.revolute[i]
        lower, upper = joint.lower, joint.upper
        if joint.type == "continuous" or lower is None or upper is None:
            if joint.type != "continuous":
                raise URDFError(f"{description.source}: {joint.label} ({joint.type}) has no "
                                "lower/upper limit; expected both", field="joint",
                                value=joint.name, expected="<limit lower=... upper=...>")
            lower, upper = -CONTINUOUS_LIMIT, CONTINUOUS_LIMIT
        table_joints.append(Joint(
            name=joint.name, link=links[i], type="revolute" if revolute else "prismatic",
            a=rows.a[i], alpha=rows.alpha[i], d=rows.fixed[i] if revolute else 0.0,
            theta=0.0 if revolute else rows.fixed[i], offset=rows.offset[i],
            direction=rows.direction[i], lower=float(lower), upper=float(upper),
            velocity=joint.velocity, effort=joint.effort))
    tool = invert(rows.frame_n) @ chain.tip
    flange = _flange(description, base, tip, rows.frame_n, tool)
    table_name = name if name is not None else Path(description.source).name.split(".")[0]
    problem = name_problem(table_name, macro=True)
    if problem is not None:
        origin = "--name" if name is not None else f"the file name {description.source}"
        raise InputError(f"name (from {origin}): {problem}; give a name with --name",
                         field="name", value=table_name, expected=ROBOT_NAME_RULE)
    try:
        return DHTable(name=table_name, convention=convention,  # type: ignore[arg-type]
                       joints=tuple(table_joints), base=rows.frame_0, tool=tool, flange=flange,
                       description=f"{description.robot_name}, imported from "
                                   f"{Path(description.source).name} ({base} -> {tip})")
    except DHError as exc:  # a value a table cannot hold: named as the description has it
        raise described_error(exc, description.source, joints) from exc


def _flange(description: Description, base: str, tip: str, frame_n: NDArray[np.float64],
            tool: NDArray[np.float64]) -> NDArray[np.float64]:
    """DH frame n -> flange: the description's ``flange`` link where it hangs rigidly below
    the last joint, else tool0 -> flange as ROS-Industrial (:data:`TOOL0_TO_FLANGE`)."""
    if "flange" in description.links and tip != "flange":
        try:
            flange_path = description.path(base, "flange")
        except URDFError:
            flange_path = []
        tip_path = description.path(base, tip)
        moving = [j.name for j in tip_path if j.actuated]
        if flange_path and [j.name for j in flange_path if j.actuated] == moving:
            from dhkin.reference import Reference

            pose = Reference(description.text, tip="flange", base=base,
                             source=description.source).fk(np.zeros(len(moving)))
            return invert(frame_n) @ pose
    return tool @ TOOL0_TO_FLANGE


def _corrected(table: DHTable, chain: URDFChain) -> DHTable:
    """The nominal table (the family's ideal model when one fits within the band) with
    corrections fitted to the chain."""
    from dhkin.ik.family import fit_family, ideal_model

    first = fit_to_chain(table, chain)
    try:
        fit_family(first)
    except FamilyError:
        return first
    return fit_to_chain(ideal_model(first), chain)


def _clean(table: DHTable, units: Mapping[str, str], reach: float) -> DHTable:
    """Every DH value, correction, base, tool and flange component as the shortest decimal in
    ``units`` within CLEAN of it: CLEAN metres for a length, CLEAN / ``reach`` radians for an
    angle (``reach``: the chain's extent in metres, at least 1), so that no rounding moves a
    point of the arm by more than CLEAN (a 300 m chain's angles rounded to 1e-12 rad would move
    its tip by 3e-10 m each). Limits, velocities and efforts are untouched."""
    length, angle = units["length"], units["angle"]

    def clean(value: float, unit: str) -> float:
        return _shortest(value, unit, CLEAN / reach if unit in ANGLE_UNITS else CLEAN)

    def clean_joint(joint: Joint) -> Joint:
        variable = angle if joint.is_revolute else length
        correction = tuple(clean(v, length if k < 3 else angle)
                           for k, v in enumerate(joint.correction))
        return replace(joint, a=clean(joint.a, length), alpha=clean(joint.alpha, angle),
                       d=clean(joint.d, length), theta=clean(joint.theta, angle),
                       offset=clean(joint.offset, variable),
                       correction=correction)  # type: ignore[arg-type]

    def clean_frame(T: NDArray[np.float64]) -> NDArray[np.float64]:
        xyz = [clean(float(v), length) for v in T[:3, 3]]
        rpy = [clean(v, angle) for v in exact_rpy(T)]
        return xyz_rpy_to_matrix(xyz, rpy)

    return replace(table, joints=tuple(clean_joint(j) for j in table.joints),
                   base=clean_frame(table.base), tool=clean_frame(table.tool),
                   flange=clean_frame(table.flange))


def _reach(chain: URDFChain) -> float:
    """The chain's extent (m, at least 1): the farthest joint axis point or tip from the base."""
    points = np.vstack([chain.frames[:, :3, 3], chain.tip[None, :3, 3]])
    return max(1.0, float(np.linalg.norm(points, axis=1).max()))


def _shortest(value: float, unit: str, limit: float) -> float:
    """The SI value of the shortest decimal in ``unit`` (m, mm, rad or deg) within ``limit``
    (SI) of ``value`` (SI), converted as :func:`dhkin.load_table` converts it."""
    scale = LENGTH_UNITS[unit] if unit in LENGTH_UNITS else ANGLE_UNITS[unit]
    in_unit = value / scale
    for digits in range(18):
        back = round(in_unit, digits) * scale
        if abs(back - value) <= limit:
            return float(back)
    return value


def _source(description: Description, base: str, tip: str, notes: list[str]) -> str:
    text = (f"Imported with `dhkin import` from {description.source} ({base} -> {tip}): the "
            "description's zero pose, joint and link names, limits, velocities and efforts")
    return text + "".join(f"; {note}" for note in notes) + "."


def _family(table: DHTable) -> tuple[str | None, str, bool]:
    from dhkin.ik.family import fit_family

    if table.dof != 6:
        return None, f"{table.dof} joints; the closed-form families have 6", False
    try:
        fit = fit_family(table)
    except FamilyError as exc:
        problems = exc.value if isinstance(exc.value, dict) else {}
        reason = "; ".join(f"{family}: {found[0]}" for family, found in problems.items()
                           if found) or str(exc)
        return None, reason, False
    return fit.family, "", fit.refine
