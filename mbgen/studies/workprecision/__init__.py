"""Work-precision benchmark: error against run time for every integrator and back end.

:func:`work_precision` solves one scene at a sweep of tolerances with

* ``scipy.integrate.solve_ivp`` -- ``RK45``, ``DOP853``, ``Radau``, ``BDF``,
  ``LSODA``; the implicit three (``Radau``, ``BDF``, ``LSODA``) both without a
  Jacobian (solve_ivp's finite differences) and with ``jac=`` the Jacobian of
  the *same* back end -- over three right-hand-side back ends: ``lambdify``
  (:class:`~mbgen.runtime.lambdified.LambdifiedModel` of the scene's baked equations),
  ``python`` (the generated Python, :func:`mbgen.python_model`) and ``c`` (the
  compiled C), all called with the compiled model's arrays;
* the generated C integrators (:meth:`mbgen.runtime.compiled.CompiledModel.integrate`):
  ``dopri5`` and ``rosenbrock`` at the same tolerances, and ``rk4`` at a sweep
  of fixed steps laid onto the same tolerance rows (see :func:`rk4_steps`).

Method
------
The scene is generated and compiled once; a pilot solve sets the absolute
tolerances and the ``rk4`` steps; the reference is computed; then every point
(configuration and tolerance) is probed and timed, with BLAS pinned to one
thread.  Each step is documented where it is done:

Tolerances and the reference
    :mod:`mbgen.studies.workprecision.reference`.
Errors, timing, counts and overhead
    :mod:`mbgen.studies.workprecision.runs`.
Configurations, points and the ``rk4`` steps
    :mod:`mbgen.studies.workprecision.points`.
The back ends and one ``solve_ivp`` call
    :mod:`mbgen.studies.workprecision.solve`.
Table, CSV, summary and figure
    :mod:`mbgen.studies.workprecision.report`, :mod:`mbgen.studies.workprecision.plot`.

Timings on a shared or small machine are noisy: compare within one run.

How to add a method or a back end
---------------------------------
1. A ``solve_ivp`` method: :data:`SOLVE_IVP_METHODS` in ``points.py`` (and
   :data:`IMPLICIT_METHODS` when it takes ``jac=``).  A generated C integrator needs
   nothing here: :data:`C_METHODS` is read from ``abi.INTEGRATORS`` (add it to
   :mod:`mbgen.integrators`); its ``adaptive`` and ``implicit`` properties choose
   tolerances or fixed steps (:func:`rk4_steps`) and the compiled Jacobian.
2. A back end: :data:`BACKENDS` in ``points.py`` and its right-hand side and Jacobian in
   :class:`~mbgen.studies.workprecision.solve.Backends` (``solve.py``).
3. ``tests/studies/test_workprecision.py``: ``test_configurations`` lists the curves of a
   choice of methods and back ends, ``test_every_point_ran`` runs each one.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence

import numpy as np
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from ...errors import UsageError
from ...model.scene import Scene, load_scene
from ...runtime.simulate import consistent_start
from ..ensemble import MAX_POINTS
from .points import (
    BACKENDS,
    C_METHODS,
    DEFAULT_RTOLS,
    IMPLICIT_METHODS,
    SOLVE_IVP_METHODS,
    Config,
    Point,
    configurations,
    plan,
    rk4_steps,
)
from .reference import (
    ATOL_RATIO,
    REFERENCE_BUDGET_FACTOR,
    REFERENCE_BUDGET_MIN_S,
    STIFF_STEPS,
    TrueSolution,
    make_reference,
    pilot,
    stiffness_steps,
    typical_magnitude,
)
from .report import CSV_COLUMNS, ERROR_LEVELS, WorkPrecisionReport
from .runs import run_tasks
from .solve import Backends

DEFAULT_TIME_BUDGET_S = 10.0
DEFAULT_T_EVAL_POINTS = 101


def work_precision(scene: Scene | str, *, rtols: Sequence[float] = DEFAULT_RTOLS,
                   atol_scale: float | None = None, methods: Sequence[str] | None = None,
                   backends: Sequence[str] = BACKENDS, repeats: int = 3,
                   t_eval_points: int = DEFAULT_T_EVAL_POINTS,
                   time_budget: float = DEFAULT_TIME_BUDGET_S,
                   progress: bool | Callable[[str], None] | None = None
                   ) -> WorkPrecisionReport:
    """Error against run time of every integrator and back end on one scene.

    Parameters
    ----------
    scene : Scene or str
        A scene, or the name or path :func:`mbgen.load_scene` takes.
    rtols : sequence of float
        Relative tolerances (the rows of the table).
    atol_scale : float, optional
        ``atol = rtol * atol_scale``; default ``ATOL_RATIO`` x the typical
        state magnitude (:mod:`mbgen.studies.workprecision.reference`).
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
        are skipped.  The pilot and each reference solve may take
        ``REFERENCE_BUDGET_FACTOR`` (5) times as long, and at least
        ``REFERENCE_BUDGET_MIN_S`` (60 s) (:mod:`mbgen.studies.workprecision.reference`).
        ``math.inf`` stops nothing (what a test whose points must all succeed uses: its
        verdict then does not depend on the machine's speed).
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
        b = Backends.build(scene, backends, c_methods)
        x0 = consistent_start(b.compiled, scene.x0(b.compiled.layout), b.p)
        t_eval = np.linspace(*map(float, scene.t_span), t_eval_points)
        b.warm_up(x0, t_eval[0])
        stiff_steps = stiffness_steps(b, t_eval, x0)
        stiff = stiff_steps > STIFF_STEPS
        budget_s = max(REFERENCE_BUDGET_FACTOR * time_budget, REFERENCE_BUDGET_MIN_S)
        if stiff:
            say(f"stiff: an explicit method needs at least {stiff_steps:.2g} steps "
                f"(stability bound); implicit pilot and reference")
        say("pilot solve")
        loosest = max(rtols)
        pilot_scale = atol_scale or ATOL_RATIO * typical_magnitude(x0[None])
        bar = progress is True
        steps, pilot_x, pilot_method = pilot(b, t_eval, x0, loosest, loosest * pilot_scale,
                                             stiff=stiff, budget_s=budget_s, bar=bar)
        magnitude = typical_magnitude(pilot_x)
        atol_note = (f"atol = rtol x {atol_scale:g} (given)" if atol_scale else
                     f"atol = rtol x {ATOL_RATIO * magnitude:.3g} ({ATOL_RATIO:g} x typical "
                     f"state magnitude {magnitude:.3g}: median over states of max |x_i|, "
                     f"{pilot_method} pilot)")
        atol_scale = atol_scale or ATOL_RATIO * magnitude
        reference = make_reference(scene, b, t_eval, x0, atol_scale, say, stiff=stiff,
                                   budget_s=budget_s, bar=bar)
        hs = rk4_steps(rtols, steps, t_eval)
        tasks = plan(configurations(methods, backends), rtols, atol_scale, hs)
        points = run_tasks(tasks, b, t_eval, x0, reference, repeats, time_budget, progress)
    return WorkPrecisionReport(scene.name, tuple(b.compiled.state_names), t_eval, tuple(rtols),
                               atol_scale, atol_note, reference, tuple(points), repeats,
                               time_budget, time.perf_counter() - start)


def _validate(methods, backends, rtols, repeats, t_eval_points, time_budget, atol_scale) -> None:
    """Refuse a mistaken argument before any work (:class:`~mbgen.errors.UsageError`, a
    ``ValueError``; ``mbgen bench`` prints it as one line, exit 2)."""
    unknown = set(methods) - set(SOLVE_IVP_METHODS + C_METHODS)
    if unknown:
        raise UsageError(f"unknown integrator(s) {sorted(unknown)}; choose from "
                         f"{', '.join(SOLVE_IVP_METHODS + C_METHODS)}")
    if set(backends) - set(BACKENDS) or not backends:
        raise UsageError(f"backends must be some of {', '.join(BACKENDS)}; got {list(backends)}")
    if not rtols or not all(0 < r < 1 for r in rtols):
        raise UsageError(f"rtols must be numbers in (0, 1); got {list(rtols)}")
    if repeats < 1 or t_eval_points < 2 or not time_budget > 0:
        raise UsageError("need repeats >= 1, t_eval_points >= 2 and time_budget > 0")
    if t_eval_points > MAX_POINTS:
        raise UsageError(f"t_eval_points={t_eval_points:,} is more than {MAX_POINTS:,}; ask for "
                         f"fewer")
    if atol_scale is not None and not atol_scale > 0:
        raise UsageError(f"atol_scale must be positive; got {atol_scale!r}")


def _reporter(progress) -> Callable[[str], None]:
    """Setup messages: to a callable ``progress``, through tqdm when True, else dropped."""
    if callable(progress):
        return progress
    if progress:
        return lambda message: tqdm.write(message, file=sys.stderr)
    return lambda message: None


__all__ = ["work_precision", "WorkPrecisionReport", "Point", "Config", "TrueSolution",
           "configurations", "rk4_steps", "typical_magnitude", "DEFAULT_RTOLS",
           "DEFAULT_TIME_BUDGET_S", "REFERENCE_BUDGET_FACTOR", "REFERENCE_BUDGET_MIN_S",
           "SOLVE_IVP_METHODS", "IMPLICIT_METHODS", "C_METHODS", "BACKENDS", "ATOL_RATIO",
           "ERROR_LEVELS", "CSV_COLUMNS"]
