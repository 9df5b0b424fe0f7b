"""Simulation with a generated right-hand side, and trajectory output.

:func:`simulate` picks the integrator when none is named (``method=None``):

1. the model's own generated C integrator (``dopri5``, ``rosenbrock`` or
   ``rk4``: whichever the scene generates), unless the inputs are a Python
   function (an :class:`~mbgen.runtime.named.InputTable` stays in C);
2. otherwise scipy's ``DOP853``, watched for stiffness: when its steps are
   held down by stability rather than accuracy (step ``h`` times the spectral
   radius ``rho`` of ``df/dx`` near the method's stability limit, after 2000
   steps) it says so and continues with ``Radau``.

A model known to be stiff (``stiff=True``: a compliant ground, :mod:`mbgen.model.ground`,
whose contact springs and regularised friction are its fastest time scales; ``mbgen
simulate`` passes it for such a scene) goes straight to an implicit method instead: the
generated C ``rosenbrock`` where the model has it (and the inputs are no Python function),
else scipy's ``Radau``; its steps are at most :data:`STIFF_MAX_STEP` long.

The implicit solve_ivp methods (``Radau``, ``BDF``, ``LSODA``) always get the
compiled Jacobian when the model has the ``jacobian`` output.  A named explicit
method that turns out stiffness-bound is kept, with a note naming the better
choice.  Runs longer than about 2 s show a progress bar (tqdm, on stderr).

Saturation (``saturate={input: (lower, upper)}``, e.g. ``scene.input_bounds()``; off by
default): the inputs are clamped to their bounds before any right-hand side reads them,
as the generated step API and FMU clamp them (:func:`saturated`): constant inputs once,
a function's every value, and an :class:`~mbgen.runtime.named.InputTable` by a table of
its own whose knots include every time the signal crosses a bound, so that the C
integrators' linear interpolation of it is the clamped signal.  A constant input beyond
its bound gives bit for bit the trajectory of the input at the bound.
"""

from __future__ import annotations

import sys
import threading
import time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import replace

import numpy as np
from scipy import integrate as ivp

from ..abi import INTEGRATORS, Output
from ..errors import (
    ArgumentError,
    ArgumentTypeError,
    IntegrationError,
    StiffnessWarning,
    UsageError,
)
from ..integrators import DEFAULT_ATOL, DEFAULT_RTOL, METHODS
from . import named
from .arguments import real_number
from .base import ModelBase
from .integration import Trajectory

SOLVE_IVP = {"RK23": ivp.RK23, "RK45": ivp.RK45, "DOP853": ivp.DOP853, "Radau": ivp.Radau,
             "BDF": ivp.BDF, "LSODA": ivp.LSODA}
IMPLICIT = frozenset({"Radau", "BDF", "LSODA"})
C_METHODS = tuple(o.value for o in INTEGRATORS)
# Where each explicit method's stability region meets the negative real axis (|h lambda|).
_STABILITY = {"RK23": 2.5, "RK45": 3.3, "DOP853": 6.0}
STIFF_MIN_STEPS = 2000      # below this many steps nothing is called stiffness-bound
PROGRESS_DELAY = 2.0        # seconds before a progress bar appears
MAX_STEPS = 1_000_000       # default step limit of the solve_ivp paths (C: the integrator's own)
RK4_STEPS = 10_000          # default steps of the fixed-step rk4 over the span
#: Longest step (s) of a stiff run (``stiff=True``): a ground contact lasts tens of
#: milliseconds (a period of 2 pi sqrt(delta / g) = 63 ms at the default 1 mm sinking), and
#: a step that leaps into the ground from free flight evaluates states far inside it.
STIFF_MAX_STEP = 0.01


def holonomic_outputs(scene) -> tuple:
    """The outputs :func:`consistent_start` needs for ``scene`` (none without configuration
    constraints): ``(Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN)``."""
    model = scene.model
    stated = getattr(model, "constraints_", None)
    if stated is not None:
        has = any(c.kind == "holonomic" for c in stated)
    else:
        c = getattr(model, "constraints", None)
        has = c is not None and c.m_h > 0
    return (Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN) if has else ()


