"""The 50-digit reference of the floating-point bound (:mod:`mbgen.stress.precision`).

:class:`HighPrecision` evaluates ``M``, ``F`` and ``G`` of the *unoptimised*
equations with mpmath at :data:`DPS` digits and solves ``M a = F`` at that
precision; :meth:`HighPrecision.evaluate` returns a :class:`Reference`: the
right-hand side, ``cond(M)``, whether ``M`` is positive definite, and the
estimated rounding error of the same formula in double
(:attr:`Reference.formula_error`, from evaluations at :data:`FORMULA_BITS`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Mapping

import mpmath
import sympy as sm

#: Digits of the high-precision reference.
DPS = 50
#: Precisions (bits) at which the formula's own rounding error is sampled.
FORMULA_BITS = (56, 58, 60, 62, 64)


@dataclass(frozen=True)
class Reference:
    """The right-hand side at 50 digits at one point.

    Attributes
    ----------
    f : list of mpf or None
        ``[G; M^-1 F]``; None when ``M`` is not positive definite or ``f`` is not finite.
    positive_definite : bool
    cond : float
        2-norm condition number of ``M`` (``inf`` when not positive definite).
    problem : str
        Empty, or why ``f`` is missing (``"not positive definite"``, ``"non-finite"``).
    formula_error : float
        Estimated error ``||f_53 - f||_inf`` of evaluating the same formula (and
        solve) in 53-bit arithmetic: the largest of ``||f_b - f||_inf
        2^(b - 53)`` over the precisions ``b`` of :data:`FORMULA_BITS` (inputs
        are exact at those precisions, so only the formula's own rounding
        counts).
    """

    f: list | None
    positive_definite: bool
    cond: float
    problem: str = ""
    formula_error: float = 0.0


class HighPrecision:
    """``M``, ``F``, ``G`` of ``equations`` evaluated with mpmath, ``M a = F`` solved in mpmath.

    Parameters
    ----------
    equations : Equations
        Unoptimised equations (``mbgen.equations_of(scene)``).
    dps : int
        Decimal digits of the evaluation.

    Notes
    -----
    Arguments are given by name, so the reference can be called with the
    arrays of a compiled model whose layout (ABI) differs from the
    equations' (e.g. parameters the outputs never read are dropped there).
    Double inputs are converted to mpf exactly.
    """

    def __init__(self, equations, dps: int = DPS):
        L = equations.layout
        self.dps = dps
        self.layout = L
        self._symbols = (L.time,) + tuple(L.states) + tuple(L.parameters) + tuple(L.inputs)
        self._names = ("t",) + L.state_names + L.parameter_names + L.input_names
        self.n_u = L.n_u
        args = list(self._symbols)
        self._M = sm.lambdify(args, list(equations.mass_matrix), modules="mpmath")
        self._F = sm.lambdify(args, list(equations.forcing), modules="mpmath")
        self._G = sm.lambdify(args, list(equations.kinematics), modules="mpmath")

    def _args(self, t, values: Mapping[str, float]):
        missing = [n for n in self.layout.state_names + self.layout.parameter_names
                   if n not in values]
        if missing:
            raise ValueError(f"no value for {missing}")
        return [mpmath.mpf(float(t))] + [mpmath.mpf(float(values.get(n, 0.0)))
                                         for n in self._names[1:]]

    def evaluate(self, t: float, values: Mapping[str, float], formula: bool = True) -> Reference:
        """The reference right-hand side at ``t`` and the named state/parameter/input ``values``.

        ``formula``: also estimate the formula's own rounding error in double
        (see :attr:`Reference.formula_error`).
        """
        ref = self._evaluate(t, values)
        if not formula or ref.f is None:
            return ref
        worst = 0.0
        for bits in FORMULA_BITS:
            with mpmath.workprec(bits):
                low = self._evaluate_here(t, values, strict=False)
            if low.f is None:
                return replace(ref, formula_error=math.inf)
            with mpmath.workdps(self.dps):
                err = max(abs(a - b) for a, b in zip(low.f, ref.f))
            worst = max(worst, float(err) * 2.0 ** (bits - 53))
        return replace(ref, formula_error=worst)

    def _evaluate(self, t, values) -> Reference:
        """Evaluate at ``self.dps`` digits."""
        with mpmath.workdps(self.dps):
            return self._evaluate_here(t, values)

    def _evaluate_here(self, t, values, strict: bool = True) -> Reference:
        """Evaluate at the current mpmath precision.

        ``strict``: ``M`` counts as singular when its smallest eigenvalue is
        below ``2^(16 - prec)`` times the largest (else only when it is <= 0).
        """
        args = self._args(t, values)
        n = self.n_u
        try:
            M = mpmath.matrix(n, n)
            for k, v in enumerate(self._M(*args)):
                M[k // n, k % n] = _real(v)
            ok_m = all(mpmath.isfinite(M[i, j]) for i in range(n) for j in range(n))
        except (ZeroDivisionError, ValueError, OverflowError, TypeError):
            ok_m = False
        if not ok_m:
            return Reference(None, False, math.inf, "non-finite mass matrix")
        eig = mpmath.eigsy(M, eigvals_only=True)
        lo, hi = min(eig), max(abs(e) for e in eig)
        if hi == 0 or lo <= (hi * mpmath.mpf(2) ** (16 - mpmath.mp.prec) if strict else 0):
            return Reference(None, False, math.inf, "not positive definite")
        cond = float(hi / lo)
        try:
            F = mpmath.matrix([_real(v) for v in self._F(*args)])
            G = [_real(v) for v in self._G(*args)]
            a = mpmath.cholesky_solve(M, F)
            f = G + [a[i] for i in range(n)]
        except (ZeroDivisionError, ValueError, OverflowError, TypeError):
            return Reference(None, True, cond, "non-finite")
        if not all(mpmath.isfinite(v) for v in f):
            return Reference(None, True, cond, "non-finite")
        return Reference(f, True, cond)


def _real(value):
    """``value`` as an mpf; a complex value (the root or log of a negative number, NaN in
    double) is a ``ValueError``."""
    if isinstance(value, mpmath.mpc):
        if value.imag != 0:
            raise ValueError("complex intermediate (NaN in double)")
        return value.real
    return mpmath.mpf(value)
