"""Work-precision benchmark: error against run time for every integrator and back end.

:func:`work_precision` solves one scene at a sweep of tolerances with

* ``scipy.integrate.solve_ivp`` -- ``RK45``, ``DOP853``, ``Radau``, ``BDF``,
  ``LSODA``; the implicit three (``Radau``, ``BDF``, ``LSODA``) both without a
  Jacobian (solve_ivp's finite differences) and with ``jac=`` the Jacobian of
  the *same* back end -- over three right-hand-side back ends: ``lambdify``
  (:class:`~mbgen.reference.LambdifiedModel` of the scene's baked equations),
  ``python`` (the generated Python, :func:`mbgen.python_model`) and ``c`` (the
  compiled C), all called with the compiled model's arrays;
* the generated C integrators (:meth:`mbgen.runtime.CompiledModel.integrate`):
  ``dopri5`` and ``rosenbrock`` at the same tolerances, and ``rk4`` at a sweep
  of fixed steps laid onto the same tolerance rows (see :func:`rk4_steps`).

Method
------
Tolerances
    ``atol = rtol * atol_scale`` for every state.  By default
    ``atol_scale = ATOL_RATIO * m`` with ``m`` the *typical state magnitude*:
    the median over the states of ``max_t |x_i(t)|`` along a pilot solve
    (:data:`PILOT_METHODS` at the loosest ``rtol``).  So the relative
    tolerance governs states of typical size and the absolute one only takes
    over two decades below it (a state passing through zero).
Reference
    The scene's closed form when it has one (``Scene.closed_form``).
    Otherwise the first two of :data:`REFERENCE_SOLVES` that succeed (DOP853
    at rtol 1e-13; Radau at rtol 1e-12 with the compiled Jacobian; LSODA as a
    fallback for stiff scenes), all on the C back end with ``atol = rtol *
    atol_scale``.  The first is the reference; the largest difference between
    the two over the output grid is reported and is the *floor* below which
    an error is not meaningful.
Errors
    On a fixed output grid ``t_eval`` (``t_eval_points`` equally spaced times
    over the scene's ``t_span``; every solver evaluates there, solve_ivp and
    the C integrators by their dense output): ``err_final`` = max abs error
    over the states at the final time, ``err_final_rel`` = that divided by the
    largest reference state at the final time, ``err_max`` = max abs error
    over states and output times.  Tables, plot and summary use ``err_max``.
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

Timings on a shared or small machine are noisy: compare within one run.
"""

from __future__ import annotations

import csv
import gc
import io
import math
import statistics
import sys
import time
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Callable, Iterable, Iterator, Sequence

import numpy as np
from scipy.integrate import solve_ivp
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from .errors import IntegrationError
from .fileio import atomic_path, write_atomic
from .optimize import Output
from .pipeline import python_model, run
from .reference import LambdifiedModel
from .runtime import CompiledModel
from .scene import Scene, load_scene

#: Relative tolerances swept by default, loosest first.
DEFAULT_RTOLS = tuple(10.0 ** -k for k in range(3, 11))
SOLVE_IVP_METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
#: solve_ivp methods that use a Jacobian (each runs with and without ``jac=``).
IMPLICIT_METHODS = ("Radau", "BDF", "LSODA")
C_METHODS = ("dopri5", "rosenbrock", "rk4")
BACKENDS = ("lambdify", "python", "c")
#: ``atol_scale = ATOL_RATIO * typical state magnitude`` unless given.
ATOL_RATIO = 1e-2
#: Error levels of the summary (max abs error over the output grid).
ERROR_LEVELS = (1e-2, 1e-4, 1e-6, 1e-8, 1e-10)
#: Candidates for the numerical reference ``(method, rtol, jac)``; the first two that succeed.
REFERENCE_SOLVES = (("DOP853", 1e-13, False), ("Radau", 1e-12, True), ("LSODA", 1e-12, True))
#: Pilot solves (typical magnitude, rk4 step count): the first that succeeds.
PILOT_METHODS = ("RK45", "LSODA")
#: Seconds a pilot or reference solve may take before the next candidate is tried.
REFERENCE_BUDGET_S = 300.0
DEFAULT_TIME_BUDGET_S = 10.0
#: Shortest loop (seconds) of runs that counts as one timing of a fast point.
MIN_LOOP_S = 0.05
DEFAULT_T_EVAL_POINTS = 101

OK, FAILED, OVER_BUDGET, SKIPPED = "ok", "failed", "over budget", "skipped"
#: Columns of :meth:`WorkPrecisionReport.to_csv`, one row per point.
CSV_COLUMNS = ("method", "backend", "jac", "rtol", "atol", "h", "err_final", "err_max", "time_s",
               "nfev", "njev", "nlu", "status", "message", "err_final_rel", "overhead")


