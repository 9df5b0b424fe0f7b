"""Rendering: ``Kernel -> Rendered`` (file texts and the cffi cdef).

Printers turn expressions into code strings; the Jinja templates in
``templates/`` own the file structure.  Templates receive plain data (strings,
numbers, lists of tuples), never sympy objects or modules.

What is rendered is one loop over the rows of :data:`mbgen.codegen.targets.TARGETS` that are
wanted for the kernel and the user's :class:`~mbgen.codegen.targets.Targets`: each adds its
context, its status codes, its declarations, the sections it includes into the model's
files, its stack bounds and its files (the model's ``.h``, ``.c``, ``.py``; the batch loops
of the Python extension).  Runtime routines are emitted once, where a section first asks
for one (:class:`~mbgen.codegen.targets.runtime.Runtime`).

Text a user controls (model, scene, point and symbol names, descriptions, the
source line, output labels) reaches the templates raw and is escaped where it
lands, by the filter of that context (:mod:`mbgen.codegen.escape`):
``{{ name|c_comment }}`` in a C comment, ``{{ name|py_docstring }}`` in a
Python docstring, ``{{ names|py_list }}`` for a Python list literal.

The C prototypes and ``#define`` constants are produced once and used both by the
header template and by the cdef string, so they cannot drift apart.
"""

from __future__ import annotations

from ..abi import (
    CONSTRAINT_STATUS_CODES,
    CONTACT_STATUS_CODES,
    STATUS_CODES,
    FunctionInfo,
    Output,
    Rendered,
)
from ..names import model_prefix
from . import header as head
from .optimize import Kernel
from .targets import TARGETS, Targets
from .targets.base import EXTENSION, HEADER, SOURCE
from .targets.model import function_views
from .targets.runtime import Runtime
from .templating import environment


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
    prefix = model_prefix(eq.name)
    views = function_views(kernel, prefix)
    active = [t for t in TARGETS if t.wanted(kernel, targets)]
    ctx: dict = {}
    for t in active:
        ctx.update(t.context(kernel, views, prefix))
    codes = STATUS_CODES + tuple(dict.fromkeys(c for t in active for c in t.status_codes))
    if eq.constraints is not None:
        codes += CONSTRAINT_STATUS_CODES
    if eq.contacts is not None:
        codes += CONTACT_STATUS_CODES
    ctx["defines"] += [(f"{prefix.upper()}_{code}", value, text) for code, value, text in codes]
    runtime = Runtime(ctx)
    for t in active:
        ctx["declarations"] += t.declarations(ctx)
        ctx["sections"] += [(tpl, runtime.view(t)) for tpl, where in t.templates(prefix)
                            if where == SOURCE]
    bounds: dict[str, int] = {}
    for t in active:
        bounds.update(t.stack_bounds(kernel, ctx, bounds))
    ctx.update(index_defines=head.index_defines(prefix.upper(), kernel.layout),
               content_hash=head.HASH_PLACEHOLDER, stack_bounds=sorted(bounds.items()))
    env = environment()
    files, extension, cdef = {}, "", []
    for t in active:
        ctx["runtime"] = runtime.view(t)
        for tpl, where in t.templates(prefix):
            if where == EXTENSION:
                extension += env.get_template(tpl).render(ctx)
            elif where not in (HEADER, SOURCE) and t.bundled:
                files[where] = env.get_template(tpl).render(ctx)
        cdef += t.cdef(ctx)
    digest = head.content_hash(files)
    header = f"{prefix}.h"
    files[header] = files[header].replace(f'_CONTENT_HASH "{head.HASH_PLACEHOLDER}"',
                                          f'_CONTENT_HASH "{digest}"')
    declarations = "\n".join([f"#define {n} {v}" for n, v, _ in ctx["defines"]]
                             + ctx["declarations"]) + "\n"
    args = tuple(ctx["args"])
    infos = tuple(FunctionInfo(v["output"], v["name"], args, v["out_size"],
                               tuple(v["out_shape"]), tuple(v["out_labels"])) for v in views.c)
    step_methods = tuple(ctx["step"]["names"]) if "step" in ctx else ()
    c = eq.constraints
    return Rendered(prefix, files, declarations, infos, kernel.layout,
                    {str(sym): eq.defaults[str(sym)] for sym in kernel.layout.parameters
                     if str(sym) in eq.defaults}, kernel.outputs, extension,
                    "\n".join(cdef) + "\n", digest, tuple(sorted(bounds.items())), step_methods,
                    _joints(kernel), c.names if c is not None else
                    eq.contacts.labels() if eq.contacts is not None else (),
                    tuple(map(str, c.dependent_coordinates)) if c is not None else ())


def _joints(kernel: Kernel) -> tuple:
    J = kernel.equations.reactions
    if J is None or Output.REACTIONS not in kernel.outputs:
        return ()
    return tuple(zip(J.names, J.frames))


__all__ = ["render"]
