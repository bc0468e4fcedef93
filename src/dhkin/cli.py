"""The `dhkin` command line (every argparse parser of dhkin lives here). Exit status 0 means all
is well; 1 a failed check; 2 bad input."""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence

import numpy as np

from dhkin.cli_check import cmd_check
from dhkin.cli_describe import add_export_parser, add_import_parser, package_arg, packages_of
from dhkin.cli_input import (
    EXIT_BAD_INPUT,
    EXIT_BROKEN_PIPE,
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    Parser,
    angles,
    finite_float,
    force_arg,
    ik_target,
    input_error_text,
    interrupted_text,
    non_negative_float,
    non_negative_int,
    output_name,
    output_paths,
    path_states,
    positive_float,
    positive_int,
)
from dhkin.errors import DhkinError, InputError
from dhkin.robot import Robot, builtin_names, load
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import matrix_to_rpy


def _robot_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("robot", help="built-in robot name (see `dhkin robots`) or a table file")


#: The heading of the built-in robots that are no vendor's arm (textbook examples).
TEXTBOOK = "textbook arms (no vendor)"


def cmd_robots(args: argparse.Namespace) -> int:
    """The built-in robots by vendor (dhkin.vendors), and within a vendor by IK family."""
    from collections import Counter

    from dhkin.vendors import VENDOR_REFERENCES

    groups: dict[str, list[tuple[str, str, Robot]]] = {}
    for name in builtin_names():
        robot = load(name)
        listed = VENDOR_REFERENCES.get(name)
        vendor = listed.vendor if listed is not None and listed.vendor else TEXTBOOK
        groups.setdefault(vendor, []).append((robot.ik_family, name, robot))
    vendors = sorted((v for v in groups if v != TEXTBOOK), key=str.lower)
    vendors += [v for v in groups if v == TEXTBOOK]
    for vendor in vendors:
        families = Counter(family for family, _, _ in groups[vendor])
        print(f"{vendor}: {len(groups[vendor])} (" + ", ".join(
            f"{family} {count}" for family, count in sorted(families.items())) + ")")
        for family, name, robot in sorted(groups[vendor], key=lambda entry: entry[:2]):
            print(f"  {family:16s} {name:21s} {robot.dof} joints  {robot.table.convention:8s}  "
                  f"{robot.table.description}")
    real = sum(len(groups[v]) for v in vendors if v != TEXTBOOK)
    print(f"{real} real arms of {len([v for v in vendors if v != TEXTBOOK])} vendors, "
          f"{len(groups.get(TEXTBOOK, []))} textbook arms")
    return EXIT_OK


def cmd_compare(args: argparse.Namespace) -> int:
    """Poses and joints (names, types, limits, velocities) of a table against another URDF.
    Exit 1 on a pose deviation above --tolerance; with --strict also on any joint difference."""
    from dhkin.compare import compare_with_urdf
    from dhkin.vendors import VendorReference, shipped_reference

    robot = load(args.robot)
    # Without a URDF: the robot's vendor URDF shipped with dhkin, with its frames.
    urdf, listed = ((args.urdf, VendorReference(args.urdf, "base_link", "tool0"))
                    if args.urdf is not None else shipped_reference(robot.name, "urdf"))
    report = compare_with_urdf(robot, urdf, base_frame=args.base_frame or listed.base,
                               tip=args.tip or listed.tip,
                               robot_tip=args.robot_tip or listed.robot_tip,
                               n=args.n, seed=args.seed, tolerance=args.tolerance,
                               packages=packages_of(args))
    print(report.summary())
    if not report.ok:
        print(f"worst joint vector (rad): {np.array2string(report.worst_q, precision=6)}")
    if report.ok and not report.joints_ok:
        print("the poses agree; the joints differ" + (" (--strict: FAIL)" if args.strict else
                                                     " (exit 0; --strict makes this a failure)"))
    passed = report.strict_ok if args.strict else report.ok
    return EXIT_OK if passed else EXIT_FAILED


def _joint_values(robot: Robot, values: Sequence[float], degrees: bool,
                  field: str = "q") -> np.ndarray:
    """Joint values given on the command line (argument ``field``) -> SI; ``degrees`` converts
    the revolute joints only. InputError unless there is one value per joint. (The one parser
    of joint values for every subcommand.)"""
    q = np.asarray(values, dtype=float)
    if q.shape != (robot.dof,):
        raise InputError(f"{field}: {robot.name} has {robot.dof} joints, got {q.size} values",
                         field=field, value=q.tolist(), expected=f"{robot.dof} joint values")
    revolute = np.array([j.is_revolute for j in robot.table.joints])
    return np.where(revolute & degrees, np.radians(q), q)


