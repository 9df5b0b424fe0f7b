"""The pipeline, one line per stage.

::

    Model --derive--> Equations --bake--> Equations --optimize--> Kernel --render--> Rendered
          --build--> CompiledModel

``bake`` is the scene's slice: fixed parameters become numbers and absent
inputs zero (:mod:`mbgen.codegen.slicing`); ``optimize`` keeps only the requested
outputs and the parameters they read (:mod:`mbgen.codegen.optimize`).

Which derivation: a method named by ``method=`` or the scene is used; otherwise
:func:`mbgen.derivation.choose_method` decides from the model's joint tree where it
can (Newton–Euler for long chains of joints, without deriving Kane), and where
it leaves the choice open :func:`run` derives, bakes and optimises both and
keeps the one whose right-hand side has fewer operations (:func:`operations`;
a tie goes to Kane; the process remembers the outcome for the model's slice, so that
other outputs of it, or a regeneration, derive only the method kept).  Either way ``Equations.method_reason`` says why, and the
generated header, ``mbgen generate --explain`` and the notebook summaries show
it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Callable, Iterable, Mapping, Sequence

from .build.extension import compiled_path, load
from .derivation import NAMED, Method, choose_method, derive, method_of
from .symbolic.equations import Equations
from .symbolic.graph import reachable
from .errors import ModelError
from .model.builder import Model
from .codegen.optimize import CseBackend, Form, Kernel, optimize
from .abi import Output
from .abi import Rendered
from .codegen.render import render
from .codegen.outputs import needs_jacobian
from .runtime.compiled import CompiledModel
from .model.scene import Scene, source_label
from .codegen.slicing import bake
from .codegen.solver import solve_ops


@dataclass(frozen=True)
class PipelineResult:
    """Every value the pipeline produced, and how long each stage took (seconds).

    ``equations`` are the derived equations, ``baked`` the scene's slice of them
    (what was optimised); ``kernel.layout`` is the generated ABI.
    """

    equations: Equations
    baked: Equations
    kernel: Kernel
    rendered: Rendered
    compiled: CompiledModel | None
    timings: Mapping[str, float] = field(default_factory=dict)
    compile_cached: bool = False
    #: the parameter values baked in (``baked`` no longer holds them; the check needs them)
    fixed: Mapping[str, float] = field(default_factory=dict)

    @property
    def layout(self):
        return self.kernel.layout


def equations_of(source: Model | Equations | Scene, method: Method | None = None, *,
                 energy: bool = True, points: Sequence[str] | None = None,
                 reactions: bool = False, jacobian: bool = False) -> Equations:
    """Derive (for a ``Model`` or a scene holding one) or pass through ``Equations``.

    A scene's parameter values become the equations' defaults and its name and
    file the equations' source line.  ``energy``: derive energies too;
    ``points``: names of points whose position and velocity to carry (``None``:
    the scene's points, else none); ``jacobian``: the analytic residual Jacobian
    where the derivation has one.  ``method``: the derivation (default: the
    scene's, else :func:`mbgen.derivation.derive`'s default, which compares no
    operation counts: :func:`run` does).
    """
    if isinstance(source, Scene):
        eq = equations_of(source.model, method or source.method, energy=energy,
                          points=source.points if points is None else points,
                          reactions=reactions, jacobian=jacobian)
        if method is None and source.method is not None and eq.method_reason == NAMED:
            eq = replace(eq, method_reason=SCENE_NAMED)
        src = source_label(source)  # the file's name, never the path as typed
        return replace(eq, defaults={**eq.defaults, **{k: float(v) for k, v in
                                                          source.parameters.items()}},
                       source=src)
    if isinstance(source, Model):
        return derive(source, method, energy=energy, points=tuple(points or ()),
                      reactions=reactions, jacobian=jacobian)
    if isinstance(source, Equations):
        return source
    raise ModelError(f"expected a Model, Equations or Scene, got {type(source).__name__}")


#: ``Equations.method_reason`` of a method named by the scene (or ``--derivation``).
SCENE_NAMED = "named by the scene or --derivation"


def operations(kernel: Kernel) -> int:
    """Operations of a kernel's generated code: after CSE, plus one L D L^T solve of ``M``
    where ``u'`` is solved (``optimize`` weighs the recursion against the solve the same
    way).  The default derivation keeps the method for which this is smaller."""
    solves = any(f.spec.solve for f in kernel.functions)
    return kernel.ops_after + (solve_ops(kernel.layout.n_u, kernel.mass_pattern) if solves
                               else 0)


@dataclass(frozen=True)
class _Trial:
    """One derivation through the optimiser: equations, their scene slice, the kernel."""

    equations: Equations
    baked: Equations
    kernel: Kernel

    def because(self, reason: str) -> "_Trial":
        """The same, with ``reason`` as every stage's ``Equations.method_reason``."""
        return _Trial(replace(self.equations, method_reason=reason),
                      replace(self.baked, method_reason=reason),
                      replace(self.kernel, equations=replace(self.kernel.equations,
                                                             method_reason=reason)))


