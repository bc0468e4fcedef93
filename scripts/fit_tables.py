"""Fit the built-in robots whose tables carry corrections: nominal table + vendor URDF -> table.

For each robot of FITTED, ``dhkin.fit_corrections`` fits base, per-joint corrections and tool of
its nominal DH table to the vendor URDF named in dhkin.vendors.VENDOR_REFERENCES (base -> tip),
and ``dhkin.table_to_yaml`` writes robots/<name>.yaml in m and rad (every number exact). Then
run scripts/regenerate.py for the xacro/URDF files.

Usage: python scripts/fit_tables.py          (writes the tables, prints the figures)
       python scripts/fit_tables.py --check  (exit 1 if a committed table differs from a fresh
                                             fit by more than 1e-14 in FK or any correction)
       --reference-dir DIR                   (vendor URDFs; default robots/vendor)
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from dhkin.dh import DHTable
from dhkin.files import write_file
from dhkin.fit import fit_corrections, largest_correction, read_chain, structural_relations
from dhkin.reference import Reference
from dhkin.robot import builtin_dir
from dhkin.table_file import load_table, table_to_yaml
from dhkin.transforms import pose_error
from dhkin.vendors import VENDOR_REFERENCES

REPO = Path(__file__).resolve().parents[1]
DEFAULT_REFERENCE_DIR = REPO / "robots" / "vendor"
CHECK_TOLERANCE = 1e-14


@dataclass(frozen=True)
class Fitted:
    """A built-in robot fitted from a nominal table (path relative to the repository)."""

    name: str
    nominal: str
    description: str | None = None  # None: the nominal table's
    source: str | None = None  # None: the nominal table's, followed by the fit's provenance


UR5E_CALIBRATED_SOURCE = (
    "One real UR5e with its factory calibration: robots/vendor/ur5e_calibrated.urdf, the "
    "ur_calibration output (hash calib_17107847223675855653) published in "
    "github.com/inaki1111/ur5_gra_ros2-main @ d0303ef39023903bb3cd3043a3e579f737ca99dc "
    "(my_robot_calibration.yaml), expanded with UniversalRobots/Universal_Robots_ROS2_Description "
    "@ 2221ec0f (v2.4.5). Nominal table: robots/ur5e.yaml (Universal Robots' published UR5e DH "
    "parameters; limits, velocities, efforts and frames as UR's description).")

FITTED: tuple[Fitted, ...] = (
    Fitted("ur5e_calibrated", "robots/ur5e.yaml",
           description="Universal Robots UR5e, one calibrated robot (factory calibration)",
           source=UR5E_CALIBRATED_SOURCE),
    Fitted("tm5_900", "tests/data/tm5_900_nominal.yaml"),
    Fitted("kinova_gen3_6dof", "tests/data/kinova_gen3_6dof_nominal.yaml"),
)


def nominal_table(entry: Fitted) -> DHTable:
    table = load_table(REPO / entry.nominal)
    return replace(table, name=entry.name,
                   description=entry.description or table.description,
                   source=entry.source or table.source)


def fit(entry: Fitted, reference_dir: Path) -> tuple[DHTable, DHTable, Path]:
    """(nominal table, fitted table, vendor URDF path) of one robot."""
    vendor = VENDOR_REFERENCES[entry.name]
    urdf = reference_dir / vendor.file
    nominal = nominal_table(entry)
    fitted = fit_corrections(nominal, urdf, vendor.base, vendor.tip)
    provenance = (f" Base, per-joint corrections and tool fitted with dhkin.fit_corrections "
                  f"(scripts/fit_tables.py) to robots/vendor/{vendor.file} "
                  f"({vendor.base} -> {vendor.tip}), whose FK this table reproduces exactly; "
                  f"nominal table: {entry.nominal}.")
    return nominal, replace(fitted, source=nominal.source + provenance), urdf


def header(entry: Fitted) -> str:
    return (f"Written by scripts/fit_tables.py from {entry.nominal}\n"
            "and the vendor URDF named in dhkin.vendors. Do not edit by hand: change the nominal\n"
            "table and run the script (units m and rad, so that every number is exact).")


def figures(nominal: DHTable, fitted: DHTable, urdf: Path, samples: int = 10_000) -> str:
    """FK agreement with the vendor, largest correction, structural deviations."""
    vendor = VENDOR_REFERENCES[fitted.name]
    other = Reference(urdf.read_text(encoding="utf-8"), tip=vendor.tip, base=vendor.base)
    q = np.vstack([np.zeros(fitted.dof), fitted.random_q(samples, np.random.default_rng(0))])
    position, rotation = pose_error(fitted.fk(q), other.fk(q))
    nominal_position, nominal_rotation = pose_error(nominal.fk(q), other.fk(q))
    shift, turn = largest_correction(fitted)
    relations = structural_relations(nominal, read_chain(urdf, vendor.base, vendor.tip))
    lines = [f"{fitted.name}: own FK vs {urdf.name} over {len(q)} q: max {position.max():.2e} m, "
             f"{rotation.max():.2e} rad (nominal table: {nominal_position.max():.2e} m, "
             f"{nominal_rotation.max():.2e} rad)",
             f"  largest correction: {shift:.3e} m, {turn:.3e} rad"]
    for kind, unit in (("parallel", "rad"), ("perpendicular", "rad"), ("intersecting", "m")):
        chosen = [r for r in relations if r.kind == kind]
        if chosen:
            worst = max(chosen, key=lambda r: r.deviation)
            lines.append(f"  {kind} axes: worst {worst.deviation:.3e} {unit} (axes {worst.i + 1} "
                         f"and {worst.j + 1}); pairs: "
                         + ", ".join(f"{r.i + 1}-{r.j + 1}" for r in chosen))
    return "\n".join(lines)


def same(committed: DHTable, fresh: DHTable) -> bool:
    q = np.vstack([np.zeros(fresh.dof), fresh.random_q(1000, np.random.default_rng(1))])
    if np.abs(committed.fk(q) - fresh.fk(q)).max() > CHECK_TOLERANCE:
        return False
    for mine, theirs in zip(committed.joints, fresh.joints, strict=True):
        if np.abs(np.subtract(mine.correction, theirs.correction)).max() > CHECK_TOLERANCE:
            return False
        if replace(mine, correction=theirs.correction) != theirs:
            return False
    return committed.source == fresh.source and committed.description == fresh.description


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare instead of writing")
    parser.add_argument("--reference-dir", type=Path, default=DEFAULT_REFERENCE_DIR)
    args = parser.parse_args()
    stale = []
    for entry in FITTED:
        nominal, fitted, urdf = fit(entry, args.reference_dir)
        path = builtin_dir() / f"{entry.name}.yaml"
        if args.check:
            if not path.is_file() or not same(load_table(path), fitted):
                stale.append(path)
            continue
        write_file(path, table_to_yaml(fitted, header=header(entry)), force=True)  # atomic
        print(f"written: {path}")
        print(figures(nominal, fitted, urdf))
    if args.check:
        for path in stale:
            print(f"stale: {path}")
        print(f"{len(stale)} fitted table(s) stale")
        return 1 if stale else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
