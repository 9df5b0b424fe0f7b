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
shared output times and options (and one Rosenbrock work space, reused item after item).
Each item runs exactly the single call, so results are bit for bit those of ``k`` single
calls.

The prototypes are produced once (:meth:`Batch.context`) and printed both by the template
and into the extension's cdef.  ``mbgen generate --target batch`` writes the same loops as
``<prefix>_batch.c`` (``templates/batch/export.c.j2``), to compile with ``<prefix>.c``.
"""

from __future__ import annotations

from ..._version import __version__
from ...integrators import METHODS
from ..templating import environment
from .base import EXTENSION, Job, Target


def _tail(layout) -> tuple[str, str]:
    params = "".join(f", const double *{a}, long {a}_stride"
                     for a, n in (("p", layout.n_p), ("r", layout.n_r)) if n)
    args = "".join(f", {a} + i * {a}_stride" for a, n in (("p", layout.n_p), ("r", layout.n_r))
                   if n)
    return params, args


class Batch(Target):
    """The batch loops: always rendered, into the Python extension's own source."""

    name = "batch"
    files = (("batch.c.j2", EXTENSION), ("export.c.j2", "{prefix}_batch.c"))
    needs = ("c",)

    def context(self, kernel, views, prefix: str) -> dict:
        """Key ``batch``: the functions and integrators to loop over (each with its
        prototype), the strided arguments."""
        L = kernel.layout
        params, args = _tail(L)
        functions = [dict(name=v["name"], out_size=v["out_size"],
                          prototype=f"int {v['name']}_batch(long k, const double *t, "
                                    f"long t_stride, const double *x, long x_stride{params}, "
                                    f"double *out, int *status)") for v in views.c]
        integrators = [dict(name=o.value, implicit=METHODS[o].implicit,
                            prototype=f"int {prefix}_{o.value}_batch(long k, const double *x0, "
                                      f"long x0_stride{params}, int n_out, const double *t_out, "
                                      f"double *x_out, const {prefix}_options *opt, "
                                      f"{prefix}_stats *stats, int *status"
                                      + (f", {prefix}_{o.value}_work *work)"
                                         if METHODS[o].implicit else ")"))
                       for o in kernel.integrators]
        return dict(batch=dict(functions=functions, integrators=integrators, params=params,
                               args=args, n_x=L.n_x))

    def cdef(self, ctx: dict) -> list[str]:
        """The cffi declarations of the loops (the extension's cdef)."""
        B = ctx["batch"]
        return [f["prototype"] + ";" for f in B["functions"] + B["integrators"]]

    def export(self, job: Job) -> dict[str, str]:
        """``<prefix>_batch.c``: the extension's loops, with the header and their prototypes."""
        R = job.rendered
        [(template, name)] = [(t, w) for t, w in self.templates(R.prefix) if w != EXTENSION]
        return {name: environment().get_template(template).render(
            version=__version__, prefix=R.prefix, loops=R.extension.lstrip("\n"),
            declarations=[d for d in R.extension_cdef.splitlines() if d])}


#: The batch target.
BATCH = Batch()

__all__ = ["BATCH", "Batch"]
