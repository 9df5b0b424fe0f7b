"""The tolerances and the reference of a work-precision run: the pilot solve
(:func:`pilot`), the typical state magnitude (:func:`typical_magnitude`) and the
solution errors are measured against (:class:`TrueSolution`, :func:`make_reference`).

Tolerances
    ``atol = rtol * atol_scale`` for every state.  By default
    ``atol_scale = ATOL_RATIO * m`` with ``m`` the *typical state magnitude*:
    the median over the states of ``max_t |x_i(t)|`` along a pilot solve
    (:data:`PILOT_METHODS` at the loosest ``rtol``).  So the relative
    tolerance governs states of typical size and the absolute one only takes
    over two decades below it (a state passing through zero).
True solution (``TrueSolution``)
    The scene's closed form when it has one (``Scene.closed_form``).
    Otherwise the first two of :data:`REFERENCE_SOLVES` that succeed (DOP853
    at rtol 1e-13; Radau at rtol 1e-12 with the compiled Jacobian; LSODA as a
    fallback for stiff scenes), all on the C back end with ``atol = rtol *
    atol_scale``.  The first is the reference; the largest difference between
    the two over the output grid is reported and is the *floor* below which
    an error is not meaningful.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import IntegrationError
from ..scene import Scene
from .points import IMPLICIT_METHODS
from .solve import Backends, Failed, solve

#: ``atol_scale = ATOL_RATIO * typical state magnitude`` unless given.
ATOL_RATIO = 1e-2
#: Candidates for the numerical reference ``(method, rtol, jac)``; the first two that succeed.
REFERENCE_SOLVES = (("DOP853", 1e-13, False), ("Radau", 1e-12, True), ("LSODA", 1e-12, True))
#: Pilot solves (typical magnitude, rk4 step count): the first that succeeds.
PILOT_METHODS = ("RK45", "LSODA")
#: Seconds a pilot or reference solve may take before the next candidate is tried.
REFERENCE_BUDGET_S = 300.0


@dataclass(frozen=True)
class TrueSolution:
    """The solution errors are measured against, on the output grid.

    Attributes
    ----------
    t : ndarray, shape (k,)
    x : ndarray, shape (k, n_x)
    source : str
        ``"closed form"`` or the solve that produced ``x``.
    check : str
        The second solve it was compared with (empty for a closed form).
    disagreement : float
        Max abs difference between the two solves: the floor of meaningful
        error (0 for a closed form).
    notes : tuple of str
        Candidates that failed on the way.
    """

    t: np.ndarray
    x: np.ndarray
    source: str
    check: str = ""
    disagreement: float = 0.0
    notes: tuple[str, ...] = ()

    def describe(self) -> str:
        if not self.check:
            return f"reference: {self.source}"
        return (f"reference: {self.source}, checked against {self.check}: "
                f"disagreement {self.disagreement:.1e} (floor of meaningful error)")


def typical_magnitude(x: np.ndarray) -> float:
    """Median over the states of ``max_t |x_i(t)|`` (``x`` of shape (k, n_x)); 1 if that is 0."""
    value = float(np.median(np.abs(np.asarray(x)).max(axis=0)))
    return value if value > 0 and math.isfinite(value) else 1.0


def pilot(b: Backends, t_eval, x0, rtol: float, atol: float) -> tuple[int, np.ndarray, str]:
    """``(steps, states at the steps, method)``: the first of :data:`PILOT_METHODS` to succeed."""
    notes = []
    for method in PILOT_METHODS:
        jac = b.jac("c") if method in IMPLICIT_METHODS else None
        try:
            sol, _ = solve(b.fun("c"), jac, method, t_eval, x0, rtol, atol, grid=False,
                           deadline=time.perf_counter() + REFERENCE_BUDGET_S)
        except Failed as failure:
            notes.append(f"{method}: {failure.message}")
            continue
        return sol.t.size - 1, sol.y.T, method
    raise IntegrationError(f"no pilot solve succeeded: {'; '.join(notes)}")


def _numerical_reference(b: Backends, t_eval, x0, atol_scale: float,
                         say: Callable[[str], None]) -> TrueSolution:
    """The first two of :data:`REFERENCE_SOLVES` that succeed, compared."""
    solved, notes = [], []
    for method, rtol, use_jac in REFERENCE_SOLVES:
        name = f"{method} rtol={rtol:.0e} (C RHS{', C Jacobian' if use_jac else ''})"
        say(f"reference: {name}")
        try:
            sol, _ = solve(b.fun("c"), b.jac("c") if use_jac else None, method, t_eval, x0,
                           rtol, rtol * atol_scale,
                           deadline=time.perf_counter() + REFERENCE_BUDGET_S)
        except Failed as failure:
            notes.append(f"{name}: {failure.status}: {failure.message}")
            continue
        solved.append((name, sol.y.T))
        if len(solved) == 2:
            (source, x), (check, other) = solved
            return TrueSolution(np.asarray(t_eval), x, source, check,
                             float(np.abs(x - other).max()), tuple(notes))
    raise IntegrationError(f"fewer than two reference solves succeeded: {'; '.join(notes)}")


def make_reference(scene: Scene, b: Backends, t_eval, x0, atol_scale, say) -> TrueSolution:
    """The scene's closed form when it has one, else :func:`_numerical_reference`."""
    if scene.closed_form is not None:
        x = np.asarray(scene.closed_form(t_eval, x0, b.p), dtype=float)
        return TrueSolution(np.asarray(t_eval), x, "closed form")
    return _numerical_reference(b, t_eval, x0, atol_scale, say)


#: The old name of :class:`TrueSolution` (``Reference`` now names only the check's
#: reference, :mod:`mbgen.reference`); kept for imports written before the rename.
Reference = TrueSolution
