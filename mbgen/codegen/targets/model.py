"""The model's targets: ``c`` (``<prefix>.h``, ``<prefix>.c``) and ``python`` (``<prefix>.py``),
both from ``templates/model/``.

Every function of the kernel becomes a plain-data view (:func:`function_views`:
strings, numbers, lists of tuples, never sympy objects) printed once in C and once
in Python (:class:`Views`); :data:`C`'s context adds what the whole files state (names,
sizes, the ``#define`` sizes, the ``L D L^T`` solver's lines) and :data:`PYTHON`'s the
Python views.  The other targets' sections are merged in by
:func:`mbgen.codegen.render.render`.

The C prototypes are produced once here and used both by the header template and
by the cdef string, so they cannot drift apart.

Stack bounds (:meth:`ModelC.stack_bounds`): a function's own automatic storage
(:func:`function_bytes`; a split function's largest part, :func:`part_bytes`) over the
deepest routine it calls: ``all_finite``, the ``L D L^T`` and its row-wise column solve,
a constrained model's velocity and KKT solves over the LU.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

from ..._version import __version__
from ...abi import Output
from ...symbolic.equations import acceleration_symbols, lambda_symbols
from ..contacts import contact_solver
from ..header import SMALL, frame
from ..optimize import Kernel, KernelFunction
from ..outputs import Form
from ..pairs import columns_target, dt_slots, lines
from ..printing import SORT_TERMS_MAX_OPS, CPrinter, PyPrinter, math_functions
from ..solver import UNROLL_MAX, c_lines, factor_program, pivot_factor, py_lines, solve_program
from ..split import split_view
from ..tree_solve import vector_lines
from .base import Job, Target
from .runtime import model_tree, routine_bounds, routine_context, unread_m


def signature_args(kernel: Kernel) -> tuple[str, ...]:
    """Arguments of every generated function: ``t, x`` and ``p``, ``r`` when there are any."""
    L = kernel.layout
    return ("t", "x") + (("p",) if L.n_p else ()) + (("r",) if L.n_r else ())


def _view(kernel: Kernel, fn: KernelFunction, prefix: str, printer) -> dict:
    """Plain-data description of one function for the templates."""
    L = kernel.layout
    s = fn.spec
    arrays = L.arrays()
    loads = [(L.identifiers[sym], arrays[sym][0], arrays[sym][1]) for sym in fn.symbols_used
             if sym != L.time]
    args = signature_args(kernel)

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
        contact=s.contact,
        forces=s.forces,
        stride=s.stride,
        velocity=blocks(fn.velocity),
        velocity_temps=temps(fn.velocity_temporaries),
        n_q=s.first_row,   # the solved rows start here (below q', or at 0)
        n_u=L.n_u,
        ops_before=fn.ops_before,
        ops_after=fn.ops_after,
    )


def _c_prototype(fn_view: dict, args) -> str:
    params = ["double t" if a == "t" else f"const double *{a}" for a in args]
    params.append(f"double *{fn_view['out']}")
    return f"int {fn_view['name']}({', '.join(params)})"


@dataclass(frozen=True)
class Views:
    """The functions of a kernel as plain data, once for C and once for Python.

    Attributes
    ----------
    c, python : list of dict
        One view per function (:func:`function_views`); a C view has its ``prototype``.
    """

    c: list
    python: list


def function_views(kernel: Kernel, prefix: str) -> Views:
    """The C and Python views of every function of ``kernel``."""
    eq = kernel.equations
    L = kernel.layout
    names = dict(L.identifiers)
    for fn in kernel.functions:
        for sym, _ in fn.velocity_temporaries + fn.temporaries + fn.post_temporaries:
            names[sym] = str(sym)
    c_names, py_names = dict(names), dict(names)
    constrained = eq.constraints is not None
    for i, a in enumerate(acceleration_symbols(L.n_u + L.n_d)):
        c_names[a] = py_names[a] = f"ACC[{i}]" if constrained else f"F[{i}]"
    if eq.contacts is not None:   # the contact forces, solved into LAM with u' into F
        for i, lam in enumerate(lambda_symbols(eq.contacts.m)):
            c_names[lam] = py_names[lam] = f"LAM[{i}]"
    if constrained:
        for i, u in enumerate(L.dependent_speeds):
            c_names[u] = py_names[u] = f"UR[{i}]"
        for i, lam in enumerate(lambda_symbols(eq.constraints.m)):
            c_names[lam] = py_names[lam] = f"LAM[{i}]"
    args = signature_args(kernel)
    sort = kernel.ops_after <= SORT_TERMS_MAX_OPS
    c_views = [_view(kernel, fn, prefix, CPrinter(c_names, sort)) for fn in kernel.functions]
    solver = contact_solver(eq) if eq.contacts is not None else None
    for v in c_views:   # contact columns: the solves as vector loops (mbgen.codegen.contacts)
        v["contact_columns"] = solver.columns_c(v["stride"], CONTACT_ARRAYS) \
            if v["contact"] and v["columns"] else []
    py_views = [_view(kernel, fn, prefix, PyPrinter(py_names, sort)) for fn in kernel.functions]
    _tree_views(kernel, c_views, py_views)
    for v in c_views:
        v["prototype"] = _c_prototype(v, args)
        if constrained:     # its temporaries may read ACC, LAM, UR: kept in one function
            split_view(v, L.identifiers[L.time], (), split_chars=float("inf"))
        else:
            split_view(v, L.identifiers[L.time], (("F", "LAM") if v["contact"] else ("F",))
                       if v["solve"] else ())
    return Views(c_views, py_views)


def _tree_views(kernel: Kernel, c_views: list, py_views: list) -> None:
    """Keys ``tree`` (the function factors ``M`` with the ``tree`` routine: a function that
    solves columns, of a model with a :func:`~mbgen.codegen.targets.runtime.model_tree`; the
    RHS keeps the ``ldl``) of every view and ``tree_columns`` (its column solve's C lines)
    of the C views; a C view's ``DT`` is written straight into the output's rows
    (:func:`_columns_in_place`); then the pair loops' lines (:func:`_pair_views`), which
    write there too."""
    tree, L = model_tree(kernel), kernel.layout
    for v in c_views + py_views:
        v["tree"] = tree is not None and bool(v["solve"] and v["columns"]) and not v["contact"]
    for fn, v in zip(kernel.functions, c_views):
        v["tree_columns"] = _tree_columns(tree, v) if v["tree"] and v["columns"] else []
        v["in_place"] = bool(v["tree_columns"]) and _columns_in_place(v, dt_slots(fn.spec, L.n_u))
    for fn, c, py in zip(kernel.functions, c_views, py_views):
        _pair_views(fn.spec, c, py)


def _pair_views(s, c: dict, py: dict) -> None:
    """Keys ``pairs_pre`` and ``pairs_post`` of a function's C and Python views: the lines of
    the chain's pair products (:mod:`mbgen.codegen.pairs`; none without them).  ``R`` goes to
    ``DT`` (column-major), or in the C to the output's rows where they are stored in place."""
    for v, language in ((c, "c"), (py, "python")):
        target = columns_target(v["n_u"])
        if v.get("in_place"):
            width = v["columns"]
            target = replace(target, R=(v["out"], width, 1, v["n_q"] * width))
        v["pairs_pre"] = lines(s, v["n_u"], "pre", target, language)
        v["pairs_post"] = lines(s, v["n_u"], "post", target, language)


def _columns_in_place(view: dict, slots=frozenset()) -> bool:
    """Store the columns' right-hand sides, ``DT`` (column-major, ``columns x n_u``), where the
    tree's column solve reads them, the output's rows from ``n_q`` on (row-major ``n_u x
    columns``), instead of a local array copied there: True where every entry of ``DT`` is
    assigned (or in ``slots``, written by the pair loops), so the copy does nothing the
    stores do not.  The 32-link arm, module's flags,
    paired C loops: ``jacobian`` 18.8 -> 16.5 µs, ``tangent_jacobian`` 19.7 -> 17.5 µs, the
    same bits, 16 KB less stack; but gcc's basic-block vectoriser then took 32.6 -> 52.0 s
    and 0.40 -> 1.12 GB, which :data:`~mbgen.build.extension.NO_SLP` takes back (26.7 s,
    0.38 GB; 17.5 and 17.6 µs)."""
    n_u, n_q, width = view["n_u"], view["n_q"], view["columns"]
    for b in view["post"]:
        if b["name"] == "DT" and len({k for k, _ in b["assignments"]} | slots) == b["size"]:
            b.update(name=view["out"], local=False, assignments=[
                ((n_q + k % n_u) * width + k // n_u, e) for k, e in b["assignments"]])
            return True
    return False


def _tree_columns(tree, view: dict) -> list[str]:
    """C lines of ``M^{-1}`` applied to a function's columns in the rows of ``B`` (``n_u x
    columns``, row-major: the output's rows from ``n_q`` on), one vector loop per statement
    of the tree solve: the body of ``<function>_tree_columns`` (``templates/model/model.c.j2``;
    a function of its own, so that the long public function compiles no slower)."""
    width = view["columns"]
    program = tree.solve(b=lambda p: f"B[{p * width} + j]")
    return unread_m(tree) + vector_lines(program, width, ("M", "ID"))


def tree_columns_bytes(view: dict) -> int:
    """Stack bound of ``<function>_tree_columns``: every constant its loops read (``_k``),
    as if none shared a slot, and ``j``."""
    return frame(sum(len(re.findall(r"\b_k\d+ = ", line)) for line in view["tree_columns"]), 1)


def function_bytes(view: dict) -> int:
    """Automatic storage one model function declares (its parts' own: :func:`part_bytes`)."""
    temps = sum(len(view[s]) for s in ("temps", "post_temps") if s not in view["split"])
    imports = sum(len(v) for v in view["main_imports"].values())
    doubles = int(view["main_uses_time"]) + len(view["main_loads"]) + temps + imports \
        + view["work"] + sum(b["size"] for b in view["pre"] + view["post"] if b["local"]) \
        + contact_doubles(view) + (view["n_u"] if view["tree"] else 0)
    ints = int(bool(view["solve"])) + int(bool(view["columns"])) + 1 \
        + int(any(p["status"] for p in view["parts"]))
    return frame(doubles, ints) - frame()


#: The names of the contact factors in a model function (``templates/model/model.c.j2``).
CONTACT_ARRAYS = {"M": "M", "ID": "CD", "W": "CW", "V": "CV", "G": "CG"}


def contact_doubles(view: dict) -> int:
    """The contact solve's arrays in a function: ``CD`` (``n_u``), ``CW``, ``CV`` (``m x n_u``
    each), ``CG`` (``m x m``), ``LAM`` (``m``) and, solving columns, ``DL`` (``m x stride``)."""
    m, n = view["contact"], view["n_u"]
    return n + m * (2 * n + m + 1 + (view["stride"] if view["columns"] else 0)) if m else 0


def _contact_python(kernel: Kernel) -> dict:
    """The Python lines of the contact solve (:mod:`mbgen.codegen.contacts`; the C's are the
    ``contact`` routine's, :func:`~mbgen.codegen.targets.runtime.routine_context`)."""
    if kernel.equations.contacts is None:
        return dict(contact_factor_py=[], contact_solve_py=[])
    solver = contact_solver(kernel.equations)
    return dict(
        contact_factor_py=py_lines(solver.factor_mass(), "NotPositiveDefinite('mass matrix is "
                                                         "not positive definite')")
        + py_lines(solver.factor_rows(), "")
        + py_lines(solver.factor_delassus(), "ContactSingular('the Delassus matrix of the "
                                             "contacts is singular')"),
        contact_solve_py=py_lines(solver.solve(b=lambda p: f"b[o + {p}*s]",
                                               c=lambda r: f"c[co + {r}*s]"), ""))


def part_bytes(view: dict) -> int:
    """The largest automatic storage of one part of a split function (0: not split)."""
    return max((frame(int(p["uses_time"]) + len(p["loads"]) + len(p["imports"])
                      + len(p["temps"]), 1) - frame() for p in view["parts"]), default=0)


class ModelC(Target):
    """The model's functions in C: the header and the source, always rendered."""

    name = "c"
    folder = "model"
    files = (("model.h.j2", "{prefix}.h"), ("model.c.j2", "{prefix}.c"))
    requires = ("ldl", "ldl_columns", "lu", "lu_solve_t", "contact", "tree")
    bundled = True

    def context(self, kernel: Kernel, views: Views, prefix: str) -> dict:
        """What the model's templates print: names, sizes, functions, the solver's unrolled
        lines, the routines' constants; ``declarations`` and ``sections`` start with the
        model's own (prototypes; none)."""
        eq = kernel.equations
        L = kernel.layout
        upper = prefix.upper()
        defaults = [eq.defaults.get(str(sym)) for sym in L.parameters]
        has_defaults = bool(L.parameters) and all(d is not None for d in defaults)
        defines = [(f"{upper}_N_Q", L.n_q, "number of generalized coordinates"),
                   (f"{upper}_N_U", L.n_u, "number of generalized speeds"),
                   (f"{upper}_N_X", L.n_x, "length of the state x = [q, u]"),
                   (f"{upper}_N_P", L.n_p, "number of parameters"),
                   (f"{upper}_N_R", L.n_r, "number of inputs")]
        prototypes = [v["prototype"] + ";" for v in views.c]
        if has_defaults:
            prototypes.append(f"void {prefix}_default_parameters(double *p);")
        exprs = [e for fn in kernel.functions for _, e in
                 fn.velocity_temporaries + fn.temporaries + fn.post_temporaries] + [
            e for fn in kernel.functions for b in fn.velocity + fn.pre + fn.post
            for _, e in b.entries]
        funcs = sorted(math_functions(exprs))
        any_solve = any(fn.spec.solve for fn in kernel.functions)
        unrolled = any_solve and L.n_u <= UNROLL_MAX
        factor = factor_program(L.n_u, kernel.mass_pattern) if unrolled else []
        constrained = eq.constraints is not None
        tree = model_tree(kernel)
        return dict(
            version=__version__,
            prefix=prefix,
            upper=upper,
            name=eq.name,
            source=eq.source or eq.name,
            derivation=eq.derivation,
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
            functions=views.c,
            math_functions=funcs,
            ops_before=kernel.ops_before,
            ops_after=kernel.ops_after,
            any_solve=any_solve,
            unrolled=unrolled,
            pivot_factor=pivot_factor(L.n_u),
            ldl_factor_c=c_lines(factor, f"{upper}_NOT_POSITIVE_DEFINITE") if unrolled else [],
            ldl_solve_c=c_lines(solve_program(L.n_u, kernel.mass_pattern), "")
            if unrolled else [],
            ldl_factor_py=py_lines(factor, "NotPositiveDefinite('mass matrix is not positive "
                                           "definite')") if unrolled else [],
            ldl_solve_py=py_lines(solve_program(L.n_u, kernel.mass_pattern, "b", "o + "), "")
            if unrolled else [],
            needs_math=bool(funcs) or bool(kernel.integrators) or constrained,
            any_columns=any(fn.spec.columns for fn in kernel.functions),
            args=list(signature_args(kernel)),
            integrators=[o.value for o in kernel.integrators],
            recursive=kernel.form is Form.RECURSIVE,
            constrained=constrained,
            m=eq.constraints.m if constrained else 0,
            n_all=L.n_u + L.n_d,
            any_kkt=constrained and any_solve,
            any_contact=any(fn.spec.contact for fn in kernel.functions),
            any_ldl=any(v["solve"] and not v["contact"] and not v["tree"] for v in views.c),
            any_tree=tree is not None,
            tree_factor_py=py_lines(tree.factor(), "NotPositiveDefinite('mass matrix is not "
                                                   "positive definite')") if tree else [],
            tree_solve_py=py_lines(tree.solve(b=lambda p: f"b[o + {p}]"), "") if tree else [],
            **_contact_python(kernel),
            declarations=prototypes,
            sections=[],
            **routine_context(kernel, 0 if unrolled else max(
                (v["columns"] for v in views.c if not v["contact"] and not v["tree"]),
                default=0)),
        )

    def stack_bounds(self, kernel, ctx: dict, known: dict) -> dict[str, int]:
        """Every model function over its deepest callee; ``default_parameters``."""
        routines = routine_bounds(kernel, ctx, known)
        c = kernel.equations.constraints
        solves = 0   # velocity_solve, kkt_factor, kkt_solve: their arrays over the LU, the LDL
        if c is not None:
            solves = frame(c.m + ctx["n_all"] + 10, 10) + max(routines["lu"], routines["ldl"])
        bounds = {}
        for v in ctx["functions"]:
            callees = [SMALL, solves, frame() + part_bytes(v) if v["parts"] else 0]
            if v["tree"]:
                callees += [routines["tree"], tree_columns_bytes(v)]
            elif v["solve"] or v["columns"]:
                callees.append(routines["ldl"])
            if v["columns"] and not ctx["unrolled"] and not v["contact"] and not v["tree"]:
                callees.append(routines["ldl_columns"])
            if v["contact"]:
                callees.append(routines["contact"])
            bounds[v["name"]] = frame() + function_bytes(v) + max(callees)
        if ctx["has_defaults"]:
            bounds[f"{ctx['prefix']}_default_parameters"] = frame()
        return bounds

    def export(self, job: Job) -> dict[str, str]:
        return {name: job.rendered.files[name] for _, name in self.templates(job.rendered.prefix)}


class ModelPython(ModelC):
    """The model's functions in Python (``<prefix>.py``), printed from the same kernel."""

    name = "python"
    files = (("model.py.j2", "{prefix}.py"),)
    requires = ()

    def context(self, kernel: Kernel, views: Views, prefix: str) -> dict:
        return dict(py_functions=list(views.python))

    def stack_bounds(self, kernel, ctx: dict, known: dict) -> dict[str, int]:
        return {}


#: The model's C (header and source).
C = ModelC()
#: The model's Python module.
PYTHON = ModelPython()

__all__ = ["C", "PYTHON", "ModelC", "ModelPython", "Views", "function_views", "signature_args",
           "function_bytes", "part_bytes", "contact_doubles", "tree_columns_bytes"]
