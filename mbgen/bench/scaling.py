"""Scaling benchmark: mbgen against plain sympy on the n-link pendulum on a cart.

For every ``n`` both sides run in the same process, one after the other, on
the same model (:mod:`mbgen.scenes.n_link_cart` is
:func:`sympy.physics.mechanics.models.n_link_pendulum_on_cart` with
``cart_force=True``, same symbols and state order):

mbgen
    the stages of :func:`mbgen.pipeline.run` with Kane's method (what
    :func:`mbgen.derive` takes for this model at every ``n``); *derive*: ``build_model(n)``
    + the derivation; *CSE*: :func:`mbgen.codegen.optimize.optimize` (RHS output; this
    includes block assembly, power hoisting and the operation counts); *render*;
    *compile*: :func:`mbgen.build.extension.load` into an empty temporary cache, so the C
    compiler really runs (the *bake* stage has nothing to bake here and is not reported);
    *RHS*: one ``CompiledModel.rhs(t, x, p, r)`` call.
sympy
    *derive*: ``n_link_pendulum_on_cart(n, cart_force=True)`` (builds the model,
    ``KanesMethod`` and ``kanes_equations``) plus reading ``mass_matrix_full``
    and ``forcing_full``; *CSE*: ``sympy.cse`` over the entries of both;
    *RHS*: the usual PyDy-style right-hand side, ``lambdify(..., cse=True)`` of
    ``M_full`` and ``F_full`` and ``numpy.linalg.solve`` (lambdify itself is
    not timed).

Method
------
* Wall time by :func:`time.perf_counter`.
* Symbolic stages (derive, CSE, render, compile) take seconds, so each is
  measured **once** per ``n``.  sympy's global cache is cleared before each
  side's derive so neither side profits from expressions the other built.
  A warm-up pass at ``n = 1`` (not reported) first pays the one-time costs
  (imports, template loading, the first compiler start), which would
  otherwise land on the first row.
* An RHS call is timed as a loop of ``number`` calls divided by ``number``
  (``number`` doubled until a loop takes at least :data:`MIN_LOOP_S`), with the
  garbage collector off as in :mod:`timeit`; the median of ``repeats`` loops is
  reported.  Both sides are evaluated at the same state, parameters and input,
  and their results compared (:attr:`ScalingRow.rhs_max_abs_diff`).
* Operation counts use :mod:`mbgen.symbolic.graph` on both sides: *before* is
  :func:`~mbgen.symbolic.graph.count_ops_tree` of the expressions handed to CSE,
  *after* counts the CSE output the way :attr:`mbgen.codegen.optimize.Kernel.ops_after`
  does (each temporary and each output expression once).  mbgen's RHS holds the
  lower triangle of ``M`` (n_u x n_u), ``F`` and ``G``; sympy's holds all of
  ``M_full`` (2 n_u square, with the identity block) and ``F_full``.
* BLAS threads are pinned to one for the whole run with ``threadpoolctl``
  (the sympy RHS calls ``numpy.linalg.solve``); the table footer says so.

Timings on a shared or small machine are noisy; compare ratios within one run.
"""

from __future__ import annotations

import csv
import gc
import io
import os
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols
from sympy.physics.mechanics.models import n_link_pendulum_on_cart
from threadpoolctl import threadpool_limits

from ..abi import Output
from ..derivation import Method
from ..fileio import write_atomic
from ..pipeline import run
from ..scenes.n_link_cart import build_model
from ..symbolic.graph import count_ops_dag, count_ops_tree
from ..viz.plots import figure, save_png

#: Shortest loop (seconds) of RHS calls that counts as one timing.
MIN_LOOP_S = 0.05



