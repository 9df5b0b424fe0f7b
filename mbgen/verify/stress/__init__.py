r"""Numerical stress suite: stiffness, extreme parameters, singular configurations, long runs
and floating point, for one scene.

``stress(scene)`` compiles the scene once (all parameters free, so any of them can
be varied at run time), generates the cases that apply to it from a list of case
specifications, runs them and returns a :class:`StressReport`: one :class:`Case`
per row with what was measured (the *figure*), the *bound* it had to meet, the
verdict and a *reason*.  Every case either meets its stated bound or fails with
a named reason; integrators that stop at a step or evaluation budget, and states
where the mass matrix is not positive definite, are results with a reason, never
crashes and never NaNs.

Budgets and failures
--------------------
The suite's budgets count steps and evaluations of the right-hand side, never seconds
(:class:`~mbgen.verify.stress.context.Size`): a case stops at the same place on any
machine, however loaded.  A failed case says whose failure it is
(:attr:`Case.failure`, set by the case that judged it, never read from its text):
``model`` (the model or generated code missed the bound), ``budget`` (a run stopped at
the suite's budget before the bound could be judged: a harness limit, not a wrong
result) or ``harness`` (the suite could not run the case); the verdict line counts the
three apart, and ``mbgen stress`` prints it.

Progress
--------
``progress`` is called once before the compilation and once before each case, with a
counter ``[i/n]`` of cases: the ``i``-th case of the ``n`` known so far.  A case that
decides others (an extreme point that admits a simulation, a point where ``M`` is not
positive definite, a scan that found its worst point) adds them to ``n`` when it has
run, so the last counter is ``[n/n]`` with ``n`` the cases of the report.

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
    and BDF with the compiled Jacobian, and C dopri5 vs C
    rosenbrock.
``long_run``
    ``conserves_energy`` scenes with energy expressions: drift of ``T + V``;
    scenes with a prescribed motion that do not depend explicitly on time, no
    dampers and no inputs (they run with ``r = 0``): drift of the Jacobi
    integral ``h = T2 - T0 + V``; scenes with ``closed_form``: error against it.

Bounds
------
Each bound is documented in full in the module that checks it:

* floating point (``fp``, and the evaluations of ``extreme`` and ``singular``),
  :mod:`mbgen.verify.stress.precision`: the compiled right-hand side against a
  50-digit reference, ``||f_C - f_HP||_inf <= C eps (cond(M) ||f_HP||_inf +
  max_i s_i) + 30 e_formula``; a mass matrix that is not positive definite
  and a non-finite reference must be reported as such;
* stiff, :mod:`mbgen.verify.stress.stiff`: implicit methods succeed and agree with
  Radau; explicit ones finish or stop at their step or evaluation budget, needing at
  least 10x the steps at the largest stiffness;
* long runs, :mod:`mbgen.verify.stress.long_runs`: drift of ``T + V`` or of the
  Jacobi integral ``<= 1e-6``, error against the closed form ``<= 1e-7``;
* short simulations after the ``extreme`` evaluations,
  :mod:`mbgen.verify.stress.extreme`.

Modules
-------
:mod:`~mbgen.verify.stress.report` (the rows and the table),
:mod:`~mbgen.verify.stress.reference` (the 50-digit reference),
:mod:`~mbgen.verify.stress.precision` (the floating-point bound),
:mod:`~mbgen.verify.stress.context` (sizes, and the scene compiled once),
:mod:`~mbgen.verify.stress.runs` (integrations with a step and evaluation budget), one
module per case kind (:mod:`~mbgen.verify.stress.extreme`,
:mod:`~mbgen.verify.stress.singular`, :mod:`~mbgen.verify.stress.stiff`,
:mod:`~mbgen.verify.stress.long_runs`) and :mod:`~mbgen.verify.stress.cases` (the ``fp``
cases, the case list and the follow-ups).  BLAS runs on one thread (``threadpoolctl``)
for the whole suite, so the reported times are comparable (none is judged).

How to add a case kind
----------------------
1. ``verify/stress/<kind>.py``: a ``<kind>_case(ctx, ...) -> Case`` that measures
   (the *figure*), states its *bound* and gives the verdict with a *reason* (and, when a
   run stopped at its budget, ``stopped`` and ``cause=BUDGET``); the module docstring
   documents the bound in full.
2. ``verify/stress/cases.py``: the rule that says when it applies, in
   :func:`~mbgen.verify.stress.cases.case_specs` (one ``CaseSpec`` per row; a row that
   depends on another's result is a follow-up of that row's spec).
3. This docstring: the kind under "Which cases apply" and its bound under "Bounds".
4. ``tests/verify/test_stress.py``: ``test_ci_suite_passes_with_the_expected_case_kinds``
   fails until the kind is in ``EXPECTED_KINDS`` of the scenes it applies to; add a test
   that its bound catches a fault.

Example
-------
>>> report = stress("stiff_chain", size="ci")          # doctest: +SKIP
>>> print(report.format()); report.ok                   # doctest: +SKIP
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

from ...errors import MbgenError
from ...model.scene import Scene
from .cases import CaseSpec, case_specs
from .context import SIZES, Context, Size, make_context
from .extreme import classify_parameters
from .precision import PointResult, check_point, evaluate_point, judge_point
from .reference import HighPrecision, HighPrecisionValue
from .reference import Reference as Reference  # the old name, for imports written before
from .report import BUDGET, HARNESS, MODEL, Case, StressReport, report_path
from .singular import SINGULAR_PATHS

Progress = Callable[[str], None]


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
        Called with a line before the compilation and before each case (see "Progress").

    Returns
    -------
    StressReport
        ``.ok``, ``.format()``; a case that raises an mbgen error is reported as a
        failure named by the exception, never raised.
    """
    from threadpoolctl import threadpool_limits

    start = time.perf_counter()
    say = progress or (lambda _msg: None)
    notes: list[str] = []
    name = scene if isinstance(scene, str) else scene.name
    say(f"stress {name} ({size}): compiling")
    with threadpool_limits(1):
        ctx = make_context(scene, size, notes)
        cases = run_specs(ctx, case_specs(ctx), say)
    return StressReport(ctx.scene.name, size, tuple(cases), tuple(notes),
                        time.perf_counter() - start)


