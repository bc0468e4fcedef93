"""Vendor support packages as published (robots/vendor/packages): every arm's top-level xacro
imports without ROS, ``$(find)`` resolved the three ways dhkin knows (given, environment,
checkout), and the published OPW files are compared by FK.

The oracle is Pinocchio on the URDF the xacro expands to (dhkin.xacro_expansion, xacro itself
doing the expansion): each imported table's FK, read back from the file the import writes, must
equal it to DEFAULT_TOLERANCE on the joint vectors of ``oracle_q`` (zero, every joint at +-pi/2,
and random ones within the limits, fixed seed), and so must each published OPW file that dhkin
calls equivalent, and each one it blames once the blamed fields hold dhkin's values.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest

import dhkin
from dhkin.cli import main
from dhkin.errors import URDFError
from dhkin.importer import import_description
from dhkin.opw import opw_fk, opw_parameters
from dhkin.opw_compare import compare_opw, read_opw_file
from dhkin.reference import Reference
from dhkin.ros_packages import PackageFinder, PackageNotFoundError, package_name
from dhkin.table_file import table_to_yaml
from dhkin.tolerances import DEFAULT_TOLERANCE
from dhkin.transforms import pose_error
from dhkin.xacro_expansion import expand_xacro

from .conftest import REPO

PACKAGES = REPO / "robots" / "vendor" / "packages"
#: Every top-level arm xacro of the packages (the macros and the *_resources are included).
ARM_XACROS = sorted(path for path in PACKAGES.glob("*/urdf/*.xacro")
                    if not path.name.endswith("_macro.xacro")
                    and not path.parent.parent.name.endswith("_resources"))
#: Arms whose tip is not tool0 (upstream names it otherwise; the import finds it as the one
#: leaf besides ROS-Industrial's base frame).
TIPS = {"sia10f.xacro": "link_tool0"}
#: Random joint vectors of the oracle comparison (besides zero and the +-pi/2 vectors).
ORACLE_SAMPLES = 200


def oracle_q(table: dhkin.DHTable, seed: int = 5) -> np.ndarray:
    """q = 0, each joint alone at +-pi/2 (clipped to the limits), and random vectors."""
    special = [np.zeros(table.dof)]
    for k in range(table.dof):
        for value in (0.5 * math.pi, -0.5 * math.pi):
            q = np.zeros(table.dof)
            q[k] = min(max(value, table.lower[k]), table.upper[k])
            special.append(q)
    return np.vstack([*special, table.random_q(ORACLE_SAMPLES, np.random.default_rng(seed))])


def test_the_packages_hold_the_arms() -> None:
    """54 arms of KUKA, FANUC and Yaskawa (6- and 7-axis), with their *_resources packages."""
    assert len(ARM_XACROS) == 54
    assert {path.parent.parent.name.split("_")[0] for path in ARM_XACROS} == \
        {"kuka", "fanuc", "motoman"}


@pytest.mark.parametrize("xacro_file", ARM_XACROS, ids=lambda p: p.name)
def test_every_vendor_xacro_imports_as_published(xacro_file: Path, tmp_path: Path) -> None:
    """`dhkin import FILE -o TABLE` with no other option: the table file reads back as written
    (its text is a fixed point), and its FK equals Pinocchio's on the expanded URDF."""
    tip = TIPS.get(xacro_file.name)
    output = tmp_path / "table.yaml"
    assert main(["import", str(xacro_file), "-o", str(output)]) == 0
    robot = dhkin.load(output)
    text = output.read_text(encoding="utf-8")
    assert table_to_yaml(robot.table, {"length": "m", "angle": "deg"}) in text  # round trip
    oracle = Reference(expand_xacro(xacro_file), tip=tip or "tool0", base="base_link")
    q = oracle_q(robot.table)
    position, rotation = pose_error(robot.fk(q), oracle.fk(q))
    assert position.max() <= DEFAULT_TOLERANCE and rotation.max() <= DEFAULT_TOLERANCE
    assert robot.table.joint_names == oracle.joint_names


def test_the_default_tip_is_the_leaf_besides_the_base_frame(tmp_path: Path) -> None:
    """SIA10F's leaves are link_tool0 and ROS-Industrial's base frame: the tip is link_tool0;
    with a third leaf (a camera) and none named tool0, --tip is asked for."""
    xacro_file = PACKAGES / "motoman_sia10f_support" / "urdf" / "sia10f.xacro"
    assert "(base_link -> link_tool0)" in import_description(xacro_file).table.description
    text = expand_xacro(xacro_file).replace(
        "</robot>", '<link name="camera"/><joint name="camera_joint" type="fixed"><parent '
                    'link="base_link"/><child link="camera"/></joint></robot>')
    (tmp_path / "sia10f.urdf").write_text(text)
    with pytest.raises(URDFError, match=r"sia10f\.urdf: several leaf links \['link_tool0', "
                                        r"'base', 'camera'\] and none is tool0; expected --tip"):
        import_description(tmp_path / "sia10f.urdf")