def _format_pose(T: np.ndarray, degrees: bool) -> str:
    rpy = np.array(matrix_to_rpy(T))
    unit = "deg" if degrees else "rad"
    rpy_text = np.array2string(np.degrees(rpy) if degrees else rpy, precision=9)
    return (np.array2string(T, precision=9, suppress_small=True)
            + f"\nxyz (m): {np.array2string(T[:3, 3], precision=9)}\nrpy ({unit}): {rpy_text}")


def cmd_fk(args: argparse.Namespace) -> int:
    robot = load(args.robot)
    q = _joint_values(robot, args.q, args.deg)
    T = robot.fk(q) if args.frame == "tool0" else robot.reference().fk(q, args.frame)
    print(f"base_link -> {args.frame}:")
    print(_format_pose(T, args.deg))
    return EXIT_OK


def cmd_ik(args: argparse.Namespace) -> int:
    robot = load(args.robot)
    T = ik_target(args)
    seed = None if args.seed is None else _joint_values(robot, args.seed, args.deg)
    solutions = robot.ik(T, q_seed=seed, copies=args.all_copies)
    revolute = np.array([j.is_revolute for j in robot.table.joints])
    shown = np.where(revolute & args.deg, np.degrees(solutions.q), solutions.q)
    if args.json:
        print(json.dumps({
            "robot": robot.name, "family": solutions.family, "target": T.tolist(),
            "units": "deg" if args.deg else "rad", "reason": solutions.reason,
            "solutions": [
                {"q": row.tolist(), "configuration": dict(c.labels), "turns": list(c.turns),
                 "flags": sorted(f), "residual_m": float(r[0]), "residual_rad": float(r[1])}
                for row, c, f, r in zip(shown, solutions.configurations, solutions.flags,
                                        solutions.residuals, strict=True)],
        }, indent=2))
        return EXIT_OK if solutions else EXIT_FAILED
    if not solutions:
        print(f"no solution: {solutions.reason}")
        return EXIT_FAILED
    unit = "deg" if args.deg else "rad"
    print(f"{len(solutions)} solutions ({solutions.family}, joint values in {unit}):")
    for row, configuration, flags, residual in zip(shown, solutions.configurations,
                                                   solutions.flags, solutions.residuals,
                                                   strict=True):
        flag_text = f" [{', '.join(sorted(flags))}]" if flags else ""
        print(f"  {np.array2string(row, precision=6, floatmode='fixed')}  {configuration}"
              f"{flag_text}  residual {max(residual):.1e}")
    return EXIT_OK


def cmd_validate(args: argparse.Namespace) -> int:
    from dhkin.files import check_output, unused_name, write_file
    from dhkin.validation import (
        adapt,
        failures_json,
        load_ik,
        own_ik,
        replay,
        tool_frame_from_robot,
        validate,
    )
    from dhkin.validation.arguments import check_command_line

    check_command_line(args)
    for option, output in (("--json", args.json), ("--report", args.report),
                           ("--failures", args.failures)):
        if output is not None:  # checked before the run, so that no result is lost after it
            check_output(output, option, force=args.force)
    robot = load(args.robot)
    ik, name = None, args.ik  # None: the robot's own IK, closed form or numerical, as the API
    if args.ik is None:
        family = robot.ik_family
        name = f"dhkin's own IK ({family})"
    else:
        ik = load_ik(args.ik)
        if args.deg or args.ik_frame:
            tool = tool_frame_from_robot(robot, args.ik_frame) if args.ik_frame else None
            ik = adapt(ik, degrees=args.deg, tool=tool)
    if args.replay:
        # The failure file names its reference; --reference/--base/--tip override it.
        report = replay(robot, own_ik(robot) if ik is None else ik, args.replay, ik_name=name,
                        reference=args.reference, base=args.base, tip=args.tip,
                        timeout=args.timeout, isolate=args.isolate,
                        packages=packages_of(args))
    else:
        report = validate(robot, ik, n=args.n, seed=args.seed, tolerance=args.tolerance,
                          joint_tolerance=args.joint_tolerance, progress=sys.stderr.isatty(),
                          ik_name=name, reference=args.reference, base=args.base,
                          tip=args.tip, timeout=args.timeout, isolate=args.isolate,
                          packages=packages_of(args))
    print(report.summary())
    if args.json:
        write_file(args.json, json.dumps(report.to_json(), indent=1), "--json", args.force)
    if args.report:
        write_file(args.report, report.markdown(), "--report", args.force)
    if report.failures:
        text = failures_json(report)
        path = args.failures or f"{robot.name}_ik_failures.json"
        if args.failures is None and not args.force:  # a default name replaces nothing
            path = unused_name(path, text)
        path = write_file(path, text, "--failures", args.force)
        print(f"failures written to {path} (rerun on the same reference: dhkin validate "
              f"{args.robot} --replay {path}{' --ik ' + args.ik if args.ik else ''})")
    return EXIT_OK if report.ok else EXIT_FAILED


