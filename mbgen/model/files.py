"""Model files are regular files: anything else is named for what it is and never read.

A model file (URDF, MJCF, a scene) given as a folder, a named pipe or a device used to
be "missing" (``Path.is_file`` is false for each) or, worse, read: a FIFO's size is 0
and its read waits for a writer for ever; ``/dev/zero`` never ends.
:func:`require_regular_file` stats the path (following links, as ``open`` would) and
refuses anything but a regular file, with what it is (:func:`kind_of`);
:func:`read_regular_file` also reads it, opened without blocking and checked again on
the open descriptor, so a path swapped for a pipe between the two is refused too.
Each takes the error class to raise, so every reader keeps its own family of errors.
"""

from __future__ import annotations

import os
import stat

#: What a path is, by its ``st_mode`` test; the first that holds names it.
KINDS = (
    (stat.S_ISREG, "a regular file"),
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a named pipe (FIFO)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def kind_of(mode: int) -> str:
    """``"a folder"``, ``"a named pipe (FIFO)"``, ... for an ``st_mode``."""
    return next((name for test, name in KINDS if test(mode)), "something other than a file")


def _refuse(path, what: str, mode: int, error: type[Exception]):
    raise error(f"{what} {str(path)!r} is {kind_of(mode)}, not a file; give a file's path")


def require_regular_file(path, what: str, error: type[Exception]) -> os.stat_result:
    """The ``stat`` of ``path`` if it is a regular file; else ``error`` naming ``what``
    (e.g. ``"MJCF file"``) and what the path is, or that it cannot be read."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise error(f"{what} {str(path)!r} cannot be read: {exc.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        _refuse(path, what, st.st_mode, error)
    return st


def read_regular_file(path, what: str, error: type[Exception], limit: int,
                      hint: str = "") -> bytes:
    """The bytes of the regular file ``path``, refused (``error``) if it is anything else
    or over ``limit`` bytes (``hint`` ends that message), before any byte is read."""
    st = require_regular_file(path, what, error)
    about = (path, what, error, limit, hint)
    _check_size(st.st_size, *about)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | \
        getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise error(f"{what} {str(path)!r} cannot be read: {exc.strerror}") from None
    with os.fdopen(fd, "rb") as f:
        st = os.fstat(f.fileno())          # what was opened, not what was stat'ed
        if not stat.S_ISREG(st.st_mode):
            _refuse(path, what, st.st_mode, error)
        _check_size(st.st_size, *about)
        try:
            data = f.read(limit + 1)
        except OSError as exc:
            raise error(f"{what} {str(path)!r} cannot be read: {exc.strerror}") from None
    _check_size(len(data), *about)   # it grew while read
    return data


def _check_size(size: int, path, what: str, error: type[Exception], limit: int,
                hint: str) -> None:
    if size > limit:
        raise error(f"{what} {str(path)!r} is {_amount(size)}, over the {_amount(limit)} "
                    f"limit{hint}")


def _amount(size: int) -> str:
    return f"{size / 2**20:.0f} MiB" if size >= 2**20 else f"{size} bytes"
