"""Single files written so that a reader never sees half of one.

A file is written to a temporary beside it (``.<name>.<random>.tmp``), then renamed over
it (:func:`write_atomic`, :func:`atomic_path`): an interrupted write leaves the old file (or
nothing).  New files get 0666 minus the umask, replaced ones keep their mode
(:func:`keep_mode`).  Also the names and fingerprints the generations of
:mod:`mbgen.fileio.generations` are made of: :func:`plain_name`, :func:`digest`,
:func:`fingerprint`.
"""

from __future__ import annotations

import hashlib
import os
import re
import secrets
import stat
from collections.abc import Iterator, Mapping
from contextlib import contextmanager, suppress
from pathlib import Path

from ..errors import SceneError

_PLAIN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}\Z")


def keep_mode(path: Path, new: Path) -> None:
    """Give ``new`` the mode of the file at ``path`` that it replaces, if any.  A new file keeps
    the 0666 minus umask it was created with: the umask is never set to be read (``os.umask``
    is process-wide, and another thread may be creating files meanwhile)."""
    with suppress(FileNotFoundError):
        os.chmod(new, stat.S_IMODE(os.stat(path).st_mode))


def _new_temp(path: Path) -> Path:
    """A new empty ``.<name>.<random>.tmp`` beside ``path``, 0666 minus the umask."""
    while True:
        tmp = path.parent / f".{path.name}.{secrets.token_hex(4)}.tmp"
        with suppress(FileExistsError):                  # odds 2**-32: draw again
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            return tmp


@contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path``, else it is
    removed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _new_temp(path)
    try:
        yield tmp
        keep_mode(path, tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_atomic(path, text: str) -> bool:
    """Write ``text`` to ``path`` atomically; skip (return False) when unchanged."""
    path = Path(path)
    if path.exists() and path.read_text(encoding="utf-8") == text:
        return False
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8", newline="\n")
    return True


def write_files(folder, files: Mapping[str, str]) -> list[Path]:
    """Write every ``{name: text}`` into ``folder`` atomically; return the paths that changed."""
    folder = Path(folder)
    return [folder / n for n, text in sorted(files.items()) if write_atomic(folder / n, text)]


def plain_name(name: str, what: str = "file name") -> str:
    """``name`` if it is a plain file name (no folder part, no ``..``), else a SceneError."""
    if not is_plain(name):
        raise SceneError(f"{what} {name!r} is not a plain file name (letters, digits, '_', '.', "
                         f"'-'; no folders, at most 128 characters)")
    return name


def is_plain(name) -> bool:
    """Whether ``name`` is a plain file name (see :func:`plain_name`)."""
    return isinstance(name, str) and bool(_PLAIN.match(name)) and ".." not in name


def digest(data: bytes) -> str:
    """SHA-256 of ``data`` in hex; the manifest records ``"sha256:" + digest(bytes)``."""
    return hashlib.sha256(data).hexdigest()


def fingerprint(path: Path) -> str | None:
    """``sha256:<hex>`` of a regular file, ``link:<target>`` of a symbolic link, else None."""
    st = os.lstat(path)
    if stat.S_ISLNK(st.st_mode):
        return "link:" + os.readlink(path)
    if stat.S_ISREG(st.st_mode):
        return "sha256:" + digest(path.read_bytes())
    return None

