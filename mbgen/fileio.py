"""Atomic file writing: write to a temporary in the same folder, then rename.

A reader never sees a half-written file, and an interrupted write leaves the
old file (or nothing) behind.
"""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Mapping


def file_mode(path: Path) -> int:
    """Mode for a new file at ``path``: the old file's, else 0o666 minus the umask.

    (``tempfile.mkstemp`` creates files readable by the owner only.)
    """
    try:
        return os.stat(path).st_mode & 0o777
    except FileNotFoundError:
        mask = os.umask(0)
        os.umask(mask)
        return 0o666 & ~mask


@contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path``, else it is removed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, file_mode(path))
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