# ----------------------------------------------------------------- values
@dataclass(frozen=True)
class Config:
    """One curve of the diagram: an integrator on a back end, with or without a Jacobian."""

    method: str
    backend: str
    jac: bool = False

    @property
    def is_c_integrator(self) -> bool:
        return self.method in C_METHODS

    @property
    def label(self) -> str:
        """``"Radau [c, jac]"``, ``"RK45 [lambdify]"``."""
        return f"{self.method} [{self.backend}{', jac' if self.jac else ''}]"


@dataclass(frozen=True)
class Point:
    """One run of one configuration at one tolerance (or one fixed step for ``rk4``).

    Attributes
    ----------
    method, backend, jac :
        The configuration (:class:`Config`).
    rtol : float
        Relative tolerance; for ``rk4`` the tolerance row its step ``h`` is laid on.
    atol : float or None
        Absolute tolerance (None for ``rk4``).
    h : float or None
        Fixed step of ``rk4`` (None for the adaptive methods).
    status : str
        ``"ok"``, ``"failed"`` (integrator or model error), ``"over budget"``
        (stopped after ``time_budget`` s) or ``"skipped"`` (a looser tolerance
        of the same configuration went over budget).
    message : str
        Why the point is not ok (empty when it is).
    err_final, err_final_rel, err_max : float
        Errors against the reference (module docstring); NaN unless ok.
    time_s : float
        Median wall time of the timed runs, seconds; NaN unless ok.
    nfev, njev, nlu : int or None
        RHS calls, Jacobian calls, LU decompositions (probe run).
    callback_s : float or None
        Seconds inside the RHS/Jacobian callables in the probe run (solve_ivp only).
    probe_s : float or None
        Wall time of the probe run.
    """

    method: str
    backend: str
    jac: bool
    rtol: float
    atol: float | None
    h: float | None
    status: str
    message: str = ""
    err_final: float = math.nan
    err_final_rel: float = math.nan
    err_max: float = math.nan
    time_s: float = math.nan
    nfev: int | None = None
    njev: int | None = None
    nlu: int | None = None
    callback_s: float | None = None
    probe_s: float | None = None

    @property
    def config(self) -> Config:
        return Config(self.method, self.backend, self.jac)

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def overhead(self) -> float | None:
        """Share of the probe's wall time spent outside the RHS/Jacobian (solve_ivp only)."""
        if self.callback_s is None or not self.probe_s:
            return None
        return 1.0 - self.callback_s / self.probe_s

    @property
    def setting(self) -> str:
        """``"rtol=1e-06"`` or, for ``rk4``, ``"h=0.0123"``."""
        return _setting(self.rtol, self.h)


@dataclass(frozen=True)
class Reference:
    """The solution errors are measured against, on the output grid.

    Attributes
    ----------
    t : ndarray, shape (k,)
    x : ndarray, shape (k, n_x)
    source : str
        ``"closed form"`` or the solve that produced ``x``.
    check : str
        The second solve it was compared with (empty for a closed form).
    disagreement : float
        Max abs difference between the two solves: the floor of meaningful
        error (0 for a closed form).
    notes : tuple of str
        Candidates that failed on the way.
    """

    t: np.ndarray
    x: np.ndarray
    source: str
    check: str = ""
    disagreement: float = 0.0
    notes: tuple[str, ...] = ()

    def describe(self) -> str:
        if not self.check:
            return f"reference: {self.source}"
        return (f"reference: {self.source}, checked against {self.check}: "
                f"disagreement {self.disagreement:.1e} (floor of meaningful error)")


@dataclass(frozen=True)
class _Task:
    """A point to run."""

    config: Config
    rtol: float
    atol: float | None
    h: float | None

    def describe(self) -> str:
        return f"{self.config.label} {_setting(self.rtol, self.h)}"

    def point(self, status: str, message: str = "", **measured) -> Point:
        c = self.config
        return Point(c.method, c.backend, c.jac, self.rtol, self.atol, self.h, status, message,
                     **measured)


@dataclass(frozen=True)
class _Run:
    """What one solve returned: states on the grid, counts, and times."""

    x: np.ndarray
    nfev: int
    njev: int
    nlu: int
    wall_s: float
    callback_s: float | None = None


class _Failed(Exception):
    """A point did not produce a solution; ``status`` and ``message`` say why."""

    def __init__(self, status: str, message: str):
        super().__init__(message)
        self.status, self.message = status, message


class _OverBudget(Exception):
    """Raised from inside a callable once the probe's deadline has passed."""


