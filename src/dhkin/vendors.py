"""The vendor descriptions each built-in robot is checked against, shipped with dhkin.

The vendor URDFs live in ``robots/vendor/`` (:func:`vendor_dir`: inside the installed package, or
the repository's), each with its provenance in its first comment and its upstream licence in
``robots/vendor/README.md``. :data:`VENDOR_REFERENCES` maps a built-in robot's name to a
:class:`VendorReference`: the vendor URDF's file name and the frames that correspond to the
table's ``base_link`` and ``tool0``. The tables of ur5e_calibrated, tm5_900 and kinova_gen3_6dof
are fitted to these files (scripts/fit_tables.py, dhkin.fit_corrections): their corrections
reproduce them exactly. The tables in :data:`IMPORTED` are imported from them
(scripts/import_vendor_tables.py). Every table listed here takes its joint limits and velocities
exactly from its vendor file (`dhkin compare`, `dhkin check` and tests/test_vendor_compare.py
check it); the vendor's continuous joints (UR3 wrist_3_joint, Kinova joints 1, 4, 6) are
-360..360 deg in the tables.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from dhkin.builtin import builtin_dir
from dhkin.errors import InputError


@dataclass(frozen=True)
class VendorReference:
    """A vendor URDF and its frames: ``base`` (= the table's base_link), ``tip`` (the vendor's
    frame that equals the table's ``robot_tip``, normally tool0); ``vendor``: the maker, as
    `dhkin robots` groups the arms."""

    file: str
    base: str
    tip: str
    robot_tip: str = "tool0"
    vendor: str = ""


@dataclass(frozen=True)
class PackageArm:
    """An arm of the ROS-Industrial support packages in ``robots/vendor/packages``: its maker,
    support package, top-level xacro (in the package's ``urdf/``), model as the maker writes it,
    and the frame of the xacro that is the table's tool0."""

    vendor: str
    package: str
    xacro: str
    model: str
    tip: str = "tool0"


#: The built-in arms imported from the support packages as published (xacro with ``$(find)``;
#: scripts/import_vendor_tables.py), by their ROS-Industrial model names. Each one's vendor
#: URDF is the expansion of its xacro, shipped as ``robots/vendor/<name>.urdf``.
PACKAGE_ARMS: dict[str, PackageArm] = {
    "kuka_kr3r540": PackageArm("KUKA", "kuka_kr3_support", "kr3r540.xacro", "KUKA KR 3 R540"),
    "kuka_kr5_arc": PackageArm("KUKA", "kuka_kr5_support", "kr5_arc.xacro", "KUKA KR 5 arc"),
    "kuka_kr10r900_2": PackageArm("KUKA", "kuka_kr10_support", "kr10r900_2.xacro",
                                  "KUKA KR 10 R900-2 (KR AGILUS-2)"),
    "kuka_kr10r1100sixx": PackageArm("KUKA", "kuka_kr10_support", "kr10r1100sixx.xacro",
                                     "KUKA KR 10 R1100 sixx (KR AGILUS)"),
    "kuka_kr10r1420": PackageArm("KUKA", "kuka_kr10_support", "kr10r1420.xacro",
                                 "KUKA KR 10 R1420"),
    "fanuc_cr7ia": PackageArm("FANUC", "fanuc_cr7ia_support", "cr7ia.xacro", "FANUC CR-7iA"),
    "fanuc_cr7ial": PackageArm("FANUC", "fanuc_cr7ia_support", "cr7ial.xacro",
                               "FANUC CR-7iA/L"),
    "fanuc_cr35ia": PackageArm("FANUC", "fanuc_cr35ia_support", "cr35ia.xacro",
                               "FANUC CR-35iA"),
    "fanuc_lrmate200i": PackageArm("FANUC", "fanuc_lrmate200i_support", "lrmate200i.xacro",
                                   "FANUC LR Mate 200i"),
    "fanuc_lrmate200ib": PackageArm("FANUC", "fanuc_lrmate200ib_support", "lrmate200ib.xacro",
                                    "FANUC LR Mate 200iB"),
    "fanuc_lrmate200ib3l": PackageArm("FANUC", "fanuc_lrmate200ib_support",
                                      "lrmate200ib3l.xacro", "FANUC LR Mate 200iB/3L"),
    "fanuc_lrmate200ic": PackageArm("FANUC", "fanuc_lrmate200ic_support", "lrmate200ic.xacro",
                                    "FANUC LR Mate 200iC"),
    "fanuc_lrmate200ic5f": PackageArm("FANUC", "fanuc_lrmate200ic_support",
                                      "lrmate200ic5f.xacro", "FANUC LR Mate 200iC/5F"),
    "fanuc_lrmate200ic5h": PackageArm("FANUC", "fanuc_lrmate200ic_support",
                                      "lrmate200ic5h.xacro", "FANUC LR Mate 200iC/5H"),
    "fanuc_lrmate200ic5hs": PackageArm("FANUC", "fanuc_lrmate200ic_support",
                                       "lrmate200ic5hs.xacro",
                                       "FANUC LR Mate 200iC/5HS"),
    "fanuc_lrmate200ic5l": PackageArm("FANUC", "fanuc_lrmate200ic_support",
                                      "lrmate200ic5l.xacro", "FANUC LR Mate 200iC/5L"),
    "fanuc_m6ib": PackageArm("FANUC", "fanuc_m6ib_support", "m6ib.xacro", "FANUC M-6iB"),
    "fanuc_m6ib6s": PackageArm("FANUC", "fanuc_m6ib_support", "m6ib6s.xacro",
                               "FANUC M-6iB/6S"),
    "fanuc_m16ib20": PackageArm("FANUC", "fanuc_m16ib_support", "m16ib20.xacro",
                                "FANUC M-16iB/20"),
    "fanuc_m20ib25": PackageArm("FANUC", "fanuc_m20ib_support", "m20ib25.xacro",
                                "FANUC M-20iB/25"),
    "fanuc_m430ia2f": PackageArm("FANUC", "fanuc_m430ia_support", "m430ia2f.xacro",
                                 "FANUC M-430iA/2F"),
    "fanuc_m430ia2p": PackageArm("FANUC", "fanuc_m430ia_support", "m430ia2p.xacro",
                                 "FANUC M-430iA/2P"),
    "fanuc_m710ic45m": PackageArm("FANUC", "fanuc_m710ic_support", "m710ic45m.xacro",
                                  "FANUC M-710iC/45M"),
    "fanuc_m710ic50": PackageArm("FANUC", "fanuc_m710ic_support", "m710ic50.xacro",
                                 "FANUC M-710iC/50"),
    "fanuc_m900ia260l": PackageArm("FANUC", "fanuc_m900ia_support", "m900ia260l.xacro",
                                   "FANUC M-900iA/260L"),
    "fanuc_m900ib700": PackageArm("FANUC", "fanuc_m900ib_support", "m900ib700.xacro",
                                  "FANUC M-900iB/700"),
    "fanuc_r1000ia80f": PackageArm("FANUC", "fanuc_r1000ia_support", "r1000ia80f.xacro",
                                   "FANUC R-1000iA/80F"),
    "motoman_ar2010": PackageArm("Yaskawa", "motoman_ar2010_support", "ar2010.xacro",
                                 "Yaskawa Motoman AR2010"),
    "motoman_gp4": PackageArm("Yaskawa", "motoman_gp4_support", "gp4.xacro",
                              "Yaskawa Motoman GP4"),
    "motoman_gp12": PackageArm("Yaskawa", "motoman_gp12_support", "gp12.xacro",
                               "Yaskawa Motoman GP12"),
    "motoman_gp25": PackageArm("Yaskawa", "motoman_gp25_support", "gp25.xacro",
                               "Yaskawa Motoman GP25"),
    "motoman_gp35l": PackageArm("Yaskawa", "motoman_gp35l_support", "gp35l.xacro",
                                "Yaskawa Motoman GP35L"),
    "motoman_gp50": PackageArm("Yaskawa", "motoman_gp50_support", "gp50.xacro",
                               "Yaskawa Motoman GP50"),
    "motoman_gp70l": PackageArm("Yaskawa", "motoman_gp70l_support", "gp70l.xacro",
                                "Yaskawa Motoman GP70L"),
    "motoman_gp88": PackageArm("Yaskawa", "motoman_gp88_support", "gp88.xacro",
                               "Yaskawa Motoman GP88"),
    "motoman_gp110": PackageArm("Yaskawa", "motoman_gp110_support", "gp110.xacro",
                                "Yaskawa Motoman GP110"),
    "motoman_gp180": PackageArm("Yaskawa", "motoman_gp180_support", "gp180.xacro",
                                "Yaskawa Motoman GP180"),
    "motoman_gp180_120": PackageArm("Yaskawa", "motoman_gp180_support", "gp180_120.xacro",
                                    "Yaskawa Motoman GP180-120"),
    "motoman_gp200r": PackageArm("Yaskawa", "motoman_gp200r_support", "gp200r.xacro",
                                 "Yaskawa Motoman GP200R"),
    "motoman_hc10": PackageArm("Yaskawa", "motoman_hc10_support", "hc10.xacro",
                               "Yaskawa Motoman HC10"),
    "motoman_hc10dt": PackageArm("Yaskawa", "motoman_hc10_support", "hc10dt.xacro",
                                 "Yaskawa Motoman HC10DT"),
    "motoman_hc10dt_b10": PackageArm("Yaskawa", "motoman_hc10_support", "hc10dt_b10.xacro",
                                     "Yaskawa Motoman HC10DT-B10"),
    "motoman_hc10dtp_b00": PackageArm("Yaskawa", "motoman_hc10_support", "hc10dtp_b00.xacro",
                                      "Yaskawa Motoman HC10DTP-B00"),
    "motoman_hc20": PackageArm("Yaskawa", "motoman_hc20_support", "hc20.xacro",
                               "Yaskawa Motoman HC20"),
    "motoman_ma2010": PackageArm("Yaskawa", "motoman_ma2010_support", "ma2010.xacro",
                                 "Yaskawa Motoman MA2010"),
    "motoman_mh50": PackageArm("Yaskawa", "motoman_mh50_support", "mh50.xacro",
                               "Yaskawa Motoman MH50"),
    "motoman_mh110": PackageArm("Yaskawa", "motoman_mh110_support", "mh110.xacro",
                                "Yaskawa Motoman MH110"),
    "motoman_motomini": PackageArm("Yaskawa", "motoman_motomini_support", "motomini.xacro",
                                   "Yaskawa Motoman MotoMini"),
    "motoman_ms210": PackageArm("Yaskawa", "motoman_ms210_support", "ms210.xacro",
                                "Yaskawa Motoman MS210"),
    "motoman_sia5d": PackageArm("Yaskawa", "motoman_sia5d_support", "sia5d.xacro",
                                "Yaskawa Motoman SIA5D"),
    "motoman_sia10f": PackageArm("Yaskawa", "motoman_sia10f_support", "sia10f.xacro",
                                 "Yaskawa Motoman SIA10F", tip="link_tool0"),
    "motoman_sia20d": PackageArm("Yaskawa", "motoman_sia20d_support", "sia20d.xacro",
                                 "Yaskawa Motoman SIA20D"),
    "motoman_sia30d": PackageArm("Yaskawa", "motoman_sia30d_support", "sia30d.xacro",
                                 "Yaskawa Motoman SIA30D"),
    "motoman_sia50": PackageArm("Yaskawa", "motoman_sia50_support", "sia50.xacro",
                                "Yaskawa Motoman SIA50"),
}


#: Built-in robot -> its vendor description in :func:`vendor_dir`.
VENDOR_REFERENCES: dict[str, VendorReference] = {
    "abb_irb1200_7_70": VendorReference("abb_irb1200_7_70.urdf", "base_link", "tool0",
                                        vendor="ABB"),
    "aubo_i10": VendorReference("aubo_i10.urdf", "base_link", "wrist3_Link", vendor="AUBO"),
    "ur3": VendorReference("ur3.urdf", "base_link", "tool0", vendor="Universal Robots"),
    "ur5": VendorReference("ur5.urdf", "base_link", "tool0", vendor="Universal Robots"),
    "ur10": VendorReference("ur10.urdf", "base_link", "tool0", vendor="Universal Robots"),
    "ur5e": VendorReference("ur5e.urdf", "base_link", "tool0", vendor="Universal Robots"),
    "ur5e_calibrated": VendorReference("ur5e_calibrated.urdf", "base_link", "tool0",
                                       vendor="Universal Robots"),
    "tm5_900": VendorReference("tm5_900.urdf", "link_0", "flange", vendor="Techman"),
    "kinova_gen3_6dof": VendorReference("kinova_gen3_6dof.urdf", "base_link",
                                        "end_effector_link", vendor="Kinova"),
    "kuka_kr6r900sixx": VendorReference("kuka_kr6r900sixx.urdf", "base_link", "tool0",
                                        vendor="KUKA"),
    "fanuc_m10ia": VendorReference("fanuc_m10ia.urdf", "base_link", "tool0", vendor="FANUC"),
    "motoman_gp7": VendorReference("motoman_gp7.urdf", "base_link", "tool0", vendor="Yaskawa"),
    "staubli_tx2_60": VendorReference("staubli_tx2_60.urdf", "base_link", "tool0",
                                      vendor="Staubli"),
    "xarm6": VendorReference("xarm6.urdf", "link_base", "link_eef", vendor="UFactory"),
    "fanuc_crx10ia": VendorReference("fanuc_crx10ia.urdf", "base_link", "flange",
                                     vendor="FANUC"),
    **{name: VendorReference(f"{name}.urdf", "base_link", arm.tip, vendor=arm.vendor)
       for name, arm in PACKAGE_ARMS.items()},
}

#: Built-in robots whose tables are imported from their vendor description with ``dhkin
#: import`` (scripts/import_vendor_tables.py), and their descriptions: the vendor URDFs above,
#: and the xacros of :data:`PACKAGE_ARMS` as published.
IMPORTED: dict[str, str] = {
    "kuka_kr6r900sixx": "KUKA KR 6 R900 sixx",
    "fanuc_m10ia": "FANUC M-10iA",
    "motoman_gp7": "Yaskawa Motoman GP7",
    "staubli_tx2_60": "Staubli TX2-60",
    "xarm6": "UFactory xArm6 (axes 5 and 6 0.076 m apart: no closed-form family)",
    "fanuc_crx10ia": "FANUC CRX-10iA (axes 3 and 4 not parallel: no closed-form family)",
    **{name: arm.model for name, arm in PACKAGE_ARMS.items()},
}


def vendor_dir() -> Path:
    """Folder of the vendor reference URDFs shipped with dhkin (``robots/vendor`` beside the
    built-in tables: :func:`dhkin.builtin.builtin_dir`)."""
    return builtin_dir() / "vendor"


def vendor_file(robot_name: str) -> Path | None:
    """The shipped vendor URDF of a built-in robot listed in :data:`VENDOR_REFERENCES`, or None
    for a robot without one."""
    listed = VENDOR_REFERENCES.get(robot_name)
    return None if listed is None else vendor_dir() / listed.file


def shipped_reference(robot_name: str, field: str = "robot") -> tuple[Path, VendorReference]:
    """The shipped vendor URDF of a built-in robot and its frames; InputError naming ``field``
    for a robot without one."""
    shipped = vendor_file(robot_name)
    if shipped is None:
        raise InputError(f"{field}: {robot_name} has no vendor URDF shipped with dhkin (robots "
                         f"with one: {', '.join(sorted(VENDOR_REFERENCES))}); name a URDF of "
                         "the same robot", field=field, value=robot_name,
                         expected="a robot listed in dhkin.vendors, or a URDF path")
    return shipped, VENDOR_REFERENCES[robot_name]
