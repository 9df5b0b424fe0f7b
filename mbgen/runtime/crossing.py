"""The Python crossing in C: a generated function's common case without Python in between.

A compiled model is a plain library; beside it, one small CPython extension for every
model (``mbgen/build/crossing.c``, compiled once per cache by
:func:`mbgen.build.extension.crossing_module`).  :func:`c_entry` makes from it, for one
generated function of the library, a callable with the Python path's signature
``call(t, x, p=None, r=None)``:

* the common case -- ``t`` a float, ``x`` (and ``p``, ``r`` when given) exactly
  ``numpy.ndarray``, float64, 1-D of the right length with stride 8 -- is checked in C
  and calls ``<prefix>_<output>`` directly; the result is a new float64 array of the
  output's shape;
* anything else, and every non-zero status of the C function, is handed to the
  ``fallback`` it was made with (:meth:`mbgen.runtime.compiled.CompiledModel._make_call`'s
  Python path), with the very arguments of the call: every conversion, batch and error
  (class and message) is that path's.

Why: through cffi a call of the spatial arm's RHS cost about 1.3 µs at n = 2 (two
``ffi.from_buffer``, ``np.empty``, the checks in Python and cffi's call), for about
30 ns of C; see the site's performance page (docs/performance.md) for the figures after.

An entry reads each array's data pointer at every call (an array may be reallocated
in place between calls); only the default ``p`` and ``r`` it was given, which it keeps
alive, are the same arrays every time.  It holds the GIL while it reads the arrays; it
releases it around the C function only when made with ``release=True``.
"""

from __future__ import annotations

import re
from collections.abc import Callable

import numpy as np

from ..errors import MbgenError

#: Bits of the entry's ``takes``: which of ``p`` and ``r`` the C function takes.
TAKES_P, TAKES_R = 1, 2

#: A function of at least this many operations after CSE (as its header states them) runs
#: with the GIL released, so that other threads go on meanwhile.  Releasing and taking it
#: back costs about 30 ns a call (the spatial arm's RHS from Python, best of 7 x 200k
#: calls, 2 cores: n = 2, 102 vs 133 ns; n = 32, 2,424 vs 2,458 ns): a third of a small
#: call, a few per cent from about 5,000 operations (a microsecond or more).
RELEASE_GIL_OPS = 5000


def operations(header: str, c_name: str) -> int | None:
    """Operations after CSE of ``c_name`` as the model's header states them, or None."""
    found = re.search(rf"^ \*   {re.escape(c_name)}: (\d+) \(", header, re.M)
    return int(found.group(1)) if found else None


def releases_gil(header: str, c_name: str) -> bool:
    """Whether ``c_name``'s entry should release the GIL: :data:`RELEASE_GIL_OPS` or more
    operations, or a count the header does not state (as cffi's calls do)."""
    ops = operations(header, c_name)
    return ops is None or ops >= RELEASE_GIL_OPS


def available(module) -> bool:
    """Whether the loaded ``module`` comes with the crossing (libraries opened by
    :func:`mbgen.build.extension.load` do)."""
    return getattr(module, "crossing", None) is not None


def c_entry(module, info, fallback: Callable, sizes: tuple[int, int, int],
            p_default: np.ndarray | None, r_default: np.ndarray | None, *,
            release: bool = False):
    """The C entry of the generated function ``info`` (a :class:`~mbgen.abi.FunctionInfo`).

    Parameters
    ----------
    module
        The model's loaded library (:func:`available`: ``.ffi``, ``.lib``, ``.crossing``).
    fallback : callable
        ``fallback(t, x, p=None, r=None)``: called with the same arguments for every
        call that is not the common case, and for every non-zero status.
    sizes : (n_x, n_p, n_r)
    p_default, r_default : ndarray or None
        Float64 arrays of shape ``(n_p,)``, ``(n_r,)`` that the entry uses (and keeps
        alive) for a ``p`` or ``r`` of None; None where there is no default (``p`` None
        then goes to ``fallback``).  Nobody else should write them.
    release : bool
        Release the GIL around the C function (cffi's calls do); see :func:`releases_gil`.

    Raises
    ------
    MbgenError
        The function's C type is not ``int(double, double *, [double *, [double *,]]
        double *)`` as ``info.args`` says, or the extension refused the request.
    """
    ffi, lib = module.ffi, module.lib
    takes = ("p" in info.args) * TAKES_P | ("r" in info.args) * TAKES_R
    pointer = ffi.addressof(lib, info.c_name)
    arity = 3 + bin(takes).count("1")
    want = f"int(*)(double, {', '.join(['double *'] * (arity - 1))})"
    got = ffi.getctype(ffi.typeof(pointer))
    if got != want:
        raise MbgenError(f"{info.c_name} has the C type {got}, not {want}: the extension does "
                         f"not match the model's functions; rebuild it")
    shape = tuple(int(n) for n in info.out_shape)
    sink: list = []
    request = (fallback, p_default, r_default, int(ffi.cast("uintptr_t", pointer)), takes,
               *map(int, sizes), shape, bool(release), info.c_name, sink)
    try:
        made = module.crossing.entry(request)
    except (TypeError, ValueError, OverflowError) as exc:
        raise MbgenError(f"cannot make the C entry of {info.c_name}: {exc}") from None
    if len(sink) != 1 or sink[0] is not made:
        raise MbgenError(f"cannot make the C entry of {info.c_name}: the crossing returned "
                         f"{made!r}")
    return made


__all__ = ["available", "c_entry", "operations", "releases_gil", "RELEASE_GIL_OPS", "TAKES_P",
           "TAKES_R"]
