"""Writing output files: every file dhkin writes goes through here, so that nothing is lost or
overwritten by accident.

The rules (README, "Files dhkin writes"):

* **Atomic.** The content goes to a temporary file in the destination's folder (flushed and
  fsync'd), which then replaces the destination in one ``os.replace``. On any error (a full
  disk, a file size limit, an interrupt) the temporary file is removed and the old file is left
  as it was; the error is a one-line :class:`~dhkin.errors.FileWriteError` naming the file and
  the system's reason. Several files written together (an export) are all written to temporary
  files first, and replace their destinations only once every one of them is complete.
* **No silent overwrite.** An existing file whose content differs is replaced only with
  ``force=True`` (``--force``); an existing file with the same content is left untouched, so a
  repeated export succeeds and changes nothing.
* **No symbolic links.** A destination that is a symbolic link is refused, whatever it points
  to (with or without force): dhkin never writes through a link into another place, and never
  replaces a link with a file. (Links among the folders above the file are the user's choice and
  are followed.)
* **Streams.** An existing character device or pipe (``/dev/null``, ``/dev/stdout``) is written
  to directly: there is no file to keep.
* **Folders.** A file's folder must exist: it is not created. :func:`make_folder` creates an
  output *folder* (``dhkin export -o DIR``) with its missing parents and says which ones it
  created, so that a failed export can remove them again.
* **Before long runs.** :func:`check_output` checks a destination before the work that produces
  it (the folder exists and is writable, the name is usable, and an existing file is only
  replaced with force, since its content cannot be compared yet), so nothing is computed and then
  lost.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import stat
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from dhkin.errors import FileWriteError, InputError

#: Temporary files are named ``.<file name>.<random hex><TEMPORARY_SUFFIX>`` in the destination's
#: folder (hidden, and recognisable if a crash ever leaves one behind).
TEMPORARY_SUFFIX = ".dhkin-tmp"
#: Random bytes in a temporary file's name (hex-encoded): enough that two writers never collide.
TEMPORARY_TOKEN_BYTES = 6
#: Permission bits of a new file before the umask, as ``open()`` gives them.
NEW_FILE_MODE = 0o666
#: What every refusal to replace a file suggests instead.
FORCE_HINT = "a new name, or --force (force=True in Python) to replace it"


@dataclass(frozen=True)
class _Destination:
    """One file to write: where, what, and how (``stream``: write into an existing device)."""

    path: Path
    content: bytes
    stream: bool


def as_path(path: str | os.PathLike[str], field: str = "output") -> Path:
    """``path`` as a Path; InputError for an empty name (``Path("")`` would be the current folder,
    so ``-o ""`` would silently write there)."""
    if not os.fspath(path).strip():
        raise InputError(f"{field}: expected a file or folder name, got an empty string",
                         field=field, value=os.fspath(path), expected="a non-empty path")
    return Path(path)


def _stat(path: Path) -> os.stat_result | None:
    """lstat of ``path`` (the link itself, never its target), or None if nothing is there."""
    try:
        return os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise _write_error(path, exc, "cannot look at the destination") from exc


def _write_error(path: Path, exc: OSError, doing: str = "cannot write the file") -> FileWriteError:
    reason = exc.strerror or str(exc)
    error = FileWriteError(f"{path}: {doing} ({reason}); nothing was changed", field=str(path),
                           value=str(path), expected="a writable file")
    error.errno, error.strerror, error.filename = exc.errno, reason, str(path)
    return error


def _is_stream(info: os.stat_result) -> bool:
    return stat.S_ISCHR(info.st_mode) or stat.S_ISFIFO(info.st_mode)


def _usable(path: Path, field: str) -> os.stat_result | None:
    """The destination's lstat after the checks every write makes: not a link, not a folder (or
    anything else that is not a file or a stream), and its folder exists."""
    info = _stat(path)
    if info is not None and stat.S_ISLNK(info.st_mode):
        target = os.readlink(path)
        raise InputError(f"{field} {path}: is a symbolic link (to {target}); dhkin does not "
                         "write through links: expected a regular file or a new name",
                         field=field, value=str(path), expected="not a symbolic link")
    if info is not None and not (stat.S_ISREG(info.st_mode) or _is_stream(info)):
        raise InputError(f"{field} {path}: is a folder or special file; expected a file name",
                         field=field, value=str(path), expected="a file name")
    if info is None and not path.parent.is_dir():
        raise InputError(f"{field} {path}: folder {str(path.parent)!r} does not exist; expected "
                         "an existing folder", field=field, value=str(path),
                         expected="a file in an existing folder")
    return info


def _probe(folder: Path) -> None:
    """Create and remove a temporary file in ``folder``: FileWriteError if the system refuses
    (permissions, a read-only file system). Checking the mode bits would miss both."""
    probe = folder / f".dhkin-probe.{secrets.token_hex(TEMPORARY_TOKEN_BYTES)}{TEMPORARY_SUFFIX}"
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, NEW_FILE_MODE))
        os.unlink(probe)
    except OSError as exc:
        raise _write_error(folder, exc, "cannot write in this folder") from exc


def check_output(path: str | os.PathLike[str], field: str = "output",
                 force: bool = False) -> Path:
    """Check a destination before the run that produces it; the path.

    InputError for an empty name, a symbolic link, a folder, a missing folder or (without
    ``force``) an existing file; FileWriteError if the folder cannot be written. An existing
    device or pipe (``/dev/null``) passes."""
    file = as_path(path, field)
    info = _usable(file, field)
    if info is not None and _is_stream(info):
        return file
    if info is not None and not force:
        raise InputError(f"{field} {file}: the file exists; expected {FORCE_HINT}",
                         field=field, value=str(file), expected=FORCE_HINT)
    _probe(file.parent)
    return file


def _encode(content: str | bytes) -> bytes:
    return content.encode("utf-8") if isinstance(content, str) else content


def _plan(files: Mapping[Path, str | bytes], field: str, force: bool) -> list[_Destination]:
    """The files that need writing (an identical existing file needs none); InputError before
    anything is written if any destination is refused."""
    planned = []
    for path, content in files.items():
        data = _encode(content)
        info = _usable(path, field)
        if info is not None and _is_stream(info):
            planned.append(_Destination(path, data, stream=True))
            continue
        if info is not None:
            try:
                if path.read_bytes() == data:
                    continue
            except OSError as exc:
                raise _write_error(path, exc, "cannot read the existing file") from exc
            if not force:
                raise InputError(f"{field} {path}: the file exists with other content; "
                                 f"expected {FORCE_HINT}", field=field, value=str(path),
                                 expected=FORCE_HINT)
        planned.append(_Destination(path, data, stream=False))
    return planned


def _write_all(fd: int, data: bytes) -> None:
    """Write every byte of ``data`` to ``fd`` (os.write may write less than asked)."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def _write_temporary(destination: _Destination) -> Path:
    """``destination``'s content in a new temporary file beside it, flushed to the disk, with
    the permission bits of the file it will replace (or a new file's); FileWriteError (the
    temporary file removed) if the system refuses."""
    path = destination.path
    temporary = path.with_name(
        f".{path.name}.{secrets.token_hex(TEMPORARY_TOKEN_BYTES)}{TEMPORARY_SUFFIX}")
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(temporary, flags, NEW_FILE_MODE)
    except OSError as exc:
        raise _write_error(path, exc) from exc
    try:
        try:
            _write_all(fd, destination.content)
            os.fsync(fd)
            with contextlib.suppress(FileNotFoundError):
                os.chmod(temporary, stat.S_IMODE(os.stat(path).st_mode))
        finally:
            os.close(fd)
    except BaseException as exc:  # an interrupt too: never leave the temporary file
        temporary.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise _write_error(path, exc) from exc
        raise
    return temporary