@dataclass(frozen=True)
class ScalingRow:
    """Timings and operation counts of one ``n``; the ratios are sympy / mbgen.

    Attributes
    ----------
    n : int
        Number of links.
    derive_s, cse_s, render_s, compile_s : float
        mbgen's stages, seconds (each measured once).
    rhs_s : float
        One call of the compiled RHS, seconds (median).
    ops_before, ops_after : int
        mbgen's operation counts before and after CSE (``Kernel.ops_before/after``).
    sympy_derive_s, sympy_cse_s, sympy_rhs_s : float or None
        The sympy baseline, same meaning; None when sympy was skipped for this ``n``.
    sympy_ops_before, sympy_ops_after : int or None
        Operations of ``M_full`` and ``F_full`` before and after ``sympy.cse``.
    rhs_max_abs_diff : float or None
        Largest difference between the two RHS results at the timed point.
    """

    n: int
    derive_s: float
    cse_s: float
    render_s: float
    compile_s: float
    rhs_s: float
    ops_before: int
    ops_after: int
    sympy_derive_s: float | None = None
    sympy_cse_s: float | None = None
    sympy_rhs_s: float | None = None
    sympy_ops_before: int | None = None
    sympy_ops_after: int | None = None
    rhs_max_abs_diff: float | None = None

    @staticmethod
    def _ratio(theirs: float | None, ours: float) -> float | None:
        return None if theirs is None else theirs / ours

    @property
    def derive_ratio(self) -> float | None:
        """sympy / mbgen derive time."""
        return self._ratio(self.sympy_derive_s, self.derive_s)

    @property
    def cse_ratio(self) -> float | None:
        """sympy / mbgen CSE time."""
        return self._ratio(self.sympy_cse_s, self.cse_s)

    @property
    def total_ratio(self) -> float | None:
        """sympy / mbgen time of derive + CSE."""
        theirs = None if self.sympy_derive_s is None else self.sympy_derive_s + self.sympy_cse_s
        return self._ratio(theirs, self.derive_s + self.cse_s)

    @property
    def rhs_ratio(self) -> float | None:
        """sympy lambdify / mbgen C time of one RHS call."""
        return self._ratio(self.sympy_rhs_s, self.rhs_s)


@contextmanager
def _fresh_cache():
    """Point ``MBGEN_CACHE_DIR`` at an empty temporary folder, restore it afterwards."""
    old = os.environ.get("MBGEN_CACHE_DIR")
    with tempfile.TemporaryDirectory(prefix="mbgen-bench-", ignore_cleanup_errors=True) as tmp:
        os.environ["MBGEN_CACHE_DIR"] = tmp
        try:
            yield
        finally:
            if old is None:
                del os.environ["MBGEN_CACHE_DIR"]
            else:
                os.environ["MBGEN_CACHE_DIR"] = old


def _timed(fn, *args, **kwargs):
    """``(fn(*args, **kwargs), seconds)``."""
    t0 = time.perf_counter()
    value = fn(*args, **kwargs)
    return value, time.perf_counter() - t0


def _per_call(fn: Callable[[], object], repeats: int) -> float:
    """Median seconds of one ``fn()`` call over ``repeats`` loops (see module docstring)."""

    def loop(number: int) -> float:
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        return time.perf_counter() - t0

    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        number = 1
        while loop(number) < MIN_LOOP_S:
            number *= 2
        return statistics.median(loop(number) / number for _ in range(repeats))
    finally:
        if gc_was_enabled:
            gc.enable()


def _ops_after(reps, reduced) -> int:
    """Operations of a CSE result, counted like :attr:`mbgen.codegen.optimize.Kernel.ops_after`."""
    return count_ops_dag([e for _, e in reps]) + sum(count_ops_dag([e]) for e in reduced)


def _point(layout) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """State, parameters and input at which both RHS are timed (by layout name)."""
    x = np.concatenate([0.1 * np.arange(layout.n_q), 0.05 * np.arange(1, layout.n_u + 1)])
    p = np.array([9.81 if name == "g" else 1.0 for name in layout.parameter_names])
    r = np.full(layout.n_r, 0.5)
    return x, p, r


#: How the progress lines name the pipeline's stages (the others by their own names).
_SAID = {"cse": "CSE"}


def _mbgen_side(n: int, repeats: int, say: Callable[[str], None]):
    """Run and time mbgen's stages; returns ``(fields, layout, (x, p, r), dxdt)``."""
    sm.core.cache.clear_cache()
    model, build_s = _timed(build_model, n)
    result = run(model, (Output.RHS,), method=Method.KANE,
                 stage=lambda name: say(f"n={n}: mbgen {_SAID.get(name, name)}"))
    seconds, kernel, layout = result.timings, result.kernel, result.equations.layout
    compiled = result.compiled
    x, p, r = _point(layout)
    say(f"n={n}: mbgen RHS")
    rhs_s = _per_call(lambda: compiled.rhs(0.0, x, p, r), repeats)
    fields = dict(n=n, derive_s=build_s + seconds["derive"], cse_s=seconds["cse"],
                  render_s=seconds["render"], compile_s=seconds["compile"], rhs_s=rhs_s,
                  ops_before=kernel.ops_before, ops_after=kernel.ops_after)
    return fields, layout, (x, p, r), compiled.rhs(0.0, x, p, r)


