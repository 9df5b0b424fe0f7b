r"""Numerical stress suite: stiffness, extreme parameters, singular configurations, long runs
and floating point, for one scene.

``stress(scene)`` compiles the scene once (all parameters free, so any of them can
be varied at run time), generates the cases that apply to it from a list of case
specifications, runs them and returns a :class:`StressReport`: one :class:`Case`
per row with what was measured (the *figure*), the *bound* it had to meet, the
verdict and a *reason*.  Every case either meets its stated bound or fails with
a named reason; integrators that stop at a step or time budget, and states where
the mass matrix is not positive definite, are results with a reason, never
crashes and never NaNs.

Which cases apply (the rules)
-----------------------------
Parameters are classified by name (:func:`classify_parameters`):

* *mass-like*: ``m``, ``m3``, ``mass...``, ``J`` and moments of inertia ``I11``,
  ``Ixx`` (two equal indices); products of inertia (``I12``) are not scaled;
* *length-like*: ``l``, ``L``, ``l2``, ``a``, ``h``, ``s``, ``r``, ``R``, ``d``
  (optionally followed by digits), ``len...``;
* *gravity*: ``g``.

``fp``
    Every scene: the nominal state (the scene's initial state and parameters)
    and seeded random states near it.
``extreme``
    The last mass-like parameter (``full``: also the first) and the last
    length-like parameter scaled by the ratios of the size, relative to the
    others; ``g`` scaled (tiny and huge gravity); every scene: the speeds scaled
    to ``1e3 .. 1e6``.  Mass-like parameters are also set to ``0`` and ``-1``
    times their value (non-physical: the mass matrix is then usually not
    positive definite, which must be *reported* as such).  Each evaluation is
    followed by a short simulation when the state is admissible.
``singular``
    Scenes with a known singular configuration (table :data:`SINGULAR_PATHS`:
    gimbal lock of ``torque_free``, pole of ``spherical_rod``, axis of
    ``paraboloid``, bob on the axis of ``disc_pendulum``, collapsed spring of
    ``spring_pendulum``, meeting masses of ``stiff_chain``, aligned links of
    ``n_link_cart``) are approached with offsets ``delta -> 0`` (and hit).
    Every scene: a scan of each coordinate over ``x0 +- pi`` reporting the
    largest ``cond(M)`` found.
``stiff``
    Scenes whose ``scene()`` has a ``stiffness`` option (``stiff_chain``,
    ``spring_pendulum``), at the stiffnesses of the size: scipy RK45 vs Radau
    and BDF with the compiled Jacobian, and (when compiled in) C dopri5 vs C
    rosenbrock.
``long_run``
    ``conserves_energy`` scenes with energy expressions: drift of ``T + V``;
    scenes with a prescribed motion that do not depend explicitly on time, no
    dampers and no inputs (they run with ``r = 0``): drift of the Jacobi
    integral ``h = T2 - T0 + V``; scenes with ``closed_form``: error against it.

Bounds
------
Floating point (``fp``, and the evaluations of ``extreme`` and ``singular``):
the compiled right-hand side ``f_C`` is compared with ``f_HP``, the *unoptimised*
sympy expressions ``M, F, G`` (the same as :class:`mbgen.LambdifiedModel` uses,
no CSE) evaluated with mpmath at :data:`DPS` = 50 digits and ``M a = F`` solved
at that precision, for the same double inputs.  The bound is a backward-error
model: a stable evaluation returns the exact result for inputs and intermediate
values perturbed by a few units of roundoff ``eps``; the forward error is then at
most ``eps`` times the condition number of the problem, plus whatever the formula
itself loses to cancellation between intermediate values.  With
``s_i = sum_j |df_i/dx_j| |x_j| + sum_k |df_i/dp_k| |p_k| + |df_i/dt| |t|``
(sensitivity to relative perturbations of every input, from the compiled
Jacobians), ``cond(M)`` (2-norm, from the 50-digit eigenvalues) and ``e_formula``
(the error of evaluating the *same unoptimised formula* and solve in 53-bit
arithmetic, estimated from mpmath evaluations at 56..64 bits scaled to 53,
:attr:`Reference.formula_error`)::

    ||f_C - f_HP||_inf <= C eps (cond(M) ||f_HP||_inf + max_i s_i) + 30 e_formula

with ``C = FP_SAFETY = 1e3`` for the number of operations.  The first term bounds
the solve ``M a = F``, the second the propagation of rounding in the inputs (a
stiff spring between two absolute positions, ``k (|x_2 - x_1| - a)``, is only
known to ``k eps |x|``), the third a cancellation *inside* the formula that no
input perturbation shows: a spring of natural length ``l`` stretched by a tiny
``s`` is evaluated as ``k (sqrt((l + s)^2) - l)``, which loses ``k eps l`` whatever
the code generator does.  Such rows pass with the reason ``formula-limited``, so
the loss is visible; what fails is an error more than ~30x above what the
formula permits (CSE, printing or a wrong expression).  Measured on every
built-in scene at ``full`` size (395 points): the compiled error never exceeded
``0.4 eps (cond(M) |f| + s)`` except where the formula cancels, and there it was
``0.1 .. 0.9 e_formula``; so both factors leave a margin of 30x or more, while
an error of ``1e-8`` injected into ``F`` fails at the nominal state.

Where ``C eps cond(M) >= 1`` the mass matrix is *numerically singular*: both a
finite result and :class:`~mbgen.errors.SingularMassMatrixError` are accepted.
Where the 50-digit ``M`` is not positive definite, the compiled model must raise
``SingularMassMatrixError`` (and a C integrator must stop with status
``NOT_POSITIVE_DEFINITE``); where the 50-digit ``f`` is not finite,
``NonFiniteResultError``.

Stiff: Radau and BDF with the compiled Jacobian (and C rosenbrock) must succeed,
and every method that finished must agree with Radau on the final state within
``1e3 rtol`` (relative to ``max(1, |x|)``); explicit methods must finish or stop at
the step/time budget (reason ``budget``); the explicit/implicit step ratio at the
largest stiffness must be at least 10 and not below the ratio at the smallest.

Long runs: relative drift ``max|E - E_0| / max(|T| + |V|) <= 1e-6`` at ``rtol =
1e-10`` (the same for the Jacobi integral); closed form: ``max|x - x_cf| /
max|x_cf| <= 1e-7`` at ``rtol = 1e-10``.

Short simulations (after ``extreme`` evaluations): over ``min(T, 10 tau)`` (``tau``
the fastest time scale at the start, :func:`time_scale`), Radau with the Jacobian
must succeed; DOP853 must agree within ``1e-5 max(1, |x|)`` or stop at its budget;
energy drift ``<= 1e-6`` for conservative scenes (both at ``rtol = 1e-8``).

The scene is compiled from its equations with every parameter free (a scene's
``fixed`` parameters and input selection are ignored, inputs are zero), with
``rhs, mass_matrix, jacobian, parameter_jacobian, time_derivative, energy`` and,
when this mbgen has them, the C integrators ``dopri5`` and ``rosenbrock``.  BLAS
runs on one thread (``threadpoolctl``) for the whole suite, so timings are
comparable.

Example
-------
>>> report = stress("stiff_chain", size="ci")          # doctest: +SKIP
>>> print(report.format()); report.ok                   # doctest: +SKIP
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Sequence

import mpmath
import numpy as np
import sympy as sm

from .errors import (IntegrationError, MbgenError, NonFiniteResultError,
                     SceneError, SingularMassMatrixError)
from .outputs import Output
from .scene import Scene, builtin_names, load_scene, scene_options

#: Unit roundoff of float64.
EPS = float(np.finfo(float).eps)
#: Safety factor of the floating-point bound (see the module docstring).
FP_SAFETY = 1e3
#: Digits of the high-precision reference.
DPS = 50
#: Precisions (bits) at which the formula's own rounding error is sampled.
FORMULA_BITS = (56, 58, 60, 62, 64)
#: Factor on that estimate in the floating-point bound.
FORMULA_SAFETY = 30.0
#: C status codes of the generated code (see :mod:`mbgen.render`).
STATUS_NOT_POSITIVE_DEFINITE = 1
STATUS_MAX_STEPS = 4

Progress = Callable[[str], None]


# =============================================================================== report
@dataclass(frozen=True)
class Case:
    """One row of the report.

    Attributes
    ----------
    kind : str
        ``"fp"``, ``"extreme"``, ``"singular"``, ``"stiff"`` or ``"long_run"``.
    name : str
        What was varied, e.g. ``"k=1e6 RK45"`` or ``"m3 x1e-6"``.
    figure : str
        What was measured.
    bound : str
        What it had to meet.
    ok : bool
        Whether it met the bound.
    reason : str
        Why (the named outcome: ``"within bound"``, ``"budget: ..."``,
        ``"not positive definite: SingularMassMatrixError"``, ...).
    data : mapping str -> float
        The measured numbers (steps, errors, condition numbers, ...).
    seconds : float
        Wall time of the case.
    """

    kind: str
    name: str
    figure: str
    bound: str
    ok: bool
    reason: str
    data: Mapping[str, float] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def verdict(self) -> str:
        return "ok" if self.ok else "FAIL"


@dataclass(frozen=True)
class StressReport:
    """The cases run on one scene.

    Attributes
    ----------
    scene : str
    size : str
        ``"ci"`` or ``"full"``.
    cases : tuple of Case
    notes : tuple of str
        What was skipped and why (e.g. C integrators not compiled in).
    seconds : float
        Total wall time, compilation included.
    """

    scene: str
    size: str
    cases: tuple[Case, ...]
    notes: tuple[str, ...] = ()
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        """True when every case met its bound."""
        return all(c.ok for c in self.cases)

    @property
    def kinds(self) -> set[str]:
        """The case kinds present."""
        return {c.kind for c in self.cases}

    @property
    def failures(self) -> tuple[Case, ...]:
        return tuple(c for c in self.cases if not c.ok)

    def find(self, kind: str, name: str | None = None) -> list[Case]:
        """Cases of ``kind`` whose name contains ``name`` (all of that kind when None)."""
        return [c for c in self.cases if c.kind == kind and (name is None or name in c.name)]

    def format(self, width: int = 64) -> str:
        """A terminal table: case, figure, bound, verdict, reason (long cells are cut)."""
        rows = [(f"{c.kind}: {c.name}", c.figure, c.bound, c.verdict, c.reason)
                for c in self.cases]
        head = ("case", "figure", "bound", "verdict", "reason")
        cut = [tuple(_cut(cell, width) for cell in row) for row in rows]
        widths = [max(len(r[i]) for r in cut + [head]) for i in range(5)]
        widths[-1] = len(head[-1])  # the reason is last: no padding
        line = "  ".join("-" * w for w in widths[:-1]) + "  " + "-" * 6

        def fmt(row):
            return "  ".join(cell.ljust(w) for cell, w in zip(row[:-1], widths[:-1])) + \
                "  " + row[-1]

        n_fail = len(self.failures)
        out = [f"stress {self.scene} ({self.size}): {len(self.cases)} cases, "
               f"{n_fail} failed, {self.seconds:.1f} s", fmt(head), line]
        out += [fmt(r) for r in cut]
        out += [f"note: {n}" for n in self.notes]
        out.append("PASSED" if self.ok else "FAILED: " + ", ".join(
            f"{c.kind}: {c.name}" for c in self.failures))
        return "\n".join(out)


def _cut(text: str, width: int) -> str:
    return text if len(text) <= width else text[:width - 1] + "~"


def _sci(v: float) -> str:
    """Compact notation: 1e6, 2.5e-3, 0, -1, 2.5."""
    if v == 0 or 0.1 <= abs(v) < 1e3:
        return f"{v:g}"
    mant, exp = f"{v:.1e}".split("e")
    mant = mant.rstrip("0").rstrip(".")
    return f"{mant}e{int(exp)}"


def _g(v: float) -> str:
    return f"{v:.2g}" if np.isfinite(v) else str(v)


# =============================================================================== sizes
@dataclass(frozen=True)
class Size:
    """Case grid of one size (``ci`` or ``full``)."""

    stiffness: tuple[float, ...]
    stiff_horizon: float          # fraction of the scene's t_span for stiff runs
    step_budget: int              # accepted steps of a scipy explicit run
    wall_budget: float            # seconds of one scipy run
    ratios: tuple[float, ...]     # mass and length scalings
    speeds: tuple[float, ...]
    gravity: tuple[float, ...]
    offsets: tuple[float, ...]    # distances to a singular configuration
    long_factor: float            # long runs over long_factor * t_span
    random_states: int
    scan_points: int
    first_and_last: bool          # scale the first mass-like parameter too


SIZES = {
    "ci": Size(stiffness=(1e4, 1e6, 1e8), stiff_horizon=0.25, step_budget=20_000,
               wall_budget=5.0, ratios=(1e-6, 1e6), speeds=(1e3, 1e6), gravity=(1e-6, 1e6),
               offsets=(1e-2, 1e-6, 1e-12, 0.0), long_factor=1.0, random_states=3,
               scan_points=16, first_and_last=False),
    "full": Size(stiffness=(1e4, 1e5, 1e6, 1e7, 1e8), stiff_horizon=1.0, step_budget=200_000,
                 wall_budget=30.0, ratios=(1e-6, 1e-3, 1e3, 1e6), speeds=(1e3, 1e4, 1e5, 1e6),
                 gravity=(1e-6, 1e-3, 1e3, 1e6),
                 offsets=(1e-1, 1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14, 0.0),
                 long_factor=10.0, random_states=20, scan_points=64, first_and_last=True),
}
NON_PHYSICAL = (0.0, -1.0)

STIFF_RTOL, STIFF_ATOL = 1e-6, 1e-9
LONG_RTOL, LONG_ATOL = 1e-10, 1e-12
DRIFT_BOUND = 1e-6
CLOSED_FORM_BOUND = 1e-7
SIM_RTOL = 1e-8
SIM_AGREE = 1e-5
RATIO_BOUND = 10.0


# =============================================================================== parameters
_MASS = re.compile(r"^(m|mass\w*|J|I([0-9xyz])\2)\d*$|^m_?\d+$")
_LENGTH = re.compile(r"^(l|L|a|h|s|r|R|d|len\w*)_?\d*$")


def classify_parameters(names: Sequence[str]) -> dict[str, list[str]]:
    """Group parameter names into ``mass`` (and moments of inertia), ``length`` and ``gravity``.

    Parameters
    ----------
    names : sequence of str
        Parameter names in layout order.

    Returns
    -------
    dict
        ``{"mass": [...], "length": [...], "gravity": [...]}`` in layout order.
    """
    out = {"mass": [], "length": [], "gravity": []}
    for n in names:
        if n == "g":
            out["gravity"].append(n)
        elif _MASS.match(n):
            out["mass"].append(n)
        elif _LENGTH.match(n):
            out["length"].append(n)
    return out


# =============================================================================== high precision
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


# =============================================================================== context
@dataclass
class Context:
    """Everything the cases share: the scene, the compiled model, the reference, the size."""

    scene: Scene
    source: str | None            # built-in name or scene file, for reloading with options
    result: object                # PipelineResult
    model: object                 # CompiledModel
    hp: HighPrecision
    equations: object             # the unoptimised equations behind hp
    size: Size
    size_name: str
    values: dict[str, float]      # nominal parameter values by name
    x0: np.ndarray
    t0: float
    span: tuple[float, float]
    c_integrators: bool
    outputs: tuple
    cache: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)

    @property
    def p0(self) -> np.ndarray:
        return self.p_of(self.values)

    def p_of(self, values: Mapping[str, float]) -> np.ndarray:
        """Parameter array in the compiled model's order."""
        return np.array([float(values[n]) for n in self.model.parameter_names])

    def named(self, x, values: Mapping[str, float]) -> dict[str, float]:
        """States (by the model's names), parameters and zero inputs as one name -> value dict."""
        out = dict(values)
        out.update(zip(self.model.state_names, np.asarray(x, dtype=float).tolist()))
        return out


