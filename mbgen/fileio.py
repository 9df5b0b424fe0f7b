"""Atomic file writing: write to a temporary in the same folder, then rename."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Mapping


def write_atomic(path: Path, text: str) -> bool:
    """Write ``text`` to ``path`` atomically; skip (return False) when unchanged."""
    path = Path(path)
    if path.exists() and path.read_text(encoding="utf-8") == text:
        return False
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return True


def write_files(folder: Path, files: Mapping[str, str]) -> list[Path]:
    """Write every ``{name: text}`` into ``folder`` atomically; return the paths that changed."""
    folder = Path(folder)
    return [folder / n for n, text in sorted(files.items()) if write_atomic(folder / n, text)]
