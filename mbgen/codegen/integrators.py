"""C-template views of the integrators: the context ``templates/integrators/integrators.c.j2`` renders.

The methods themselves (tableaux, orders, the Rosenbrock reference step) are data in
:mod:`mbgen.codegen.integrators.tableaux`; this module turns them into the strings and flags the
template prints (coefficients with full precision, stage sums, prototypes) for one
kernel.
"""

from __future__ import annotations

import math

import numpy as np

from ..abi import Output
from ..errors import ModelError
from ..integrators import DEFAULT_MAX_STEPS, ROSENBROCK, RK4, Dopri5
from ..names import model_prefix
from ..symbolic.availability import time_symbols


def c_double(value) -> str:
    """A C double literal that round-trips exactly."""
    text = repr(float(value))
    if not math.isfinite(float(value)):  # pragma: no cover - tableaux are finite
        raise ValueError(f"coefficient {value!r} is not finite")
    return text


def _terms(coeffs, vector: str, skip_zero: bool = True) -> str:
    """``c0 * K[0][i] + c1 * K[1][i] ...`` (``vector`` formats the index)."""
    out = []
    for j, c in enumerate(coeffs):
        c = float(c)
        if skip_zero and c == 0.0:
            continue
        term = vector.format(j) if abs(c) == 1.0 else f"{c_double(abs(c))} * {vector.format(j)}"
        if out:
            out.append(f"{'-' if c < 0 else '+'} {term}")
        else:
            out.append(f"-{term}" if c < 0 else term)
    return " ".join(out) if out else "0.0"


def dopri5_view() -> dict:
    T = Dopri5
    stages = []
    for s in range(1, T.n_stages):
        stages.append(dict(index=s, c=c_double(T.C[s]),
                           sum=_terms(T.A[s, :s], "K[{}][i]")))
    return dict(
        n_stages=T.n_stages,
        stages=stages,
        b=_terms(T.B, "K[{}][i]"),
        e=_terms(T.E, "K[{}][i]"),
        # dense output: y + h * sum_j K_j * (P_j0 s + P_j1 s^2 + P_j2 s^3 + P_j3 s^4)
        p=[(j, [c_double(v) for v in T.P[j]]) for j in range(T.n_stages + 1) if np.any(T.P[j])],
        order=T.error_estimator_order,
        inv_order=c_double(1.0 / (T.error_estimator_order + 1)),
        exponent=c_double(-1.0 / (T.error_estimator_order + 1)),
        safety=c_double(T.SAFETY), min_factor=c_double(T.MIN_FACTOR), max_factor=c_double(T.MAX_FACTOR),
    )


def rk4_view() -> dict:
    T = RK4
    return dict(stages=[dict(index=s, c=c_double(T.C[s]), sum=_terms(T.A[s, :s], "K[{}][i]"))
                        for s in range(1, T.n_stages)],
                b=_terms(T.B, "K[{}][i]"), n_stages=T.n_stages)


def rosenbrock_view(T) -> dict:
    stages = []
    for s, new in enumerate(T.new_f()):
        stages.append(dict(
            index=s,
            new_f=new and s > 0,
            alpha=c_double(T.alpha[s]),
            arg=_terms(T.A[s, :s], "K[{}][i]"),
            has_arg=bool(np.any(T.A[s, :s])),
            coupling=_terms(T.C[s, :s], "K[{}][i]"),
            has_coupling=bool(np.any(T.C[s, :s])),
            gamma_t=c_double(T.gamma_t[s]),
            has_gamma_t=T.gamma_t[s] != 0.0,
        ))
    return dict(
        name=T.name,
        reference=T.reference,
        n_stages=T.n_stages(),
        gamma=c_double(T.gamma),
        stages=stages,
        m=_terms(T.M, "K[{}][i]"),
        e=_terms(T.E, "K[{}][i]"),
        order=T.order,
        embedded_order=T.error_estimator_order,
        inv_order=c_double(1.0 / (T.error_estimator_order + 1)),
        exponent=c_double(-1.0 / (T.error_estimator_order + 1)),
        safety=c_double(T.SAFETY), min_factor=c_double(T.MIN_FACTOR), max_factor=c_double(T.MAX_FACTOR),
    )


def explicit_time(kernel) -> bool:
    """Whether the right-hand side depends explicitly on ``t`` (so df/dt is needed)."""
    eq = kernel.equations
    return eq.layout.time in time_symbols(eq)


def integrator_context(kernel) -> dict:
    """Template context for ``integrators/integrators.h.j2`` / ``integrators/integrators.c.j2`` (key ``integ``)."""
    L = kernel.layout
    prefix = model_prefix(kernel.equations.name)
    wanted = {o.value for o in kernel.integrators}
    extra_params = "".join(f", const double *{a}" for a in ("p", "r")
                           if (a == "p" and L.n_p) or (a == "r" and L.n_r))
    extra_args = "".join(f", {a}" for a in ("p", "r")
                         if (a == "p" and L.n_p) or (a == "r" and L.n_r))
    tail = (f"int n_out, const double *t_out, double *x_out, const {prefix}_options *opt, "
            f"{prefix}_stats *stats")
    prototypes = [(o.value, f"int {prefix}_{o.value}(const double *x0{extra_params}, {tail}"
                            + (f", {prefix}_rosenbrock_work *work)" if o is Output.ROSENBROCK
                               else ")"))
                  for o in (Output.DOPRI5, Output.RK4, Output.ROSENBROCK) if o.value in wanted]
    non_autonomous = Output.ROSENBROCK.value in wanted and explicit_time(kernel)
    if non_autonomous and not any(f.output is Output.TIME_DERIVATIVE for f in kernel.functions):
        raise ModelError(f"the Rosenbrock integrator of {kernel.equations.name!r} needs df/dt "
                         f"(the equations depend on t explicitly); add Output.TIME_DERIVATIVE")
    if Output.ROSENBROCK.value in wanted and not any(f.output is Output.JACOBIAN
                                                     for f in kernel.functions):
        raise ModelError(f"the Rosenbrock integrator of {kernel.equations.name!r} needs the "
                         f"Jacobian; add Output.JACOBIAN")
    return dict(integ=dict(
        prototypes=prototypes,
        proto=dict(prototypes),
        wanted=sorted(wanted),
        dopri5=dopri5_view() if "dopri5" in wanted else None,
        rk4=rk4_view() if "rk4" in wanted else None,
        rosenbrock=rosenbrock_view(ROSENBROCK) if "rosenbrock" in wanted else None,
        adaptive="dopri5" in wanted or "rosenbrock" in wanted,
        non_autonomous=non_autonomous,
        args=extra_args,
        params=extra_params,
        table=bool(L.n_r),   # inputs r(t) from a table in the options (mbgen.run.named.InputTable)
        n_r=L.n_r,
        p_arg=", p" if L.n_p else "",
        n=max(L.n_x, 1),
        max_steps=DEFAULT_MAX_STEPS,
        project=projection(kernel),
    ))


def projection(kernel):
    """What the integrators need to project onto holonomic constraints (None: nothing)."""
    c = kernel.equations.constraints
    if c is None or not c.m_h:
        return None
    L = kernel.layout
    dep = [L.coordinates.index(q) for q in c.dependent_coordinates]
    return dict(m=c.m_h, n_q=L.n_q, dep=dep, names=[str(q) for q in c.dependent_coordinates])


__all__ = ["c_double", "integrator_context", "dopri5_view", "rk4_view", "rosenbrock_view", "explicit_time",
           "projection"]