def _source_of(scene: Scene, given: str | None) -> str | None:
    if given:
        return given
    if scene.name in builtin_names():
        return scene.name
    if scene.source and scene.source.endswith(".py"):
        return scene.source
    return None


def _wanted_outputs(equations) -> list[Output]:
    outs = [Output.RHS, Output.MASS_MATRIX, Output.JACOBIAN, Output.TIME_DERIVATIVE]
    if equations.kinetic_energy is not None:
        outs.append(Output.ENERGY)
    if equations.layout.n_p:
        outs.append(Output.PARAMETER_JACOBIAN)
    return outs


def c_integrators_available() -> bool:
    """True when this mbgen has ``CompiledModel.integrate`` and the integrator templates."""
    import importlib.util

    from .runtime import CompiledModel

    return callable(getattr(CompiledModel, "integrate", None)) and \
        importlib.util.find_spec("mbgen.integrators") is not None


def _compile(equations, notes: list[str]):
    """Compile with every output the cases use; add the C integrators when they build."""
    from .pipeline import run

    base = _wanted_outputs(equations)
    if c_integrators_available():
        try:
            res = run(equations, base + [Output.DOPRI5, Output.ROSENBROCK])
            return res, True
        except (MbgenError, ImportError, AttributeError) as exc:
            notes.append(f"C integrators did not build ({type(exc).__name__}: {exc}); "
                         f"C cases skipped")
    else:
        notes.append("C integrators (CompiledModel.integrate) not available in this mbgen; "
                     "C dopri5/rosenbrock cases skipped")
    return run(equations, base), False


