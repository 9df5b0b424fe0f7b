"""Build: ``Rendered -> compiled extension module`` with cffi (API mode, out of line).

The module is named after a hash of its source (``_mbgen_<prefix>_<hash>``) and
cached in :func:`cache_dir`, so loading an unchanged model again does not call
the compiler.  A build happens in a private temporary folder and the finished
extension is moved into the cache with an atomic rename, so concurrent builds
and interrupted builds never leave a half-written module behind.

No ``os.chdir``, no ``sys.path`` edits: the module is loaded from its file.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import shutil
import sys
import sysconfig
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path

from .errors import BuildError
from .fileio import write_files
from .render import Rendered

#: Flags for the generated C.  -ffp-contract=off keeps results bitwise close to
#: the Python module (no fused multiply-add contraction).
CFLAGS = ("-std=c99", "-O2", "-ffp-contract=off")

_loaded: dict[str, object] = {}
_lock = threading.Lock()


def cache_dir() -> Path:
    """Folder of compiled modules: ``$MBGEN_CACHE_DIR`` or ``~/.cache/mbgen``."""
    env = os.environ.get("MBGEN_CACHE_DIR")
    root = Path(env) if env else Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "mbgen"
    root.mkdir(parents=True, exist_ok=True)
    return root


def module_name(rendered: Rendered) -> str:
    """Content-hash module name of ``rendered`` (flags and toolchain included)."""
    import cffi

    h = hashlib.sha256(rendered.digest().encode())
    h.update(" ".join(CFLAGS).encode())
    h.update(cffi.__version__.encode())
    h.update(sys.version.encode())
    return f"_mbgen_{rendered.prefix}_{h.hexdigest()[:16]}"


def _suffix() -> str:
    return importlib.machinery.EXTENSION_SUFFIXES[0]


def compiled_path(rendered: Rendered) -> Path:
    return cache_dir() / (module_name(rendered) + _suffix())


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


def _compiler() -> str:
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
    if target.exists() and not force:
        return target
    _compiler()
    import cffi

    name = module_name(rendered)
    with tempfile.TemporaryDirectory(prefix=f"{name}-", dir=cache_dir()) as tmp:
        tmpdir = Path(tmp)
        write_files(tmpdir, rendered.files)
        ffi = cffi.FFI()
        try:
            ffi.cdef(rendered.cdef + rendered.extension_cdef)
        except Exception as exc:  # cffi.CDefError and friends
            raise BuildError(f"cffi could not parse the declarations of {rendered.prefix}: "
                             f"{exc}") from exc
        ffi.set_source(name, f'#include "{rendered.prefix}.h"\n' + rendered.extension,
                       sources=[str(tmpdir / f"{rendered.prefix}.c")],
                       include_dirs=[str(tmpdir)], extra_compile_args=list(CFLAGS),
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
        os.replace(built, target)
    return target


def load(rendered: Rendered, *, force: bool = False):
    """Build if needed and import the extension; returns the cffi module (``.ffi``, ``.lib``)."""
    path = build(rendered, force=force)
    key = str(path)
    with _lock:
        mod = _loaded.get(key)
        if mod is None:
            name = path.name[: -len(_suffix())]
            spec = importlib.util.spec_from_file_location(name, path)
            if spec is None or spec.loader is None:  # pragma: no cover
                raise BuildError(f"cannot load compiled module {path}")
            mod = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(mod)
            _loaded[key] = mod
    return mod
