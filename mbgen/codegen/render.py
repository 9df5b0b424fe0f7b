"""Rendering: ``Kernel -> Rendered`` (file texts and the cffi cdef).

Printers turn expressions into code strings; the Jinja templates in
``templates/`` own the file structure.  Templates receive plain data (strings,
numbers, lists of tuples), never sympy objects or modules.

Text a user controls (model, scene, point and symbol names, descriptions, the
source line, output labels) reaches the templates raw and is escaped where it
lands, by the filter of that context (:mod:`mbgen.codegen.escape`):
``{{ name|c_comment }}`` in a C comment, ``{{ name|py_docstring }}`` in a
Python docstring, ``{{ names|py_list }}`` for a Python list literal.

The C prototypes and ``#define`` constants are produced once here and used both
by the header template and by the cdef string, so they cannot drift apart.
"""

from __future__ import annotations

from .._version import __version__
from ..abi import (CONSTRAINT_STATUS_CODES, INTEGRATOR_STATUS_CODES, STATUS_CODES, FunctionInfo,
                   Output, Rendered)
from ..names import model_prefix
from .optimize import Kernel, KernelFunction
from .outputs import Form
from ..symbolic.equations import acceleration_symbols, lambda_symbols
from .printing import CPrinter, PyPrinter, math_functions
from .solver import UNROLL_MAX, c_lines, factor_program, py_lines, solve_program
from .templating import environment
from .integrators import integrator_context
from .targets import Targets, batch, step
from . import header as head


def _signature_args(kernel: Kernel) -> tuple[str, ...]:
    L = kernel.layout
    return ("t", "x") + (("p",) if L.n_p else ()) + (("r",) if L.n_r else ())


def _view(kernel: Kernel, fn: KernelFunction, prefix: str, printer) -> dict:
    """Plain-data description of one function for the templates."""
    L = kernel.layout
    s = fn.spec
    arrays = L.arrays()
    loads = [(L.identifiers[sym], arrays[sym][0], arrays[sym][1]) for sym in fn.symbols_used
             if sym != L.time]
    args = _signature_args(kernel)

    def blocks(bs):
        return [dict(name=s.out_name if b.name == "out" else b.name, local=b.name != "out",
                     size=b.size, assignments=[(i, printer.doprint(e)) for i, e in b.entries],
                     mirror=list(b.mirror)) for b in bs]

    def temps(ts):
        return [(printer.doprint(sym), printer.doprint(e), sym in fn.checks) for sym, e in ts]

    return dict(
        output=s.output.value,
        name=f"{prefix}_{s.output.value}",
        py_name=s.output.value,
        doc=s.doc,
        out=s.out_name,
        out_size=s.out_size,
        out_shape=list(s.out_shape),
        out_labels=list(s.labels),
        args=list(args),
        unused=[a for a in args if a not in fn.uses],
        time_name=L.identifiers[L.time],
        uses_time=L.time in fn.symbols_used,
        loads=loads,
        temps=temps(fn.temporaries),
        pre=blocks(fn.pre),
        solve=s.solve,
        rhs=s.output is Output.RHS and s.solve,
        post_temps=temps(fn.post_temporaries),
        post=blocks(fn.post),
        columns=s.columns,
        implicit=s.implicit,
        velocity=blocks(fn.velocity),
        velocity_temps=temps(fn.velocity_temporaries),
        n_q=L.n_q,
        n_u=L.n_u,
        ops_before=fn.ops_before,
        ops_after=fn.ops_after,
    )


def _c_prototype(fn_view: dict, args) -> str:
    params = ["double t" if a == "t" else f"const double *{a}" for a in args]
    params.append(f"double *{fn_view['out']}")
    return f"int {fn_view['name']}({', '.join(params)})"