def make_context(scene: Scene | str, size: str = "ci", notes: list[str] | None = None) -> Context:
    """Load (if named) and compile ``scene`` for the suite; see :func:`stress`."""
    from .pipeline import equations_of

    if size not in SIZES:
        raise ValueError(f"size must be one of {sorted(SIZES)}, got {size!r}")
    notes = [] if notes is None else notes
    given = scene if isinstance(scene, str) else None
    scn = load_scene(scene) if isinstance(scene, str) else scene
    equations = equations_of(scn)
    result, has_c = _compile(equations, notes)
    model = result.compiled
    reference_eq = getattr(result, "baked", None) or result.equations
    values = {**{k: float(v) for k, v in scn.parameters.items()},
              **{k: float(v) for k, v in getattr(scn, "fixed", {}).items()}}
    x0 = scn.x0(model.layout)
    return Context(scene=scn, source=_source_of(scn, given), result=result, model=model,
                   hp=HighPrecision(reference_eq), equations=reference_eq, size=SIZES[size],
                   size_name=size,
                   values=values, x0=x0, t0=float(scn.t_span[0]),
                   span=(float(scn.t_span[0]), float(scn.t_span[1])), c_integrators=has_c,
                   outputs=tuple(model.outputs), notes=notes)


# =============================================================================== point checks
@dataclass(frozen=True)
class PointResult:
    """The compiled RHS at one point next to the reference, and the floating-point bound.

    ``abs_err = ||f_C - f_HP||_inf``; the allowed error is the sum of three
    terms (absolute): ``cond_term = C eps cond(M) ||f||``, ``input_term = C eps
    max_i s_i`` and ``formula_term = FORMULA_SAFETY * formula_error``.
    """

    f: np.ndarray | None
    error: str                # "" or the mbgen exception name (or "unexpected ...")
    reference: Reference
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