def consistent_start(model: ModelBase, x0, p=None, r=None, t0: float = 0.0) -> np.ndarray:
    """``x0`` with its dependent coordinates solved from the configuration constraints.

    The given values of the dependent coordinates are the starting guess of
    Newton's method (:meth:`ModelBase.consistent`); the independent coordinates
    and the speeds (only independent speeds are states) are kept.  A model
    without configuration constraints gets ``x0`` back unchanged.

    Raises
    ------
    ConstraintError
        Newton did not converge or the constraints cannot be solved there.
    """
    x0 = model._x(x0).copy()
    if not getattr(model, "dependent_coordinates", ()):
        return x0
    return model.consistent(x0, p, r, t0)


def _residual(model, t, x, p, r) -> float:
    """Largest ``|f_h|`` over the rows of ``x`` (NaN without configuration constraints)."""
    if not getattr(model, "dependent_coordinates", ()):
        return float("nan")
    return max(float(np.max(np.abs(model.holonomic(ti, xi, p, r)))) for ti, xi in zip(t, x))


def input_limits(model: ModelBase, bounds) -> tuple[np.ndarray, np.ndarray]:
    """``(lower, upper)``, shape ``(n_r,)`` each, in ``model``'s input order, of
    ``bounds = {input: (lower, upper)}`` (inputs left out, and None ends: unbounded).

    Raises
    ------
    ArgumentTypeError
        ``bounds`` is not a mapping, or an end is not a real number.
    UnknownNameError
        A name is not an input of ``model``.
    ArgumentError
        An end is NaN, or ``lower > upper``.
    """
    if not isinstance(bounds, Mapping):
        raise ArgumentTypeError(f"saturate must be a mapping {{input: (lower, upper)}}, e.g. "
                                f"scene.input_bounds(); got {type(bounds).__name__} "
                                f"{bounds!r:.60}")
    named.check_names(bounds, model.input_names, "inputs", model.name)
    lower = np.full(model.n_r, -np.inf)
    upper = np.full(model.n_r, np.inf)
    for name, ends in bounds.items():
        i = model.input_names.index(name)
        try:
            lo, hi = ends
        except (TypeError, ValueError):
            raise ArgumentTypeError(f"saturate[{name!r}] must be a pair (lower, upper); got "
                                    f"{ends!r:.60}") from None
        if lo is not None:
            lower[i] = real_number(lo, f"saturate[{name!r}] lower")
        if hi is not None:
            upper[i] = real_number(hi, f"saturate[{name!r}] upper")
        if not lower[i] <= upper[i]:
            raise ArgumentError(f"saturate[{name!r}] = {ends!r}: give lower <= upper, "
                                f"neither NaN")
    return lower, upper


def clamp(values, lower, upper) -> np.ndarray:
    """``values`` (shape ``(..., n_r)``) clamped as the generated ``<prefix>_saturate_inputs``
    does: below ``lower`` is ``lower``, above ``upper`` is ``upper``, the rest (NaN too) as is."""
    values = np.asarray(values, dtype=float)
    return np.where(values < lower, lower, np.where(values > upper, upper, values))


def saturated(model: ModelBase, r, bounds):
    """The inputs ``r`` (as :func:`simulate` takes them) clamped to ``bounds``
    (:func:`input_limits`): an array for constant inputs (None: zeros, clamped), a function
    for a function, a table for a table.

    A table's clamped signal ``clamp(r(t))`` is piecewise linear with a knot wherever
    ``r(t)`` crosses a bound inside a segment: those knots are added (the crossing time by
    linear interpolation, the value there the bound itself), the original knots keep their
    clamped values, so the C integrators interpolate the clamped signal (exactly at the
    original knots, up to rounding at the added ones).
    """
    lower, upper = input_limits(model, bounds)
    if isinstance(r, named.InputTable):
        return _clamped_table(r.for_model(model), lower, upper)
    if callable(r):
        check_r = model._r
        return lambda t, x: clamp(check_r(r(t, x)), lower, upper)
    return clamp(model._r(r), lower, upper)