def _sympy_side(n: int, repeats: int, layout, point, say: Callable[[str], None]):
    """Run and time the sympy baseline; returns ``(fields, dxdt)``."""
    def derive_sympy():
        kane = n_link_pendulum_on_cart(n, cart_force=True)
        return kane, kane.mass_matrix_full, kane.forcing_full

    say(f"n={n}: sympy derive")
    sm.core.cache.clear_cache()
    (kane, M, F), derive_s = _timed(derive_sympy)
    exprs = list(M) + list(F)
    say(f"n={n}: sympy CSE")
    (reps, reduced), cse_s = _timed(sm.cse, exprs)

    states = list(kane.q) + list(kane.u)
    if [str(s.func) for s in states] != list(layout.state_names):
        raise RuntimeError(f"state order differs: sympy {states}, mbgen {layout.state_names}")
    args = (states, [sm.Symbol(name) for name in layout.parameter_names],
            [dynamicsymbols(name) for name in layout.input_names])
    M_fn = sm.lambdify(args, M, modules="numpy", cse=True)
    F_fn = sm.lambdify(args, F, modules="numpy", cse=True)

    def rhs(t, x, p, r):
        return np.linalg.solve(M_fn(x, p, r), F_fn(x, p, r)).ravel()

    x, p, r = point
    say(f"n={n}: sympy RHS")
    rhs_s = _per_call(lambda: rhs(0.0, x, p, r), repeats)
    fields = dict(sympy_derive_s=derive_s, sympy_cse_s=cse_s, sympy_rhs_s=rhs_s,
                  sympy_ops_before=count_ops_tree(exprs), sympy_ops_after=_ops_after(reps, reduced))
    return fields, rhs(0.0, x, p, r)


def scaling(ns: Sequence[int] = (2, 4, 8, 16, 32), *, sympy_max_n: int = 32, repeats: int = 5,
            progress: Callable[[str], None] | None = None) -> list[ScalingRow]:
    """Time mbgen and sympy on the n-link pendulum on a cart for every ``n``.

    Parameters
    ----------
    ns : sequence of int
        Numbers of links.
    sympy_max_n : int
        Largest ``n`` for which the sympy baseline runs; above it the
        ``sympy_*`` fields are None.
    repeats : int
        Loops of RHS calls whose median is reported.
    progress : callable, optional
        Called with a short message (``"n=8: sympy CSE"``) before each stage.

    Returns
    -------
    list of ScalingRow
        One row per ``n``, in the order of ``ns``.

    Notes
    -----
    Each ``n`` compiles into its own empty temporary cache (``MBGEN_CACHE_DIR``
    is set for the duration of mbgen's stages and restored afterwards).  See
    the module docstring for the method.
    """
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats}")
    with threadpool_limits(limits=1):
        return _scaling(ns, sympy_max_n, repeats, progress or (lambda message: None))


def _scaling(ns, sympy_max_n, repeats, say) -> list[ScalingRow]:
    say("warm-up (n=1, not reported)")
    with _fresh_cache():
        _, layout, point, _ = _mbgen_side(1, 1, lambda message: None)
    if any(n <= sympy_max_n for n in ns):
        _sympy_side(1, 1, layout, point, lambda message: None)
    rows = []
    for n in ns:
        with _fresh_cache():
            fields, layout, point, ours = _mbgen_side(n, repeats, say)
        if n <= sympy_max_n:
            theirs_fields, theirs = _sympy_side(n, repeats, layout, point, say)
            fields.update(theirs_fields, rhs_max_abs_diff=float(np.max(np.abs(ours - theirs))))
        rows.append(ScalingRow(**fields))
    return rows


_COLUMNS = (  # (header, width, text of a row's value)
    ("n", 3, lambda r: f"{r.n}"),
    ("derive mb", 9, lambda r: f"{r.derive_s:.3f}"),
    ("derive sp", 9, lambda r: _opt(r.sympy_derive_s, ".3f")),
    ("x", 5, lambda r: _opt(r.derive_ratio, ".1f")),
    ("CSE mb", 6, lambda r: f"{r.cse_s:.3f}"),
    ("CSE sp", 6, lambda r: _opt(r.sympy_cse_s, ".3f")),
    ("x", 5, lambda r: _opt(r.cse_ratio, ".1f")),
    ("total x", 7, lambda r: _opt(r.total_ratio, ".1f")),
    ("ops mb before/after", 19, lambda r: f"{r.ops_before}/{r.ops_after}"),
    ("ops sp after", 12, lambda r: _opt(r.sympy_ops_after, "d")),
    ("render", 6, lambda r: f"{r.render_s:.3f}"),
    ("compile", 7, lambda r: f"{r.compile_s:.2f}"),
    ("RHS mb µs", 9, lambda r: f"{r.rhs_s * 1e6:.2f}"),
    ("RHS sp µs", 9, lambda r: _opt(None if r.sympy_rhs_s is None else r.sympy_rhs_s * 1e6,
                                    ".1f")),
    ("x", 5, lambda r: _opt(r.rhs_ratio, ".0f")),
)

