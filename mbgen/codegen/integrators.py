"""C-template views of the integrators: what ``templates/integrators/``, ``templates/step/`` print.

The methods themselves (tableaux, orders, ``adaptive``, ``implicit``, ``needs``) are data in
:mod:`mbgen.integrators`; this module turns one method into the strings and flags its template
prints (coefficients with full precision, stage sums, prototypes) for one kernel.  Which
view and which template a method gets is read from its properties and its output's name,
never from a test of the name:

* an explicit Runge--Kutta method: :func:`explicit_view` (with the error estimate and
  the dense output when ``adaptive``);
* a linearly implicit (Rosenbrock) method: :func:`rosenbrock_view`;
* its template: ``templates/integrators/<output>.c.j2`` (whole trajectory) and
  ``templates/step/<output>.c.j2``, ``.h.j2`` (the step API).
"""

from __future__ import annotations

import math

import numpy as np

from ..abi import Output
from ..errors import ModelError
from ..integrators import DEFAULT_MAX_STEPS, METHODS, Method
from ..names import model_prefix
from ..symbolic.availability import time_symbols

#: What a missing output is called in the message of an integrator that needs it.
NEEDED = {Output.JACOBIAN: "the Jacobian",
          Output.TIME_DERIVATIVE: "df/dt (the equations depend on t explicitly)"}


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


def _control(T) -> dict:
    """The step-size controller's constants of an adaptive method."""
    return dict(inv_order=c_double(1.0 / (T.error_estimator_order + 1)),
                exponent=c_double(-1.0 / (T.error_estimator_order + 1)),
                safety=c_double(T.SAFETY), min_factor=c_double(T.MIN_FACTOR),
                max_factor=c_double(T.MAX_FACTOR))


def explicit_view(T) -> dict:
    """An explicit Runge--Kutta method: stages ``K_s``, the weights ``b``; when ``T.adaptive``
    also the error weights ``E`` (FSAL: ``n_stages + 1`` entries), the dense output ``P`` and
    the controller's constants."""
    view = dict(stages=[dict(index=s, c=c_double(T.C[s]), sum=_terms(T.A[s, :s], "K[{}][i]"))
                        for s in range(1, T.n_stages)],
                b=_terms(T.B, "K[{}][i]"), n_stages=T.n_stages)
    if T.adaptive:
        # dense output: y + h * sum_j K_j * (P_j0 s + P_j1 s^2 + P_j2 s^3 + P_j3 s^4)
        view.update(e=_terms(T.E, "K[{}][i]"),
                    p=[(j, [c_double(v) for v in T.P[j]]) for j in range(T.n_stages + 1)
                       if np.any(T.P[j])], **_control(T))
    return view


def rosenbrock_view(T) -> dict:
    """A Rosenbrock method in the KPP form (:class:`mbgen.integrators.Rosenbrock`)."""
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
        **_control(T),
    )


def method_view(output: Output) -> dict:
    """What the templates of one integrator read: its name, properties and coefficients."""
    T = METHODS[output]
    return dict(name=output.value, label=T.label, adaptive=T.adaptive, implicit=T.implicit,
                view=rosenbrock_view(T) if T.implicit else explicit_view(T))


def explicit_time(kernel) -> bool:
    """Whether the right-hand side depends explicitly on ``t`` (so df/dt is needed)."""
    eq = kernel.equations
    return eq.layout.time in time_symbols(eq)


def require(kernel, outputs, what: str, time_message: str) -> bool:
    """Check that ``kernel`` has what the integrators ``outputs`` call; whether df/dt is among it.

    An implicit method also needs ``df/dt`` when the equations depend on ``t``
    explicitly (``time_message`` is then what it is called).  ``what`` names the
    caller in the message (``"integrator"``, ``"step"``).  Raises
    :class:`~mbgen.errors.ModelError` naming the output to add.
    """
    name = kernel.equations.name
    functions = {f.output for f in kernel.functions}
    implicit = [METHODS[o] for o in outputs if METHODS[o].implicit]
    non_autonomous = bool(implicit) and explicit_time(kernel)
    if non_autonomous and Output.TIME_DERIVATIVE not in functions:
        raise ModelError(f"the {implicit[0].label} {what} of {name!r} needs {time_message}; "
                         f"add Output.TIME_DERIVATIVE")
    for o in outputs:
        for need in METHODS[o].needs:   # the RHS every method calls comes with any integrator
            if need not in functions and need not in Method.needs:
                raise ModelError(f"the {METHODS[o].label} {what} of {name!r} needs "
                                 f"{NEEDED[need]}; add Output.{need.name}")
    return non_autonomous


def integrator_context(kernel) -> dict:
    """Template context for ``integrators/integrators.h.j2`` / ``.c.j2`` (key ``integ``)."""
    L = kernel.layout
    prefix = model_prefix(kernel.equations.name)
    wanted = [o for o in METHODS if o in kernel.integrators]
    extra_params = "".join(f", const double *{a}" for a in ("p", "r")
                           if (a == "p" and L.n_p) or (a == "r" and L.n_r))
    extra_args = "".join(f", {a}" for a in ("p", "r")
                         if (a == "p" and L.n_p) or (a == "r" and L.n_r))
    tail = (f"int n_out, const double *t_out, double *x_out, const {prefix}_options *opt, "
            f"{prefix}_stats *stats")
    non_autonomous = require(kernel, wanted, "integrator", NEEDED[Output.TIME_DERIVATIVE])
    methods = []
    for o in wanted:
        m = method_view(o)
        m.update(template=f"integrators/{o.value}.c.j2",
                 proto=f"int {prefix}_{o.value}(const double *x0{extra_params}, {tail}"
                       + (f", {prefix}_{o.value}_work *work)" if m["implicit"] else ")"))
        methods.append(m)
    return dict(integ=dict(
        methods=methods,
        names=[m["name"] for m in methods],
        implicit=[m["name"] for m in methods if m["implicit"]],
        adaptive=any(m["adaptive"] for m in methods),
        non_autonomous=non_autonomous,
        args=extra_args,
        params=extra_params,
        # inputs r(t) from a table in the options (mbgen.runtime.named.InputTable)
        table=bool(L.n_r),
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


__all__ = ["c_double", "integrator_context", "explicit_view", "rosenbrock_view", "method_view",
           "explicit_time", "require", "projection", "NEEDED"]