def _call(fn, *args):
    """``(value, "")`` or ``(None, error name)``; non-mbgen exceptions are named 'unexpected'."""
    try:
        out = fn(*args)
    except SingularMassMatrixError:
        return None, "SingularMassMatrixError"
    except NonFiniteResultError:
        return None, "NonFiniteResultError"
    except MbgenError as exc:
        return None, f"{type(exc).__name__}"
    except Exception as exc:  # noqa: BLE001 - reported, never raised
        return None, f"unexpected {type(exc).__name__}: {exc}"
    if out is not None and not np.all(np.isfinite(out)):
        return None, "unexpected non-finite values returned"
    return out, ""


def _sensitivity(model, t, x, p) -> float:
    """``max_i s_i`` of the bound (``inf`` when a Jacobian cannot be evaluated)."""
    total = np.zeros(model.n_x)
    J, err = _call(model.jacobian, t, x, p)
    if err:
        return math.inf
    total += np.abs(J) @ np.abs(x)
    if Output.PARAMETER_JACOBIAN in model.outputs and model.n_p:
        Jp, err = _call(model.parameter_jacobian, t, x, p)
        if err:
            return math.inf
        total += np.abs(Jp) @ _parameter_scale(model, p, Jp.shape[1])
    if Output.TIME_DERIVATIVE in model.outputs:
        ft, err = _call(model.time_derivative, t, x, p)
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
    f, error = _call(model.rhs, t, x, p)
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


def judge_point(pr: PointResult, safety: float = FP_SAFETY) -> tuple[bool, str, str, str]:
    """``(ok, figure, bound, reason)`` of a point check (rules in the module docstring)."""
    ref = pr.reference
    bound = POINT_BOUND
    if pr.error.startswith("unexpected"):
        return False, "compiled RHS failed", bound, pr.error
    if not ref.positive_definite:
        fig = f"M {ref.problem} (50 digits)"
        want = "reported as SingularMassMatrixError"
        if pr.error == "SingularMassMatrixError":
            return True, fig, want, f"not positive definite: {pr.error}"
        if pr.error:
            return False, fig, want, f"reported as {pr.error}, not as a singular mass matrix"
        return False, fig, want, "a result was returned for a singular mass matrix"
    numerically_singular = safety * EPS * ref.cond >= 1.0
    if ref.f is None:
        fig = f"reference f {ref.problem}, cond(M) {_g(ref.cond)}"
        want = "reported as an mbgen error"
        if pr.error:
            return True, fig, want, f"{ref.problem}: {pr.error}"
        return False, fig, want, "a finite result where the reference is not finite"
    if pr.f is None:
        fig = f"cond(M) {_g(ref.cond)}"
        if numerically_singular and pr.error == "SingularMassMatrixError":
            return True, fig, "finite, or SingularMassMatrixError when C eps cond(M) >= 1", \
                f"numerically singular: {pr.error}"
        huge = max(abs(float(v)) for v in ref.f) > 1e300
        if huge and pr.error == "NonFiniteResultError":
            return True, fig, "finite, or NonFiniteResultError on overflow", \
                "reference overflows double: NonFiniteResultError"
        return False, fig, bound, f"spurious {pr.error} (reference is finite)"
    fig = f"rel err {_g(pr.rel_err)} <= {_g(pr.rel_allowed)}, cond(M) {_g(ref.cond)}"
    if pr.abs_err <= pr.allowed:
        if numerically_singular:
            reason = "numerically singular; finite result"
        elif pr.formula_limited:
            reason = (f"formula-limited: formula loses "
                      f"{_g(_ratio(ref.formula_error, pr.fnorm))} in double")
        else:
            reason = "within bound"
        return True, fig, bound, reason
    return False, fig, bound, f"error {_g(pr.abs_err)} exceeds {_g(pr.allowed)}"


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


# =============================================================================== integration
@dataclass(frozen=True)
class Run:
    """One integration: how it ended and what it cost.

    ``status`` is ``"done"``, ``"budget"`` (step or time budget reached) or
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
              max_steps: int, wall_budget: float, record: bool = True) -> Run:
    """Step a scipy solver (``RK45``, ``DOP853``, ``Radau``, ``BDF``) with a step and time budget.

    Errors of the right-hand side (an mbgen error, e.g. a singular mass
    matrix reached) end the run with status ``"failed"`` and the error named.
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
            if steps >= max_steps or time.perf_counter() - start > wall_budget:
                status = "budget"
                message = f"{max_steps} steps" if steps >= max_steps else f"{wall_budget:g} s"
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
        code = re.search(r"_([A-Z_]+):", str(exc))
        msg = f"{max_steps} steps" if status == "budget" else \
            f"status {exc.status} {code.group(1) if code else ''} at t={t_end:.3g}"
        return Run(f"C {method}", status, msg, np.array([t_out[0], t_end]),
                   np.array([x0, np.full(len(x0), np.nan)]), max_steps if status == "budget"
                   else 0, 0, 0, 0, time.perf_counter() - start)
    x = np.asarray(res.x)
    return Run(f"C {method}", "done", str(getattr(res, "status", "")), np.asarray(res.t), x,
               int(res.n_steps), int(res.n_rhs), int(getattr(res, "n_jac", 0)),
               int(getattr(res, "n_lu", 0)), float(getattr(res, "wall_time", 0.0)) or
               time.perf_counter() - start)


def _rel_diff(a, b) -> float:
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / max(1.0, np.abs(b).max()))


# =============================================================================== stiff cases
def _stiff_scene(ctx: Context, k: float) -> Scene:
    options = {key: v for key, v in dict(ctx.scene.options).items() if key != "stiffness"}
    return load_scene(ctx.source, **options, stiffness=k)


def _stiff_runs(ctx: Context, k: float) -> dict[str, Run]:
    """Every integrator at stiffness ``k`` (cached: the rows of one k share them)."""
    key = ("stiff", k)
    if key in ctx.cache:
        return ctx.cache[key]
    scn = _stiff_scene(ctx, k)
    model = ctx.model
    if tuple(scn.x0(model.layout).shape) != tuple(ctx.x0.shape):
        raise SceneError("the scene's states change with the stiffness option")
    values = {**ctx.values, **{n: float(v) for n, v in scn.parameters.items()}}
    p, x0 = ctx.p_of(values), scn.x0(model.layout)
    t0, t1 = float(scn.t_span[0]), float(scn.t_span[1])
    span = (t0, t0 + ctx.size.stiff_horizon * (t1 - t0))
    f, jac = model.bind(p), model.bind(p, output=Output.JACOBIAN)
    sz = ctx.size
    runs = {}
    for method in ("Radau", "BDF", "RK45"):
        implicit = method != "RK45"
        runs[method] = scipy_run(method, f, jac, span, x0, rtol=STIFF_RTOL, atol=STIFF_ATOL,
                                 max_steps=10 * sz.step_budget if implicit else sz.step_budget,
                                 wall_budget=sz.wall_budget, record=False)
    if ctx.c_integrators:
        for method in ("rosenbrock", "dopri5"):
            runs[f"C {method}"] = c_run(model, method, list(span), x0, p, rtol=STIFF_RTOL,
                                        atol=STIFF_ATOL, max_steps=10 * sz.step_budget)
    ctx.cache[key] = runs
    return runs


