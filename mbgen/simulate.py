"""Simulation with a generated right-hand side, and trajectory output."""

from __future__ import annotations

import csv
import io
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from .errors import MbgenError
from .fileio import write_atomic
from .runtime import ModelBase


@dataclass(frozen=True)
class Trajectory:
    """A simulated trajectory.

    Attributes
    ----------
    t : ndarray, shape (k,)
    x : ndarray, shape (k, n_x)
        States at ``t``, columns in ``names`` order.
    names : tuple of str
    nfev : int
        Right-hand-side evaluations.
    wall_time : float
        Seconds spent in the integrator.
    method : str
    max_residual : float
        Models with configuration constraints: the largest ``|f_h(q, t)|`` met
        (C integrators: after any step, before projection; solve_ivp, which
        does not project: at the output times).  NaN without such constraints.
    """

    t: np.ndarray
    x: np.ndarray
    names: tuple[str, ...]
    nfev: int
    wall_time: float
    method: str
    max_residual: float = float("nan")

    @property
    def final(self) -> dict[str, float]:
        return dict(zip(self.names, self.x[-1].tolist()))

    def to_csv(self) -> str:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(("t",) + self.names)
        for ti, xi in zip(self.t, self.x):
            w.writerow([repr(float(ti))] + [repr(float(v)) for v in xi])
        return buf.getvalue()

    def write_csv(self, path) -> Path:
        """Write ``t`` and the states as CSV (atomically)."""
        path = Path(path)
        write_atomic(path, self.to_csv())
        return path


def holonomic_outputs(scene) -> tuple:
    """The outputs :func:`consistent_start` needs for ``scene`` (none without configuration
    constraints): ``(Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN)``."""
    from .outputs import Output

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


def simulate_in_c(model, x0, t_span, *, method: str = "dopri5", rtol: float = 1e-9,
                  atol: float = 1e-12, n_out: int = 201, p=None, r=None,
                  rk4_steps: int = 10000, project: bool = True) -> Trajectory:
    """Integrate with a generated C integrator (``model.integrate``); see :func:`simulate`.

    Models with configuration constraints start from :func:`consistent_start`
    and are projected back onto the constraints after each step unless
    ``project=False``.
    """
    t = np.linspace(float(t_span[0]), float(t_span[1]), n_out)
    h = (t[-1] - t[0]) / rk4_steps if method == "rk4" else None
    x0 = consistent_start(model, x0, p, r, t[0])
    result = model.integrate(method, t, x0, p, r, rtol=rtol, atol=atol, h=h, project=project)
    return Trajectory(result.t, result.x, tuple(model.state_names), result.n_rhs,
                      result.wall_time, f"C {method}", result.max_residual)


def simulate(model: ModelBase, x0, t_span, *, p=None, r=None, method: str = "DOP853",
             rtol: float = 1e-9, atol: float = 1e-12, n_out: int = 201,
             t_eval=None) -> Trajectory:
    """Integrate ``model.rhs`` with :func:`scipy.integrate.solve_ivp`.

    Parameters
    ----------
    model : ModelBase
        Compiled, generated-Python or lambdified model.
    x0 : array, shape (n_x,)
    t_span : (float, float)
    p, r : arrays, optional
        Parameters (default: the model's defaults) and constant inputs (default 0).
    method, rtol, atol :
        Passed to ``solve_ivp``.
    n_out : int
        Number of equally spaced output times when ``t_eval`` is not given.

    Models with configuration constraints start from :func:`consistent_start`;
    solve_ivp does not project, so their trajectory drifts off the constraints
    (``Trajectory.max_residual`` measures how far).

    Raises
    ------
    MbgenError
        When the integrator fails (the solver's message is included).
    ConstraintError
        The dependent coordinates of ``x0`` cannot be completed.
    """
    f = model.bind(p, r)
    x0 = consistent_start(model, x0, p, r, float(t_span[0]))
    t0, t1 = float(t_span[0]), float(t_span[1])
    if t_eval is None:
        t_eval = np.linspace(t0, t1, n_out)
    start = time.perf_counter()
    sol = solve_ivp(f, (t0, t1), x0, method=method, rtol=rtol, atol=atol, t_eval=t_eval)
    wall = time.perf_counter() - start
    if not sol.success:
        raise MbgenError(f"integration of {model.name} failed at t={sol.t[-1] if sol.t.size else t0}: "
                         f"{sol.message}")
    x = sol.y.T.copy()
    return Trajectory(sol.t, x, tuple(model.state_names), int(sol.nfev), wall, method,
                      _residual(model, sol.t, x, p, r))
