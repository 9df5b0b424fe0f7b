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
    at rtol 1e-13; the generated C Rodas4 ``rosenbrock`` at rtol 1e-12 where it was
    compiled -- an implicit method of another order, with no Python per step: 0.1 s
    where solve_ivp's Radau took 6.2 s on ``disc_pendulum`` --; Radau at rtol 1e-12
    with the compiled Jacobian; LSODA as a fallback), all on the C back end with
    ``atol = rtol * atol_scale``; on a *stiff* scene the implicit candidates
    :data:`STIFF_REFERENCE_SOLVES` are used instead (the generated C Rodas4
    ``rosenbrock`` first when it was compiled: on ``stiff_chain -O stiffness=1e6`` it
    takes 2.2 s at rtol 1e-12 where solve_ivp's Radau ran past 60 s).  The first is
    the reference; the largest difference between the two over the output grid is
    reported and
    is the *floor* below which an error is not meaningful.
Stiffness
    :func:`stiffness_steps`: an explicit method is stable only while
    ``h |Re lambda| <~ 3`` for every eigenvalue ``lambda`` of the Jacobian
    with ``Re lambda < 0``, so it needs at least ``T max(-Re lambda) / 3``
    steps over the span ``T`` whatever the tolerance.  Evaluated with the
    compiled Jacobian at the initial state; above :data:`STIFF_STEPS` the
    scene counts as stiff (``stiff_chain`` at its default stiffness 1e4:
    about 2e3; at 1e6: 2e4).  The pilot then starts with LSODA.
Budget and progress
    Each pilot and reference solve may take ``max(REFERENCE_BUDGET_FACTOR x
    time_budget, REFERENCE_BUDGET_MIN_S)`` seconds (60 s at the default budget
    of 10 s); one that runs past it is stopped and the next candidate is tried
    (the notes say so).
    With a progress bar, each solve shows the fraction of the time span it
    has reached and its elapsed time.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...abi import Output
from ...errors import IntegrationError
from ...model.scene import Scene
from .points import C_METHODS, FAILED, IMPLICIT_METHODS, OVER_BUDGET
from .solve import Backends, Failed, solve

#: ``atol_scale = ATOL_RATIO * typical state magnitude`` unless given.
ATOL_RATIO = 1e-2
#: Candidates for the numerical reference ``(method, rtol, jac)``; the first two that succeed.
REFERENCE_SOLVES = (("DOP853", 1e-13, False), ("rosenbrock", 1e-12, True),
                    ("Radau", 1e-12, True), ("LSODA", 1e-12, True))
#: Reference candidates of a stiff scene: implicit only, with the compiled Jacobian; the
#: generated C ``rosenbrock`` (Rodas4, no Python per step) first when it was compiled.
STIFF_REFERENCE_SOLVES = (("rosenbrock", 1e-12, True), ("LSODA", 1e-12, True),
                          ("Radau", 1e-12, True), ("BDF", 1e-12, True))
#: The C integrator cannot be stopped by a clock: its step limit is this many steps per
#: second of budget.
C_STEPS_PER_BUDGET_S = 20_000
#: Pilot solves (typical magnitude, rk4 step count): the first that succeeds.
PILOT_METHODS = ("RK45", "LSODA")
STIFF_PILOT_METHODS = ("LSODA", "Radau")
#: A pilot or reference solve may take this many times the points' time budget ...
REFERENCE_BUDGET_FACTOR = 5.0
#: ... and at least this many seconds.
REFERENCE_BUDGET_MIN_S = 60.0
#: Least explicit step count (stability bound) above which a scene is stiff.
STIFF_STEPS = 1e4


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


def stiffness_steps(b: Backends, t_eval, x0) -> float:
    """Least number of steps an explicit method needs over ``t_eval`` (its stability bound).

    ``(t_end - t_0) max(-Re lambda) / 3`` over the eigenvalues of the compiled
    Jacobian at ``x0`` (0 when none has a negative real part); see the module.
    """
    try:
        eig = np.linalg.eigvals(np.asarray(b.jac("c")(float(t_eval[0]), x0), dtype=float))
    except (np.linalg.LinAlgError, ValueError):
        return 0.0
    decay = float(np.max(-eig.real, initial=0.0))
    return decay * float(t_eval[-1] - t_eval[0]) / 3.0 if np.isfinite(decay) else 0.0


class _Progress:
    """A tqdm bar over the time span for one solve (or nothing), closed on exit."""

    def __init__(self, enabled: bool, desc: str, t_eval):
        self.bar = None
        if enabled:
            from tqdm import tqdm

            self.t0, self.span = float(t_eval[0]), float(t_eval[-1] - t_eval[0]) or 1.0
            self.bar = tqdm(total=100, desc=desc, unit="%", file=sys.stderr, leave=False,
                            bar_format="{desc}: {percentage:3.0f}% of t_span |{bar}| "
                                       "{elapsed}")

    def __call__(self, t) -> None:
        done = int(100 * min(max((float(t) - self.t0) / self.span, 0.0), 1.0))
        if done > self.bar.n:
            self.bar.update(done - self.bar.n)

    @property
    def on_time(self):
        return self if self.bar is not None else None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.close()


def pilot(b: Backends, t_eval, x0, rtol: float, atol: float, *, stiff: bool = False,
          budget_s: float = 50.0, bar: bool = False) -> tuple[int, np.ndarray, str]:
    """``(steps, states at the steps, method)``: the first of :data:`PILOT_METHODS` (stiff:
    :data:`STIFF_PILOT_METHODS`) to succeed within ``budget_s`` seconds each."""
    notes = []
    for method in STIFF_PILOT_METHODS if stiff else PILOT_METHODS:
        jac = b.jac("c") if method in IMPLICIT_METHODS else None
        try:
            with _Progress(bar, f"pilot {method}", t_eval) as progress:
                sol, _ = solve(b.fun("c"), jac, method, t_eval, x0, rtol, atol, grid=False,
                               deadline=time.perf_counter() + budget_s,
                               on_time=progress.on_time)
        except Failed as failure:
            notes.append(f"{method}: {failure.message}")
            continue
        return sol.t.size - 1, sol.y.T, method
    raise IntegrationError(f"no pilot solve succeeded within {budget_s:g} s each: "
                           f"{'; '.join(notes)}")


def _numerical_reference(b: Backends, t_eval, x0, atol_scale: float,
                         say: Callable[[str], None], *, stiff: bool = False,
                         budget_s: float = 50.0, bar: bool = False) -> TrueSolution:
    """The first two of :data:`REFERENCE_SOLVES` (stiff: :data:`STIFF_REFERENCE_SOLVES`)
    that succeed within ``budget_s`` seconds each, compared."""
    solved, notes = [], []
    if stiff:
        notes.append("stiff scene: implicit reference solves only")
    for method, rtol, use_jac in STIFF_REFERENCE_SOLVES if stiff else REFERENCE_SOLVES:
        in_c = method in C_METHODS
        if in_c and Output(method) not in b.compiled.outputs:
            continue
        name = (f"C {method} rtol={rtol:.0e}" if in_c else
                f"{method} rtol={rtol:.0e} (C RHS{', C Jacobian' if use_jac else ''})")
        say(f"reference: {name} (budget {budget_s:g} s)")
        start = time.perf_counter()
        try:
            if in_c:
                x = _c_solve(b, method, t_eval, x0, rtol, rtol * atol_scale, budget_s)
            else:
                with _Progress(bar, f"reference {method}", t_eval) as progress:
                    sol, _ = solve(b.fun("c"), b.jac("c") if use_jac else None, method, t_eval,
                                   x0, rtol, rtol * atol_scale, deadline=start + budget_s,
                                   on_time=progress.on_time)
                x = sol.y.T
        except Failed as failure:
            notes.append(f"{name}: {failure.status} after {time.perf_counter() - start:.1f} s: "
                         f"{failure.message}")
            say(f"reference: {name}: {failure.status}")
            continue
        solved.append((name, x))
        if len(solved) == 2:
            (source, x), (check, other) = solved
            return TrueSolution(np.asarray(t_eval), x, source, check,
                             float(np.abs(x - other).max()), tuple(notes))
    raise IntegrationError(f"fewer than two reference solves succeeded within {budget_s:g} s "
                           f"each (raise --time-budget; they may take "
                           f"{REFERENCE_BUDGET_FACTOR:g} times it): {'; '.join(notes)}")


def _c_solve(b: Backends, method: str, t_eval, x0, rtol: float, atol: float,
             budget_s: float) -> np.ndarray:
    """States on ``t_eval`` from a generated C integrator, its step limit set by the budget
    (at least one step; ``budget_s = inf``: the integrator's own limit)."""
    max_steps = 0 if math.isinf(budget_s) else max(1, int(C_STEPS_PER_BUDGET_S * budget_s))
    try:
        run = b.compiled.integrate(method, t_eval, x0, b.p, rtol=rtol, atol=atol,
                                   max_steps=max_steps)
    except IntegrationError as exc:
        status = OVER_BUDGET if exc.status == 4 else FAILED   # 4: MAX_STEPS
        raise Failed(status, str(exc)) from None
    return run.x


def make_reference(scene: Scene, b: Backends, t_eval, x0, atol_scale, say, *,
                   stiff: bool = False, budget_s: float = 50.0, bar: bool = False) -> TrueSolution:
    """The scene's closed form when it has one, else :func:`_numerical_reference`.

    ``budget_s`` is the seconds each reference solve may take (a C integrator's step
    limit is :data:`C_STEPS_PER_BUDGET_S` per second); ``math.inf`` sets no limit (the C
    integrators keep their own step limit) and ``0`` stops every solve at its first call,
    so neither depends on how fast the machine is.
    """
    if scene.closed_form is not None:
        x = np.asarray(scene.closed_form(t_eval, x0, b.p), dtype=float)
        return TrueSolution(np.asarray(t_eval), x, "closed form")
    return _numerical_reference(b, t_eval, x0, atol_scale, say, stiff=stiff, budget_s=budget_s,
                                bar=bar)


#: The old name of :class:`TrueSolution` (``Reference`` now names only the check's
#: reference, :mod:`mbgen.runtime.lambdified`); kept for imports written before the rename.
Reference = TrueSolution