IMPLICIT = {"RK45": "Radau", "C dopri5": "C rosenbrock"}


def _run_figure(r: Run) -> str:
    fig = f"{r.steps} steps, {r.nfev} f"
    if r.njev:
        fig += f", {r.njev} J, {r.nlu} LU"
    return fig + f", {r.seconds:.2f} s"


def stiff_case(ctx: Context, k: float, method: str) -> list[Case]:
    """One integrator at stiffness ``k``: cost, and agreement with Radau."""
    runs = _stiff_runs(ctx, k)
    r, ref = runs[method], runs["Radau"]
    name = f"k={_sci(k)} {method}" + (" +jac" if method in ("Radau", "BDF", "C rosenbrock")
                                      else "")
    implicit = method not in IMPLICIT
    tol = 1e3 * STIFF_RTOL
    data = {"steps": r.steps, "nfev": r.nfev, "njev": r.njev, "nlu": r.nlu, "seconds": r.seconds,
            "t_reached": r.t_reached, "budget": float(r.status == "budget")}
    fig = _run_figure(r)
    if not implicit:
        base = runs[IMPLICIT[method]]
        ratio = r.steps / max(base.steps, 1)
        data["ratio"] = ratio
        fig += f"; {'>=' if r.status == 'budget' else ''}{ratio:.3g}x {IMPLICIT[method]}"
    if implicit:
        bound = f"succeeds; |x_T - x_T(Radau)| <= {tol:g} max(1,|x|)"
    else:
        bound = f"succeeds (agrees to {tol:g}) or stops at budget"
    if r.status == "failed":
        ok, reason = False, f"failed: {r.message}"
    elif r.status == "budget":
        ok = not implicit
        reason = (f"budget: {r.message} reached at t={r.t_reached:.3g} of "
                  f"{ref.t_reached if ref.status == 'done' else float('nan'):.3g}")
    elif ref.status != "done":
        ok, reason = False, "no Radau reference"
    else:
        d = _rel_diff(r.final, ref.final)
        data["diff"] = d
        ok = d <= tol
        reason = f"agrees with Radau to {_g(d)}" if ok else f"differs from Radau by {_g(d)}"
        if method == "Radau":
            reason = "succeeded"
    # the runs of one stiffness are shared (cached): a row's time is its own run's
    return [Case("stiff", name, fig, bound, ok, reason, data, r.seconds)]


def stiff_fp_case(ctx: Context, k: float) -> list[Case]:
    """The compiled RHS vs 50 digits at the start of the stiff run at stiffness ``k``."""
    scn = _stiff_scene(ctx, k)
    values = {**ctx.values, **{n: float(v) for n, v in scn.parameters.items()}}
    return [check_point(ctx.model, ctx.hp, float(scn.t_span[0]), scn.x0(ctx.model.layout),
                        ctx.p_of(values), values, name=f"k={_sci(k)} start")]


def stiff_scaling_case(ctx: Context, method: str) -> list[Case]:
    """Explicit/implicit step ratio across the stiffnesses: it must grow to >= 10."""
    start = time.perf_counter()
    ks = ctx.size.stiffness
    ratios = []
    for k in ks:
        runs = _stiff_runs(ctx, k)
        ratios.append(runs[method].steps / max(runs[IMPLICIT[method]].steps, 1))
    fig = ", ".join(f"{r:.3g}x@{_sci(k)}" for r, k in zip(ratios, ks))
    bound = f">= {RATIO_BOUND:g}x at k={_sci(ks[-1])}, not below k={_sci(ks[0])}"
    ok = ratios[-1] >= RATIO_BOUND and ratios[-1] >= ratios[0]
    reason = "explicit cost grows with stiffness" if ok else \
        f"ratio {ratios[-1]:.3g} at the largest stiffness"
    return [Case("stiff", f"{method}/{IMPLICIT[method]} steps", fig, bound, ok, reason,
                 {"ratio_min_k": ratios[0], "ratio_max_k": ratios[-1]},
                 time.perf_counter() - start)]


# =============================================================================== extreme cases
@dataclass(frozen=True)
class Variation:
    """A changed point: parameter values, state and a label."""

    name: str
    values: dict
    x: np.ndarray


def time_scale(model, t, x, p) -> float:
    """The fastest time scale at ``x``: the least of ``1 / rho(J)``, ``max(1, |q_i|) / |q_i'|``
    and ``sqrt(max(1, |q_i|) / |u_i'|)`` (the last two only for ``n_q == n_u``).

    ``rho(J)`` alone can miss a fast scale (at a turning point the Jacobian
    may not show the gravity term); the velocity and acceleration scales
    catch large speeds and forces.
    """
    J, err = _call(model.jacobian, t, x, p)
    f, err_f = _call(model.rhs, t, x, p)
    if err or err_f:
        return math.nan
    scales = []
    rho = float(np.abs(np.linalg.eigvals(J)).max())
    if rho > 0:
        scales.append(1.0 / rho)
    nq, nu = model.layout.n_q, model.layout.n_u
    size = np.maximum(1.0, np.abs(x[:nq]))
    with np.errstate(divide="ignore"):
        scales += list(size / np.abs(f[:nq]))
        if nq == nu:
            scales += list(np.sqrt(size / np.abs(f[nq:])))
    return float(min(scales)) if scales else math.inf


def _energy_series(model, ts, xs, p) -> tuple[np.ndarray, float]:
    TV = np.array([model.energy(t, x, p) for t, x in zip(ts, xs)])
    E = TV.sum(axis=1)
    scale = float(np.abs(TV).sum(axis=1).max())
    return E, scale


