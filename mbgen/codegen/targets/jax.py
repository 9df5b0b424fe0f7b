r"""The ``jax`` target: the kernel printed into ``jax.numpy`` (``<prefix>_jax.py``).

The same CSE'd kernel as ``<prefix>.c`` and ``<prefix>.py``, as pure functions
``<output>(t, x, p=None, r=None)`` of scalars held in Python lists while JAX traces them:
no loop over bodies, the ``L D L^T`` solve written out for the mass matrix's own
pattern (:func:`mbgen.codegen.solver.factor_program`, unrolled at every size), so
``jax.jit`` sees one straight-line graph and ``jax.vmap``, ``jax.jacfwd``, ``jax.grad``
apply.  The printer (:class:`JaxPrinter`) is the Python one with what a traced value cannot
do replaced: a ``Piecewise`` is ``jnp.where``, ``Min``/``Max`` ``jnp.minimum``/``maximum``,
``and``/``or`` ``jnp.logical_*``, ``sign`` ``jnp.sign``; ``math.<f>`` names the
``jax.numpy`` function through the module's ``math`` namespace.

A check the C makes (a pivot of the ``L D L^T`` or of the recursion that is not positive)
cannot raise on a traced value: the output is NaN there instead.  Constrained models are
refused (:func:`refusal`): their velocity and KKT solves are not printed.  Float64 needs
``jax.config.update("jax_enable_x64", True)``; JAX computes in float32 by default.
"""

from __future__ import annotations

import sympy as sm

from ..._version import __version__
from ...abi import Output
from ...symbolic.equations import acceleration_symbols
from ..optimize import Kernel, KernelFunction
from ..pairs import columns_target, lines
from ..printing import SORT_TERMS_MAX_OPS, PyPrinter
from ..solver import factor_program, pivot_factor, solve_program
from ..templating import environment
from .base import Job, Target


class JaxPrinter(PyPrinter):
    """Python printer whose output JAX can trace: no Python branch on a value."""

    def _print_Piecewise(self, expr):
        *pieces, (last, cond) = expr.args
        text = self._print(last) if cond == sm.true else \
            f"jnp.where({self._print(cond)}, {self._print(last)}, jnp.nan)"
        for e, c in reversed(pieces):
            text = f"jnp.where({self._print(c)}, {self._print(e)}, {text})"
        return text

    def _fold(self, fn: str, args) -> str:
        text = self._print(args[0])
        for a in args[1:]:
            text = f"jnp.{fn}({text}, {self._print(a)})"
        return text

    def _print_Min(self, expr):
        return self._fold("minimum", expr.args)

    def _print_Max(self, expr):
        return self._fold("maximum", expr.args)

    def _print_And(self, expr):
        return self._fold("logical_and", expr.args)

    def _print_Or(self, expr):
        return self._fold("logical_or", expr.args)

    def _print_Not(self, expr):
        return f"jnp.logical_not({self._print(expr.args[0])})"

    def _print_sign(self, expr):
        return f"jnp.sign({self._print(expr.args[0])})"

    def _print_Heaviside(self, expr):
        return f"jnp.heaviside({self._print(expr.args[0])}, 0.5)"


def refusal(kernel: Kernel) -> str | None:
    """Why the kernel cannot be printed for JAX (None: it can)."""
    if kernel.equations.constraints is not None:
        return (f"{kernel.equations.name!r} has constraints (or contacts), whose velocity and "
                f"KKT solves the JAX printer does not write; use the CasADi function or the "
                f"compiled C")
    return None


def _names(kernel: Kernel) -> dict:
    L = kernel.layout
    names = dict(L.identifiers)
    for fn in kernel.functions:
        for sym, _ in fn.temporaries + fn.post_temporaries:
            names[sym] = str(sym)
    for i, a in enumerate(acceleration_symbols(L.n_u)):
        names[a] = f"F[{i}]"
    return names


