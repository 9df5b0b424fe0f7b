"""Common-subexpression elimination: one pass over a program and the expressions that read it.

Two back ends give the same numbers: ``symengine.cse`` (default; measured
0.43 s against 1.2 s for ``sympy.cse`` on the 32-link pendulum on a cart, with
17% fewer operations) and ``sympy.cse``.

:func:`eliminate` is the whole pass, in four steps:

1. CSE of the program's definitions and the expressions together;
2. *merge*: the program's assignments and the CSE temporaries in one order
   where every symbol is defined before it is read;
3. *hoist*: the compound base of a small integer power gets a temporary
   (the power prints as ``b*b*b``);
4. *drop copies* (``a = b`` becomes ``b``) and *rename*: the survivors are
   ``<prefix>0, <prefix>1, ...`` in evaluation order.

With symengine, steps 1--4 run on symengine expressions and the result crosses
back to sympy once, the renaming folded into that conversion
(:func:`mbgen.symbolic.graph.to_sympy` with a seeded memo): sympy builds each
distinct node of the result once and nothing else.  (Renaming in sympy after the
conversion rebuilt every node twice more, and was most of the time of
``optimize`` on the 32-link arm.)  Expressions cross between the libraries
through :func:`mbgen.symbolic.graph.to_symengine` and
:func:`~mbgen.symbolic.graph.to_sympy`, which convert each distinct node once
(``symengine.sympify`` would expand a shared graph into its tree).
"""

from __future__ import annotations

from collections.abc import Sequence
from enum import Enum

import sympy as sm

from ..symbolic.graph import (
    postorder_unique,
    symbols_back,
    symengine_rebuilt,
    to_symengine,
    to_sympy,
    walk_unique,
    xreplace_dag,
)
from .printing import printed_base_count


class CseBackend(str, Enum):
    """Which library performs common-subexpression elimination."""

    SYMENGINE = "symengine"
    SYMPY = "sympy"


def eliminate(assignments: Sequence, exprs: Sequence, prefix: str,
              backend: CseBackend = CseBackend.SYMENGINE, checks=frozenset()):
    """CSE of ``exprs`` and of the program ``assignments`` (``[(symbol, expr)]`` in order).

    ``checks`` are program symbols that must keep their own temporary (the
    recursion's pivots, checked for positivity) even where they copy another.

    Returns
    -------
    reps : list of (Symbol, Expr)
        Program assignments and CSE temporaries merged in evaluation order,
        named ``<prefix>0, <prefix>1, ...``.
    reduced : list
        ``exprs`` in terms of those temporaries.
    final : dict
        What each program symbol became: its temporary, or the symbol it copied.
    """
    assignments = list(assignments)
    exprs = [sm.sympify(e) for e in exprs]
    values = [e for _, e in assignments]
    na = len(values)
    if CseBackend(backend) is CseBackend.SYMENGINE:
        import symengine as se

        memo: dict = {}
        converted = to_symengine(values + exprs, memo)
        syms = to_symengine([s for s, _ in assignments], memo)
        temps, reduced = _symengine_cse(converted, se)
        renamed_checks = {memo[c] for c in checks if c in memo}
        power = se.Pow
    else:
        numbered = sm.numbered_symbols("mbgen:cse")
        temps, reduced = sm.cse(values + exprs, symbols=numbered, order="none") \
            if values or exprs else ([], [])
        syms, renamed_checks, power = [s for s, _ in assignments], set(checks), sm.Pow
    reps = _merge(list(temps), list(zip(syms, reduced[:na])))
    reduced = list(reduced[na:])
    reps, reduced = _hoist_power_bases(reps, reduced, power)
    aliases: dict = {}
    for sym, e in reps:
        if e.is_Symbol and sym not in renamed_checks:
            aliases[sym] = aliases.get(e, e)
    kept = [(sym, e) for sym, e in reps if sym not in aliases]
    names = [sm.Symbol(f"{prefix}{k}") for k in range(len(kept))]
    if CseBackend(backend) is CseBackend.SYMENGINE:
        back = symbols_back(memo)
        back.update({sym: name for (sym, _), name in zip(kept, names)})
        for sym, target in aliases.items():
            back[sym] = back[target]
        out = to_sympy([e for _, e in kept] + reduced, back, small=True)
        final = {s: back[memo[s]] for s, _ in assignments}
    else:
        mapping = {sym: name for (sym, _), name in zip(kept, names)}
        mapping.update({sym: mapping.get(t, t) for sym, t in aliases.items()})
        out = xreplace_dag([e for _, e in kept] + reduced, mapping)
        final = {s: mapping.get(s, s) for s, _ in assignments}
    return list(zip(names, out[:len(kept)])), out[len(kept):], final


#: Above this many distinct nodes, CSE is the linear pass :func:`_value_numbering` instead
#: of ``symengine.cse``, whose matching of common arguments of sums and products grows faster
#: than linearly: on the 32-link arm's Jacobian (200,000 operations, already a program of
#: named intermediates) it took 171 s for 10 % fewer operations.
LINEAR_CSE_NODES = 60_000


