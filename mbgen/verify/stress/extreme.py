"""Extreme cases: masses, lengths, gravity and speeds scaled far from the nominal point,
and non-physical masses (:func:`extreme_variations`; which parameters, by name,
:func:`classify_parameters`).  Each point is checked against the 50-digit reference
(:func:`extreme_case`) and then, as its own case, simulated briefly when admissible
(:func:`admits_simulation`, :func:`short_simulation`) or started in a C integrator
where ``M`` is not positive definite (:func:`c_not_positive_definite`).

Short simulations
-----------------
Over ``min(T, 10 tau)`` (``tau`` the fastest time scale at the start,
:func:`time_scale`), Radau with the Jacobian must succeed; DOP853 must agree
within ``1e-5 max(1, |x|)`` or stop at its budget; energy drift ``<= 1e-6`` for
conservative scenes (both at ``rtol = 1e-8``).  Radau stopped at its step or evaluation
budget is a harness budget failure (cause ``budget``), never a model failure.  Where
``M`` is not positive definite, C dopri5 must stop with status ``NOT_POSITIVE_DEFINITE``.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ...abi import Output
from .context import Context
from .long_runs import DRIFT_BOUND
from .precision import check_point, numerically_singular, try_call
from .report import BUDGET, Case, fmt_g, fmt_sci
from .runs import STATUS_NOT_POSITIVE_DEFINITE, c_run, energy_series, scipy_run

#: Factors the mass-like parameters are also scaled by (non-physical).
NON_PHYSICAL = (0.0, -1.0)
#: Tolerance of the short simulations, and how closely DOP853 must agree with Radau there.
SIM_RTOL = 1e-8
SIM_AGREE = 1e-5

_MASS = re.compile(r"^(m|mass\w*|J|I([0-9xyz])\2)\d*$|^m_?\d+$")
_LENGTH = re.compile(r"^(l|L|a|h|s|r|R|d|len\w*)_?\d*$")


def classify_parameters(names: Sequence[str]) -> dict[str, list[str]]:
    """Group parameter names into ``mass`` (and moments of inertia), ``length`` and ``gravity``.

    Parameters
    ----------
    names : sequence of str
        Parameter names in layout order.

    Returns
    -------
    dict
        ``{"mass": [...], "length": [...], "gravity": [...]}`` in layout order.
    """
    out = {"mass": [], "length": [], "gravity": []}
    for n in names:
        if n == "g":
            out["gravity"].append(n)
        elif _MASS.match(n):
            out["mass"].append(n)
        elif _LENGTH.match(n):
            out["length"].append(n)
    return out


@dataclass(frozen=True)
class Variation:
    """A changed point: parameter values, state and a label."""

    name: str
    values: dict
    x: np.ndarray


def time_scale(model, t, x, p) -> float:
    """The fastest time scale at ``x``: the least of ``1 / rho(J)``, ``max(1, |q_i|) / |q_i'|``
    and ``sqrt(max(1, |q_i|) / |u_i'|)`` (the last two only for ``n_q == n_u``).

    ``rho(J)`` alone can miss a fast scale (at a turning point the Jacobian
    may not show the gravity term); the velocity and acceleration scales
    catch large speeds and forces.
    """
    J, err = try_call(model.jacobian, t, x, p)
    f, err_f = try_call(model.rhs, t, x, p)
    if err or err_f:
        return math.nan
    scales = []
    rho = float(np.abs(np.linalg.eigvals(J)).max())
    if rho > 0:
        scales.append(1.0 / rho)
    nq, nu = model.layout.n_q, model.layout.n_u
    size = np.maximum(1.0, np.abs(x[:nq]))
    with np.errstate(divide="ignore"):
        scales += list(size / np.abs(f[:nq]))
        if nq == nu:
            scales += list(np.sqrt(size / np.abs(f[nq:])))
    return float(min(scales)) if scales else math.inf


def admits_simulation(evaluation: Case) -> bool:
    """Whether a point whose evaluation is ``evaluation`` is simulated: it met its bound with a
    finite error and ``M`` is not numerically singular there."""
    return (evaluation.ok and np.isfinite(evaluation.data["rel_err"])
            and not numerically_singular(evaluation.data["cond"]))


def not_positive_definite(evaluation: Case) -> bool:
    """Whether the 50-digit ``M`` of an evaluated point is not positive definite."""
    return evaluation.data.get("positive_definite") == 0.0


def short_simulation(ctx: Context, v: Variation) -> Case:
    """Radau+jac (must succeed) and DOP853 (agree or budget) over ten fast time scales."""
    start = time.perf_counter()
    model, sz = ctx.model, ctx.size
    p = ctx.p_of(v.values)
    tau = time_scale(model, ctx.t0, v.x, p)
    T = ctx.span[1] - ctx.span[0]
    horizon = min(T, 10.0 * tau) if np.isfinite(tau) and tau > 0 else T
    span = (ctx.t0, ctx.t0 + horizon)
    atol = 1e-12 * max(1.0, float(np.abs(v.x).max()))
    f, jac = model.bind(p), model.bind(p, output=Output.JACOBIAN)
    rad = scipy_run("Radau", f, jac, span, v.x, rtol=SIM_RTOL, atol=atol,
                    max_steps=10 * sz.step_budget, max_evals=sz.eval_budget)
    dop = scipy_run("DOP853", f, None, span, v.x, rtol=SIM_RTOL, atol=atol,
                    max_steps=sz.step_budget, max_evals=sz.eval_budget, record=False)
    data = {"horizon": horizon, "radau_steps": rad.steps, "dop853_steps": dop.steps}
    fig = f"horizon {fmt_g(horizon)} s: Radau {rad.steps} steps, DOP853 {dop.steps} steps"
    conservative = ctx.scene.conserves_energy and Output.ENERGY in model.outputs
    bound = f"Radau ok; DOP853 agrees to {SIM_AGREE:g} or budget" + \
        (f"; drift <= {DRIFT_BOUND:g}" if conservative else "")
    name = f"{v.name} sim"
    if rad.status == "failed" and "SingularConstraintError" in rad.message:
        # the motion reached a configuration where the constraints do not determine the
        # dependent speeds (a four-bar's dead point): the coordinates end there, and the
        # model says so by name
        return Case("extreme", name, fig + f", stopped at t = {fmt_g(rad.t_reached)}",
                    bound + "; or a named singular configuration", True,
                    "reached a singular configuration: SingularConstraintError", data,
                    time.perf_counter() - start)
    if rad.status == "budget":
        return Case("extreme", name, fig, bound, False,
                    f"Radau stopped at its budget ({rad.message}) at t = {fmt_g(rad.t_reached)}",
                    data, time.perf_counter() - start, stopped=f"Radau: {rad.message}",
                    cause=BUDGET)
    if rad.status != "done":
        return Case("extreme", name, fig, bound, False, f"Radau {rad.status}: {rad.message}",
                    data, time.perf_counter() - start)
    if not np.all(np.isfinite(rad.x)):
        return Case("extreme", name, fig, bound, False, "non-finite states", data,
                    time.perf_counter() - start)
    reasons, ok, stopped = [], True, ""
    scale = max(1.0, float(np.abs(rad.x).max()))
    if dop.status == "done":
        d = float(np.abs(dop.final - rad.final).max()) / scale
        data["diff"] = d
        fig += f", diff {fmt_g(d)}"
        if d > SIM_AGREE:
            ok = False
            reasons.append(f"DOP853 differs by {fmt_g(d)}")
    elif dop.status == "budget":
        reasons.append(f"DOP853 budget ({dop.message})")
        stopped = f"DOP853: {dop.message}"
    else:
        ok = False
        reasons.append(f"DOP853 failed: {dop.message}")
    if conservative:
        E, escale = energy_series(model, rad.t, rad.x, p)
        drift = float(np.abs(E - E[0]).max() / escale) if escale > 0 else 0.0
        data["drift"] = drift
        fig += f", drift {fmt_g(drift)}"
        if drift > DRIFT_BOUND:
            ok = False
            reasons.append(f"energy drift {fmt_g(drift)}")
    return Case("extreme", name, fig, bound, ok, "; ".join(reasons) or "within bound", data,
                time.perf_counter() - start, stopped=stopped)


def extreme_case(ctx: Context, v: Variation) -> Case:
    """Evaluate at an extreme point (vs 50 digits); what follows is decided from this case
    (:func:`admits_simulation`, :func:`not_positive_definite`)."""
    return check_point(ctx.model, ctx.hp, ctx.t0, v.x, ctx.p_of(v.values), v.values,
                       kind="extreme", name=v.name)


def c_not_positive_definite(ctx: Context, v: Variation, kind: str = "extreme") -> Case:
    """A C integrator started where M is not positive definite must stop with that status."""
    start = time.perf_counter()
    r = c_run(ctx.model, "dopri5", [ctx.t0, ctx.t0 + 1e-3], v.x, ctx.p_of(v.values),
              rtol=1e-6, atol=1e-9, max_steps=1000)
    ok = r.status == "failed" and r.message.startswith(f"status {STATUS_NOT_POSITIVE_DEFINITE} ")
    return Case(kind, f"{v.name} C dopri5",
                r.message or r.status, "stops with status NOT_POSITIVE_DEFINITE", ok,
                "not positive definite: C status" if ok else f"got {r.status}: {r.message}",
                {}, time.perf_counter() - start)


def extreme_variations(ctx: Context) -> list[Variation]:
    """Scaled masses, lengths, gravity and speeds (rules in :mod:`mbgen.verify.stress`)."""
    sz, values = ctx.size, ctx.values
    names = [n for n in ctx.model.parameter_names if n in values]
    groups = classify_parameters(names)
    out = []
    masses = groups["mass"]
    chosen = masses[-1:] + (masses[:1] if sz.first_and_last and len(masses) > 1 else [])
    for n in chosen:
        for r in sz.ratios + NON_PHYSICAL:
            out.append(Variation(f"{n} x{fmt_sci(r)}", {**values, n: values[n] * r}, ctx.x0))
    for n in groups["length"][-1:]:
        for r in sz.ratios:
            out.append(Variation(f"{n} x{fmt_sci(r)}", {**values, n: values[n] * r}, ctx.x0))
    for n in groups["gravity"]:
        for r in sz.gravity:
            out.append(Variation(f"{n} x{fmt_sci(r)}", {**values, n: values[n] * r}, ctx.x0))
    L = ctx.model.layout
    u0 = ctx.x0[L.n_q:]
    direction = u0 / np.abs(u0).max() if np.abs(u0).max() > 0 else np.ones(L.n_u)
    for speed in sz.speeds:
        x = ctx.x0.copy()
        x[L.n_q:] = speed * direction
        out.append(Variation(f"speeds {fmt_sci(speed)}", dict(values), x))
    return out