def _clamped_table(table: named.InputTable, lower, upper) -> named.InputTable:
    """``table`` clamped with its bound crossings as knots (see :func:`saturated`)."""
    t, v = table.times, table.values
    crossings = []
    for j in range(v.shape[1]):
        for bound in (lower[j], upper[j]):
            if not np.isfinite(bound):
                continue
            side = np.sign(v[:, j] - bound)
            k = np.nonzero(side[:-1] * side[1:] < 0)[0]     # strictly across, inside a segment
            share = (bound - v[k, j]) / (v[k + 1, j] - v[k, j])
            crossings.append(t[k] + share * (t[k + 1] - t[k]))
    added = np.setdiff1d(np.concatenate(crossings), t) if crossings else np.zeros(0)
    if added.size == 0:
        return named.InputTable(t, clamp(v, lower, upper))
    times = np.union1d(t, added)
    values = np.stack([np.interp(times, t, col) for col in v.T], axis=1)
    values[np.searchsorted(times, t)] = v                      # the original knots as given
    return named.InputTable(times, clamp(values, lower, upper))


def beyond_bounds(traj: Trajectory, bounds) -> dict[str, tuple[float, float]]:
    """``{state: (t, value)}`` of the states of ``traj`` that leave their ``bounds``
    (``{state: (lower, upper)}``, e.g. ``model.bounds("speeds")``; names not in ``traj``
    are skipped) at an output time: the first such time and the value farthest outside.

    States are never clamped (saturating a state inside an integrator is no physics: see
    :mod:`mbgen.codegen.targets.step`); this reports a speed over its ``<limit velocity>``
    after the fact, at the output times only (a short excursion between them is missed).
    """
    out = {}
    for name, (lo, hi) in bounds.items():
        if name not in traj.names:
            continue
        v = traj.x[:, traj.names.index(name)]
        outside = np.nonzero((v < lo) | (v > hi))[0]
        if outside.size:
            excess = np.maximum(lo - v, v - hi)
            out[name] = float(traj.t[outside[0]]), float(v[int(np.argmax(excess))])
    return out


def choose_method(model: ModelBase, method: str | None = None, r=None,
                  stiff: bool = False) -> tuple[str, str]:
    """``(method, reason)``: the method :func:`simulate` will use.

    ``method`` is a solve_ivp name (any case), a generated C integrator or
    ``None``/``"auto"``; ``stiff`` makes auto choose an implicit one (module notes).

    Raises
    ------
    UsageError
        An unknown method, a C integrator the model was not compiled with, or
        a C integrator asked to follow a Python input function.
    """
    python_inputs = callable(r) and not isinstance(r, named.InputTable)
    if (method is None or str(method).lower() == "auto") and stiff:
        return _stiff_choice(model, python_inputs)
    if method is None or str(method).lower() == "auto":
        own = [o.value for o in model.c_integrators]
        if own and not python_inputs:
            return own[0], f"the model's generated C integrator {own[0]!r}"
        why = ("inputs are a Python function (an InputTable would stay in C)" if python_inputs
               else "no generated C integrator")
        return "DOP853", f"{why}: scipy DOP853, switching to Radau if stiffness-bound"
    name = str(method)
    if name.lower() in C_METHODS:
        name = name.lower()
        if Output(name) not in model.c_integrators:
            raise UsageError(f"the C integrator {name!r} was not generated for {model.name!r}; "
                             f"compile with outputs including {name!r}, or name a solve_ivp "
                             f"method ({', '.join(SOLVE_IVP)})")
        if python_inputs:
            raise UsageError(f"a Python input function cannot drive the C integrator {name!r}; "
                             f"give the inputs as mbgen.runtime.named.InputTable(times, values), "
                             f"or use a solve_ivp method")
        return name, "as asked"
    by_lower = {k.lower(): k for k in SOLVE_IVP}
    if name.lower() not in by_lower:
        raise UsageError(f"unknown integration method {method!r}; choose a solve_ivp method "
                         f"({', '.join(SOLVE_IVP)}), a generated C integrator "
                         f"({', '.join(C_METHODS)}) or auto")
    return by_lower[name.lower()], "as asked"


def _stiff_choice(model: ModelBase, python_inputs: bool) -> tuple[str, str]:
    """Auto's choice for a stiff model: C ``rosenbrock`` if compiled, else ``Radau``."""
    if Output.ROSENBROCK in model.c_integrators and not python_inputs:
        return "rosenbrock", "stiff: the model's generated C integrator 'rosenbrock'"
    jac = "with" if Output.JACOBIAN in model.outputs else "without"
    return "Radau", f"stiff: scipy Radau ({jac} the compiled Jacobian)"


