"""The child process that runs cffi's build, so that the asking process is left alone.

cffi compiles through distutils, which changes process-wide state: the working directory
(``os.chdir`` into the build folder), environment variables, distutils' log level; and
the compiler writes to file descriptors 1 and 2.  Done in the process that asked for the
build, two threads building at once lost each other's sources, and capturing the
compiler's output meant swapping the process's fds 1 and 2 (from two threads: stdout
left on a deleted file).  Here all of that happens in a child: the parent's working
directory and file descriptors are never touched, and it reads the compiler's output
from a pipe.  It costs a Python start-up per build (about 0.15 s; a cache hit starts
nothing).

Run by :func:`mbgen.build.extension.build` as ``python -c START cffi_child.py`` in the
build folder.  :data:`START` drops the build folder from ``sys.path`` (it holds the
model's generated ``<name>.py``: a model named ``json`` or ``cffi`` would shadow the
real module) and imports nothing of mbgen (``import mbgen`` costs 0.7 s).  Reads a JSON
object from stdin (the keys are :func:`main`'s), builds in the current folder and
writes :data:`RESULT` there: ``{"module": path}``, ``{"cdef": message}`` when cffi
cannot parse the declarations, or ``{"error": message}`` when the build fails (the
compiler's own output is on stdout/stderr).
"""

import json
import os
import sys

import cffi

#: What the parent passes to ``python -c``: run this file as a script, without ``''``
#: (the build folder) on ``sys.path``.
START = ("import sys, runpy; sys.path[:] = [p for p in sys.path if p not in ('', '.')]; "
         "runpy.run_path(sys.argv[1], run_name='__main__')")

#: The file the child writes its result to, in the build folder.
RESULT = "cffi-result.json"


def _result(**fields) -> None:
    with open(RESULT, "w", encoding="utf-8") as f:
        json.dump(fields, f)


def main() -> int:
    """Build the extension that stdin describes: ``name``, ``cdef``, ``source`` (the
    C preamble), ``sources``, ``extra_objects`` (optional), ``include_dirs``,
    ``define_macros`` (``[name, value]`` pairs, optional), ``extra_compile_args``,
    ``libraries``."""
    spec = json.load(sys.stdin)
    ffi = cffi.FFI()
    try:
        ffi.cdef(spec["cdef"])
    except Exception as exc:  # cffi.CDefError and friends
        _result(cdef=str(exc))
        return 3
    ffi.set_source(spec["name"], spec["source"], sources=spec["sources"],
                   extra_objects=spec.get("extra_objects", []),
                   include_dirs=spec["include_dirs"],
                   define_macros=[tuple(m) for m in spec.get("define_macros", ())],
                   extra_compile_args=spec["extra_compile_args"], libraries=spec["libraries"])
    try:
        module = ffi.compile(tmpdir=".", verbose=False)
    except Exception as exc:  # cffi.VerificationError (the compiler failed), OSError
        _result(error=str(exc))
        return 1
    _result(module=os.path.abspath(module))
    return 0


if __name__ == "__main__":
    sys.exit(main())
