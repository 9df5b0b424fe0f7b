r"""What the header states besides the prototypes: index macros, content hash, stack-bound units.

Index macros
    ``<PREFIX>_X_<state>``, ``<PREFIX>_P_<parameter>``, ``<PREFIX>_R_<input>``:
    the index of each symbol in ``x``, ``p`` and ``r`` (``x[DISC_PENDULUM_X_q2]``).
Content hash
    ``<PREFIX>_CONTENT_HASH``: the first 16 hex digits of the SHA-256 of the
    generated ``.h``, ``.c`` and ``.py`` texts with the hash itself blanked
    (:func:`content_hash`).  An FMU's GUID and the ensemble runner's cache key.
Stack bounds
    ``<PREFIX>_STACK_<FUNCTION>``: an upper bound, in bytes, of the stack one
    call of each public function uses, the functions it calls included.  Each target
    states the bounds of its own functions
    (:meth:`~mbgen.codegen.targets.base.Target.stack_bounds`) and each runtime routine
    the bound of one call (:data:`mbgen.codegen.targets.runtime.ROUTINES`), in the
    units here: :func:`frame` counts every automatic variable a function declares (8
    bytes a double or a long, 4 an int) plus :data:`FRAME_BYTES` per call level for the
    return address, saved registers, alignment and the compiler's own spills.
    ``tests/codegen/test_header.py`` checks every bound against ``gcc -fstack-usage``.
    Work arrays that grow with ``n_x^2`` (Rosenbrock's Jacobian and iteration
    matrix) live in caller-owned structs: ``<prefix>_rosenbrock_work`` of the
    whole-trajectory integrator and the step API's memory; never on the stack.
"""

from __future__ import annotations

import hashlib
import re

from .escape import c_comment

#: Allowance per call level: return address, saved registers, alignment, compiler spills.
FRAME_BYTES = 256
#: Bytes of an automatic ``double`` (or ``long``, or pointer) and of an ``int``.
DOUBLE, INT = 8, 4
#: Placeholder of the hash while the texts are hashed.
HASH_PLACEHOLDER = "0" * 16


def frame(doubles: int = 0, ints: int = 0) -> int:
    """Stack bound of one call level declaring ``doubles`` 8-byte and ``ints`` 4-byte locals."""
    return FRAME_BYTES + DOUBLE * doubles + INT * ints


#: Bound of a small helper that calls nothing: ``all_finite``, ``integ_start``, a solve.
SMALL = frame(8, 4)


def index_defines(upper: str, layout) -> list[tuple[str, int, str]]:
    """``(macro, index, symbol)`` for every state, parameter and input (the symbol escaped
    for a C comment)."""
    def ident(s):
        return re.sub(r"[^A-Za-z0-9_]", "_", str(s))

    groups = (("X", layout.states), ("P", layout.parameters), ("R", layout.inputs))
    return [(f"{upper}_{a}_{ident(s)}", i, c_comment(str(s))) for a, syms in groups
            for i, s in enumerate(syms)]


def content_hash(files: dict) -> str:
    """SHA-256 (16 hex digits) of ``{name: text}`` with the hash placeholder in place."""
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    return h.hexdigest()[:16]


__all__ = ["index_defines", "content_hash", "frame", "FRAME_BYTES", "DOUBLE", "INT", "SMALL",
           "HASH_PLACEHOLDER"]