#: The comparisons this process made: the Newton-Euler equations' content (baked: the
#: scene's slice) and the optimiser's settings -> (method, reason).  Any other outputs of
#: the same slice (a test suite, a sweep, ``--explain``) then derive only the method kept.
#: At most ``_REMEMBERED`` entries, oldest out.
_CHOSEN: dict[tuple, tuple[Method, str]] = {}
_REMEMBERED = 256


def _compared(derived, optimized, settings: tuple, outs: tuple[Output, ...]) -> _Trial:
    """The derivation whose right-hand side has fewer :func:`operations`; a tie goes to Kane.

    The right-hand side decides for every output: it is what the others are built around
    (the integrators call it, the Jacobians differentiate it), its kernel is the cheapest
    to compare, and one choice per model slice can be remembered whatever is asked of it.
    ``derived(method) -> (equations, baked)`` and ``optimized(equations, baked, outputs)
    -> _Trial`` are :func:`run`'s stages; ``settings`` the CSE back end and form.
    """
    rhs = (Output.RHS,)
    try:
        newton_euler = derived(Method.NEWTON_EULER)
    except ModelError as exc:   # Newton-Euler does not apply; Kane says so if nothing does
        return optimized(*derived(Method.KANE), outs).because(
            f"chosen: Newton-Euler does not apply ({str(exc).splitlines()[0]})")
    key = (_content(newton_euler[1]), settings)
    if key in _CHOSEN:
        method, reason = _CHOSEN[key]
        kept = newton_euler if method is Method.NEWTON_EULER else derived(Method.KANE)
        return optimized(*kept, outs).because(reason)
    ne = optimized(*newton_euler, rhs)
    kane = optimized(*derived(Method.KANE), rhs)
    a, b = operations(kane.kernel), operations(ne.kernel)
    said = "right-hand side of {} operations with the L D L^T solve"
    if b < a:
        method, reason = Method.NEWTON_EULER, f"chosen: a {said.format(b)}, against Kane's {a}"
    elif a < b:
        method, reason = Method.KANE, f"chosen: a {said.format(a)}, against Newton-Euler's {b}"
    else:
        method, reason = Method.KANE, (f"chosen: a {said.format(a)}, as many as "
                                       f"Newton-Euler's; a tie goes to Kane")
    if len(_CHOSEN) >= _REMEMBERED:
        del _CHOSEN[next(iter(_CHOSEN))]
    _CHOSEN[key] = method, reason
    kept = ne if method is Method.NEWTON_EULER else kane
    if tuple(outs) != rhs:
        kept = optimized(kept.equations, kept.baked, outs)
    return kept.because(reason)


