"""Rendering: ``Kernel -> Rendered`` (file texts and the cffi cdef).

Printers turn expressions into code strings; the Jinja templates in
``templates/`` own the file structure.  Templates receive plain data (strings,
numbers, lists of tuples), never sympy objects or modules.

What is rendered is a loop over targets (:mod:`mbgen.codegen.targets`): the model's
files (:data:`~mbgen.codegen.targets.MODEL`), the sections the wanted targets add
to them (:data:`~mbgen.codegen.targets.SECTIONS`: the integrators when the scene asks
for one, the step API with ``Targets(step=True)``) and the batch loops compiled into
the Python extension (:data:`~mbgen.codegen.targets.BATCH`).

Text a user controls (model, scene, point and symbol names, descriptions, the
source line, output labels) reaches the templates raw and is escaped where it
lands, by the filter of that context (:mod:`mbgen.codegen.escape`):
``{{ name|c_comment }}`` in a C comment, ``{{ name|py_docstring }}`` in a
Python docstring, ``{{ names|py_list }}`` for a Python list literal.

The C prototypes and ``#define`` constants are produced once and used both by the
header template and by the cdef string, so they cannot drift apart.
"""

from __future__ import annotations

from ..abi import CONSTRAINT_STATUS_CODES, STATUS_CODES, FunctionInfo, Output, Rendered
from ..names import model_prefix
from . import header as head
from .optimize import Kernel
from .templating import environment
from .targets import BATCH, MODEL, SECTIONS, STEP, Targets
from .targets.base import EXTENSION, SOURCE
from .targets.model import function_views


def render(kernel: Kernel, targets=None) -> Rendered:
    """Render the C header, C source and Python module of ``kernel``.

    ``targets`` (:class:`mbgen.codegen.targets.Targets`) adds what is rendered besides
    the outputs (the step API).

    Returns
    -------
    Rendered
        Texts are deterministic: the same kernel always gives the same bytes.
    """
    targets = targets or Targets()
    eq = kernel.equations
    L = kernel.layout
    prefix = model_prefix(eq.name)
    upper = prefix.upper()
    c_views, py_views = function_views(kernel, prefix)
    ctx = MODEL.context(kernel, c_views, prefix, py_views)
    sections = [t for t in SECTIONS if t.wanted(kernel, targets)]
    codes = STATUS_CODES + tuple(dict.fromkeys(c for t in sections for c in t.status_codes))
    if eq.constraints is not None:
        codes += CONSTRAINT_STATUS_CODES
    ctx["defines"] += [(f"{upper}_{code}", value, text) for code, value, text in codes]
    for t in sections:
        ctx.update(t.context(kernel, c_views, prefix))
        ctx["declarations"] += t.declarations(ctx)
        ctx["sections"] += [tpl for tpl, where in t.templates(prefix) if where == SOURCE]
    step_methods = tuple(ctx["step"]["names"]) if STEP in sections else ()
    bounds = head.stack_bounds(kernel, c_views, prefix, step_methods)
    ctx.update(index_defines=head.index_defines(upper, L), content_hash=head.HASH_PLACEHOLDER,
               stack_bounds=sorted(bounds.items()))
    env = environment()
    files = {name: env.get_template(tpl).render(ctx) for tpl, name in MODEL.templates(prefix)}
    digest = head.content_hash(files)
    header = f"{prefix}.h"
    files[header] = files[header].replace(f'_CONTENT_HASH "{head.HASH_PLACEHOLDER}"',
                                          f'_CONTENT_HASH "{digest}"')
    ctx.update(BATCH.context(kernel, c_views, prefix))
    extension = "".join(env.get_template(tpl).render(ctx)
                        for tpl, where in BATCH.templates(prefix) if where == EXTENSION)
    cdef = "\n".join([f"#define {n} {v}" for n, v, _ in ctx["defines"]]
                     + ctx["declarations"]) + "\n"
    args = tuple(ctx["args"])
    infos = tuple(FunctionInfo(v["output"], v["name"], args, v["out_size"],
                               tuple(v["out_shape"]), tuple(v["out_labels"])) for v in c_views)
    return Rendered(prefix, files, cdef, infos, L,
                    {str(sym): eq.defaults[str(sym)] for sym in L.parameters
                     if str(sym) in eq.defaults}, kernel.outputs, extension,
                    "\n".join(BATCH.declarations(ctx)) + "\n", digest,
                    tuple(sorted(bounds.items())), step_methods, _joints(kernel),
                    eq.constraints.names if eq.constraints is not None else (),
                    tuple(map(str, eq.constraints.dependent_coordinates))
                    if eq.constraints is not None else ())


def _joints(kernel: Kernel) -> tuple:
    J = kernel.equations.reactions
    if J is None or Output.REACTIONS not in kernel.outputs:
        return ()
    return tuple(zip(J.names, J.frames))


__all__ = ["render"]