# ------------------------------------------------------------------ solving
class _Meter:
    """Wraps callables: counts calls, sums the seconds inside them, enforces a deadline."""

    def __init__(self, deadline: float):
        self.deadline = deadline
        self.seconds = 0.0
        self.calls = {"fun": 0, "jac": 0}

    def wrap(self, fn: Callable, kind: str) -> Callable:
        clock, calls = time.perf_counter, self.calls

        def wrapped(t, x):
            start = clock()
            if start > self.deadline:
                raise _OverBudget
            out = fn(t, x)
            self.seconds += clock() - start
            calls[kind] += 1
            return out

        return wrapped


def _solve(fun, jac, method: str, t_eval, x0, rtol: float, atol: float, *,
           deadline: float | None = None, grid: bool = True):
    """``(solution, meter)`` of one ``solve_ivp`` call; instrumented when ``deadline`` is set.

    ``grid=False`` keeps every step in ``solution.t`` instead of evaluating at
    ``t_eval``.  Raises :class:`_Failed` on any failure.
    """
    meter = None if deadline is None else _Meter(deadline)
    f = fun if meter is None else meter.wrap(fun, "fun")
    extra = {}
    if jac is not None:
        extra["jac"] = jac if meter is None else meter.wrap(jac, "jac")
    try:
        sol = solve_ivp(f, (t_eval[0], t_eval[-1]), x0, method=method, rtol=rtol, atol=atol,
                        t_eval=t_eval if grid else None, **extra)
    except _OverBudget:
        raise _Failed(OVER_BUDGET, "stopped at the time budget") from None
    except Exception as exc:  # a failed point is recorded, whatever went wrong
        raise _Failed(FAILED, f"{type(exc).__name__}: {exc}") from None
    if not sol.success:
        raise _Failed(FAILED, f"solve_ivp: {sol.message}")
    return sol, meter


def _probe_solve_ivp(fun, jac, method, t_eval, x0, rtol, atol, deadline) -> _Run:
    """The instrumented run of a solve_ivp point."""
    start = time.perf_counter()
    sol, meter = _solve(fun, jac, method, t_eval, x0, rtol, atol, deadline=deadline)
    wall = time.perf_counter() - start
    return _Run(sol.y.T, meter.calls["fun"], meter.calls["jac"], int(sol.nlu), wall,
                meter.seconds)


def _timed_solve_ivp(fun, jac, method, t_eval, x0, rtol, atol) -> float:
    """Seconds of one plain (uninstrumented) solve_ivp run."""
    start = time.perf_counter()
    _solve(fun, jac, method, t_eval, x0, rtol, atol)
    return time.perf_counter() - start


def _run_c(model, task: _Task, t_eval, x0, p) -> _Run:
    """One run of a generated C integrator."""
    kw = {"h": task.h} if task.h is not None else {"rtol": task.rtol, "atol": task.atol}
    start = time.perf_counter()
    try:
        out = model.integrate(task.config.method, t_eval, x0, p, **kw)
    except Exception as exc:  # IntegrationError and friends: recorded, not raised
        raise _Failed(FAILED, f"{type(exc).__name__}: {exc}") from None
    wall = time.perf_counter() - start
    return _Run(out.x, out.n_rhs, out.n_jac, out.n_lu, wall)


def _median_time(timed: Callable[[], float], repeats: int, number: int) -> float:
    """Median over ``repeats`` loops of the mean of ``number`` calls of ``timed`` (seconds each)."""
    times = []
    for _ in range(repeats):
        gc.collect()
        times.append(sum(timed() for _ in range(number)) / number)
    return statistics.median(times)


def _errors(x: np.ndarray, ref: np.ndarray) -> dict[str, float]:
    """``err_final``, ``err_final_rel`` and ``err_max`` of ``x`` against ``ref`` (both (k, n_x))."""
    diff = np.abs(np.asarray(x) - ref)
    final = float(diff[-1].max())
    scale = float(np.abs(ref[-1]).max()) or 1.0
    return dict(err_final=final, err_final_rel=final / scale, err_max=float(diff.max()))


def _measure(task: _Task, probe: Callable[[float], _Run], timed: Callable[[], float],
             reference: Reference, repeats: int, budget: float) -> Point:
    """Probe once (counts, errors, budget), then time ``repeats`` plain runs."""
    try:
        run_ = probe(time.perf_counter() + budget)
        if run_.wall_s > budget:
            raise _Failed(OVER_BUDGET, f"took {run_.wall_s:.3g} s")
    except _Failed as failure:
        message = failure.message
        if failure.status == OVER_BUDGET:
            message = f"over the {budget:g} s budget: {message}"
        return task.point(failure.status, message)
    number = max(1, math.ceil(MIN_LOOP_S / run_.wall_s))
    return task.point(OK, time_s=_median_time(timed, repeats, number), nfev=run_.nfev,
                      njev=run_.njev, nlu=run_.nlu, callback_s=run_.callback_s,
                      probe_s=run_.wall_s,
                      **_errors(run_.x, reference.x))


