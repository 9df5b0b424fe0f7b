"""Verification: compiled C vs generated Python vs lambdified sympy.

On seeded random states (and random inputs), every generated output is
evaluated three ways: the compiled C, the generated Python module, and a
``sympy.lambdify`` of the *unsliced, unoptimised* equations
(:mod:`mbgen.runtime.lambdified`): the derived equations before the scene's fixed
parameters were baked in and its absent inputs zeroed, called with the fixed
values and zero inputs.  So a slicing or optimisation fault (a dropped output,
a wrongly baked parameter) shows as an error, not as agreement with itself.

The report gives, per output and back end, the largest absolute error, the
largest relative error ``|a - b|_inf / |b|_inf`` against the reference, and how
many samples were compared.  A sample where the reference raises (a singular
mass matrix, a non-finite result) agrees only if the back end raises the same
error, and is then not compared.

The reference is trusted only as far as its arithmetic reaches.  Its linear solves
are nondimensionalised (each speed in its own mass's units, each constraint row of
unit size: :mod:`mbgen.runtime.lambdified`), so the scale of a model costs it nothing (the
rolling disc at ``m = 1e-20`` agrees to 1e-15).  What is left is the conditioning of
the state itself: a solve with condition number ``kappa`` of size ``n`` vouches for a
relative error of ``n kappa u`` only (``u`` the unit roundoff; the reference's
``resolution``).  A sample whose difference is above tolerance but within twice that
(the back end rounds too) is *unresolved*: neither a pass nor a failure (``--rtol 0``
asks for bit-for-bit agreement, where no sample is unresolved).  Every other sample
decides as before, so a real fault (a flipped sign, a dropped term: relative errors of
order one) still fails wherever it shows.  The verdict:

``PASSED``        every output of every back end compared on at least one sample,
                  within tolerance, and no sample where the back ends disagree on failing
                  or the reference could not resolve the difference;
``FAILED``        an error above tolerance on a sample the reference resolves, or a sample
                  where one side fails and the other does not (or fails differently):
                  :class:`~mbgen.errors.CheckFailed`;
``INCONCLUSIVE``  nothing failed, but some output of some back end was compared on no
                  sample at all (every sample failed everywhere: a zero mass, a NaN
                  parameter, a coordinate that appears nowhere), or differed only where
                  the reference's own rounding could explain it (an ill-conditioned state:
                  a four-bar crank of 1e-6): :class:`~mbgen.errors.CheckInconclusive`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..abi import Output
from ..errors import ArgumentError, CheckFailed, CheckInconclusive, MbgenError
from ..pipeline import PipelineResult, run
from ..runtime.base import ModelBase
from ..runtime.lambdified import LambdifiedModel
from ..runtime.python import python_model
from ..symbolic.availability import SENSITIVITIES
from ..symbolic.layout import Layout

#: The columns of ``df/dp``: the parameters of a layout that the equations' motion uses.
_PARAMETER_COLUMNS = SENSITIVITIES[Output.PARAMETER_JACOBIAN].variables


@dataclass(frozen=True)
class ErrorRow:
    """Largest errors of one output of one back end against the reference.

    ``samples`` states were drawn; the back end returned a value at ``evaluated`` of them;
    ``compared`` gave a value in both the back end and the reference; ``both_failed``
    raised the same named error in both; ``mismatched_failures`` failed on one side only,
    or with different errors; ``unresolved`` were above tolerance but within twice the
    reference's ``resolution`` (up to ``unresolved_rel``, with condition numbers up to
    ``condition``); ``exceeded``: the errors of the other compared samples are above
    tolerance (a failure).  ``max_abs`` and ``max_rel`` are over every compared sample.
    """

    output: str
    backend: str
    max_abs: float
    max_rel: float
    samples: int
    mismatched_failures: int
    ok: bool
    compared: int = 0
    both_failed: int = 0
    evaluated: int = 0
    unresolved: int = 0
    unresolved_rel: float = 0.0
    condition: float = 0.0
    exceeded: bool = False

    @property
    def within_tolerance(self) -> bool:
        """Nothing failed: passed, or compared nothing, or differed only where the reference
        could not resolve the difference."""
        return self.ok or (self.mismatched_failures == 0 and not self.exceeded
                           and (self.compared == 0 or self.unresolved > 0))


@dataclass(frozen=True)
class CheckReport:
    """Result of :func:`check`."""

    name: str
    rows: tuple[ErrorRow, ...]
    samples: int
    seed: int
    rtol: float
    atol: float
    reference: str = "lambdify of the unsliced, unoptimised equations"

    @property
    def ok(self) -> bool:
        """Passed: every row compared something and agreed."""
        return bool(self.rows) and all(r.ok for r in self.rows)

    @property
    def inconclusive(self) -> bool:
        """Nothing disagreed, but some output of some back end was never compared."""
        return not self.ok and all(r.within_tolerance for r in self.rows)

    @property
    def verdict(self) -> str:
        return "PASSED" if self.ok else ("INCONCLUSIVE" if self.inconclusive else "FAILED")

    @property
    def max_abs(self) -> float:
        return max((r.max_abs for r in self.rows), default=0.0)

    @property
    def max_rel(self) -> float:
        return max((r.max_rel for r in self.rows), default=0.0)

    def evaluated(self) -> dict[str, int]:
        """Samples compared per back end (the fewest over its outputs)."""
        out: dict[str, int] = {}
        for r in self.rows:
            out[r.backend] = min(out.get(r.backend, r.compared), r.compared)
        return out

    def format(self) -> str:
        lines = [f"check {self.name}: {self.samples} seeded random states (seed {self.seed}), "
                 f"reference = {self.reference}",
                 f"{'output':<19}{'backend':<9}{'max abs err':>13}{'max rel err':>13}"
                 f"{'evaluated':>11}{'compared':>10}{'both fail':>11}  result"]
        for r in self.rows:
            if r.ok:
                verdict = "ok"
            elif r.mismatched_failures:
                verdict = f"FAIL ({r.mismatched_failures} samples disagree on failure)"
            elif r.exceeded:
                verdict = "FAIL"
            elif r.unresolved:
                verdict = (f"UNRESOLVED ({r.unresolved} samples differ by up to rel "
                           f"{r.unresolved_rel:.1e}, within the reference's rounding)")
            else:
                verdict = "NOTHING COMPARED"
            lines.append(f"{r.output:<19}{r.backend:<9}{r.max_abs:13.3e}{r.max_rel:13.3e}"
                         f"{f'{r.evaluated}/{r.samples}':>11}{f'{r.compared}/{r.samples}':>10}"
                         f"{r.both_failed:>11}  {verdict}")
        counts = ", ".join(f"{b} {n}" for b, n in self.evaluated().items())
        lines.append(f"samples compared per back end (fewest over its outputs): {counts}")
        lines.append(f"tolerance: rel <= {self.rtol:g} or abs <= {self.atol:g}; {self.verdict}")
        if self.inconclusive:
            lines.append(self.reason)
        return "\n".join(lines)

    @property
    def reason(self) -> str:
        """Why the check is inconclusive (empty when it is not)."""
        if not self.inconclusive:
            return ""
        why = []
        if any(r.compared == 0 for r in self.rows):
            why.append("nothing was compared for the rows marked NOTHING COMPARED: every "
                       "sample failed in every back end (check masses and inertias > 0, "
                       "parameters finite, every coordinate in the motion)")
        unresolved = [r for r in self.rows if r.unresolved]
        if unresolved:
            worst = max(unresolved, key=lambda r: r.unresolved_rel)
            why.append(f"the rows marked UNRESOLVED differ only where the reference's own "
                       f"rounding could explain it: its linear solves have condition numbers "
                       f"up to {max(r.condition for r in unresolved):.1e} there, so relative "
                       f"differences up to {worst.unresolved_rel:.1e} ({worst.output}, "
                       f"{worst.backend}) prove nothing either way (an ill-conditioned state: "
                       f"a near-singular mass matrix or constraint Jacobian): --rtol above "
                       f"{worst.unresolved_rel:.1e} accepts them")
        return "; ".join(why)

    def raise_if_failed(self) -> CheckReport:
        if self.inconclusive:
            raise CheckInconclusive(self.format())
        if not self.ok:
            raise CheckFailed(self.format())
        return self


def random_states(model: ModelBase, samples: int, seed: int):
    """Seeded ``(x, r)`` pairs: states and inputs uniform in [-1, 1]."""
    rng = np.random.default_rng(seed)
    return [(rng.uniform(-1.0, 1.0, model.n_x), rng.uniform(-1.0, 1.0, model.n_r))
            for _ in range(samples)]


def _evaluate(model: ModelBase, output, t, x, p, r):
    try:
        return getattr(model, output.value)(t, x, p, r), None
    except MbgenError as exc:
        return None, type(exc)


def compare(models: dict[str, ModelBase], reference: ModelBase, outputs, *, p=None,
            samples: int = 20, seed: int = 0, rtol: float = 1e-9,
            atol: float = 1e-12) -> tuple[ErrorRow, ...]:
    """Error rows of every model in ``models`` against ``reference`` on random states.

    A reference with a ``resolution`` (the relative error its last evaluation may carry,
    :attr:`mbgen.runtime.lambdified.LambdifiedModel.resolution`) marks a sample above tolerance
    but within twice that as unresolved; one without is trusted to the last bit, and so is
    every reference when ``rtol`` is 0 (bit-for-bit agreement asked for: no rounding
    excuses a difference).
    """
    states = random_states(reference, samples, seed)
    rows = []
    for output in outputs:
        for backend, model in models.items():
            max_abs = max_rel = resolved_abs = resolved_rel = unresolved_rel = condition = 0.0
            mismatched = compared = both_failed = evaluated = unresolved = 0
            for k, (x, r) in enumerate(states):
                t = 0.1 * k
                ref, ref_err = _evaluate(reference, output, t, x, p, r)
                got, got_err = _evaluate(model, output, t, x, p, r)
                evaluated += got_err is None
                if ref_err or got_err:
                    if ref_err is got_err:
                        both_failed += 1
                    else:
                        mismatched += 1
                    continue
                if np.shape(got) != np.shape(ref):
                    mismatched += 1
                    continue
                compared += 1
                diff = float(np.max(np.abs(got - ref), initial=0.0))
                scale = float(np.max(np.abs(ref), initial=0.0))
                rel = diff / scale if scale > 0 else (0.0 if diff == 0 else np.inf)
                max_abs, max_rel = max(max_abs, diff), max(max_rel, rel)
                if (rtol > 0 and rel > rtol and diff > atol
                        and rel <= 2 * getattr(reference, "resolution", 0.0)):
                    unresolved += 1
                    unresolved_rel = max(unresolved_rel, rel)
                    condition = max(condition, getattr(reference, "condition", 0.0))
                else:
                    resolved_abs, resolved_rel = max(resolved_abs, diff), max(resolved_rel, rel)
            exceeded = resolved_rel > rtol and resolved_abs > atol
            ok = compared > 0 and mismatched == 0 and unresolved == 0 and not exceeded
            rows.append(ErrorRow(output.value, backend, max_abs, max_rel, samples, mismatched, ok,
                                 compared, both_failed, evaluated, unresolved, unresolved_rel,
                                 condition, exceeded))
    return tuple(rows)


class UnslicedReference(ModelBase):
    """The lambdified *unsliced* equations, called with a sliced model's ``(p, r)``.

    The sliced layout's parameters and inputs are a subset of the unsliced ones
    (``mbgen.codegen.slicing.bake`` removed the fixed parameters and absent inputs;
    ``optimize`` may drop parameters no output reads).  A call scatters them into the
    unsliced vectors: fixed parameters take their fixed values, absent inputs zero,
    parameters the generated code does not read their default (else 1.0) -- if the code
    wrongly dropped one, the difference shows.
    """

    backend = "lambdify"

    def __init__(self, full: LambdifiedModel, layout: Layout, fixed: Mapping[str, float],
                 defaults: Mapping[str, float] | None, sensitivity_columns=()):
        super().__init__(full.name, layout, defaults, full.outputs)
        self.full = full
        FL = full.layout
        missing = [n for n in FL.parameter_names
                   if n not in layout.parameter_names and n not in fixed]
        base = {**{n: float((full.equations.defaults or {}).get(n, 1.0)) for n in missing},
                **{k: float(v) for k, v in fixed.items()}}
        self._p_base = np.array([base.get(n, 0.0) for n in FL.parameter_names])
        self._p_to = np.array([FL.parameter_names.index(n) for n in layout.parameter_names],
                              dtype=int)
        unknown = set(layout.input_names) - set(FL.input_names)
        if unknown or set(layout.parameter_names) - set(FL.parameter_names):
            raise ArgumentError(f"{full.name}: the sliced layout is not a subset of the "
                                f"unsliced one ({sorted(unknown)})")
        self._r_to = np.array([FL.input_names.index(n) for n in layout.input_names], dtype=int)
        self.constraint_names = full.constraint_names
        self.dependent_coordinates = full.dependent_coordinates
        self.reaction_names, self.reaction_frames = full.reaction_names, full.reaction_frames
        # df/dp: the unsliced columns are the unsliced dynamic parameters; pick the sliced
        # model's (a parameter missing there has a zero column)
        full_cols = [str(s) for s in _PARAMETER_COLUMNS(full.equations, FL)]
        self._dp_cols = [(full_cols.index(n) if n in full_cols else None)
                         for n in sensitivity_columns]

    @property
    def resolution(self) -> float:
        """The relative error the last evaluation may carry from its linear solves."""
        return self.full.resolution

    @property
    def condition(self) -> float:
        """The largest condition number of the last evaluation's linear solves."""
        return self.full.condition

    def _evaluate(self, output, t, x, p, r):
        self._require(output)
        P = self._p_base.copy()
        P[self._p_to] = self._p(p)
        R = np.zeros(self.full.n_r)
        R[self._r_to] = self._r(r)
        out = self.full._evaluate(output, t, x, P, R)
        if output is Output.PARAMETER_JACOBIAN:
            out = np.column_stack([out[:, j] if j is not None else np.zeros(out.shape[0])
                                   for j in self._dp_cols]) if self._dp_cols else \
                np.zeros((out.shape[0], 0))
        return out


