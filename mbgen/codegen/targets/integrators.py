"""The integrators target: whole-trajectory C integrators in the model's files.

Rendered when the scene asks for an integrator output (``Output.DOPRI5``, ``RK4``,
``ROSENBROCK``): ``templates/integrators/integrators.h.j2`` (options, statistics, work
structs, prototypes) into ``<prefix>.h`` and ``integrators.c.j2`` (what every method
shares, then one template per method, ``<output>.c.j2``) into ``<prefix>.c``.  The
views of the methods are :mod:`mbgen.codegen.integrators`.  Not chosen by name: the
outputs choose it, and its text is in the ``c`` target's files.

Stack bounds (:meth:`Integrators.stack_bounds`): a method's own arrays
(:func:`integrator_bytes`: ``n_x``-long states and stages; Rosenbrock's ``n_x x n_x``
matrices are in the caller's work struct) over the deepest of what it calls: the RHS
(after a step also the projection, :func:`project_bound`), the runtime routines
``initial_step`` and ``lu``, an implicit method's Jacobian and ``df/dt``.
"""

from __future__ import annotations

from ...abi import INTEGRATOR_STATUS_CODES
from ...integrators import METHODS
from ..header import SMALL, frame
from ..integrators import explicit_time, integrator_context
from .base import HEADER, SOURCE, Target
from .runtime import routine_bounds


def integrator_bytes(T, n: int, non_autonomous: bool) -> int:
    """Automatic storage of a whole-trajectory integrator (``integrators/<name>.c.j2``), with
    its statistics; ``n`` the state's length."""
    stats = frame(6) - frame()
    if T.implicit:                      # J, G and piv are in the caller's work struct
        return frame((8 + int(non_autonomous) + T.n_stages()) * n + 18, 4) - frame() + stats
    if T.adaptive:                      # y, y_new, xs, err, sc, K (FSAL: one stage more), w
        return frame((5 + T.n_stages + 1) * n + T.n_stages + 1 + 14, 4) - frame() + stats
    return frame((2 + T.n_stages) * n + 5, 3) - frame() + stats


def project_bound(kernel, prefix: str, known: dict, routines: dict) -> int:
    """``<prefix>_project``: Newton on the dependent coordinates (``f``, ``J``, the block
    ``a``, ``dq``, ``piv``) over the constraint functions and the LU; 0 without one."""
    c = kernel.equations.constraints
    if c is None or not c.m_h or not kernel.integrators:
        return 0
    m, n_q = c.m_h, kernel.layout.n_q
    return frame(2 * m + m * n_q + m * m + 3, m + 6) + max(
        known.get(f"{prefix}_holonomic", 0), known.get(f"{prefix}_holonomic_jacobian", 0),
        routines["lu"], SMALL)


class Integrators(Target):
    """The C integrators the kernel asks for, a section of the model's files."""

    name = "integrators"
    files = (("integrators.h.j2", HEADER), ("integrators.c.j2", SOURCE))
    status_codes = INTEGRATOR_STATUS_CODES
    requires = ("initial_step", "lu")
    chosen = False

    def wanted(self, kernel, targets) -> bool:
        return bool(kernel.integrators)

    def context(self, kernel, views, prefix: str) -> dict:
        return integrator_context(kernel)

    def stack_bounds(self, kernel, ctx: dict, known: dict) -> dict[str, int]:
        """``<prefix>_<method>`` of every integrator the kernel asks for."""
        prefix = ctx["prefix"]
        routines = routine_bounds(kernel, ctx, known)
        rhs = max(known.get(f"{prefix}_rhs", 0), project_bound(kernel, prefix, known, routines))
        non_autonomous = (any(METHODS[o].implicit for o in kernel.integrators)
                          and explicit_time(kernel))
        bounds = {}
        for o in kernel.integrators:
            T = METHODS[o]
            calls = [rhs, SMALL]
            if T.adaptive:
                calls.append(routines["initial_step"])
            if T.implicit:
                calls += [known.get(f"{prefix}_{need.value}", 0) for need in T.needs]
                calls += [known.get(f"{prefix}_time_derivative", 0), routines["lu"]]
            bounds[f"{prefix}_{o.value}"] = (frame() + integrator_bytes(T, ctx["routine"]["n"],
                                                                        non_autonomous)
                                             + max(calls))
        return bounds


#: The integrators target.
INTEGRATORS = Integrators()

__all__ = ["INTEGRATORS", "Integrators", "integrator_bytes", "project_bound"]
