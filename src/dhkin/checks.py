"""The main job, `dhkin check`: for each built-in robot, regenerate, validate and cross-check.

Per robot, in order: the committed xacro/URDF equal regeneration; the URDF passes check_urdf,
Pinocchio and yourdfpy; own FK equals Pinocchio FK; the vendor URDF agrees where one exists
("vendor": poses within 1e-9, and position and velocity limits equal within
dhkin.compare.LIMIT_TOLERANCE, since the built-in tables take them from the vendor files; joint
name and type differences, such as a vendor's continuous joint where the table has +-360 deg, are
listed in the cell without failing it); the IK is cross-validated (dhkin.validation) twice:

* "ik vs pin": targets made and solutions checked by Pinocchio on the exact generated URDF
  (``reference="exact"``): closed-form IK (a family, or the general 6R solver for six-revolute
  arms without one: CRX-10iA, xArm6) on ``ik_poses`` uniform poses plus the special-angle and
  near-singular sets, with zero wrong, missing, missing-branch and discontinuous samples
  required; the numerical IK (robots without a closed form, one solution per call) on
  NUMERICAL_POSES poses, with zero wrong and zero unsolved required. The exact URDF, not the
  default "rounded" reference: rounding to 10 significant digits moves the UR and AUBO models by
  ~1.1e-9 rad, more than the 1e-9 tolerance, so an IK exact on the table would be "wrong" there;
* "ik vs vendor" (robots listed in dhkin.vendors.VENDOR_REFERENCES): the same checks with the
  targets made and the solutions checked on the vendor URDF (its base and tip frames from
  VENDOR_REFERENCES), so a bug shared by the table's own model and the IK cannot hide. It runs on
  ``vendor_poses`` uniform poses (default VENDOR_POSES = 2000, fewer than the main run to keep
  the job's time reasonable; the numerical IK on at most NUMERICAL_POSES, as in "ik vs pin")
  plus the special-angle and near-singular sets (n/10 each).
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dhkin.compare import compare_with_urdf
from dhkin.errors import DhkinError
from dhkin.robot import Robot, builtin_dir, load
from dhkin.validators import load_in_pinocchio, load_in_yourdfpy, run_check_urdf
from dhkin.vendors import VENDOR_REFERENCES

if TYPE_CHECKING:
    from dhkin.validation import ValidationReport

FK_SAMPLES = 1000
FK_TOLERANCE = 1e-12
NUMERICAL_POSES = 1000
#: Uniform poses of the vendor-URDF validation (plus n/10 special-angle and n/10 near-singular).
VENDOR_POSES = 2000


@dataclass(frozen=True)
class CheckCell:
    """One check of one robot: whether it passed, a short text with its figures, the seconds it
    took (set by :func:`check_robot`) and, for the IK validations, the figures as data
    (:func:`validation_figures`)."""

    ok: bool
    text: str
    seconds: float = 0.0
    figures: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class RobotCheck:
    """Every check of one robot (None: the check does not apply), its IK family and time."""

    name: str
    family: str
    cells: dict[str, CheckCell | None]
    seconds: float

    @property
    def ok(self) -> bool:
        return all(c.ok for c in self.cells.values() if c is not None)


@dataclass(frozen=True)
class CheckOptions:
    """The options of a run; ``progress``: a bar per validation on a terminal's stderr (off
    where several robots are checked at once)."""

    reference_dir: Path | None
    ik_poses: int = 10_000
    vendor_poses: int = VENDOR_POSES
    seed: int = 0
    progress: bool = True


def check_generated(robot: Robot) -> CheckCell:
    """The committed artefacts in the built-in folder equal what generation gives now (the
    robot's generation, made once: its URDF is the one the other checks read)."""
    folder = builtin_dir()
    stale = [name for name, text in robot.generated().as_dict().items()
             if not (folder / name).is_file()
             or (folder / name).read_text(encoding="utf-8") != text]
    return CheckCell(not stale, "up to date" if not stale else "stale: " + ", ".join(stale))


def check_validators(robot: Robot) -> CheckCell:
    """check_urdf, Pinocchio and yourdfpy all accept the generated URDF."""
    with tempfile.TemporaryDirectory(prefix="dhkin-check-") as tmp:
        path = Path(tmp) / f"{robot.name}.urdf"
        path.write_text(robot.urdf(), encoding="utf-8")
        verdicts = [run_check_urdf(path), load_in_pinocchio(robot.urdf()), load_in_yourdfpy(path)]
    failed = [f"{v.validator}: {v.detail}" for v in verdicts if not v.ok]
    return CheckCell(not failed, "3/3 pass" if not failed else "; ".join(failed))


def check_fk(robot: Robot, seed: int) -> CheckCell:
    """Own numpy FK equals Pinocchio FK on the generated URDF (max ``|T_own - T_pin|``)."""
    q = robot.table.random_q(FK_SAMPLES, np.random.default_rng(seed))
    deviation = float(np.abs(robot.fk(q) - robot.reference().fk(q)).max())
    return CheckCell(deviation <= FK_TOLERANCE, f"{deviation:.1e}")


def check_vendor(robot: Robot, reference_dir: Path | None) -> CheckCell | None:
    """Max pose deviation from the vendor URDF and its joint differences (failing on poses and
    on limits; see the module docstring), or None when the robot has no reference."""
    if robot.name not in VENDOR_REFERENCES:
        return None
    vendor = VENDOR_REFERENCES[robot.name]
    if reference_dir is None or not (reference_dir / vendor.file).is_file():
        return CheckCell(False, f"missing {vendor.file}")
    report = compare_with_urdf(robot, reference_dir / vendor.file, base_frame=vendor.base,
                               tip=vendor.tip, robot_tip=vendor.robot_tip)
    text = f"{max(report.max_position, report.max_rotation):.1e}"
    if report.joints_ok:
        text += ", joints equal"
    else:
        text += ", " + "; ".join(f"{d.joint} {d.field} {_short(d.ours)} vs {_short(d.theirs)}"
                                 for d in report.joint_differences)
    return CheckCell(report.ok and not report.limit_differences, text)


def _short(value: str | float | None) -> str:
    """A joint property for a table cell: text as is, numbers in full (repr: any difference
    above LIMIT_TOLERANCE shows), None as 'none'."""
    if value is None:
        return "none"
    return value if isinstance(value, str) else repr(value)


def validation_figures(report: ValidationReport) -> dict[str, Any]:
    """The figures of a validation as data: the report's JSON (counts, rates, residuals, by set
    and configuration, reference, seconds) without its failing samples, which ``dhkin validate``
    writes to a failure file; their number stays (``failure_count``). Adds the worst residual
    (m or rad, the larger) and the completeness (%: samples neither missing, missing a branch
    nor unsolved)."""
    data = report.to_json()
    data["failure_count"] = len(data.pop("failures"))
    data["worst_residual"] = max(report.residuals.get("position_max", 0.0),
                                 report.residuals.get("rotation_max", 0.0))
    counts = report.counts
    incomplete = counts["missing"] + counts["no_solution"] + counts["missing_branch"]
    data["completeness"] = 100 * (report.samples - incomplete) / report.samples
    return data


def _ik_text(figures: dict[str, Any]) -> str:
    """Samples, max residual, completeness and failure counts of a validation, for a cell."""
    counts = figures["counts"]
    text = (f"{figures['samples']} poses, max {figures['worst_residual']:.1e}, "
            f"complete {figures['completeness']:.2f}%, "
            f"wrong {counts['wrong']}, missing {counts['missing']}, "
            f"missing-branch {counts['missing_branch']}, "
            f"discontinuous {counts['discontinuous']}")
    if not figures["complete_expected"]:
        text += " (1 solution/call)"
    return text


def check_ik(robot: Robot, poses: int, seed: int, progress: bool = True) -> CheckCell:
    """Cross-validate the robot's own IK on the exact generated URDF (see the module docstring);
    ``progress``: a bar on stderr when it is a terminal."""
    from dhkin.validation import validate

    n = poses if robot.complete_ik else min(poses, NUMERICAL_POSES)
    report = validate(robot, n=n, seed=seed, progress=progress and sys.stderr.isatty(),
                      reference="exact")
    figures = validation_figures(report)
    return CheckCell(report.ok, f"{robot.ik_family}: {_ik_text(figures)}", figures=figures)


def check_ik_vendor(robot: Robot, reference_dir: Path | None, poses: int,
                    seed: int, progress: bool = True) -> CheckCell | None:
    """Cross-validate the robot's own IK with targets made and solutions checked on its vendor
    URDF (frames from VENDOR_REFERENCES), or None when the robot has no vendor reference."""
    from dhkin.validation import validate

    if robot.name not in VENDOR_REFERENCES:
        return None
    vendor = VENDOR_REFERENCES[robot.name]
    if reference_dir is None or not (reference_dir / vendor.file).is_file():
        return CheckCell(False, f"missing {vendor.file}")
    n = poses if robot.complete_ik else min(poses, NUMERICAL_POSES)
    report = validate(robot, n=n, seed=seed, progress=progress and sys.stderr.isatty(),
                      reference=reference_dir / vendor.file, base=vendor.base, tip=vendor.tip)
    figures = validation_figures(report)
    return CheckCell(report.ok, f"{vendor.file}: {_ik_text(figures)}", figures=figures)


COLUMNS: tuple[str, ...] = ("generated", "validators", "fk vs pin", "vendor", "ik vs pin",
                            "ik vs vendor")


#: The columns whose cells are IK validations (with figures; see :func:`validation_figures`).
IK_COLUMNS: tuple[str, ...] = ("ik vs pin", "ik vs vendor")


def longest_first(robots: list[Robot]) -> list[int]:
    """The indices of ``robots`` in the order a pool of workers should start their checks: the
    general 6R solver's, the numerical IK's and the refined closed-form tables' first (10-40 s
    each against 1-4 s for an exact family's; docs/check.md), so that the workers end together
    instead of one finishing a long check alone after the others ran out of robots."""
    def slow(robot: Robot) -> bool:
        try:
            family = robot.ik_family
            return family in ("general6r", "numerical") or robot.ik_solver.fit.refine
        except DhkinError:
            return False

    return sorted(range(len(robots)), key=lambda k: not slow(robots[k]))


def check_robot(robot: Robot, options: CheckOptions) -> RobotCheck:
    """Run every check on one robot, timing each; a check that raises a dhkin error is a failed
    cell."""
    runs: dict[str, Callable[[], CheckCell | None]] = {
        "generated": lambda: check_generated(robot),
        "validators": lambda: check_validators(robot),
        "fk vs pin": lambda: check_fk(robot, options.seed),
        "vendor": lambda: check_vendor(robot, options.reference_dir),
        "ik vs pin": lambda: check_ik(robot, options.ik_poses, options.seed, options.progress),
        "ik vs vendor": lambda: check_ik_vendor(robot, options.reference_dir,
                                                options.vendor_poses, options.seed,
                                                options.progress),
    }
    started = time.perf_counter()
    cells: dict[str, CheckCell | None] = {}
    for column, run in runs.items():
        begun = time.perf_counter()
        try:
            cell = run()
        except DhkinError as exc:
            cell = CheckCell(False, f"error: {exc}")
        cells[column] = None if cell is None else replace(cell,
                                                          seconds=time.perf_counter() - begun)
    try:
        family = robot.ik_family
    except DhkinError:
        family = "none"
    return RobotCheck(robot.name, family, cells, time.perf_counter() - started)


def check_named(name: str, options: CheckOptions) -> RobotCheck:
    """:func:`check_robot` of a built-in robot's name or a table file (what a worker process of
    `dhkin check --jobs N` runs)."""
    return check_robot(load(name), options)
