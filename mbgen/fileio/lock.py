"""The lock of an output folder: one generation writes it at a time.

``<parent>/.<name>.lock`` is locked with ``fcntl.flock`` (:func:`generation_lock`); the
kernel releases it when its process ends, however it ends.  A second generation into the
folder waits up to :data:`LOCK_WAIT` s, then raises ``OutputBusyError``.  The lock is
opened ``O_NOFOLLOW`` and must be a regular file of the user's (:func:`_open_lock`):
whoever can write the parent folder could otherwise plant a link there and make the user
(root, say) create a file wherever it points.  Without ``fcntl`` (Windows) the file is
created with ``O_CREAT | O_EXCL``; a killed run leaves it there, and the refusal names it
for the user to delete.

The folder's siblings (the lock, :mod:`~mbgen.fileio.generations`' folders written aside)
take its name and at most 14 more bytes; a legal name too long for that is shortened in
them (:func:`sibling_stem`).
"""

from __future__ import annotations

import os
import stat
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

try:
    import fcntl
except ImportError:                                        # Windows
    fcntl = None

from ..errors import OutputBusyError, OutputPathError
from .files import digest

#: Seconds a generation waits for another one writing the same folder before it refuses.
LOCK_WAIT = 30.0

#: Bytes in a file name, where the system does not say (``pathconf``'s ``PC_NAME_MAX``).
NAME_MAX = 255

#: ``open`` flags of the lock: never through a link; a named pipe planted there does not block.
_LOCK_FLAGS = os.O_RDWR | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)


def output_folder(folder: Path) -> Path:
    """The real path of the output folder (symbolic links resolved), checked: a folder (or
    nothing yet), below the root, each name in it no longer than the system allows."""
    most = _name_max(folder.parent)
    for part in folder.parts:
        if len(os.fsencode(part)) > most:
            raise OutputPathError(f"the name {part[:40]!r}... in the output folder is "
                                  f"{len(os.fsencode(part))} bytes long, and a name here has "
                                  f"at most {most}; choose a shorter one")
    try:
        if folder.exists() and not folder.is_dir():
            raise OutputPathError(f"output folder {str(folder)!r} is a file; give a folder "
                                  f"with -o")
        target = folder.resolve()
    except FileNotFoundError:       # the working folder is gone: a generation replaced it?
        raise OutputPathError("the current folder no longer exists (did a generation replace "
                              "it?); run 'cd .' to enter the folder now at its path") from None
    except OSError as exc:
        raise OutputPathError(f"cannot use {str(folder)!r} as the output folder: "
                              f"{exc.strerror or exc}") from None
    if not target.name:
        raise OutputPathError(f"cannot generate into {str(folder)!r}: choose a folder below it")
    return target


def _name_max(folder: Path) -> int:
    """The most bytes a file name may have in ``folder`` (or its nearest existing parent)."""
    for place in (folder, *folder.parents):
        with suppress(OSError, ValueError, AttributeError):
            return os.pathconf(place, "PC_NAME_MAX")
    return NAME_MAX


def sibling_stem(target: Path) -> str:
    """``target``'s name as its siblings (``.<stem>.lock``, ``.<stem>.new-XXXXXXXX``) hold it:
    the name itself, or, for a name that leaves no room for their 14 more bytes (a legal
    name of 242 bytes or more), its first 200 bytes and a hash of the whole."""
    name = os.fsencode(target.name)
    if len(name) + 14 <= NAME_MAX:
        return target.name
    return f"{os.fsdecode(name[:200])}~{digest(name)[:16]}"


@contextmanager
def generation_lock(folder, wait: float = LOCK_WAIT) -> Iterator[None]:
    """Hold the lock ``<parent>/.<name>.lock`` of the output folder ``folder`` (removed on
    release); wait up to ``wait`` seconds for another holder, then raise OutputBusyError."""
    target = output_folder(Path(folder))
    lock = target.parent / f".{sibling_stem(target)}.lock"
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd = _acquire(lock, time.monotonic() + wait, target)
    except OSError as exc:
        raise OutputPathError(f"cannot write beside {str(target)!r} (its lock {lock.name}): "
                              f"{exc.strerror or exc}; choose a folder whose parent you can "
                              f"write") from None
    try:
        yield
    finally:                       # flock: unlink first, so a waiter that opened it retries
        if fcntl is None:
            os.close(fd)
        with suppress(FileNotFoundError):
            os.unlink(lock)
        if fcntl is not None:
            os.close(fd)


def _acquire(lock: Path, deadline: float, target: Path) -> int:
    """The descriptor of ``lock``, locked; waits until ``deadline`` for another holder.  A lock
    taken on a file that its last holder had already removed (opened before the removal) is
    no lock: the file now at that name, if any, is another, so the loop opens it again."""
    while True:
        if fcntl is None:
            with suppress(FileExistsError):
                return os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666)
        else:
            fd = _open_lock(lock, target)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                now, there = os.fstat(fd), os.lstat(lock)
                held = (now.st_dev, now.st_ino) == (there.st_dev, there.st_ino)
            except (BlockingIOError, FileNotFoundError):
                held = False
            if held:
                return fd
            os.close(fd)
        if time.monotonic() >= deadline:
            stale = "" if fcntl else f"; if no mbgen is running, delete {lock}"
            raise OutputBusyError(f"another mbgen generation is writing {target} (it holds "
                                  f"{lock.name}); wait for it to finish and run again{stale}")
        time.sleep(0.05)


def _open_lock(lock: Path, target: Path) -> int:
    """Open ``lock`` (made 0666 minus the umask when missing), never through a link, and
    only a regular file of the user's: an OutputPathError names anything else."""
    try:
        fd = os.open(lock, os.O_CREAT | _LOCK_FLAGS, 0o666)
    except OSError:
        if not os.path.islink(lock):
            raise
        raise OutputPathError(f"{lock}, the lock of {target}, is a symbolic link (to "
                              f"{os.readlink(lock)!r}), which mbgen never follows: whoever "
                              f"could write {lock.parent} may have put it there; delete it "
                              f"and run again") from None
    info = os.fstat(fd)
    why = ("is not a regular file" if not stat.S_ISREG(info.st_mode) else
           f"belongs to uid {info.st_uid}, not to you" if
           hasattr(os, "geteuid") and info.st_uid != os.geteuid() else None)
    if why:
        os.close(fd)
        raise OutputPathError(f"{lock}, the lock of {target}, {why}; if no mbgen of another "
                              f"user is writing {target}, delete it and run again")
    return fd

