"""dhkin: kinematics of 6-axis industrial arms from DH tables, validated against Pinocchio.

``dhkin.load(name_or_path)`` returns a :class:`~dhkin.robot.Robot`; see DESIGN.md for the contracts.
"""

from dhkin.dh import DHTable, Joint, load_table, parse_table, table_to_yaml, write_table
from dhkin.errors import DHError, DhkinError, FamilyError, RobotNotFoundError, URDFError
from dhkin.fit import fit_corrections
from dhkin.robot import Robot, builtin_names, load

__all__ = [
    "DHError",
    "DHTable",
    "DhkinError",
    "FamilyError",
    "Joint",
    "Robot",
    "RobotNotFoundError",
    "URDFError",
    "builtin_names",
    "fit_corrections",
    "load",
    "load_table",
    "parse_table",
    "table_to_yaml",
    "write_table",
]
__version__ = "0.1.0"
