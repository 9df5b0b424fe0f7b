"""Stiff cases: scenes whose ``scene()`` has a ``stiffness`` option, run at the stiffnesses
of the size with scipy RK45, Radau and BDF (the implicit two with the compiled
Jacobian) and C dopri5 and C rosenbrock.

Bounds
------
Radau and BDF with the compiled Jacobian (and C rosenbrock) must succeed,
and every method that finished must agree with Radau on the final state within
``1e3 rtol`` (relative to ``max(1, |x|)``); explicit methods must finish or stop at
the step or evaluation budget (reason ``budget``); an implicit method stopped at its
budget, or a comparison left without the Radau run it needs, is a harness budget
failure (cause ``budget``), never a model failure; the explicit/implicit step ratio at the
largest stiffness must be at least 10 and not below the ratio at the smallest.
The compiled right-hand side is also checked against the 50-digit reference at
the start of each stiff run (:func:`stiff_fp_case`).
"""

from __future__ import annotations

import time

import numpy as np

from ...abi import INTEGRATORS, Output
from ...errors import SceneError
from ...integrators import METHODS
from ...model.scene import Scene, load_scene
from .context import Context
from .precision import check_point
from .report import BUDGET, MODEL, Case, fmt_g, fmt_sci
from .runs import Run, c_run, run_figure, scipy_run

#: Tolerances of the stiff runs.
STIFF_RTOL, STIFF_ATOL = 1e-6, 1e-9
#: Least explicit/implicit step ratio at the largest stiffness.
RATIO_BOUND = 10.0
#: scipy's methods of the stiff runs.
SCIPY_METHODS = ("Radau", "BDF", "RK45")
#: The generated C integrators of the stiff runs: the adaptive ones, the implicit first.
C_METHODS = tuple(o.value for o in sorted((o for o in INTEGRATORS if METHODS[o].adaptive),
                                          key=lambda o: not METHODS[o].implicit))
_C_IMPLICIT = [f"C {o.value}" for o in INTEGRATORS if METHODS[o].adaptive and METHODS[o].implicit]
#: Every run of one stiffness, by the label its cases carry.
STIFF_METHODS = SCIPY_METHODS + tuple(f"C {m}" for m in C_METHODS)
#: The runs that use the compiled Jacobian.
WITH_JACOBIAN = ("Radau", "BDF", *_C_IMPLICIT)
#: Explicit method -> the implicit one its steps are compared with.
IMPLICIT = {"RK45": "Radau", **{f"C {o.value}": _C_IMPLICIT[0] for o in INTEGRATORS
                                if METHODS[o].adaptive and not METHODS[o].implicit}}


def _rel_diff(a, b) -> float:
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / max(1.0, np.abs(b).max()))


def _stiff_scene(ctx: Context, k: float) -> Scene:
    options = {key: v for key, v in dict(ctx.scene.options).items() if key != "stiffness"}
    return load_scene(ctx.source, **options, stiffness=k)


def _stiff_runs(ctx: Context, k: float) -> dict[str, Run]:
    """Every integrator at stiffness ``k`` (cached: the rows of one k share them)."""
    key = ("stiff", k)
    if key in ctx.cache:
        return ctx.cache[key]
    scn = _stiff_scene(ctx, k)
    model = ctx.model
    if tuple(scn.x0(model.layout).shape) != tuple(ctx.x0.shape):
        raise SceneError("the scene's states change with the stiffness option")
    values = {**ctx.values, **{n: float(v) for n, v in scn.parameters.items()}}
    p, x0 = ctx.p_of(values), scn.x0(model.layout)
    t0, t1 = float(scn.t_span[0]), float(scn.t_span[1])
    span = (t0, t0 + ctx.size.stiff_horizon * (t1 - t0))
    f, jac = model.bind(p), model.bind(p, output=Output.JACOBIAN)
    sz = ctx.size
    runs = {}
    for method in SCIPY_METHODS:
        implicit = method in WITH_JACOBIAN
        runs[method] = scipy_run(method, f, jac, span, x0, rtol=STIFF_RTOL, atol=STIFF_ATOL,
                                 max_steps=10 * sz.step_budget if implicit else sz.step_budget,
                                 max_evals=sz.eval_budget, record=False)
    for method in C_METHODS:
        runs[f"C {method}"] = c_run(model, method, list(span), x0, p, rtol=STIFF_RTOL,
                                    atol=STIFF_ATOL, max_steps=10 * sz.step_budget)
    ctx.cache[key] = runs
    return runs