def _sync_folder(folder: Path) -> None:
    """Flush ``folder``'s entries (the renames) to the disk, where the system allows it."""
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def write_files(files: Mapping[Path, str | bytes], field: str = "output",
                force: bool = False) -> list[Path]:
    """Write several files (text as UTF-8) under the rules of the module docstring, all or none:
    every destination is checked, then every content is written to a temporary file, and only
    then do they replace their destinations. Returns the paths, in the order given."""
    paths = [as_path(path, field) for path in files]
    planned = _plan(dict(zip(paths, files.values(), strict=True)), field, force)
    temporaries: dict[Path, Path] = {}
    try:
        for destination in planned:
            if not destination.stream:
                temporaries[destination.path] = _write_temporary(destination)
        for destination in planned:
            if destination.stream:
                _write_stream(destination)
            else:
                try:
                    os.replace(temporaries.pop(destination.path), destination.path)
                except OSError as exc:
                    raise _write_error(destination.path, exc) from exc
    finally:
        for temporary in temporaries.values():
            temporary.unlink(missing_ok=True)
    for folder in {destination.path.parent for destination in planned}:
        _sync_folder(folder)
    return paths


def _write_stream(destination: _Destination) -> None:
    try:
        with open(destination.path, "wb") as stream:
            stream.write(destination.content)
    except OSError as exc:
        raise _write_error(destination.path, exc) from exc