def _content(eq: Equations) -> int:
    """A hash of what the right-hand side's code depends on in ``eq`` (a slice's identity,
    whatever else was derived with it: energies, points, reactions)."""
    roots = list(eq.mass_matrix) + list(eq.forcing) + list(eq.kinematics)
    roots += list(eq.accelerations or ()) + (eq.constraints.expressions() if eq.constraints
                                              else [])
    reached = reachable(roots, dict(eq.program.assignments))
    program = tuple((sym, e) for sym, e in eq.program.assignments if sym in reached)
    return hash((eq.layout, eq.mass_matrix, eq.forcing, eq.kinematics, program,
                 eq.accelerations, eq.constraints))


def _outputs(source, outputs) -> tuple[Output, ...]:
    if outputs is None:
        outputs = source.outputs if isinstance(source, Scene) else (Output.RHS,)
    return Output.parse(outputs)


def _all_points(source) -> tuple[str, ...]:
    model = source.model if isinstance(source, Scene) else source
    if not isinstance(model, Model):
        return ()
    return tuple(p.name for p in model.points if p is not model.origin)


def run(source: Model | Equations | Scene, outputs: Iterable | None = None, *,
        build: bool = True, parameters: Mapping[str, float] | None = None,
        fixed: Mapping[str, float] | None = None, inputs: Sequence[str] | None = None,
        name: str | None = None, sliced: bool = True,
        cse_backend: CseBackend = CseBackend.SYMENGINE, targets=None,
        method: Method | None = None, form: Form | None = None,
        stage: Callable[[str], None] | None = None) -> PipelineResult:
    """Run every stage and time it: derive, bake, optimize, render, and (optionally) compile.

    Parameters
    ----------
    source : Model, Equations or Scene
    outputs : iterable of Output or names, optional
        Default: the scene's outputs, else ``RHS``.
    build : bool
        Compile and load the C (else stop after rendering).
    parameters : mapping, optional
        Default values of free parameters (override a scene's).
    fixed, inputs : optional
        Parameters to bake in and inputs present (default: the scene's).
    name : str, optional
        Model name, i.e. the C prefix (default: the model's or the scene's prefix).
    sliced : bool
        ``False`` ignores the scene's fixed parameters and input selection.
    targets : mbgen.codegen.targets.Targets, optional
        What to render besides the outputs (the step API; default: the scene's).
    method : Method, optional
        Derivation method (default: the scene's, else the cheaper for this model
        and these outputs: see the module docstring).
    form : Form, optional
        How ``u'`` is computed (default: chosen by operation count; see
        :func:`mbgen.codegen.optimize.optimize`).
    stage : callable, optional
        Called with each stage's name (``derive``, ``bake``, ``cse``, ``render``,
        ``compile``) as it starts: the command line's progress lines.  While both
        derivations are compared, the first three carry the method: ``derive/kane``.
    """
    outs = _outputs(source, outputs)
    scene = source if isinstance(source, Scene) else None
    timings: dict[str, float] = {}

    comparing = []   # non-empty while both derivations run: stage lines name the method

    def timed(label, fn, *args, of: Equations | Method | None = None, **kw):
        if stage is not None:
            method = of.method if isinstance(of, Equations) else of
            stage(f"{label}/{Method(method).value}" if comparing and method else label)
        t0 = time.perf_counter()
        value = fn(*args, **kw)
        timings[label] = timings.get(label, 0.0) + time.perf_counter() - t0
        return value

    wants_points = bool({Output.POSITIONS, Output.VELOCITIES} & set(outs))
    points = None if not wants_points or (scene and scene.points) else _all_points(source)
    if fixed is None and sliced and scene:
        fixed = scene.fixed
    if inputs is None and sliced and scene:
        inputs = scene.inputs
    if targets is None and scene:
        targets = scene.targets
    name = name or (scene.prefix if scene and scene.prefix else None)

    def derived(how: Method | None, reason: str = "") -> tuple[Equations, Equations]:
        """Derive with ``how`` (None: the source's own) for ``reason``, and bake."""
        equations = timed("derive", equations_of, source, how, of=how,
                          reactions=Output.REACTIONS in outs, energy=Output.ENERGY in outs,
                          points=points, jacobian=needs_jacobian(outs))
        if reason:
            equations = replace(equations, method_reason=reason)
        if parameters:
            equations = replace(equations, defaults={**equations.defaults,
                                                     **{k: float(v) for k, v in
                                                        parameters.items()}})
        if name:
            equations = replace(equations, name=name)
        return equations, timed("bake", bake, equations, fixed, inputs, of=equations)

    def optimized(equations: Equations, baked: Equations, only=outs) -> _Trial:
        return _Trial(equations, baked, timed("cse", optimize, baked, only, cse_backend, form,
                                              of=equations))

    model = source.model if scene else source
    named = method_of(method) if method is not None else None
    if named is not None or not isinstance(model, Model) or scene and scene.method is not None:
        trial = optimized(*derived(named))
    else:
        t0 = time.perf_counter()
        choice = choose_method(model)
        timings["derive"] = time.perf_counter() - t0
        if choice.method is not None:
            trial = optimized(*derived(choice.method, choice.reason))
        else:
            comparing.append(True)
            trial = _compared(derived, optimized, (CseBackend(cse_backend), form), outs)
    equations, baked, kernel = trial.equations, trial.baked, trial.kernel
    rendered = timed("render", render, kernel, targets)
    compiled, cached = None, False
    if build:
        cached = compiled_path(rendered).exists()
        module = timed("compile", load, rendered)
        compiled = CompiledModel(rendered, module, rendered.layout, rendered.defaults,
                                 rendered.outputs)
    return PipelineResult(equations, baked, kernel, rendered, compiled, timings, cached,
                          {k: float(v) for k, v in (fixed or {}).items()})


