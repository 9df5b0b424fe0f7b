"""Long runs: drift of the energy ``T + V`` (``conserves_energy`` scenes), drift of the
Jacobi integral ``h = T2 - T0 + V`` (prescribed motion without explicit time,
dampers or inputs, :func:`jacobi_applies`), and error against the scene's closed
form, each with scipy DOP853 and C dopri5.

Bounds
------
Relative drift ``max|E - E_0| / max(|T| + |V|) <= 1e-6`` at ``rtol =
1e-10`` (the same for the Jacobi integral); closed form: ``max|x - x_cf| /
max|x_cf| <= 1e-7`` at ``rtol = 1e-10``.  Energy runs last ``long_factor``
times the scene's ``t_span`` (:class:`~mbgen.verify.stress.context.Size`), the others
one ``t_span``.  A run stopped at its step or evaluation budget is judged on the part it
ran (the verdict says ``ok, budget`` when that part is within the bound).
"""

from __future__ import annotations

import time

import numpy as np
import sympy as sm

from ...abi import Output
from ...model.builder import Model
from ...model.elements import LineElement
from ...symbolic.graph import free_symbols
from .context import Context
from .report import Case, fmt_g
from .runs import c_run, energy_series, run_figure, scipy_run

#: Tolerances of the long runs.
LONG_RTOL, LONG_ATOL = 1e-10, 1e-12
#: Largest relative drift of the energy or Jacobi integral (short simulations too).
DRIFT_BOUND = 1e-6
#: Largest relative error against the closed form.
CLOSED_FORM_BOUND = 1e-7


def _has_explicit_time(equations) -> bool:
    exprs = list(equations.mass_matrix) + list(equations.forcing) + list(equations.kinematics)
    return equations.layout.time in free_symbols(exprs)


def jacobi_applies(ctx: Context) -> bool:
    """Prescribed motion, no explicit time, no dampers, energy available (inputs are zero)."""
    mdl = ctx.scene.model
    if not isinstance(mdl, Model) or not mdl.prescribed_ or ctx.scene.conserves_energy:
        return False
    if Output.ENERGY not in ctx.model.outputs or _has_explicit_time(ctx.equations):
        return False
    subs = {sm.Symbol(n): v for n, v in ctx.values.items()}
    for load in mdl.loads:
        if isinstance(load, LineElement) and float(sm.sympify(load.damping).subs(subs)) != 0:
            return False
    return True


def _jacobi_series(model, ts, xs, p) -> tuple[np.ndarray, float]:
    """``h = T2 - T0 + V`` along a trajectory, and its scale ``max(|T2| + |T0| + |V|)``."""
    nq = model.layout.n_q
    h, scale = [], 0.0
    for t, x in zip(ts, xs):
        T, V = model.energy(t, x, p)
        x0 = x.copy()
        x0[nq:] = 0.0
        xm = x.copy()
        xm[nq:] = -x[nq:]
        T0 = model.energy(t, x0, p)[0]
        Tm = model.energy(t, xm, p)[0]
        T2 = 0.5 * (T + Tm) - T0
        h.append(T2 - T0 + V)
        scale = max(scale, abs(T2) + abs(T0) + abs(V))
    return np.array(h), scale


def long_run_case(ctx: Context, what: str, integrator: str) -> Case:
    """Drift of the energy or Jacobi integral, or error against the closed form."""
    start = time.perf_counter()
    model, p, sz = ctx.model, ctx.p0, ctx.size
    T = ctx.span[1] - ctx.span[0]
    factor = sz.long_factor if what == "energy" else 1.0
    span = (ctx.t0, ctx.t0 + factor * T)
    if integrator == "DOP853":
        r = scipy_run("DOP853", model.bind(p), None, span, ctx.x0, rtol=LONG_RTOL,
                      atol=LONG_ATOL, max_steps=sz.step_budget * 5,
                      max_evals=sz.eval_budget * 2)
    else:
        t_out = np.linspace(span[0], span[1], 2001)
        r = c_run(model, "dopri5", t_out, ctx.x0, p, rtol=LONG_RTOL, atol=LONG_ATOL,
                  max_steps=100 * sz.step_budget)
    name = f"{what} {r.method} rtol {LONG_RTOL:g}, {fmt_g(span[1] - span[0])} s"
    data = {"steps": r.steps, "t_reached": r.t_reached}
    if r.status == "failed":
        return Case("long_run", name, run_figure(r), "succeeds", False, f"failed: {r.message}",
                    data, time.perf_counter() - start)
    ts, xs = (r.t, r.x) if r.status == "done" else (r.t[:-1], r.x[:-1]) \
        if not np.all(np.isfinite(r.x[-1])) else (r.t, r.x)
    if what == "closed_form":
        exact = np.asarray(ctx.scene.closed_form(ts - ctx.t0, ctx.x0, p))
        err = float(np.abs(xs - exact).max() / max(np.abs(exact).max(), 1e-300))
        bound, value = f"max|x - x_cf|/max|x_cf| <= {CLOSED_FORM_BOUND:g}", err
        fig = f"rel err {fmt_g(err)}; {r.steps} steps, {r.seconds:.2f} s"
        limit = CLOSED_FORM_BOUND
    else:
        series = energy_series if what == "energy" else _jacobi_series
        E, scale = series(model, ts, xs, p)
        value = float(np.abs(E - E[0]).max() / scale) if scale > 0 else 0.0
        label = "E" if what == "energy" else "h"
        bound = f"max|{label}-{label}0|/scale <= {DRIFT_BOUND:g}"
        fig = f"drift {fmt_g(value)}; {r.steps} steps, {r.seconds:.2f} s"
        limit = DRIFT_BOUND
    data["value"] = value
    ok = value <= limit
    if r.status == "budget":
        reason = f"budget: {r.message} at t={r.t_reached:.3g}; " + \
            ("within bound so far" if ok else "exceeded")
    else:
        reason = "within bound" if ok else f"{fmt_g(value)} exceeds {limit:g}"
    return Case("long_run", name, fig, bound, ok, reason, data, time.perf_counter() - start,
                stopped=f"{r.method}: {r.message}" if r.status == "budget" else "")