def _symengine_cse(exprs: list, se):
    """``symengine.cse(exprs)``, or :func:`_value_numbering` for a large input."""
    if not exprs:
        return [], []
    seen: set = set()
    stack = list(exprs)
    while stack and len(seen) <= LINEAR_CSE_NODES:
        node = stack.pop()
        if node not in seen:
            seen.add(node)
            stack.extend(node.args)
    if len(seen) <= LINEAR_CSE_NODES:
        return se.cse(exprs)
    return _value_numbering(exprs, se)


def _value_numbering(exprs: list, se):
    """CSE in one pass over the graph: every compound node with two or more parents (or a
    parent and a root) gets a temporary; returns ``(temps, reduced)`` like ``symengine.cse``.

    Each distinct node is visited once (children before parents); nodes are rebuilt only
    where a descendant was replaced.  It finds no common *part* of two sums or products
    (``a + b`` in ``a + b + c`` and ``a + b + d``), which ``symengine.cse`` does.
    """
    from symengine.lib.symengine_wrapper import Boolean
    order = postorder_unique(exprs)
    uses: dict = {}
    for root in exprs:
        uses[root] = uses.get(root, 0) + 1
    for node in order:
        for a in node.args:
            if a.args:
                uses[a] = uses.get(a, 0) + 1
    names = (se.Symbol(f"mbgen:vn{k}") for k in range(len(order)))
    temps: list = []
    memo: dict = {}   # node -> its replacement, for the nodes that changed
    for node in order:
        args = node.args
        value = symengine_rebuilt(node, [memo.get(a, a) for a in args]) \
            if any(a in memo for a in args) else node
        if uses.get(node, 0) >= 2 and not isinstance(node, Boolean):   # conditions stay put
            t = next(names)
            temps.append((t, value))
            memo[node] = t
        elif value is not node:
            memo[node] = value
    return temps, [memo.get(e, e) for e in exprs]


def _free(expr) -> set:
    """Free symbols of a small expression (sympy or symengine: CSE left it small)."""
    return expr.free_symbols


def _merge(reps, assignments) -> list:
    """CSE temporaries and program assignments in one order where every use follows its definition.

    Program assignments keep their order; a temporary goes right before its
    first use (depth first, iteratively).
    """
    defs = dict(reps)
    defs.update(assignments)
    out: list = []
    done: set = set()
    for root in [s for s, _ in assignments] + [s for s, _ in reps]:
        if root in done:
            continue
        stack = [(root, False)]
        while stack:
            sym, expanded = stack.pop()
            if sym in done:
                continue
            if expanded:
                done.add(sym)
                out.append((sym, defs[sym]))
                continue
            stack.append((sym, True))
            deps = sorted((d for d in _free(defs[sym]) if d in defs and d not in done),
                          key=str, reverse=True)
            stack.extend((d, False) for d in deps)
    return out


def _repeats_base(exp) -> bool:
    """True when a power with exponent ``exp`` prints its base more than once (the rule:
    :func:`mbgen.codegen.printing.power_form`)."""
    return printed_base_count(sm.sympify(exp)) >= 2


def _hoist_power_bases(reps, reduced, power):
    """Give every compound base of a small integer power its own temporary.

    Powers print as repeated multiplication (``b*b*b``); a compound ``b``
    (``cos(q1)``, ``q1 + q2``) would then be evaluated once per factor.  The new
    temporary is placed right after the last temporary its base depends on.
    ``power`` is the library's power class (sympy's or symengine's).
    """
    values = [e for _, e in reps] + list(reduced)
    bases: list = []
    seen: set = set()
    for node in walk_unique(values):
        if (isinstance(node, power) and node.args[0].args and node.args[0] not in seen
                and _repeats_base(node.args[1])):
            seen.add(node.args[0])
            bases.append(node.args[0])
    if not bases:
        return reps, reduced
    bases.reverse()  # nested bases (descendants) before the bases that contain them
    position = {s: i for i, (s, _) in enumerate(reps)}
    new_of = {b: sm.Symbol(f"mbgen:pow{k}") for k, b in enumerate(bases)}
    if power is not sm.Pow:
        import symengine as se

        new_of = {b: se.Symbol(str(s)) for b, s in new_of.items()}
    sub = {node: power(new_of[node.args[0]], node.args[1]) for node in walk_unique(values)
           if isinstance(node, power) and node.args[0] in new_of}
    inserts: dict[int, list] = {}
    for base in bases:
        deps = [position[s] for s in _free(base) if s in position]
        inserts.setdefault(max(deps) if deps else -1, []).append((new_of[base], base.xreplace(sub)))
    out = list(inserts.get(-1, []))
    for i, (s, e) in enumerate(reps):
        out.append((s, e.xreplace(sub)))
        out.extend(inserts.get(i, []))
    return out, [e.xreplace(sub) for e in reduced]
