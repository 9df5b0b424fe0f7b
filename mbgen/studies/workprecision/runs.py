"""Measuring the points: each point runs once instrumented (the *probe*), then in timed
plain runs (:func:`_measure`); :func:`run_tasks` measures every point of the plan in
order.

Errors
    On a fixed output grid ``t_eval`` (``t_eval_points`` equally spaced times
    over the scene's ``t_span``; every solver evaluates there, solve_ivp and
    the C integrators by their dense output): ``err_final`` = max abs error
    over the states at the final time, ``err_final_rel`` = that divided by the
    largest reference state at the final time, ``err_max`` = max abs error
    over states and output times.  Tables, plot and summary use ``err_max``.
    For a model with configuration constraints, ``err_residual`` = max
    ``|f_h(q, t)|`` over the output times, and ``err_max`` is the larger of the
    state error and the residual: a solution off the constraint manifold is
    wrong by that much whatever the reference says.
Timing
    Each point runs once instrumented (the *probe*, which also warms up),
    then ``repeats`` timed loops of plain runs; ``time_s`` is the median over
    the loops of the mean time of one run (``time.perf_counter`` around the
    whole ``solve_ivp`` or ``integrate`` call).  A loop holds as many runs as
    make it last :data:`MIN_LOOP_S` by the probe's time: one run for all but
    the fast points (the C integrators take well under a millisecond on small
    models, and single runs that short are all noise).  The garbage
    collector runs before each loop.  The right-hand sides and Jacobians of
    every back end are called once before anything is timed (the lambdified
    ones are built on first use).  BLAS threads are pinned to one for the
    whole run (``threadpoolctl``).
Counts and overhead
    The probe wraps the RHS and Jacobian callables given to solve_ivp: it
    counts the calls (``nfev`` and ``njev`` are the *actual* calls --
    solve_ivp's own ``nfev`` leaves out the finite-difference Jacobian
    columns), sums the seconds spent inside them, and stops the solve once it
    runs past ``time_budget``.  ``overhead`` = 1 - (seconds inside the
    callables) / (probe wall time): the share of the run that is solve_ivp's
    own Python (the wrapper's two clock reads per call count as overhead
    too).  ``nlu`` is solve_ivp's count of LU decompositions.  The C
    integrators report their own counts; their probe is checked against the
    budget after the fact.  Once a point is over budget the tighter
    tolerances of the same configuration are skipped.
"""

from __future__ import annotations

import gc
import math
import statistics
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
from tqdm import tqdm

from ...errors import MbgenError
from .points import FAILED, OK, OVER_BUDGET, SKIPPED, Point, Task
from .reference import TrueSolution
from .solve import Backends, Failed, solve

#: Shortest loop (seconds) of runs that counts as one timing of a fast point.
MIN_LOOP_S = 0.05


@dataclass(frozen=True)
class _Run:
    """What one solve returned: states on the grid, counts, and times."""

    x: np.ndarray
    nfev: int
    njev: int
    nlu: int
    wall_s: float
    callback_s: float | None = None


def _probe_solve_ivp(fun, jac, method, t_eval, x0, rtol, atol, deadline) -> _Run:
    """The instrumented run of a solve_ivp point."""
    start = time.perf_counter()
    sol, meter = solve(fun, jac, method, t_eval, x0, rtol, atol, deadline=deadline)
    wall = time.perf_counter() - start
    return _Run(sol.y.T, meter.calls["fun"], meter.calls["jac"], int(sol.nlu), wall,
                meter.seconds)


def _timed_solve_ivp(fun, jac, method, t_eval, x0, rtol, atol) -> float:
    """Seconds of one plain (uninstrumented) solve_ivp run."""
    start = time.perf_counter()
    solve(fun, jac, method, t_eval, x0, rtol, atol)
    return time.perf_counter() - start


def _run_c(model, task: Task, t_eval, x0, p) -> _Run:
    """One run of a generated C integrator."""
    kw = {"h": task.h} if task.h is not None else {"rtol": task.rtol, "atol": task.atol}
    start = time.perf_counter()
    try:
        out = model.integrate(task.config.method, t_eval, x0, p, **kw)
    except MbgenError as exc:  # IntegrationError and friends: recorded (a bug propagates)
        raise Failed(FAILED, f"{type(exc).__name__}: {exc}") from None
    wall = time.perf_counter() - start
    return _Run(out.x, out.n_rhs, out.n_jac, out.n_lu, wall)