def simulate(model: ModelBase, x0, t_span, *, p=None, r=None, method: str | None = None,
             rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL, n_out: int = 201,
             t_eval=None,
             progress: bool = True, say: Callable[[str], None] | None = None,
             rk4_steps: int = RK4_STEPS, project: bool = True,
             max_steps: int | None = None, saturate=None,
             stiff: bool = False) -> Trajectory:
    """Integrate ``model`` from ``x0`` over ``t_span``.

    Parameters
    ----------
    model : ModelBase
        Compiled, generated-Python or lambdified model.
    x0 : array, shape (n_x,), or mapping by state name (others 0)
    t_span : (float, float)
    p : array or mapping by name, optional
        Parameters (default, and for names left out: the model's defaults).
    r : array, mapping, InputTable or function ``r(t, x)``, optional
        Inputs: constant (default 0), a piecewise-linear table (interpolated in
        C by the C integrators), or a Python function (solve_ivp only).
    method : str, optional
        ``None`` (auto, see the module notes), a solve_ivp method (``RK45``,
        ``DOP853``, ``Radau``, ``BDF``, ``LSODA``, ``RK23``) or a generated C
        integrator (``dopri5``, ``rosenbrock``, ``rk4`` with the fixed step
        ``(t1 - t0) / rk4_steps``).
    rtol, atol : float
        Error tolerances (default :data:`mbgen.integrators.DEFAULT_RTOL`,
        ``DEFAULT_ATOL``: 1e-6, 1e-9, as every integration mbgen runs).
    n_out : int
        Number of equally spaced output times when ``t_eval`` is not given.
    progress : bool
        Show a progress bar (stderr) once a run takes longer than 2 s.
    say : callable, optional
        Receives notes (stiffness); default: :class:`StiffnessWarning` warnings.
    project : bool
        C integrators of models with configuration constraints: project the
        dependent coordinates back onto the constraints after each step.
    max_steps : int, optional
        Step limit (attempted steps in C; accepted steps in solve_ivp, default
        :data:`MAX_STEPS`); reaching it is an :class:`IntegrationError`.
    saturate : mapping input name -> (lower, upper), optional
        Clamp the inputs to these bounds before the right-hand side reads them (None ends:
        unbounded), as the generated step API does for ``Scene(saturate=True)``; e.g.
        ``saturate=scene.input_bounds()`` (see the module notes and :func:`saturated`).
        Default None: the inputs as given.
    stiff : bool
        The model is stiff (a compliant ground): auto (``method=None``) takes the C
        ``rosenbrock`` where compiled, else ``Radau``, without trying DOP853 first; no
        adaptive step is longer than :data:`STIFF_MAX_STEP`.

    Models with configuration constraints start from :func:`consistent_start`;
    solve_ivp does not project, so their trajectory drifts off the constraints
    (``Trajectory.max_residual`` measures how far).

    Raises
    ------
    UsageError
        Unknown method (see :func:`choose_method`).
    IntegrationError
        The integrator failed (the solver's message is included).
    ConstraintError
        The dependent coordinates of ``x0`` cannot be completed.
    """
    say = say or (lambda msg: warnings.warn(msg, StiffnessWarning, stacklevel=3))
    if saturate is not None:
        r = saturated(model, r, saturate)
    chosen, reason = choose_method(model, method, r, stiff=bool(stiff))
    t0, t1 = float(t_span[0]), float(t_span[1])
    if not (np.isfinite(t0) and np.isfinite(t1) and t1 > t0):
        raise ArgumentError(f"t_span {t_span!r}: give two finite times, the second after the "
                            f"first")
    if max_steps is not None and (isinstance(max_steps, bool) or int(max_steps) != max_steps
                                  or max_steps < 1):
        raise ArgumentError(f"max_steps={max_steps!r}: give a positive whole number of steps")
    r0 = None if callable(r) or isinstance(r, named.InputTable) else r   # for the constraints
    x0 = consistent_start(model, x0, p, r0, t0)
    t_eval = np.linspace(t0, t1, n_out) if t_eval is None else np.asarray(t_eval, dtype=float)
    if chosen in C_METHODS:
        return _in_c(model, chosen, x0, p, r, t_eval, rtol, atol, rk4_steps, progress, reason,
                     project, int(max_steps or 0), STIFF_MAX_STEP if stiff else 0.0)
    auto = method is None or str(method).lower() == "auto"
    if t_eval.ndim != 1 or t_eval.size < 1 or np.any(np.diff(t_eval) <= 0) \
            or t_eval[0] < t0 or t_eval[-1] > t1:
        raise ValueError(f"t_eval must be increasing times within t_span {(t0, t1)}")
    return _solve_ivp(model, chosen, x0, p, r, (t0, t1), t_eval, rtol, atol, progress, say,
                      auto, reason, int(max_steps or MAX_STEPS),
                      STIFF_MAX_STEP if stiff else np.inf)