def _short_simulation(ctx: Context, v: Variation) -> Case:
    """Radau+jac (must succeed) and DOP853 (agree or budget) over ten fast time scales."""
    start = time.perf_counter()
    model, sz = ctx.model, ctx.size
    p = ctx.p_of(v.values)
    tau = time_scale(model, ctx.t0, v.x, p)
    T = ctx.span[1] - ctx.span[0]
    horizon = min(T, 10.0 * tau) if np.isfinite(tau) and tau > 0 else T
    span = (ctx.t0, ctx.t0 + horizon)
    atol = 1e-12 * max(1.0, float(np.abs(v.x).max()))
    f, jac = model.bind(p), model.bind(p, output=Output.JACOBIAN)
    rad = scipy_run("Radau", f, jac, span, v.x, rtol=SIM_RTOL, atol=atol,
                    max_steps=10 * sz.step_budget, wall_budget=sz.wall_budget)
    dop = scipy_run("DOP853", f, None, span, v.x, rtol=SIM_RTOL, atol=atol,
                    max_steps=sz.step_budget, wall_budget=sz.wall_budget, record=False)
    data = {"horizon": horizon, "radau_steps": rad.steps, "dop853_steps": dop.steps}
    fig = f"{_g(horizon)} s: Radau {rad.steps} steps, DOP853 {dop.steps}"
    conservative = ctx.scene.conserves_energy and Output.ENERGY in model.outputs
    bound = f"Radau ok; DOP853 agrees to {SIM_AGREE:g} or budget" + \
        (f"; drift <= {DRIFT_BOUND:g}" if conservative else "")
    name = f"{v.name} sim"
    if rad.status != "done":
        return Case("extreme", name, fig, bound, False, f"Radau {rad.status}: {rad.message}",
                    data, time.perf_counter() - start)
    if not np.all(np.isfinite(rad.x)):
        return Case("extreme", name, fig, bound, False, "non-finite states", data,
                    time.perf_counter() - start)
    reasons, ok = [], True
    scale = max(1.0, float(np.abs(rad.x).max()))
    if dop.status == "done":
        d = float(np.abs(dop.final - rad.final).max()) / scale
        data["diff"] = d
        fig += f", diff {_g(d)}"
        if d > SIM_AGREE:
            ok = False
            reasons.append(f"DOP853 differs by {_g(d)}")
    elif dop.status == "budget":
        reasons.append(f"DOP853 budget ({dop.message})")
    else:
        ok = False
        reasons.append(f"DOP853 failed: {dop.message}")
    if conservative:
        E, escale = _energy_series(model, rad.t, rad.x, p)
        drift = float(np.abs(E - E[0]).max() / escale) if escale > 0 else 0.0
        data["drift"] = drift
        fig += f", drift {_g(drift)}"
        if drift > DRIFT_BOUND:
            ok = False
            reasons.append(f"energy drift {_g(drift)}")
    return Case("extreme", name, fig, bound, ok, "; ".join(reasons) or "within bound", data,
                time.perf_counter() - start)


def extreme_case(ctx: Context, v: Variation) -> list[Case]:
    """Evaluate at an extreme point (vs 50 digits), then simulate briefly when admissible."""
    case = check_point(ctx.model, ctx.hp, ctx.t0, v.x, ctx.p_of(v.values), v.values,
                       kind="extreme", name=v.name)
    cases = [case]
    if ctx.c_integrators and case.data.get("positive_definite") == 0.0:
        cases.append(_c_not_positive_definite(ctx, v))
    if case.ok and np.isfinite(case.data["rel_err"]) and not case.reason.startswith("numerically"):
        cases.append(_short_simulation(ctx, v))
    return cases


def _c_not_positive_definite(ctx: Context, v: Variation) -> Case:
    """A C integrator started where M is not positive definite must stop with that status."""
    start = time.perf_counter()
    r = c_run(ctx.model, "dopri5", [ctx.t0, ctx.t0 + 1e-3], v.x, ctx.p_of(v.values),
              rtol=1e-6, atol=1e-9, max_steps=1000)
    ok = r.status == "failed" and r.message.startswith(f"status {STATUS_NOT_POSITIVE_DEFINITE} ")
    return Case("extreme", f"{v.name} C dopri5",
                r.message or r.status, "stops with status NOT_POSITIVE_DEFINITE", ok,
                "not positive definite: C status" if ok else f"got {r.status}: {r.message}",
                {}, time.perf_counter() - start)


def extreme_variations(ctx: Context) -> list[Variation]:
    """Scaled masses, lengths, gravity and speeds (rules in the module docstring)."""
    sz, values = ctx.size, ctx.values
    names = [n for n in ctx.model.parameter_names if n in values]
    groups = classify_parameters(names)
    out = []
    masses = groups["mass"]
    chosen = masses[-1:] + (masses[:1] if sz.first_and_last and len(masses) > 1 else [])
    for n in chosen:
        for r in sz.ratios + NON_PHYSICAL:
            out.append(Variation(f"{n} x{_sci(r)}", {**values, n: values[n] * r}, ctx.x0))
    for n in groups["length"][-1:]:
        for r in sz.ratios:
            out.append(Variation(f"{n} x{_sci(r)}", {**values, n: values[n] * r}, ctx.x0))
    for n in groups["gravity"]:
        for r in sz.gravity:
            out.append(Variation(f"{n} x{_sci(r)}", {**values, n: values[n] * r}, ctx.x0))
    L = ctx.model.layout
    u0 = ctx.x0[L.n_q:]
    direction = u0 / np.abs(u0).max() if np.abs(u0).max() > 0 else np.ones(L.n_u)
    for speed in sz.speeds:
        x = ctx.x0.copy()
        x[L.n_q:] = speed * direction
        out.append(Variation(f"speeds {_sci(speed)}", dict(values), x))
    return out


# =============================================================================== singular cases
@dataclass(frozen=True)
class SingularPath:
    """A known singular configuration and how to approach it.

    ``state(x, values, delta)`` returns the state overrides (name -> value) at
    distance ``delta`` from the singular configuration (``delta = 0``: on it);
    ``x`` and ``values`` are the nominal state and parameters by name.
    """

    name: str
    state: Callable[[Mapping[str, float], Mapping[str, float], float], dict]
    note: str = ""


def _chain_aligned(x, values, d):
    links = sorted(int(n[1:]) for n in x if re.fullmatch(r"q\d+", n) and n != "q0")
    return {f"q{i}": 0.3 + d * j for j, i in enumerate(links)}


#: Known singular configurations of the built-in scenes (scene name -> paths).
SINGULAR_PATHS: dict[str, tuple[SingularPath, ...]] = {
    "torque_free": (SingularPath("gimbal lock q2->pi/2",
                                 lambda x, v, d: {"q2": math.pi / 2 - d},
                                 "q' = G(q) u has 1/cos(q2); M is the constant inertia"),),
    "spherical_rod": (SingularPath("pole q2->0", lambda x, v, d: {"q2": d},
                                   "M = diag(J sin(q2)^2, J)"),),
    "paraboloid": (SingularPath("axis q1->0", lambda x, v, d: {"q1": d},
                                "M = diag(m (1 + 4 k^2 q1^2), m q1^2)"),),
    "disc_pendulum": (SingularPath("bob on axis s+l sin(q2)->0",
                                   lambda x, v, d: {"q2": -math.asin(v["s"] / v["l"]) + d},
                                   "M11 = m (s + l sin q2)^2"),),
    "spring_pendulum": (SingularPath("collapsed spring s->-l", lambda x, v, d: {"s": -v["l"] + d},
                                     "M = diag(m (l + s)^2, m); spring direction undefined"),),
    "stiff_chain": (SingularPath("masses meet x2->x1", lambda x, v, d: {"x2": x["x1"] + d},
                                 "line element direction (x2 - x1)/|x2 - x1| undefined"),),
    "n_link_cart": (SingularPath("links aligned q_i->q_1", _chain_aligned,
                                 "absolute angles: M stays positive definite"),),
}


