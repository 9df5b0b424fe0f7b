r"""What the header states besides the prototypes: index macros, content hash, stack bounds.

Index macros
    ``<PREFIX>_X_<state>``, ``<PREFIX>_P_<parameter>``, ``<PREFIX>_R_<input>``:
    the index of each symbol in ``x``, ``p`` and ``r`` (``x[DISC_PENDULUM_X_q2]``).
Content hash
    ``<PREFIX>_CONTENT_HASH``: the first 16 hex digits of the SHA-256 of the
    generated ``.h``, ``.c`` and ``.py`` texts with the hash itself blanked
    (:func:`content_hash`).  An FMU's GUID and the ensemble runner's cache key.
Stack bounds
    ``<PREFIX>_STACK_<FUNCTION>``: an upper bound, in bytes, of the stack one
    call of each public function uses, the functions it calls included.  It
    counts every automatic variable the function and its callees declare (8
    bytes a double or a long, 4 an int) plus :data:`FRAME_BYTES` per call level
    for the return address, saved registers, alignment and the compiler's own
    spills; ``tests/runtime/test_step.py`` checks it against ``gcc -fstack-usage``.
    Work arrays that grow with ``n_x^2`` (Rosenbrock's Jacobian and iteration
    matrix) live in caller-owned structs: ``<prefix>_rosenbrock_work`` of the
    whole-trajectory integrator and the step API's memory; never on the stack.
"""

from __future__ import annotations

import hashlib
import re

from ..integrators import METHODS, method
from .escape import c_comment
from .integrators import explicit_time
from .solver import UNROLL_MAX, factor_program

#: Allowance per call level: return address, saved registers, alignment, compiler spills.
FRAME_BYTES = 256
#: Placeholder of the hash while the texts are hashed.
HASH_PLACEHOLDER = "0" * 16
D, I = 8, 4


def index_defines(upper: str, layout) -> list[tuple[str, int, str]]:
    """``(macro, index, symbol)`` for every state, parameter and input (symbol escaped for a C comment)."""
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


def _function_bytes(view: dict) -> int:
    """Automatic storage one model function declares (its parts' own: :func:`_part_bytes`)."""
    temps = sum(len(view[s]) for s in ("temps", "post_temps") if s not in view["split"])
    imports = sum(len(v) for v in view["main_imports"].values())
    doubles = int(view["main_uses_time"]) + len(view["main_loads"]) + temps + imports \
        + view["work"] + sum(b["size"] for b in view["pre"] + view["post"] if b["local"])
    ints = int(bool(view["solve"])) + int(bool(view["columns"])) + 1 \
        + int(any(p["status"] for p in view["parts"]))
    if view["columns"] and view["n_u"] > UNROLL_MAX:    # the row-wise solve: acc, B, k
        doubles += view["columns"] + 1
        ints += 1
    return D * doubles + I * ints


def _part_bytes(view: dict) -> int:
    """The largest automatic storage of one part of a split function (0: not split)."""
    return max((D * (int(p["uses_time"]) + len(p["loads"]) + len(p["imports"]) + len(p["temps"]))
                + I for p in view["parts"]), default=0)


def _ldl_bytes(kernel) -> int:
    n = kernel.layout.n_u
    if n <= UNROLL_MAX:
        lets = sum(1 for s in factor_program(n, kernel.mass_pattern) if s.kind == "let")
        return D * lets
    return D * (n + 3) + I * 3


def _integrator_bytes(T, n: int, non_autonomous: bool) -> int:
    """Automatic storage of a whole-trajectory integrator (``integrators/<name>.c.j2``)."""
    stats = 5 * D + D
    if T.implicit:                      # J, G and piv are in the caller's work struct
        return D * ((8 + int(non_autonomous) + T.n_stages()) * n + 18) + I * 4 + stats
    if T.adaptive:                      # y, y_new, xs, err, sc, K (FSAL: one stage more), w
        return D * ((5 + T.n_stages + 1) * n + T.n_stages + 1 + 14) + stats + I * 4
    return D * ((2 + T.n_stages) * n + 5) + stats + I * 3


def stack_bounds(kernel, views: list[dict], prefix: str, step_methods=()) -> dict[str, int]:
    """``{C function name: bound in bytes}`` for every public function (``step_methods``:
    the step API's, when it is rendered)."""
    n = max(kernel.layout.n_x, 1)
    F = FRAME_BYTES
    helper = F + D * 8 + I * 4        # rms, lu_solve, all_finite, integ_start, ...
    ldl = F + _ldl_bytes(kernel)
    bounds: dict[str, int] = {}
    c = kernel.equations.constraints
    constraint_solve = 0   # velocity_solve / kkt_factor / kkt_solve, each over con_lu_solve
    if c is not None:
        n_all = kernel.layout.n_u + c.m
        constraint_solve = 2 * F + D * (c.m + n_all + 10) + I * 10
    for v in views:
        callee = max(ldl, helper) if v["solve"] or v["columns"] else helper
        callee = max(callee, constraint_solve, F + _part_bytes(v) if v["parts"] else 0)
        bounds[v["name"]] = F + _function_bytes(v) + callee
    fn = {v["output"]: bounds[v["name"]] for v in views}
    rhs = fn.get("rhs", 0)
    lu = F + D * 4 + I * 4
    initial = F + D * (3 * n + 8) + I * 2 + max(rhs, helper)
    c = kernel.equations.constraints
    project = 0                       # <prefix>_project: Newton on the dependent coordinates
    if c is not None and c.m_h and kernel.integrators:
        m, n_q = c.m_h, kernel.layout.n_q
        project = F + D * (3 * m + m * n_q + m * m + 3) + I * 6 + max(
            fn.get("holonomic", 0), fn.get("holonomic_jacobian", 0), helper)
    rhs = max(rhs, project)           # called where the RHS is: after a step
    non_autonomous = (any(METHODS[o].implicit for o in kernel.integrators)
                      and explicit_time(kernel))
    for o in kernel.integrators:
        T = METHODS[o]
        calls = [rhs, helper]
        if T.adaptive:
            calls.append(initial)
        if T.implicit:
            calls += [fn.get(need.value, 0) for need in T.needs]
            calls += [fn.get("time_derivative", 0), lu]
        bounds[f"{prefix}_{o.value}"] = F + _integrator_bytes(T, n, non_autonomous) + max(calls)
    if step_methods and project:
        bounds[f"{prefix}_project_state"] = F + D * 14 + I * 2 + project
    for m in step_methods:
        bounds[f"{prefix}_{m}_init"] = F + D * 2 + helper
        own = D * 24 + I * 6
        calls = max(rhs, helper, F + D * 14 + I * 2 + project if project else 0)
        T = method(m)
        if T.adaptive:                  # the initial step
            calls = max(calls, F + D * 8 + I * 2 + max(rhs, helper))
        if T.implicit:
            calls = max(calls, *(fn.get(need.value, 0) for need in T.needs),
                        fn.get("time_derivative", 0), lu)
        bounds[f"{prefix}_{m}_step"] = F + own + calls
    if kernel.layout.n_p and all(str(s) in kernel.equations.defaults
                                 for s in kernel.layout.parameters):
        bounds[f"{prefix}_default_parameters"] = F
    return bounds


__all__ = ["index_defines", "content_hash", "stack_bounds", "FRAME_BYTES", "HASH_PLACEHOLDER"]
