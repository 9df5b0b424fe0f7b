"""Build: ``Rendered -> compiled extension module`` with cffi (API mode, out of line).

The module is named after a hash of its source (``_mbgen_<prefix>_<hash>``) and
cached in :func:`cache_dir`, so loading an unchanged model again does not call
the compiler.  A build happens in a private temporary folder and the finished
extension is moved into the cache with an atomic rename, so concurrent builds
and interrupted builds never leave a half-written module behind.

The cache does not trust file names.  Next to every module the build records its
size and SHA-256 (``<module>.sha256``, written after the module); a module is
loaded only when it matches, otherwise it is rebuilt -- a truncated library would
crash the interpreter (SIGBUS) when mapped, an empty one fail to import.  Every build
folder holds an ``owner`` file (host and process id); folders left by builds that
were killed are removed by the next build.  A default cache folder that cannot be
written falls back to a private folder under the system's temporary directory; an
explicit ``$MBGEN_CACHE_DIR`` that cannot be written is a
:class:`~mbgen.errors.CacheError`.

No ``os.chdir``, no ``sys.path`` edits: the module is loaded from its file.
"""

from __future__ import annotations

import getpass
import hashlib
import importlib.machinery
import importlib.util
import os
import shutil
import sys
import socket
import sysconfig
import tempfile
import threading
import time
from contextlib import contextmanager
from pathlib import Path

from ..errors import BuildError, CacheError
from ..fileio import write_files
from ..abi import Rendered

#: Flags for the generated C.  -ffp-contract=off keeps results bitwise close to
#: the Python module (no fused multiply-add contraction).
CFLAGS = ("-std=c99", "-O2", "-ffp-contract=off")

#: Sources longer than this (characters) compile at -O1 (see :func:`cflags`).
LARGE_SOURCE_CHARS = 200_000
#: ``$MBGEN_OPT`` forces an optimisation level for every build (e.g. ``-O2``).
OPT_LEVELS = ("-O0", "-O1", "-O2", "-O3", "-Os")


def cflags(rendered: Rendered) -> tuple[str, ...]:
    """Compiler flags for ``rendered``: :data:`CFLAGS`, at -O1 for a large source.

    gcc's -O2 grows much faster than linearly with the size of one function:
    the Whipple bicycle's RHS + Jacobian (343 KB of C) took 53.5 s and 3.4 GB at
    -O2 against 8.8 s and 0.28 GB at -O1, for calls 10 % slower (RHS 1.43 vs
    1.57 µs, Jacobian 8.4 vs 9.1 µs).  ``$MBGEN_OPT`` (one of :data:`OPT_LEVELS`)
    overrides the choice; the flags are part of the module's cache key.
    """
    forced = os.environ.get("MBGEN_OPT", "").strip()
    if forced:
        if forced not in OPT_LEVELS:
            raise BuildError(f"MBGEN_OPT={forced!r}: give one of {', '.join(OPT_LEVELS)} or "
                             f"unset it")
        level = forced
    else:
        source = rendered.files[f"{rendered.prefix}.c"]
        level = "-O1" if len(source) > LARGE_SOURCE_CHARS else "-O2"
    return tuple(level if f == "-O2" else f for f in CFLAGS)

_loaded: dict[str, object] = {}
_lock = threading.Lock()


#: A build folder whose owner cannot be checked is stale after this many seconds.
STALE_AFTER = 24 * 3600.0


def _writable(root: Path) -> str | None:
    """``None`` when ``root`` is (made) a writable folder, else why not."""
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return f"{exc.strerror or exc}"
    if not root.is_dir():
        return "not a folder"
    if not os.access(root, os.W_OK | os.X_OK):
        return "not writable"
    return None


def cache_dir() -> Path:
    """Folder of compiled modules: ``$MBGEN_CACHE_DIR`` or ``~/.cache/mbgen``.

    A default folder that cannot be written falls back to
    ``<tempdir>/mbgen-cache-<user id>``.

    Raises
    ------
    CacheError
        ``$MBGEN_CACHE_DIR`` (or the fallback) cannot be created or written.
    """
    env = os.environ.get("MBGEN_CACHE_DIR")
    if env:
        root = Path(env)
        why = _writable(root)
        if why:
            raise CacheError(f"the cache folder MBGEN_CACHE_DIR={env!r} cannot be used ({why}); "
                             f"point MBGEN_CACHE_DIR at a writable folder or unset it")
        return root
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    root = Path(base) / "mbgen"
    why = _writable(root)
    if why is None:
        return root
    uid = os.getuid() if hasattr(os, "getuid") else getpass.getuser()
    fallback = Path(tempfile.gettempdir()) / f"mbgen-cache-{uid}"
    why2 = _writable(fallback)
    if why2:
        raise CacheError(f"no writable cache folder: {root} ({why}), {fallback} ({why2}); set "
                         f"MBGEN_CACHE_DIR to a writable folder")
    return fallback


