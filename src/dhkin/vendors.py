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
    frame that equals the table's ``robot_tip``, normally tool0)."""

    file: str
    base: str
    tip: str
    robot_tip: str = "tool0"


#: Built-in robot -> its vendor description in :func:`vendor_dir`.
VENDOR_REFERENCES: dict[str, VendorReference] = {
    "abb_irb1200_7_70": VendorReference("abb_irb1200_7_70.urdf", "base_link", "tool0"),
    "aubo_i10": VendorReference("aubo_i10.urdf", "base_link", "wrist3_Link"),
    "ur3": VendorReference("ur3.urdf", "base_link", "tool0"),
    "ur5": VendorReference("ur5.urdf", "base_link", "tool0"),
    "ur10": VendorReference("ur10.urdf", "base_link", "tool0"),
    "ur5e": VendorReference("ur5e.urdf", "base_link", "tool0"),
    "ur5e_calibrated": VendorReference("ur5e_calibrated.urdf", "base_link", "tool0"),
    "tm5_900": VendorReference("tm5_900.urdf", "link_0", "flange"),
    "kinova_gen3_6dof": VendorReference("kinova_gen3_6dof.urdf", "base_link", "end_effector_link"),
    "kuka_kr6r900sixx": VendorReference("kuka_kr6r900sixx.urdf", "base_link", "tool0"),
    "fanuc_m10ia": VendorReference("fanuc_m10ia.urdf", "base_link", "tool0"),
    "motoman_gp7": VendorReference("motoman_gp7.urdf", "base_link", "tool0"),
    "staubli_tx2_60": VendorReference("staubli_tx2_60.urdf", "base_link", "tool0"),
    "xarm6": VendorReference("xarm6.urdf", "link_base", "link_eef"),
    "fanuc_crx10ia": VendorReference("fanuc_crx10ia.urdf", "base_link", "flange"),
}

#: Built-in robots whose tables are imported from their vendor URDF with ``dhkin import``
#: (scripts/import_vendor_tables.py), and their descriptions.
IMPORTED: dict[str, str] = {
    "kuka_kr6r900sixx": "KUKA KR 6 R900 sixx",
    "fanuc_m10ia": "FANUC M-10iA",
    "motoman_gp7": "Yaskawa Motoman GP7",
    "staubli_tx2_60": "Staubli TX2-60",
    "xarm6": "UFactory xArm6 (axes 5 and 6 0.076 m apart: no closed-form family)",
    "fanuc_crx10ia": "FANUC CRX-10iA (axes 3 and 4 not parallel: no closed-form family)",
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
