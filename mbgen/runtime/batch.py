r"""Batch calls in C from Python: ``k`` items in one call of a generated batch loop.

The loops themselves are rendered by :mod:`mbgen.codegen.targets.batch` into the Python
extension (``<prefix>_<output>_batch``, ``<prefix>_<method>_batch``); this module
checks a batch's arrays, calls them and names failures.  A 1-D ``x``, ``p`` or
``r`` is shared by every item (stride 0); 2-D ones have ``k`` rows.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..abi import status_message
from ..errors import ArgumentError, ArgumentTypeError, IntegrationError, MbgenError
from ..integrators import METHODS
from .arguments import real_vector


def _rows(model, value, n: int, what: str, names, k: int | None):
    """``(array (k', n) C-contiguous, stride)``: a 1-D value broadcasts (stride 0)."""
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


def scalar_time(t) -> bool:
    """Whether a batch call's ``t`` is one number (else it must be one per item)."""
    try:
        return np.ndim(t) == 0
    except ValueError:  # ragged: not a number, and the shape check names it
        return False


def _two_d(v) -> bool:
    try:
        return np.ndim(v) == 2
    except ValueError:  # ragged nested lists: the array checks name the problem
        return False


def batch_args(model, x, p, r, x_what="state x"):
    """Validated ``(k, [(array, stride)] for x, p, r)`` of a batch call."""
    k = None
    for v in (x, p, r):
        if v is not None and _two_d(v):
            rows = np.shape(v)[0]
            if k is not None and rows != k:
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
    if scalar_time(t):
        return np.array([model._t(t)]), 0
    try:
        shape = np.shape(t)
    except ValueError:
        shape = "ragged"
    if shape != (k,):
        raise ArgumentError(f"t must be a number or have shape ({k},); got shape {shape}")
    return real_vector(t, k, "t", ()), 1


def evaluate(model, info, t, x, p, r):
    """One output for a batch: ``x (k, n_x)`` (and/or ``p``, ``r`` with ``k`` rows) ->
    ``(k, *shape)``."""
    k, (xa, xs), (pa, ps), (ra, rs) = batch_args(model, x, p, r)
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


def options(model, *, rtol, atol, h0, h_max, max_steps, project) -> tuple[dict, bool]:
    """The fields of ``<prefix>_options`` for one call of a generated integrator, and whether
    the model projects onto its constraints (then ``no_projection`` is among them and the
    stats carry ``max_residual``)."""
    settings = {"rtol": rtol, "atol": atol, "h0": h0, "h_max": h_max,
                "max_steps": int(max_steps)}
    projects = "no_projection" in dict(
        model.ffi.typeof(f"{model.rendered.prefix}_options").fields)
    if projects:
        settings["no_projection"] = 0 if project else 1
    return settings, projects


def integrate(model, output, t, x0, p, r, *, rtol, atol, h0, h_max, max_steps,
              on_failure: str = "raise", project: bool = True,
              check_start: Callable | None = None):
    """Batch of trajectories in one C call: see
    :meth:`mbgen.runtime.compiled.CompiledModel.integrate`.

    ``check_start(t0, x0, p, r)`` (the batch, validated) refuses starts off the configuration
    constraints, as the single call does; ``project=False`` turns the C projection off.
    Returns a :class:`BatchIntegration`; with ``on_failure="raise"`` the first failed
    member raises :class:`~mbgen.errors.IntegrationError`.
    """
    if on_failure not in ("raise", "record"):
        raise ArgumentError(f"on_failure must be 'raise' or 'record'; got {on_failure!r:.40}")
    k, (xa, xs), (pa, ps), (ra, rs) = batch_args(model, x0, p, r, "initial states x0")
    if not np.all(np.isfinite(xa)):
        raise ArgumentError("initial states x0 must be finite")
    if check_start:
        check_start(t[0], xa if xs else xa[0], (pa if ps else pa[0]) if model.n_p else None,
                    (ra if rs else ra[0]) if model.n_r else None)
    ffi, prefix = model.ffi, model.rendered.prefix
    buf = ffi.from_buffer
    settings, projects = options(model, rtol=rtol, atol=atol, h0=h0, h_max=h_max,
                                 max_steps=max_steps, project=project)
    opt = ffi.new(f"{prefix}_options *", settings)
    stats = ffi.new(f"{prefix}_stats[]", k)
    status = np.zeros(k, dtype=np.intc)
    x_out = np.empty((k, t.size, model.n_x))
    args = [k, buf("double[]", xa), xs]
    if model.n_p:
        args += [buf("double[]", pa), ps]
    if model.n_r:
        args += [buf("double[]", ra), rs]
    start = time.perf_counter()
    work = (ffi.new(f"{prefix}_{output.value}_work *"),) if METHODS[output].implicit else ()
    getattr(model.lib, f"{prefix}_{output.value}_batch")(
        *args, t.size, buf("double[]", t), buf("double[]", x_out), opt, stats,
        buf("int[]", status), *work)
    wall = time.perf_counter() - start
    struct = f"{prefix}_stats"
    fields = ("n_steps", "n_rejected", "n_rhs", "n_jac", "n_lu", "t_reached") + (
        ("max_residual",) if projects else ())
    floats = ["f8"] * (len(fields) - 5)
    layout = np.dtype(dict(names=list(fields),
                           formats=[f"i{ffi.sizeof('long')}"] * 5 + floats,
                           offsets=[ffi.offsetof(struct, f) for f in fields],
                           itemsize=ffi.sizeof(struct)))
    raw = np.frombuffer(ffi.buffer(stats), dtype=layout, count=k).astype(
        [(f, "i8") for f in fields[:5]] + [(f, "f8") for f in fields[5:]])
    result = BatchIntegration(t, x_out, output.value, status.astype(int), raw, wall,
                              tuple(status_message(prefix, int(s)) for s in status))
    if on_failure == "raise" and status.any():
        i = int(np.flatnonzero(status)[0])
        raise IntegrationError(f"{model.name}.integrate({output.value!r}): member {i} of {k} "
                               f"failed ({int((status != 0).sum())} failed): "
                               f"{result.messages[i]} at t_reached={raw['t_reached'][i]!r}",
                               int(status[i]), float(raw["t_reached"][i]))
    return result


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
        ``n_steps, n_rejected, n_rhs, n_jac, n_lu, t_reached`` per member, and
        ``max_residual`` (the largest configuration-constraint residual met, as
        ``Trajectory.max_residual``) for a model with configuration constraints.
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


__all__ = ["is_batch", "scalar_time", "batch_args", "batch_times", "evaluate", "integrate",
           "options", "BatchIntegration"]
