r"""Ensembles: parameter studies and Monte Carlo runs of one scene, serially or on Dask.

``ensemble(scene, grid={"l": [1, 2, 4]}, samples={"m": ("uniform", 0.5, 2)}, n=100)``
builds the members in this process (the grids' product, each point repeated
``n`` times with fresh draws of ``samples``; seeded, so the same call gives
the same members), then integrates them in chunks.  Each chunk is one C call
(:func:`mbgen.runtime.batch.integrate`); on Dask every chunk is a task.

What travels to a worker: the rendered sources (plain strings, scattered
once) with their content hash, and the chunk's ``(k, n_x)`` initial states and
``(k, n_p)`` parameters.  A worker checks the hash against the sources,
compiles them (portable flags) into its own cache (``$MBGEN_CACHE_DIR`` or
``~/.cache/mbgen``; no shared file system assumed) at most once per process,
and returns arrays.  Nothing compiled is pickled.

A failed member (mass matrix not positive definite, step too small, ...)
keeps its row with its C status and message and ``NaN`` results; a failed
task (a compiler error, a worker that died running it) marks its members with
status ``-1`` and the reason.  Neither stops the ensemble, and no finished
chunk is lost (:mod:`mbgen.studies.cluster`: what Dask advises, with bounded
retries: each chunk runs at most twice).  Nor is the wait unbounded (``chunk_timeout``,
``max_restarts``: workers that crash as they start fail no task): past it the unfinished
chunks' members are marked ``-1``, "task abandoned", and the rest is returned.

Counts are checked before any work (``chunk``, ``n``, ``n_workers`` >= 1; at most
:data:`MAX_POINTS` output times, :data:`MAX_MEMBERS` members, a table that fits in
memory); an automatic chunk's trajectories stay under :data:`CHUNK_BYTES`.

The result is one table, a NumPy structured array with one row per member
(``member``, the varied names, ``status``, ``message``, ``t_reached``,
``n_steps``, then ``final_<state>``, ``min_<state>``, ``max_<state>``; with
``trajectories=True`` a field ``x`` of shape ``(n_t, n_x)``, and a field per
model output asked for with ``outputs=``, e.g. ``energy`` of shape ``(n_t, 2)``).  Chosen
over pandas and xarray: no new dependency, exact float64 bits (the tests compare runs
bit for bit), a fixed-shape field holds the trajectories; ``to_pandas()`` converts.
"""

from __future__ import annotations

import itertools
import math
import os
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..abi import Output, Rendered
from ..build.extension import compiled_path, load, wants_native
from ..errors import ArgumentError, MbgenError, SceneError
from ..fileio import write_atomic
from ..integrators import DEFAULT_ATOL, DEFAULT_RTOL, METHODS
from ..pipeline import run
from ..runtime import batch
from ..runtime.arguments import whole_number
from .cluster import CHUNK_TIMEOUT, Abandoned, Patience, lost_worker, reach, run_chunks

#: Members per task when ``chunk`` is not given: about 4 tasks per worker, at most this.
MAX_CHUNK = 2000
#: Bytes of one automatic chunk's trajectories (members x output times x states doubles).
CHUNK_BYTES = 2**28
#: Most output times of an ensemble (``n_out``, ``t_eval``; ``mbgen sweep --points``).
MAX_POINTS = 1_000_000
#: Most members of an ensemble (the grids' product times ``n``).
MAX_MEMBERS = 10_000_000


# ------------------------------------------------------------------ members
def parse_grid(items) -> dict[str, list[float]]:
    """``["l=1,2,4", "m=0.5:2:4"]`` (values, or ``lo:hi:n`` evenly spaced) -> ``{name: values}``."""
    out = {}
    for item in items or ():
        if "=" not in item:
            raise SceneError(f"grid {item!r} must look like NAME=V1,V2 or NAME=LO:HI:N")
        name, spec = (s.strip() for s in item.split("=", 1))
        try:
            if ":" in spec:
                lo, hi, n = spec.split(":")
                lo, hi, n = float(lo), float(hi), int(n)
            else:
                out[name] = [float(v) for v in spec.split(",")]
        except ValueError:
            raise SceneError(f"grid {item!r}: values must be numbers (NAME=1,2,3 or "
                             f"NAME=0.5:2:4)") from None
        if ":" in spec:
            if not 1 <= n <= MAX_MEMBERS:
                raise SceneError(f"grid {item!r}: give from 1 to {MAX_MEMBERS:,} points")
            out[name] = np.linspace(lo, hi, n).tolist()
    return out


