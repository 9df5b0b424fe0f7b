"""What a work-precision run measures: the configurations (:class:`Config`, one curve of the
diagram each), the points (:class:`Point`, one run of a configuration at one
tolerance) and the plan that lists them (:func:`configurations`,
:func:`rk4_steps`, :func:`plan`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from ...abi import INTEGRATORS
from ...integrators import METHODS
from ...integrators import method as integrator

#: Relative tolerances swept by default, loosest first.
DEFAULT_RTOLS = tuple(10.0 ** -k for k in range(3, 11))
SOLVE_IVP_METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
#: solve_ivp methods that use a Jacobian (each runs with and without ``jac=``).
IMPLICIT_METHODS = ("Radau", "BDF", "LSODA")
#: The generated C integrators (``abi.INTEGRATORS``), the adaptive ones first.
C_METHODS = tuple(o.value for o in sorted(INTEGRATORS, key=lambda o: not METHODS[o].adaptive))
BACKENDS = ("lambdify", "python", "c")

#: Statuses of a point (:attr:`Point.status`).
OK, FAILED, OVER_BUDGET, SKIPPED = "ok", "failed", "over budget", "skipped"


@dataclass(frozen=True)
class Config:
    """One curve of the diagram: an integrator on a back end, with or without a Jacobian."""

    method: str
    backend: str
    jac: bool = False

    @property
    def is_c_integrator(self) -> bool:
        return self.method in C_METHODS

    @property
    def label(self) -> str:
        """``"Radau [c, jac]"``, ``"RK45 [lambdify]"``."""
        return f"{self.method} [{self.backend}{', jac' if self.jac else ''}]"


@dataclass(frozen=True)
class Point:
    """One run of one configuration at one tolerance (or one fixed step for ``rk4``).

    Attributes
    ----------
    method, backend, jac :
        The configuration (:class:`Config`).
    rtol : float
        Relative tolerance; for ``rk4`` the tolerance row its step ``h`` is laid on.
    atol : float or None
        Absolute tolerance (None for ``rk4``).
    h : float or None
        Fixed step of ``rk4`` (None for the adaptive methods).
    status : str
        ``"ok"``, ``"failed"`` (integrator or model error), ``"over budget"``
        (stopped after ``time_budget`` s) or ``"skipped"`` (a looser tolerance
        of the same configuration went over budget).
    message : str
        Why the point is not ok (empty when it is).
    err_final, err_final_rel, err_max : float
        Errors against the reference (:mod:`mbgen.studies.workprecision.runs`); NaN unless ok.
        For a model with configuration constraints ``err_max`` includes the
        constraint residual (the larger of the two).
    err_residual : float
        Largest ``|f_h(q, t)|`` over the output times (NaN without configuration
        constraints, or unless ok).
    time_s : float
        Median wall time of the timed runs, seconds; NaN unless ok.
    nfev, njev, nlu : int or None
        RHS calls, Jacobian calls, LU decompositions (probe run).
    callback_s : float or None
        Seconds inside the RHS/Jacobian callables in the probe run (solve_ivp only).
    probe_s : float or None
        Wall time of the probe run.
    """

    method: str
    backend: str
    jac: bool
    rtol: float
    atol: float | None
    h: float | None
    status: str
    message: str = ""
    err_final: float = math.nan
    err_final_rel: float = math.nan
    err_max: float = math.nan
    time_s: float = math.nan
    nfev: int | None = None
    njev: int | None = None
    nlu: int | None = None
    callback_s: float | None = None
    probe_s: float | None = None
    err_residual: float = math.nan

    @property
    def config(self) -> Config:
        return Config(self.method, self.backend, self.jac)

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def overhead(self) -> float | None:
        """Share of the probe's wall time spent outside the RHS/Jacobian (solve_ivp only)."""
        if self.callback_s is None or not self.probe_s:
            return None
        return 1.0 - self.callback_s / self.probe_s

    @property
    def setting(self) -> str:
        """``"rtol=1e-06"`` or, for ``rk4``, ``"h=0.0123"``."""
        return _setting(self.rtol, self.h)


@dataclass(frozen=True)
class Task:
    """A point to run."""

    config: Config
    rtol: float
    atol: float | None
    h: float | None

    def describe(self) -> str:
        return f"{self.config.label} {_setting(self.rtol, self.h)}"

    def point(self, status: str, message: str = "", **measured) -> Point:
        c = self.config
        return Point(c.method, c.backend, c.jac, self.rtol, self.atol, self.h, status, message,
                     **measured)


def configurations(methods: Iterable[str], backends: Iterable[str]) -> list[Config]:
    """Every curve of the diagram, method by method.

    solve_ivp methods run on every back end, the implicit ones with and
    without the Jacobian; the C integrators only on ``"c"`` (an implicit one,
    ``rosenbrock``, always uses the compiled Jacobian) and only when ``"c"`` is a back end.
    """
    backends = tuple(backends)
    configs = []
    for method in methods:
        if method in C_METHODS:
            if "c" in backends:
                configs.append(Config(method, "c", integrator(method).implicit))
            continue
        for backend in backends:
            configs.append(Config(method, backend))
            if method in IMPLICIT_METHODS:
                configs.append(Config(method, backend, True))
    return configs


def rk4_steps(rtols: Sequence[float], pilot_steps: int, t_eval: np.ndarray) -> tuple[float, ...]:
    """Fixed steps of ``rk4``, one per tolerance row.

    At the loosest ``rtol`` rk4 takes about as many steps as the pilot solve
    (an adaptive 5(4) method at that tolerance took ``pilot_steps``); every
    decade tighter multiplies the step count by ``10^(1/4)`` -- a tenth of
    the error of a 4th-order method -- so the rk4 curve spans the same error
    range as the adaptive ones.  The C integrator splits every output
    interval into equal steps, so each step is an output interval divided by
    a whole number: the step it really takes.
    """
    intervals = len(t_eval) - 1
    dt = (t_eval[-1] - t_eval[0]) / intervals
    loosest = max(rtols)
    return tuple(float(dt / math.ceil(pilot_steps * (loosest / r) ** 0.25 / intervals))
                 for r in rtols)


def plan(configs: Sequence[Config], rtols: Sequence[float], atol_scale: float,
         hs: Sequence[float]) -> list[Task]:
    """Every configuration at every tolerance; a fixed-step C integrator (``rk4``) at the step
    ``hs`` lays on that row."""
    return [Task(c, r, None, h) if c.is_c_integrator and not integrator(c.method).adaptive
            else Task(c, r, r * atol_scale, None) for c in configs for r, h in zip(rtols, hs)]


def _setting(rtol: float, h: float | None) -> str:
    return f"h={h:.3g}" if h is not None else f"rtol={rtol:.0e}"
