"""dhkin: kinematics of 6-axis industrial arms from DH tables, validated against Pinocchio.

``dhkin.load(name_or_path)`` returns a :class:`~dhkin.robot.Robot`; ``dhkin.validate(robot, ik,
n=...)`` cross-validates an IK callable against Pinocchio (:mod:`dhkin.validation`, whose other
names are imported from there). Errors: :mod:`dhkin.errors` (one class per fault, all exported
here).
"""

from dhkin.dh import DHTable, Joint
from dhkin.errors import (
    DHError,
    DhkinError,
    FamilyError,
    FileWriteError,
    IKInputError,
    InputError,
    RobotNotFoundError,
    SingularityError,
    UnreachableError,
    URDFError,
    ValidationInputError,
)
from dhkin.fit import fit_corrections
from dhkin.importer import ImportResult, import_description
from dhkin.robot import Robot, builtin_names, load
from dhkin.table_file import load_table, parse_table, table_to_yaml, write_table
from dhkin.validation import validate

__all__ = [
    "DHError",
    "DHTable",
    "DhkinError",
    "FamilyError",
    "FileWriteError",
    "IKInputError",
    "ImportResult",
    "InputError",
    "Joint",
    "Robot",
    "RobotNotFoundError",
    "SingularityError",
    "URDFError",
    "UnreachableError",
    "ValidationInputError",
    "builtin_names",
    "fit_corrections",
    "import_description",
    "load",
    "load_table",
    "parse_table",
    "table_to_yaml",
    "validate",
    "write_table",
]
__version__ = "0.1.0"
