"""One ``solve_ivp`` call (:func:`solve`), optionally instrumented: a :class:`_Meter` around
the callables counts the calls, sums the seconds inside them and stops the solve at a
deadline.  The callables come from :class:`Backends`: the ``lambdify``, ``python`` and
``c`` models of one scene, all taking the compiled model's arrays.  A solve that yields
no solution raises :class:`Failed`, which says why.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from ...abi import Output
from ...errors import MbgenError
from ...model.scene import Scene
from ...pipeline import run
from ...runtime.compiled import CompiledModel
from ...runtime.lambdified import LambdifiedModel
from ...runtime.python import python_model
from ...runtime.simulate import holonomic_outputs
from .points import FAILED, OVER_BUDGET


class Failed(Exception):
    """A point did not produce a solution; ``status`` and ``message`` say why."""

    def __init__(self, status: str, message: str):
        super().__init__(message)
        self.status, self.message = status, message


class _OverBudget(Exception):
    """Raised from inside a callable once the probe's deadline has passed."""


class _Meter:
    """Wraps callables: counts calls, sums the seconds inside them, enforces a deadline."""

    def __init__(self, deadline: float, on_time: Callable[[float], None] | None = None):
        self.deadline = deadline
        self.seconds = 0.0
        self.calls = {"fun": 0, "jac": 0}
        self.on_time = on_time

    def wrap(self, fn: Callable, kind: str) -> Callable:
        clock, calls, on_time = time.perf_counter, self.calls, self.on_time

        def wrapped(t, x):
            start = clock()
            if start >= self.deadline:    # a budget of 0 s stops at the first call
                raise _OverBudget
            if on_time is not None:
                on_time(t)
            out = fn(t, x)
            self.seconds += clock() - start
            calls[kind] += 1
            return out

        return wrapped


def solve(fun, jac, method: str, t_eval, x0, rtol: float, atol: float, *,
          deadline: float | None = None, grid: bool = True,
          on_time: Callable[[float], None] | None = None):
    """``(solution, meter)`` of one ``solve_ivp`` call; instrumented when ``deadline`` is set.

    ``grid=False`` keeps every step in ``solution.t`` instead of evaluating at
    ``t_eval``.  ``on_time(t)`` (with a deadline) is called at every RHS or
    Jacobian call: the time the solver has reached, for a progress bar.
    Raises :class:`Failed` on any failure.
    """
    meter = None if deadline is None else _Meter(deadline, on_time)
    f = fun if meter is None else meter.wrap(fun, "fun")
    extra = {}
    if jac is not None:
        extra["jac"] = jac if meter is None else meter.wrap(jac, "jac")
    try:
        sol = solve_ivp(f, (t_eval[0], t_eval[-1]), x0, method=method, rtol=rtol, atol=atol,
                        t_eval=t_eval if grid else None, **extra)
    except _OverBudget:
        raise Failed(OVER_BUDGET, "stopped at the time budget") from None
    except MbgenError as exc:  # a singular or non-finite RHS: a failed point (a bug propagates)
        raise Failed(FAILED, f"{type(exc).__name__}: {exc}") from None
    if not sol.success:
        raise Failed(FAILED, f"solve_ivp: {sol.message}")
    return sol, meter


@dataclass
class Backends:
    """The three models of one scene and the bound callables of each back end."""

    compiled: CompiledModel
    p: np.ndarray
    models: dict

    @classmethod
    def build(cls, scene: Scene, backends: Sequence[str], c_methods: Sequence[str]) -> Backends:
        """Generate and compile once; every back end takes the compiled model's arrays."""
        expression_outputs = (Output.RHS, Output.JACOBIAN) + holonomic_outputs(scene)
        result = run(scene, (*expression_outputs, *c_methods))
        models = {"c": result.compiled}
        if "python" in backends:
            models["python"] = python_model(result.rendered)
        if "lambdify" in backends:
            models["lambdify"] = LambdifiedModel(result.baked, expression_outputs,
                                                 layout=result.layout)
        return cls(result.compiled, scene.p(result.layout), models)

    def fun(self, backend: str) -> Callable:
        return self.models[backend].bind(self.p)

    def jac(self, backend: str) -> Callable:
        return self.models[backend].bind(self.p, output=Output.JACOBIAN)

    def warm_up(self, x0: np.ndarray, t0: float) -> None:
        """Call every right-hand side and Jacobian once (lazy set-up is not timed)."""
        for backend in self.models:
            self.fun(backend)(t0, x0)
            self.jac(backend)(t0, x0)
