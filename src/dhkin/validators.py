"""Real URDF validators: urdfdom's ``check_urdf``, Pinocchio and yourdfpy.

Each validator returns a :class:`Verdict` instead of raising, so that `dhkin check` can report all
of them; :func:`require` turns a failed verdict into a :class:`~dhkin.errors.URDFError`.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from dhkin.errors import URDFError

#: Frames every generated URDF has (see :mod:`dhkin.urdf`).
REQUIRED_FRAMES = ("base_link", "base", "flange", "tool0")


@dataclass(frozen=True)
class Verdict:
    """Outcome of one validator on one file."""

    validator: str
    ok: bool
    detail: str


def check_urdf_executable() -> Path:
    """Path of urdfdom's ``check_urdf`` (installed with pin in the environment's bin folder)."""
    found = shutil.which("check_urdf") or shutil.which("check_urdf", path=str(Path(sys.executable)
                                                                                .parent))
    if found is None:
        raise URDFError("check_urdf: not found on PATH nor next to the Python executable; "
                        "expected urdfdom's tool, which the 'pin' package installs")
    return Path(found)


def run_check_urdf(urdf_file: str | Path) -> Verdict:
    """Run urdfdom's ``check_urdf`` on a file; ok when it exits 0. A failure's detail is
    urdfdom's first "Error:" line (the cause; its last line only says "Model Parsing the xml
    failed")."""
    result = subprocess.run([str(check_urdf_executable()), str(urdf_file)], capture_output=True,
                            text=True, errors="replace", check=False)
    output = (result.stdout + "\n" + result.stderr).strip()
    if result.returncode != 0:
        lines = [line.strip() for line in output.splitlines() if line.strip()]
        causes = [line.removeprefix("Error:").strip() for line in lines
                  if line.startswith("Error:")]
        return Verdict("check_urdf", False,
                       causes[0] if causes else (lines[-1] if lines else "failed"))
    return Verdict("check_urdf", True, "Successfully parsed")


def load_in_pinocchio(urdf_text: str, frames: Iterable[str] = REQUIRED_FRAMES) -> Verdict:
    """Build a Pinocchio model from the text and check that the named frames exist."""
    import pinocchio as pin

    try:
        model = pin.buildModelFromXML(urdf_text)
    except Exception as exc:
        return Verdict("pinocchio", False, str(exc))
    missing = [f for f in frames if not model.existFrame(f)]
    if missing:
        return Verdict("pinocchio", False, f"missing frames {missing}")
    return Verdict("pinocchio", True, f"nq={model.nq}, {len(model.frames)} frames")


def load_in_yourdfpy(urdf_file: str | Path, frames: Iterable[str] = REQUIRED_FRAMES) -> Verdict:
    """Load the file with yourdfpy (no meshes) and check its links and its validation."""
    import yourdfpy

    try:
        model = yourdfpy.URDF.load(str(urdf_file), load_meshes=False, build_scene_graph=True)
    except Exception as exc:
        return Verdict("yourdfpy", False, str(exc))
    missing = [f for f in frames if f not in model.link_map]
    if missing:
        return Verdict("yourdfpy", False, f"missing links {missing}")
    if not model.validate():
        return Verdict("yourdfpy", False, "URDF.validate() returned False")
    return Verdict("yourdfpy", True, f"{len(model.actuated_joints)} actuated joints")


def require(verdict: Verdict, source: str) -> None:
    """Raise URDFError when a verdict failed."""
    if not verdict.ok:
        raise URDFError(f"{source}: {verdict.validator} failed: {verdict.detail}")