# --------------------------------------------------------------------------------------------
# `dhkin singularity ROBOT q... [--deg]` and `dhkin map ROBOT -o FILE.png [options]`


def _add_singularity_arguments(parser: argparse.ArgumentParser) -> None:
    from dhkin.singularity import DEFAULT_THRESHOLDS, DISTANCE_UNITS, KINDS

    _robot_arg(parser)
    parser.add_argument("q", type=finite_float, nargs="+",
                        help="joint values (rad and m, or --deg)")
    parser.add_argument("--deg", action="store_true", help="revolute joint values in degrees")
    for kind in KINDS:
        parser.add_argument(f"--{kind}", type=non_negative_float,
                            default=DEFAULT_THRESHOLDS.of(kind), metavar="T",
                            help=f"{kind} threshold ({DISTANCE_UNITS[kind]}, "
                                 f"default {DEFAULT_THRESHOLDS.of(kind):g})")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")


def cmd_singularity(args: argparse.Namespace) -> int:
    """Print the singularity report of one configuration."""
    from dhkin.singularity import KINDS, Thresholds, report_to_json, singularity_report

    robot = load(args.robot)
    q = _joint_values(robot, args.q, bool(args.deg))
    thresholds = Thresholds(**{kind: getattr(args, kind) for kind in KINDS})
    report = singularity_report(robot, q, thresholds)
    if args.json:
        print(json.dumps(report_to_json(report), indent=2))
        return EXIT_OK
    if args.deg:
        revolute = np.array([j.is_revolute for j in robot.table.joints])
        shown = np.where(revolute, np.asarray(args.q, dtype=float), q)  # as given
        print(f"q = {np.array2string(shown, precision=4)} (deg for revolute joints)")
    print(report)
    return EXIT_OK