# --------------------------------------------------------- setup: the plan
def configurations(methods: Iterable[str], backends: Iterable[str]) -> list[Config]:
    """Every curve of the diagram, method by method.

    solve_ivp methods run on every back end, the implicit ones with and
    without the Jacobian; the C integrators only on ``"c"`` (``rosenbrock``
    always uses the compiled Jacobian) and only when ``"c"`` is a back end.
    """
    backends = tuple(backends)
    configs = []
    for method in methods:
        if method in C_METHODS:
            if "c" in backends:
                configs.append(Config(method, "c", method == "rosenbrock"))
            continue
        for backend in backends:
            configs.append(Config(method, backend))
            if method in IMPLICIT_METHODS:
                configs.append(Config(method, backend, True))
    return configs


def typical_magnitude(x: np.ndarray) -> float:
    """Median over the states of ``max_t |x_i(t)|`` (``x`` of shape (k, n_x)); 1 if that is 0."""
    value = float(np.median(np.abs(np.asarray(x)).max(axis=0)))
    return value if value > 0 and math.isfinite(value) else 1.0


def rk4_steps(rtols: Sequence[float], pilot_steps: int, t_eval: np.ndarray) -> tuple[float, ...]:
    """Fixed steps of ``rk4``, one per tolerance row.

    At the loosest ``rtol`` rk4 takes about as many steps as the pilot solve
    (an adaptive 5(4) method at that tolerance took ``pilot_steps``); every
    decade tighter multiplies the step count by ``10^(1/4)`` -- a tenth of
    the error of a 4th-order method -- so the rk4 curve spans the same error
    range as the adaptive ones.  The C integrator splits every output
    interval into equal steps, so each step is an output interval divided by
    a whole number: the step it really takes.
    """
    intervals = len(t_eval) - 1
    dt = (t_eval[-1] - t_eval[0]) / intervals
    loosest = max(rtols)
    return tuple(float(dt / math.ceil(pilot_steps * (loosest / r) ** 0.25 / intervals))
                 for r in rtols)


def _plan(configs: Sequence[Config], rtols: Sequence[float], atol_scale: float,
          hs: Sequence[float]) -> list[_Task]:
    return [_Task(c, r, None, h) if c.method == "rk4" else _Task(c, r, r * atol_scale, None)
            for c in configs for r, h in zip(rtols, hs)]


@dataclass
class _Backends:
    """The three models of one scene and the bound callables of each back end."""

    compiled: CompiledModel
    p: np.ndarray
    models: dict

    @classmethod
    def build(cls, scene: Scene, backends: Sequence[str], c_methods: Sequence[str]) -> "_Backends":
        """Generate and compile once; every back end takes the compiled model's arrays."""
        expression_outputs = (Output.RHS, Output.JACOBIAN)
        result = run(scene, (*expression_outputs, *c_methods))
        models = {"c": result.compiled}
        if "python" in backends:
            models["python"] = python_model(result.rendered)
        if "lambdify" in backends:
            models["lambdify"] = LambdifiedModel(result.baked, expression_outputs,
                                                 layout=result.layout)
        return cls(result.compiled, scene.p(result.layout), models)

    def fun(self, backend: str) -> Callable:
        return self.models[backend].bind(self.p)

    def jac(self, backend: str) -> Callable:
        return self.models[backend].bind(self.p, output=Output.JACOBIAN)

    def warm_up(self, x0: np.ndarray, t0: float) -> None:
        """Call every right-hand side and Jacobian once (lazy set-up is not timed)."""
        for backend in self.models:
            self.fun(backend)(t0, x0)
            self.jac(backend)(t0, x0)


def _pilot(b: _Backends, t_eval, x0, rtol: float, atol: float) -> tuple[int, np.ndarray, str]:
    """``(steps, states at the steps, method)``: the first of :data:`PILOT_METHODS` to succeed."""
    notes = []
    for method in PILOT_METHODS:
        jac = b.jac("c") if method in IMPLICIT_METHODS else None
        try:
            sol, _ = _solve(b.fun("c"), jac, method, t_eval, x0, rtol, atol, grid=False,
                            deadline=time.perf_counter() + REFERENCE_BUDGET_S)
        except _Failed as failure:
            notes.append(f"{method}: {failure.message}")
            continue
        return sol.t.size - 1, sol.y.T, method
    raise IntegrationError(f"no pilot solve succeeded: {'; '.join(notes)}")


