r"""Into the optimisers and the learners: a model as a CasADi function and as a JAX function.

``casadi_function(source, output="rhs")`` returns a ``casadi.Function`` ``f(t, x, p, r)``
backed by mbgen's compiled C through CasADi's external-function interface
(:mod:`mbgen.codegen.targets.casadi`); for the right-hand side its Jacobian
``jac_<name>`` is mbgen's analytic one, so ``nlpsol``, ``integrator`` and any ``MX`` graph
get exact first derivatives and CasADi never differentiates numerically.  The library is
compiled once into the cache (:func:`mbgen.build.library.shared_library`).

``jax_function(source, output="rhs")`` returns a pure function ``f(t, x, p=None, r=None)``
printed from the same CSE'd kernel into ``jax.numpy`` (:mod:`mbgen.codegen.targets.jax`):
``jax.jit``, ``jax.vmap``, ``jax.jacfwd``, ``jax.jacrev`` and ``jax.grad`` work on it.
It computes in float64 only with ``jax.config.update("jax_enable_x64", True)`` (JAX's
default is float32).

``source`` is a :class:`~mbgen.Scene`, :class:`~mbgen.Model` or
:class:`~mbgen.Equations` (generated here, with the derivative outputs the CasADi Jacobian
needs), a :class:`~mbgen.pipeline.PipelineResult` (``mbgen.run(..., build=False)``), or for
CasADi a compiled model (which must carry those derivative outputs; dense blocks, since its
kernel is not at hand).  ``casadi`` and ``jax`` are optional extras (``pip install
'mbgen[casadi]'``, ``'mbgen[jax]'``); without them a :class:`~mbgen.errors.MissingExtraError`
says so.
"""

from __future__ import annotations

import hashlib
import os
import re
import tempfile
import threading
import types
from pathlib import Path

from .abi import Output
from .build.cache import loadable
from .build.extension import cflags
from .build.library import shared_library
from .codegen.targets.casadi import default_name, externals, missing_derivatives, render_glue
from .codegen.targets.jax import jax_module_text, refusal
from .errors import BuildError, MissingExtraError, ModelError, UsageError
from .model.builder import Model
from .model.scene import Scene
from .pipeline import PipelineResult, run
from .runtime.compiled import CompiledModel
from .symbolic.availability import require, time_symbols
from .symbolic.equations import Equations

#: The outputs a right-hand side's CasADi Jacobian is filled from, besides ``jacobian``.
_OPTIONAL = (Output.PARAMETER_JACOBIAN, Output.INPUT_JACOBIAN)

_lock = threading.Lock()
_functions: dict = {}     # (library, name, options) -> casadi.Function
_modules: dict = {}       # sha256 of a JAX module's text -> module


def _import(name: str, extra: str, what: str):
    try:
        return __import__(name)
    except ImportError:
        raise MissingExtraError(f"{what} needs {name}, which is not installed: pip install "
                                f"'mbgen[{extra}]' (or pip install {name})") from None


def _generated(source, output: Output, derivatives: bool) -> PipelineResult:
    """The pipeline's result for ``source`` with ``output`` and, for the right-hand side with
    ``derivatives``, every derivative output its CasADi Jacobian reads that the equations
    have: in one run, ``time_derivative`` (zeros for a model that does not depend on ``t``)
    and the parameter and input Jacobians where the model has free parameters and inputs
    (:func:`_free`); should one of them not exist after all (a free parameter that the
    motion does not read), the baked equations say which do."""
    if isinstance(source, PipelineResult):
        return source
    if not isinstance(source, (Scene, Model, Equations)):
        raise UsageError(f"expected a Scene, Model, Equations, a compiled model or "
                         f"mbgen.run(..., build=False)'s result, got {type(source).__name__}")
    if output is not Output.RHS or not derivatives:
        return run(source, [output], build=False)
    base = [Output.RHS, Output.JACOBIAN, Output.TIME_DERIVATIVE]
    try:
        return run(source, base + [o for o, free in zip(_OPTIONAL, _free(source)) if free],
                   build=False)
    except ModelError:
        pass
    first = run(source, base, build=False)
    more = [o for o in _OPTIONAL if _available(first.baked, o)]
    if not more:
        return first
    return run(first.baked, base + more, build=False, name=first.rendered.prefix)


