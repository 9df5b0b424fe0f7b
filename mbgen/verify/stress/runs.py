"""Integrations with a budget: a :class:`Run` records how one ended (done, at its step or
evaluation budget, or failed) and what it cost; :func:`scipy_run` steps a scipy solver,
:func:`c_run` calls a generated C integrator.  Also the energy along a run, which the
drift bounds read.

Budgets count steps and evaluations, never seconds: a run stops at the same place on
any machine, so a case's verdict does not depend on how loaded the machine is.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ...abi import CONSTRAINT_STATUS_CODES, INTEGRATOR_STATUS_CODES, STATUS_CODES
from ...errors import IntegrationError, MbgenError

#: C status codes of the generated code (see :mod:`mbgen.codegen.render`).
STATUS_NOT_POSITIVE_DEFINITE = 1
STATUS_MAX_STEPS = 4


@dataclass(frozen=True)
class Run:
    """One integration: how it ended and what it cost.

    ``status`` is ``"done"``, ``"budget"`` (step or evaluation budget reached) or
    ``"failed"``; ``t``/``x`` are the accepted steps (or output times).
    """

    method: str
    status: str
    message: str
    t: np.ndarray
    x: np.ndarray
    steps: int
    nfev: int
    njev: int
    nlu: int
    seconds: float

    @property
    def final(self) -> np.ndarray:
        return self.x[-1]

    @property
    def t_reached(self) -> float:
        return float(self.t[-1])


def scipy_run(method: str, fun, jac, span, x0, *, rtol: float, atol: float,
              max_steps: int, max_evals: int, record: bool = True) -> Run:
    """Step a scipy solver (``RK45``, ``DOP853``, ``Radau``, ``BDF``) with a step and an
    evaluation budget.

    The run stops with status ``"budget"`` before a step once it has taken ``max_steps``
    accepted steps or made ``max_evals`` calls of ``fun`` and ``jac`` together.  Errors of
    the right-hand side (an mbgen error, e.g. a singular mass matrix reached) end the run
    with status ``"failed"`` and the error named.
    """
    from scipy import integrate as si

    cls = {"RK45": si.RK45, "DOP853": si.DOP853, "Radau": si.Radau, "BDF": si.BDF}[method]
    kw = {"jac": jac} if method in ("Radau", "BDF") and jac is not None else {}
    start = time.perf_counter()
    ts, xs = [float(span[0])], [np.array(x0, dtype=float)]
    status, message, steps = "done", "", 0
    try:
        solver = cls(fun, float(span[0]), np.array(x0, dtype=float), float(span[1]),
                     rtol=rtol, atol=atol, **kw)
        while solver.status == "running":
            evals = solver.nfev + getattr(solver, "njev", 0)
            if steps >= max_steps or evals >= max_evals:
                status = "budget"
                message = f"{max_steps} steps" if steps >= max_steps else \
                    f"{max_evals} evaluations"
                if not record:
                    ts.append(solver.t)
                    xs.append(solver.y.copy())
                break
            msg = solver.step()
            steps += 1
            if solver.status == "failed":
                status, message = "failed", str(msg)
                break
            if record or solver.status != "running":
                ts.append(solver.t)
                xs.append(solver.y.copy())
        nfev, njev, nlu = solver.nfev, getattr(solver, "njev", 0), getattr(solver, "nlu", 0)
    except MbgenError as exc:
        status, message = "failed", f"{type(exc).__name__}: {str(exc).split(';')[0]}"
        nfev = njev = nlu = 0
    return Run(method, status, message, np.array(ts), np.array(xs), steps, int(nfev), int(njev),
               int(nlu), time.perf_counter() - start)


def c_run(model, method: str, t_out, x0, p, *, rtol: float, atol: float, max_steps: int) -> Run:
    """Run a C integrator (``model.integrate``); the step limit is a budget, not a crash."""
    start = time.perf_counter()
    t_out = np.asarray(t_out, dtype=float)
    try:
        res = model.integrate(method, t_out, x0, p, rtol=rtol, atol=atol, max_steps=max_steps)
    except IntegrationError as exc:
        status = "budget" if exc.status == STATUS_MAX_STEPS else "failed"
        t_end = exc.t if exc.t is not None else float(t_out[0])
        msg = f"{max_steps} steps" if status == "budget" else \
            f"status {exc.status} {status_name(model, exc.status)} at t={t_end:.3g}"
        return Run(f"C {method}", status, msg, np.array([t_out[0], t_end]),
                   np.array([x0, np.full(len(x0), np.nan)]), max_steps if status == "budget"
                   else 0, 0, 0, 0, time.perf_counter() - start)
    x = np.asarray(res.x)
    return Run(f"C {method}", "done", str(getattr(res, "status", "")), np.asarray(res.t), x,
               int(res.n_steps), int(res.n_rhs), int(getattr(res, "n_jac", 0)),
               int(getattr(res, "n_lu", 0)), float(getattr(res, "wall_time", 0.0)) or
               time.perf_counter() - start)


def status_name(model, status: int) -> str:
    """The name of a C status code as the generated header spells it, ``<PREFIX>_<CODE>``
    (e.g. ``SPRING_PENDULUM_MAX_STEPS``)."""
    codes = {v: n for n, v, _ in STATUS_CODES + INTEGRATOR_STATUS_CODES + CONSTRAINT_STATUS_CODES}
    prefix = getattr(getattr(model, "rendered", None), "prefix", None) or model.name
    return f"{prefix.upper()}_{codes.get(status, 'UNKNOWN')}"


def run_figure(r: Run) -> str:
    fig = f"{r.steps} steps, {r.nfev} RHS calls"
    if r.njev:
        fig += f", {r.njev} Jacobians, {r.nlu} LU"
    return fig + f", {r.seconds:.2f} s"


def energy_series(model, ts, xs, p) -> tuple[np.ndarray, float]:
    TV = np.array([model.energy(t, x, p) for t, x in zip(ts, xs)])
    E = TV.sum(axis=1)
    scale = float(np.abs(TV).sum(axis=1).max())
    return E, scale
