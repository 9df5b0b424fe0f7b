"""The warm cache: what a model's inputs rendered to, so that an unchanged model loads
without deriving.

The cache's first index names a compiled module after its rendered text
(:func:`~mbgen.build.extension.module_name`), which exists only once the derivation, CSE
and rendering have run: 55 s of a 58 s ``mbgen simulate`` of a humanoid, paid again on
every run.  This second index names a *record* after what the user gave -- the key
(:func:`key`) -- and holds the :class:`~mbgen.abi.Rendered` value those inputs rendered
to: the texts, the cffi declarations, the layout, the defaults, everything
:class:`~mbgen.runtime.compiled.CompiledModel` reads.  :func:`mbgen.pipeline.run` (so
``mbgen.compile`` and every command that compiles) looks here first; on a hit it loads
the module of the stored ``Rendered`` through the first index (compiling it from the
stored C if the compiler or its flags changed since) and derives nothing.

The key is SHA-256 over the canonical form (:mod:`mbgen.build.canonical`) of the inputs
the pipeline passes -- the model's content (every record of a :class:`~mbgen.Model`, the
expressions as graphs), the scene's fields that reach the code, the outputs, targets,
method, form, fixed parameters and every other option of the run -- and over
:func:`code_identity`: mbgen's version and the bytes of its own code and templates, and
the versions of Python and of what writes the code (sympy, symengine, Jinja).  A changed
file, option or mbgen misses, always.  A scene file (``.py``) is code: its model's
canonical form is the key, whatever the file's text.

A record is ``_mbgen_warm-<key>.pickle`` in :func:`~mbgen.build.cache.cache_dir` with a
SHA-256 record beside it, written and checked as a module is
(:func:`~mbgen.build.cache.write_verified`, :func:`~mbgen.build.cache.read_verified`): a
record that is not the user's own, whole and unchanged is never unpickled, only
ignored (the pipeline then derives and writes it anew).  Only mbgen writes these files,
and the module beside them is code that the same checks let run.

``MBGEN_WARM=0`` (or ``mbgen.compile(..., warm=False)``) derives every time;
:func:`clear` (or deleting ``_mbgen_warm-*`` from the cache folder) forgets every record.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pickle
import sys
from collections.abc import Mapping
from importlib import metadata, resources
from pathlib import Path

from .._version import __version__
from ..abi import Rendered
from ..errors import BuildError, CacheError
from . import canonical
from .cache import cache_dir, read_verified, record_path, write_verified

#: Names of the records in the cache folder: ``_mbgen_warm-<key>.pickle`` (a module's name,
#: ``_mbgen_<prefix>_<hash>``, never holds a ``-``).
PREFIX = "_mbgen_warm-"
SUFFIX = ".pickle"
#: What a record holds; a new format misses every older record.
FORMAT = 1
#: Libraries whose version changes the generated text (a record keyed by them).
WRITERS = ("sympy", "symengine", "jinja2")


def enabled(asked: bool | None = None) -> bool:
    """Whether to use the warm cache: ``asked`` where given, else ``$MBGEN_WARM`` (``1``
    or ``0``; unset: yes)."""
    if asked is not None:
        return bool(asked)
    env = os.environ.get("MBGEN_WARM", "").strip()
    if env not in ("", "0", "1"):
        raise BuildError(f"MBGEN_WARM={env!r}: give 1 (load an unchanged model without "
                         f"deriving it), 0 (derive every time) or unset it")
    return env != "0"


@functools.cache
def code_identity() -> str:
    """What generates the code in this process: mbgen's version, a SHA-256 over the bytes
    of its Python, C and templates (about 20 ms, once per process: a source checkout being
    edited misses where its code changed), the versions of Python and of :data:`WRITERS`."""
    h = hashlib.sha256(f"mbgen {__version__}\n{sys.version}\n".encode())
    for name in WRITERS:
        try:
            h.update(f"{name} {metadata.version(name)}\n".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{name} -\n".encode())
    for root in (Path(__file__).resolve().parents[1], _templates()):
        for path in sorted(root.rglob("*")):
            if path.suffix in (".py", ".j2", ".c", ".h") and "__pycache__" not in path.parts:
                h.update(f"{path.relative_to(root).as_posix()}\0".encode())
                h.update(path.read_bytes() + b"\0")
    return h.hexdigest()


def _templates() -> Path:
    """The templates folder (``mbgen._templates`` in a wheel, ``templates/`` in a checkout:
    :func:`mbgen.codegen.templating.environment`'s rule, without importing Jinja)."""
    try:
        return Path(str(resources.files("mbgen._templates")))
    except ModuleNotFoundError:
        return Path(__file__).resolve().parents[2] / "templates"


def key(inputs: Mapping[str, object]) -> str:
    """The record's name for ``inputs`` (what the pipeline was given, by name): a SHA-256
    of their canonical form and of :func:`code_identity`.

    Raises
    ------
    mbgen.build.canonical.Uncacheable
        Some input has no canonical form (a function, another library's object).
    """
    h = hashlib.sha256(f"warm {FORMAT}\n{code_identity()}\n".encode())
    h.update(canonical.digest(dict(inputs)).encode())
    return h.hexdigest()


def path(name: str, root: Path | None = None) -> Path:
    """Where the record of key ``name`` lives."""
    return (root or cache_dir()) / f"{PREFIX}{name}{SUFFIX}"


def lookup(name: str) -> Rendered | None:
    """The ``Rendered`` stored under key ``name``, or None: no record, a record that is not
    the user's own, whole and unchanged, one of another format, or no usable cache folder
    (the build that follows says why)."""
    try:
        data = read_verified(path(name))
    except (CacheError, OSError):
        return None
    if data is None:
        return None
    try:
        record = pickle.loads(data)
    except Exception:   # noqa: BLE001 -- any damage is a miss; the record is then rewritten
        return None
    if not isinstance(record, dict) or record.get("format") != FORMAT or \
            record.get("key") != name or not isinstance(record.get("rendered"), Rendered):
        return None
    return record["rendered"]


def store(name: str, rendered: Rendered) -> bool:
    """Keep ``rendered`` under key ``name``; whether it was kept.  A cache that cannot take
    it (read-only, full) keeps nothing and says nothing: the next run derives again."""
    try:
        data = pickle.dumps({"format": FORMAT, "key": name, "rendered": rendered},
                            protocol=pickle.HIGHEST_PROTOCOL)
        write_verified(path(name), data)
    except (CacheError, OSError):
        return False
    except Exception:   # noqa: BLE001 -- a value pickle cannot write: not kept
        return False
    return True


def clear(root: Path | None = None) -> int:
    """Delete every record of the warm cache (the compiled modules stay); how many."""
    root = root or cache_dir()
    removed = 0
    for found in root.glob(f"{PREFIX}*{SUFFIX}"):
        for file in (found, record_path(found)):
            try:
                file.unlink()
            except FileNotFoundError:
                continue
        removed += 1
    return removed


__all__ = ["FORMAT", "PREFIX", "SUFFIX", "WRITERS", "clear", "code_identity", "enabled",
           "key", "lookup", "path", "store"]