LEGEND = """\
mb = mbgen (RHS: compiled C); sp = sympy (RHS: lambdify + numpy.linalg.solve).
x = sp / mb of the two columns before it; total x = sp / mb of derive + CSE.
Times in s, RHS in µs per call (median); '-' = sympy side skipped."""


def _opt(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def format_scaling(rows: Sequence[ScalingRow]) -> str:
    """Plain-text table of :func:`scaling` rows, fixed-width columns.

    Below the table: :data:`LEGEND` and the BLAS thread pinning.
    """
    def line(cells) -> str:
        return "  ".join(f"{c:>{w}}" for c, (_, w, _) in zip(cells, _COLUMNS)).rstrip()

    header = line(h for h, _, _ in _COLUMNS)
    body = [line(fmt(r) for _, _, fmt in _COLUMNS) for r in rows]
    return "\n".join([header, "-" * len(header), *body, "", LEGEND,
                      "BLAS threads pinned to 1 (threadpoolctl)."])


#: Columns of :func:`write_scaling_csv`, the fields of :class:`ScalingRow`.
CSV_FIELDS = ("n", "derive_s", "cse_s", "render_s", "compile_s", "rhs_s", "ops_before",
              "ops_after", "sympy_derive_s", "sympy_cse_s", "sympy_rhs_s", "sympy_ops_before",
              "sympy_ops_after", "rhs_max_abs_diff")


def write_scaling_csv(rows: Sequence[ScalingRow], path):
    """Write the rows as CSV (one line per ``n``, :data:`CSV_FIELDS`; empty: sympy skipped)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_FIELDS)
    for r in rows:
        w.writerow(["" if getattr(r, f) is None else repr(getattr(r, f)) for f in CSV_FIELDS])
    path = Path(path)
    write_atomic(path, buf.getvalue())
    return path


def plot_scaling(rows: Sequence[ScalingRow], path):
    """Log-log PNG against ``n``: symbolic stages (s), one RHS call (µs), operations after CSE.

    mbgen solid, sympy dashed; every point is a measured row (sympy's only
    where it ran).
    """
    ns = [r.n for r in rows]
    fig = figure(13.0, 4.4)
    ax_time, ax_rhs, ax_ops = fig.subplots(1, 3)

    def series(ax, values, **style):
        pts = [(n, v) for n, v in zip(ns, values) if v is not None and v > 0]
        if pts:
            ax.plot(*zip(*pts), marker="o", markersize=4, **style)

    for label, ours, theirs, colour in (
            ("derive", [r.derive_s for r in rows], [r.sympy_derive_s for r in rows], "C0"),
            ("CSE", [r.cse_s for r in rows], [r.sympy_cse_s for r in rows], "C1")):
        series(ax_time, ours, color=colour, label=f"mbgen {label}")
        series(ax_time, theirs, color=colour, linestyle="--", label=f"sympy {label}")
    series(ax_time, [r.render_s for r in rows], color="C2", label="mbgen render")
    series(ax_time, [r.compile_s for r in rows], color="C3", label="mbgen compile (C)")
    series(ax_rhs, [r.rhs_s * 1e6 for r in rows], color="C0", label="mbgen (compiled C)")
    series(ax_rhs, [None if r.sympy_rhs_s is None else r.sympy_rhs_s * 1e6 for r in rows],
           color="C0", linestyle="--", label="sympy (lambdify + solve)")
    series(ax_ops, [r.ops_after for r in rows], color="C0", label="mbgen after CSE")
    series(ax_ops, [r.ops_before for r in rows], color="C0", linestyle=":",
           label="mbgen before CSE")
    series(ax_ops, [r.sympy_ops_after for r in rows], color="C1", linestyle="--",
           label="sympy after cse")
    for ax, title, unit in ((ax_time, "symbolic stages", "seconds (one run each)"),
                            (ax_rhs, "one RHS call", "µs per call (median)"),
                            (ax_ops, "operations", "arithmetic operations")):
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xlabel("n (links of the pendulum on a cart)")
        ax.set_ylabel(unit)
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="major", alpha=0.4)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, frameon=False)
    fig.suptitle("mbgen vs sympy KanesMethod + cse on the n-link pendulum on a cart "
                 "(solid: mbgen, dashed: sympy)", fontsize=10)
    return save_png(fig, path, dpi=110)
