"""Singular cases: the known singular configurations of the built-in scenes
(:data:`SINGULAR_PATHS`) approached with offsets ``delta -> 0`` and hit
(:func:`singular_case`; where ``M`` is not positive definite, a C integrator started
there follows as its own case), and a scan of every coordinate over ``x0 +- pi`` for the
largest ``cond(M)`` (:func:`scan_case`, followed by the check of its worst point,
:func:`scan_worst_case`).  Every point is judged by the floating-point bound
(:mod:`mbgen.verify.stress.precision`).
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import numpy as np

from ...model.scene import scene_module
from .context import Context
from .extreme import Variation, c_not_positive_definite
from .precision import check_point, try_call
from .report import Case, fmt_g, fmt_sci


@dataclass(frozen=True)
class SingularPath:
    """A known singular configuration and how to approach it.

    ``state(x, values, delta)`` returns the state overrides (name -> value) at
    distance ``delta`` from the singular configuration (``delta = 0``: on it);
    ``x`` and ``values`` are the nominal state and parameters by name.
    """

    name: str
    state: Callable[[Mapping[str, float], Mapping[str, float], float], dict]
    note: str = ""
    applies: Callable[[Mapping[str, float]], bool] | None = None   # by parameter values


def _four_bar_lengths(values):
    return {k: values[k] for k in ("la", "lb", "lc", "ld")}


def _four_bar_dead(x, values, d):
    four_bar = scene_module("four_bar")
    lengths = _four_bar_lengths(values)
    q1 = four_bar.dead_angle(**lengths) - d
    q2, q3 = four_bar.closed_loop(q1, lengths)
    return {"q1": q1, "q2": q2, "q3": q3}


def _four_bar_has_dead_point(values) -> bool:
    return scene_module("four_bar").dead_angle(**_four_bar_lengths(values)) is not None


def _chain_aligned(x, values, d):
    links = sorted(int(n[1:]) for n in x if re.fullmatch(r"q\d+", n) and n != "q0")
    return {f"q{i}": 0.3 + d * j for j, i in enumerate(links)}


#: Known singular configurations of the built-in scenes (scene name -> paths).
SINGULAR_PATHS: dict[str, tuple[SingularPath, ...]] = {
    "torque_free": (SingularPath("gimbal lock q2->pi/2",
                                 lambda x, v, d: {"q2": math.pi / 2 - d},
                                 "q' = G(q) u has 1/cos(q2); M is the constant inertia"),),
    "spherical_rod": (SingularPath("pole q2->0", lambda x, v, d: {"q2": d},
                                   "M = diag(J sin(q2)^2, J)"),),
    "paraboloid": (SingularPath("axis q1->0", lambda x, v, d: {"q1": d},
                                "M = diag(m (1 + 4 k^2 q1^2), m q1^2)"),),
    "disc_pendulum": (SingularPath("bob on axis s+l sin(q2)->0",
                                   lambda x, v, d: {"q2": -math.asin(v["s"] / v["l"]) + d},
                                   "M11 = m (s + l sin q2)^2"),),
    "spring_pendulum": (SingularPath("collapsed spring s->-l", lambda x, v, d: {"s": -v["l"] + d},
                                     "M = diag(m (l + s)^2, m); spring direction undefined"),),
    "stiff_chain": (SingularPath("masses meet x2->x1", lambda x, v, d: {"x2": x["x1"] + d},
                                 "line element direction (x2 - x1)/|x2 - x1| undefined"),),
    "four_bar": (SingularPath("dead point q1->q1*", _four_bar_dead,
                              "coupler and rocker in line: det A_r = lb lc sin(q1 + q2 - q3)",
                              _four_bar_has_dead_point),),
    "n_link_cart": (SingularPath("links aligned q_i->q_1", _chain_aligned,
                                 "absolute angles: M stays positive definite"),),
}


def singular_point(ctx: Context, path: SingularPath, delta: float) -> Variation:
    """The state at ``delta`` from a singular configuration, the nominal parameters."""
    x_named = dict(zip(ctx.model.state_names, ctx.x0.tolist()))
    x_named.update(path.state(x_named, ctx.values, delta))
    x = np.array([x_named[n] for n in ctx.model.state_names])
    return Variation(f"{path.name} d={fmt_sci(delta)}", dict(ctx.values), x)


def singular_case(ctx: Context, path: SingularPath, delta: float) -> Case:
    """Evaluate at ``delta`` from a singular configuration (vs 50 digits)."""
    v = singular_point(ctx, path, delta)
    case = check_point(ctx.model, ctx.hp, ctx.t0, v.x, ctx.p0, ctx.values, kind="singular",
                       name=v.name)
    if np.isfinite(case.data["fnorm"]):  # how large q', u' grow near the singularity
        case = replace(case, figure=f"|f| {fmt_g(case.data['fnorm'])}; " + case.figure)
    return case


def singular_c_case(ctx: Context, path: SingularPath, delta: float) -> Case:
    """A C integrator started at ``delta`` from a singular configuration where ``M`` is not
    positive definite must stop with that status."""
    return c_not_positive_definite(ctx, singular_point(ctx, path, delta), kind="singular")


def scan_case(ctx: Context, index: int) -> Case:
    """Scan one coordinate over ``x0 +- pi``: every point finite or a named error; worst
    cond(M), whose coordinate value is ``data["worst_at"]`` (absent when no ``M`` was
    found)."""
    start = time.perf_counter()
    model, p = ctx.model, ctx.p0
    name = model.state_names[index]
    grid = ctx.x0[index] + np.linspace(-math.pi, math.pi, ctx.size.scan_points)
    worst, worst_x, errors, unexpected = 0.0, None, {}, []
    for value in grid:
        x = ctx.x0.copy()
        x[index] = value
        M, err = try_call(model.mass_matrix, ctx.t0, x, p)
        f, err_f = try_call(model.rhs, ctx.t0, x, p)
        for e in (err, err_f):
            if e.startswith("unexpected"):
                unexpected.append(f"{name}={value:.3g}: {e}")
            elif e:
                errors[e] = errors.get(e, 0) + 1
        if M is not None:
            c = float(np.linalg.cond(M)) if np.all(np.isfinite(M)) else math.inf
            if not c < worst:
                worst, worst_x = c, x
    fig = f"max cond(M) {fmt_g(worst)}" + (f" at {name}={worst_x[index]:.3g}"
                                            if worst_x is not None else "")
    if errors:
        fig += "; errors: " + ", ".join(f"{k} at {n} points" for k, n in errors.items())
    bound = "finite or a named mbgen error"
    data = {"max_cond": worst}
    if worst_x is not None:
        data["worst_at"] = float(worst_x[index])
    return Case("singular", f"scan {name} ({len(grid)} pts)", fig, bound, not unexpected,
                unexpected[0] if unexpected else "no NaN, no unnamed error", data,
                time.perf_counter() - start)


def scan_worst_case(ctx: Context, index: int, worst_at: float) -> Case:
    """The worst point of a scan (coordinate ``index`` at ``worst_at``) vs 50 digits."""
    x = ctx.x0.copy()
    x[index] = worst_at
    return check_point(ctx.model, ctx.hp, ctx.t0, x, ctx.p0, ctx.values, kind="singular",
                       name=f"scan {ctx.model.state_names[index]} worst point")
