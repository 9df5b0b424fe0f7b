"""The result of an integration: one type for the C integrators and for solve_ivp.

:meth:`CompiledModel.integrate <mbgen.runtime.compiled.CompiledModel.integrate>` and
:func:`mbgen.runtime.simulate.simulate` both return a :class:`Trajectory`: the states
``x``, shape ``(k, n_x)``, at the times ``t``, shape ``(k,)``, and what the run cost.
It reads like scipy's ``OdeResult`` too (``y``, ``nfev``, ``success``, ``result["y"]``).
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..fileio import write_atomic

#: The ``message`` of a C integration that reached its last output time.
SUCCESS = "The solver successfully reached the end of the integration interval."


@dataclass(frozen=True)
class Trajectory:
    """A computed trajectory; reads like scipy's ``OdeResult`` too.

    ``t``, ``y`` (shape ``(n_x, k)``), ``success``, ``message``, ``status``,
    ``nfev``, ``njev``, ``nlu`` are scipy's names (also as ``result["y"]``);
    ``n_rhs``, ``n_jac``, ``n_lu`` are the same counts by mbgen's C names.

    Attributes
    ----------
    t : ndarray, shape (k,)
        The output times.
    x : ndarray, shape (k, n_x)
        States at ``t``, columns in ``names`` order (row 0 is ``x0``; ``y`` is ``x.T``,
        as solve_ivp's).
    names : tuple of str
        The state names.
    nfev : int
        Right-hand-side evaluations (``n_rhs``).
    wall_time : float
        Seconds spent in the integrator (``time.perf_counter``).
    method : str
        :meth:`~mbgen.runtime.compiled.CompiledModel.integrate`: ``"dopri5"``, ``"rk4"`` or
        ``"rosenbrock"``; :func:`~mbgen.runtime.simulate.simulate`: ``"C rosenbrock"``,
        ``"DOP853"``, ``"DOP853 -> Radau"`` (switched on stiffness), ...
    njev, nlu, n_steps : int
        Jacobian evaluations (``n_jac``), LU factorisations (``n_lu``), accepted steps.
    message : str
        How the integration ended (``integrate``), or why this method and any
        stiffness note (``simulate``).
    max_residual : float
        Models with configuration constraints: the largest ``|f_h(q, t)|`` met
        (C integrators: after any step, before projection; solve_ivp, which
        does not project: at the output times).  NaN without such constraints.
    status : int
        The C status code (0: success; failures raise instead).
    n_rejected : int
        Rejected steps (C integrators).
    """

    t: np.ndarray
    x: np.ndarray
    names: tuple[str, ...]
    nfev: int
    wall_time: float
    method: str
    njev: int = 0
    nlu: int = 0
    n_steps: int = 0
    message: str = ""
    max_residual: float = float("nan")
    status: int = 0
    n_rejected: int = 0

    @property
    def y(self) -> np.ndarray:
        """States as columns, shape ``(n_x, k)`` (as ``solve_ivp``'s ``y``)."""
        return self.x.T

    @property
    def success(self) -> bool:
        return self.status == 0  # failures raise

    @property
    def n_rhs(self) -> int:
        return self.nfev

    @property
    def n_jac(self) -> int:
        return self.njev

    @property
    def n_lu(self) -> int:
        return self.nlu

    @property
    def final(self) -> dict[str, float]:
        return dict(zip(self.names, self.x[-1].tolist()))

    def __getitem__(self, key: str):
        try:
            return getattr(self, key)
        except AttributeError:
            raise KeyError(key) from None

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


#: The name :meth:`CompiledModel.integrate <mbgen.runtime.compiled.CompiledModel.integrate>`'s
#: documentation uses for its result (``Integration.max_residual``): the same type.
Integration = Trajectory

__all__ = ["Trajectory", "Integration", "SUCCESS"]