def _numerical_reference(b: _Backends, t_eval, x0, atol_scale: float,
                         say: Callable[[str], None]) -> Reference:
    """The first two of :data:`REFERENCE_SOLVES` that succeed, compared."""
    solved, notes = [], []
    for method, rtol, use_jac in REFERENCE_SOLVES:
        name = f"{method} rtol={rtol:.0e} (C RHS{', C Jacobian' if use_jac else ''})"
        say(f"reference: {name}")
        try:
            sol, _ = _solve(b.fun("c"), b.jac("c") if use_jac else None, method, t_eval, x0,
                            rtol, rtol * atol_scale,
                            deadline=time.perf_counter() + REFERENCE_BUDGET_S)
        except _Failed as failure:
            notes.append(f"{name}: {failure.status}: {failure.message}")
            continue
        solved.append((name, sol.y.T))
        if len(solved) == 2:
            (source, x), (check, other) = solved
            return Reference(np.asarray(t_eval), x, source, check,
                             float(np.abs(x - other).max()), tuple(notes))
    raise IntegrationError(f"fewer than two reference solves succeeded: {'; '.join(notes)}")


def _reference(scene: Scene, b: _Backends, t_eval, x0, atol_scale, say) -> Reference:
    if scene.closed_form is not None:
        x = np.asarray(scene.closed_form(t_eval, x0, b.p), dtype=float)
        return Reference(np.asarray(t_eval), x, "closed form")
    return _numerical_reference(b, t_eval, x0, atol_scale, say)


def _reporter(progress) -> Callable[[str], None]:
    """Setup messages: to a callable ``progress``, through tqdm when True, else dropped."""
    if callable(progress):
        return progress
    if progress:
        return lambda message: tqdm.write(message, file=sys.stderr)
    return lambda message: None


def _iterate(tasks: Sequence[_Task], progress) -> Iterator[_Task]:
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


# ------------------------------------------------------------------ the run
def work_precision(scene: Scene | str, *, rtols: Sequence[float] = DEFAULT_RTOLS,
                   atol_scale: float | None = None, methods: Sequence[str] | None = None,
                   backends: Sequence[str] = BACKENDS, repeats: int = 3,
                   t_eval_points: int = DEFAULT_T_EVAL_POINTS,
                   time_budget: float = DEFAULT_TIME_BUDGET_S,
                   progress: bool | Callable[[str], None] | None = None
                   ) -> "WorkPrecisionReport":
    """Error against run time of every integrator and back end on one scene.

    Parameters
    ----------
    scene : Scene or str
        A scene, or the name or path :func:`mbgen.load_scene` takes.
    rtols : sequence of float
        Relative tolerances (the rows of the table).
    atol_scale : float, optional
        ``atol = rtol * atol_scale``; default ``ATOL_RATIO`` x the typical
        state magnitude (module docstring).
    methods : sequence of str, optional
        Any of :data:`SOLVE_IVP_METHODS` and :data:`C_METHODS`; default all.
    backends : sequence of str
        Any of :data:`BACKENDS` for solve_ivp (the C integrators need ``"c"``).
    repeats : int
        Timed runs per point; the median is reported.
    t_eval_points : int
        Equally spaced output times over the scene's ``t_span``.
    time_budget : float
        Seconds one solve may take; longer ones are stopped and recorded as
        ``"over budget"``, and the tighter tolerances of that configuration
        are skipped.
    progress : bool or callable, optional
        True: a tqdm bar on stderr; a callable gets one line of text per
        point (and per set-up stage).

    Returns
    -------
    WorkPrecisionReport
        Failed points are recorded in it, never raised.

    Raises
    ------
    ValueError
        Unknown method or back end, or bad numbers.
    IntegrationError
        The pilot or the numerical reference could not be computed.
    """
    methods = tuple(SOLVE_IVP_METHODS + C_METHODS if methods is None else methods)
    _validate(methods, backends, rtols, repeats, t_eval_points, time_budget, atol_scale)
    start = time.perf_counter()
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    say = _reporter(progress)
    with threadpool_limits(limits=1):
        say(f"{scene.name}: generate and compile")
        c_methods = [m for m in methods if m in C_METHODS] if "c" in backends else []
        b = _Backends.build(scene, backends, c_methods)
        x0 = scene.x0(b.compiled.layout)
        t_eval = np.linspace(*map(float, scene.t_span), t_eval_points)
        b.warm_up(x0, t_eval[0])
        say("pilot solve")
        loosest = max(rtols)
        pilot_scale = atol_scale or ATOL_RATIO * typical_magnitude(x0[None])
        steps, pilot_x, pilot_method = _pilot(b, t_eval, x0, loosest, loosest * pilot_scale)
        magnitude = typical_magnitude(pilot_x)
        atol_note = (f"atol = rtol x {atol_scale:g} (given)" if atol_scale else
                     f"atol = rtol x {ATOL_RATIO * magnitude:.3g} ({ATOL_RATIO:g} x typical "
                     f"state magnitude {magnitude:.3g}: median over states of max |x_i|, "
                     f"{pilot_method} pilot)")
        atol_scale = atol_scale or ATOL_RATIO * magnitude
        reference = _reference(scene, b, t_eval, x0, atol_scale, say)
        hs = rk4_steps(rtols, steps, t_eval)
        tasks = _plan(configurations(methods, backends), rtols, atol_scale, hs)
        points = _run_tasks(tasks, b, t_eval, x0, reference, repeats, time_budget, progress)
    return WorkPrecisionReport(scene.name, tuple(b.compiled.state_names), t_eval, tuple(rtols),
                               atol_scale, atol_note, reference, tuple(points), repeats,
                               time_budget, time.perf_counter() - start)


