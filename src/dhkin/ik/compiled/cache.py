"""Where numba caches the compiled IK kernels, so that IK also works from a read-only install
(a system package, a Docker image, a user who cannot write the package folder).

numba caches a ``cache=True`` kernel beside its source (``__pycache__``), else in
``~/.cache/numba``; where neither can be written, decorating the kernel raises ``RuntimeError:
cannot cache function ...: no locator available``, and dhkin's IK failed to import. The folder
is chosen once per process, before the first kernel is decorated, the first of these that can be
written (:func:`choose`):

1. ``$NUMBA_CACHE_DIR`` when set (numba's own setting; numba places the kernels there);
2. the package's own ``ik/compiled/__pycache__`` (numba's default);
3. ``$XDG_CACHE_HOME/dhkin/numba/<key>``, else ``~/.cache/dhkin/numba/<key>``, where ``<key>``
   names the installation (two virtual environments never share or fight over one folder);
4. ``<temporary folder>/dhkin-<uid>/numba/<key>``: a folder of this user's own (mode 0700; one
   owned by someone else, or open to others, is not used, since numba's cache files are pickles);
5. none: the kernels are compiled in memory in every process (a slower first IK call), said once
   in one line on the ``dhkin`` logger.

Cases 3 and 4 register a cache locator for this package's files only (numba's locator list is a
private hook; where this numba has none, case 5 applies instead). A pre-built cache inside a
read-only package (made when the image was built: run one IK as the installing user) is copied
into the folder of case 3 or 4 on first use when its stamp matches the sources, so that a new
user loads the kernels instead of compiling them.

Cache guard: numba's on-disk cache checks only the source file of the function it compiled, so a
kernel calling a helper from another module of this package would keep a stale copy of that
helper after an edit. :func:`guard` hashes every module of the package and, when the hash differs
from the one stored beside the cache, deletes the cache files before anything is compiled or
loaded. Where the folder cannot be written, nothing is deleted.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import secrets
import shutil
import stat
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: File beside numba's cache files recording the hash of the sources they were compiled from.
STAMP_NAME = "dhkin-kernels.sha256"
#: numba's cache files: the index of each kernel and its compiled code.
CACHE_PATTERNS = ("*.nbi", "*.nbc")
#: Folder of dhkin's kernels under a user's cache folder ($XDG_CACHE_HOME or ~/.cache).
USER_SUBFOLDER = Path("dhkin") / "numba"
#: Characters of the hash of the package's path that name an installation's cache folder.
KEY_LENGTH = 16
#: Permission bits of the folders created for the cache: the user's own.
PRIVATE_MODE = 0o700
#: Where each choice of :func:`choose` comes from (CacheChoice.kind).
KINDS = ("numba-cache-dir", "package", "user", "temporary", "none")

logger = logging.getLogger("dhkin")


@dataclass(frozen=True)
class CacheChoice:
    """Where the kernels are cached: ``folder`` (None: not cached, compiled in memory) and
    ``kind``, one of :data:`KINDS`. ``prebuilt`` is the package's own cache folder when it holds
    a pre-built cache the chosen folder can be seeded from."""

    folder: Path | None
    kind: str
    prebuilt: Path | None = None


def source_hash(folder: Path) -> str:
    """SHA-256 of the names and contents of every ``*.py`` file in ``folder``, sorted by name."""
    digest = hashlib.sha256()
    for path in sorted(folder.glob("*.py")):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _stamp(folder: Path) -> str | None:
    try:
        return (folder / STAMP_NAME).read_text(encoding="ascii").strip()
    except (OSError, UnicodeDecodeError):
        return None


def writable(folder: Path) -> bool:
    """Whether files can be created in ``folder`` (made, with its parents, if missing): tried,
    as numba does, since permission bits say nothing of a read-only file system or of root."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError:
        return False
    return True


def _installation_key(package: Path) -> str:
    return hashlib.sha256(str(package).encode()).hexdigest()[:KEY_LENGTH]


def user_roots(environ: Mapping[str, str]) -> list[Path]:
    """The user's cache folders for dhkin, in order: $XDG_CACHE_HOME (if absolute, as the XDG
    specification says), then ~/.cache."""
    roots = []
    xdg = environ.get("XDG_CACHE_HOME", "")
    if os.path.isabs(xdg):
        roots.append(Path(xdg) / USER_SUBFOLDER)
    home = environ.get("HOME") or os.path.expanduser("~")
    if os.path.isabs(home):
        roots.append(Path(home) / ".cache" / USER_SUBFOLDER)
    return roots


def _private_folder(root: Path) -> Path | None:
    """``root/dhkin-<uid>``, created for this user alone, or None when it cannot be, or when
    what is there is a link, is someone else's or is open to others."""
    folder = root / f"dhkin-{os.geteuid()}"
    with contextlib.suppress(FileExistsError, OSError):
        folder.mkdir(mode=PRIVATE_MODE)
    try:
        info = os.lstat(folder)
    except OSError:
        return None
    if (not stat.S_ISDIR(info.st_mode) or info.st_uid != os.geteuid()
            or info.st_mode & 0o077):
        return None
    return folder


def _numba_cache_dir(package: Path) -> Path | None:
    """numba's folder for this package's kernels under $NUMBA_CACHE_DIR, if set."""
    from numba.core import caching, config

    root = getattr(config, "CACHE_DIR", "")  # set from $NUMBA_CACHE_DIR when numba loads
    if not root:
        return None
    locator = getattr(caching, "UserProvidedCacheLocator", None) or getattr(
        caching, "_UserProvidedCacheLocator", None)
    subpath = (locator.get_suitable_cache_subpath(str(package / "jit.py")) if locator
               else f"{package.name}_{hashlib.sha1(str(package).encode()).hexdigest()}")
    return Path(root) / subpath