def parse_samples(items) -> dict[str, tuple]:
    """``["m=uniform:0.5:2", "q2=normal:1:0.1"]`` -> ``{name: (distribution, a, b)}``."""
    out = {}
    for item in items or ():
        try:
            name, spec = (s.strip() for s in item.split("=", 1))
            kind, a, b = spec.split(":")
            out[name] = (kind, float(a), float(b))
        except ValueError:
            raise SceneError(f"samples {item!r} must look like NAME=uniform:LO:HI or "
                             f"NAME=normal:MEAN:SIGMA") from None
    return out


def _draw(rng, spec, n: int, name: str) -> np.ndarray:
    if callable(spec):
        return np.asarray(spec(rng, n), dtype=float).reshape(n)
    kind, a, b = spec
    if kind == "uniform":
        return rng.uniform(a, b, n)
    if kind == "normal":
        return rng.normal(a, b, n)
    raise SceneError(f"samples of {name!r}: unknown distribution {kind!r}; use 'uniform' "
                     f"or 'normal', or a function (rng, n) -> values")


def members(scene, layout, grid=None, samples=None, n=None, seed=0):
    """``(names, values (k, m), x0 (k, n_x), p (k, n_p))`` of the ensemble."""
    grid, samples = dict(grid or {}), dict(samples or {})
    varied = list(grid) + [s for s in samples if s not in grid]
    known = set(layout.state_names) | set(layout.parameter_names)
    for name in varied:
        if name not in known:
            where = (f"it is baked into the code (fixed={dict(scene.fixed)}); drop it from the "
                     f"scene's fixed parameters to vary it" if name in scene.fixed else
                     f"states: {list(layout.state_names)}, free parameters: "
                     f"{list(layout.parameter_names)}")
            raise SceneError(f"cannot vary {name!r}: {where}")
    n = (1 if grid else 100) if n is None else whole_number(n, "n", 1, MAX_MEMBERS)
    k = math.prod(len(v) for v in grid.values()) * n
    if k > MAX_MEMBERS:
        raise ArgumentError(f"{k:,} members (the grids' product times n={n}) are more than "
                            f"{MAX_MEMBERS:,}; ask for fewer")
    points = list(itertools.product(*grid.values())) or [()]
    rng = np.random.default_rng(seed)
    values = np.empty((k, len(varied)))
    for j in range(len(grid)):
        values[:, j] = np.repeat([pt[j] for pt in points], n)
    for j, name in enumerate(varied[len(grid):], start=len(grid)):
        values[:, j] = _draw(rng, samples[name], k, name)
    x0 = np.tile(scene.x0(layout), (k, 1))
    p = np.tile(scene.p(layout), (k, 1))
    for j, name in enumerate(varied):
        if name in layout.state_names:
            x0[:, layout.state_names.index(name)] = values[:, j]
        else:
            p[:, layout.parameter_names.index(name)] = values[:, j]
    return varied, values, x0, p


# ------------------------------------------------------------------ worker side
class _Sources:
    """A rendered model as plain strings (what :func:`mbgen.build.extension.load` needs)."""

    def __init__(self, d: dict):
        self.prefix, self.files, self.cdef = d["prefix"], d["files"], d["cdef"]
        self.extension, self.extension_cdef = d["extension"], d["extension_cdef"]

    def digest(self) -> str:
        return Rendered.digest(self)


class _Raw:
    """The little of a CompiledModel that :func:`mbgen.runtime.batch.integrate` uses."""

    def __init__(self, module, prefix, n_x, n_p, n_r):
        self.ffi, self.lib = module.ffi, module.lib
        self.name, self.n_x, self.n_p, self.n_r = prefix, n_x, n_p, n_r
        self.rendered = type("R", (), {"prefix": prefix})
        self.state_names = [f"x{i}" for i in range(n_x)]
        self.parameter_names = [f"p{i}" for i in range(n_p)]
        self.input_names = [f"r{i}" for i in range(n_r)]


