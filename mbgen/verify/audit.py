"""The slicing audit: what a scene's generated code leaves out, and what each cut saves.

``mbgen generate SCENE --explain`` prints it.  The starting point is the *full*
code, derived by the method the scene's code uses (named, or chosen as
:mod:`mbgen.pipeline` says; the audit's first line says which and why): every
output mbgen can emit for the model (right-hand side, mass matrix,
forcing, energy, Jacobians, positions and velocities of every point) plus the
scene's integrators, with every parameter free and every input present.  The
cuts, in pipeline order:

1. outputs the scene does not ask for (whole functions);
2. fixed parameters baked in as numbers and folded;
3. inputs the scene does not provide (set to zero);
4. parameters and inputs that no emitted expression reads (gone from the ABI);
5. exact zeros (entries that need no arithmetic; the solve skips structural
   zeros of ``M``);
6. the accelerations: the mass matrix and its solve, or the articulated-body
   recursion, whichever needs fewer operations;
7. common-subexpression elimination.

Operation counts are those of :mod:`mbgen.symbolic.graph` (expressions evaluated as
trees before CSE; temporaries plus outputs after); lines are the lines of the
generated ``.c`` and ``.h``.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..abi import INTEGRATORS, Output
from ..codegen.outputs import Form
from ..codegen.printing import math_functions
from ..codegen.solver import UNROLL_MAX, fill_pattern
from ..derivation import Method
from ..model.scene import Scene
from ..pipeline import PipelineResult, equations_of, run
from ..symbolic.availability import applicable


@dataclass(frozen=True)
class Cut:
    """One slicing step: what it removed, why, and the operations before and after it."""

    step: str
    removed: str
    reason: str
    ops_before: int | None = None
    ops_after: int | None = None


@dataclass(frozen=True)
class Audit:
    """The cuts of one scene, and totals of the full and the sliced code."""

    scene: str
    prefix: str
    cuts: tuple[Cut, ...]
    full_ops: int
    sliced_ops: int
    full_lines: int
    sliced_lines: int
    derivation: str = ""

    def format(self) -> str:
        lines = [f"audit of scene {self.scene!r} (C prefix {self.prefix}): what the generated "
                 f"code leaves out", f"derivation: {self.derivation}", ""]
        width = max(len(c.step) for c in self.cuts)
        for c in self.cuts:
            ops = ("" if c.ops_before is None else
                   f"  [ops {c.ops_before} -> {c.ops_after}]")
            lines.append(f"{c.step:<{width}}  {c.removed}{ops}")
            lines.append(f"{'':<{width}}    why: {c.reason}")
        lines += ["", f"full code:   {self.full_ops:>7} operations after CSE, "
                      f"{self.full_lines:>6} lines of C (.c + .h)",
                  f"scene code:  {self.sliced_ops:>7} operations after CSE, "
                  f"{self.sliced_lines:>6} lines of C (.c + .h)"]
        return "\n".join(lines)


def _c_lines(result: PipelineResult) -> int:
    r = result.rendered
    return r.header.count("\n") + r.source.count("\n")


def _tree_ops(result: PipelineResult) -> int:
    return result.kernel.ops_before


def audit(scene: Scene) -> Audit:
    """Audit the slice of ``scene``: see the module docstring."""
    outs = Output.parse(scene.outputs)
    integrators = tuple(o for o in outs if o in INTEGRATORS)
    all_points = tuple(p.name for p in getattr(scene.model, "points", ())
                       if p is not getattr(scene.model, "origin", None))
    sliced = run(scene, outs, build=False)   # what `mbgen generate` writes
    how = _method(sliced)   # the other stages derive the same way
    full_eq = equations_of(scene, how, points=all_points, reactions=True)
    everything = applicable(full_eq) + integrators
    full = run(full_eq, everything, build=False, sliced=False)
    wanted = run(scene, outs, build=False, sliced=False, method=how)
    baked = run(scene, outs, build=False, fixed=scene.fixed, inputs=None, method=how)

    cuts = []
    dropped = [o for o in full.kernel.outputs if o not in wanted.kernel.outputs]
    cost = {f.output: f.ops_after for f in full.kernel.functions}
    cuts.append(Cut(
        "1 outputs", ", ".join(f"{o.value} ({cost[o]} ops)" if o in cost else o.value
                               for o in dropped) or "nothing",
        f"the scene asks for {', '.join(o.value for o in outs)} (integrators pull in what "
        f"they call)", _tree_ops(full), _tree_ops(wanted)))
    fixed = ", ".join(f"{k} = {v:g}" for k, v in scene.fixed.items())
    cuts.append(Cut("2 fixed parameters", fixed or "nothing",
                    "baked in as numbers and folded (scene.fixed)" if fixed else
                    "the scene fixes no parameter", _tree_ops(wanted), _tree_ops(baked)))
    absent = [n for n in baked.baked.layout.input_names
              if n not in sliced.baked.layout.input_names]
    cuts.append(Cut("3 inputs", ", ".join(absent) or "nothing",
                    "not provided by the scene (scene.inputs): zero" if absent else
                    "every input is provided at run time", _tree_ops(baked), _tree_ops(sliced)))
    unused_p = [n for n in sliced.baked.layout.parameter_names
                if n not in sliced.layout.parameter_names]
    unused_r = [n for n in sliced.baked.layout.input_names if n not in sliced.layout.input_names]
    cuts.append(Cut("4 unused symbols", ", ".join(unused_p + unused_r) or "nothing",
                    "no emitted expression reads them, so they leave the ABI (p/r slots)"
                    if unused_p or unused_r else "every remaining parameter is read"))
    cuts.append(Cut("5 exact zeros", _zeros(sliced), "zero entries need no arithmetic; the "
                    "L D L^T solve touches only structural nonzeros"))
    cuts.append(_form_cut(sliced))
    cuts.append(Cut("7 CSE", f"{sliced.kernel.ops_before - sliced.kernel.ops_after} repeated "
                    f"operations", f"one {sliced.kernel.cse_backend.value} CSE pass over every "
                    f"emitted expression", sliced.kernel.ops_before, sliced.kernel.ops_after))
    has_math = "#include <math.h>" in sliced.rendered.source
    cuts.append(Cut("8 includes", "nothing: <math.h> is kept" if has_math else "<math.h>",
                    "it declares " + _math_reason(sliced) if has_math else
                    "no math function is called"))
    return Audit(scene.name, sliced.rendered.prefix, tuple(cuts), full.kernel.ops_after,
                 sliced.kernel.ops_after, _c_lines(full), _c_lines(sliced),
                 sliced.equations.derivation)


def _method(result: PipelineResult) -> Method | None:
    """The derivation ``result`` used (None: equations that came from elsewhere)."""
    try:
        return Method(result.equations.method)
    except ValueError:
        return None


def _form_cut(result: PipelineResult) -> Cut:
    """How ``u'`` is computed: the mass matrix and its solve, or the articulated-body recursion."""
    k = result.kernel
    costs = dict(k.form_costs)
    if not costs:
        why = ("the equations carry no recursion (Kane's method, or joints whose speeds are "
               "shared: derive with Method.NEWTON_EULER and relative joint coordinates)"
               if result.baked.accelerations is None else "the form was chosen by the caller")
        return Cut("6 accelerations", "nothing: u' solves M u' = F", why)
    solve, rec = costs[Form.SOLVE], costs[Form.RECURSIVE]
    if k.form is Form.RECURSIVE and k.solve_bounded:
        return Cut("6 accelerations", f"the mass matrix and its L D L^T solve (at least {solve} "
                   f"ops: the solve alone)", f"the articulated-body recursion gives u' in {rec} "
                   f"ops (right-hand side alone, after CSE)", solve, rec)
    if k.form is Form.RECURSIVE:
        return Cut("6 accelerations", f"the mass matrix and its L D L^T solve ({solve} ops)",
                   f"the articulated-body recursion gives u' in {rec} ops (right-hand side "
                   f"alone, after CSE)", solve, rec)
    return Cut("6 accelerations", f"the articulated-body recursion ({rec} ops)",
               f"M u' = F with its L D L^T solve costs {solve} ops (right-hand side alone, "
               f"after CSE, solve included)", rec, solve)


def _zeros(result: PipelineResult) -> str:
    total = zeros = 0
    for f in result.kernel.functions:
        for b in f.pre + f.post:
            total += len(b.entries)
            zeros += sum(1 for _, e in b.entries if e == 0)
    n = result.layout.n_u
    pattern = result.kernel.mass_pattern
    fill = fill_pattern(n, pattern) - pattern
    below = n * (n - 1) // 2
    solve = (f"M has {below - len(pattern)} of {below} entries below the diagonal zero "
             f"({len(fill)} fill-in); solve {'unrolled' if n <= UNROLL_MAX else 'dense loops'}")
    return f"{zeros} of {total} assigned entries are exact zeros; {solve}"


def _math_reason(result: PipelineResult) -> str:
    exprs = [e for f in result.kernel.functions for _, e in f.temporaries + f.post_temporaries]
    exprs += [e for f in result.kernel.functions for b in f.pre + f.post for _, e in b.entries]
    funcs = sorted(math_functions(exprs))
    parts = [", ".join(funcs)] if funcs else []
    if result.kernel.integrators:
        parts.append("the integrators (fabs, sqrt, pow)")
    return " and ".join(parts)