def module_name(rendered: Rendered) -> str:
    """Content-hash module name of ``rendered`` (flags and toolchain included)."""
    import cffi

    h = hashlib.sha256(rendered.digest().encode())
    h.update(" ".join(cflags(rendered)).encode())
    h.update(cffi.__version__.encode())
    h.update(sys.version.encode())
    return f"_mbgen_{rendered.prefix}_{h.hexdigest()[:16]}"


def _suffix() -> str:
    return importlib.machinery.EXTENSION_SUFFIXES[0]


def compiled_path(rendered: Rendered) -> Path:
    return cache_dir() / (module_name(rendered) + _suffix())


def _record_path(path: Path) -> Path:
    return path.with_name(path.name + ".sha256")


def _fingerprint(path: Path) -> str:
    """``"<size> <sha256>"`` of the file at ``path``."""
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
            size += len(block)
    return f"{size} {h.hexdigest()}"


def verified(path: Path) -> bool:
    """Whether the module at ``path`` is the one its build recorded (size and SHA-256)."""
    try:
        recorded = _record_path(path).read_text().strip()
        if os.stat(path).st_size != int(recorded.split()[0]):
            return False  # cheap first: a truncated or empty file
        return _fingerprint(path) == recorded
    except (OSError, ValueError, IndexError):
        return False


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
    for folder in root.glob("_mbgen_*-*"):
        if folder.is_dir() and _stale(folder, now):
            shutil.rmtree(folder, ignore_errors=True)
            if not folder.exists():
                removed.append(folder)
    return removed


@contextmanager
def _capture_fds():
    """Redirect file descriptors 1 and 2 into a temporary file (compiler chatter)."""
    sys.stdout.flush()
    sys.stderr.flush()
    with tempfile.TemporaryFile(mode="w+b") as log:
        saved = os.dup(1), os.dup(2)
        os.dup2(log.fileno(), 1)
        os.dup2(log.fileno(), 2)
        box = {"text": ""}
        try:
            yield box
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            log.seek(0)
            box["text"] = log.read().decode(errors="replace")


def compiler() -> str:
    cc = os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc"
    exe = cc.split()[0]
    if shutil.which(exe) is None:
        raise BuildError(f"no C compiler found (looked for {exe!r}); install one "
                         f"(e.g. 'apt install gcc') or set CC")
    return exe


def build(rendered: Rendered, *, force: bool = False) -> Path:
    """Compile ``rendered`` into the cache (unless already there) and return the module path.

    Raises
    ------
    BuildError
        With the compiler's own output when compilation fails.
    """
    target = compiled_path(rendered)
    if not force and target.exists() and verified(target):
        return target
    compiler()
    import cffi

    name = module_name(rendered)
    remove_stale_builds(target.parent)
    with tempfile.TemporaryDirectory(prefix=f"{name}-", dir=target.parent) as tmp:
        tmpdir = Path(tmp)
        (tmpdir / "owner").write_text(f"{socket.gethostname()} {os.getpid()}\n")
        write_files(tmpdir, rendered.files)
        ffi = cffi.FFI()
        try:
            ffi.cdef(rendered.cdef + rendered.extension_cdef)
        except Exception as exc:  # cffi.CDefError and friends
            raise BuildError(f"cffi could not parse the declarations of {rendered.prefix}: "
                             f"{exc}") from exc
        ffi.set_source(name, f'#include "{rendered.prefix}.h"\n' + rendered.extension,
                       sources=[str(tmpdir / f"{rendered.prefix}.c")],
                       include_dirs=[str(tmpdir)], extra_compile_args=list(cflags(rendered)),
                       libraries=["m"])
        output = ""
        try:
            with _capture_fds() as box:
                built = ffi.compile(tmpdir=str(tmpdir), verbose=False)
            output = box["text"]
        except Exception as exc:
            output = box["text"] if "box" in locals() else ""
            raise BuildError(f"compiling model {rendered.prefix!r} failed: {exc}\n"
                             f"--- compiler output ---\n{output.strip()}") from exc
        record = tmpdir / "record"
        record.write_text(_fingerprint(Path(built)) + "\n")
        os.replace(built, target)
        os.replace(record, _record_path(target))  # after the module: a record proves it whole
    return target


def _import(path: Path):
    name = path.name[: -len(_suffix())]
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:  # pragma: no cover
        raise BuildError(f"cannot load compiled module {path}")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def load(rendered: Rendered, *, force: bool = False):
    """Build if needed and import the extension; returns the cffi module (``.ffi``, ``.lib``).

    A module that is loaded is one whose size and SHA-256 match its build's record
    (else it is rebuilt first); one that still fails to import is rebuilt once more.
    """
    key = str(compiled_path(rendered))
    with _lock:
        mod = None if force else _loaded.get(key)
    if mod is not None:
        return mod
    path = build(rendered, force=force)  # outside the lock: threads compile side by side
    with _lock:
        mod = _loaded.get(key)
        if mod is None or force:
            try:
                mod = _import(path)
            except ImportError as first:
                path = build(rendered, force=True)
                try:
                    mod = _import(path)
                except ImportError as exc:
                    raise BuildError(f"the compiled module {path} of {rendered.prefix!r} does "
                                     f"not import ({exc}; before a rebuild: {first})") from exc
            _loaded[key] = mod
    return mod