def _view(kernel: Kernel, fn: KernelFunction, printer: JaxPrinter) -> dict:
    L = kernel.layout
    s = fn.spec
    arrays = L.arrays()

    def blocks(bs):
        return [dict(name=s.out_name if b.name == "out" else b.name, size=b.size,
                     assignments=[(i, printer.doprint(e)) for i, e in b.entries],
                     mirror=list(b.mirror)) for b in bs]

    def temps(ts):
        return [(printer.doprint(sym), printer.doprint(e), sym in fn.checks) for sym, e in ts]

    loads = [(L.identifiers[sym], arrays[sym][0], arrays[sym][1]) for sym in fn.symbols_used
             if sym != L.time]
    return dict(name=s.output.value, doc=s.doc, out=s.out_name, out_size=s.out_size,
                out_shape=list(s.out_shape), time_name=L.identifiers[L.time],
                uses_time=L.time in fn.symbols_used, loads=loads, temps=temps(fn.temporaries),
                pre=blocks(fn.pre), solve=s.solve, rhs=s.output is Output.RHS and s.solve,
                post_temps=temps(fn.post_temporaries), post=blocks(fn.post),
                columns=s.columns, checks=bool(fn.checks) or s.solve,
                pairs_pre=_pairs(s, L, "pre"), pairs_post=_pairs(s, L, "post"),
                n_q=s.first_row, n_u=L.n_u,
                ops=fn.ops_after)


def _pairs(s, L, stage: str) -> list[str]:
    """The chain's pair products of ``stage`` (:mod:`mbgen.codegen.pairs`), as in Python."""
    return lines(s, L.n_u, stage, columns_target(L.n_u), "python")


def _lines(program) -> list[str]:
    """The factorisation's statements, a failed pivot check folded into ``ok``."""
    out = []
    for st in program:
        if st.kind == "check":
            out.append(f"ok = jnp.logical_and(ok, {st.target} > {st.value})")
        else:
            out.append(f"{st.target} = {st.value}")
    return out


def jax_context(kernel: Kernel, prefix: str) -> dict:
    """What ``templates/jax/model.py.j2`` prints for ``kernel``."""
    eq = kernel.equations
    L = kernel.layout
    printer = JaxPrinter(_names(kernel), kernel.ops_after <= SORT_TERMS_MAX_OPS)
    defaults = [eq.defaults.get(str(sym)) for sym in L.parameters]
    any_solve = any(fn.spec.solve for fn in kernel.functions)
    return dict(
        version=__version__, prefix=prefix, name=eq.name, n_q=L.n_q, n_u=L.n_u, n_x=L.n_x,
        n_p=L.n_p, n_r=L.n_r, state_names=list(L.state_names),
        parameter_names=list(L.parameter_names), input_names=list(L.input_names),
        defaults=[repr(float(d)) for d in defaults] if all(d is not None for d in defaults)
        else None,
        functions=[_view(kernel, fn, printer) for fn in kernel.functions],
        any_solve=any_solve, pivot_factor=pivot_factor(L.n_u),
        ldl_factor=_lines(factor_program(L.n_u, kernel.mass_pattern)) if any_solve else [],
        ldl_solve=_lines(solve_program(L.n_u, kernel.mass_pattern, "b", "o + "))
        if any_solve else [],
        ops_after=kernel.ops_after)


def jax_module_text(kernel: Kernel, prefix: str) -> str:
    """The text of ``<prefix>_jax.py`` (see :func:`refusal` for what it cannot print)."""
    return environment().get_template("jax/model.py.j2").render(jax_context(kernel, prefix))


class JaxTarget(Target):
    """``<prefix>_jax.py``: the outputs as pure ``jax.numpy`` functions."""

    name = "jax"
    files = (("model.py.j2", "{prefix}_jax.py"),)

    def wanted(self, kernel, targets) -> bool:
        return False

    def unavailable(self, kernel) -> str | None:
        return refusal(kernel)

    def export(self, job: Job) -> dict[str, str]:
        [(_, name)] = self.templates(job.rendered.prefix)
        return {name: jax_module_text(job.kernel, job.rendered.prefix)}


#: The JAX target.
JAX = JaxTarget()

__all__ = ["JAX", "JaxTarget", "JaxPrinter", "jax_context", "jax_module_text", "refusal"]
