"""The folder of compiled modules: where it is, whom it belongs to, what vouches for a file.

A compiled module is a shared library: loading it runs its code in this process, so the
cache trusts a file only when nobody but its user could have put it there -- the rule
ssh applies to ``~/.ssh`` and pip to its private folders:

* A cache folder is created 0700.  A folder owned by another user (root aside, like
  ssh), or one that group or others may write, is refused with a
  :class:`~mbgen.errors.CacheError` naming it, its owner and mode, and the fix
  (``chmod go-w`` or ``$MBGEN_CACHE_DIR``).  The check runs on every use, not only when
  the folder is made: a folder opened up later is refused too.
* A module is loaded only when it and its record are owned by the user, not writable by
  group or others, and the module's size and SHA-256 match the record
  (``<module>.sha256``, written by the build after the module).  Anything else is
  rebuilt: a changed file, even of the same size and modification time, a truncated one
  (mapping it was a SIGBUS), an empty one.
* A read-only cache that holds the module loads it; one that does not is a
  ``CacheError`` (make it writable, or point ``$MBGEN_CACHE_DIR`` elsewhere).  A default
  folder (``~/.cache/mbgen``) that cannot be made or written falls back to
  ``<tempdir>/mbgen-cache-<uid>``, which passes the same checks (another user may have
  made it first: it is then refused, never used).
* A full disk (ENOSPC, or a quota) is a ``CacheError`` naming the folder, whether the
  compiler or mbgen's own writes hit it.

Builds happen in a folder of their own (``<module>-<random>``) holding an ``owner`` file
(host and process id); :func:`remove_stale_builds` removes those of killed builds.
"""

from __future__ import annotations

import errno
import getpass
import hashlib
import os
import shutil
import socket
import stat
import tempfile
import time
from pathlib import Path

from ..errors import CacheError

try:
    import pwd
except ImportError:  # Windows: no user ids, no owner check
    pwd = None

#: A build folder whose owner cannot be checked is stale after this many seconds.
STALE_AFTER = 24 * 3600.0

#: errno values that mean "the disk (or the user's quota) is full".
DISK_FULL = tuple(e for e in (errno.ENOSPC, getattr(errno, "EDQUOT", None)) if e is not None)


def _uid() -> int | None:
    """The effective user id, or None where the platform has none (Windows)."""
    return os.geteuid() if hasattr(os, "geteuid") else None


def _owner(uid: int) -> str:
    try:
        return f"{pwd.getpwuid(uid).pw_name} (uid {uid})"
    except (AttributeError, KeyError):
        return f"uid {uid}"


def _foreign(info: os.stat_result) -> str | None:
    """Why a file or folder with this ``stat`` could hold something planted, else None."""
    uid = _uid()
    if uid is None:
        return None
    mode = oct(info.st_mode & 0o7777)
    if info.st_uid not in (uid, 0):
        return f"owned by {_owner(info.st_uid)}, not by you (mode {mode})"
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        who = " and ".join(w for w, bit in (("group", stat.S_IWGRP), ("others", stat.S_IWOTH))
                           if info.st_mode & bit)
        return f"writable by {who} (mode {mode})"
    return None


def check_private(root: Path) -> Path:
    """``root`` if only its owner (the user, or root) can write it, else a CacheError."""
    why = _foreign(os.stat(root))
    if why is None:
        return root
    fix = ("set MBGEN_CACHE_DIR to a folder of your own" if why.startswith("owned") else
           f"run 'chmod go-w {root}' or set MBGEN_CACHE_DIR to a folder of your own")
    raise CacheError(f"the cache folder {root} is {why}: a library planted there would run "
                     f"when loaded; {fix}")


def _make_folder(root: Path) -> str | None:
    """``None`` when ``root`` is (made, 0700) a folder, else why not."""
    try:
        root.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError as exc:
        return f"{exc.strerror or exc}"
    return None if root.is_dir() else "not a folder"


def writable(root: Path) -> bool:
    return os.access(root, os.W_OK | os.X_OK)


