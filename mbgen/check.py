"""Verification: compiled C vs generated Python vs lambdified sympy.

On seeded random states (and random inputs), every generated output is
evaluated three ways: the compiled C, the generated Python module, and a
``sympy.lambdify`` of the *unoptimised* equations (:mod:`mbgen.reference`).
The report gives, per output and back end, the largest absolute error and the
largest relative error ``|a - b|_inf / |b|_inf`` against the reference.

A sample where the reference finds the mass matrix singular counts as agreement
only if the back end raises the same error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import CheckFailed, MbgenError
from .pipeline import PipelineResult, python_model, run
from .reference import LambdifiedModel
from .runtime import ModelBase


@dataclass(frozen=True)
class ErrorRow:
    """Largest errors of one output of one back end against the reference."""

    output: str
    backend: str
    max_abs: float
    max_rel: float
    samples: int
    mismatched_failures: int
    ok: bool


@dataclass(frozen=True)
class CheckReport:
    """Result of :func:`check`."""

    name: str
    rows: tuple[ErrorRow, ...]
    samples: int
    seed: int
    rtol: float
    atol: float

    @property
    def ok(self) -> bool:
        return all(r.ok for r in self.rows)

    @property
    def max_abs(self) -> float:
        return max((r.max_abs for r in self.rows), default=0.0)

    @property
    def max_rel(self) -> float:
        return max((r.max_rel for r in self.rows), default=0.0)

    def format(self) -> str:
        lines = [f"check {self.name}: {self.samples} seeded random states (seed {self.seed}), "
                 f"reference = lambdify of the unoptimised equations",
                 f"{'output':<13}{'backend':<9}{'max abs err':>13}{'max rel err':>13}  result"]
        for r in self.rows:
            verdict = "ok" if r.ok else "FAIL"
            if r.mismatched_failures:
                verdict += f" ({r.mismatched_failures} samples disagree on failure)"
            lines.append(f"{r.output:<13}{r.backend:<9}{r.max_abs:13.3e}{r.max_rel:13.3e}  {verdict}")
        lines.append(f"tolerance: rel <= {self.rtol:g} or abs <= {self.atol:g}; "
                     f"{'PASSED' if self.ok else 'FAILED'}")
        return "\n".join(lines)

    def raise_if_failed(self) -> "CheckReport":
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
    """Error rows of every model in ``models`` against ``reference`` on random states."""
    states = random_states(reference, samples, seed)
    rows = []
    for output in outputs:
        for backend, model in models.items():
            max_abs = max_rel = 0.0
            mismatched = 0
            for k, (x, r) in enumerate(states):
                t = 0.1 * k
                ref, ref_err = _evaluate(reference, output, t, x, p, r)
                got, got_err = _evaluate(model, output, t, x, p, r)
                if ref_err or got_err:
                    mismatched += ref_err is not got_err
                    continue
                diff = float(np.max(np.abs(got - ref)))
                scale = float(np.max(np.abs(ref)))
                max_abs = max(max_abs, diff)
                max_rel = max(max_rel, diff / scale if scale > 0 else (0.0 if diff == 0 else np.inf))
            ok = mismatched == 0 and (max_rel <= rtol or max_abs <= atol)
            rows.append(ErrorRow(output.value, backend, max_abs, max_rel, samples, mismatched, ok))
    return tuple(rows)


def check(source, *, samples: int = 20, seed: int = 0, rtol: float = 1e-9, atol: float = 1e-12,
          result: PipelineResult | None = None) -> CheckReport:
    """Compare compiled C and generated Python with the lambdified reference.

    Parameters
    ----------
    source : Model, Equations or Scene
        What to check (ignored when ``result`` is given).
    samples, seed : int
        Number of random states and the seed of their generator.
    rtol, atol : float
        An output passes when its max relative error is at most ``rtol`` or its
        max absolute error at most ``atol``.
    result : PipelineResult, optional
        Reuse an already compiled pipeline result.
    """
    result = result or run(source)
    compiled = result.compiled
    outputs = tuple(o for o in compiled.outputs if not o.is_integrator)
    models = {"c": compiled, "python": python_model(result.rendered)}
    reference = LambdifiedModel(result.baked, outputs, layout=result.layout)
    p = compiled.default_parameters
    if p is None and compiled.n_p:
        p = np.random.default_rng(seed + 1).uniform(0.5, 1.5, compiled.n_p)
    rows = compare(models, reference, outputs, p=p, samples=samples, seed=seed, rtol=rtol,
                   atol=atol)
    return CheckReport(compiled.name, rows, samples, seed, rtol, atol)
