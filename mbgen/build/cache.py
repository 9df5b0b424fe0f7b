"""The folder of compiled modules: where it is, whom it belongs to, what vouches for a file.

A compiled module is a shared library: loading it runs its code in this process, so the
cache trusts a file only when nobody but its user could have put it there -- the rule
ssh applies to ``~/.ssh`` and pip to its private folders:

* A cache folder is created 0700.  A folder owned by another user (root aside, like
  ssh), or one that group or others may write, is refused with a
  :class:`~mbgen.errors.CacheError` naming it, its owner and mode, and the fix
  (``chmod go-w`` or ``$MBGEN_CACHE_DIR``).  The check runs on every use, not only when
  the folder is made: a folder opened up later is refused too.
* A cache folder reached through a symbolic link that another user owns (the folder
  itself, or any folder on the way) is refused the same way: its owner can point it
  elsewhere at any moment.  :func:`real_folder` resolves the path link by link, checking
  each, and the cache is then used by its real path.
* A module is loaded only when it and its record are owned by the user, not writable by
  group or others, and the module's size and SHA-256 match the record
  (``<module>.sha256``, written by the build after the module).  Anything else is
  rebuilt: a changed file, even of the same size and modification time, a truncated one
  (mapping it was a SIGBUS), an empty one.
* The checked bytes are the loaded bytes (:func:`open_verified`, :func:`loadable`): the
  module is opened once (``O_NOFOLLOW``, in its folder's open descriptor), the owner, mode
  and SHA-256 are those of that open file, and the loader maps the same open file; a swap
  of the name after the check (7 of 300 loads ran a planted library when the check and
  the load each opened the path) changes nothing.
* A read-only cache that holds the module loads it; one that does not is a
  ``CacheError`` (make it writable, or point ``$MBGEN_CACHE_DIR`` elsewhere).  A default
  folder (``~/.cache/mbgen``) that cannot be made or written falls back to
  ``<tempdir>/mbgen-cache-<uid>``, which passes the same checks (another user may have
  made it first: it is then refused, never used).
* A full disk (ENOSPC, or a quota) is a ``CacheError`` naming the folder, whether the
  compiler or mbgen's own writes hit it.

Builds happen in a folder of their own (``<module>-<random>``) holding an ``owner`` file
(host and process id); :func:`remove_stale_builds` removes those of killed builds.

The warm cache's records (:mod:`mbgen.build.warm`: pickled rendered code, which runs code
when read, as a module does when loaded) are written and read under the same rules
(:func:`write_verified`, :func:`read_verified`).
"""

from __future__ import annotations

import errno
import getpass
import hashlib
import os
import shutil
import socket
import stat
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import CacheError

try:
    import pwd
except ImportError:  # Windows: no user ids, no owner check
    pwd = None

#: A build folder whose owner cannot be checked is stale after this many seconds.
STALE_AFTER = 24 * 3600.0

#: Symbolic links followed at most while resolving the cache folder (Linux's own limit).
MAX_LINKS = 40

#: ``O_NOFOLLOW`` where the system has it: a module or record that is a link is not opened.
NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)

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


def real_folder(path: Path) -> Path:
    """``path`` with its symbolic links resolved one by one, each checked to be the user's
    (or root's); the part that does not exist yet is kept as written.

    A link is a name its owner may point elsewhere at any moment (even between a check and
    a load), so a cache reached through another user's link is theirs, as a folder they
    own would be: a :class:`~mbgen.errors.CacheError` names the link and its owner.
    """
    uid = _uid()
    whole = path if path.is_absolute() else Path(os.getcwd(), path)
    here, todo, hops = Path(whole.anchor), list(reversed(whole.parts[1:])), 0
    while todo:
        name = todo.pop()
        if name == "..":
            here = here.parent
            continue
        step = here / name
        try:
            info = os.lstat(step)
        except OSError:                 # missing (made next) or not a folder: said later
            return step.joinpath(*reversed(todo))
        if not stat.S_ISLNK(info.st_mode):
            here = step
            continue
        if uid is not None and info.st_uid not in (uid, 0):
            raise CacheError(f"the cache folder {path} is reached through the link {step}, "
                             f"owned by {_owner(info.st_uid)}, not by you: its owner can point "
                             f"it elsewhere at any moment; set MBGEN_CACHE_DIR to a folder of "
                             f"your own, reached without another user's links")
        hops += 1
        if hops > MAX_LINKS:
            raise CacheError(f"the cache folder {path} cannot be reached: more than "
                             f"{MAX_LINKS} links (a loop?); set MBGEN_CACHE_DIR to a real folder")
        target = Path(os.readlink(step))
        if target.is_absolute():
            here = Path(target.anchor)
        todo.extend(reversed(target.parts[1:] if target.is_absolute() else target.parts))
    return here


