"""What the compiler takes, asked once per compiler and machine and remembered in the cache.

A library's flags depend on two questions put to the compiler: does it take
:data:`~mbgen.build.extension.VECTORIZE` without a word, and what does ``-march=native``
mean on this CPU (:func:`~mbgen.build.extension.native_target`).  Each is a compiler process
(15 ms), and a new process asked both before every first build: 0.03 s of the 2-link arm's
0.13 s compile stage.  The answers are kept in the cache as ``probe-<key>.txt``, written and
read with the cache's checks (:func:`~mbgen.build.cache.write_verified`,
:func:`~mbgen.build.cache.read_verified`: the user's own file, whole and unchanged).

The key (:func:`probe_key`) holds the question, the compiler's resolved path with its size
and modification time (an upgraded compiler asks again) and, on Linux, the CPU's vendor,
model and flags from ``/proc/cpuinfo`` (a cache shared between machines never answers for
another CPU).  Anything that fails -- a cache that cannot be written, a damaged answer --
asks the compiler, as before.
"""

from __future__ import annotations

import hashlib
import os
import platform
import shutil
from collections.abc import Callable

from ..errors import CacheError
from .cache import cache_dir, read_verified, write_verified

#: The lines of ``/proc/cpuinfo`` that name the CPU (its first processor's).
CPU_FIELDS = ("vendor_id", "model name", "flags")


def cpu_identity() -> str:
    """The CPU: :data:`CPU_FIELDS` of ``/proc/cpuinfo`` where there is one, else what
    :mod:`platform` says."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            fields = {}
            for line in f:
                key, _, value = line.partition(":")
                key = key.strip()
                if key in CPU_FIELDS and key not in fields:
                    fields[key] = value.strip()
                if len(fields) == len(CPU_FIELDS):
                    break
        return "|".join(fields.get(k, "") for k in CPU_FIELDS)
    except OSError:
        return f"{platform.machine()}|{platform.processor()}"


def probe_key(question: str, cc: str) -> str | None:
    """The cache key of ``question`` put to ``cc`` on this machine; None where ``cc`` is not
    found (nothing is remembered about a compiler that is not there)."""
    exe = shutil.which(cc)
    if exe is None:
        return None
    try:
        info = os.stat(os.path.realpath(exe))
    except OSError:
        return None
    h = hashlib.sha256()
    for part in ("probe 1", question, os.path.realpath(exe), str(info.st_size),
                 str(info.st_mtime_ns), cpu_identity()):
        h.update(part.encode() + b"\0")
    return h.hexdigest()[:24]


def remembered(question: str, cc: str, ask: Callable[[], str]) -> str:
    """The answer to ``question`` from the cache, else ``ask()``'s, then kept there."""
    key = probe_key(question, cc)
    if key is None:
        return ask()
    try:
        path = cache_dir() / f"probe-{key}.txt"
        data = read_verified(path)
        if data is not None:
            return data.decode("utf-8")
    except (OSError, CacheError, UnicodeDecodeError):
        return ask()
    answer = ask()
    try:
        write_verified(path, answer.encode("utf-8"))
    except (OSError, CacheError):
        pass    # a cache that cannot keep it asks again next time
    return answer


__all__ = ["remembered", "probe_key", "cpu_identity"]
