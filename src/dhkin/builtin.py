"""The robots that ship with dhkin: their folder, names, and how a name or path becomes a table
file (foundation layer: no kinematics here)."""

from __future__ import annotations

from pathlib import Path

from dhkin.errors import RobotNotFoundError


def builtin_dir() -> Path:
    """Folder of the built-in robots: inside the installed package, or the repository's robots/."""
    packaged = Path(__file__).resolve().parent / "robots"
    if packaged.is_dir():
        return packaged
    return Path(__file__).resolve().parents[2] / "robots"


def builtin_names() -> list[str]:
    """Names of the built-in robots (the ``*.yaml`` tables in :func:`builtin_dir`)."""
    return sorted(p.stem for p in builtin_dir().glob("*.yaml"))


def resolve_table_path(name_or_path: str | Path) -> Path:
    """A built-in robot name or a path to a ``.yaml`` table -> the table file's path."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml") or candidate.exists():
        if not candidate.is_file():
            what = ("is a folder, not a DH table file" if candidate.is_dir()
                    else "is not a regular file" if candidate.exists()
                    else "no such DH table file")
            raise RobotNotFoundError(f"{candidate}: {what}", field="robot",
                                     value=str(candidate), expected="a DH table file")
        return candidate
    builtin = builtin_dir() / f"{name_or_path}.yaml"
    if builtin.is_file():
        return builtin
    raise RobotNotFoundError(f"{name_or_path!r} is neither a built-in robot nor a table file; "
                             f"built-in robots: {builtin_names()}", field="robot",
                             value=str(name_or_path),
                             expected=f"one of {builtin_names()} or a table file")
