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
a tie goes to Kane; :data:`COMPARISONS` remembers the outcome for the model's slice, so
that other outputs of it, or a regeneration, derive only the method kept).  The choice
hands the model's prepared value and Newton–Euler outward pass on to the derivation, so
neither runs twice.  Either way ``Equations.method_reason`` says why, and the generated
header, ``mbgen generate --explain`` and the notebook summaries show it.

A run that builds first looks its inputs up in the warm cache (:mod:`mbgen.build.warm`,
keyed by the model's content and every option, :func:`_warm_key`): an unchanged model loads
its module and derives nothing (:attr:`PipelineResult.warm`).

Whoever wants to hear of the stages passes a :class:`StageTimer` (``stage=`` for the
start of each alone): the command line's progress lines and the benchmarks' per-stage
times come from the one sequence in :func:`run`.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace

from .abi import Output, Rendered
from .build import warm as warm_cache
from .build.canonical import Uncacheable
from .build.extension import compiled_path, load
from .codegen.optimize import CseBackend, Form, Kernel, optimize
from .codegen.outputs import needs_jacobian
from .codegen.render import render
from .codegen.slicing import bake
from .codegen.solver import solve_ops
from .codegen.targets import Targets
from .derivation import NAMED, Method, choose_method, derive, method_of
from .derivation.prepare import Prepared
from .errors import ModelError, UsageError
from .model.builder import Model
from .model.scene import Scene, source_label
from .runtime.compiled import CompiledModel
from .symbolic.equations import Equations
from .symbolic.graph import fewer_collections, reachable

#: The values of a :class:`PipelineResult` that a warm run derives only when they are read.
DERIVED = ("equations", "baked", "kernel")


@dataclass(frozen=True)
class PipelineResult:
    """Every value the pipeline produced, and how long each stage took (seconds).

    ``equations`` are the derived equations, ``baked`` the scene's slice of them
    (what was optimised); ``layout`` is the generated ABI.

    ``warm``: the rendered code came from the warm cache (:mod:`mbgen.build.warm`) and
    nothing was derived; ``equations``, ``baked`` and ``kernel`` are then derived when one
    of them is first read (``later``, the same run without the cache), so that a caller
    that reads only ``compiled`` or ``rendered`` never pays for them.
    """

    equations: Equations | None
    baked: Equations | None
    kernel: Kernel | None
    rendered: Rendered
    compiled: CompiledModel | None
    timings: Mapping[str, float] = field(default_factory=dict)
    compile_cached: bool = False
    #: the parameter values baked in (``baked`` no longer holds them; the check needs them)
    fixed: Mapping[str, float] = field(default_factory=dict)
    warm: bool = False
    later: Callable[[], PipelineResult] | None = field(default=None, repr=False,
                                                       compare=False)

    def __getattribute__(self, name: str):
        value = object.__getattribute__(self, name)
        if value is None and name in DERIVED:
            later = object.__getattribute__(self, "later")
            if later is not None:
                cold = later()
                for derived in DERIVED:
                    object.__setattr__(self, derived, getattr(cold, derived))
                object.__setattr__(self, "later", None)
                value = object.__getattribute__(self, name)
        return value

    def __repr__(self) -> str:      # as the dataclass's, but never deriving what is left
        shown = (f"{f.name}={object.__getattribute__(self, f.name)!r}" for f in fields(self)
                 if f.repr)
        return f"PipelineResult({', '.join(shown)})"

    @property
    def layout(self):
        return self.rendered.layout


def equations_of(source: Model | Equations | Scene, method: Method | None = None, *,
                 energy: bool = True, points: Sequence[str] | None = None,
                 reactions: bool = False, jacobian: bool = False,
                 prepared: Prepared | None = None) -> Equations:
    """Derive (for a ``Model`` or a scene holding one) or pass through ``Equations``.

    A scene's parameter values become the equations' defaults and its name and
    file the equations' source line.  ``energy``: derive energies too;
    ``points``: names of points whose position and velocity to carry (``None``:
    the scene's points, else none); ``jacobian``: the analytic residual Jacobian
    where the derivation has one.  ``method``: the derivation (default: the
    scene's, else :func:`mbgen.derivation.derive`'s default, which compares no
    operation counts: :func:`run` does).  ``prepared``: the model's
    :class:`~mbgen.derivation.prepare.Prepared` value (a :class:`~mbgen.derivation.Choice`'s,
    so that nothing the choice computed is computed again).
    """
    if isinstance(source, Scene):
        eq = equations_of(source.model, method or source.method, energy=energy,
                          points=source.points if points is None else points,
                          reactions=reactions, jacobian=jacobian, prepared=prepared)
        if method is None and source.method is not None and eq.method_reason == NAMED:
            eq = replace(eq, method_reason=SCENE_NAMED)
        src = source_label(source)  # the file's name, never the path as typed
        return replace(eq, defaults={**eq.defaults, **{k: float(v) for k, v in
                                                          source.parameters.items()}},
                       source=src)
    if isinstance(source, Model):
        if prepared is not None and prepared.model is not source:
            raise ModelError("equations_of(prepared=...) is the prepared value of another model")
        return derive(prepared or source, method, energy=energy, points=tuple(points or ()),
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
class StageTimer:
    """Who hears of :func:`run`'s stages: ``started(name)`` as each starts and
    ``finished(name, seconds, value)`` as it ends.

    ``name`` is ``derive``, ``bake``, ``cse``, ``render`` or ``compile``, or ``warm`` alone
    where the warm cache held the rendered code (:mod:`mbgen.build.warm`: the module loaded,
    nothing derived); ``started`` gets
    ``derive/kane`` and the like while both derivations are compared (the command line's
    progress lines).  ``seconds`` is the stage's time so far in this run (a stage that runs
    twice, as while comparing, adds up: :attr:`PipelineResult.timings`), ``value`` what the
    stage returned (``Equations``, ``Kernel``, ``Rendered``, the loaded module).  The
    benchmarks time the pipeline through ``finished``, so a new stage reaches every one.
    """

    started: Callable[[str], None] | None = None
    finished: Callable[[str, float, object], None] | None = None


class _Clock:
    """Runs the stages of one :func:`run`, sums their seconds by name, tells the timer."""

    def __init__(self, timer: StageTimer):
        self.timer = timer
        self.timings: dict[str, float] = {}
        self.comparing = False   # while both derivations run, started() names the method

    def __call__(self, name: str, fn, *args, of: Equations | Method | None = None,
                 quiet: bool = False, **kw):
        """``fn(*args, **kw)`` as stage ``name`` (of the method of ``of``); ``quiet``: timed,
        not announced (the choice of method, part of ``derive``)."""
        if self.timer.started is not None and not quiet:
            method = of.method if isinstance(of, Equations) else of
            self.timer.started(f"{name}/{Method(method).value}" if self.comparing and method
                               else name)
        t0 = time.perf_counter()
        value = fn(*args, **kw)
        self.timings[name] = self.timings.get(name, 0.0) + time.perf_counter() - t0
        if self.timer.finished is not None and not quiet:
            self.timer.finished(name, self.timings[name], value)
        return value


@dataclass(frozen=True)
class _Trial:
    """One derivation through the optimiser: equations, their scene slice, the kernel."""

    equations: Equations
    baked: Equations
    kernel: Kernel

    def because(self, reason: str) -> _Trial:
        """The same, with ``reason`` as every stage's ``Equations.method_reason``."""
        return _Trial(replace(self.equations, method_reason=reason),
                      replace(self.baked, method_reason=reason),
                      replace(self.kernel, equations=replace(self.kernel.equations,
                                                             method_reason=reason)))


class Comparisons:
    """The outcomes of comparing Kane and Newton–Euler, by model slice, at most ``size``.

    The key is a hash of what the right-hand side depends on in the Newton–Euler equations'
    scene slice (:func:`_content`), with the optimiser's settings; the value the method kept
    and why.  A run that finds its slice here derives only the method kept.
    """

    def __init__(self, size: int = 256):
        self.size = size
        self._kept: dict[tuple, tuple[Method, str]] = {}

    def get(self, key: tuple) -> tuple[Method, str] | None:
        """``(method, reason)`` of a slice compared before, else None."""
        return self._kept.get(key)

    def remember(self, key: tuple, method: Method, reason: str) -> None:
        """Keep an outcome; the oldest goes when there are ``size``."""
        if len(self._kept) >= self.size:
            del self._kept[next(iter(self._kept))]
        self._kept[key] = method, reason

    def clear(self) -> None:
        """Forget every outcome."""
        self._kept.clear()

    def __len__(self) -> int:
        return len(self._kept)


#: The comparisons this process made (:func:`run`'s default): other outputs of a slice
#: compared once (a test suite, a sweep, ``--explain``) then derive only the method kept.
COMPARISONS = Comparisons()


@dataclass(frozen=True)
class _Stages:
    """Derive-and-bake and optimise for one :func:`run`, its arguments resolved."""

    source: Model | Equations | Scene
    outs: tuple[Output, ...]
    clock: _Clock
    points: tuple[str, ...] | None
    parameters: Mapping[str, float] | None
    name: str | None
    fixed: Mapping[str, float] | None
    inputs: Sequence[str] | None
    cse_backend: CseBackend
    form: Form | None

    @classmethod
    def of(cls, source, outs, clock, parameters, name, fixed, inputs, sliced: bool,
           cse_backend, form) -> _Stages:
        """:func:`run`'s arguments with a scene's defaults filled in: its slice (unless not
        ``sliced``), its prefix, and its points, or every point, where positions are asked."""
        scene = source if isinstance(source, Scene) else None
        if scene is not None and sliced:
            fixed = scene.fixed if fixed is None else fixed
            inputs = scene.inputs if inputs is None else inputs
        wants_points = bool({Output.POSITIONS, Output.VELOCITIES} & set(outs))
        points = None if not wants_points or (scene and scene.points) else _all_points(source)
        name = name or (scene.prefix if scene and scene.prefix else None)
        return cls(source, outs, clock, points, parameters, name, fixed, inputs, cse_backend,
                   form)

    def derived(self, how: Method | None, reason: str = "",
                prepared: Prepared | None = None) -> tuple[Equations, Equations]:
        """Derive with ``how`` (None: the source's own) for ``reason``, and bake;
        ``prepared``: the model's prepared value that the choice of method computed."""
        outs = self.outs
        equations = self.clock("derive", equations_of, self.source, how, of=how,
                               reactions=Output.REACTIONS in outs, energy=Output.ENERGY in outs,
                               points=self.points, jacobian=needs_jacobian(outs),
                               prepared=prepared)
        if reason:
            equations = replace(equations, method_reason=reason)
        if self.parameters:
            equations = replace(equations, defaults={**equations.defaults,
                                                     **{k: float(v) for k, v in
                                                        self.parameters.items()}})
        if self.name:
            equations = replace(equations, name=self.name)
        return equations, self.clock("bake", bake, equations, self.fixed, self.inputs,
                                     of=equations)

    def optimized(self, equations: Equations, baked: Equations,
                  only: tuple[Output, ...] | None = None) -> _Trial:
        """The trial of ``equations``: its kernel for ``only`` (default: the run's outputs)."""
        return _Trial(equations, baked, self.clock("cse", optimize, baked,
                                                   self.outs if only is None else only,
                                                   self.cse_backend, self.form, of=equations))

    @property
    def settings(self) -> tuple:
        """The optimiser's settings that a comparison's outcome depends on."""
        return CseBackend(self.cse_backend), self.form


def _chosen(stages: _Stages, named: Method | None, comparisons: Comparisons | None) -> _Trial:
    """The trial of the method named, else of :func:`~mbgen.derivation.choose_method`'s, else
    of the cheaper of both (:func:`_compared`); the choice's prepared model is derived."""
    source = stages.source
    scene = source if isinstance(source, Scene) else None
    model = source.model if scene else source
    if named is not None or not isinstance(model, Model) or scene and scene.method is not None:
        return stages.optimized(*stages.derived(named))
    choice = stages.clock("derive", choose_method, model, quiet=True)
    if choice.method is not None:
        return stages.optimized(*stages.derived(choice.method, choice.reason, choice.prepared))
    stages.clock.comparing = True
    return _compared(stages, choice.prepared, comparisons)


def _compared(stages: _Stages, prepared: Prepared,
              comparisons: Comparisons | None) -> _Trial:
    """The derivation whose right-hand side has fewer :func:`operations`; a tie goes to Kane.

    The right-hand side decides for every output: it is what the others are built around
    (the integrators call it, the Jacobians differentiate it), its kernel is the cheapest
    to compare, and one choice per model slice can be remembered (``comparisons``)
    whatever is asked of it.
    """
    rhs = (Output.RHS,)
    try:
        newton_euler = stages.derived(Method.NEWTON_EULER, prepared=prepared)
    except ModelError as exc:   # Newton-Euler does not apply; Kane says so if nothing does
        return stages.optimized(*stages.derived(Method.KANE, prepared=prepared)).because(
            f"chosen: Newton-Euler does not apply ({str(exc).splitlines()[0]})")
    key = (_content(newton_euler[1]), stages.settings)
    known = comparisons.get(key) if comparisons is not None else None
    if known is not None:
        method, reason = known
        kept = (newton_euler if method is Method.NEWTON_EULER
                else stages.derived(Method.KANE, prepared=prepared))
        return stages.optimized(*kept).because(reason)
    ne = stages.optimized(*newton_euler, rhs)
    kane = stages.optimized(*stages.derived(Method.KANE, prepared=prepared), rhs)
    method, reason = _cheaper(operations(kane.kernel), operations(ne.kernel))
    if comparisons is not None:
        comparisons.remember(key, method, reason)
    kept = ne if method is Method.NEWTON_EULER else kane
    if stages.outs != rhs:
        kept = stages.optimized(kept.equations, kept.baked)
    return kept.because(reason)


def _cheaper(kane: int, newton_euler: int) -> tuple[Method, str]:
    """The method with fewer operations (a tie: Kane), and the reason in words."""
    said = "right-hand side of {} operations with the L D L^T solve"
    if newton_euler < kane:
        return Method.NEWTON_EULER, f"chosen: a {said.format(newton_euler)}, against Kane's {kane}"
    if kane < newton_euler:
        return Method.KANE, f"chosen: a {said.format(kane)}, against Newton-Euler's {newton_euler}"
    return Method.KANE, (f"chosen: a {said.format(kane)}, as many as Newton-Euler's; a tie goes "
                         f"to Kane")


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


#: The fields of a :class:`~mbgen.model.scene.Scene` that never reach the generated code,
#: left out of the warm cache's key (so that ``mbgen simulate -x ... --t-end ...`` of an
#: unchanged model loads it); every other field is keyed, a field added later included.
SCENE_UNKEYED = {
    "initial_state": "the run's start, given to the compiled model",
    "t_span": "the run's time span",
    "description": "prose for 'mbgen scenes'",
    "closed_form": "the scene's reference solution, for checks",
    "conserves_energy": "what the checks expect of the energy",
    "options": "what made the model and the values: keyed through them",
    "source": "keyed as the label the header records (the file's name, not its folder)",
}


def _warm_key(stages: _Stages, sliced: bool, targets, method) -> str | None:
    """The warm cache's key of a run (:func:`mbgen.build.warm.key`): what it was given, the
    scene's fields but :data:`SCENE_UNKEYED`; None where a value has no canonical form."""
    source = stages.source
    if isinstance(source, Scene):
        source = {f.name: getattr(source, f.name) for f in fields(Scene)
                  if f.name not in SCENE_UNKEYED} | {"label": source_label(source)}
    try:
        return warm_cache.key({"source": source, "outputs": stages.outs,
                               "points": stages.points, "parameters": stages.parameters,
                               "name": stages.name, "fixed": stages.fixed,
                               "inputs": stages.inputs, "sliced": sliced,
                               "cse_backend": stages.cse_backend, "form": stages.form,
                               "targets": targets, "method": method})
    except Uncacheable:
        return None


def _warm_result(rendered: Rendered, stages: _Stages, clock: _Clock,
                 cold: Callable[[], PipelineResult]) -> PipelineResult:
    """The result of a warm run: ``rendered`` from the cache, its module loaded (stage
    ``warm``), the derived values left to ``cold``."""
    cached = compiled_path(rendered).exists()
    compiled = CompiledModel(rendered, clock("warm", load, rendered))
    return PipelineResult(None, None, None, rendered, compiled, clock.timings, cached,
                          {k: float(v) for k, v in (stages.fixed or {}).items()},
                          warm=True, later=cold)


def run(source: Model | Equations | Scene, outputs: Iterable | None = None, *,
        build: bool = True, parameters: Mapping[str, float] | None = None,
        fixed: Mapping[str, float] | None = None, inputs: Sequence[str] | None = None,
        name: str | None = None, sliced: bool = True,
        cse_backend: CseBackend = CseBackend.SYMENGINE, targets=None,
        method: Method | None = None, form: Form | None = None,
        stage: Callable[[str], None] | None = None, timer: StageTimer | None = None,
        comparisons: Comparisons | None = COMPARISONS,
        warm: bool | None = None) -> PipelineResult:
    """Run every stage and time it: derive, bake, optimize, render, and (optionally) compile.

    Where it builds, it first looks for the same inputs in the warm cache
    (:mod:`mbgen.build.warm`: keyed by the model's content, the scene, the outputs and every
    option here, and mbgen's own code): there it loads the compiled module of the stored
    rendered code and derives nothing (:attr:`PipelineResult.warm`); otherwise it runs the
    stages and stores what they rendered.  ``build=False`` always derives.

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
        ``compile``; ``warm`` alone on a warm start) as it starts: the command line's
        progress lines.  While both
        derivations are compared, the first three carry the method: ``derive/kane``.
        Short for ``timer=StageTimer(started=stage)`` (not read when ``timer`` is given).
    timer : StageTimer, optional
        Told as each stage starts and ends (with its seconds and value).
    comparisons : Comparisons or None
        Where the outcomes of comparing both derivations are remembered and looked up
        (default: the process's :data:`COMPARISONS`; None compares afresh and keeps nothing).
    warm : bool, optional
        Use the warm cache (only where ``build``; default: ``$MBGEN_WARM``, else yes, but no
        where a ``timer`` is given: a benchmark times the stages, so it runs them).
    """
    clock = _Clock(timer if timer is not None else StageTimer(started=stage))
    stages = _Stages.of(source, _outputs(source, outputs), clock, parameters, name,
                        fixed, inputs, sliced, cse_backend, form)
    if targets is None and isinstance(source, Scene):
        targets = source.targets
    if targets is not None and not isinstance(targets, Targets):
        raise UsageError(f"run(targets={targets!r}): give an mbgen.codegen.targets.Targets, "
                         f"e.g. Targets(step=True) for the step API; to write named targets' "
                         f"files use mbgen.generate(scene, targets=('c', 'step', ...))")
    if warm is None and timer is not None:
        warm = False
    key = _warm_key(stages, sliced, targets, method) if build and warm_cache.enabled(warm) \
        else None
    stored = clock("warm", warm_cache.lookup, key, quiet=True) if key else None
    if stored is not None:
        cold = functools.partial(run, source, outputs, build=False, parameters=parameters,
                                 fixed=fixed, inputs=inputs, name=name, sliced=sliced,
                                 cse_backend=cse_backend, targets=targets, method=method,
                                 form=form, comparisons=comparisons, warm=False)
        return _warm_result(stored, stages, clock, cold)
    with fewer_collections():
        trial = _chosen(stages, method_of(method) if method is not None else None, comparisons)
        kernel = trial.kernel
        if isinstance(source, Scene) and source.saturate:   # the bounds the step API clamps to
            kernel = replace(kernel, input_bounds=tuple(
                (n, lo, hi) for n, (lo, hi) in sorted(source.input_bounds().items())))
        rendered = clock("render", render, kernel, targets)
    if key:
        warm_cache.store(key, rendered)
    compiled, cached = None, False
    if build:
        cached = compiled_path(rendered).exists()
        compiled = CompiledModel(rendered, clock("compile", load, rendered))
    return PipelineResult(trial.equations, trial.baked, kernel, rendered, compiled,
                          clock.timings, cached,
                          {k: float(v) for k, v in (stages.fixed or {}).items()})


def compile(source: Model | Equations | Scene, outputs: Iterable | None = None, *,
            parameters: Mapping[str, float] | None = None,
            fixed: Mapping[str, float] | None = None, inputs: Sequence[str] | None = None,
            name: str | None = None,
            cse_backend: CseBackend = CseBackend.SYMENGINE, targets=None,
            method: Method | None = None, form: Form | None = None,
            stage: Callable[[str], None] | None = None,
            warm: bool | None = None) -> CompiledModel:
    """Generate, compile (cached by content hash) and load ``source``.

    An unchanged model (the same content, outputs and options, the same mbgen) loads from
    the warm cache without deriving (:mod:`mbgen.build.warm`; ``warm=False`` or
    ``MBGEN_WARM=0`` derives every time).

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
    warm : bool, optional
        Use the warm cache (default: ``$MBGEN_WARM``, else yes).

    Returns
    -------
    CompiledModel
        ``model.rhs(t, x, p=None, r=None)`` and the other requested outputs.
    """
    return run(source, outputs, parameters=parameters, fixed=fixed, inputs=inputs, name=name,
               cse_backend=cse_backend, targets=targets, method=method, form=form,
               stage=stage, warm=warm).compiled
