"""Import the built-in robots whose tables come from a vendor description (robots/<name>.yaml),
with ``dhkin.import_description``, and write the vendor URDFs of the package arms.

Two sources (dhkin.vendors.IMPORTED):

* a vendor URDF of robots/vendor (its first comment names its upstream source);
* an arm of the ROS-Industrial support packages in robots/vendor/packages, as published (xacro
  with ``$(find)``; dhkin.vendors.PACKAGE_ARMS): its table is imported from its top-level xacro,
  and its vendor URDF, the file `dhkin check` compares the table and the IK with, is that
  xacro's expansion (dhkin.xacro_expansion.expand_xacro, with no environment), kinematics only
  (visual, collision, inertial, material, transmission and gazebo elements removed, XML comments
  dropped, indented), written as robots/vendor/<name>.urdf with its provenance in its first
  comment: upstream repository @ commit, package, xacro file and the package's licence.

Then run scripts/regenerate.py for the xacro/URDF files of the tables; `dhkin check --all` checks
each table against its vendor URDF (dhkin.vendors.VENDOR_REFERENCES).

Usage: python scripts/import_vendor_tables.py          (writes the files, prints the summaries)
       python scripts/import_vendor_tables.py --check  (exit 1 if a committed table or vendor
                                                       URDF differs from a fresh import)
       --reference-dir DIR                            (default robots/vendor)
"""

from __future__ import annotations

import argparse
import re
import sys
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

from dhkin.files import write_file
from dhkin.importer import ImportResult, import_description
from dhkin.robot import builtin_dir
from dhkin.table_file import table_to_yaml
from dhkin.vendors import IMPORTED, PACKAGE_ARMS, VENDOR_REFERENCES, PackageArm
from dhkin.xacro_expansion import expand_xacro

REPO = Path(__file__).resolve().parents[1]
DEFAULT_REFERENCE_DIR = REPO / "robots" / "vendor"
_UPSTREAM = re.compile(r"<!--\s*source:\s*(.*?)\s*-->", re.DOTALL)

#: The repositories the support packages were copied from (robots/vendor/packages/README.md), by
#: the first word of the package's name.
PACKAGE_UPSTREAM: dict[str, tuple[str, str]] = {
    "kuka": ("github.com/ros-industrial/kuka_experimental",
             "e78bbd15edb2b39c9053ff3b963ef2947e10a531"),
    "fanuc": ("github.com/ros-industrial/fanuc", "8fee5e30e535378758ace26dfdffb8ab0403e23c"),
    "motoman": ("github.com/ros-industrial/motoman", "433be15f6a27cb9a5715cc3887b1cd15ff33a8cb"),
}

#: Elements of a link or of the robot that carry no kinematics (removed from a shipped URDF).
NOT_KINEMATICS = ("visual", "collision", "inertial", "material", "transmission", "gazebo")


def package_xacro(arm: PackageArm, reference_dir: Path) -> Path:
    return reference_dir / "packages" / arm.package / "urdf" / arm.xacro


def package_licence(arm: PackageArm, reference_dir: Path) -> str:
    """The ``<license>`` of the arm's package.xml (several joined by ' and ')."""
    text = (reference_dir / "packages" / arm.package / "package.xml").read_text(encoding="utf-8")
    return " and ".join(" ".join(found.split())
                        for found in re.findall(r"<license[^>]*>(.*?)</license>", text, re.S))


def provenance(arm: PackageArm, reference_dir: Path) -> str:
    """Upstream repository @ commit, package and xacro file of a package arm, and its licence."""
    repository, commit = PACKAGE_UPSTREAM[arm.package.split("_")[0]]
    return (f"{repository} @ {commit}, package {arm.package}, urdf/{arm.xacro} (licence "
            f"{package_licence(arm, reference_dir)}, the package's package.xml)")


def kinematics_only(urdf_text: str) -> str:
    """The URDF without its :data:`NOT_KINEMATICS` elements and comments, indented; every
    attribute of the links and joints kept as written."""
    robot = ET.fromstring(urdf_text)
    for parent in [robot, *robot.iter("link")]:
        for child in [c for c in parent if c.tag in NOT_KINEMATICS]:
            parent.remove(child)
    ET.indent(robot, space="  ")
    return ET.tostring(robot, encoding="unicode") + "\n"


def package_urdf(name: str, reference_dir: Path) -> str:
    """The vendor URDF of a package arm: its xacro's expansion, kinematics only, with its
    provenance as its first comment."""
    arm = PACKAGE_ARMS[name]
    xacro_file = package_xacro(arm, reference_dir)
    header = (f"<!-- source: {provenance(arm, reference_dir)}; expanded without ROS by "
              "scripts/import_vendor_tables.py (dhkin.xacro_expansion.expand_xacro, $(find) "
              "answered by robots/vendor/packages); kinematics only: "
              f"{', '.join(NOT_KINEMATICS)} and comments removed -->\n")
    return header + kinematics_only(expand_xacro(xacro_file, environ={}))


def imported(name: str, reference_dir: Path) -> tuple[ImportResult, str]:
    """The import of one built-in robot and its table file's text."""
    vendor = VENDOR_REFERENCES[name]
    arm = PACKAGE_ARMS.get(name)
    if arm is not None:
        path = package_xacro(arm, reference_dir)
        cited = f"robots/vendor/packages/{arm.package}/urdf/{arm.xacro}"
        upstream = (f" Upstream: {provenance(arm, reference_dir)}. Its expansion ships as "
                    f"robots/vendor/{vendor.file}.")
    else:
        path = reference_dir / vendor.file
        cited = f"robots/vendor/{vendor.file}"
        found = _UPSTREAM.search(path.read_text(encoding="utf-8"))
        upstream = ("" if found is None else
                    f" Upstream (the file's first comment): {' '.join(found.group(1).split())}")
    result = import_description(path, base=vendor.base, tip=vendor.tip, name=name, environ={})
    source = result.table.source.replace(str(path), cited) + upstream
    table = replace(result.table, description=IMPORTED[name], source=source)
    result = replace(result, table=table)
    header = (f"Written by scripts/import_vendor_tables.py (dhkin import of {cited}).\n"
              + result.summary())
    return result, table_to_yaml(table, result.units, header=header)


def outputs(name: str, reference_dir: Path) -> tuple[ImportResult, dict[Path, str]]:
    """The import of one robot and the files it gives: its table, and for a package arm its
    vendor URDF."""
    result, text = imported(name, reference_dir)
    files = {builtin_dir() / f"{name}.yaml": text}
    if name in PACKAGE_ARMS:
        files[reference_dir / VENDOR_REFERENCES[name].file] = package_urdf(name, reference_dir)
    return result, files


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare, do not write")
    parser.add_argument("--reference-dir", type=Path, default=DEFAULT_REFERENCE_DIR)
    args = parser.parse_args(argv)
    stale = []
    for name in IMPORTED:
        result, files = outputs(name, args.reference_dir)
        for target, text in files.items():
            if args.check:
                if not target.is_file() or target.read_text(encoding="utf-8") != text:
                    stale.append(target.name)
                continue
            write_file(target, text, force=True)  # atomic; regenerating replaces
        if not args.check:
            shown = builtin_dir() / f"{name}.yaml"
            print(f"{shown.relative_to(REPO)}\n  " + result.summary().replace("\n", "\n  "))
    if args.check:
        print(f"{len(stale)} imported file(s) stale" + (f": {stale}" if stale else ""))
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