def simulate_in_c(model, x0, t_span, *, method: str = "dopri5", rtol: float = DEFAULT_RTOL,
                  atol: float = DEFAULT_ATOL, n_out: int = 201, p=None, r=None,
                  rk4_steps: int = RK4_STEPS, progress: bool = False,
                  project: bool = True) -> Trajectory:
    """Integrate with a generated C integrator (``model.integrate``); see :func:`simulate`."""
    return simulate(model, x0, t_span, method=method, rtol=rtol, atol=atol, n_out=n_out, p=p,
                    r=r, rk4_steps=rk4_steps, progress=progress, project=project)


# ------------------------------------------------------------------ C integrators
def _in_c(model, method, x0, p, r, t, rtol, atol, rk4_steps, progress, reason,
          project=True, max_steps=0, h_max=0.0) -> Trajectory:
    h = None if METHODS[Output(method)].adaptive else (t[-1] - t[0]) / rk4_steps
    done: dict = {}

    def work():  # cffi releases the GIL: the bar below keeps time while C runs
        try:
            done["result"] = model.integrate(method, t, x0, p, r, rtol=rtol, atol=atol, h=h,
                                             project=project, max_steps=max_steps,
                                             **({"h_max": h_max} if h_max and h is None
                                                else {}))
        except BaseException as exc:  # re-raised in the caller's thread
            done["error"] = exc

    worker = threading.Thread(target=work, daemon=True)
    worker.start()
    worker.join(PROGRESS_DELAY if progress else None)
    if worker.is_alive():
        from tqdm import tqdm

        with tqdm(desc=f"{model.name}: C {method}", bar_format="{desc}: {elapsed}",
                  file=sys.stderr) as bar:
            while worker.is_alive():
                worker.join(0.2)
                bar.refresh()
    if "error" in done:
        raise done["error"]
    return replace(done["result"], method=f"C {method}", message=reason)


# ------------------------------------------------------------------ solve_ivp
def _spectral_radius(jac, f, t, y, fy) -> float:
    """``max |lambda|`` of ``df/dx`` at ``(t, y)``: eigenvalues of the compiled
    Jacobian, else power iteration on finite-difference products ``J v``."""
    if jac is not None and y.size <= 200:
        return float(np.max(np.abs(np.linalg.eigvals(jac(t, y)))))
    v = np.random.default_rng(0).standard_normal(y.size)
    v /= np.linalg.norm(v)
    eps = np.sqrt(np.finfo(float).eps) * (1.0 + np.linalg.norm(y))
    rho = 0.0
    for _ in range(12):
        w = (f(t, y + eps * v) - fy) / eps
        rho = float(np.linalg.norm(w))
        if not rho > 0 or not np.isfinite(rho):
            return 0.0
        v = w / rho
    return rho


