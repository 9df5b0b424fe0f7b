"""Plain shared libraries in the cache: generated C that another program loads (CasADi's
``external``), built and trusted like the Python extensions.

:func:`shared_library` compiles a set of C files into ``<stem>_<hash>.so`` (``.dylib``,
``.dll``) in :func:`~mbgen.build.cache.cache_dir`: the name is a hash of every file, the
compiler and its flags (:func:`~mbgen.build.extension.cflags`, ``-fPIC -shared``), so an
unchanged library is never compiled again; it is built in a private folder and moved in
with its record, as a module is (:func:`~mbgen.build.extension.build`).
:func:`~mbgen.build.cache.loadable` then gives the path a loader may open: the checked
bytes, never the name opened again.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import tempfile
import threading
from pathlib import Path

from ..errors import BuildError
from ..fileio import write_files
from .cache import (
    cache_dir,
    disk_error,
    owner_line,
    record_path,
    remove_stale_builds,
    require_writable,
    verified,
    write_record,
)
from .extension import compiler
from .fmu import library_suffix

#: Added to the model's flags for a library another program loads.
SHARED_FLAGS = ("-fPIC", "-shared")

_lock = threading.Lock()


def library_path(stem: str, files: dict[str, str], flags: tuple[str, ...]) -> Path:
    """Where :func:`shared_library` keeps the library of ``files`` built with ``flags``."""
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    for part in (compiler(), *flags, *SHARED_FLAGS):
        h.update(part.encode() + b"\0")
    return cache_dir() / f"_mbgen_lib_{stem}_{h.hexdigest()[:16]}{library_suffix()}"


def shared_library(stem: str, files: dict[str, str], sources: tuple[str, ...],
                   flags: tuple[str, ...]) -> Path:
    """Compile ``sources`` (names of ``files``, written beside each other) into a shared
    library in the cache, unless the same one is there already; its path.

    Raises
    ------
    BuildError
        With the compiler's output when it fails.
    CacheError
        The cache is read-only and lacks the library, or the disk is full.
    """
    target = library_path(stem, files, flags)
    if verified(target):
        return target
    require_writable(target)
    root = target.parent
    cc = compiler()
    with _lock:
        if verified(target):
            return target
        try:
            remove_stale_builds(root)
            with tempfile.TemporaryDirectory(prefix=f"{target.stem}-", dir=root) as tmp:
                folder = Path(tmp)
                (folder / "owner").write_text(owner_line())
                write_files(folder, files)
                built = folder / target.name
                cmd = [cc, *flags, *SHARED_FLAGS, *sources, "-lm", "-o", built.name]
                done = subprocess.run(cmd, cwd=folder, capture_output=True, text=True,
                                      errors="replace")
                if done.returncode != 0:
                    raise BuildError(f"compiling the shared library {stem!r} failed "
                                     f"({' '.join(cmd)}):\n{done.stdout}{done.stderr}")
                record = folder / "record"
                write_record(built, record)
                os.replace(built, target)
                os.replace(record, record_path(target))
        except OSError as exc:
            raise disk_error(exc, root, target.name) from exc
    return target


__all__ = ["shared_library", "library_path", "SHARED_FLAGS"]