def cache_dir() -> Path:
    """Folder of compiled modules: ``$MBGEN_CACHE_DIR`` or ``~/.cache/mbgen``, checked private.

    A default folder that cannot be made or written falls back to
    ``<tempdir>/mbgen-cache-<user id>``.  ``$MBGEN_CACHE_DIR`` may be read-only.

    Raises
    ------
    CacheError
        The folder cannot be made, or others could write it (see :func:`check_private`).
    """
    env = os.environ.get("MBGEN_CACHE_DIR")
    if env:
        root = Path(env)
        why = _make_folder(root)
        if why:
            raise CacheError(f"the cache folder MBGEN_CACHE_DIR={env!r} cannot be used ({why}); "
                             f"point MBGEN_CACHE_DIR at a writable folder or unset it")
        return check_private(root)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    root = Path(base) / "mbgen"
    why = _make_folder(root)
    if why is None and writable(root):
        return check_private(root)
    user = os.getuid() if hasattr(os, "getuid") else getpass.getuser()
    fallback = Path(tempfile.gettempdir()) / f"mbgen-cache-{user}"
    why2 = _make_folder(fallback) or (None if writable(fallback) else "not writable")
    if why2:
        raise CacheError(f"no writable cache folder: {root} ({why or 'not writable'}), "
                         f"{fallback} ({why2}); set MBGEN_CACHE_DIR to a writable folder")
    return check_private(fallback)


def record_path(path: Path) -> Path:
    return path.with_name(path.name + ".sha256")


def fingerprint(path: Path) -> str:
    """``"<size> <sha256>"`` of the file at ``path``."""
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
            size += len(block)
    return f"{size} {h.hexdigest()}"


def write_record(module: Path, record: Path) -> None:
    """Record ``module``'s fingerprint in ``record``; neither writable by group or others."""
    record.write_text(fingerprint(module) + "\n")
    for path in (module, record):
        os.chmod(path, os.stat(path).st_mode & ~(stat.S_IWGRP | stat.S_IWOTH))


def verified(path: Path) -> bool:
    """Whether the module at ``path`` is the user's own build, whole and unchanged.

    The module, its record and their folder are owned by the user (or root) and not
    writable by group or others, and the module's size and SHA-256 are the recorded ones
    (every byte is hashed: a same-size change with its modification time restored is
    caught; SHA-256 costs about 0.06 ms per 100 KB).
    """
    try:
        record = record_path(path)
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode) or any(
                _foreign(i) for i in (info, os.stat(record), os.stat(path.parent))):
            return False
        recorded = record.read_text().strip()
        if info.st_size != int(recorded.split()[0]):
            return False  # cheap first: a truncated or empty file
        return fingerprint(path) == recorded
    except (OSError, ValueError, IndexError):
        return False


def disk_error(exc: OSError, root: Path, name: str) -> CacheError:
    """The CacheError for an OSError met while building ``name`` in ``root``."""
    if exc.errno in DISK_FULL:
        return disk_full(root, name, exc.strerror or str(exc))
    return CacheError(f"cannot build {name} in the cache folder {root}: {exc.strerror or exc}"
                      f"{f' ({exc.filename})' if exc.filename else ''}; make it writable or "
                      f"set MBGEN_CACHE_DIR to a writable folder")


def disk_full(root: Path, name: str, detail: str) -> CacheError:
    return CacheError(f"no space left on device (disk full) while building {name} in the cache "
                      f"folder {root} [{detail.strip()}]; free some space (there and in the "
                      f"temporary folder {tempfile.gettempdir()}) or set MBGEN_CACHE_DIR to a "
                      f"folder on another disk")


def mentions_full_disk(text: str) -> str | None:
    """The line of a compiler's output that says the disk is full, or None."""
    signs = tuple(os.strerror(e).lower() for e in DISK_FULL)
    return next((line for line in text.splitlines() if any(s in line.lower() for s in signs)),
                None)


def owner_line() -> str:
    """What a build folder's ``owner`` file holds: ``"<host> <pid>"``."""
    return f"{socket.gethostname()} {os.getpid()}\n"


def _stale(folder: Path, now: float) -> bool:
    """A build folder left by a build that no longer runs."""
    try:
        host, pid = (folder / "owner").read_text().split()
        if host == socket.gethostname():
            try:
                os.kill(int(pid), 0)
            except ProcessLookupError:
                return True
            except (PermissionError, ValueError):
                pass
            else:
                return False
    except (OSError, ValueError):
        pass
    try:
        return now - folder.stat().st_mtime > STALE_AFTER
    except OSError:
        return False


def remove_stale_builds(root: Path | None = None) -> list[Path]:
    """Remove the build folders (``_mbgen_*-*``) of killed builds; return what was removed."""
    root = root or cache_dir()
    now = time.time()
    removed = []
    for folder in root.glob("_mbgen_*-*"):
        if folder.is_dir() and _stale(folder, now):
            shutil.rmtree(folder, ignore_errors=True)
            if not folder.exists():
                removed.append(folder)
    return removed