def worker_module(sources: dict, native: bool = False):
    """Load the model, compiling it into this process's cache if it is not there yet;
    ``(module, compiled)``, ``compiled`` True only for the call that ran the compiler.
    Portable flags (a cluster's machines may differ) unless ``native`` (a serial run) or
    ``MBGEN_NATIVE=1``."""
    src = _Sources(sources)
    if src.digest() != sources["digest"]:
        raise MbgenError("the rendered sources do not match their content hash; refusing to "
                         "compile them")
    native = wants_native(native)
    compiled = not compiled_path(src, native).exists()
    return load(src, native=native), compiled


def run_chunk(sources: dict, spec: dict, x0: np.ndarray, p: np.ndarray) -> dict:
    """Integrate one chunk of members; every array in the result has one row per member."""
    module, compiled = worker_module(sources, spec.get("native", False))
    raw = _Raw(module, sources["prefix"], spec["n_x"], spec["n_p"], spec["n_r"])
    t = np.asarray(spec["t"], dtype=float)
    res = batch.integrate(raw, Output(spec["method"]), t, x0, p if spec["n_p"] else None,
                          None, rtol=spec["rtol"], atol=spec["atol"], h0=spec["h0"],
                          h_max=0.0, max_steps=spec["max_steps"], on_failure="record")
    ok = res.status == 0
    x = np.where(ok[:, None, None], res.x, np.nan)
    out = dict(status=res.status, messages=list(res.messages),
               t_reached=res.stats["t_reached"], n_steps=res.stats["n_steps"],
               final=x[:, -1], min=x.min(axis=1), max=x.max(axis=1),
               worker=os.getpid(), compiled=compiled, seconds=res.wall_time)
    if spec["trajectories"]:
        out["x"] = x
    for name, c_name, args, shape in spec["outputs"]:
        out[name] = _output_at(raw, c_name, args, shape, t, res.x, p, ok)
    return out


def _output_at(raw, c_name, args, shape, t, x, p, ok) -> np.ndarray:
    """A model output at every member's output times, ``(k, n_t, *shape)`` (NaN where failed)."""
    k, n_t, n_x = x.shape
    size = int(np.prod(shape))
    flat = np.ascontiguousarray(x.reshape(k * n_t, n_x))
    tt = np.ascontiguousarray(np.tile(t, k))
    values = np.empty((k * n_t, size))
    status = np.zeros(k * n_t, dtype=np.intc)
    buf = raw.ffi.from_buffer
    call = [k * n_t, buf("double[]", tt), 1, buf("double[]", flat), n_x]
    if "p" in args:
        call += [buf("double[]", np.ascontiguousarray(np.repeat(p, n_t, axis=0))), raw.n_p]
    if "r" in args:
        call += [buf("double[]", np.zeros(max(raw.n_r, 1))), 0]
    getattr(raw.lib, f"{c_name}_batch")(*call, buf("double[]", values), buf("int[]", status))
    good = np.repeat(ok, n_t) & (status == 0)
    values[~good] = np.nan
    return values.reshape((k, n_t) + tuple(shape))


