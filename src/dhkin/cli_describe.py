"""The `dhkin` subcommands that turn descriptions into tables and tables into files:
``dhkin import`` (URDF or xacro -> DH table) and ``dhkin export`` (table -> xacro/URDF, or
MoveIt's OPW parameters, compared with another OPW file by ``--compare``), and the
``--package NAME=DIR`` option every command that reads a description has (where a ROS package
is, for xacro's ``$(find NAME)``: :mod:`dhkin.ros_packages`).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from dhkin.cli_input import EXIT_FAILED, EXIT_OK, force_arg, output_name, xacro_arguments
from dhkin.errors import InputError
from dhkin.robot import load
from dhkin.ros_packages import given_packages


def package_arg(parser: argparse.ArgumentParser) -> None:
    """The repeatable ``--package NAME=DIR`` option."""
    parser.add_argument("--package", action="append", metavar="NAME=DIR",
                        help="folder of the ROS package NAME, for xacro's $(find NAME) "
                             "(repeatable; else ROS_PACKAGE_PATH / AMENT_PREFIX_PATH, else the "
                             "packages beside and above the description's own)")


def packages_of(args: argparse.Namespace) -> dict[str, Path]:
    """The ``--package`` options of a command line, checked."""
    return given_packages(args.package)


def add_export_parser(sub: Any) -> None:
    """The `export` subcommand's parser (``sub``: the subparsers of `dhkin`)."""
    p = sub.add_parser("export", help="write <name>_macro.xacro, <name>.urdf.xacro, <name>.urdf "
                                      "(or, --format opw, <name>_opw.yaml)")
    p.add_argument("robot", help="built-in robot name (see `dhkin robots`) or a table file")
    p.add_argument("-o", "--output", required=True, type=output_name,
                   help="output folder (created if needed)")
    force_arg(p)
    p.add_argument("--format", choices=("urdf", "opw"), default="urdf",
                   help="urdf: the xacro macro, its top-level xacro and the URDF (default); "
                        "opw: MoveIt opw_kinematics parameters (spherical-wrist arms with an "
                        "ortho-parallel basis; an error for any other arm)")
    p.add_argument("--compare", metavar="FILE.yaml",
                   help="with --format opw: compare another OPW file (a vendor's) by FK with the "
                        "table: 'equivalent' (exit 0), or the largest difference and the field "
                        "to blame (exit 1)")
    p.set_defaults(run=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    robot = load(args.robot)
    if args.format == "opw":
        from dhkin.opw_compare import compare_opw
        from dhkin.opw_yaml import export_opw

        print(export_opw(robot.table, args.output, force=args.force))
        if args.compare is None:
            return EXIT_OK
        comparison = compare_opw(robot.table, args.compare)
        print(comparison.summary())
        return EXIT_OK if comparison.equivalent else EXIT_FAILED
    if args.compare is not None:
        raise InputError("--compare: compares OPW files; expected --format opw with it",
                         field="compare", value=args.compare, expected="--format opw")
    from dhkin.urdf import export

    for path in export(robot.table, args.output, force=args.force):
        print(path)
    return EXIT_OK


def add_import_parser(sub: Any) -> None:
    """The `import` subcommand's parser (``sub``: the subparsers of `dhkin`)."""
    p = sub.add_parser("import", help="import a URDF or xacro description as a DH table")
    p.add_argument("description", help="the URDF or xacro file")
    p.add_argument("-o", "--output", required=True, type=output_name,
                   help="the table file to write (.yaml)")
    p.add_argument("--base", help="base link of the chain (default: the root link)")
    p.add_argument("--tip", help="tip link of the chain (default: the single leaf link, or "
                                 "tool0 among several)")
    p.add_argument("--convention", choices=("standard", "modified"), default="standard",
                   help="DH convention (default standard)")
    p.add_argument("--length", choices=("m", "mm"), default="m", help="length unit (default m)")
    p.add_argument("--angle", choices=("deg", "rad"), default="deg",
                   help="angle unit (default deg)")
    p.add_argument("--xacro-arg", action="append", metavar="NAME:=VALUE",
                   help="a xacro argument (repeatable)")
    package_arg(p)
    p.add_argument("--name", help="the table's robot name (default: the file name's stem)")
    p.add_argument("--force", action="store_true", help="replace an existing output file")
    p.set_defaults(run=cmd_import)


def cmd_import(args: argparse.Namespace) -> int:
    from dhkin.files import check_output, write_file
    from dhkin.importer import import_description

    output = Path(args.output)
    if output.suffix not in (".yaml", ".yml"):
        raise InputError(f"-o {output}: expected a .yaml table file name", field="output",
                         value=str(output), expected="a path ending in .yaml")
    check_output(output, "-o", force=True)  # folder, link, writable; the content is compared last
    result = import_description(args.description, base=args.base, tip=args.tip,
                                convention=args.convention,
                                units={"length": args.length, "angle": args.angle},
                                xacro_args=xacro_arguments(args.xacro_arg), name=args.name,
                                packages=packages_of(args))
    write_file(output, result.yaml(), "-o", force=args.force)
    print(result.summary())
    for note in result.notes:
        print(f"note: {note}")
    print(f"wrote {output}")
    return EXIT_OK