def render(kernel: Kernel, targets=None) -> Rendered:
    """Render the C header, C source and Python module of ``kernel``.

    ``targets`` (:class:`mbgen.codegen.targets.Targets`) adds what is rendered besides
    the outputs (the step API).

    Returns
    -------
    Rendered
        Texts are deterministic: the same kernel always gives the same bytes.
    """
    eq = kernel.equations
    L = kernel.layout
    prefix = model_prefix(eq.name)
    names = dict(L.identifiers)
    for fn in kernel.functions:
        for sym, _ in fn.velocity_temporaries + fn.temporaries + fn.post_temporaries:
            names[sym] = str(sym)
    c_names, py_names = dict(names), dict(names)
    constrained = eq.constraints is not None
    for i, a in enumerate(acceleration_symbols(L.n_u + L.n_d)):
        c_names[a] = py_names[a] = f"ACC[{i}]" if constrained else f"F[{i}]"
    if constrained:
        for i, u in enumerate(L.dependent_speeds):
            c_names[u] = py_names[u] = f"UR[{i}]"
        for i, lam in enumerate(lambda_symbols(eq.constraints.m)):
            c_names[lam] = py_names[lam] = f"LAM[{i}]"
    args = _signature_args(kernel)
    c_views = [_view(kernel, fn, prefix, CPrinter(c_names)) for fn in kernel.functions]
    py_views = [_view(kernel, fn, prefix, PyPrinter(py_names)) for fn in kernel.functions]
    for v in c_views:
        v["prototype"] = _c_prototype(v, args)

    upper = prefix.upper()
    defaults = [eq.defaults.get(str(sym)) for sym in L.parameters]
    has_defaults = bool(L.parameters) and all(d is not None for d in defaults)
    defines = [(f"{upper}_N_Q", L.n_q, "number of generalized coordinates"),
               (f"{upper}_N_U", L.n_u, "number of generalized speeds"),
               (f"{upper}_N_X", L.n_x, "length of the state x = [q, u]"),
               (f"{upper}_N_P", L.n_p, "number of parameters"),
               (f"{upper}_N_R", L.n_r, "number of inputs")]
    targets = targets or Targets()
    codes = STATUS_CODES + (INTEGRATOR_STATUS_CODES if kernel.integrators or targets.step
                            else ())
    if eq.constraints is not None:
        codes += CONSTRAINT_STATUS_CODES
    defines += [(f"{upper}_{code}", value, text) for code, value, text in codes]
    prototypes = [v["prototype"] + ";" for v in c_views]
    if has_defaults:
        prototypes.append(f"void {prefix}_default_parameters(double *p);")

    exprs = [e for fn in kernel.functions for _, e in
             fn.velocity_temporaries + fn.temporaries + fn.post_temporaries] + [
        e for fn in kernel.functions for b in fn.velocity + fn.pre + fn.post for _, e in b.entries]
    funcs = sorted(math_functions(exprs))
    any_solve = any(fn.spec.solve for fn in kernel.functions)
    unrolled = any_solve and L.n_u <= UNROLL_MAX
    factor = factor_program(L.n_u, kernel.mass_pattern) if unrolled else []
    ctx = dict(
        version=__version__,
        prefix=prefix,
        upper=upper,
        name=eq.name,
        source=eq.source or eq.name,
        method=str(eq.method),
        cse=kernel.cse_backend.value,
        states=list(enumerate(L.state_names)),
        n_q=L.n_q,
        n_u=L.n_u,
        n_x=L.n_x,
        parameters=[(i, n, None if d is None else repr(float(d)))
                    for i, (n, d) in enumerate(zip(L.parameter_names, defaults))],
        inputs=list(enumerate(L.input_names)),
        state_names=list(L.state_names),
        parameter_names=list(L.parameter_names),
        input_names=list(L.input_names),
        default_values=[repr(float(d)) for d in defaults] if has_defaults else [],
        has_defaults=has_defaults,
        defines=defines,
        functions=c_views,
        math_functions=funcs,
        ops_before=kernel.ops_before,
        ops_after=kernel.ops_after,
        any_solve=any_solve,
        unrolled=unrolled,
        ldl_factor_c=c_lines(factor, f"{upper}_NOT_POSITIVE_DEFINITE") if unrolled else [],
        ldl_solve_c=c_lines(solve_program(L.n_u, kernel.mass_pattern), "") if unrolled else [],
        ldl_factor_py=py_lines(factor, "NotPositiveDefinite('mass matrix is not positive "
                                       "definite')") if unrolled else [],
        ldl_solve_py=py_lines(solve_program(L.n_u, kernel.mass_pattern, "b", "o + "), "")
        if unrolled else [],
        needs_math=bool(funcs) or bool(kernel.integrators) or eq.constraints is not None,
        any_columns=any(fn.spec.columns for fn in kernel.functions),
        args=list(args),
        integrators=[o.value for o in kernel.integrators],
        recursive=kernel.form is Form.RECURSIVE,
        constrained=constrained,
        m=eq.constraints.m if constrained else 0,
        n_all=L.n_u + L.n_d,
        any_kkt=constrained and any_solve,
    )
    env = environment()
    declarations = list(prototypes)
    if kernel.integrators:
        ctx.update(integrator_context(kernel))
        declarations.append(env.get_template("integrators/integrators.h.j2").render(ctx).strip())
    methods = ()
    if targets.step:
        ctx.update(step.step_context(kernel, prefix))
        methods = tuple(ctx["step"]["methods"])
        declarations.append(env.get_template("step/step.h.j2").render(ctx).strip())
    bounds = head.stack_bounds(kernel, c_views, prefix, methods,
                               ctx.get("integ", ctx.get("step", {})).get("non_autonomous",
                                                                          False))
    ctx.update(index_defines=head.index_defines(upper, L), content_hash=head.HASH_PLACEHOLDER,
               stack_bounds=sorted(bounds.items()), step_target=bool(methods))
    ctx["declarations"] = declarations
    header = env.get_template("model/model.h.j2").render(ctx)
    source = env.get_template("model/model.c.j2").render(ctx)
    python = env.get_template("model/model.py.j2").render(dict(ctx, functions=py_views))
    digest = head.content_hash({f"{prefix}.h": header, f"{prefix}.c": source,
                                f"{prefix}.py": python})
    header = header.replace(f'_CONTENT_HASH "{head.HASH_PLACEHOLDER}"', f'_CONTENT_HASH "{digest}"')
    ext_source, ext_cdef = batch.batch_source(kernel, c_views, prefix)
    cdef = "\n".join([f"#define {n} {v}" for n, v, _ in defines] + declarations) + "\n"
    infos = tuple(FunctionInfo(v["output"], v["name"], tuple(args), v["out_size"],
                               tuple(v["out_shape"]), tuple(v["out_labels"])) for v in c_views)
    return Rendered(prefix, {f"{prefix}.h": header, f"{prefix}.c": source,
                             f"{prefix}.py": python}, cdef, infos, L,
                    {str(sym): eq.defaults[str(sym)] for sym in L.parameters
                     if str(sym) in eq.defaults}, kernel.outputs, ext_source, ext_cdef, digest,
                    tuple(sorted(bounds.items())), methods, _joints(kernel),
                    eq.constraints.names if eq.constraints is not None else (),
                    tuple(map(str, eq.constraints.dependent_coordinates))
                    if eq.constraints is not None else ())


def _joints(kernel: Kernel) -> tuple:
    J = kernel.equations.reactions
    if J is None or Output.REACTIONS not in kernel.outputs:
        return ()
    return tuple(zip(J.names, J.frames))


__all__ = ["render"]
