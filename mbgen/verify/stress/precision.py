r"""The floating-point bound: the compiled right-hand side at one point against the 50-digit
reference (:func:`evaluate_point` measures, :func:`judge_point` decides,
:func:`check_point` makes the :class:`~mbgen.verify.stress.report.Case`).

The bound
---------
Floating point (``fp``, and the evaluations of ``extreme`` and ``singular``):
the compiled right-hand side ``f_C`` is compared with ``f_HP``, the *unoptimised*
sympy expressions ``M, F, G`` (the same as :class:`mbgen.LambdifiedModel` uses,
no CSE) evaluated with mpmath at :data:`~mbgen.verify.stress.reference.DPS` = 50
digits and ``M a = F`` solved at that precision, for the same double inputs
(:class:`~mbgen.verify.stress.reference.HighPrecision`).  The bound is a backward-error
model: a stable evaluation returns the exact result for inputs and intermediate
values perturbed by a few units of roundoff ``eps``; the forward error is then at
most ``eps`` times the condition number of the problem, plus whatever the formula
itself loses to cancellation between intermediate values.  With
``s_i = sum_j |df_i/dx_j| |x_j| + sum_k |df_i/dp_k| |p_k| + |df_i/dt| |t|``
(sensitivity to relative perturbations of every input, from the compiled
Jacobians), ``cond(M)`` (2-norm, from the 50-digit eigenvalues) and ``e_formula``
(the error of evaluating the *same unoptimised formula* and solve in 53-bit
arithmetic, estimated from mpmath evaluations at 56..64 bits scaled to 53,
:attr:`~mbgen.verify.stress.reference.HighPrecisionValue.formula_error`)::

    ||f_C - f_HP||_inf <= C eps (cond(M) ||f_HP||_inf + max_i s_i) + 30 e_formula

with ``C = FP_SAFETY = 1e3`` for the number of operations.  The first term bounds
the solve ``M a = F``, the second the propagation of rounding in the inputs (a
stiff spring between two absolute positions, ``k (|x_2 - x_1| - a)``, is only
known to ``k eps |x|``), the third a cancellation *inside* the formula that no
input perturbation shows (``sqrt(y^2) - l`` with ``y`` close to ``l`` loses
``eps l`` whatever the code generator does).  Such rows pass with the reason
``formula-limited``, so the loss is visible; what fails is an error more than
~30x above what the formula permits (CSE, printing or a wrong expression).
Measured on every built-in scene at ``full`` size (395 points): the compiled
error never exceeded ``0.4 eps (cond(M) |f| + s)`` except where the formula
cancels, and there it was ``0.1 .. 0.9 e_formula``; so both factors leave a
margin of 30x or more, while an error of ``1e-8`` injected into ``F`` fails at
the nominal state.

The ``formula-limited`` rule caught mbgen's own stiff spring: a spring of
natural length ``l`` stretched by a tiny ``s`` was evaluated as
``k (sqrt((l + s)^2) - l)``, which loses ``k eps l`` (relative error ``9e-10`` at
``k = 1e8``).  The derivation now writes the stretch as
``(|r|^2 - l^2) / (|r| + l)`` with the numerator expanded, so that
``(l + s)^2 - l^2`` becomes ``s^2 + 2 l s`` (``_stretch`` in
:mod:`mbgen.derivation.kane`), and the stiff spring keeps full precision.  The rule
remains for formulas that still cancel (user models).

Singular and non-finite references
----------------------------------
Where ``C eps cond(M) >= 1`` the mass matrix is *numerically singular*: both a
finite result and :class:`~mbgen.errors.SingularMassMatrixError` are accepted
(for constrained models ``cond`` includes the dependent block of the constraint
Jacobian, and :class:`~mbgen.errors.SingularConstraintError` is accepted too).
Where the 50-digit ``M`` is not positive definite, the compiled model must raise
``SingularMassMatrixError`` (and a C integrator must stop with status
``NOT_POSITIVE_DEFINITE``, see :mod:`mbgen.verify.stress.extreme`); where the 50-digit
``f`` is not finite, ``NonFiniteResultError``.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Mapping
from dataclasses import dataclass

import mpmath
import numpy as np

from ...abi import Output
from ...errors import MbgenError, NonFiniteResultError, SingularMassMatrixError
from .reference import HighPrecision, HighPrecisionValue
from .report import Case, fmt_g

#: Unit roundoff of float64.
EPS = float(np.finfo(float).eps)
#: Safety factor of the floating-point bound (see the module docstring).
FP_SAFETY = 1e3
#: Factor on the formula's own rounding error (``HighPrecisionValue.formula_error``) in the bound.
FORMULA_SAFETY = 30.0


@dataclass(frozen=True)
class PointResult:
    """The compiled RHS at one point next to the reference, and the floating-point bound.

    ``abs_err = ||f_C - f_HP||_inf``; the allowed error is the sum of three
    terms (absolute): ``cond_term = C eps cond(M) ||f||``, ``input_term = C eps
    max_i s_i`` and ``formula_term = FORMULA_SAFETY * formula_error``.
    """

    f: np.ndarray | None
    error: str                # "" or the mbgen exception name (or "unexpected ...")
    reference: HighPrecisionValue
    abs_err: float = math.nan
    fnorm: float = math.nan
    cond_term: float = math.nan
    input_term: float = math.nan
    formula_term: float = math.nan

    @property
    def allowed(self) -> float:
        return self.cond_term + self.input_term + self.formula_term

    @property
    def rel_err(self) -> float:
        return _ratio(self.abs_err, self.fnorm)

    @property
    def rel_allowed(self) -> float:
        return _ratio(self.allowed, self.fnorm)

    @property
    def formula_limited(self) -> bool:
        """The formula's own rounding, not the conditioning, sets the bound (cancellation)."""
        return self.formula_term > 10 * (self.cond_term + self.input_term)


