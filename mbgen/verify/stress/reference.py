"""The 50-digit reference of the floating-point bound (:mod:`mbgen.verify.stress.precision`).

:class:`HighPrecision` evaluates ``M``, ``F`` and ``G`` of the *unoptimised*
equations with mpmath at :data:`DPS` digits and solves ``M a = F`` at that
precision; :meth:`HighPrecision.evaluate` returns a :class:`HighPrecisionValue`: the
right-hand side, ``cond(M)``, whether ``M`` is positive definite, and the
estimated rounding error of the same formula in double
(:attr:`HighPrecisionValue.formula_error`, from evaluations at :data:`FORMULA_BITS`).

Constrained equations (``equations.constraints``; ``M``, ``F`` over every speed,
``A u + b = 0``, ``A u' + beta = 0``, ``A = [A_s A_r]``) are reduced the way the
generated code reduces them, at 50 digits: the dependent speeds from ``A_r u_r =
-(A_s u_s + b)``, then with ``T = [I; -A_r^-1 A_s]`` and ``d = [0; -A_r^-1 beta]``
the reduced system ``(T^T M T) u_s' = T^T (F - M d)``.  ``positive_definite`` and
``cond`` are those of ``T^T M T``, with ``cond`` multiplied by ``cond(A_r)`` (the
dependent block's conditioning amplifies the rounding of ``T``).  A singular
``A_r`` gives no ``f`` (problem ``"singular constraint Jacobian"``): the compiled
model must raise an mbgen error (``SingularConstraintError``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import mpmath
import sympy as sm

#: Digits of the high-precision reference.
DPS = 50
#: Precisions (bits) at which the formula's own rounding error is sampled.
FORMULA_BITS = (56, 58, 60, 62, 64)


@dataclass(frozen=True)
class HighPrecisionValue:
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
        self.n_d = L.n_d
        args = list(self._symbols) + list(L.dependent_speeds)
        self._M = sm.lambdify(args, list(equations.mass_matrix), modules="mpmath")
        self._F = sm.lambdify(args, list(equations.forcing), modules="mpmath")
        self._G = sm.lambdify(args, list(equations.kinematics), modules="mpmath")
        c = equations.constraints
        if c is not None:
            self._A = sm.lambdify(args, list(c.velocity_matrix), modules="mpmath")
            self._b = sm.lambdify(args, list(c.velocity_bias), modules="mpmath")
            self._beta = sm.lambdify(args, list(c.acceleration_bias), modules="mpmath")

    def _args(self, t, values: Mapping[str, float]):
        missing = [n for n in self.layout.state_names + self.layout.parameter_names
                   if n not in values]
        if missing:
            raise ValueError(f"no value for {missing}")
        return [mpmath.mpf(float(t))] + [mpmath.mpf(float(values.get(n, 0.0)))
                                         for n in self._names[1:]]

    def evaluate(self, t: float, values: Mapping[str, float],
                 formula: bool = True) -> HighPrecisionValue:
        """The reference right-hand side at ``t`` and the named state/parameter/input ``values``.

        ``formula``: also estimate the formula's own rounding error in double
        (see :attr:`HighPrecisionValue.formula_error`).
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

    def _evaluate(self, t, values) -> HighPrecisionValue:
        """Evaluate at ``self.dps`` digits."""
        with mpmath.workdps(self.dps):
            return self._evaluate_here(t, values)

    def _evaluate_here(self, t, values, strict: bool = True) -> HighPrecisionValue:
        """Evaluate at the current mpmath precision.

        ``strict``: ``M`` counts as singular when its smallest eigenvalue is
        below ``2^(16 - prec)`` times the largest (else only when it is <= 0).
        """
        args = self._args(t, values)
        n = self.n_u
        reduction = None
        if self.n_d:
            try:
                args, reduction = self._dependent_speeds(args)
            except (ZeroDivisionError, ValueError, OverflowError, TypeError):
                return HighPrecisionValue(None, True, math.inf, "singular constraint Jacobian")
        n_all = n + self.n_d
        try:
            M = mpmath.matrix(n_all, n_all)
            for k, v in enumerate(self._M(*args)):
                M[k // n_all, k % n_all] = _real(v)
            ok_m = all(mpmath.isfinite(M[i, j]) for i in range(n_all) for j in range(n_all))
        except (ZeroDivisionError, ValueError, OverflowError, TypeError):
            ok_m = False
        if not ok_m:
            return HighPrecisionValue(None, False, math.inf, "non-finite mass matrix")
        F_all = None
        if reduction is not None:
            T, cond_ar = reduction
            try:
                F_all = mpmath.matrix([_real(v) for v in self._F(*args)])
                d = self._acceleration_offset(args, T)
            except (ZeroDivisionError, ValueError, OverflowError, TypeError):
                return HighPrecisionValue(None, True, math.inf, "non-finite")
            F_all = T.T * (F_all - M * d)
            M = T.T * M * T
        eig = mpmath.eigsy(M, eigvals_only=True)
        lo, hi = min(eig), max(abs(e) for e in eig)
        if hi == 0 or lo <= (hi * mpmath.mpf(2) ** (16 - mpmath.mp.prec) if strict else 0):
            return HighPrecisionValue(None, False, math.inf, "not positive definite")
        cond = float(hi / lo) * (reduction[1] if reduction is not None else 1.0)
        try:
            F = F_all if F_all is not None else mpmath.matrix([_real(v) for v in self._F(*args)])
            G = [_real(v) for v in self._G(*args)]
            a = mpmath.cholesky_solve(M, F)
            f = G + [a[i] for i in range(n)]
        except (ZeroDivisionError, ValueError, OverflowError, TypeError):
            return HighPrecisionValue(None, True, cond, "non-finite")
        if not all(mpmath.isfinite(v) for v in f):
            return HighPrecisionValue(None, True, cond, "non-finite")
        return HighPrecisionValue(f, True, cond)


    def _dependent_speeds(self, args):
        """``(args + u_r, (T, cond(A_r)))`` with ``u_r`` solved from the velocity constraints."""
        n, m = self.n_u, self.n_d
        zeros = [mpmath.mpf(0)] * m                  # A and b do not contain u_r
        A = [_real(v) for v in self._A(*args, *zeros)]
        b = [_real(v) for v in self._b(*args, *zeros)]
        n_all = n + m
        As = mpmath.matrix([[A[i * n_all + j] for j in range(n)] for i in range(m)])
        Ar = mpmath.matrix([[A[i * n_all + n + j] for j in range(m)] for i in range(m)])
        first = 1 + len(self.layout.coordinates)
        us = mpmath.matrix(args[first:first + n])
        Ar_inv = mpmath.inverse(Ar)                  # ZeroDivisionError when singular
        ur = -(Ar_inv * (As * us + mpmath.matrix(b)))
        T = mpmath.matrix(n_all, n)
        for i in range(n):
            T[i, i] = 1
        block = -(Ar_inv * As)
        for i in range(m):
            for j in range(n):
                T[n + i, j] = block[i, j]
        cond_ar = float(mpmath.mnorm(Ar, 1) * mpmath.mnorm(Ar_inv, 1))
        self._Ar_inv = Ar_inv
        return list(args) + [ur[i] for i in range(m)], (T, cond_ar)

    def _acceleration_offset(self, args, T):
        """``d = [0; -A_r^-1 beta]``: the part of ``u'`` that ``u_s'`` does not set."""
        n, m = self.n_u, self.n_d
        beta = mpmath.matrix([_real(v) for v in self._beta(*args)])
        dr = -(self._Ar_inv * beta)
        d = mpmath.matrix(n + m, 1)
        for i in range(m):
            d[n + i] = dr[i]
        return d


def _real(value):
    """``value`` as an mpf; a complex value (the root or log of a negative number, NaN in
    double) is a ``ValueError``."""
    if isinstance(value, mpmath.mpc):
        if value.imag != 0:
            raise ValueError("complex intermediate (NaN in double)")
        return value.real
    return mpmath.mpf(value)


#: The old name of :class:`HighPrecisionValue` (``Reference`` names only the check's
#: lambdified reference, :mod:`mbgen.runtime.lambdified`); kept for imports written before
#: the rename.
Reference = HighPrecisionValue
