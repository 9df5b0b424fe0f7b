"""The pipeline, one line per stage.

::

    Model --derive--> Equations --bake--> Equations --optimize--> Kernel --render--> Rendered
          --build--> CompiledModel

``bake`` is the scene's slice: fixed parameters become numbers and absent
inputs zero (:mod:`mbgen.codegen.slicing`); ``optimize`` keeps only the requested
outputs and the parameters they read (:mod:`mbgen.codegen.optimize`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Callable, Iterable, Mapping, Sequence

from .build.extension import compiled_path, load
from .derive import Method, derive
from .symbolic.equations import Equations
from .errors import ModelError
from .model.builder import Model
from .codegen.optimize import CseBackend, Form, Kernel, optimize
from .abi import Output
from .abi import Rendered
from .codegen.render import render
from .run.compiled import CompiledModel
from .model.scene import Scene, source_label
from .codegen.slicing import bake


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
                 reactions: bool = False) -> Equations:
    """Derive (for a ``Model`` or a scene holding one) or pass through ``Equations``.

    A scene's parameter values become the equations' defaults and its name and
    file the equations' source line.  ``energy``: derive energies too;
    ``points``: names of points whose position and velocity to carry (``None``:
    the scene's points, else none).
    """
    if isinstance(source, Scene):
        eq = equations_of(source.model, method or source.method, energy=energy,
                          points=source.points if points is None else points,
                          reactions=reactions)
        src = source_label(source)  # the file's name, never the path as typed
        return replace(eq, defaults={**eq.defaults, **{k: float(v) for k, v in
                                                          source.parameters.items()}},
                       source=src)
    if isinstance(source, Model):
        return derive(source, method or Method.KANE, energy=energy, points=tuple(points or ()),
                      reactions=reactions)
    if isinstance(source, Equations):
        return source
    raise ModelError(f"expected a Model, Equations or Scene, got {type(source).__name__}")


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
        Derivation method (default: the scene's, else ``Method.KANE``).
    form : Form, optional
        How ``u'`` is computed (default: chosen by operation count; see
        :func:`mbgen.codegen.optimize.optimize`).
    stage : callable, optional
        Called with each stage's name (``derive``, ``bake``, ``cse``, ``render``,
        ``compile``) as it starts: the command line's progress lines.
    """
    outs = _outputs(source, outputs)
    scene = source if isinstance(source, Scene) else None
    timings: dict[str, float] = {}

    def timed(name, fn, *args, **kw):
        if stage is not None:
            stage(name)
        t0 = time.perf_counter()
        value = fn(*args, **kw)
        timings[name] = time.perf_counter() - t0
        return value

    wants_points = bool({Output.POSITIONS, Output.VELOCITIES} & set(outs))
    points = None if not wants_points or (scene and scene.points) else _all_points(source)
    equations = timed("derive", equations_of, source, method,
                      reactions=Output.REACTIONS in outs, energy=Output.ENERGY in outs,
                      points=points)
    if parameters:
        equations = replace(equations, defaults={**equations.defaults,
                                                 **{k: float(v) for k, v in parameters.items()}})
    name = name or (scene.prefix if scene and scene.prefix else None)
    if name:
        equations = replace(equations, name=name)
    if fixed is None and sliced and scene:
        fixed = scene.fixed
    if inputs is None and sliced and scene:
        inputs = scene.inputs
    if targets is None and scene:
        targets = scene.targets
    baked = timed("bake", bake, equations, fixed, inputs)
    kernel = timed("cse", optimize, baked, outs, cse_backend, form)
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
        ``Method.KANE`` or ``Method.NEWTON_EULER`` (default: the scene's, else Kane).
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