def _make_folder(root: Path) -> str | None:
    """``None`` when ``root`` is (made, 0700) a folder, else why not."""
    try:
        root.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError as exc:
        return f"{exc.strerror or exc}"
    return None if root.is_dir() else "not a folder"


def writable(root: Path) -> bool:
    return os.access(root, os.W_OK | os.X_OK)


def require_writable(target: Path) -> None:
    """Raise :class:`~mbgen.errors.CacheError` unless ``target``'s folder can take a new
    build (a read-only cache may serve what it holds, never build what it lacks)."""
    root = target.parent
    if not writable(root):
        raise CacheError(f"the cache folder {root} is read-only and holds no usable "
                         f"{target.name}; make it writable or point MBGEN_CACHE_DIR at a "
                         f"writable folder")


def cache_dir() -> Path:
    """Folder of compiled modules: ``$MBGEN_CACHE_DIR`` or ``~/.cache/mbgen``, checked private.

    A default folder that cannot be made or written falls back to
    ``<tempdir>/mbgen-cache-<user id>``.  ``$MBGEN_CACHE_DIR`` may be read-only.  The
    folder is returned by its real path (:func:`real_folder`, resolved again after it is
    made, so that a link planted in its place meanwhile is checked too).

    Raises
    ------
    CacheError
        The folder cannot be made, others could write it (see :func:`check_private`), or
        it is reached through another user's link.
    """
    env = os.environ.get("MBGEN_CACHE_DIR")
    if env:
        root, why = _made(Path(env))
        if why:
            raise CacheError(f"the cache folder MBGEN_CACHE_DIR={env!r} cannot be used ({why}); "
                             f"point MBGEN_CACHE_DIR at a writable folder or unset it")
        return check_private(root)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    root, why = _made(Path(base) / "mbgen")
    if why is None and writable(root):
        return check_private(root)
    user = os.getuid() if hasattr(os, "getuid") else getpass.getuser()
    fallback, why2 = _made(Path(tempfile.gettempdir()) / f"mbgen-cache-{user}")
    why2 = why2 or (None if writable(fallback) else "not writable")
    if why2:
        raise CacheError(f"no writable cache folder: {root} ({why or 'not writable'}), "
                         f"{fallback} ({why2}); set MBGEN_CACHE_DIR to a writable folder")
    return check_private(fallback)


def _made(path: Path) -> tuple[Path, str | None]:
    """(the real path of ``path``, None) once it is a folder (made 0700 if missing), else
    (the path, why not).  Resolved again after making: a link put in its way meanwhile is
    checked too."""
    why = _make_folder(real_folder(path))
    return real_folder(path), why


def record_path(path: Path) -> Path:
    return path.with_name(path.name + ".sha256")


def _digest(fd: int) -> str:
    """``"<size> <sha256>"`` of the bytes of the open file ``fd``, read from its start."""
    h = hashlib.sha256()
    size = 0
    os.lseek(fd, 0, os.SEEK_SET)
    for block in iter(lambda: os.read(fd, 1 << 20), b""):
        h.update(block)
        size += len(block)
    return f"{size} {h.hexdigest()}"


def fingerprint(path: Path) -> str:
    """``"<size> <sha256>"`` of the file at ``path``."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_BINARY", 0))
    try:
        return _digest(fd)
    finally:
        os.close(fd)


def write_record(module: Path, record: Path) -> None:
    """Record ``module``'s fingerprint in ``record``; neither writable by group or others."""
    record.write_text(fingerprint(module) + "\n")
    for path in (module, record):
        os.chmod(path, os.stat(path).st_mode & ~(stat.S_IWGRP | stat.S_IWOTH))


def _open_plain(name: str, folder: Path, folder_fd: int | None) -> tuple[int, os.stat_result]:
    """Open the regular file ``name`` of ``folder`` read-only, never through a link (in the
    folder's descriptor where the system allows; a pipe does not block); an OSError if it
    is not a regular file."""
    flags = os.O_RDONLY | NOFOLLOW | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    fd = os.open(name, flags, dir_fd=folder_fd) if folder_fd is not None else \
        os.open(folder / name, flags)
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode):
        os.close(fd)
        raise IsADirectoryError(errno.EISDIR, "not a regular file", name)
    return fd, info


