"""Small symbolic utilities that respect shared subexpressions.

Derived expressions share subtrees (the same Python object appears in many
places), so a naive recursive walk visits a subtree once per reference and can
take exponential time on deep rotation chains.  These helpers walk the
expression DAG once.
"""

from __future__ import annotations

from typing import Iterable

import sympy as sm


def walk_unique(exprs: Iterable[sm.Basic]):
    """Yield every distinct node of ``exprs`` once (pre-order, deterministic)."""
    seen: set = set()
    stack = [sm.sympify(e) for e in reversed(list(exprs))]
    while stack:
        node = stack.pop()
        if node in seen:
            continue
        seen.add(node)
        yield node
        stack.extend(reversed(node.args))


def free_symbols(exprs: Iterable[sm.Basic]) -> set:
    """Union of free symbols of ``exprs`` (DAG walk)."""
    return {n for n in walk_unique(exprs) if isinstance(n, sm.Symbol)}


def applied_functions(exprs: Iterable[sm.Basic]) -> set:
    """Undefined functions applied to arguments, e.g. ``q1(t)`` (DAG walk)."""
    return {n for n in walk_unique(exprs) if isinstance(n, sm.core.function.AppliedUndef)}


def node_ops(node: sm.Basic) -> int:
    """Floating-point operations of one node, its arguments excluded.

    ``Add``/``Mul`` with ``k`` arguments: ``k - 1`` (a ``-1`` coefficient is a
    subtraction, not a multiplication); ``x**n`` for integer ``n``: ``|n| - 1``
    multiplications (plus one division when ``n < 0``); any other power or
    function call: 1.
    """
    if not node.args or isinstance(node, (sm.Number, sm.Symbol)):
        return 0
    if isinstance(node, sm.Add):
        return len(node.args) - 1
    if isinstance(node, sm.Mul):
        n = len(node.args) - 1
        return n - 1 if node.args[0] == -1 else n
    if isinstance(node, sm.Pow):
        e = node.exp
        if e.is_Integer:
            k = abs(int(e))
            return k - 1 + (1 if e < 0 else 0) if k > 0 else 0
        return 1
    return 1


def count_ops_tree(exprs: Iterable[sm.Basic]) -> int:
    """Operations of ``exprs`` evaluated as trees (no sharing): what a printer emits without CSE.

    Counted with :func:`node_ops`, memoised per distinct node, so it is fast on
    shared DAGs even when the tree it describes is huge.
    """
    memo: dict = {}

    def ops(node) -> int:
        hit = memo.get(node)
        if hit is not None:
            return hit
        n = node_ops(node) + sum(ops(a) for a in node.args)
        memo[node] = n
        return n

    total = 0
    for e in exprs:
        e = sm.sympify(e)
        # iterative warm-up of the memo (post-order) to avoid deep recursion
        for node in reversed(list(walk_unique([e]))):
            ops(node)
        total += ops(e)
    return total


def count_ops_dag(exprs: Iterable[sm.Basic]) -> int:
    """Arithmetic operations when every distinct subexpression is computed once."""
    return sum(node_ops(node) for node in walk_unique(exprs))