def singular_case(ctx: Context, path: SingularPath, delta: float) -> list[Case]:
    """Evaluate at ``delta`` from a singular configuration (vs 50 digits)."""
    x_named = dict(zip(ctx.model.state_names, ctx.x0.tolist()))
    x_named.update(path.state(x_named, ctx.values, delta))
    x = np.array([x_named[n] for n in ctx.model.state_names])
    v = Variation(f"{path.name} d={_sci(delta)}", dict(ctx.values), x)
    case = check_point(ctx.model, ctx.hp, ctx.t0, x, ctx.p0, ctx.values, kind="singular",
                       name=v.name)
    if np.isfinite(case.data["fnorm"]):  # how large q', u' grow near the singularity
        case = replace(case, figure=f"|f| {_g(case.data['fnorm'])}; " + case.figure)
    cases = [case]
    if ctx.c_integrators and case.data.get("positive_definite") == 0.0:
        cases.append(replace(_c_not_positive_definite(ctx, v), kind="singular"))
    return cases


def scan_case(ctx: Context, index: int) -> list[Case]:
    """Scan one coordinate over ``x0 +- pi``: every point finite or a named error; worst cond(M)."""
    start = time.perf_counter()
    model, p = ctx.model, ctx.p0
    name = model.state_names[index]
    grid = ctx.x0[index] + np.linspace(-math.pi, math.pi, ctx.size.scan_points)
    worst, worst_x, errors, unexpected = 0.0, None, {}, []
    for value in grid:
        x = ctx.x0.copy()
        x[index] = value
        M, err = _call(model.mass_matrix, ctx.t0, x, p)
        f, err_f = _call(model.rhs, ctx.t0, x, p)
        for e in (err, err_f):
            if e.startswith("unexpected"):
                unexpected.append(f"{name}={value:.3g}: {e}")
            elif e:
                errors[e] = errors.get(e, 0) + 1
        if M is not None:
            c = float(np.linalg.cond(M)) if np.all(np.isfinite(M)) else math.inf
            if not c < worst:
                worst, worst_x = c, x
    fig = f"max cond(M) {_g(worst)}" + (f" at {name}={worst_x[index]:.3g}"
                                         if worst_x is not None else "")
    if errors:
        fig += "; " + ", ".join(f"{k} x{n}" for k, n in errors.items())
    bound = "finite or a named mbgen error"
    cases = [Case("singular", f"scan {name} ({len(grid)} pts)", fig, bound, not unexpected,
                  unexpected[0] if unexpected else "no NaN, no unnamed error",
                  {"max_cond": worst}, time.perf_counter() - start)]
    if worst_x is not None:
        cases.append(check_point(model, ctx.hp, ctx.t0, worst_x, p, ctx.values, kind="singular",
                                 name=f"scan {name} worst point"))
    return cases


# =============================================================================== long runs
def _has_explicit_time(equations) -> bool:
    from .symbolic import free_symbols

    exprs = list(equations.mass_matrix) + list(equations.forcing) + list(equations.kinematics)
    return equations.layout.time in free_symbols(exprs)


def jacobi_applies(ctx: Context) -> bool:
    """Prescribed motion, no explicit time, no dampers, energy available (inputs are zero)."""
    from .model import LineElement, Model

    mdl = ctx.scene.model
    if not isinstance(mdl, Model) or not mdl.prescribed_ or ctx.scene.conserves_energy:
        return False
    if Output.ENERGY not in ctx.model.outputs or _has_explicit_time(ctx.equations):
        return False
    subs = {sm.Symbol(n): v for n, v in ctx.values.items()}
    for load in mdl.loads:
        if isinstance(load, LineElement) and float(sm.sympify(load.damping).subs(subs)) != 0:
            return False
    return True


def _jacobi_series(model, ts, xs, p) -> tuple[np.ndarray, float]:
    """``h = T2 - T0 + V`` along a trajectory, and its scale ``max(|T2| + |T0| + |V|)``."""
    nq = model.layout.n_q
    h, scale = [], 0.0
    for t, x in zip(ts, xs):
        T, V = model.energy(t, x, p)
        x0 = x.copy()
        x0[nq:] = 0.0
        xm = x.copy()
        xm[nq:] = -x[nq:]
        T0 = model.energy(t, x0, p)[0]
        Tm = model.energy(t, xm, p)[0]
        T2 = 0.5 * (T + Tm) - T0
        h.append(T2 - T0 + V)
        scale = max(scale, abs(T2) + abs(T0) + abs(V))
    return np.array(h), scale


