r"""Batch evaluation in C: one loop over ``k`` items, no Python per item.

``templates/batch/batch.c.j2`` renders, for every generated function
``<prefix>_<output>`` and every whole-trajectory integrator, a loop
``<prefix>_<output>_batch`` / ``<prefix>_<method>_batch``.  They are compiled
into the Python extension only (the embeddable ``.c`` does not change), so a
scene pays nothing for them.

Arrays and strides (in doubles; a stride of 0 broadcasts one row to all items)::

    t    (k,)          t_stride  1 or 0
    x    (k, n_x)      x_stride  n_x or 0
    p    (k, n_p)      p_stride  n_p or 0
    r    (k, n_r)      r_stride  n_r or 0
    out  (k, *shape)   contiguous
    status (k,)        int, per item (0 = OK)

Integrators: ``x0 (k, n_x)``, ``x_out (k, n_out, n_x)``, one ``stats`` per item,
shared output times and options (and one Rosenbrock work space, reused item after item).  Each item runs exactly the single call, so
results are bit for bit those of ``k`` single calls.
"""

from __future__ import annotations

from ...integrators import METHODS
from .base import EXTENSION, Target


def _tail(layout) -> tuple[str, str]:
    params = "".join(f", const double *{a}, long {a}_stride"
                     for a, n in (("p", layout.n_p), ("r", layout.n_r)) if n)
    args = "".join(f", {a} + i * {a}_stride" for a, n in (("p", layout.n_p), ("r", layout.n_r))
                   if n)
    return params, args


class Batch(Target):
    """The batch loops: always rendered, into the Python extension's own source."""

    name = "batch"
    files = (("batch.c.j2", EXTENSION),)

    def context(self, kernel, views: list[dict], prefix: str) -> dict:
        """Key ``batch``: the functions and integrators to loop over, the strided arguments."""
        L = kernel.layout
        params, args = _tail(L)
        integrators = [dict(name=o.value, implicit=METHODS[o].implicit)
                       for o in kernel.integrators]
        return dict(batch=dict(
            functions=[dict(name=v["name"], out_size=v["out_size"]) for v in views],
            integrators=integrators, params=params, args=args, n_x=L.n_x))

    def declarations(self, ctx: dict) -> list[str]:
        """The cffi declarations of the loops (the extension's cdef)."""
        prefix, B = ctx["prefix"], ctx["batch"]
        params = B["params"]
        cdef = [f"int {v['name']}_batch(long k, const double *t, long t_stride, const double *x, "
                f"long x_stride{params}, double *out, int *status);" for v in B["functions"]]
        cdef += [f"int {prefix}_{m['name']}_batch(long k, const double *x0, long x0_stride"
                 f"{params}, int n_out, const double *t_out, double *x_out, "
                 f"const {prefix}_options *opt, {prefix}_stats *stats, int *status"
                 + (f", {prefix}_{m['name']}_work *work);" if m["implicit"] else ");")
                 for m in B["integrators"]]
        return cdef


#: The batch target.
BATCH = Batch()

__all__ = ["BATCH", "Batch"]