def _add_map_arguments(parser: argparse.ArgumentParser) -> None:
    from dhkin.maps import DEFAULT_JOINT_RESOLUTION, DEFAULT_RESOLUTION, PLANES

    _robot_arg(parser)
    parser.add_argument("-o", "--output", required=True, type=output_name,
                        help="PNG file to write (its folder must exist)")
    force_arg(parser)
    parser.add_argument("--plane", choices=sorted(PLANES), default="xz",
                        help="workspace slice plane of base_link (default xz)")
    parser.add_argument("--offset", type=finite_float, default=0.0,
                        help="the plane's third coordinate (m, default 0)")
    parser.add_argument("--rpy", type=finite_float, nargs=3, metavar=("R", "P", "Y"),
                        help="tool0 orientation, URDF rpy (rad, or --deg); default per family: "
                             "tool0 z along +x (spherical wrist, Stanford), horizontal at "
                             "45 deg to the slice (offset wrist)")
    parser.add_argument("--q", type=finite_float, nargs="+", metavar="Q",
                        help="joint values held fixed in the joint slices (rad and m, or --deg)")
    parser.add_argument("--deg", action="store_true", help="angles of --rpy and --q in degrees")
    parser.add_argument("--resolution", type=positive_int, default=DEFAULT_RESOLUTION,
                        help=f"workspace grid cells per side (default {DEFAULT_RESOLUTION})")
    parser.add_argument("--joint-resolution", type=positive_int,
                        default=DEFAULT_JOINT_RESOLUTION,
                        help=f"joint grid cells per side (default {DEFAULT_JOINT_RESOLUTION})")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def cmd_map(args: argparse.Namespace) -> int:
    """Draw the maps, print what was written and found."""
    from dhkin.maps import describe, draw_maps

    robot = load(args.robot)
    rpy = None
    if args.rpy is not None:
        rpy = [float(v) for v in angles(args.rpy, bool(args.deg))]
    q_fixed = None
    if args.q is not None:
        q_fixed = _joint_values(robot, args.q, bool(args.deg), "--q")
    maps = draw_maps(robot, args.output, plane=args.plane, offset=args.offset, rpy=rpy,
                     resolution=args.resolution, joint_resolution=args.joint_resolution,
                     q_fixed=q_fixed, progress=not args.no_progress and sys.stderr.isatty(),
                     force=args.force)
    print(describe(maps))
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="dhkin", description="Kinematics of serial arms from DH tables, checked against "
                                  "Pinocchio. ROBOT is a built-in name or a path to a table.")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("robots", help="list the built-in robots")
    p.set_defaults(run=cmd_robots)

    add_export_parser(sub)

    p = sub.add_parser("compare", help="compare a robot with another URDF (e.g. the vendor's): "
                                       "poses, and joint names, types, limits and velocities")
    _robot_arg(p)
    p.add_argument("urdf", nargs="?",
                   help="the other URDF file (default: the robot's vendor URDF shipped with "
                        "dhkin, robots/vendor, with its frames from dhkin.vendors)")
    p.add_argument("--base-frame", help="base frame in the other URDF (default base_link)")
    p.add_argument("--tip", help="tip frame in the other URDF (default tool0)")
    p.add_argument("--robot-tip", help="tip frame of our URDF (default tool0)")
    p.add_argument("-n", type=positive_int, default=1000,
                   help="joint vectors to sample (default 1000)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="random seed (default 0)")
    p.add_argument("--tolerance", type=positive_float, default=DEFAULT_TOLERANCE,
                   help=f"m and rad (default {DEFAULT_TOLERANCE:g})")
    p.add_argument("--strict", action="store_true",
                   help="also fail (exit 1) on any difference of joint names, types, limits or "
                        "velocities (always reported)")
    package_arg(p)
    p.set_defaults(run=cmd_compare)

    add_import_parser(sub)

    p = sub.add_parser("fk", help="forward kinematics base_link -> tool0 (or --frame)")
    _robot_arg(p)
    p.add_argument("q", type=finite_float, nargs="+", help="joint values (rad and m, or --deg)")
    p.add_argument("--deg", action="store_true", help="revolute values and rpy in degrees")
    p.add_argument("--frame", default="tool0", help="frame of the generated URDF")
    p.set_defaults(run=cmd_fk)

    p = sub.add_parser("ik", help="the IK solutions of a pose: one per branch, its in-limit "
                                  "2pi copy nearest the seed (every copy: --all-copies)")
    _robot_arg(p)
    target = p.add_mutually_exclusive_group(required=True)
    target.add_argument("--xyz", type=finite_float, nargs=3, metavar=("X", "Y", "Z"),
                        help="position (m), with --rpy (default 0 0 0)")
    target.add_argument("--matrix", help="file with the 4x4 pose base_link -> tool0")
    p.add_argument("--rpy", type=finite_float, nargs=3, metavar=("R", "P", "Y"),
                   help="URDF roll-pitch-yaw of tool0 (rad, or --deg; with --xyz only)")
    p.add_argument("--seed", type=finite_float, nargs="+",
                   help="joint values: each branch's copy nearest them, and the free joints at "
                        "a singularity (default 0)")
    p.add_argument("--all-copies", action="store_true",
                   help="every in-limit 2pi copy of every branch, not only the nearest")
    p.add_argument("--deg", action="store_true", help="angles in and out in degrees")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(run=cmd_ik)

    from dhkin.validation.calls import DEFAULT_CALL_TIMEOUT
    from dhkin.validation.run import DEFAULT_JOINT_TOLERANCE

    p = sub.add_parser("validate", help="cross-validate an IK against Pinocchio on a reference "
                                        "description (rounded, exact or a vendor URDF)")
    _robot_arg(p)
    p.add_argument("--ik", help="module:function of an IK, ik(T) -> joint vectors (default: ours)")
    p.add_argument("-n", type=positive_int, default=10_000,
                   help="uniform samples (default 10000), plus n/10 special and n/10 near-singular")
    p.add_argument("--seed", type=non_negative_int, default=0, help="random seed (default 0)")
    p.add_argument("--tolerance", type=positive_float, default=DEFAULT_TOLERANCE,
                   help=f"m and rad (default {DEFAULT_TOLERANCE:g})")
    p.add_argument("--joint-tolerance", type=positive_float, default=DEFAULT_JOINT_TOLERANCE,
                   help=f"rad / m: same joint vector (default {DEFAULT_JOINT_TOLERANCE:g})")
    p.add_argument("--deg", action="store_true", help="the --ik IK works in degrees")
    p.add_argument("--ik-frame", help="the --ik IK solves for this frame of our URDF, not tool0")
    p.add_argument("--timeout", type=positive_float, default=DEFAULT_CALL_TIMEOUT,
                   help=f"seconds per IK call, else a failure of its pose "
                        f"(default {DEFAULT_CALL_TIMEOUT:g})")
    p.add_argument("--isolate", action="store_true", help="call the IK in a child process: a "
                   "crash or a hang it swallows fails its pose, not the run")
    p.add_argument("--json", type=output_name, help="write the report as JSON to this file")
    p.add_argument("--report", type=output_name,
                   help="write the report as Markdown to this file")
    p.add_argument("--failures", type=output_name,
                   help="failure file (default <robot>_ik_failures.json, or -2, -3, ... "
                        "rather than replace an earlier one)")
    force_arg(p)
    p.add_argument("--replay", help="rerun the samples of a failure file (on the reference it "
                                    "records)")
    p.add_argument("--reference", help="description that makes the targets and checks the "
                                       "solutions: 'rounded' (default: the generated URDF with "
                                       "10 significant digits), 'exact' (the generated URDF), "
                                       "'vendor' (the robot's vendor URDF shipped with dhkin) "
                                       "or a vendor URDF file of the same robot")
    p.add_argument("--base", help="base frame in the --reference URDF (default: from "
                                  "dhkin.vendors for a listed robot, else base_link)")
    p.add_argument("--tip", help="frame of the --reference URDF equal to the table's tool0 "
                                 "(default: from dhkin.vendors for a listed robot, else tool0)")
    package_arg(p)
    p.set_defaults(run=cmd_validate)

    p = sub.add_parser("singularity", help="singularity classes, factored det J and Pinocchio's "
                                           "manipulability of a configuration")
    _add_singularity_arguments(p)
    p.set_defaults(run=cmd_singularity)

    p = sub.add_parser("map", help="manipulability maps with singular loci (PNG)")
    _add_map_arguments(p)
    p.set_defaults(run=cmd_map)

    p = sub.add_parser("check", help="the main job: regenerate, validate, cross-check")
    p.add_argument("robots", nargs="*", help="robots to check (default with --all: built-ins)")
    p.add_argument("--all", action="store_true", help="check every built-in robot")
    p.add_argument("--reference-dir", help="folder of vendor URDFs (default: the ones shipped "
                                           "with dhkin, robots/vendor)")
    p.add_argument("--ik-poses", type=positive_int, default=10_000, help="IK poses per robot")
    p.add_argument("--vendor-poses", type=positive_int, default=None,
                   help="IK poses per robot on its vendor URDF (default 2000)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="random seed (default 0)")
    p.add_argument("--jobs", type=positive_int, default=None,
                   help="robots checked at once, each in a process of its own (default: the "
                        "CPUs this process may use; 1: one by one in this process)")
    p.add_argument("--details", action="store_true",
                   help="also print every check's figures, robot by robot")
    p.add_argument("--json", type=output_name,
                   help="write every check's figures to this file as JSON")
    force_arg(p)
    p.set_defaults(run=cmd_check)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one subcommand. Every failure of the input (dhkin's errors, files that cannot be read
    or written, text that is not UTF-8, input nested too deeply or too large for memory) is one
    line on stderr, ``dhkin: error: ...``, and exit status 2; a reader of stdout that goes away
    (``| head``) ends the command quietly; Ctrl-C is one line saying which output files were
    left as they were (each is written whole or not at all), exit status 130."""
    try:
        args = build_parser().parse_args(argv)
    except KeyboardInterrupt:
        print("dhkin: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    outputs = output_paths(args)
    before = path_states(outputs)
    try:
        status = int(args.run(args))
        sys.stdout.flush()  # a closed pipe shows here, not at interpreter exit
        return status
    except BrokenPipeError:
        # The recipe of the `signal` module's documentation: no further writes to the pipe.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
        return EXIT_BROKEN_PIPE
    except (DhkinError, OSError, UnicodeDecodeError, RecursionError, MemoryError) as exc:
        print(f"dhkin: error: {input_error_text(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"dhkin: {interrupted_text(outputs, before)}", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