def stiff_case(ctx: Context, k: float, method: str) -> Case:
    """One integrator at stiffness ``k``: cost, and agreement with Radau."""
    runs = _stiff_runs(ctx, k)
    r, ref = runs[method], runs["Radau"]
    name = f"k={fmt_sci(k)} {method}" + (" +jac" if method in WITH_JACOBIAN else "")
    implicit = method not in IMPLICIT
    tol = 1e3 * STIFF_RTOL
    data = {"steps": r.steps, "nfev": r.nfev, "njev": r.njev, "nlu": r.nlu,
            "t_reached": r.t_reached}
    fig = run_figure(r)
    if not implicit:
        base = runs[IMPLICIT[method]]
        ratio = r.steps / max(base.steps, 1)
        data["ratio"] = ratio
        fig += (f"; steps {'>=' if r.status == 'budget' else ''}{ratio:.3g}x those of "
                f"{IMPLICIT[method]}")
    if implicit:
        bound = f"succeeds; |x_T - x_T(Radau)| <= {tol:g} max(1,|x|)"
    else:
        bound = f"succeeds (agrees to {tol:g}) or stops at budget"
    stopped, cause = (f"{method}: {r.message}" if r.status == "budget" else ""), MODEL
    if r.status == "failed":
        ok, reason = False, f"failed: {r.message}"
    elif r.status == "budget":
        ok, cause = not implicit, BUDGET
        reason = (f"budget: {r.message} reached at t={r.t_reached:.3g} of "
                  f"{ref.t_reached if ref.status == 'done' else float('nan'):.3g}")
    elif ref.status == "budget":
        ok, cause = False, BUDGET
        stopped = f"Radau: {ref.message}"
        reason = f"budget: no Radau reference (Radau stopped at its {ref.message} budget)"
    elif ref.status != "done":
        ok, reason = False, "no Radau reference"
    else:
        d = _rel_diff(r.final, ref.final)
        data["diff"] = d
        ok = d <= tol
        reason = f"agrees with Radau to {fmt_g(d)}" if ok else f"differs from Radau by {fmt_g(d)}"
        if method == "Radau":
            reason = "succeeded"
    # the runs of one stiffness are shared (cached): a row's time is its own run's
    return Case("stiff", name, fig, bound, ok, reason, data, r.seconds, stopped=stopped,
                cause=cause)


def stiff_fp_case(ctx: Context, k: float) -> Case:
    """The compiled RHS vs 50 digits at the start of the stiff run at stiffness ``k``."""
    scn = _stiff_scene(ctx, k)
    values = {**ctx.values, **{n: float(v) for n, v in scn.parameters.items()}}
    return check_point(ctx.model, ctx.hp, float(scn.t_span[0]), scn.x0(ctx.model.layout),
                       ctx.p_of(values), values, name=f"k={fmt_sci(k)} start")


def stiff_scaling_case(ctx: Context, method: str) -> Case:
    """Explicit/implicit step ratio across the stiffnesses: it must grow to >= 10."""
    start = time.perf_counter()
    ks = ctx.size.stiffness
    ratios = []
    for k in ks:
        runs = _stiff_runs(ctx, k)
        ratios.append(runs[method].steps / max(runs[IMPLICIT[method]].steps, 1))
    fig = "step ratio " + ", ".join(f"{r:.3g}x at k={fmt_sci(k)}" for r, k in zip(ratios, ks))
    bound = f">= {RATIO_BOUND:g}x at k={fmt_sci(ks[-1])}, not below k={fmt_sci(ks[0])}"
    ok = ratios[-1] >= RATIO_BOUND and ratios[-1] >= ratios[0]
    reason = "explicit cost grows with stiffness" if ok else \
        f"ratio {ratios[-1]:.3g} at the largest stiffness"
    return Case("stiff", f"{method}/{IMPLICIT[method]} steps", fig, bound, ok, reason,
                {"ratio_min_k": ratios[0], "ratio_max_k": ratios[-1]},
                time.perf_counter() - start)
