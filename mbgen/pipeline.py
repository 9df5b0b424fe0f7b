"""The pipeline, one line per stage.

::

    Model --derive--> Equations --optimize--> Kernel --render--> Rendered --build--> CompiledModel
"""

from __future__ import annotations

import builtins
import time
import types
from dataclasses import dataclass, field, replace
from typing import Iterable, Mapping

from .build import compiled_path, load
from .derive import Method, derive
from .equations import Equations
from .errors import ModelError
from .model import Model
from .optimize import CseBackend, Kernel, Output, optimize
from .render import Rendered, render
from .runtime import CompiledModel, PythonModel
from .scene import Scene


@dataclass(frozen=True)
class PipelineResult:
    """Every value the pipeline produced, and how long each stage took (seconds)."""

    equations: Equations
    kernel: Kernel
    rendered: Rendered
    compiled: CompiledModel | None
    timings: Mapping[str, float] = field(default_factory=dict)
    compile_cached: bool = False


def equations_of(source: Model | Equations | Scene, method: Method = Method.KANE, *,
                 energy: bool = True) -> Equations:
    """Derive (for a ``Model`` or a scene holding one) or pass through ``Equations``.

    A scene's parameter values become the equations' defaults and its name and
    file the equations' source line.  ``energy``: derive energies too.
    """
    if isinstance(source, Scene):
        eq = equations_of(source.model, method, energy=energy)
        src = f"scene {source.name!r} ({source.source})" if source.source else f"scene {source.name!r}"
        return replace(eq, defaults={**eq.defaults, **{k: float(v) for k, v in
                                                          source.parameters.items()}},
                       source=src)
    if isinstance(source, Model):
        return derive(source, method, energy=energy)
    if isinstance(source, Equations):
        return source
    raise ModelError(f"expected a Model, Equations or Scene, got {type(source).__name__}")


def _outputs(source, outputs) -> tuple[Output, ...]:
    if outputs is None:
        outputs = source.outputs if isinstance(source, Scene) else (Output.RHS,)
    if isinstance(outputs, (str, Output)):
        outputs = (outputs,)
    return Output.parse(outputs)


def run(source: Model | Equations | Scene, outputs: Iterable | None = None, *,
        build: bool = True, parameters: Mapping[str, float] | None = None,
        cse_backend: CseBackend = CseBackend.SYMENGINE) -> PipelineResult:
    """Run every stage and time it: derive, optimize, render, and (optionally) compile."""
    outs = _outputs(source, outputs)
    timings: dict[str, float] = {}

    def timed(stage, fn, *args, **kw):
        t0 = time.perf_counter()
        value = fn(*args, **kw)
        timings[stage] = time.perf_counter() - t0
        return value

    equations = timed("derive", equations_of, source, energy=Output.ENERGY in outs)
    if parameters:
        equations = replace(equations, defaults={**equations.defaults,
                                                 **{k: float(v) for k, v in parameters.items()}})
    kernel = timed("cse", optimize, equations, outs, cse_backend)
    rendered = timed("render", render, kernel)
    compiled, cached = None, False
    if build:
        cached = compiled_path(rendered).exists()
        module = timed("compile", load, rendered)
        compiled = CompiledModel(rendered, module, equations.layout, equations.defaults,
                                 kernel.outputs)
    return PipelineResult(equations, kernel, rendered, compiled, timings, cached)


def compile(source: Model | Equations | Scene, outputs: Iterable | None = None, *,
            parameters: Mapping[str, float] | None = None,
            cse_backend: CseBackend = CseBackend.SYMENGINE) -> CompiledModel:
    """Generate, compile (cached by content hash) and load ``source``.

    Parameters
    ----------
    source : Model, Equations or Scene
    outputs : iterable of Output or names, optional
        Default: the scene's outputs, else ``{Output.RHS}``.
    parameters : mapping, optional
        Default parameter values (override a scene's).

    Returns
    -------
    CompiledModel
        ``model.rhs(t, x, p=None, r=None)`` and the other requested outputs.
    """
    return run(source, outputs, parameters=parameters, cse_backend=cse_backend).compiled


def python_model(rendered: Rendered, equations: Equations, outputs: Iterable) -> PythonModel:
    """Load the generated Python module of ``rendered`` (no files written)."""
    name = f"mbgen_generated_{rendered.prefix}"
    module = types.ModuleType(name)
    module.__file__ = f"<generated {rendered.prefix}.py>"
    exec(builtins.compile(rendered.python, module.__file__, "exec"), module.__dict__)
    return PythonModel(rendered, module, equations.layout, equations.defaults, Output.parse(outputs))