def _median_time(timed: Callable[[], float], repeats: int, number: int) -> float:
    """Median over ``repeats`` loops of the mean of ``number`` calls of ``timed`` (seconds each)."""
    times = []
    for _ in range(repeats):
        gc.collect()
        times.append(sum(timed() for _ in range(number)) / number)
    return statistics.median(times)


def _errors(x: np.ndarray, ref: np.ndarray, residual=None) -> dict[str, float]:
    """``err_final``, ``err_final_rel`` and ``err_max`` of ``x`` against ``ref`` (both (k, n_x));
    with ``residual`` (rows of x -> max |f_h|) also ``err_residual``, folded into ``err_max``."""
    diff = np.abs(np.asarray(x) - ref)
    final = float(diff[-1].max())
    scale = float(np.abs(ref[-1]).max()) or 1.0
    out = dict(err_final=final, err_final_rel=final / scale, err_max=float(diff.max()))
    if residual is not None:
        out["err_residual"] = residual(x)
        out["err_max"] = max(out["err_max"], out["err_residual"])
    return out


def constraint_residual(model, t_eval, p):
    """``x -> max |f_h(q, t)|`` over the rows of ``x`` (None without configuration constraints)."""
    if not getattr(model, "dependent_coordinates", ()):
        return None

    def residual(x) -> float:
        return max(float(np.max(np.abs(model.holonomic(t, xi, p)))) for t, xi in zip(t_eval, x))
    return residual


def _measure(task: Task, probe: Callable[[float], _Run], timed: Callable[[], float],
             reference: TrueSolution, repeats: int, budget: float, residual=None) -> Point:
    """Probe once (counts, errors, budget), then time ``repeats`` plain runs."""
    try:
        run_ = probe(time.perf_counter() + budget)
        if run_.wall_s > budget:
            raise Failed(OVER_BUDGET, f"took {run_.wall_s:.3g} s")
    except Failed as failure:
        message = failure.message
        if failure.status == OVER_BUDGET:
            message = f"over the {budget:g} s budget: {message}"
        return task.point(failure.status, message)
    number = max(1, math.ceil(MIN_LOOP_S / run_.wall_s))
    return task.point(OK, time_s=_median_time(timed, repeats, number), nfev=run_.nfev,
                      njev=run_.njev, nlu=run_.nlu, callback_s=run_.callback_s,
                      probe_s=run_.wall_s,
                      **_errors(run_.x, reference.x, residual))


def run_tasks(tasks, b: Backends, t_eval, x0, reference, repeats, budget,
              progress) -> list[Point]:
    """Every point in order; a configuration over budget skips its tighter tolerances."""
    points, over = [], {}
    residual = constraint_residual(b.compiled, t_eval, b.p)
    for task in _iterate(tasks, progress):
        c = task.config
        if c in over:
            points.append(task.point(SKIPPED, f"{over[c]} went over the {budget:g} s budget"))
            continue
        if c.is_c_integrator:
            def probe(deadline, task=task):
                return _run_c(b.compiled, task, t_eval, x0, b.p)

            def timed(task=task):
                return _run_c(b.compiled, task, t_eval, x0, b.p).wall_s
        else:
            args = (b.fun(c.backend), b.jac(c.backend) if c.jac else None, c.method, t_eval,
                    x0, task.rtol, task.atol)
            probe, timed = partial(_probe_solve_ivp, *args), partial(_timed_solve_ivp, *args)
        point = _measure(task, probe, timed, reference, repeats, budget, residual)
        if point.status == OVER_BUDGET:
            over[c] = point.setting
        points.append(point)
    return points


def _iterate(tasks: Sequence[Task], progress) -> Iterator[Task]:
    """Yield the tasks, showing a tqdm bar (``progress=True``) or calling ``progress(text)``."""
    if progress is True:
        with tqdm(tasks, file=sys.stderr, unit="point", desc="work-precision") as bar:
            for task in bar:
                bar.set_postfix_str(task.describe())
                yield task
        return
    for task in tasks:
        if callable(progress):
            progress(task.describe())
        yield task