# --------------------------------------------------------------------------------------------
# Where $(find NAME) comes from


def copy_packages(folder: Path, *names: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name in names:
        shutil.copytree(PACKAGES / name, folder / name)
    return folder


KR10 = ("kuka_kr10_support", "urdf/kr10r1420.xacro")


def test_the_ways_to_give_a_package(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The KR 10 R1420 support package alone, its kuka_resources elsewhere: found through
    --package, ROS_PACKAGE_PATH (searched below), AMENT_PREFIX_PATH (an ament index), and the
    checkout (beside the package); the same URDF each way."""
    alone = copy_packages(tmp_path / "alone", KR10[0])
    xacro_file = alone / KR10[0] / KR10[1]
    resources = copy_packages(tmp_path / "elsewhere" / "deep", "kuka_resources")
    expected = expand_xacro(PACKAGES / KR10[0] / KR10[1], environ={})
    given = expand_xacro(xacro_file, packages={"kuka_resources": resources / "kuka_resources"},
                         environ={})
    assert given == expected
    assert expand_xacro(xacro_file, environ={"ROS_PACKAGE_PATH": str(tmp_path / "elsewhere")}) \
        == expected
    prefix = tmp_path / "install"
    index = prefix / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    (index / "kuka_resources").write_text("")
    shutil.copytree(resources / "kuka_resources", prefix / "share" / "kuka_resources")
    assert expand_xacro(xacro_file, environ={"AMENT_PREFIX_PATH": str(prefix)}) == expected
    # The checkout: a clone of the vendor repository holds both packages side by side.
    clone = copy_packages(tmp_path / "kuka_experimental", KR10[0], "kuka_resources")
    assert expand_xacro(clone / KR10[0] / KR10[1], environ={}) == expected
    # The command line: --package, and ROS_PACKAGE_PATH from the real environment.
    table = tmp_path / "kr10.yaml"
    assert main(["import", str(xacro_file), "-o", str(table), "--package",
                 f"kuka_resources={resources / 'kuka_resources'}"]) == 0
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "elsewhere"))
    assert main(["import", str(xacro_file), "-o", str(table), "--force"]) == 0


def test_an_unresolved_package_is_one_line_with_the_three_ways(tmp_path: Path, capsys) -> None:
    alone = copy_packages(tmp_path / "alone", KR10[0])
    xacro_file = alone / KR10[0] / KR10[1]
    with pytest.raises(PackageNotFoundError) as caught:
        import_description(xacro_file, environ={})
    text = str(caught.value)
    macro_lines = (alone / KR10[0] / "urdf" / "kr10r1420_macro.xacro").read_text().splitlines()
    line = 1 + next(k for k, t in enumerate(macro_lines) if "$(find kuka_resources)" in t)
    assert text.startswith(f"{alone / KR10[0] / 'urdf' / 'kr10r1420_macro.xacro'}: line "
                           f"{line}: $(find kuka_resources): package 'kuka_resources' not found;")
    for way in ("--package kuka_resources=DIR", "ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH",
                "beside or above the description's package"):
        assert way in text
    assert caught.value.value == "kuka_resources"
    code = main(["import", str(xacro_file), "-o", str(tmp_path / "t.yaml")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "package 'kuka_resources' not found" in err


def test_the_nearest_package_of_a_name_wins_and_names_come_from_package_xml(
        tmp_path: Path) -> None:
    """Two folders declaring kuka_resources: the one nearer the description wins; a folder
    whose package.xml names another package is found by that name, not its folder name."""
    near = copy_packages(tmp_path / "a" / "b", KR10[0])
    shutil.copytree(PACKAGES / "kuka_resources", near / "renamed_folder")
    copy_packages(tmp_path / "a", "kuka_resources")
    finder = PackageFinder.for_description(near / KR10[0] / KR10[1], environ={})
    assert finder.find("kuka_resources") == (near / "renamed_folder").resolve()
    assert package_name(near / "renamed_folder") == "kuka_resources"
    with pytest.raises(PackageNotFoundError):
        finder.find("renamed_folder")


@pytest.mark.parametrize("option", ["kuka_resources", "=DIR", "kuka_resources="])
def test_a_malformed_package_option_is_a_usage_error(option: str, tmp_path: Path,
                                                     capsys) -> None:
    code = main(["import", str(PACKAGES / KR10[0] / KR10[1]), "-o", str(tmp_path / "t.yaml"),
                 "--package", option])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith(f"dhkin: error: --package {option!r}: expected NAME=DIR")


def test_a_package_folder_that_is_not_a_folder(tmp_path: Path, capsys) -> None:
    code = main(["import", str(PACKAGES / KR10[0] / KR10[1]), "-o", str(tmp_path / "t.yaml"),
                 "--package", f"kuka_resources={tmp_path / 'nowhere'}"])
    assert code == 2
    assert "is not a folder; expected the package's folder" in capsys.readouterr().err


# --------------------------------------------------------------------------------------------
# The published OPW files

#: config file -> (its arm's xacro, the verdict: None equivalent, else the fields to blame).
PUBLISHED_OPW: dict[str, tuple[str, tuple[str, ...] | None]] = {
    "kuka_kr10_support/config/opw_parameters_kr10r1420.yaml":
        ("kuka_kr10_support/urdf/kr10r1420.xacro", None),
    "fanuc_m16ib_support/config/opw_parameters_m16ib20.yaml":
        ("fanuc_m16ib_support/urdf/m16ib20.xacro", None),
    "fanuc_m20ib_support/config/opw_parameters_m20ib25.yaml":
        ("fanuc_m20ib_support/urdf/m20ib25.xacro", None),
    "fanuc_m6ib_support/config/opw_parameters_m6ib.yaml": ("fanuc_m6ib_support/urdf/m6ib.xacro",
                                                           None),
    "fanuc_lrmate200ib_support/config/opw_parameters_lrmate200ib.yaml":
        ("fanuc_lrmate200ib_support/urdf/lrmate200ib.xacro", None),
    "fanuc_lrmate200ib_support/config/opw_parameters_lrmate200ib3l.yaml":
        ("fanuc_lrmate200ib_support/urdf/lrmate200ib3l.xacro", None),
    "fanuc_lrmate200ic_support/config/opw_parameters_lrmate200ic.yaml":
        ("fanuc_lrmate200ic_support/urdf/lrmate200ic.xacro", None),
    "fanuc_lrmate200ic_support/config/opw_parameters_lrmate200ic5l.yaml":
        ("fanuc_lrmate200ic_support/urdf/lrmate200ic5l.xacro", None),
    "motoman_gp4_support/config/opw_parameters_gp4.yaml": ("motoman_gp4_support/urdf/gp4.xacro",
                                                           None),
    "motoman_gp110_support/config/opw_parameters_gp110.yaml":
        ("motoman_gp110_support/urdf/gp110.xacro", None),
    "motoman_mh110_support/config/opw_parameters_mh110.yaml":
        ("motoman_mh110_support/urdf/mh110.xacro", None),
    # pi/2 written as -1.57079632679: 4.9e-12 rad off, above the 1e-12 of "equivalent"
    "kuka_kr5_support/config/opw_kinematics_kr5.yaml":
        ("kuka_kr5_support/urdf/kr5_arc.xacro", ("opw_kinematics_joint_offsets[1]",)),
    "motoman_gp35l_support/config/opw_parameters_gp35l.yaml":
        ("motoman_gp35l_support/urdf/gp35l.xacro", ("opw_kinematics_geometric_parameters.a2",)),
    "motoman_gp70l_support/config/opw_parameters_gp70l.yaml":
        ("motoman_gp70l_support/urdf/gp70l.xacro",
         ("opw_kinematics_geometric_parameters.a2", "opw_kinematics_geometric_parameters.a1",
          "opw_kinematics_geometric_parameters.c2")),
}


def test_every_published_opw_file_is_covered() -> None:
    assert sorted(str(p.relative_to(PACKAGES)) for p in PACKAGES.glob("*/config/opw_*.yaml")) \
        == sorted(PUBLISHED_OPW)


def published_fk_against_the_oracle(xacro_file: Path, params: dhkin.opw.OPWParameters,
                                    table: dhkin.DHTable) -> tuple[float, float]:
    """Largest position and rotation difference of an OPW parameter set (OPW base = base_link,
    OPW flange = tool0) from Pinocchio on the expanded URDF."""
    oracle = Reference(expand_xacro(xacro_file), tip="tool0", base="base_link")
    q = oracle_q(table)
    position, rotation = pose_error(params.base @ opw_fk(params, q) @ params.tool, oracle.fk(q))
    return float(position.max()), float(rotation.max())


@pytest.mark.parametrize("config", sorted(PUBLISHED_OPW))
def test_published_opw_files_against_the_expanded_urdf(config: str) -> None:
    """Equivalent files reproduce Pinocchio on the expanded URDF; a blamed file does once the
    blamed fields hold dhkin's values (and not before)."""
    xacro_file, blamed = PUBLISHED_OPW[config]
    table = import_description(PACKAGES / xacro_file).table
    comparison = compare_opw(table, PACKAGES / config)
    published = read_opw_file(PACKAGES / config, opw_parameters(table))
    error = published_fk_against_the_oracle(PACKAGES / xacro_file, published, table)
    if blamed is None:
        assert comparison.equivalent, comparison.summary()
        assert max(error) <= DEFAULT_TOLERANCE
        assert "equivalent (same FK to 1e-12)" in comparison.summary()
        return
    assert not comparison.equivalent
    assert tuple(b.field for b in comparison.blamed) == blamed, comparison.summary()
    assert comparison.blamed[-1].remaining <= comparison.tolerance
    if "kr5" in config:  # a rounded pi/2: within the oracle's tolerance, not within 1e-12
        assert comparison.tolerance < max(error) <= DEFAULT_TOLERANCE
    else:  # wrong by centimetres to decimetres
        assert max(error) > 0.01
    from dhkin.opw_compare import _nearest_form, _with

    fixed = _with(published, _nearest_form(opw_parameters(table), published,
                                           oracle_q(table)), list(blamed))
    assert max(published_fk_against_the_oracle(PACKAGES / xacro_file, fixed, table)) \
        <= DEFAULT_TOLERANCE


@pytest.mark.parametrize(("arm", "config"), [
    ("kuka_kr10_support/urdf/kr10r1420.xacro",
     "kuka_kr10_support/config/opw_parameters_kr10r1420.yaml"),
    ("fanuc_m16ib_support/urdf/m16ib20.xacro",
     "fanuc_m16ib_support/config/opw_parameters_m16ib20.yaml")])
def test_export_opw_compare_of_kr10_and_m16ib(arm: str, config: str, tmp_path: Path,
                                              capsys) -> None:
    """`dhkin export --format opw --compare`: dhkin's file and the vendor's both equal
    Pinocchio on the expanded URDF; the M-16iB/20 file writes the wrist with axis 5 turned
    around (sign 5 -1, offset 6 180 deg where dhkin writes +1 and offset 4 180 deg), which the
    comparison names as the same arm in another form."""
    table_file = tmp_path / "arm.yaml"
    assert main(["import", str(PACKAGES / arm), "-o", str(table_file)]) == 0
    capsys.readouterr()
    code = main(["export", str(table_file), "--format", "opw", "-o", str(tmp_path / "out"),
                 "--compare", str(PACKAGES / config)])
    out = capsys.readouterr().out
    assert code == 0, out
    assert f"{PACKAGES / config}: equivalent (same FK to 1e-12)" in out
    table = dhkin.load(table_file).table
    ours = read_opw_file(tmp_path / "out" / f"{table.name}_opw.yaml", opw_parameters(table))
    assert max(published_fk_against_the_oracle(PACKAGES / arm, ours, table)) <= DEFAULT_TOLERANCE
    if "m16ib" in arm:
        assert "written in another form (axis 5 turned around" in out
        assert "opw_kinematics_joint_sign_corrections[4] -1 (dhkin 1)" in out
    else:
        assert "the same parameters as dhkin's" in out


def test_export_opw_compare_names_the_field_to_blame(tmp_path: Path, capsys) -> None:
    """GP35L: the published a2 has the wrong sign (0.42 m off); exit 1, one line naming it."""
    table_file = tmp_path / "gp35l.yaml"
    assert main(["import", str(PACKAGES / "motoman_gp35l_support/urdf/gp35l.xacro"), "-o",
                 str(table_file)]) == 0
    capsys.readouterr()
    config = PACKAGES / "motoman_gp35l_support/config/opw_parameters_gp35l.yaml"
    code = main(["export", str(table_file), "--format", "opw", "-o", str(tmp_path / "out"),
                 "--compare", str(config)])
    out = capsys.readouterr().out.splitlines()
    assert code == 1
    assert out[-1].startswith(f"{config}: differs from the table's FK: largest difference 0.42 m")
    assert out[-1].endswith("field to blame: opw_kinematics_geometric_parameters.a2: 0.21, dhkin "
                            "-0.21 (with dhkin's value: 8.88e-16)")