def _validate(methods, backends, rtols, repeats, t_eval_points, time_budget, atol_scale) -> None:
    unknown = set(methods) - set(SOLVE_IVP_METHODS + C_METHODS)
    if unknown:
        raise ValueError(f"unknown method(s) {sorted(unknown)}; choose from "
                         f"{', '.join(SOLVE_IVP_METHODS + C_METHODS)}")
    if set(backends) - set(BACKENDS) or not backends:
        raise ValueError(f"backends must be some of {', '.join(BACKENDS)}; got {list(backends)}")
    if not rtols or not all(0 < r < 1 for r in rtols):
        raise ValueError(f"rtols must be numbers in (0, 1); got {list(rtols)}")
    if repeats < 1 or t_eval_points < 2 or not time_budget > 0:
        raise ValueError("need repeats >= 1, t_eval_points >= 2 and time_budget > 0")
    if atol_scale is not None and not atol_scale > 0:
        raise ValueError(f"atol_scale must be positive; got {atol_scale!r}")


def _run_tasks(tasks, b: _Backends, t_eval, x0, reference, repeats, budget,
               progress) -> list[Point]:
    """Every point in order; a configuration over budget skips its tighter tolerances."""
    points, over = [], {}
    for task in _iterate(tasks, progress):
        c = task.config
        if c in over:
            points.append(task.point(SKIPPED, f"{over[c]} went over the {budget:g} s budget"))
            continue
        if c.is_c_integrator:
            probe = lambda deadline, task=task: _run_c(b.compiled, task, t_eval, x0, b.p)
            timed = lambda task=task: _run_c(b.compiled, task, t_eval, x0, b.p).wall_s
        else:
            args = (b.fun(c.backend), b.jac(c.backend) if c.jac else None, c.method, t_eval,
                    x0, task.rtol, task.atol)
            probe, timed = partial(_probe_solve_ivp, *args), partial(_timed_solve_ivp, *args)
        point = _measure(task, probe, timed, reference, repeats, budget)
        if point.status == OVER_BUDGET:
            over[c] = point.setting
        points.append(point)
    return points


