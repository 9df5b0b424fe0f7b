"""Atomic file writing: write to a temporary in the same folder, then rename.

A reader never sees a half-written file, and an interrupted write leaves the
old file (or nothing) behind.

:func:`write_generated` is how ``mbgen generate`` writes a folder of generated
files: every file name is a plain name (it cannot leave the folder), a file
mbgen did not write is never overwritten unless asked, and a manifest
(:data:`MANIFEST`) records what mbgen wrote, so that a regeneration removes the
files it no longer produces -- and only those.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Mapping

from .errors import SceneError

#: File listing what mbgen wrote into an output folder (JSON: {"files": [...]}).
MANIFEST = ".mbgen-manifest.json"

_PLAIN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}\Z")


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


def plain_name(name: str, what: str = "file name") -> str:
    """``name`` if it is a plain file name (no folder part, no ``..``), else a SceneError."""
    if not isinstance(name, str) or not _PLAIN.match(name) or ".." in name:
        raise SceneError(f"{what} {name!r} is not a plain file name (letters, digits, '_', '.', "
                         f"'-'; no folders, at most 128 characters)")
    return name


def _manifest(folder: Path) -> set[str]:
    path = folder / MANIFEST
    if not path.is_file():
        return set()
    try:
        names = json.loads(path.read_text(encoding="utf-8"))["files"]
    except (ValueError, KeyError, TypeError, OSError):
        raise SceneError(f"{path} is damaged; remove it (and the files mbgen generated there) "
                         f"and generate again") from None
    return {n for n in names if isinstance(n, str) and _PLAIN.match(n) and ".." not in n}


def write_generated(folder, files: Mapping[str, str], *,
                    overwrite: bool = False) -> tuple[list[Path], list[Path]]:
    """Write generated ``{name: text}`` into ``folder``; return ``(changed, removed)`` paths.

    * Names must be plain file names (:func:`plain_name`): nothing is written
      outside ``folder``.
    * A file already in ``folder`` that mbgen did not write (it is not in the
      folder's manifest) and whose text differs is not overwritten: a
      :class:`~mbgen.errors.SceneError` names it, unless ``overwrite``.
    * Files the previous generation wrote (manifest) and this one does not are
      removed; nothing else is.

    Raises
    ------
    SceneError
        ``folder`` is a file, a name is not plain, a foreign file is in the way,
        or the manifest is damaged.
    """
    folder = Path(folder)
    for name in files:
        plain_name(name)
    if folder.exists() and not folder.is_dir():
        raise SceneError(f"output folder {str(folder)!r} is a file; give a folder with -o")
    previous = _manifest(folder) if folder.is_dir() else set()
    if not overwrite:
        foreign = sorted(n for n, text in files.items() if n not in previous
                         and (folder / n).exists()
                         and (not (folder / n).is_file()
                              or (folder / n).read_text(encoding="utf-8", errors="replace") != text))
        if foreign:
            raise SceneError(f"{folder} already holds {', '.join(foreign)}, which mbgen did not "
                             f"write; choose another output folder (-o) or pass --overwrite to "
                             f"replace them")
    try:
        changed = write_files(folder, files)
    except OSError as exc:
        raise SceneError(f"cannot write into {str(folder)!r}: {exc.strerror or exc}") from None
    removed = []
    for name in sorted(previous - set(files)):
        path = folder / name
        if path.is_file() and not path.is_symlink():
            path.unlink()
            removed.append(path)
    write_atomic(folder / MANIFEST, json.dumps({"files": sorted(files)}, indent=1) + "\n")
    return changed, removed
