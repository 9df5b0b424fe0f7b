"""The case list: which cases apply to a scene (:func:`case_specs`, by the rules in
:mod:`mbgen.verify.stress`), each a :class:`CaseSpec` that makes exactly one case, and the
``fp`` cases (the nominal state and seeded random states near it, :func:`fp_case`).

Some cases are decided by another's result: an extreme point is simulated only when its
evaluation admits it, a C integrator is started only where ``M`` is not positive
definite, a scan's worst point is checked only when the scan found one.  Their specs are
the *follow-ups* of the spec whose case decides them (:attr:`CaseSpec.follow`), so the
suite knows every case it runs by the time it runs it, and counts them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...abi import Output
from ...errors import SceneError
from ...model.scene import scene_options
from .context import Context
from .extreme import (
    Variation,
    admits_simulation,
    c_not_positive_definite,
    extreme_case,
    extreme_variations,
    not_positive_definite,
    short_simulation,
)
from .long_runs import jacobi_applies, long_run_case
from .precision import check_point
from .report import Case, fmt_sci
from .singular import (
    SINGULAR_PATHS,
    SingularPath,
    scan_case,
    scan_worst_case,
    singular_c_case,
    singular_case,
)
from .stiff import IMPLICIT, STIFF_METHODS, stiff_case, stiff_fp_case, stiff_scaling_case


def fp_case(ctx: Context, which: int) -> Case:
    """The nominal point (``which = 0``) or seeded random point ``which`` near it."""
    if which == 0:
        return check_point(ctx.model, ctx.hp, ctx.t0, ctx.x0, ctx.p0, ctx.values,
                           name="nominal state")
    rng = np.random.default_rng(1000 + which)
    x = ctx.x0 + rng.uniform(-0.2, 0.2, ctx.x0.size)
    values = {n: v * rng.uniform(0.9, 1.1) for n, v in ctx.values.items()}
    t = float(rng.uniform(0.0, 1.0))
    return check_point(ctx.model, ctx.hp, t, x, ctx.p_of(values), values,
                       name=f"random state {which}")


@dataclass(frozen=True)
class CaseSpec:
    """One entry of the case list: ``run(ctx, *args) -> Case``, then
    ``follow(ctx, case, *args) -> list[CaseSpec]``, the cases that case decides (run next)."""

    kind: str
    label: str
    run: Callable[..., Case]
    args: tuple = ()
    follow: Callable[..., list[CaseSpec]] | None = None


def _after_extreme(ctx: Context, evaluation: Case, v: Variation) -> list[CaseSpec]:
    """A C integrator where M is not positive definite; a short simulation where admissible."""
    specs = []
    if not_positive_definite(evaluation):
        specs.append(CaseSpec("extreme", f"{v.name} C dopri5", c_not_positive_definite, (v,)))
    if admits_simulation(evaluation):
        specs.append(CaseSpec("extreme", f"{v.name} sim", short_simulation, (v,)))
    return specs


def _after_singular(ctx: Context, evaluation: Case, path: SingularPath,
                    delta: float) -> list[CaseSpec]:
    """A C integrator where M is not positive definite."""
    if not not_positive_definite(evaluation):
        return []
    return [CaseSpec("singular", f"{path.name} {fmt_sci(delta)} C dopri5", singular_c_case,
                     (path, delta))]


def _after_scan(ctx: Context, scan: Case, index: int) -> list[CaseSpec]:
    """The scan's worst point, when it found one."""
    if "worst_at" not in scan.data:
        return []
    return [CaseSpec("singular", f"scan {ctx.model.state_names[index]} worst point",
                     scan_worst_case, (index, scan.data["worst_at"]))]


def case_specs(ctx: Context) -> list[CaseSpec]:
    """The cases that apply to ``ctx.scene`` (rules in :mod:`mbgen.verify.stress`), follow-ups
    not yet included (they come from :attr:`CaseSpec.follow` as the cases run)."""
    sz = ctx.size
    specs = [CaseSpec("fp", "nominal", fp_case, (0,))]
    specs += [CaseSpec("fp", f"random {i}", fp_case, (i,)) for i in range(1, sz.random_states + 1)]
    specs += [CaseSpec("extreme", v.name, extreme_case, (v,), _after_extreme)
              for v in extreme_variations(ctx)]
    for path in SINGULAR_PATHS.get(ctx.scene.name, ()):
        if path.applies is not None and not path.applies(ctx.values):
            ctx.notes.append(f"{path.name}: not reached with these parameters")
            continue
        specs += [CaseSpec("singular", f"{path.name} {fmt_sci(d)}", singular_case, (path, d),
                           _after_singular) for d in sz.offsets]
    specs += [CaseSpec("singular", f"scan {n}", scan_case, (i,), _after_scan)
              for i, n in enumerate(ctx.model.state_names[:ctx.model.layout.n_q])]
    if ctx.source and "stiffness" in _options(ctx.source):
        methods = STIFF_METHODS
        for k in sz.stiffness:
            specs.append(CaseSpec("fp", f"k={fmt_sci(k)} start", stiff_fp_case, (k,)))
            specs += [CaseSpec("stiff", f"k={fmt_sci(k)} {m}", stiff_case, (k, m)) for m in methods]
        specs += [CaseSpec("stiff", f"scaling {m}", stiff_scaling_case, (m,))
                  for m in methods if m in IMPLICIT]
    integrators = ["DOP853", "C dopri5"]
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