def _ratio(a: float, b: float) -> float:
    if b > 0:
        return a / b
    return 0.0 if a == 0 else math.inf


def try_call(fn, *args):
    """``(value, "")`` or ``(None, error name)``; other exceptions (bugs) propagate, and a
    non-finite value returned silently is reported as 'unexpected'."""
    try:
        out = fn(*args)
    except SingularMassMatrixError:
        return None, "SingularMassMatrixError"
    except NonFiniteResultError:
        return None, "NonFiniteResultError"
    except MbgenError as exc:
        return None, f"{type(exc).__name__}"
    if out is not None and not np.all(np.isfinite(out)):
        return None, "unexpected non-finite values returned"
    return out, ""


def _sensitivity(model, t, x, p) -> float:
    """``max_i s_i`` of the bound (``inf`` when a Jacobian cannot be evaluated)."""
    total = np.zeros(model.n_x)
    J, err = try_call(model.jacobian, t, x, p)
    if err:
        return math.inf
    total += np.abs(J) @ np.abs(x)
    if Output.PARAMETER_JACOBIAN in model.outputs and model.n_p:
        Jp, err = try_call(model.parameter_jacobian, t, x, p)
        if err:
            return math.inf
        total += np.abs(Jp) @ _parameter_scale(model, p, Jp.shape[1])
    if Output.TIME_DERIVATIVE in model.outputs:
        ft, err = try_call(model.time_derivative, t, x, p)
        if err:
            return math.inf
        total += np.abs(ft) * abs(t)
    return float(total.max())


def _parameter_scale(model, p, n_columns: int) -> np.ndarray:
    """``|p|`` for the parameter Jacobian's columns.

    The parameter Jacobian leaves out parameters that ``M``, ``F`` and ``G`` do
    not contain (e.g. a height that only enters ``V``); its labels
    ``d(x')/d(name)`` name the columns.  When they cannot be matched, every
    column gets ``max |p|`` (a larger, safe bound).
    """
    if n_columns == model.n_p:
        return np.abs(p)
    info = [f for f in model.rendered.functions if str(f.output) in
            (Output.PARAMETER_JACOBIAN.value, str(Output.PARAMETER_JACOBIAN))]
    labels = getattr(info[0], "out_labels", ()) if info else ()
    names = list(dict.fromkeys(re.findall(r"/d\(([^)]*)\)", " ".join(labels))))
    if len(names) == n_columns and all(n in model.parameter_names for n in names):
        return np.abs(np.array([p[model.parameter_names.index(n)] for n in names]))
    return np.full(n_columns, float(np.abs(p).max()))


def evaluate_point(model, hp: HighPrecision, t: float, x, p, values: Mapping[str, float],
                   safety: float = FP_SAFETY) -> PointResult:
    """Compiled RHS vs the 50-digit reference at ``(t, x, p)``.

    ``values`` holds every parameter by name (those missing from ``model``'s
    layout included); states are named by ``model.state_names``.
    """
    x = np.asarray(x, dtype=float)
    p = np.asarray(p, dtype=float)
    named = dict(values)
    named.update(zip(model.state_names, x.tolist()))
    named.update(zip(model.parameter_names, p.tolist()))
    ref = hp.evaluate(t, named)
    f, error = try_call(model.rhs, t, x, p)
    if f is None or ref.f is None:
        return PointResult(f, error, ref)
    with mpmath.workdps(hp.dps):
        diff = max(abs(mpmath.mpf(float(a)) - b) for a, b in zip(f, ref.f))
        scale = max(abs(b) for b in ref.f)
    fnorm = float(scale)
    return PointResult(f, error, ref, float(diff), fnorm,
                       cond_term=safety * EPS * ref.cond * fnorm,
                       input_term=safety * EPS * _sensitivity(model, t, x, p),
                       formula_term=FORMULA_SAFETY * ref.formula_error)


