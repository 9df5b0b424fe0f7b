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

from ..templating import environment


def _tail(layout) -> tuple[str, str]:
    params = "".join(f", const double *{a}, long {a}_stride"
                     for a, n in (("p", layout.n_p), ("r", layout.n_r)) if n)
    args = "".join(f", {a} + i * {a}_stride" for a, n in (("p", layout.n_p), ("r", layout.n_r))
                   if n)
    return params, args


def batch_source(kernel, views: list[dict], prefix: str) -> tuple[str, str]:
    """``(C source, cffi cdef)`` of the batch loops of ``kernel``."""
    L = kernel.layout
    params, args = _tail(L)
    integrators = [o.value for o in kernel.integrators]
    ctx = dict(prefix=prefix, upper=prefix.upper(), batch=dict(
        functions=[dict(name=v["name"], out_size=v["out_size"]) for v in views],
        integrators=integrators, params=params, args=args, n_x=L.n_x))
    source = environment().get_template("batch/batch.c.j2").render(ctx)
    cdef = [f"int {v['name']}_batch(long k, const double *t, long t_stride, const double *x, "
            f"long x_stride{params}, double *out, int *status);" for v in views]
    cdef += [f"int {prefix}_{m}_batch(long k, const double *x0, long x0_stride{params}, "
             f"int n_out, const double *t_out, double *x_out, const {prefix}_options *opt, "
             f"{prefix}_stats *stats, int *status"
             + (f", {prefix}_rosenbrock_work *work);" if m == "rosenbrock" else ");")
             for m in integrators]
    return source, "\n".join(cdef) + "\n"


__all__ = ["batch_source"]