def reference_model(result: PipelineResult, outputs) -> ModelBase:
    """The reference of :func:`check`: the unsliced equations, with the sliced ABI."""
    full = LambdifiedModel(result.equations, outputs, layout=result.equations.layout)
    columns = [str(s) for s in _PARAMETER_COLUMNS(result.baked, result.layout)]
    return UnslicedReference(full, result.layout, result.fixed, result.rendered.defaults, columns)


def check(source, *, samples: int = 20, seed: int = 0, rtol: float = 1e-9, atol: float = 1e-12,
          result: PipelineResult | None = None) -> CheckReport:
    """Compare compiled C and generated Python with the lambdified reference.

    Parameters
    ----------
    source : Model, Equations or Scene
        What to check (ignored when ``result`` is given).
    samples, seed : int
        Number of random states (at least 1) and the seed of their generator.
    rtol, atol : float
        An output passes when its max relative error is at most ``rtol`` or its
        max absolute error at most ``atol``.
    result : PipelineResult, optional
        Reuse an already compiled pipeline result.

    Returns
    -------
    CheckReport
        ``.ok`` (passed), ``.inconclusive`` (nothing compared for some output) and
        ``.raise_if_failed()``.

    Raises
    ------
    ArgumentError
        ``samples`` < 1.
    """
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise ArgumentError(f"check needs at least one sample; got samples={samples!r}")
    result = result or run(source)
    compiled = result.compiled
    outputs = tuple(o for o in compiled.outputs if not o.is_integrator)
    models = {"c": compiled, "python": python_model(result.rendered)}
    reference = reference_model(result, outputs)
    p = compiled.default_parameters
    if p is None and compiled.n_p:
        p = np.random.default_rng(seed + 1).uniform(0.5, 1.5, compiled.n_p)
    rows = compare(models, reference, outputs, p=p, samples=samples, seed=seed, rtol=rtol,
                   atol=atol)
    return CheckReport(compiled.name, rows, samples, seed, rtol, atol)