def write_file(path: str | os.PathLike[str], content: str | bytes, field: str = "output",
               force: bool = False) -> Path:
    """Write one file (text as UTF-8) under the rules of the module docstring; the path."""
    return write_files({as_path(path, field): content}, field, force)[0]


def unused_name(path: str | os.PathLike[str], content: str | bytes) -> Path:
    """``path`` if it is free or holds ``content`` already, else the first free (or identical)
    ``<stem>-2<suffix>``, ``<stem>-3<suffix>``, ...: for a default file name, which must not
    replace an earlier result without being asked to."""
    first = Path(path)
    data = _encode(content)
    candidate, number = first, 1
    while True:
        info = _stat(candidate)
        if info is None or _is_stream(info):
            return candidate
        if stat.S_ISREG(info.st_mode):
            with contextlib.suppress(OSError):
                if candidate.read_bytes() == data:
                    return candidate
        number += 1
        candidate = first.with_name(f"{first.stem}-{number}{first.suffix}")


def make_folder(path: str | os.PathLike[str], field: str = "output") -> list[Path]:
    """Create the output folder ``path`` and its missing parents; the folders created, outermost
    first (none if it existed). InputError if ``path`` or a parent is a file."""
    folder = as_path(path, field)
    missing = []
    for candidate in (folder, *folder.parents):
        if candidate.is_dir():
            break
        if candidate.exists() or candidate.is_symlink():
            raise InputError(f"{field} {folder}: {candidate} is not a folder; expected a folder "
                             "name", field=field, value=str(folder), expected="a folder")
        missing.append(candidate)
    created: list[Path] = []
    try:
        for candidate in reversed(missing):
            candidate.mkdir()
            created.append(candidate)
    except OSError as exc:
        remove_folders(created)
        raise _write_error(folder, exc, "cannot create the folder") from exc
    return created


def remove_folders(created: Sequence[Path]) -> None:
    """Remove the folders :func:`make_folder` created (innermost first), where still empty."""
    for folder in reversed(created):
        with contextlib.suppress(OSError):
            folder.rmdir()


@contextlib.contextmanager
def output_folder(path: str | os.PathLike[str], field: str = "output") -> Iterator[Path]:
    """The output folder ``path``, created if needed; the folders created here are removed again
    (if empty) when the block fails, so a failed export leaves no empty folder behind."""
    created = make_folder(path, field)
    try:
        yield Path(path)
    except BaseException:
        remove_folders(created)
        raise