def open_verified(path: Path) -> int | None:
    """A read-only descriptor of the module at ``path`` when it is the user's own build,
    whole and unchanged, else None (the caller closes it).

    Every check is made on what is open, not on the name: the folder is opened, then the
    record and the module in it (``O_NOFOLLOW``); the three are owned by the user (or root)
    and not writable by group or others, and the module's size and SHA-256 (every byte,
    read from this descriptor: a same-size change with its modification time restored is
    caught; SHA-256 costs about 0.06 ms per 100 KB) are the recorded ones.  Loading from
    the descriptor (:func:`loadable`) thus loads these bytes.
    """
    at = os.open in os.supports_dir_fd and hasattr(os, "O_DIRECTORY")
    folder_fd = fd = None
    try:
        if at:
            folder_fd = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY)
        if _foreign(os.fstat(folder_fd) if at else os.stat(path.parent)):
            return None
        record, info = _open_plain(record_path(path).name, path.parent, folder_fd)
        try:
            if _foreign(info):
                return None
            recorded = os.read(record, 256).decode("ascii").strip()
        finally:
            os.close(record)
        fd, info = _open_plain(path.name, path.parent, folder_fd)
        if _foreign(info) or info.st_size != int(recorded.split()[0]) or \
                _digest(fd) != recorded:       # the size first: a truncated or empty file
            return None
        fd, checked = None, fd
        return checked
    except (OSError, ValueError, IndexError):
        return None
    finally:
        for f in (fd, folder_fd):
            if f is not None:
                os.close(f)


def verified(path: Path) -> bool:
    """Whether the module at ``path`` is the user's own build, whole and unchanged (the
    checks of :func:`open_verified`)."""
    fd = open_verified(path)
    if fd is not None:
        os.close(fd)
    return fd is not None


def read_verified(path: Path) -> bytes | None:
    """The bytes of the file at ``path`` when it is the user's own, whole and unchanged (the
    checks of :func:`open_verified`, read from the checked descriptor), else None."""
    fd = open_verified(path)
    if fd is None:
        return None
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return b"".join(iter(lambda: os.read(fd, 1 << 20), b""))
    except OSError:
        return None
    finally:
        os.close(fd)


def write_verified(path: Path, data: bytes) -> None:
    """Put ``data`` at ``path`` in the cache with its record, as a build puts a module: in a
    private folder beside it (``<name>-<random>``, with its ``owner`` file, so that
    :func:`remove_stale_builds` removes a killed write's), then the file and after it the
    record moved in by atomic renames; a reader sees the old pair or the new one, and a file
    whose record does not match is never read (:func:`read_verified`).  An OSError as the
    disk says it."""
    folder = Path(tempfile.mkdtemp(prefix=f"{path.stem}-", dir=path.parent))
    try:
        (folder / "owner").write_text(owner_line())
        written, record = folder / path.name, folder / "record"
        written.write_bytes(data)
        write_record(written, record)
        os.replace(written, path)
        os.replace(record, record_path(path))       # after the file: it proves it whole
    finally:
        shutil.rmtree(folder, ignore_errors=True)


#: Where Linux shows a process's open files as paths (see :func:`loadable`); None elsewhere.
PROC_FD = "/proc/self/fd" if sys.platform.startswith("linux") else None
#: The descriptors of the modules loaded through :data:`PROC_FD`, kept open.
_PINNED: list[int] = []


def _shown_as(fd: int) -> str | None:
    """The :data:`PROC_FD` path of ``fd`` where it opens that very file, else None."""
    if PROC_FD is None:
        return None
    shown = f"{PROC_FD}/{fd}"
    try:
        a, b = os.stat(shown), os.fstat(fd)
    except OSError:
        return None
    return shown if (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino) else None


@contextmanager
def loadable(path: Path) -> Iterator[str | None]:
    """A path for the dynamic loader that holds exactly the checked bytes of the module at
    ``path`` (:func:`open_verified`), or None when the module is not the user's own build.

    Linux: ``/proc/self/fd/<n>`` of the checked descriptor.  Opening it opens that same
    file, whatever the name ``path`` means by then, so nothing can come between the check
    and the load (the file's bytes can change only by its owner, the user, or by root).
    The descriptor stays open for the life of the process: the library is never unloaded,
    and the dynamic loader knows it by that name, so a reused number would be taken for
    the library already loaded under it (one descriptor per module loaded).  Elsewhere, or
    without ``/proc``: a private copy of the checked bytes, in a new 0700 folder beside the
    module (in the temporary folder when the cache is read-only), removed once loaded.
    """
    fd = open_verified(path)
    if fd is None:
        yield None
        return
    shown = _shown_as(fd)
    if shown is not None:
        _PINNED.append(fd)
        yield shown
        return
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        data = b"".join(iter(lambda: os.read(fd, 1 << 20), b""))
    finally:
        os.close(fd)
    folder = Path(tempfile.mkdtemp(prefix="_mbgen_load-",
                                   dir=str(path.parent) if writable(path.parent) else None))
    try:
        copy = folder / path.name
        copy.write_bytes(data)
        yield str(copy)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


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
    for folder in root.glob("_mbgen_*-*"):  # a killed load's private copy too
        if folder.is_dir() and _stale(folder, now):
            shutil.rmtree(folder, ignore_errors=True)
            if not folder.exists():
                removed.append(folder)
    return removed
