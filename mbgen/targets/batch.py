r"""Batch evaluation in C: one loop over ``k`` items, no Python per item.

``templates/batch.c.j2`` renders, for every generated function
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

from ..render import environment


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
    source = environment().get_template("batch.c.j2").render(ctx)
    cdef = [f"int {v['name']}_batch(long k, const double *t, long t_stride, const double *x, "
            f"long x_stride{params}, double *out, int *status);" for v in views]
    cdef += [f"int {prefix}_{m}_batch(long k, const double *x0, long x0_stride{params}, "
             f"int n_out, const double *t_out, double *x_out, const {prefix}_options *opt, "
             f"{prefix}_stats *stats, int *status"
             + (f", {prefix}_rosenbrock_work *work);" if m == "rosenbrock" else ");")
             for m in integrators]
    return source, "\n".join(cdef) + "\n"


__all__ = ["batch_source"]


# ------------------------------------------------------------------ runtime half
def _rows(model, value, n: int, what: str, names, k: int | None):
    """``(array (k', n) C-contiguous, stride)``: a 1-D value broadcasts (stride 0)."""
    import numpy as np

    from ..errors import ArgumentError, ArgumentTypeError

    try:
        a = np.asarray(value)
    except Exception as exc:  # ragged lists and the like
        raise ArgumentError(f"{what} must be an array of shape ({n},) or (k, {n}): {exc}") \
            from None
    if a.dtype.kind not in "iuf":
        raise ArgumentTypeError(f"{what} must hold real numbers (float64); got dtype {a.dtype}")
    if a.ndim == 1 and a.shape == (n,):
        return np.ascontiguousarray(a, dtype=float).reshape(1, n), 0
    if a.ndim == 2 and a.shape[1] == n and (k is None or a.shape[0] == k):
        return np.ascontiguousarray(a, dtype=float), n
    want = f"({n},) or ({k if k is not None else 'k'}, {n})"
    raise ArgumentError(f"{what} must have shape {want} for {list(names)}; got shape {a.shape}")


def is_batch(x, p=None, r=None) -> bool:
    """Whether a call gets a batch: a 2-D ``x``, ``p`` or ``r``."""
    return any(v is not None and _two_d(v) for v in (x, p, r))


def _scalar_time(t) -> bool:
    """Whether a batch call's ``t`` is one number (else it must be one per item)."""
    import numpy as np

    try:
        return np.ndim(t) == 0
    except ValueError:  # ragged: not a number, and the shape check names it
        return False


def _two_d(v) -> bool:
    import numpy as np

    try:
        return np.ndim(v) == 2
    except ValueError:  # ragged nested lists: the array checks name the problem
        return False


def _batch_args(model, x, p, r, x_what="state x"):
    """Validated ``(k, [(array, stride)] for x, p, r)`` of a batch call."""
    import numpy as np

    k = None
    for v, n in ((x, model.n_x), (p, model.n_p), (r, model.n_r)):
        if v is not None and _two_d(v):
            rows = np.shape(v)[0]
            if k is not None and rows != k:
                from ..errors import ArgumentError
                raise ArgumentError(f"batch sizes differ: {k} and {rows} rows")
            k = rows
    xs = _rows(model, x, model.n_x, x_what, model.state_names, k)
    ps = _rows(model, model._p(None) if p is None else p, model.n_p, "parameters p",
               model.parameter_names, k) if model.n_p else (np.zeros((1, 0)), 0)
    rs = _rows(model, np.zeros(model.n_r) if r is None else r, model.n_r, "inputs r",
               model.input_names, k) if model.n_r else (np.zeros((1, 0)), 0)
    return k, xs, ps, rs


def batch_times(model, t, k: int):
    """``(times, stride)`` of a batch of ``k``: one time for all (stride 0) or ``k`` of them."""
    import numpy as np

    if _scalar_time(t):
        return np.array([model._t(t)]), 0
    from ..errors import ArgumentError
    from ..runtime import _real_vector

    try:
        shape = np.shape(t)
    except ValueError:
        shape = "ragged"
    if shape != (k,):
        raise ArgumentError(f"t must be a number or have shape ({k},); got shape {shape}")
    return _real_vector(t, k, "t", ()), 1


def evaluate(model, info, t, x, p, r):
    """One output for a batch: ``x (k, n_x)`` (and/or ``p``, ``r`` with ``k`` rows) -> ``(k, *shape)``."""
    import numpy as np

    from ..errors import MbgenError

    k, (xa, xs), (pa, ps), (ra, rs) = _batch_args(model, x, p, r)
    ta, ts = batch_times(model, t, k)
    out = np.empty((k,) + tuple(info.out_shape))
    status = np.zeros(k, dtype=np.intc)
    buf = model.ffi.from_buffer
    args = [k, buf("double[]", ta), ts, buf("double[]", xa), xs]
    if "p" in info.args:
        args += [buf("double[]", pa), ps]
    if "r" in info.args:
        args += [buf("double[]", ra), rs]
    failed = getattr(model.lib, f"{info.c_name}_batch")(*args, buf("double[]", out),
                                                        buf("int[]", status))
    if failed:
        i = int(np.flatnonzero(status)[0])
        try:
            model._fail(int(status[i]), info.output, ta[i * ts], xa[i * (xs > 0)])
        except MbgenError as exc:
            raise type(exc)(f"batch item {i} of {k} ({failed} failed): {exc}") from None
    return out


def integrate(model, output, t, x0, p, r, *, rtol, atol, h0, h_max, max_steps,
              on_failure: str = "raise"):
    """Batch of trajectories in one C call: see :meth:`mbgen.runtime.CompiledModel.integrate`.

    Returns a :class:`BatchIntegration`; with ``on_failure="raise"`` the first failed
    member raises :class:`~mbgen.errors.IntegrationError`.
    """
    import time

    import numpy as np

    from ..errors import ArgumentError, IntegrationError

    if on_failure not in ("raise", "record"):
        raise ArgumentError(f"on_failure must be 'raise' or 'record'; got {on_failure!r:.40}")
    k, (xa, xs), (pa, ps), (ra, rs) = _batch_args(model, x0, p, r, "initial states x0")
    if not np.all(np.isfinite(xa)):
        raise ArgumentError("initial states x0 must be finite")
    ffi, prefix = model.ffi, model.rendered.prefix
    buf = ffi.from_buffer
    opt = ffi.new(f"{prefix}_options *", {"rtol": rtol, "atol": atol, "h0": h0,
                                          "h_max": h_max, "max_steps": int(max_steps)})
    stats = ffi.new(f"{prefix}_stats[]", k)
    status = np.zeros(k, dtype=np.intc)
    x_out = np.empty((k, t.size, model.n_x))
    args = [k, buf("double[]", xa), xs]
    if model.n_p:
        args += [buf("double[]", pa), ps]
    if model.n_r:
        args += [buf("double[]", ra), rs]
    start = time.perf_counter()
    work = (ffi.new(f"{prefix}_rosenbrock_work *"),) if output.value == "rosenbrock" else ()
    getattr(model.lib, f"{prefix}_{output.value}_batch")(
        *args, t.size, buf("double[]", t), buf("double[]", x_out), opt, stats,
        buf("int[]", status), *work)
    wall = time.perf_counter() - start
    struct = f"{prefix}_stats"
    fields = ("n_steps", "n_rejected", "n_rhs", "n_jac", "n_lu", "t_reached")
    layout = np.dtype(dict(names=list(fields),
                           formats=[f"i{ffi.sizeof('long')}"] * 5 + ["f8"],
                           offsets=[ffi.offsetof(struct, f) for f in fields],
                           itemsize=ffi.sizeof(struct)))
    raw = np.frombuffer(ffi.buffer(stats), dtype=layout, count=k).astype(
        [(f, "i8") for f in fields[:5]] + [("t_reached", "f8")])
    result = BatchIntegration(t, x_out, output.value, status.astype(int), raw, wall,
                              tuple(status_message(prefix, int(s)) for s in status))
    if on_failure == "raise" and status.any():
        i = int(np.flatnonzero(status)[0])
        raise IntegrationError(f"{model.name}.integrate({output.value!r}): member {i} of {k} "
                               f"failed ({int((status != 0).sum())} failed): "
                               f"{result.messages[i]} at t_reached={raw['t_reached'][i]!r}",
                               int(status[i]), float(raw["t_reached"][i]))
    return result


def status_message(prefix: str, status: int) -> str:
    """``"<PREFIX>_CODE: text"`` of a C status code (``""`` for OK)."""
    from ..render import INTEGRATOR_STATUS_CODES, STATUS_CODES

    if status == 0:
        return ""
    names = {v: (n, text) for n, v, text in STATUS_CODES + INTEGRATOR_STATUS_CODES}
    code, text = names.get(status, ("UNKNOWN", "unknown error"))
    return f"{prefix.upper()}_{code}: {text}"


from dataclasses import dataclass  # noqa: E402


@dataclass(frozen=True)
class BatchIntegration:
    """Trajectories of a batch (:meth:`CompiledModel.integrate` with 2-D ``x0``, ``p`` or ``r``).

    Attributes
    ----------
    t : ndarray (n_t,)
    x : ndarray (k, n_t, n_x)
        Member ``i``'s states; rows after a failure are undefined.
    method : str
    status : ndarray (k,) of int
        C status per member (0: success).
    stats : structured ndarray (k,)
        ``n_steps, n_rejected, n_rhs, n_jac, n_lu, t_reached`` per member.
    wall_time : float
        Seconds in the one C call.
    messages : tuple of str
        ``""`` or the status code's name and meaning, per member.
    """

    t: object
    x: object
    method: str
    status: object
    stats: object
    wall_time: float
    messages: tuple


__all__ = ["batch_source", "is_batch", "evaluate", "integrate", "BatchIntegration",
           "status_message"]