def run_specs(ctx: Context, specs: Sequence[CaseSpec],
              say: Progress = lambda _msg: None) -> list[Case]:
    """Run ``specs`` in order, each follow-up right after the case that decided it.

    Returns one :class:`Case` per spec run, in that order; ``say`` gets the counter line
    of each (see "Progress").  A spec that raises an mbgen error is a failed case named
    by the exception (its follow-ups are not run); any other exception propagates.
    """
    pending = list(reversed(specs))          # a stack: the next spec last
    cases: list[Case] = []
    while pending:
        spec = pending.pop()
        say(f"[{len(cases) + 1}/{len(cases) + 1 + len(pending)}] {spec.kind}: {spec.label}")
        t_case = time.perf_counter()
        try:
            case = spec.run(ctx, *spec.args)
        except MbgenError as exc:  # a named failure is a failed case; a bug propagates
            cases.append(Case(spec.kind, spec.label, "crashed", "no exception", False,
                              f"{type(exc).__name__}: {exc}", {},
                              time.perf_counter() - t_case))
            continue
        cases.append(case)
        if spec.follow is not None:
            pending.extend(reversed(spec.follow(ctx, case, *spec.args)))
    return cases


__all__ = ["stress", "run_specs", "case_specs", "CaseSpec", "StressReport", "report_path",
           "Case", "MODEL",
           "BUDGET", "HARNESS", "Context", "make_context", "Size", "SIZES",
           "classify_parameters", "HighPrecision", "HighPrecisionValue", "PointResult",
           "evaluate_point", "judge_point", "check_point", "SINGULAR_PATHS"]