POINT_BOUND = "err <= C eps (cond(M)|f| + s) + 30 e_formula"


def numerically_singular(cond: float, safety: float = FP_SAFETY) -> bool:
    """Whether ``C eps cond(M) >= 1``: both a finite result and a singular-matrix error are
    then accepted (see the module)."""
    return safety * EPS * cond >= 1.0


def judge_point(pr: PointResult, safety: float = FP_SAFETY) -> tuple[bool, str, str, str]:
    """``(ok, figure, bound, reason)`` of a point check (rules in the module docstring)."""
    ref = pr.reference
    bound = POINT_BOUND
    if pr.error.startswith("unexpected"):
        return False, "compiled RHS failed", bound, pr.error
    if not ref.positive_definite:
        return _judge_singular_mass_matrix(pr)
    singular = numerically_singular(ref.cond, safety)
    if ref.f is None:
        fig = f"reference f {ref.problem}, cond(M) {fmt_g(ref.cond)}"
        want = "reported as an mbgen error"
        if pr.error:
            return True, fig, want, f"{ref.problem}: {pr.error}"
        return False, fig, want, "a finite result where the reference is not finite"
    if pr.f is None:
        return _judge_error_for_finite_reference(pr, singular)
    fig = f"rel err {fmt_g(pr.rel_err)} <= {fmt_g(pr.rel_allowed)}, cond(M) {fmt_g(ref.cond)}"
    if pr.abs_err <= pr.allowed:
        if singular:
            reason = "numerically singular; finite result"
        elif pr.formula_limited:
            reason = (f"formula-limited: formula loses "
                      f"{fmt_g(_ratio(ref.formula_error, pr.fnorm))} in double")
        else:
            reason = "within bound"
        return True, fig, bound, reason
    return False, fig, bound, f"error {fmt_g(pr.abs_err)} exceeds {fmt_g(pr.allowed)}"


def _judge_singular_mass_matrix(pr: PointResult) -> tuple[bool, str, str, str]:
    """:func:`judge_point` where the 50-digit mass matrix is not positive definite: only a
    :class:`SingularMassMatrixError` passes."""
    fig = f"M {pr.reference.problem} (50 digits)"
    want = "reported as SingularMassMatrixError"
    if pr.error == "SingularMassMatrixError":
        return True, fig, want, f"not positive definite: {pr.error}"
    if pr.error:
        return False, fig, want, f"reported as {pr.error}, not as a singular mass matrix"
    return False, fig, want, "a result was returned for a singular mass matrix"


def _judge_error_for_finite_reference(pr: PointResult,
                                      singular: bool) -> tuple[bool, str, str, str]:
    """:func:`judge_point` where the compiled RHS gave no result (an mbgen error) but the
    reference is finite: accepted when numerically singular, or on overflow."""
    ref = pr.reference
    fig = f"cond(M) {fmt_g(ref.cond)}"
    if singular and pr.error in ("SingularMassMatrixError", "SingularConstraintError"):
        return True, fig, "finite, or a singular-matrix error when C eps cond(M) >= 1", \
            f"numerically singular: {pr.error}"
    huge = max(abs(float(v)) for v in ref.f) > 1e300
    if huge and pr.error == "NonFiniteResultError":
        return True, fig, "finite, or NonFiniteResultError on overflow", \
            "reference overflows double: NonFiniteResultError"
    return False, fig, POINT_BOUND, f"spurious {pr.error} (reference is finite)"


def check_point(model, hp: HighPrecision, t: float, x, p, values: Mapping[str, float], *,
                kind: str = "fp", name: str = "point") -> Case:
    """A :class:`Case` comparing the compiled RHS with the 50-digit reference at one point."""
    start = time.perf_counter()
    pr = evaluate_point(model, hp, t, x, p, values)
    ok, figure, bound, reason = judge_point(pr)
    data = {"rel_err": pr.rel_err, "abs_err": pr.abs_err, "allowed": pr.allowed,
            "cond": pr.reference.cond, "formula_error": pr.reference.formula_error,
            "cond_term": pr.cond_term, "input_term": pr.input_term,
            "formula_term": pr.formula_term, "formula_limited": float(pr.formula_limited),
            "fnorm": pr.fnorm,
            "positive_definite": float(pr.reference.positive_definite)}
    return Case(kind, name, figure, bound, ok, reason, data, time.perf_counter() - start)
