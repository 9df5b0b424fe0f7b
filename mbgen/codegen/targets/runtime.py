r"""Runtime routines: the C helpers of the generated code, each emitted once per translation unit.

CasADi's ``core/runtime/casadi_*.hpp`` are the model: a routine is one template
``templates/runtime/<name>.c.j2`` that opens with a ``contract:`` comment and defines
``static`` functions ``<prefix>_<function>``, and a row of :data:`ROUTINES` that names
those functions, the routines they call and the stack bound of one call.  A target lists
the routines its C calls (:attr:`~mbgen.codegen.targets.base.Target.requires`) and its
templates ask for one just before the first call::

    {% for code in runtime("lu") %}
    {{ code }}
    {% endfor %}

The first request of a render emits the routine, after the routines it calls; later
requests emit nothing (CasADi's ``CodeGenerator::add_auxiliary``).  So a routine that two
targets call -- the error norm of the whole-trajectory integrators and of the step API, the
LU of the constraints, of the projection and of Rosenbrock's stages -- is defined once,
above every caller, under one name and with one rule.  A request for a routine the target
did not list fails the render (``LookupError``, :class:`Runtime`), and
``tests/codegen/test_targets.py`` fails when a target's template calls a routine's function
without listing the routine.

======================  =====================================================================
routine                 functions (``<prefix>_...``)
======================  =====================================================================
``ldl``                 ``ldl``, ``ldl_solve``: the mass matrix's ``L D L^T``
                        (:mod:`mbgen.codegen.solver`: its pivot rule, its unrolled form)
``ldl_columns``         ``ldl_solve_columns``: ``M^-1`` applied to ``C`` columns at once, row
                        by row (the sensitivities past ``UNROLL_MAX`` speeds)
``tree``                ``tree_factor``, ``tree_solve``: ``M`` factored and solved over a
                        kinematic tree's structural nonzeros, leaves first (the column solves
                        of a branched model past ``UNROLL_MAX`` speeds: :func:`model_tree`)
``lu``                  ``lu_factor``, ``lu_solve``: partial pivoting, one pivot rule
                        (:data:`mbgen.codegen.solver.LU_PIVOT`)
``lu_solve_t``          ``lu_solve_t``: the transposed solve with ``lu``'s factors
``contact``             ``contact_factor``, ``contact_solve``: rigid point contacts, ``M``
                        and the Delassus matrix ``J M^-1 J^T`` factored, then ``lambda`` and
                        ``u'``, straight-line over the structural nonzeros
                        (:mod:`mbgen.codegen.contacts`)
``rms``                 ``rms``: the adaptive methods' error norm
``initial_step``        ``initial_step``: the adaptive methods' first step (scipy's rule)
======================  =====================================================================

How to add a routine
--------------------
1. ``templates/runtime/<name>.c.j2``: a ``{# contract: ... #}`` comment, then the
   ``static`` functions ``{{ prefix }}_<function>``; sizes that vary between callers are
   arguments (one definition serves every caller), its constants come from the key
   ``routine`` of the context (:func:`routine_context`).
2. Its row in :data:`ROUTINES`: the functions, the routines it calls, its stack bound.
3. ``requires`` of every target whose C calls it, and ``runtime("<name>")`` in the
   template before the first call.  ``tests/codegen/test_targets.py`` fails when a
   template calls it undeclared, or when a routine has no template; the stack test
   (``tests/codegen/test_header.py``) checks the bound against ``gcc -fstack-usage``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ...names import model_prefix
from ..contacts import contact_solver
from ..header import SMALL, frame
from ..solver import LU_PIVOT, c_lines, factor_program, pivot_factor
from ..templating import environment
from ..tree_solve import TreeFactor, tree_factor


def _ldl_bound(kernel, ctx: dict, known: dict) -> int:
    """``ldl`` unrolled: one double per ``let`` of the factor; as loops: ``w[n_u]`` and counters."""
    n = kernel.layout.n_u
    if ctx["unrolled"]:
        return frame(sum(1 for s in factor_program(n, kernel.mass_pattern) if s.kind == "let"))
    return frame(n + 3, 3)


def _contact_bound(kernel, ctx: dict, known: dict) -> int:
    """``contact_factor``: one double per ``let`` of its straight-line code."""
    c = kernel.equations.contacts
    return frame(contact_solver(kernel.equations).locals()) if c is not None else SMALL


def model_tree(kernel) -> TreeFactor | None:
    """The tree factor a model's column solves use (:func:`~mbgen.codegen.tree_solve.tree_factor`),
    or ``None``: the dense ``ldl`` and ``ldl_columns``.  Only an unconstrained model without
    contacts (those solve with their own factors) with a function that solves columns."""
    eq = kernel.equations
    if eq.constraints is not None or eq.contacts is not None or not any(
            fn.spec.columns and fn.spec.solve for fn in kernel.functions):
        return None
    return tree_factor(kernel.layout.n_u, kernel.mass_pattern)


def unread_m(tree: TreeFactor) -> list[str]:
    """``(void)M;`` where a solve reads no ``L`` (a diagonal ``M``), else nothing."""
    return [] if tree.nonzeros else ["(void)M;"]


def _tree_bound(kernel, ctx: dict, known: dict) -> int:
    """``tree_factor``: one double per ``let`` of its straight-line code."""
    tree = model_tree(kernel)
    return frame(tree.locals()) if tree is not None else SMALL


def _initial_step_bound(kernel, ctx: dict, known: dict) -> int:
    """``sc, ya, fa`` (three states) and the scalars, over one RHS call."""
    n = ctx["routine"]["n"]
    return frame(3 * n + 8, 2) + max(known.get(f"{ctx['prefix']}_rhs", 0), SMALL)


@dataclass(frozen=True)
class Routine:
    """A row of :data:`ROUTINES`.

    Attributes
    ----------
    name : str
        Its template ``templates/runtime/<name>.c.j2`` and the name targets ask for.
    functions : tuple of str
        The C functions it defines, ``<prefix>_<function>``.
    requires : tuple of str
        The routines its functions call (emitted before it).
    bound : callable
        ``bound(kernel, ctx, known) -> bytes``: the stack of one call of its deepest
        function, callees included (``known``: bounds by C name of the model's functions).
    """

    name: str
    functions: tuple
    requires: tuple = ()
    bound: Callable = lambda kernel, ctx, known: SMALL

    @property
    def template(self) -> str:
        """``runtime/<name>.c.j2``."""
        return f"runtime/{self.name}.c.j2"


#: Every runtime routine, by name.
ROUTINES: dict[str, Routine] = {r.name: r for r in (
    Routine("ldl", ("ldl", "ldl_solve"), bound=_ldl_bound),
    Routine("ldl_columns", ("ldl_solve_columns",), ("ldl",),
            bound=lambda kernel, ctx, known: frame(ctx["routine"]["columns"] + 6, 5)),
    Routine("lu", ("lu_factor", "lu_solve"), bound=lambda kernel, ctx, known: frame(6, 6)),
    Routine("lu_solve_t", ("lu_solve_t",), ("lu",)),
    Routine("contact", ("contact_factor", "contact_solve"), bound=_contact_bound),
    Routine("tree", ("tree_factor", "tree_solve"), bound=_tree_bound),
    Routine("rms", ("rms",)),
    Routine("initial_step", ("initial_step",), ("rms",), bound=_initial_step_bound),
)}


def routine_context(kernel, columns: int) -> dict:
    """Key ``routine`` of the context: the constants the routines' templates print.

    ``n``: a state's length (at least 1); ``params``, ``args``: the trailing parameters and
    arguments ``p``, ``r`` of a model function; ``lu_pivot``: the LU's pivot rule;
    ``columns``: the most columns a function solves row by row (0: ``ldl_columns`` unused);
    ``contacts``: the contact rows ``m`` (0: none), ``contact_pivot`` the factor of
    ``G_rr`` below which a pivot of the Delassus matrix is singular (the mass matrix's rule,
    :func:`~mbgen.codegen.solver.pivot_factor`, for ``n_u + m``), ``contact_order`` the
    elimination order and ``contact_factor_c``, ``contact_solve_c`` the routine's lines
    (:class:`~mbgen.codegen.contacts.ContactSolver`); ``tree_order``, ``tree_factor_c``,
    ``tree_solve_c``: the ``tree`` routine's order and lines (:func:`model_tree`; empty
    without one).
    """
    L = kernel.layout
    tail = [a for a, n in (("p", L.n_p), ("r", L.n_r)) if n]
    c = kernel.equations.contacts
    m = c.m if c is not None else 0
    contact = {}
    if c is not None:
        solver = contact_solver(kernel.equations)
        upper = model_prefix(kernel.equations.name).upper()
        contact = dict(
            contact_order=" ".join(map(str, solver.order)),
            contact_factor_c=c_lines(solver.factor_mass(), f"{upper}_NOT_POSITIVE_DEFINITE")
            + c_lines(solver.factor_rows(), "")
            + c_lines(solver.factor_delassus(), f"{upper}_CONTACT_SINGULAR"),
            contact_solve_c=c_lines(solver.solve(), ""))
    tree = model_tree(kernel)
    if tree is not None:
        upper = model_prefix(kernel.equations.name).upper()
        contact.update(tree_order=" ".join(map(str, tree.order)),
                       tree_factor_c=c_lines(tree.factor(), f"{upper}_NOT_POSITIVE_DEFINITE"),
                       tree_solve_c=unread_m(tree) + c_lines(tree.solve(), ""))
    return dict(routine=dict(
        n=max(L.n_x, 1),
        params="".join(f", const double *{a}" for a in tail),
        args="".join(f", {a}" for a in tail),
        lu_pivot=repr(LU_PIVOT),
        columns=columns,
        contacts=m,
        contact_pivot=pivot_factor(L.n_u + m), **contact))


class Runtime:
    """The routines of one translation unit: each emitted on its first request.

    ``view(target)`` is the ``runtime`` a target's templates call: ``runtime(name)``
    returns the texts to emit (the routine and what it calls, those not yet emitted; an
    empty list after that), and refuses a routine the target does not list in ``requires``.
    """

    def __init__(self, ctx: dict):
        self._ctx = ctx
        self._emitted: list[str] = []

    def view(self, target):
        """``runtime(name)`` for the templates of ``target``."""
        def runtime(name: str) -> list[str]:
            if name not in target.requires:
                raise LookupError(f"target {target.name!r} calls the runtime routine {name!r} "
                                  f"without listing it in its requires {target.requires}")
            return self._emit(name)
        return runtime

    def _emit(self, name: str) -> list[str]:
        if name in self._emitted:
            return []
        routine = ROUTINES[name]
        texts = [text for dep in routine.requires for text in self._emit(dep)]
        self._emitted.append(name)
        text = environment().get_template(routine.template).render(self._ctx)
        return texts + [text[:-1] if text.endswith("\n") else text]


def routine_bounds(kernel, ctx: dict, known: dict) -> dict[str, int]:
    """``{routine: stack bound of one call}`` of every routine."""
    return {name: r.bound(kernel, ctx, known) for name, r in ROUTINES.items()}


__all__ = ["ROUTINES", "Routine", "Runtime", "model_tree", "routine_context", "routine_bounds"]