def choose(package: Path, environ: Mapping[str, str] | None = None,
           temporary_root: Path | None = None) -> CacheChoice:
    """The cache folder for the kernels in ``package`` (see the module docstring); ``environ``
    and ``temporary_root`` default to the process's environment and temporary folder."""
    environ = os.environ if environ is None else environ
    numba_folder = _numba_cache_dir(package)
    if numba_folder is not None and writable(numba_folder):
        return CacheChoice(numba_folder, "numba-cache-dir")
    in_tree = package / "__pycache__"
    if writable(in_tree):
        return CacheChoice(in_tree, "package")
    prebuilt = in_tree if _stamp(in_tree) == source_hash(package) else None
    key = _installation_key(package)
    for root in user_roots(environ):
        if writable(root / key):
            return CacheChoice(root / key, "user", prebuilt)
    if temporary_root is None:
        try:
            temporary_root = Path(tempfile.gettempdir())
        except OSError:  # "No usable temporary directory found"
            return CacheChoice(None, "none")
    private = _private_folder(temporary_root)
    if private is not None and writable(private / "numba" / key):
        return CacheChoice(private / "numba" / key, "temporary", prebuilt)
    return CacheChoice(None, "none")


def guard(package: Path, folder: Path, prebuilt: Path | None = None) -> None:
    """Delete the cache files in ``folder`` when the package's sources changed since they were
    made (their stamp differs); then copy in a ``prebuilt`` cache of these sources, if given.
    Nothing happens where ``folder`` cannot be written."""
    current = source_hash(package)
    if _stamp(folder) == current:
        return
    try:
        if folder.is_dir():
            for pattern in CACHE_PATTERNS:
                for path in folder.glob(pattern):
                    path.unlink(missing_ok=True)
        folder.mkdir(parents=True, exist_ok=True)
        if prebuilt is not None and prebuilt != folder:
            _copy_cache(prebuilt, folder)
        (folder / STAMP_NAME).write_text(current + "\n", encoding="ascii")
    except OSError:  # read-only: leave the cache as it is
        return


def _copy_cache(source: Path, folder: Path) -> None:
    """Copy numba's cache files from ``source`` into ``folder``, each through a temporary name
    and a rename, so that a process loading the cache meanwhile never reads half a file."""
    for pattern in CACHE_PATTERNS:
        for path in source.glob(pattern):
            partial = folder / f".{path.name}.{secrets.token_hex(6)}.partial"
            try:
                shutil.copyfile(path, partial)
                os.replace(partial, folder / path.name)
            finally:
                partial.unlink(missing_ok=True)


def _locator_hook() -> tuple[Any, Any, Any] | None:
    """numba's locator list and the two base classes a locator is made of, or None where this
    numba has none of them (private names; they lost their underscore in numba 0.62)."""
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    mixin = getattr(caching, "_SourceFileBackedLocatorMixin", None)
    base = getattr(caching, "_CacheLocator", None)
    if impl is None or mixin is None or base is None or not isinstance(
            getattr(impl, "_locator_classes", None), list):
        return None
    return impl._locator_classes, mixin, base


def register_locator(package: Path, folder: Path) -> bool:
    """Make numba cache the kernels whose source is in ``package`` in ``folder`` (first in its
    locator list; other files are left to numba's own locators). False where this numba offers
    no such hook."""
    hook = _locator_hook()
    if hook is None:
        return False
    classes, mixin, base = hook
    classes[:] = [c for c in classes if not getattr(c, "dhkin_locator", False)]

    class DhkinCacheLocator(mixin, base):  # type: ignore[misc, valid-type]
        """numba's cache of dhkin's kernels in a folder chosen by dhkin.ik.compiled.cache."""

        dhkin_locator = True

        def __init__(self, py_func: Any, py_file: str) -> None:
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno

        def get_cache_path(self) -> str:
            return str(folder)

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if Path(os.path.realpath(py_file)).parent != package:
                return None
            return super().from_function(py_func, py_file)

    classes.insert(0, DhkinCacheLocator)
    return True


_choice: CacheChoice | None = None


def prepare(package: Path | None = None) -> CacheChoice:
    """Choose the cache folder (once per process), clean or seed it, and tell numba; the
    choice. Called when :mod:`dhkin.ik.compiled` is imported, before any kernel exists."""
    global _choice
    if _choice is not None:
        return _choice
    package = Path(os.path.realpath(package or Path(__file__).parent))
    choice = choose(package)
    if choice.kind in ("user", "temporary") and choice.folder is not None and \
            not register_locator(package, choice.folder):
        choice = CacheChoice(None, "none")
    if choice.folder is not None:
        guard(package, choice.folder, choice.prebuilt)
    else:
        logger.warning("dhkin: warning: no writable folder for the compiled IK kernels (not the "
                       "package, $XDG_CACHE_HOME, ~/.cache nor the temporary folder): they are "
                       "compiled in memory in every process (a slow first IK call); set "
                       "NUMBA_CACHE_DIR to a writable folder to keep them")
    _choice = choice
    return choice


def caching_enabled() -> bool:
    """Whether kernels are cached on disk (``cache=True``) in this process."""
    return prepare().folder is not None