# ------------------------------------------------------------------ result
@dataclass
class EnsembleResult:
    """One row per member; see the module docstring for the fields of ``table``."""

    table: np.ndarray
    t: np.ndarray
    state_names: tuple
    varied: tuple
    method: str
    mode: str
    wall_time: float
    n_workers: int = 1
    compiles: dict = field(default_factory=dict)   # worker -> number of compiles there
    tasks: int = 0
    startup_time: float = 0.0                      # starting (and closing) a LocalCluster

    @property
    def n_failed(self) -> int:
        return int((self.table["status"] != 0).sum())

    def to_pandas(self):
        """The table as a ``pandas.DataFrame`` (scalar fields; needs pandas)."""
        import pandas as pd

        cols = [n for n in self.table.dtype.names if self.table.dtype[n].shape == ()]
        return pd.DataFrame({c: self.table[c] for c in cols})

    def to_csv(self) -> str:
        import csv
        import io

        cols = [n for n in self.table.dtype.names if self.table.dtype[n].shape == ()]
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(cols)
        for row in self.table:
            w.writerow([repr(float(row[c])) if self.table.dtype[c].kind == "f" else row[c]
                        for c in cols])
        return buf.getvalue()

    def write_csv(self, path):
        from pathlib import Path

        write_atomic(Path(path), self.to_csv())
        return Path(path)

    def summary(self) -> str:
        k = len(self.table)
        per = self.wall_time / max(k, 1) * 1e6
        lines = [f"{k} members ({', '.join(self.varied) or 'nothing varied'}), {self.method}, "
                 f"{self.mode}" + (f" with {self.n_workers} workers, {self.tasks} tasks"
                                   if self.mode == "dask" else "")
                 + f": {self.wall_time:.3f} s ({per:.1f} us per member), "
                   f"{self.n_failed} failed"]
        for status in sorted(set(self.table["status"].tolist()) - {0}):
            rows = self.table[self.table["status"] == status]
            lines.append(f"  status {status}: {len(rows)} members, e.g. member "
                         f"{rows['member'][0]}: {rows['message'][0]}")
        return "\n".join(lines)


def _row(varied, state_names, n_t, trajectories, extra) -> np.dtype:
    """The table's row (see the module docstring)."""
    fields = [("member", "i8")] + [(v, "f8") for v in varied] + [
        ("status", "i4"), ("message", "U120"), ("t_reached", "f8"), ("n_steps", "i8")]
    for what in ("final", "min", "max"):
        fields += [(f"{what}_{s}", "f8") for s in state_names]
    if trajectories:
        fields.append(("x", "f8", (n_t, len(state_names))))
    fields += [(name, "f8", (n_t,) + tuple(shape)) for name, _, _, shape in extra]
    return np.dtype(fields)


def _check_memory(row: np.dtype, k: int) -> None:
    """Refuse a table larger than this machine's memory (where the machine says)."""
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # not a POSIX system: nothing to go by
        return
    if row.itemsize * k > memory:
        raise ArgumentError(f"the table of {k:,} members would take "
                            f"{row.itemsize * k / 2**30:,.1f} GiB, more than this machine's "
                            f"{memory / 2**30:,.1f} GiB; ask for fewer members or output "
                            f"times, or leave out trajectories and outputs")


def _table(row, varied, values, state_names, chunks, k, trajectories, extra) -> np.ndarray:
    table = np.zeros(k, dtype=row)
    table["member"] = np.arange(k)
    for j, v in enumerate(varied):
        table[v] = values[:, j]
    for (lo, hi), out in chunks:
        table["status"][lo:hi] = out["status"]
        table["message"][lo:hi] = [m[:120] for m in out["messages"]]
        table["t_reached"][lo:hi] = out["t_reached"]
        table["n_steps"][lo:hi] = out["n_steps"]
        for what in ("final", "min", "max"):
            for i, s in enumerate(state_names):
                table[f"{what}_{s}"][lo:hi] = out[what][:, i]
        if trajectories:
            table["x"][lo:hi] = out["x"]
        for name, _, _, _ in extra:
            table[name][lo:hi] = out[name]
    return table


def _why(exc: Exception) -> str:
    """A failed task's reason, as its members' message."""
    if isinstance(exc, Abandoned):
        return f"task abandoned: {exc}"
    if lost_worker(exc):
        return (f"task failed: worker lost ({type(exc).__name__}): its worker died running "
                f"this chunk, also alone; not run")
    return f"task failed: {type(exc).__name__}: {exc}"


def _failed_chunk(lo, hi, n_x, n_t, exc, trajectories, extra=()) -> dict:
    k = hi - lo
    nan = np.full((k, n_x), np.nan)
    out = dict(status=np.full(k, -1), messages=[_why(exc)] * k,
               t_reached=np.full(k, np.nan), n_steps=np.zeros(k, dtype=int), final=nan,
               min=nan, max=nan, worker=None, compiled=False)
    if trajectories:
        out["x"] = np.full((k, n_t, n_x), np.nan)
    for name, _, _, shape in extra:
        out[name] = np.full((k, n_t) + tuple(shape), np.nan)
    return out