def _free(source) -> tuple[bool, bool]:
    """Whether ``source`` has (parameters, inputs) left free at run time."""
    scene = source if isinstance(source, Scene) else None
    model = scene.model if scene is not None else source
    if isinstance(model, Equations):
        params, inputs = model.layout.parameter_names, model.layout.input_names
    else:
        params = [str(c) for c in model.constants_]
        inputs = [str(getattr(r, "func", r)) for r in model.inputs_]
    if scene is not None:
        params = [p for p in params if p not in scene.fixed]
        inputs = [r for r in inputs if scene.inputs is None or r in scene.inputs]
    return bool(params), bool(inputs)


def _available(eq: Equations, output: Output) -> bool:
    try:
        require(eq, output)
    except ModelError:
        return False
    return True


def _missing(kernel, rendered) -> list[str]:
    """The derivative outputs a given compiled model or pipeline result lacks."""
    if kernel is not None:
        uses_time = kernel.layout.time in time_symbols(kernel.equations)
    else:
        uses_time = _uses_time(rendered)
    return missing_derivatives(rendered.layout, rendered.outputs, uses_time)


def _uses_time(rendered) -> bool:
    """Whether the compiled right-hand side reads ``t`` (its C does not start with
    ``(void)t;``)."""
    [info] = [f for f in rendered.functions if f.output == Output.RHS.value]
    head = re.search(rf"int {info.c_name}\(double t[^)]*\)\n\{{\n(.*)", rendered.source)
    return head is None or head.group(1).strip() != "(void)t;"


def casadi_function(source, output="rhs", *, name: str | None = None, sparse: bool = True,
                    derivatives: bool = True, options: dict | None = None):
    """``output`` of ``source`` as a ``casadi.Function`` ``name(t, x, p, r)``.

    Parameters
    ----------
    source : Scene, Model, Equations, PipelineResult or CompiledModel
    output : Output or str
        What it computes (default the right-hand side ``dxdt``, shape ``(n_x, 1)``).
    name : str, optional
        The CasADi function's name (default ``<prefix>_<output>_casadi``).
    sparse : bool
        Outputs with their true sparsity (default; a compiled model's are dense).
    derivatives : bool
        For the right-hand side: generate (or require) ``jacobian`` and, where the model
        has them, ``parameter_jacobian``, ``input_jacobian`` and ``time_derivative``, and
        expose them as ``jac_<name>``.  False: values only (CasADi then has no derivative,
        unless ``options`` switch on its finite differences).
    options : dict, optional
        CasADi's options of the external (``casadi.external(name, library, options)``),
        e.g. ``{"enable_fd": True}``.

    Returns
    -------
    casadi.Function
        Inputs ``t`` (1), ``x`` (n_x), ``p`` (n_p), ``r`` (n_r); one output.  Its
        evaluation fails (CasADi raises) where the C returns a nonzero status (a mass
        matrix that is not positive definite, a non-finite result).

    Raises
    ------
    MissingExtraError
        CasADi is not installed.
    UsageError
        A compiled model or pipeline result without the derivative outputs (generate it
        with them, or pass ``derivatives=False``); an output it was not generated with.
    """
    ca = _import("casadi", "casadi", "casadi_function")
    output = Output.parse(output)[0]
    if isinstance(source, CompiledModel):
        kernel, rendered = None, source.rendered
    else:
        result = _generated(source, output, derivatives)
        kernel, rendered = result.kernel, result.rendered
    if derivatives and output is Output.RHS and isinstance(source, (CompiledModel,
                                                                     PipelineResult)):
        missing = _missing(kernel, rendered)
        if missing:
            raise UsageError(f"casadi_function: {rendered.prefix!r} has no "
                             f"{', '.join(missing)} for CasADi's Jacobian; generate it with "
                             f"outputs=[..., {', '.join(map(repr, missing))}], pass the Scene "
                             f"or Model instead, or derivatives=False")
    if output.value not in {f.output for f in rendered.functions}:
        raise UsageError(f"casadi_function: {rendered.prefix!r} was not generated with "
                         f"{output.value!r}; give a source that has it")
    name = name or default_name(rendered.prefix, output)
    functions = externals(rendered, output, name, kernel, sparse, derivatives)
    glue = f"{rendered.prefix}_casadi.c"
    files = {f"{rendered.prefix}.h": rendered.header, f"{rendered.prefix}.c": rendered.source,
             glue: render_glue(rendered, functions)}
    path = shared_library(rendered.prefix, files, (f"{rendered.prefix}.c", glue),
                          cflags(rendered))
    with _lock:
        key = (path, name, repr(sorted((options or {}).items())))
        f = _functions.get(key)
        if f is None:
            f = _external(ca, name, path, options or {})
            _functions[key] = f
    return f