# ------------------------------------------------------------------ report
@dataclass(frozen=True)
class WorkPrecisionReport:
    """The points of one work-precision run, and how to show them.

    Attributes
    ----------
    scene : str
    state_names : tuple of str
    t_eval : ndarray
        The output grid the errors are measured on.
    rtols : tuple of float
    atol_scale : float
        ``atol = rtol * atol_scale``.
    atol_note : str
        How ``atol_scale`` was chosen.
    reference : Reference
    points : tuple of Point
        Configuration by configuration, tolerance by tolerance.
    repeats : int
    time_budget : float
    wall_time : float
        Seconds the whole run took (compile, pilot and reference included).
    """

    scene: str
    state_names: tuple[str, ...]
    t_eval: np.ndarray
    rtols: tuple[float, ...]
    atol_scale: float
    atol_note: str
    reference: Reference
    points: tuple[Point, ...]
    repeats: int
    time_budget: float
    wall_time: float

    def configurations(self) -> list[Config]:
        """The curves, in the order they ran."""
        return list(dict.fromkeys(p.config for p in self.points))

    def curve(self, config: Config) -> list[Point]:
        return [p for p in self.points if p.config == config]

    # ------------------------------------------------------------ table
    def table(self) -> str:
        """Terminal table: error, time and RHS calls per configuration and tolerance."""
        t0, t1 = self.t_eval[0], self.t_eval[-1]
        head = (f"{self.scene}: n_x = {len(self.state_names)}, t in [{t0:g}, {t1:g}], "
                f"{self.t_eval.size} output times; {self.atol_note}\n{self.reference.describe()}")
        blocks = [
            ("max abs error over the output times", lambda p: f"{p.err_max:.1e}"),
            (f"run time, ms (median of {self.repeats})", lambda p: _ms(p.time_s)),
            ("RHS calls", lambda p: f"{p.nfev}"),
        ]
        body = [_matrix(title, self.configurations(), self.curve, self.rtols, cell)
                for title, cell in blocks]
        rk4 = [p for p in self.points if p.h is not None]
        foot = ["rk4: fixed step h per column: " + ", ".join(f"{p.h:.3g}" for p in rk4)] \
            if rk4 else []
        foot += [f"Cells: budget = stopped after {self.time_budget:g} s; skip = a looser "
                 f"tolerance went over budget; fail = integrator or model error (see the CSV).",
                 "BLAS threads pinned to 1 (threadpoolctl)."]
        return "\n\n".join([head, *body, "\n".join(foot)])

    # -------------------------------------------------------------- CSV
    def to_csv(self) -> str:
        """One row per point, columns :data:`CSV_COLUMNS`."""
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(CSV_COLUMNS)
        for p in self.points:
            writer.writerow([_csv_value(getattr(p, name)) for name in CSV_COLUMNS])
        return buf.getvalue()

    def write_csv(self, path) -> Path:
        """Write :meth:`to_csv` to ``path`` atomically."""
        path = Path(path)
        write_atomic(path, self.to_csv())
        return path

    # ------------------------------------------------------------- plot
    def plot(self, path) -> Path:
        """Log-log error (max over the output grid) against run time, one curve per configuration.

        Written as PNG, atomically (temporary file in the same folder, then
        ``os.replace``).  Colour: method; line style: back end; filled marker:
        with Jacobian.  The dotted horizontal line is the reference floor.
        """
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=(12, 7.5), layout="constrained")
        FigureCanvasAgg(fig)
        ax = fig.add_subplot()
        colours = {m: f"C{i}" for i, m in enumerate(SOLVE_IVP_METHODS + C_METHODS)}
        styles = {"c": "-", "python": "--", "lambdify": ":"}
        for config in self.configurations():
            ok = [p for p in self.curve(config) if p.ok and p.err_max > 0]
            if not ok:
                continue
            ax.plot([p.time_s for p in ok], [p.err_max for p in ok], styles[config.backend],
                    color=colours[config.method], marker="o" if config.jac else "s",
                    markerfacecolor=None if config.jac else "none", markersize=5,
                    label=config.label)
        if self.reference.disagreement > 0:
            ax.axhline(self.reference.disagreement, color="0.4", linestyle=(0, (1, 3)),
                       label=f"reference floor {self.reference.disagreement:.1e}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"run time, s (median of {self.repeats})")
        ax.set_ylabel("max abs error over the output times")
        ax.set_title(f"{self.scene}: work-precision ({self.reference.source} reference)")
        ax.grid(True, which="major", alpha=0.4)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        path = Path(path)
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png", dpi=110)
        return path

    # ---------------------------------------------------------- summary
    def fastest(self, level: float, c_integrators: bool | None = None) -> Point | None:
        """The cheapest ok point with ``err_max <= level``.

        ``c_integrators``: True to look only at the C integrators, False only
        at solve_ivp, None at both.
        """
        pool = [p for p in self.points if p.ok and p.err_max <= level and (
            c_integrators is None or p.config.is_c_integrator == c_integrators)]
        return min(pool, key=lambda p: p.time_s, default=None)

    def summary(self) -> str:
        """Reference, fastest configuration per error level, solve_ivp overhead, failures."""
        n_ok = sum(p.ok for p in self.points)
        counts = ", ".join(f"{sum(p.status == s for p in self.points)} {s}"
                           for s in (OK, FAILED, OVER_BUDGET, SKIPPED))
        lines = [f"Work-precision summary: {self.scene} ({len(self.points)} points: {counts}; "
                 f"time: median of {self.repeats} timed loops; whole run {self.wall_time:.1f} s)",
                 self.reference.describe(), *(f"  ({n})" for n in self.reference.notes),
                 self.atol_note, ""]
        lines += self._levels() if n_ok else ["No point succeeded."]
        lines += self._same_steps()
        lines += self._overheads()
        lines += self._failures()
        return "\n".join(lines)

    def _levels(self) -> list[str]:
        floor = self.reference.disagreement
        lines = ["Fastest configuration per error level (max abs error over the output times; "
                 "cheapest point reaching it):"]
        for level in ERROR_LEVELS:
            if level < floor:
                lines.append(f"  error <= {level:.0e}: below the reference floor {floor:.1e}, "
                             f"not measurable")
                continue
            best = self.fastest(level)
            if best is None:
                lines.append(f"  error <= {level:.0e}: no configuration reached it")
                continue
            lines.append(f"  error <= {level:.0e}: {_describe(best)}")
            ivp, c = self.fastest(level, False), self.fastest(level, True)
            for name, p in (("solve_ivp", ivp), ("C integrators", c)):
                if p is not None and p is not best:
                    lines.append(f"      best {name}: {_describe(p)}")
            if ivp is not None and c is not None:
                lines.append(f"      {_speedup(ivp.time_s / c.time_s)} at this error")
        return lines

    def _same_steps(self) -> list[str]:
        """dopri5 against RK45 on the C back end: same tableau and step control."""
        pairs = [(a, b) for a, b in zip(self.curve(Config("RK45", "c")),
                                        self.curve(Config("dopri5", "c"))) if a.ok and b.ok]
        if not pairs:
            return []
        ratios = [a.time_s / b.time_s for a, b in pairs]
        evals = [b.nfev / a.nfev for a, b in pairs]
        return ["", f"dopri5 [c] vs RK45 [c] (same Dormand-Prince tableau and step control) at "
                    f"equal rtol: {statistics.median(ratios):.1f}x faster (median over "
                    f"{len(pairs)} tolerances; range {min(ratios):.1f}-{max(ratios):.1f}x), "
                    f"RHS calls ratio {min(evals):.2f}-{max(evals):.2f}"]

    def _overheads(self) -> list[str]:
        """Median share of solve_ivp's wall time spent outside the callables, per configuration."""
        rows = list(dict.fromkeys((c.method, c.jac) for c in self.configurations()
                                  if not c.is_c_integrator))
        backends = [b for b in BACKENDS if any(p.backend == b for p in self.points)]
        if not rows:
            return []
        lines = ["", "solve_ivp's own overhead: share of wall time outside the RHS/Jacobian "
                     "callables (median over ok points):",
                 "  " + f"{'method':<12}" + "".join(f"{b:>10}" for b in backends)]
        for method, jac in rows:
            cells = []
            for backend in backends:
                shares = [p.overhead for p in self.curve(Config(method, backend, jac))
                          if p.ok and p.overhead is not None]
                cells.append(f"{statistics.median(shares):>10.0%}" if shares else f"{'-':>10}")
            lines.append("  " + f"{method + (' +jac' if jac else ''):<12}" + "".join(cells))
        return lines

    def _failures(self) -> list[str]:
        bad = [p for p in self.points if not p.ok]
        if not bad:
            return []
        return ["", f"Points not ok ({len(bad)}):"] + [
            f"  {p.config.label} {p.setting}: {p.status}: {p.message}" for p in bad]


# ----------------------------------------------------------- formatting
def _setting(rtol: float, h: float | None) -> str:
    return f"h={h:.3g}" if h is not None else f"rtol={rtol:.0e}"


def _describe(p: Point) -> str:
    return f"{p.config.label} {p.setting}: {_ms(p.time_s)} ms, error {p.err_max:.1e}"


def _speedup(ratio: float) -> str:
    """``ratio`` = solve_ivp time / C integrator time, in words."""
    if ratio >= 1:
        return f"C integrators {ratio:.1f}x faster than solve_ivp"
    return f"solve_ivp {1 / ratio:.1f}x faster than the C integrators"


def _ms(seconds: float) -> str:
    """Milliseconds with three significant figures and no exponent."""
    ms = seconds * 1e3
    return f"{ms:.3f}" if ms < 1 else f"{ms:.2f}" if ms < 10 else f"{ms:.1f}" if ms < 100 \
        else f"{ms:.0f}"


_SHORT_STATUS = {FAILED: "fail", OVER_BUDGET: "budget", SKIPPED: "skip"}


def _matrix(title: str, configs: Sequence[Config], curve: Callable[[Config], list[Point]],
            rtols: Sequence[float], cell: Callable[[Point], str]) -> str:
    """A block of the table: one row per configuration, one column per tolerance."""
    width = max(len("configuration"), *(len(c.label) for c in configs)) + 2
    header = f"{'configuration':<{width}}" + "".join(f"{f'rtol {r:.0e}':>11}" for r in rtols)
    lines = [title, header, "-" * len(header)]
    for config in configs:
        cells = [cell(p) if p.ok else _SHORT_STATUS[p.status] for p in curve(config)]
        lines.append(f"{config.label:<{width}}" + "".join(f"{c:>11}" for c in cells))
    return "\n".join(lines)


def _csv_value(value) -> str:
    if value is None:
        return ""
    if isinstance(value, (float, np.floating)):
        return "" if math.isnan(value) else repr(float(value))
    return str(value)


__all__ = ["work_precision", "WorkPrecisionReport", "Point", "Config", "Reference",
           "configurations", "rk4_steps", "typical_magnitude", "DEFAULT_RTOLS",
           "SOLVE_IVP_METHODS", "IMPLICIT_METHODS", "C_METHODS", "BACKENDS", "ATOL_RATIO",
           "ERROR_LEVELS", "CSV_COLUMNS"]