def _solve_ivp(model, method, x0, p, r, t_span, t_eval, rtol, atol, progress, say, auto,
               reason, max_steps=MAX_STEPS, max_step=np.inf) -> Trajectory:
    f = model.bind(p, r)
    has_jac = Output.JACOBIAN in model.outputs
    jac = model.bind(p, r, Output.JACOBIAN) if has_jac else None
    y = model._x(x0).copy()
    t0, t1 = t_span
    if method in IMPLICIT and jac is None:
        say(f"{model.name} has no compiled Jacobian: {method} estimates it by finite "
            f"differences; compile with outputs including 'jacobian' for speed")
    from tqdm import tqdm

    bar = tqdm(total=t1 - t0, desc=f"{model.name}: {method}", file=sys.stderr,
               delay=PROGRESS_DELAY, disable=not progress, unit="s(sim)",
               bar_format="{l_bar}{bar}| t={n:.4g}/{total:.4g} [{elapsed}<{remaining}]")
    first = int(np.searchsorted(t_eval, t0, side="right"))  # t_eval entries at t0 get x0
    columns = [np.repeat(y[:, None], first, axis=1)] if first else []
    nfev = njev = nlu = steps = 0
    label, note, warned = method, reason, False
    start = time.perf_counter()
    try:
        t, idx = t0, first
        while t < t1:
            cls = SOLVE_IVP[method]
            kw = {"jac": jac} if method in IMPLICIT and jac is not None else {}
            solver = cls(f, t, y, t1, rtol=rtol, atol=atol, max_step=max_step, **kw)
            stiff = False
            while solver.status == "running":
                message = solver.step()
                if solver.status == "failed":
                    raise IntegrationError(f"integration of {model.name} ({label}) failed at "
                                           f"t={solver.t!r}: {message}", None, float(solver.t))
                steps += 1
                if steps > max_steps:
                    raise IntegrationError(
                        f"integration of {model.name} ({label}) reached its step limit of "
                        f"{max_steps} steps at t={solver.t:.6g} of {t1:.6g}; raise max_steps "
                        f"(--max-steps), loosen rtol/atol, or use an implicit or C integrator",
                        None, float(solver.t))
                j = int(np.searchsorted(t_eval, solver.t, side="right"))
                if j > idx:
                    columns.append(np.asarray(solver.dense_output()(t_eval[idx:j])).reshape(
                        y.size, j - idx))
                    idx = j
                bar.update(solver.t - bar.n)
                if (method in _STABILITY and steps >= STIFF_MIN_STEPS and steps % 500 == 0
                        and not warned):
                    h = solver.t - solver.t_old
                    fy = f(solver.t, solver.y)
                    rho = _spectral_radius(jac, f, solver.t, solver.y, fy)
                    if h * rho > 0.5 * _STABILITY[method]:
                        better = [o.value for o in model.c_integrators]
                        hint = (f"the C integrator {better[0]!r}" if better
                                else "Radau or BDF (" + (
                                    "they get the compiled Jacobian" if has_jac else
                                    "compile with outputs including 'jacobian' to pass them "
                                    "the Jacobian") + ") or the generated C 'rosenbrock'")
                        text = (f"{model.name}: {method} is stiffness-bound at t={solver.t:.6g}: "
                                f"{steps} steps so far of h={h:.3g} against the fastest time "
                                f"scale 1/rho={1 / rho:.3g} (h*rho={h * rho:.3g}, stability "
                                f"limit {_STABILITY[method]}); use {hint}")
                        warned = True
                        if auto:
                            say(text + "; switching to Radau")
                            stiff = True
                            break
                        say(text)
            nfev, njev, nlu = nfev + solver.nfev, njev + solver.njev, nlu + solver.nlu
            t, y = float(solver.t), np.array(solver.y)
            if stiff:
                method, label = "Radau", f"{label} -> Radau"
                note = reason + "; stiffness-bound, switched to Radau"
                if jac is None:
                    say(f"{model.name}: Radau without a compiled Jacobian (finite differences)")
    finally:
        bar.close()
    wall = time.perf_counter() - start
    x = np.concatenate(columns, axis=1).T.copy() if columns else np.zeros((0, y.size))
    return Trajectory(np.asarray(t_eval, dtype=float), x, tuple(model.state_names), int(nfev),
                      wall, label, int(njev), int(nlu), steps, note,
                      _residual(model, t_eval, x, p,
                                None if callable(r) or isinstance(r, named.InputTable) else r))


__all__ = ["simulate", "simulate_in_c", "consistent_start", "holonomic_outputs",
           "choose_method", "saturated", "input_limits", "clamp", "beyond_bounds", "SOLVE_IVP",
           "IMPLICIT", "C_METHODS"]