def _external(ca, name: str, path: Path, options: dict):
    """``casadi.external(name, ...)`` of the checked bytes of ``path``
    (:func:`~mbgen.build.cache.loadable`), through a link in a new private folder: CasADi
    wants a file name with the library's suffix, and ``/proc/self/fd/<n>`` has none."""
    with loadable(path) as origin:
        if origin is None:
            raise BuildError(f"the library {path} is not the user's own build, whole and "
                             f"unchanged; remove it and call again")
        with tempfile.TemporaryDirectory(prefix="_mbgen_casadi-") as tmp:
            link = Path(tmp) / path.name
            os.symlink(origin, link)
            return ca.external(name, str(link), options)


def jax_function(source, output="rhs"):
    """``output`` of ``source`` as a pure JAX function ``f(t, x, p=None, r=None)``.

    Printed from the CSE'd kernel into ``jax.numpy`` (the ``L D L^T`` solve written out):
    ``jax.jit``, ``jax.vmap``, ``jax.jacfwd`` / ``jax.jacrev`` / ``jax.grad`` apply.
    ``p`` defaults to the model's default parameters, ``r`` to zeros; the function's
    attributes ``state_names``, ``parameter_names``, ``input_names`` and
    ``default_parameters`` (a tuple, or None) give the layout.  Float64 needs
    ``jax.config.update("jax_enable_x64", True)``.  Where the C would return an error
    status (a mass matrix that is not positive definite), the result is NaN: a traced
    function cannot raise on values.

    Parameters
    ----------
    source : Scene, Model, Equations or PipelineResult
    output : Output or str
        Default the right-hand side (shape ``(n_x,)``); any unconstrained output.

    Raises
    ------
    MissingExtraError
        JAX is not installed.
    UsageError
        A compiled model (its kernel is gone: pass the Scene or Model); a constrained
        model (the JAX printer writes no KKT solve).
    """
    _import("jax", "jax", "jax_function")
    output = Output.parse(output)[0]
    if isinstance(source, CompiledModel):
        raise UsageError("jax_function prints the model's kernel, which a compiled model no "
                         "longer holds: pass the Scene or Model it was compiled from")
    result = _generated(source, output, derivatives=False)
    why = refusal(result.kernel)
    if why:
        raise UsageError(f"jax_function: {why}")
    if output not in result.kernel.outputs or output.is_integrator:
        raise UsageError(f"jax_function: {result.rendered.prefix!r} was not generated with "
                         f"{output.value!r} (an expression output); give a source that has it")
    text = jax_module_text(result.kernel, result.rendered.prefix)
    key = hashlib.sha256(text.encode()).hexdigest()
    with _lock:
        module = _modules.get(key)
        if module is None:
            module = types.ModuleType(f"mbgen_jax_{result.rendered.prefix}")
            exec(compile(text, f"<mbgen jax {result.rendered.prefix}>", "exec"),
                 module.__dict__)
            _modules[key] = module
    fn = getattr(module, output.value)
    fn.state_names, fn.parameter_names, fn.input_names = (
        tuple(module.STATE_NAMES), tuple(module.PARAMETER_NAMES), tuple(module.INPUT_NAMES))
    fn.default_parameters = module.DEFAULT_PARAMETERS
    return fn


__all__ = ["casadi_function", "jax_function"]
