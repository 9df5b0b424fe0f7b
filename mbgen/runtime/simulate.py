"""Simulation with a generated right-hand side, and trajectory output.

:func:`simulate` picks the integrator when none is named (``method=None``):

1. the model's own generated C integrator (``dopri5``, ``rosenbrock`` or
   ``rk4``: whichever the scene generates), unless the inputs are a Python
   function (an :class:`~mbgen.runtime.named.InputTable` stays in C);
2. otherwise scipy's ``DOP853``, watched for stiffness: when its steps are
   held down by stability rather than accuracy (step ``h`` times the spectral
   radius ``rho`` of ``df/dx`` near the method's stability limit, after 2000
   steps) it says so and continues with ``Radau``.

The implicit solve_ivp methods (``Radau``, ``BDF``, ``LSODA``) always get the
compiled Jacobian when the model has the ``jacobian`` output.  A named explicit
method that turns out stiffness-bound is kept, with a note naming the better
choice.  Runs longer than about 2 s show a progress bar (tqdm, on stderr).
"""

from __future__ import annotations

import sys
import threading
import time
import warnings
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from scipy import integrate as ivp

from ..abi import INTEGRATORS, Output
from ..errors import ArgumentError, IntegrationError, StiffnessWarning, UsageError
from ..integrators import DEFAULT_ATOL, DEFAULT_RTOL, METHODS
from . import named
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


def choose_method(model: ModelBase, method: str | None = None, r=None) -> tuple[str, str]:
    """``(method, reason)``: the method :func:`simulate` will use.

    ``method`` is a solve_ivp name (any case), a generated C integrator or
    ``None``/``"auto"``.

    Raises
    ------
    UsageError
        An unknown method, a C integrator the model was not compiled with, or
        a C integrator asked to follow a Python input function.
    """
    python_inputs = callable(r) and not isinstance(r, named.InputTable)
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


def simulate(model: ModelBase, x0, t_span, *, p=None, r=None, method: str | None = None,
             rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL, n_out: int = 201,
             t_eval=None,
             progress: bool = True, say: Callable[[str], None] | None = None,
             rk4_steps: int = RK4_STEPS, project: bool = True,
             max_steps: int | None = None) -> Trajectory:
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
    chosen, reason = choose_method(model, method, r)
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
                     project, int(max_steps or 0))
    auto = method is None or str(method).lower() == "auto"
    if t_eval.ndim != 1 or t_eval.size < 1 or np.any(np.diff(t_eval) <= 0) \
            or t_eval[0] < t0 or t_eval[-1] > t1:
        raise ValueError(f"t_eval must be increasing times within t_span {(t0, t1)}")
    return _solve_ivp(model, chosen, x0, p, r, (t0, t1), t_eval, rtol, atol, progress, say,
                      auto, reason, int(max_steps or MAX_STEPS))


def simulate_in_c(model, x0, t_span, *, method: str = "dopri5", rtol: float = DEFAULT_RTOL,
                  atol: float = DEFAULT_ATOL, n_out: int = 201, p=None, r=None,
                  rk4_steps: int = RK4_STEPS, progress: bool = False,
                  project: bool = True) -> Trajectory:
    """Integrate with a generated C integrator (``model.integrate``); see :func:`simulate`."""
    return simulate(model, x0, t_span, method=method, rtol=rtol, atol=atol, n_out=n_out, p=p,
                    r=r, rk4_steps=rk4_steps, progress=progress, project=project)


# ------------------------------------------------------------------ C integrators
def _in_c(model, method, x0, p, r, t, rtol, atol, rk4_steps, progress, reason,
          project=True, max_steps=0) -> Trajectory:
    h = None if METHODS[Output(method)].adaptive else (t[-1] - t[0]) / rk4_steps
    done: dict = {}

    def work():  # cffi releases the GIL: the bar below keeps time while C runs
        try:
            done["result"] = model.integrate(method, t, x0, p, r, rtol=rtol, atol=atol, h=h,
                                             project=project, max_steps=max_steps)
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
               reason, max_steps=MAX_STEPS) -> Trajectory:
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
            solver = cls(f, t, y, t1, rtol=rtol, atol=atol, **kw)
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
           "choose_method", "SOLVE_IVP", "IMPLICIT", "C_METHODS"]
