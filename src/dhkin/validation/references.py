"""Reference descriptions: the URDF whose Pinocchio model makes the targets and checks the solutions
(the table's own, rounded to 10 significant digits by default, exact, or a vendor URDF of the
same robot).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dhkin.arm import Arm
from dhkin.description import read_urdf_file
from dhkin.errors import InputError, URDFError
from dhkin.reference import Reference
from dhkin.transforms import invert
from dhkin.validation.arguments import quoted
from dhkin.vendors import VENDOR_REFERENCES, shipped_reference

#: Significant digits of the default "rounded" reference (see :func:`rounded_urdf`).
ROUNDED_DIGITS = 10


#: Names of the built-in reference descriptions (anything else is a URDF path).
REFERENCE_KINDS: tuple[str, ...] = ("rounded", "exact")


#: The name of the robot's vendor URDF shipped with dhkin (:func:`dhkin.vendors.vendor_file`).
SHIPPED_VENDOR = "vendor"


_ROUNDED_ELEMENT = re.compile(r"<(?:origin|axis|limit)\b[^>]*>")


_NUMERIC_ATTRIBUTE = re.compile(
    r"""(\b(?:xyz|rpy|lower|upper|velocity|effort)\s*=\s*)(["'])([^"']*)\2""")


def _round_token(token: str, digits: int) -> str:
    try:
        value = float(token)
    except ValueError:
        return token
    return token if not np.isfinite(value) else f"{value:.{digits}g}"


def rounded_urdf(urdf_text: str, digits: int = ROUNDED_DIGITS) -> str:
    """``urdf_text`` with every number of its ``<origin xyz rpy>``, ``<axis xyz>`` and
    ``<limit lower upper velocity effort>`` attributes rounded to ``digits`` significant digits
    (``f"{x:.{digits}g}"``): pi/2 = 1.5707963267948966 becomes 1.570796327 at 10 digits, as in
    UR's vendor files. Everything else (comments, names, layout) is kept character for character.
    """
    if int(digits) != digits or digits < 1:
        raise InputError(f"digits: expected a positive integer, got {digits!r}", field="digits")

    def attribute(match: re.Match[str]) -> str:
        numbers = " ".join(_round_token(t, int(digits)) for t in match.group(3).split())
        return f"{match.group(1)}{match.group(2)}{numbers}{match.group(2)}"

    return _ROUNDED_ELEMENT.sub(lambda m: _NUMERIC_ATTRIBUTE.sub(attribute, m.group(0)),
                                urdf_text)


@dataclass(frozen=True)
class ReferenceSpec:
    """Which description makes the targets and checks the solutions.

    ``kind``: "rounded" (generated URDF rounded to ``digits``), "exact" (generated URDF) or
    "vendor" (the URDF at ``path``, frames ``base`` -> ``tip``; ``tip`` is the frame equal to the
    table's ``robot_tip``, normally tool0).
    """

    kind: str = "rounded"
    path: str = ""
    base: str = "base_link"
    tip: str = "tool0"
    robot_tip: str = "tool0"
    digits: int = ROUNDED_DIGITS

    def describe(self) -> str:
        if self.kind == "rounded":
            return f"rounded (generated URDF, {self.digits} significant digits)"
        if self.kind == "exact":
            return "exact (generated URDF)"
        tip = self.tip if self.robot_tip == "tool0" else f"{self.tip} = {self.robot_tip}"
        return f"vendor {self.path} ({self.base} -> {tip})"

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_json(cls, data: Any, source: str = "reference") -> ReferenceSpec:
        """From :meth:`to_json`'s dict, or one of the names "rounded" / "exact"; every value is
        checked (InputError naming ``source`` and the key)."""
        if isinstance(data, str) and data in REFERENCE_KINDS:
            return cls(kind=data)
        expected = "'rounded', 'exact' or a vendor reference {kind, path, base, tip}"
        if not isinstance(data, Mapping) or data.get("kind") not in (*REFERENCE_KINDS, "vendor"):
            shown = quoted(data)
            raise InputError(f"{source}: expected {expected}, got {shown}", field=source,
                             value=shown, expected=expected)
        known: dict[str, Any] = {}
        for key in ("kind", "path", "base", "tip", "robot_tip"):
            if key in data:
                if not isinstance(data[key], str):
                    raise InputError(f"{source}.{key}: expected a string, got "
                                     f"{quoted(data[key])}", field=f"{source}.{key}",
                                     value=quoted(data[key]), expected="a string")
                known[key] = data[key]
        if "digits" in data:
            digits = data["digits"]
            if isinstance(digits, bool) or not isinstance(digits, int) or not 1 <= digits <= 17:
                raise InputError(f"{source}.digits: expected an integer in [1, 17], got "
                                 f"{quoted(digits)}", field=f"{source}.digits",
                                 value=quoted(digits), expected="an integer in [1, 17]")
            known["digits"] = digits
        if known["kind"] == "vendor" and not known.get("path"):
            raise InputError(f"{source}.path: expected the vendor URDF's path, got none",
                             field=f"{source}.path", expected="a path")
        return cls(**known)


def resolve_reference(robot: Arm, reference: str | Path | ReferenceSpec | None = None,
                      base: str | None = None, tip: str | None = None) -> ReferenceSpec:
    """``reference`` ("rounded", the default; "exact"; "vendor", the robot's vendor URDF shipped
    with dhkin; a vendor URDF path; or a ReferenceSpec) with the vendor frames ``base`` /
    ``tip`` -> a :class:`ReferenceSpec`. A vendor file's frames default to
    :data:`~dhkin.vendors.VENDOR_REFERENCES` for a robot listed there, else base_link / tool0."""
    if isinstance(reference, ReferenceSpec):
        spec = reference
    elif reference is None or (isinstance(reference, str) and reference in REFERENCE_KINDS):
        if base is not None or tip is not None:
            raise InputError("base/tip (--base/--tip): frames apply to a vendor URDF "
                             "reference only, not to 'rounded' or 'exact'")
        return ReferenceSpec(kind=str(reference or "rounded"))
    else:
        path = Path(reference)
        if isinstance(reference, str) and reference == SHIPPED_VENDOR:
            path = shipped_reference(robot.name, "reference (--reference)")[0]
        if not path.is_file():
            raise InputError(f"reference (--reference): {str(path)!r} is not a file; "
                             f"expected {', '.join(map(repr, REFERENCE_KINDS))}, "
                             f"{SHIPPED_VENDOR!r} or the path of a URDF of the same robot",
                             field="reference")
        listed = VENDOR_REFERENCES.get(robot.name)
        spec = ReferenceSpec(kind="vendor", path=str(path.resolve()),
                             base=listed.base if listed else "base_link",
                             tip=listed.tip if listed else "tool0",
                             robot_tip=listed.robot_tip if listed else "tool0")
    if spec.kind == "vendor" and (base is not None or tip is not None):
        spec = ReferenceSpec(kind="vendor", path=spec.path, base=base or spec.base,
                             tip=tip or spec.tip, robot_tip=spec.robot_tip)
    return spec


class TargetModel:
    """Pinocchio on the reference description, in the table's terms: ``fk(q)`` is the pose of
    the table's tool0 relative to its base_link, q in chain order (see :func:`target_model`)."""

    def __init__(self, spec: ReferenceSpec, reference: Reference,
                 tip_offset: NDArray[np.float64] | None = None) -> None:
        self.spec = spec
        self.reference = reference
        #: Largest pose difference (m and rad, the larger) between this description and the
        #: table's own model over the samples of a run (0 for "exact"; set by the run): a
        #: solution exact on the table may be off by this much here.
        self.deviation = 0.0
        #: robot_tip -> tool0 (constant), when the reference's tip is not the table's tool0.
        self._to_tool0 = tip_offset

    @property
    def description(self) -> str:
        return self.spec.describe()

    def fk(self, q: ArrayLike) -> NDArray[np.float64]:
        T = self.reference.fk(q)
        return T if self._to_tool0 is None else T @ self._to_tool0


def target_model(robot: Arm, reference: str | Path | ReferenceSpec | None = None,
                 base: str | None = None, tip: str | None = None,
                 packages: Mapping[str, str | Path] | None = None) -> TargetModel:
    """The Pinocchio model that makes the targets and checks the solutions (see
    :func:`resolve_reference`; a xacro reference is expanded, ``packages`` giving the folders
    of the ROS packages its ``$(find NAME)`` name: :mod:`dhkin.ros_packages`). Bad files,
    frames or chains raise InputError naming the argument."""
    spec = resolve_reference(robot, reference, base, tip)
    if spec.kind == "exact":
        return TargetModel(spec, robot.reference())
    if spec.kind == "rounded":
        text = rounded_urdf(robot.urdf(), spec.digits)
        return TargetModel(spec, Reference(text, tip="tool0", source=f"{robot.name}.urdf "
                                                                     f"(rounded)"))
    path = Path(spec.path)
    try:
        text = read_urdf_file(path, packages)
    except URDFError as exc:
        raise InputError(f"reference (--reference): {exc}", field="reference") from exc
    try:
        model = Reference(text, tip=spec.tip, base=spec.base, source=str(path))
    except URDFError as exc:
        raise InputError(_frame_error(text, spec, exc)) from exc
    if model.dof != robot.dof:
        raise InputError(
            f"reference (--reference): in {path} the chain {spec.base} -> {spec.tip} has "
            f"{model.dof} actuated joints {model.joint_names}; expected {robot.dof} like "
            f"{robot.name} (choose the frames with --base/--tip)", field="reference")
    offset = None
    if spec.robot_tip != "tool0":
        offset = invert(tool_frame_from_robot(robot, spec.robot_tip))
    return TargetModel(spec, model, offset)


def _frame_error(text: str, spec: ReferenceSpec, exc: URDFError) -> str:
    """Which argument a Reference error is about: the file, --tip or --base."""
    import pinocchio as pin

    try:
        model = pin.buildModelFromXML(text)
    except Exception:
        return f"reference (--reference): {exc}"
    if not model.existFrame(spec.tip):
        return f"tip (--tip): {exc}"
    if not model.existFrame(spec.base):
        return f"base (--base): {exc}"
    return f"reference (--reference): {exc}"


def tool_frame_from_robot(robot: Arm, frame: str) -> NDArray[np.float64]:
    """tool0 -> ``frame`` of the generated URDF (constant), for :func:`adapt`'s ``tool``."""
    reference = robot.reference()
    q = np.zeros(robot.dof)
    return invert(reference.fk(q, "tool0")) @ reference.fk(q, frame)