# ------------------------------------------------------------------ driver
def ensemble(scene, *, grid: Mapping | None = None, samples: Mapping | None = None,
             n: int | None = None, seed: int = 0, method: str | None = None,
             t_end: float | None = None, t_eval=None, n_out: int = 2, rtol: float = DEFAULT_RTOL,
             atol: float = DEFAULT_ATOL, h: float | None = None, max_steps: int = 0,
             trajectories: bool = False, outputs=(), address: str | None = None, n_workers: int = 2,
             client: Any = None, chunk: int | None = None, serial: bool = False,
             progress: bool = True, chunk_timeout: float = CHUNK_TIMEOUT,
             max_restarts: int | None = None) -> EnsembleResult:
    """Run a parameter study or Monte Carlo ensemble of ``scene``.

    Parameters
    ----------
    scene : Scene
    grid : mapping name -> values, optional
        Free parameters or initial states on a grid (the product of all grids).
    samples : mapping name -> (``"uniform"``, lo, hi) | (``"normal"``, mean, sigma) | callable
        Drawn per member (``callable(rng, k) -> values``).
    n : int, optional
        Members per grid point (default 1 with a grid, else 100).
    seed : int
        Seed of the draws.
    method : str, optional
        ``dopri5``, ``rosenbrock`` or ``rk4`` (default: the scene's integrator).
    t_end, t_eval, n_out
        Output times: ``t_eval``, or ``n_out`` evenly spaced from the scene's
        start to ``t_end`` (default: the scene's end).
    rtol, atol, h, max_steps
        As :meth:`mbgen.runtime.compiled.CompiledModel.integrate` (``h``: the step of rk4).
    trajectories : bool
        Keep every member's states at the output times (field ``x``).
    outputs : names of model outputs
        Evaluated at every output time (e.g. ``("energy",)``: field ``energy`` of
        shape ``(n_t, 2)``); added to the scene's outputs.
    address : str, optional
        A running Dask scheduler, reached within
        :data:`~mbgen.studies.cluster.CONNECT_TIMEOUT` seconds or refused
        (:class:`~mbgen.errors.UsageError`); default: a ``LocalCluster`` of ``n_workers``
        single-threaded worker processes, closed afterwards.
    client : dask.distributed.Client, optional
        Use this client (and leave it open).
    chunk : int, optional
        Members per task, at least 1 (default: about 4 tasks per worker, each chunk's
        trajectories under :data:`CHUNK_BYTES`).
    serial : bool
        Run in this process, no Dask.
    progress : bool
        Show a progress bar (tqdm, on stderr).
    chunk_timeout : float
        On Dask, seconds to wait for the next chunk to finish (the per-chunk timeout, from
        the last chunk that finished; default :data:`~mbgen.studies.cluster.CHUNK_TIMEOUT`,
        ``math.inf``: none); then the unfinished chunks are abandoned, members failed.
    max_restarts : int, optional
        On Dask, worker deaths tolerated while no chunk finishes (default
        :data:`~mbgen.studies.cluster.RESTARTS_PER_WORKER` per worker); one more abandons
        the unfinished chunks likewise.
    """
    if chunk is not None:
        whole_number(chunk, "chunk")
    patience = Patience(chunk_timeout, max_restarts)
    if not serial and client is None:
        if address:
            reach(address)  # a bad address fails now, not after the derivation
        else:
            whole_number(n_workers, "n_workers")
    if t_eval is None:
        whole_number(n_out, "n_out", 1, MAX_POINTS)
    else:
        whole_number(np.size(t_eval), "len(t_eval)", 0, MAX_POINTS)
    extra_outputs = Output.parse(outputs) if outputs else ()
    if any(o.is_integrator for o in extra_outputs):
        raise SceneError("outputs evaluated at the output times cannot be integrators; "
                         "choose the integrator with method=")
    want = None if method is None else (Output(method.lower()),)
    result = run(scene, tuple(scene.outputs) + (want or ()) + extra_outputs, build=serial)
    L, rendered = result.layout, result.rendered
    integrators = [o.value for o in result.kernel.integrators]
    method = method.lower() if method else (integrators[0] if integrators else None)
    if method not in integrators:
        raise SceneError(f"scene {scene.name!r} generates no C integrator "
                         f"{method!r}; pass method='dopri5' (or rosenbrock, rk4)")
    if not METHODS[Output(method)].adaptive and h is None:
        raise SceneError(f"the {method} ensemble needs its fixed step: pass h")
    if t_eval is None:
        t0 = float(scene.t_span[0])
        t1 = float(scene.t_span[1] if t_end is None else t_end)
        t_eval = np.linspace(t0, t1, max(n_out, 2))
    t = np.asarray(t_eval, dtype=float)
    varied, values, x0, p = members(scene, L, grid, samples, n, seed)
    k = len(x0)
    infos = {f.output: f for f in rendered.functions}
    extra = [(o.value, infos[o.value].c_name, tuple(infos[o.value].args),
              tuple(infos[o.value].out_shape)) for o in extra_outputs]
    row = _row(varied, L.state_names, t.size, trajectories, extra)
    _check_memory(row, k)
    spec = dict(method=method, t=t, rtol=float(rtol), atol=float(atol), outputs=extra,
                h0=0.0 if h is None else float(h), max_steps=int(max_steps),
                n_x=L.n_x, n_p=L.n_p, n_r=L.n_r, trajectories=bool(trajectories), native=serial)
    sources = rendered.sources()
    workers = 1 if serial else n_workers
    size = chunk or max(1, min(MAX_CHUNK, math.ceil(k / (4 * max(workers, 1))),
                               CHUNK_BYTES // (8 * t.size * max(L.n_x, 1))))
    bounds = [(lo, min(lo + size, k)) for lo in range(0, k, size)]
    from tqdm import tqdm

    bar = tqdm(total=k, disable=not progress, unit="member", desc=scene.name)
    start = time.perf_counter()
    if serial:
        results = _run_serial(sources, spec, x0, p, bounds, bar)
        mode, n_workers_used, startup = "serial", 1, 0.0
    else:
        results, n_workers_used, startup = run_chunks(
            run_chunk, sources, [(spec, x0[lo:hi], p[lo:hi]) for lo, hi in bounds],
            address=address, n_workers=n_workers, client=client, patience=patience,
            done=lambda i: bar.update(bounds[i][1] - bounds[i][0]))
        mode = "dask"
    wall = time.perf_counter() - start - startup
    bar.close()
    chunks = [((lo, hi), _failed_chunk(lo, hi, L.n_x, t.size, out, trajectories, extra)
               if isinstance(out, BaseException) else out)
              for (lo, hi), out in zip(bounds, results)]
    compiles = _compiles(chunks)
    table = _table(row, varied, values, L.state_names, chunks, k, trajectories, extra)
    return EnsembleResult(table, t, tuple(L.state_names), tuple(varied), method, mode, wall,
                          n_workers_used, compiles, len(bounds), startup)


def _run_serial(sources: dict, spec: dict, x0: np.ndarray, p: np.ndarray, bounds, bar) -> list:
    """Each chunk's result (or its exception) run in this process, one after another."""
    results = []
    for lo, hi in bounds:
        try:
            results.append(run_chunk(sources, spec, x0[lo:hi], p[lo:hi]))
        except Exception as exc:  # recorded per member, never fatal
            results.append(exc)
        bar.update(hi - lo)
    return results


def _compiles(chunks) -> dict:
    """worker -> number of compiles there, over the chunks that ran."""
    compiles: dict = {}
    for _, out in chunks:
        if out["worker"] is not None:
            compiles[out["worker"]] = compiles.get(out["worker"], 0) + int(out["compiled"])
    return compiles


__all__ = ["ensemble", "EnsembleResult", "members", "run_chunk", "parse_grid", "parse_samples",
           "worker_module"]