def compile(source: Model | Equations | Scene, outputs: Iterable | None = None, *,
            parameters: Mapping[str, float] | None = None,
            fixed: Mapping[str, float] | None = None, inputs: Sequence[str] | None = None,
            name: str | None = None,
            cse_backend: CseBackend = CseBackend.SYMENGINE, targets=None,
            method: Method | None = None, form: Form | None = None,
            stage: Callable[[str], None] | None = None) -> CompiledModel:
    """Generate, compile (cached by content hash) and load ``source``.

    Parameters
    ----------
    source : Model, Equations or Scene
    outputs : iterable of Output or names, optional
        Default: the scene's outputs, else ``{Output.RHS}``.
    parameters : mapping, optional
        Default parameter values (override a scene's).
    fixed : mapping, optional
        Parameters baked into the code as constants (default: the scene's).
    inputs : sequence of str, optional
        Inputs given at run time; the others are zero (default: the scene's, else all).
    name : str, optional
        C prefix, so that two slices of one model can live in one C program.
    method : Method, optional
        ``Method.KANE`` or ``Method.NEWTON_EULER`` (default: the scene's, else the
        one whose generated code has fewer operations, Newton–Euler for long
        chains of joints without trying Kane; see :mod:`mbgen.pipeline`).
    form : Form, optional
        ``Form.SOLVE`` or ``Form.RECURSIVE`` (default: fewer operations wins).
    targets : mbgen.codegen.targets.Targets, optional
        What to render besides the outputs, e.g. ``Targets(step=True)`` for the step API
        (default: the scene's).
    stage : callable, optional
        Called with each stage's name as it starts (see :func:`run`).

    Returns
    -------
    CompiledModel
        ``model.rhs(t, x, p=None, r=None)`` and the other requested outputs.
    """
    return run(source, outputs, parameters=parameters, fixed=fixed, inputs=inputs, name=name,
               cse_backend=cse_backend, targets=targets, method=method, form=form,
               stage=stage).compiled
