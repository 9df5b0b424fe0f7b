r"""Optimisation: ``Equations + outputs -> Kernel``.

Only the outputs a scene asks for are kept (:mod:`mbgen.codegen.outputs` says what each
computes).  Every expression of every kept output goes through **one**
common-subexpression-elimination pass (:mod:`mbgen.codegen.cse`); each generated
function then takes the temporaries its own expressions depend on, split into
those computed before the mass matrix is solved and those that need the
accelerations.  Operation counts before (expressions evaluated as trees) and
after (temporaries plus reduced outputs) are recorded per function.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import sympy as sm

from ..abi import INTEGRATORS, Output
from ..errors import ModelError
from ..symbolic.equations import Equations, acceleration_symbols, lambda_symbols
from ..symbolic.graph import count_ops_dag, count_ops_tree, free_symbols, reachable
from ..symbolic.layout import Layout
from .cse import CseBackend, eliminate
from .outputs import Block, Form, Spec, spec, with_dependencies
from .pairs import with_pairs
from .solver import solve_ops

__all__ = ["Output", "CseBackend", "Block", "Form", "KernelFunction", "Kernel", "optimize"]


@dataclass(frozen=True)
class KernelFunction:
    """One generated function: a :class:`~mbgen.codegen.outputs.Spec` after CSE.

    ``temporaries`` are evaluated before the solve, ``post_temporaries`` after
    it (they use the accelerations).
    """

    spec: Spec
    temporaries: tuple[tuple[sm.Symbol, sm.Expr], ...]
    pre: tuple[Block, ...]
    post_temporaries: tuple[tuple[sm.Symbol, sm.Expr], ...]
    post: tuple[Block, ...]
    uses: frozenset            # subset of {"t", "x", "p", "r"}
    symbols_used: tuple        # layout symbols the function reads, in layout order
    ops_before: int
    ops_after: int
    checks: frozenset = frozenset()   # temporaries that must be positive (recursion pivots)
    velocity_temporaries: tuple = ()  # constrained: before the dependent speeds are solved
    velocity: tuple = ()              # constrained: the blocks CA, CB (A and b of A u + b = 0)

    @property
    def output(self) -> Output:
        return self.spec.output


@dataclass(frozen=True)
class Kernel:
    """Optimised, ready-to-print functions of one model, plus the integrators asked for.

    ``layout`` is the ABI: the equations' layout without parameters and inputs
    that no emitted function reads.  ``input_bounds``: ``((input, lower, upper), ...)``
    that the step API and the FMU clamp the inputs to (``Scene(saturate=True)``, set by
    the pipeline); empty: no saturation.
    """

    equations: Equations
    functions: tuple[KernelFunction, ...]
    integrators: tuple[Output, ...]
    cse_backend: CseBackend
    temp_prefix: str
    layout: Layout
    mass_pattern: frozenset   # (i, j), i > j: structural nonzeros of M below the diagonal
    form: Form = Form.SOLVE   # how u' is computed (see mbgen.codegen.outputs.Form)
    form_costs: tuple = ()    # ((form, operations of the RHS), ...) when both were weighed
    solve_bounded: bool = False   # SOLVE's cost is its L D L^T alone: not tried, it cannot win
    input_bounds: tuple = ()      # ((input, lower, upper), ...): Scene(saturate=True)

    @property
    def outputs(self) -> tuple[Output, ...]:
        return tuple(f.output for f in self.functions) + self.integrators

    @property
    def ops_before(self) -> int:
        return sum(f.ops_before for f in self.functions)

    @property
    def ops_after(self) -> int:
        return sum(f.ops_after for f in self.functions)



def _temp_prefix(equations: Equations) -> str:
    names = set(equations.layout.identifiers.values())
    for prefix in ("v", "w", "tmp", "cse"):
        if not any(n.startswith(prefix) and n[len(prefix):].isdigit() for n in names):
            return prefix
    return "mbgen_tmp"  # pragma: no cover


def optimize(equations: Equations, outputs=(Output.RHS,),
             cse_backend: CseBackend = CseBackend.SYMENGINE, form: Form | None = None) -> Kernel:
    """Select ``outputs`` of ``equations`` and eliminate common subexpressions once.

    Parameters
    ----------
    equations : Equations
    outputs : iterable of Output (or names)
        What to emit; default ``(Output.RHS,)``.  Integrators pull in what they
        call (the RHS, and for ``ROSENBROCK`` the Jacobian).
    cse_backend : CseBackend
        ``SYMENGINE`` (default; faster and finds more sharing) or ``SYMPY``.
    form : Form, optional
        How ``u'`` is computed.  Default: ``SOLVE`` unless the equations carry
        a recursion (:attr:`Equations.accelerations`); then both forms of the
        right-hand side are optimised and the one with fewer operations wins
        (the solve counted with its ``L D L^T`` operations).  The recursion is
        optimised first; where the ``L D L^T`` solve alone costs more, ``SOLVE``
        cannot win and is not optimised (``Kernel.solve_bounded``; on the
        32-link arm this halves the time of ``optimize``).
    """
    outputs = with_dependencies(outputs, equations)
    if not outputs:
        raise ModelError("no outputs requested; ask for at least Output.RHS")
    cse_backend = CseBackend(cse_backend)
    costs: tuple = ()
    bounded = False
    if form is None:
        form = Form.SOLVE
        if equations.accelerations is not None:
            trial = {Form.RECURSIVE: _kernel(equations, (Output.RHS,), cse_backend,
                                             Form.RECURSIVE)}
            recursive = trial[Form.RECURSIVE].ops_after
            pattern = trial[Form.RECURSIVE].mass_pattern
            solve = solve_ops(equations.layout.n_u, pattern)
            bounded = solve > recursive   # its L D L^T alone costs more: SOLVE cannot win
            if not bounded:
                trial[Form.SOLVE] = _kernel(equations, (Output.RHS,), cse_backend, Form.SOLVE)
                solve += trial[Form.SOLVE].ops_after
            costs = ((Form.SOLVE, solve), (Form.RECURSIVE, recursive))
            form = min(costs, key=lambda fc: fc[1])[0]
            if tuple(outputs) == (Output.RHS,):
                return replace(trial[form], form_costs=costs, solve_bounded=bounded)
    return replace(_kernel(equations, outputs, cse_backend, Form(form)), form_costs=costs,
                   solve_bounded=bounded)


def _kernel(equations: Equations, outputs, cse_backend: CseBackend, form: Form) -> Kernel:
    prefix = _temp_prefix(equations)
    specs = [with_pairs(equations, spec(equations, o, form)) for o in outputs
             if not o.is_integrator]

    # every assignment the outputs reach (the program's, and each output's own), and every
    # output expression: what the outputs do not reach (another output's intermediates, the
    # energies') is left out before CSE, so it cannot change the code of what they do reach
    assignments = list(equations.program.assignments)
    for s in specs:
        assignments += list(s.extra.assignments)
    checks = set(equations.program.checks)
    roots = [e for s in specs for b in s.velocity + s.pre + s.post for _, e in b.entries]
    if any(s.pivots for s in specs):
        roots += sorted(checks, key=str)
    program_defs = dict(assignments)
    program_reads: dict = {}    # shared by every reachable() over program_defs (per output)
    reached = reachable(roots, program_defs, program_reads)
    assignments = [(sym, e) for sym, e in assignments if sym in reached]
    checks &= reached
    defined = {sym for sym, _ in assignments}

    # one CSE pass over the program and every distinct expression of every output
    distinct: dict = {}
    for e in [e for s in specs for b in s.velocity + s.pre + s.post for _, e in b.entries]:
        if e.args and e not in distinct:
            distinct[e] = len(distinct)
    reps, reduced, final = eliminate(assignments, list(distinct), prefix, cse_backend, checks)
    reduced_of = dict(zip(distinct, reduced))
    reduced_of.update(final)   # entries that are a bare program symbol
    checks = {final[c] for c in checks}
    rep_expr = dict(reps)
    order = {s: i for i, (s, _) in enumerate(reps)}
    L = equations.layout
    solved = set(acceleration_symbols(L.n_u + L.n_d))
    if equations.constraints is not None:
        solved |= set(lambda_symbols(equations.constraints.m))
    if equations.contacts is not None:   # the contact forces, solved with u'
        solved |= set(lambda_symbols(equations.contacts.m))
    after_solve = _depends_on(reps, solved - defined)

    functions = []
    rep_reads: dict = {}
    tree_counts: dict = {}
    for s in specs:
        vel = tuple(_reduce(b, reduced_of) for b in s.velocity)
        pre = tuple(_reduce(b, reduced_of) for b in s.pre)
        post = tuple(_reduce(b, reduced_of) for b in s.post)
        vel_roots = [e for b in vel for _, e in b.entries]
        roots = [e for b in pre + post for _, e in b.entries]
        if s.pivots:   # a zero pivot times a zero right-hand side is still singular
            roots += sorted(checks, key=order.__getitem__)
        first = set(reachable(vel_roots, rep_expr, rep_reads))
        needed = sorted(reachable(roots, rep_expr, rep_reads) | first, key=order.__getitem__)
        vel_temps = tuple((t, rep_expr[t]) for t in needed if t in first)
        temps = tuple((t, rep_expr[t]) for t in needed if t not in after_solve and t not in first)
        post_temps = tuple((t, rep_expr[t]) for t in needed if t in after_solve)
        every = vel_temps + temps + post_temps
        used_syms, uses = _usage(equations, vel_roots + roots + [e for _, e in every])
        raw = [e for b in s.velocity + s.pre + s.post for _, e in b.entries]
        before = count_ops_tree(raw + [program_defs[d] for d in
                                       reachable(raw, program_defs, program_reads)],
                                tree_counts)
        after = (count_ops_dag([e for _, e in every])
                 + sum(count_ops_dag([e]) for e in vel_roots + roots))
        if s.pairs is not None:     # the loops' products (mbgen.codegen.pairs)
            before, after = before + s.pairs.operations, after + s.pairs.operations
        functions.append(KernelFunction(s, temps, pre, post_temps, post, uses, used_syms,
                                        before, after, frozenset(checks & set(needed)),
                                        vel_temps, vel))
    integrators = tuple(o for o in outputs if o in INTEGRATORS)
    used = {sym for f in functions for sym in f.symbols_used + f.spec.variables}
    abi = Layout(L.coordinates, L.speeds, tuple(p for p in L.parameters if p in used),
                 tuple(r for r in L.inputs if r in used), L.time, L.dependent_speeds)
    M = equations.mass_matrix
    pattern = frozenset((i, j) for i in range(L.n_u) for j in range(i)
                        if equations.constraints is not None or M[i, j] != 0)
    return Kernel(equations, tuple(functions), integrators, cse_backend, prefix, abi, pattern,
                  form)


def _reduce(block: Block, reduced_of: dict) -> Block:
    return Block(block.name, block.size,
                 tuple((i, reduced_of.get(e, e)) for i, e in block.entries), block.mirror)


def _usage(equations: Equations, exprs) -> tuple[tuple, frozenset]:
    L = equations.layout
    used = free_symbols(exprs) & (L.symbols() - set(L.dependent_speeds))
    ordered = tuple(s for s in L.states + L.parameters + L.inputs + (L.time,) if s in used)
    groups = (("t", {L.time}), ("x", set(L.states)), ("p", set(L.parameters)),
              ("r", set(L.inputs)))
    return ordered, frozenset(k for k, group in groups if used & group)


def _depends_on(reps, roots: set) -> set:
    """Temporaries whose value depends (transitively) on any symbol in ``roots``."""
    tainted = set(roots)
    for s, e in reps:
        if free_symbols([e]) & tainted:
            tainted.add(s)
    return tainted - roots



