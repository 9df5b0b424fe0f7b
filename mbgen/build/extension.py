"""Build: ``Rendered -> compiled library``, opened with cffi (ABI mode).

A model compiles into a plain shared library -- its C and its batch loops, one translation
unit, one compiler process, no Python headers (a source cut into parts: several units,
compiled on every core, :mod:`mbgen.build.units`) -- named after a hash of its source and
every flag (``_mbgen_<prefix>_<hash>.so``) and cached in
:func:`~mbgen.build.cache.cache_dir`, so loading an unchanged model again does not call the
compiler.  cffi opens it (``ffi.dlopen`` over the model's declarations, parsed once per
process).  What the cache trusts, and whose folder it uses, is :mod:`mbgen.build.cache`'s
to say: a library is opened only when it is the user's own build, whole and unchanged;
anything else is rebuilt.

Calls from Python take the Python crossing (``crossing.c`` beside this file,
:mod:`mbgen.runtime.crossing`): one CPython extension for every model, compiled once per
cache, Python and NumPy (:func:`crossing_module`), that calls a library's functions
through their addresses.  Compiling Python's headers into every model was most of a
small model's build: the 2-link arm's RHS took 0.31 s as a cffi extension with the
crossing linked in, and takes 0.07 s as a library (gcc, this machine).

A build happens in a private folder inside the cache, and the compiler runs as child
processes whose output comes back through pipes
(:func:`~mbgen.build.units.run_compilers`).  So any number of threads may compile at once
(threads that need the same library build it once), and the
process's working directory, ``sys.stdout`` and fds 1 and 2 are never touched.  The
finished library and then its record are moved into the cache with atomic renames, so
concurrent builds -- threads or processes -- and interrupted ones never leave a
half-written library behind: a reader sees the old file or the new one, and a library
whose record does not match is rebuilt.

No ``os.chdir``, no ``sys.path`` edits: the library is opened from the very file that
passed the cache's checks (:func:`~mbgen.build.cache.loadable`), never from its name opened
again.  Every argument of the compiler and the linker is in the library's name (the cache
key: :func:`module_name`), ``$CFLAGS`` and ``$LDFLAGS`` included; flags that break IEEE
arithmetic (:data:`IEEE_BREAKERS`) are refused.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.machinery
import importlib.util
import os
import platform
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import threading
from pathlib import Path

from ..abi import Rendered
from ..errors import BuildError
from ..fileio import write_files
from .cache import (
    cache_dir,
    disk_error,
    loadable,
    owner_line,
    record_path,
    remove_stale_builds,
    require_writable,
    verified,
    write_record,
)
from .probes import remembered
from .units import build_jobs, run_compilers, units

#: Flags for the generated C.  -ffp-contract=off keeps results bitwise close to
#: the Python module (no fused multiply-add contraction).  -g0 takes back the -g that
#: Python's own CFLAGS (which cffi's build starts from) add: debug information was 40 % of
#: gcc's time on the 32-link arm's Jacobian (43.7 -> 25.2 s at -O1) and 9-15 % of a small
#: model's whole build (disc pendulum 0.51 -> 0.46 s, 8-link arm 1.23 -> 1.04 s).
CFLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-g0")
#: Added to :data:`CFLAGS` for a module built on the machine that runs it (see
#: :func:`cflags`): the spatial arm's RHS in a C loop, ns per call at n = 2 / 8 / 16 / 32,
#: -O2: 33 / 423 / 1,242 / 2,711; -O2 -march=native: 31 / 350 / 968 / 2,417; -O3 and
#: -O3 -march=native gave the same as -O2 and -O2 -march=native (within 4 %).
NATIVE = ("-march=native",)
#: Added where the compiler takes it (:func:`accepts`): gcc's -O2 vectorises only "very cheap"
#: loops, so a Jacobian's column solve (a loop over a parameter's count of columns) stayed
#: scalar: 59 % of G1's Jacobian, 70 % of Solo-12's (perf).  The dynamic cost model vectorises
#: it (paired C loops, µs, -O2 / with it / -O3: G1 70.5 / 40.7 / 37.8, Solo-12 11.6 / 7.5 /
#: 7.1, 32-link arm 28.4 / 26.2 / 24.7; gcc's time unchanged).  Lanes are independent columns
#: (no sum is reordered): the bits of -O2.
VECTORIZE = ("-fvect-cost-model=dynamic",)
#: Added where the compiler takes it: gcc's basic-block vectoriser cost generated code far
#: more compile time and memory than it gained (G1's Jacobians: 36.7 -> 26.2 s, 1.35 -> 0.39
#: GB; run time within 5 % on the robots and arms), and changed bits against the generated
#: Python (gcc 12, AVX-512); docs/performance.md, "Without gcc's basic-block vectoriser".
NO_SLP = ("-fno-tree-slp-vectorize",)

#: Flags that break the IEEE arithmetic the generated code relies on, refused wherever they
#: come from ($CFLAGS, $LDFLAGS, Python's own flags), each with its reason; the second field
#: takes the flag back when it comes later on the line (None: nothing does).  The NaN checks
#: are what turn a singular state into SingularConstraintError, and the results are meant
#: to be the generated Python's bit for bit.  (gcc < 13 also links ``crtfastmath.o`` into
#: a shared library built with -ffast-math or -Ofast: loading it sets flush-to-zero for the
#: whole process.)
IEEE_BREAKERS = (
    ("-ffast-math", "-fno-fast-math", "it assumes no NaN or infinity ever arises, so the "
     "checks that find them (a singular state's SingularConstraintError) are compiled out"),
    ("-Ofast", None, "it is -O3 with -ffast-math, which assumes no NaN or infinity ever "
     "arises, so the checks that find them are compiled out"),
    ("-ffinite-math-only", "-fno-finite-math-only", "it assumes no NaN or infinity ever "
     "arises, so the checks that find them are compiled out"),
    ("-fno-honor-nans", "-fhonor-nans", "it assumes no NaN ever arises, so the checks that "
     "find them are compiled out"),
    ("-fno-honor-infinities", "-fhonor-infinities", "it assumes no infinity ever arises"),
    ("-funsafe-math-optimizations", "-fno-unsafe-math-optimizations", "it reorders and "
     "approximates floating point: the results are no longer the generated Python's"),
    ("-fassociative-math", "-fno-associative-math", "it reorders sums: the results are no "
     "longer the generated Python's"),
    ("-freciprocal-math", "-fno-reciprocal-math", "it divides by multiplying with "
     "reciprocals: the results are no longer the generated Python's"),
)

#: A source whose longest function is longer than this (characters) compiles at -O1
#: (see :func:`cflags`; :mod:`mbgen.codegen.split` keeps most functions below it).
LARGE_FUNCTION_CHARS = 150_000
#: ``$MBGEN_OPT`` forces an optimisation level for every build (e.g. ``-O2``).
OPT_LEVELS = ("-O0", "-O1", "-O2", "-O3", "-Os")


def wants_native(default: bool = True) -> bool:
    """Whether a build adds :data:`NATIVE`: ``$MBGEN_NATIVE`` (``1`` or ``0``) where set,
    else ``default`` (True for the user's own modules; ensemble workers pass False)."""
    env = os.environ.get("MBGEN_NATIVE", "").strip()
    if env not in ("", "0", "1"):
        raise BuildError(f"MBGEN_NATIVE={env!r}: give 1 (build for this machine's CPU), "
                         f"0 (portable) or unset it")
    return default if not env else env == "1"


@functools.cache
def native_target(cc: str) -> str:
    """What ``-march=native`` means to ``cc`` on this machine: a hash of the macros it then
    predefines (the instruction set), part of the cache key so that a cache shared between
    machines never loads a module built for another CPU; "" where ``cc`` refuses the flag.
    Asked once per compiler and CPU (:mod:`mbgen.build.probes`)."""
    def ask() -> str:
        try:
            proc = subprocess.run([cc, *NATIVE, "-E", "-dM", "-x", "c", os.devnull],
                                  capture_output=True, text=True, timeout=60)
        except (OSError, subprocess.SubprocessError):
            return ""
        return hashlib.sha256(proc.stdout.encode()).hexdigest()[:16] \
            if proc.returncode == 0 else ""

    return remembered(f"native {' '.join(NATIVE)}", cc, ask)


def _cc() -> str:
    """The compiler's executable as named (``$CC``, Python's, else ``cc``); no check."""
    return (os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc").split()[0]


def cflags(rendered: Rendered, native: bool | None = None) -> tuple[str, ...]:
    """Compiler flags for ``rendered``: :data:`CFLAGS`, at -O1 for a large source,
    :data:`VECTORIZE` and :data:`NO_SLP` where the compiler takes them, and :data:`NATIVE`
    where ``native`` (default :func:`wants_native`) and the compiler takes it.

    A module built by ``mbgen.compile`` runs on the machine that built it, so it is built
    for that CPU: 1.1-1.3x faster from n = 8 links on (:data:`NATIVE`'s figures).
    -ffp-contract=off stays, so the results are those of the portable build and of the
    generated Python bit for bit (no fused multiply-add; gcc does not reassociate
    floating point without -ffast-math).  The exported C, ``example.c`` and FMUs keep
    portable flags; so do ensemble workers, whose machines may differ, unless
    ``MBGEN_NATIVE=1``.

    gcc's -O2 grows much faster than linearly with one function's size (the Whipple
    bicycle's RHS + Jacobian: 53.5 s, 3.4 GB at -O2, 8.8 s, 0.28 GB at -O1), so a source
    whose longest function exceeds :data:`LARGE_FUNCTION_CHARS` compiles at -O1;
    :mod:`mbgen.codegen.split` cuts unconstrained models' long functions into parts, which
    keep -O2.  ``$MBGEN_OPT`` (:data:`OPT_LEVELS`) overrides; the flags are in the cache key.
    """
    forced = os.environ.get("MBGEN_OPT", "").strip()
    if forced:
        if forced not in OPT_LEVELS:
            raise BuildError(f"MBGEN_OPT={forced!r}: give one of {', '.join(OPT_LEVELS)} or "
                             f"unset it")
        level = forced
    else:
        source = rendered.files[f"{rendered.prefix}.c"]
        level = "-O1" if longest_function(source) > LARGE_FUNCTION_CHARS else "-O2"
    flags = tuple(level if f == "-O2" else f for f in CFLAGS)
    for extra in (VECTORIZE, NO_SLP):
        if accepts(_cc(), extra):
            flags += extra
    if (wants_native() if native is None else native) and native_target(_cc()):
        flags += NATIVE
    return flags


@functools.cache
def accepts(cc: str, flags: tuple[str, ...]) -> bool:
    """Whether ``cc`` compiles an empty C file with ``flags`` without a word (a compiler that
    ignores an option it does not know says so); asked once per compiler and CPU
    (:mod:`mbgen.build.probes`)."""
    def ask() -> str:
        try:
            proc = subprocess.run([cc, *flags, "-Werror", "-x", "c", "-c", os.devnull, "-o",
                                   os.devnull], capture_output=True, text=True, timeout=60)
        except (OSError, subprocess.SubprocessError):
            return "0"
        return "1" if proc.returncode == 0 and not proc.stderr.strip() else "0"

    return remembered(f"accepts {' '.join(flags)}", cc, ask) == "1"


def model_flags(rendered: Rendered, native: bool | None = None) -> tuple[str, ...]:
    """The flags a library build compiles the model's source with (:func:`library_command`):
    ``$CFLAGS`` (:func:`_user_flags`), then :func:`cflags`.  Benchmarks that time the C as
    the user's library runs it compile with these."""
    return (*_user_flags()[0], *cflags(rendered, native))


def longest_function(source: str) -> int:
    """Characters of the longest top-level block of a generated C source (a function)."""
    return max(len(block) for block in source.split("\n}\n"))


_loaded: dict[str, object] = {}
_lock = threading.RLock()  # re-entered by load's rebuild of a library that does not load
#: Threads that find no crossing module build it once (:func:`crossing_module`).
_crossing_lock = threading.Lock()
#: One lock per library name: threads that need the same library build it once.
_building: dict[str, threading.Lock] = {}

#: A model's library is plain C: position-independent, shared, linked with nothing but libm.
SHARED_FLAGS = ("-fPIC", "-shared")
#: The Python crossing, a CPython extension of its own (:mod:`mbgen.runtime.crossing`).
CROSSING_SOURCE = Path(__file__).with_name("crossing.c")
#: Flags of the crossing beyond Python's own (:func:`_python_flags`).
CROSSING_FLAGS = ("-O2", "-g0")


def library_suffix() -> str:
    """File suffix of a shared library on this platform."""
    return {"Darwin": ".dylib", "Windows": ".dll"}.get(platform.system(), ".so")


@functools.cache
def crossing_source() -> str:
    """The C of the Python crossing (:data:`CROSSING_SOURCE`), read once."""
    return CROSSING_SOURCE.read_text(encoding="utf-8")


def _crossing_name() -> str:
    """``_mbgen_crossing_<hash>``: the hash of its C, NumPy, Python, the compiler and every
    flag it is built with (the key of the one crossing module of a cache)."""
    import numpy

    h = hashlib.sha256(crossing_source().encode())
    compile_flags, link = _python_flags()
    for part in (numpy.__version__, numpy.get_include(), sys.version, _cc(), *compile_flags,
                 "|", *link, "|", *CROSSING_FLAGS):
        h.update(part.encode() + b"\0")
    return f"_mbgen_crossing_{h.hexdigest()[:16]}"


_crossing: list = []


def crossing_path() -> Path:
    """The Python crossing (:data:`CROSSING_SOURCE`) compiled into the cache as an extension
    module, ``_mbgen_crossing_<hash>`` (Python's flags, NumPy's headers), unless there
    already; its path.

    It is the one part of a compiled model that needs Python's headers: compiling them was
    most of a small model's build (the 2-link arm's RHS: 0.31 s with a cffi wrapper and the
    crossing in every module, 0.07 s as a plain library).  Kept like a library: built in a
    private folder, recorded, renamed; imported only from the verified bytes.
    """
    import numpy

    name = _crossing_name()
    target = cache_dir() / f"{name}{importlib.machinery.EXTENSION_SUFFIXES[0]}"
    if verified(target):
        return target
    with _crossing_lock:
        if not verified(target):
            compile_flags, link = _python_flags()
            src = ("#define MBGEN_CROSSING_INIT PyInit_" + name + "\n"
                   f'#define MBGEN_CROSSING_NAME "{name}"\n' + crossing_source())
            flags = [*compile_flags, *CROSSING_FLAGS, *(f"-I{d}" for d in _python_includes()),
                     "-I", numpy.get_include()]
            what = "mbgen's Python crossing"

            def make(folder: Path) -> Path:
                (folder / "crossing.c").write_text(src, encoding="utf-8")
                out = folder / target.name
                run_compilers([[_cc(), *flags, "-c", "crossing.c", "-o", "crossing.o"]],
                              folder, name, what)
                run_compilers([[*link, "crossing.o", "-o", out.name]], folder, name, what)
                return out
            _build_into(target, make)
    return target


def crossing_module():
    """The Python crossing (:func:`crossing_path`), imported once per process."""
    with _lock:
        if not _crossing:
            _crossing.append(_import_extension(crossing_path(), _crossing_name()))
        return _crossing[0]


def module_name(rendered: Rendered, native: bool | None = None) -> str:
    """Content-hash name of ``rendered``'s library (flags, target CPU and toolchain included).

    Every argument that reaches the compiler and the linker is part of it -- the compiler's
    name, ``$CFLAGS`` and ``$LDFLAGS`` (:func:`_user_flags`), :func:`cflags` -- so a library
    built with other flags is never taken for this one."""
    h = hashlib.sha256(rendered.digest().encode())
    flags = cflags(rendered, native)
    compile_flags, link = _user_flags()
    for part in ("library 1", _cc(), *compile_flags, "|", *link, "|", *SHARED_FLAGS, "|",
                 *flags):
        h.update(part.encode() + b"\0")
    if NATIVE[0] in flags:
        h.update(native_target(_cc()).encode())
    return f"_mbgen_{rendered.prefix}_{h.hexdigest()[:16]}"


def _suffix() -> str:
    return library_suffix()


def compiled_path(rendered: Rendered, native: bool | None = None) -> Path:
    return cache_dir() / (module_name(rendered, native) + _suffix())


def compiler() -> str:
    """The C compiler's executable (:func:`_cc`), checked to exist."""
    exe = _cc()
    if shutil.which(exe) is None:
        raise BuildError(f"no C compiler found (looked for {exe!r}); install one "
                         f"(e.g. 'apt install gcc') or set CC")
    return exe


def build(rendered: Rendered, *, force: bool = False, native: bool | None = None) -> Path:
    """Compile ``rendered`` into the cache (unless already there) and return the library path.

    The library is one translation unit: the model's source and its batch loops
    (``rendered.extension``), compiled and linked by one compiler process
    (:func:`library_command`).

    Raises
    ------
    BuildError
        With the compiler's own output when compilation fails.
    CacheError
        The cache folder is not private, read-only (and lacks the library), or full.
    """
    target = compiled_path(rendered, native)
    if not force and verified(target):
        return target
    name = module_name(rendered, native)
    with _lock:
        building = _building.setdefault(name, threading.Lock())
    with building:
        if not force and verified(target):  # another thread built it meanwhile
            return target
        crossing_path()  # a cache that holds a library holds what opens it from Python
        _build_into(target, lambda folder: _compile(rendered, name, folder, native))
    return target


def _compile(rendered: Rendered, name: str, folder: Path, native: bool | None) -> Path:
    """Build ``rendered``'s library in ``folder`` (:func:`library_command`); its path.

    The model's source, then its batch loops: one translation unit and compiler process,
    unless the source has parts (:mod:`mbgen.codegen.split`) and the machine has cores
    (:func:`~mbgen.build.units.build_jobs`): then its units (:func:`~mbgen.build.units.units`),
    by a pool of one compiler per core, and a link.  cffi parses the declarations meanwhile."""
    texts = units(rendered.files[f"{rendered.prefix}.c"], jobs := build_jobs())
    first = f'#include "{rendered.prefix}.c"' if len(texts) == 1 else texts[0]
    extra = {f"{name}_{k}.c": text for k, text in enumerate(texts[1:], 1)}
    write_files(folder, {**rendered.files, f"{name}.c": f"{first}\n\n{rendered.extension}",
                         **extra})
    out = folder / f"{name}{_suffix()}"

    def meanwhile():   # cffi parses the declarations while the compiler runs (for load)
        _declared(rendered.cdef + rendered.extension_cdef)

    if not extra:
        run_compilers([library_command(rendered, [f"{name}.c"], out.name, native)], folder,
                      name, rendered.prefix, meanwhile=meanwhile)
        return out
    sources = [f"{name}.c", *extra]
    objects = [f"{source[:-2]}.o" for source in sources]
    flags = (*_user_flags()[0], *cflags(rendered, native), SHARED_FLAGS[0], "-c")
    run_compilers([[_cc(), *flags, s, "-o", o] for s, o in zip(sources, objects)], folder,
                  name, rendered.prefix, jobs=jobs, meanwhile=meanwhile)
    run_compilers([library_command(rendered, objects, out.name, native)], folder, name,
                  rendered.prefix)
    return out


def library_command(rendered: Rendered, inputs: list[str], output: str,
                    native: bool | None = None) -> list[str]:
    """The compiler call that builds a model's library: ``cc $CFLAGS`` :func:`cflags`
    ``-fPIC -shared inputs -lm $LDFLAGS -o output`` (``inputs``: the one source, or the
    objects of its units)."""
    compile_flags, link = _user_flags()
    return [_cc(), *compile_flags, *cflags(rendered, native), *SHARED_FLAGS, *inputs, "-lm",
            *link, "-o", output]


def _build_into(target: Path, make) -> None:
    """Run ``make(folder)`` in a private folder of the cache and move the file it returns
    to ``target`` with its record.

    The file and then its record are moved in with atomic renames, so concurrent builds
    -- threads or processes -- and interrupted ones never leave a half-written library: a
    reader sees the old file or the new one, and a file whose record does not match is
    rebuilt."""
    require_writable(target)
    root = target.parent
    compiler()
    try:
        remove_stale_builds(root)
        with tempfile.TemporaryDirectory(prefix=f"{target.stem}-", dir=root) as tmp:
            folder = Path(tmp)
            (folder / "owner").write_text(owner_line())
            built = make(folder)
            record = folder / "record"
            write_record(built, record)
            os.replace(built, target)
            os.replace(record, record_path(target))  # after the library: it proves it whole
    except OSError as exc:
        raise disk_error(exc, root, target.stem) from exc


def _python_flags() -> tuple[tuple[str, ...], tuple[str, ...]]:
    """``(compile flags, link command)`` as distutils builds an extension: Python's
    ``CFLAGS`` and ``CCSHARED`` then ``$CFLAGS``; ``LDSHARED`` (its compiler swapped for
    ``$CC`` where set) then ``$LDFLAGS``.

    Raises
    ------
    BuildError
        A variable that does not split into arguments (a quote left open), or a flag of
        :data:`IEEE_BREAKERS`, each named with the variable it came from.
    """
    var = sysconfig.get_config_var
    compile_flags = _split("Python's CFLAGS", var("CFLAGS")) + \
        _split("Python's CCSHARED", var("CCSHARED")) + _split("$CFLAGS", os.environ.get("CFLAGS"))
    link = _split("Python's LDSHARED", var("LDSHARED") or "cc -shared")
    if os.environ.get("CC"):
        link[0] = ("$CC", _cc())
    link += _split("$LDFLAGS", os.environ.get("LDFLAGS"))
    for line in (compile_flags, link):
        _refuse_ieee_breakers(line)
    return tuple(f for _, f in compile_flags), tuple(f for _, f in link)


def _user_flags() -> tuple[tuple[str, ...], tuple[str, ...]]:
    """``($CFLAGS, $LDFLAGS)`` split as the shell would: what the user adds to a model's
    library build (:func:`library_command`).

    Raises
    ------
    BuildError
        A variable that does not split into arguments, or a flag of :data:`IEEE_BREAKERS`,
        each named with the variable it came from.
    """
    compile_flags = _split("$CFLAGS", os.environ.get("CFLAGS"))
    link = _split("$LDFLAGS", os.environ.get("LDFLAGS"))
    for line in (compile_flags, link):
        _refuse_ieee_breakers(line)
    return tuple(f for _, f in compile_flags), tuple(f for _, f in link)


def _split(source: str, text: str | None) -> list[tuple[str, str]]:
    """``text`` split as the shell would, each argument paired with ``source``."""
    try:
        return [(source, arg) for arg in shlex.split(text or "")]
    except ValueError as exc:           # "No closing quotation", "No escaped character"
        name = source.lstrip("$").replace("Python's ", "")
        fix = (f"close the quote or unset {name}" if source.startswith("$") else
               f"Python's build settings (sysconfig {name}) are damaged; reinstall Python")
        raise BuildError(f"{source}={text!r} does not split into compiler arguments "
                         f"({str(exc).lower()}); {fix}") from None


def _refuse_ieee_breakers(line: list[tuple[str, str]]) -> None:
    """A BuildError for the first flag of :data:`IEEE_BREAKERS` in force on ``line``."""
    for flag, undo, why in IEEE_BREAKERS:
        last = None
        for source, arg in line:
            if arg == flag:
                last = source
            elif arg == undo:
                last = None
        if last is not None:
            fix = (f"remove it from {last[1:]}" if last.startswith("$") else
                   "use a Python built without it")
            raise BuildError(f"{last} holds {flag}, which mbgen does not build with: {why}; "
                             f"{fix}")


def _python_includes() -> tuple[str, ...]:
    paths = sysconfig.get_paths()
    return tuple(dict.fromkeys((paths["include"], paths["platinclude"])))


def _import_extension(path: Path, name: str):
    """Import the extension module at ``path`` from the bytes that passed
    :func:`~mbgen.build.cache.open_verified` (:func:`~mbgen.build.cache.loadable`: the
    checked file itself, never the name opened again)."""
    with loadable(path) as origin:
        if origin is None:
            raise BuildError(f"{path} is not the user's own build, whole and unchanged; "
                             f"delete it and run again")
        loader = importlib.machinery.ExtensionFileLoader(name, origin)
        spec = importlib.util.spec_from_file_location(name, origin, loader=loader)
        if spec is None:  # pragma: no cover
            raise BuildError(f"cannot load compiled module {path}")
        mod = importlib.util.module_from_spec(spec)
        loader.exec_module(mod)
    return mod


class Library:
    """A model's compiled library, loaded: ``ffi`` and ``lib`` (cffi's ABI mode over the
    model's declarations, ``rendered.cdef`` and ``rendered.extension_cdef``), ``crossing``
    (:func:`crossing_module`) and ``path`` (the library in the cache)."""

    __slots__ = ("ffi", "lib", "crossing", "path")

    def __init__(self, ffi, lib, crossing, path: Path):
        self.ffi, self.lib, self.crossing, self.path = ffi, lib, crossing, path

    def __repr__(self) -> str:
        return f"<mbgen library {self.path.name}>"


@functools.lru_cache(maxsize=64)
def _declared(cdef: str):
    """A cffi ``FFI`` with ``cdef`` declared (parsed once per process and text)."""
    import cffi

    ffi = cffi.FFI()
    try:
        ffi.cdef(cdef)
    except Exception as exc:  # cffi.CDefError and friends
        raise BuildError(f"cffi could not parse the declarations: {exc}") from None
    return ffi


def _open(path: Path, rendered: Rendered) -> Library:
    """Open the library at ``path`` from the bytes that passed the cache's checks
    (:func:`~mbgen.build.cache.loadable`); an ImportError when they do not."""
    ffi = _declared(rendered.cdef + rendered.extension_cdef)
    with loadable(path) as origin:
        if origin is None:
            raise ImportError(f"{path} is not the user's own build, whole and unchanged")
        try:
            lib = ffi.dlopen(origin)
        except OSError as exc:
            raise ImportError(str(exc)) from None
    return Library(ffi, lib, crossing_module(), path)


def load(rendered: Rendered, *, force: bool = False, native: bool | None = None) -> Library:
    """Build if needed and open the model's library: a :class:`Library` (``.ffi``, ``.lib``).

    A library is opened only from the bytes that were found trusted
    (:func:`mbgen.build.cache.open_verified`: the user's own, whole and unchanged, checked
    on the open file that is then loaded), else it is rebuilt first; one that still fails
    to open is rebuilt once more.  A library already opened by this process is returned
    without reading the disk.  ``native``: build for this machine's CPU (default
    :func:`wants_native`; see :func:`cflags`).
    """
    key = str(compiled_path(rendered, native))
    with _lock:
        mod = None if force else _loaded.get(key)
    if mod is not None:
        return mod
    path = build(rendered, force=force, native=native)  # outside the lock: threads in parallel
    with _lock:
        mod = _loaded.get(key)
        if mod is None or force:
            try:
                mod = _open(path, rendered)
            except ImportError as first:
                path = build(rendered, force=True, native=native)
                try:
                    mod = _open(path, rendered)
                except ImportError as exc:
                    raise BuildError(f"the compiled library {path} of {rendered.prefix!r} "
                                     f"does not load ({exc}; before a rebuild: {first})"
                                     ) from exc
            _loaded[key] = mod
    return mod