def long_run_case(ctx: Context, what: str, integrator: str) -> list[Case]:
    """Drift of the energy or Jacobi integral, or error against the closed form."""
    start = time.perf_counter()
    model, p, sz = ctx.model, ctx.p0, ctx.size
    T = ctx.span[1] - ctx.span[0]
    factor = sz.long_factor if what == "energy" else 1.0
    span = (ctx.t0, ctx.t0 + factor * T)
    if integrator == "DOP853":
        r = scipy_run("DOP853", model.bind(p), None, span, ctx.x0, rtol=LONG_RTOL,
                      atol=LONG_ATOL, max_steps=sz.step_budget * 5,
                      wall_budget=sz.wall_budget * 2)
    else:
        t_out = np.linspace(span[0], span[1], 2001)
        r = c_run(model, "dopri5", t_out, ctx.x0, p, rtol=LONG_RTOL, atol=LONG_ATOL,
                  max_steps=100 * sz.step_budget)
    name = f"{what} {r.method} rtol {LONG_RTOL:g}, {_g(span[1] - span[0])} s"
    data = {"steps": r.steps, "seconds": r.seconds, "t_reached": r.t_reached}
    if r.status == "failed":
        return [Case("long_run", name, _run_figure(r), "succeeds", False,
                     f"failed: {r.message}", data, time.perf_counter() - start)]
    ts, xs = (r.t, r.x) if r.status == "done" else (r.t[:-1], r.x[:-1]) \
        if not np.all(np.isfinite(r.x[-1])) else (r.t, r.x)
    if what == "closed_form":
        exact = np.asarray(ctx.scene.closed_form(ts - ctx.t0, ctx.x0, p))
        err = float(np.abs(xs - exact).max() / max(np.abs(exact).max(), 1e-300))
        bound, value = f"max|x - x_cf|/max|x_cf| <= {CLOSED_FORM_BOUND:g}", err
        fig = f"rel err {_g(err)}; {r.steps} steps, {r.seconds:.2f} s"
        limit = CLOSED_FORM_BOUND
    else:
        series = _energy_series if what == "energy" else _jacobi_series
        E, scale = series(model, ts, xs, p)
        value = float(np.abs(E - E[0]).max() / scale) if scale > 0 else 0.0
        label = "E" if what == "energy" else "h"
        bound = f"max|{label}-{label}0|/scale <= {DRIFT_BOUND:g}"
        fig = f"drift {_g(value)}; {r.steps} steps, {r.seconds:.2f} s"
        limit = DRIFT_BOUND
    data["value"] = value
    ok = value <= limit
    if r.status == "budget":
        reason = f"budget: {r.message} at t={r.t_reached:.3g}; " + \
            ("within bound so far" if ok else "exceeded")
    else:
        reason = "within bound" if ok else f"{_g(value)} exceeds {limit:g}"
    return [Case("long_run", name, fig, bound, ok, reason, data, time.perf_counter() - start)]


# =============================================================================== fp cases
def fp_cases(ctx: Context, which: int) -> list[Case]:
    """The nominal point (``which = 0``) or seeded random point ``which`` near it."""
    if which == 0:
        return [check_point(ctx.model, ctx.hp, ctx.t0, ctx.x0, ctx.p0, ctx.values,
                            name="nominal state")]
    rng = np.random.default_rng(1000 + which)
    x = ctx.x0 + rng.uniform(-0.2, 0.2, ctx.x0.size)
    values = {n: v * rng.uniform(0.9, 1.1) for n, v in ctx.values.items()}
    t = float(rng.uniform(0.0, 1.0))
    return [check_point(ctx.model, ctx.hp, t, x, ctx.p_of(values), values,
                        name=f"random state {which}")]


# =============================================================================== specs
@dataclass(frozen=True)
class CaseSpec:
    """One entry of the case list: ``run(ctx, *args) -> list[Case]``."""

    kind: str
    label: str
    run: Callable[..., list[Case]]
    args: tuple = ()


def case_specs(ctx: Context) -> list[CaseSpec]:
    """The cases that apply to ``ctx.scene`` (rules in the module docstring)."""
    sz = ctx.size
    specs = [CaseSpec("fp", "nominal", fp_cases, (0,))]
    specs += [CaseSpec("fp", f"random {i}", fp_cases, (i,)) for i in range(1, sz.random_states + 1)]
    specs += [CaseSpec("extreme", v.name, extreme_case, (v,)) for v in extreme_variations(ctx)]
    for path in SINGULAR_PATHS.get(ctx.scene.name, ()):
        specs += [CaseSpec("singular", f"{path.name} {_sci(d)}", singular_case, (path, d))
                  for d in sz.offsets]
    specs += [CaseSpec("singular", f"scan {n}", scan_case, (i,))
              for i, n in enumerate(ctx.model.state_names[:ctx.model.layout.n_q])]
    if ctx.source and "stiffness" in _options(ctx.source):
        methods = ["Radau", "BDF", "RK45"] + (["C rosenbrock", "C dopri5"]
                                              if ctx.c_integrators else [])
        for k in sz.stiffness:
            specs.append(CaseSpec("fp", f"k={_sci(k)} start", stiff_fp_case, (k,)))
            specs += [CaseSpec("stiff", f"k={_sci(k)} {m}", stiff_case, (k, m)) for m in methods]
        specs += [CaseSpec("stiff", f"scaling {m}", stiff_scaling_case, (m,))
                  for m in methods if m in IMPLICIT]
    integrators = ["DOP853"] + (["C dopri5"] if ctx.c_integrators else [])
    if ctx.scene.conserves_energy and Output.ENERGY not in ctx.model.outputs:
        ctx.notes.append("conserves_energy but the equations carry no energy: no drift case")
    if ctx.scene.conserves_energy and Output.ENERGY in ctx.model.outputs:
        specs += [CaseSpec("long_run", f"energy {i}", long_run_case, ("energy", i))
                  for i in integrators]
    if jacobi_applies(ctx):
        specs += [CaseSpec("long_run", f"jacobi {i}", long_run_case, ("jacobi", i))
                  for i in integrators]
    if ctx.scene.closed_form is not None:
        specs += [CaseSpec("long_run", f"closed form {i}", long_run_case, ("closed_form", i))
                  for i in integrators]
    return specs


def _options(source: str) -> dict:
    try:
        return scene_options(source)
    except SceneError:
        return {}


# =============================================================================== entry point
def stress(scene: Scene | str, *, size: str = "ci",
           progress: Progress | None = None) -> StressReport:
    """Run the stress suite on a scene.

    Parameters
    ----------
    scene : Scene or str
        A scene, a built-in scene name, or the path of a scene file.
    size : {"ci", "full"}
        ``ci``: a few values of every variation (seconds); ``full``: the whole
        grid (stiffness 1e4..1e8, ratios 1e-6..1e6, long runs over 10 t_span).
    progress : callable(str), optional
        Called with a line before each case.

    Returns
    -------
    StressReport
        ``.ok``, ``.format()``; a case that raises is reported as a failure
        named by the exception, never raised.
    """
    from threadpoolctl import threadpool_limits

    start = time.perf_counter()
    say = progress or (lambda _msg: None)
    notes: list[str] = []
    name = scene if isinstance(scene, str) else scene.name
    say(f"stress {name} ({size}): compiling")
    with threadpool_limits(1):
        ctx = make_context(scene, size, notes)
        specs = case_specs(ctx)
        cases: list[Case] = []
        for i, spec in enumerate(specs, 1):
            say(f"[{i}/{len(specs)}] {spec.kind}: {spec.label}")
            t_case = time.perf_counter()
            try:
                cases += spec.run(ctx, *spec.args)
            except Exception as exc:  # noqa: BLE001 - a case that crashes is a failed case
                cases.append(Case(spec.kind, spec.label, "crashed", "no exception", False,
                                  f"{type(exc).__name__}: {exc}", {},
                                  time.perf_counter() - t_case))
    return StressReport(ctx.scene.name, size, tuple(cases), tuple(notes),
                        time.perf_counter() - start)
