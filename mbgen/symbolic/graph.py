"""Small symbolic utilities that respect shared subexpressions.

Derived expressions share subtrees (the same Python object appears in many
places), so a naive recursive walk visits a subtree once per reference and can
take exponential time on deep rotation chains.  These helpers walk the
expression DAG once.  :func:`fewer_collections` runs the garbage collector less often
while a pipeline builds expressions.
"""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager

import sympy as sm
from sympy.functions.elementary.piecewise import ExprCondPair

from . import build

#: The cyclic collector's first threshold while expressions are built
#: (:func:`fewer_collections`); Python's default is 700.
GC_THRESHOLD = 200_000
_gc_lock = threading.Lock()
_gc_depth = [0, None]     # nesting depth, the thresholds to restore


@contextmanager
def fewer_collections() -> Iterator[None]:
    """Run the cyclic garbage collector less often inside: its first threshold is raised
    to :data:`GC_THRESHOLD` allocations, and restored on the way out (nested or in
    several threads: by the last one out).

    Why: a derivation allocates a few hundred thousand expression nodes, hardly any of them in
    a reference cycle, and every 700 allocations Python scans the youngest objects, every
    7,000 the middle generation, now and then everything alive (sympy's import included).
    The spatial arm's RHS, derive..render in a new process (``build=False``), six runs
    each at the default / raised threshold: n = 4 0.25-0.30 / 0.21-0.26 s, n = 32
    2.47-2.74 / 2.12-2.53 s; the peak resident memory is the same (133 MB).
    """
    with _gc_lock:
        if _gc_depth[0] == 0:
            _gc_depth[1] = gc.get_threshold()
            first, *rest = _gc_depth[1]
            gc.set_threshold(max(first, GC_THRESHOLD), *rest)
        _gc_depth[0] += 1
    try:
        yield
    finally:
        with _gc_lock:
            _gc_depth[0] -= 1
            if _gc_depth[0] == 0:
                gc.set_threshold(*_gc_depth[1])


def walk_unique(exprs: Iterable[sm.Basic]):
    """Yield every distinct node of ``exprs`` once (pre-order, deterministic); sympy or
    symengine expressions (anything else is sympified)."""
    seen: set = set()
    stack = [e if hasattr(e, "args") else sm.sympify(e) for e in reversed(list(exprs))]
    while stack:
        node = stack.pop()
        if node in seen:
            continue
        seen.add(node)
        yield node
        stack.extend(reversed(node.args))


def free_symbols(exprs: Iterable[sm.Basic]) -> set:
    """Union of free symbols of ``exprs`` (DAG walk; in no order, so without a generator)."""
    found: set = set()
    seen: set = set()
    stack = [e if hasattr(e, "args") else sm.sympify(e) for e in exprs]
    while stack:
        node = stack.pop()
        if not node.args:   # a leaf: nothing below it (a Float's hash is not cached)
            if isinstance(node, sm.Symbol):
                found.add(node)
            continue
        if node in seen:
            continue
        seen.add(node)
        stack.extend(node.args)
    return found


def leaves(exprs: Iterable[sm.Basic]) -> tuple[set, set]:
    """``(free symbols, applied undefined functions)`` of ``exprs`` in one DAG walk."""
    symbols, funcs = set(), set()
    for n in walk_unique(exprs):
        if isinstance(n, sm.Symbol):
            symbols.add(n)
        elif isinstance(n, sm.core.function.AppliedUndef):
            funcs.add(n)
    return symbols, funcs


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


def count_ops_tree(exprs: Iterable[sm.Basic], memo: dict | None = None) -> int:
    """Operations of ``exprs`` evaluated as trees (no sharing): what a printer emits without CSE.

    Counted with :func:`node_ops`, memoised per distinct node for every expression at
    once (a node's tree count does not depend on who reads it), so it is fast on shared
    DAGs even when the tree it describes is huge; the walk stops at counted nodes.  ``memo``
    (node -> count) may be shared between calls.
    """
    memo = {} if memo is None else memo
    total = 0
    for e in exprs:
        e = e if hasattr(e, "args") else sm.sympify(e)
        if e not in memo:
            for node in postorder_unique([e], known=memo):
                memo[node] = node_ops(node) + sum(memo[a] for a in node.args)
        total += memo[e]
    return total


def count_ops_dag(exprs: Iterable[sm.Basic]) -> int:
    """Arithmetic operations when every distinct subexpression is computed once."""
    return sum(node_ops(node) for node in walk_unique(exprs))


# --------------------------------------------------------------------------- graph passes
def postorder_unique(exprs: Iterable, known=()) -> list:
    """Distinct nodes of ``exprs`` (sympy or symengine), children before parents, iteratively.

    Each distinct node appears once, so a pass that processes this list and
    memoises by node costs what the expression *graph* costs.  Nodes in ``known`` (a
    pass's memo) and what lies below them are left out.
    """
    order: list = []
    seen: set = set()
    for root in exprs:
        if root in seen or root in known:
            continue
        stack = [(root, False)]
        while stack:
            node, expanded = stack.pop()
            if expanded:
                order.append(node)
                continue
            if node in seen or node in known:
                continue
            seen.add(node)
            stack.append((node, True))
            for a in reversed(node.args):
                if a not in seen:
                    stack.append((a, False))
    return order


def xreplace_dag(exprs: Iterable[sm.Basic], mapping: dict, memo: dict | None = None,
                 keep_sums: bool = False) -> list:
    """``[e.xreplace(mapping) for e in exprs]``, visiting each distinct node once.

    sympy's own ``xreplace`` recurses through the tree, so it costs the
    expanded tree of a shared expression; this pass is linear in the graph.
    Nodes are rebuilt (and re-evaluated, as ``xreplace`` does) only where a
    descendant changed.  ``memo`` may be shared between calls with the same
    ``mapping`` so that repeated subexpressions are replaced once.

    ``keep_sums``: a product that becomes a number times one sum stays that
    (``0.4*(x + y)``, one product) where sympy would distribute the number over
    the sum (``0.4*x + 0.4*y``, a product per term): baking ``a = 0.4`` into
    ``a*(x + y)`` must not cost operations (:func:`mbgen.codegen.slicing.bake`).
    """
    exprs = [sm.sympify(e) for e in exprs]
    memo = {} if memo is None else memo
    for node in postorder_unique(exprs):
        if node in memo:
            continue
        hit = mapping.get(node)
        if hit is not None:
            memo[node] = hit
        elif not node.args:
            memo[node] = node
        else:
            args = [memo[a] for a in node.args]
            changed = any(n is not o for n, o in zip(args, node.args))
            memo[node] = build.rebuilt(node, args, keep_sums) if changed else node
    return [memo[e] for e in exprs]


def reachable(roots: Iterable[sm.Basic], defs: Mapping, reads: dict | None = None) -> set:
    """The symbols of ``defs`` (symbol -> definition) that ``roots`` read, directly or through
    other definitions; each definition is visited once.  ``reads`` (symbol -> the symbols of
    ``defs`` its definition reads) may be shared between calls over the same ``defs``, so
    that a definition is walked once for all of them (a kernel asks once per output)."""
    reads = {} if reads is None else reads
    needed: set = set()
    stack = list(free_symbols(roots) & defs.keys())
    while stack:
        s = stack.pop()
        if s in needed:
            continue
        needed.add(s)
        direct = reads.get(s)
        if direct is None:
            direct = reads[s] = [d for d in free_symbols([defs[s]]) if d in defs]
        stack.extend(d for d in direct if d not in needed)
    return needed


def _canonical(op, args: list):
    """``op(*args)`` for the arguments of a symengine sum or product, already combined.

    Where ``args`` hold at most one number and no node of ``op`` itself, the node is built
    from its arguments in sympy's canonical order (the number first, the rest sorted as sympy
    sorts them); it equals ``op(*args)`` but for a number times a sum, which stays one
    product (sympy would distribute it).
    """
    numbers = [a for a in args if a.is_Number]
    if len(args) < 2 or len(numbers) > 1 or any(a.func is op for a in args):
        return op(*args)
    rest = sorted((a for a in args if not a.is_Number), key=build.ORDER)
    return op._from_args(numbers + rest)

#: Relations and connectives converted node by node both ways (a ``Piecewise``'s
#: conditions), by class name, the same in both libraries (symengine turns ``a > b`` into
#: ``b < a``, and its derivative of a Piecewise joins pieces under ``Or``).
LOGIC = ("StrictLessThan", "LessThan", "StrictGreaterThan", "GreaterThan", "Equality",
         "Unequality", "And", "Or", "Not")


def _se():
    import symengine

    return symengine


def _function_table():
    se = _se()
    names = ("sin cos tan cot sec csc asin acos atan acot asec acsc sinh cosh tanh coth "
             "asinh acosh atanh log Abs sign floor ceiling atan2 gamma erf erfc Max Min").split()
    out = {}
    for n in names:
        f_sm = getattr(sm, n, None)
        f_se = getattr(se, n, None)
        if f_sm is not None and f_se is not None:
            out[f_sm] = f_se
    return out


_SM_TO_SE: dict | None = None
_SE_TO_SM: dict | None = None


def to_symengine(exprs: Iterable[sm.Basic],  # noqa: C901 - type-dispatch walker, flat per node
                 memo: dict | None = None) -> list:
    """Convert sympy expressions to symengine, each distinct node once.

    ``symengine.sympify`` converts a sympy expression as a tree (its cost
    doubles with every level of a shared graph); this pass builds each
    distinct node once, bottom-up.  Pass one ``memo`` to several calls to keep
    the results sharing nodes.
    """
    global _SM_TO_SE
    se = _se()
    if _SM_TO_SE is None:
        _SM_TO_SE = _function_table()
    table = _SM_TO_SE
    exprs = [sm.sympify(e) for e in exprs]
    memo = {} if memo is None else memo
    for node in postorder_unique(exprs):
        if node in memo:
            continue
        if not node.args:
            if isinstance(node, sm.Symbol):
                out = se.Symbol(node.name)
            elif isinstance(node, sm.Integer):
                out = se.Integer(int(node))
            elif isinstance(node, sm.Rational):
                out = se.Rational(int(node.p), int(node.q))
            elif isinstance(node, sm.Float):
                out = se.RealDouble(float(node))
            else:
                out = se.sympify(node)   # pi, E, I, oo, nan: leaves
        else:
            args = [memo[a] for a in node.args]
            if isinstance(node, sm.Add):
                out = se.Add(*args)
            elif isinstance(node, sm.Mul):
                out = se.Mul(*args)
            elif isinstance(node, sm.Pow):
                out = se.Pow(*args)
            elif isinstance(node, sm.exp):
                out = se.exp(*args)
            elif node.func in table:
                out = table[node.func](*args)
            elif isinstance(node, sm.Piecewise):   # its (expression, condition) pairs
                out = se.Piecewise(*args)
            elif isinstance(node, ExprCondPair):   # no expression: a pair for the Piecewise
                out = tuple(args)
            elif isinstance(node, sm.logic.boolalg.Boolean) and type(node).__name__ in LOGIC:
                out = getattr(se, type(node).__name__)(*args)   # a > b: b < a in symengine
            else:
                out = se.sympify(node)   # rare kinds: converted as a whole
        memo[node] = out
    return [memo[e] for e in exprs]


def symbols_back(forward_memo: dict) -> dict:
    """``{symengine symbol: sympy symbol}`` for the symbols a :func:`to_symengine` memo converted.

    Seed :func:`to_sympy`'s memo with it so that symbols come back as the very
    sympy symbols that went in (with their assumptions), not as plain namesakes.
    """
    return {v: k for k, v in forward_memo.items() if isinstance(k, sm.Symbol)}


def to_sympy(exprs: Iterable, memo: dict | None = None,  # noqa: C901 - type-dispatch walker
             small: bool = False) -> list:
    """Convert symengine expressions to sympy, each distinct node once (see :func:`to_symengine`).

    ``memo`` may be pre-seeded (``{symengine symbol: sympy symbol}``) to rename
    symbols on the way, and shared between calls to keep results sharing nodes.

    ``small``: the expressions are small assignments (a program's, or what CSE left), so
    sums and products are built from their arguments in sympy's canonical order without
    re-evaluating them (:func:`_canonical`; most of the conversion's time otherwise).  Not for
    deep shared graphs: such a node is not sympy's cached one, and comparing two equal but
    distinct deep graphs walks them as trees.
    """
    global _SE_TO_SM
    se = _se()
    if _SE_TO_SM is None:
        _SE_TO_SM = {type(f_se(se.Symbol("a"), se.Symbol("b")) if f_sm in (sm.atan2, sm.Max, sm.Min)
                          else f_se(se.Symbol("a"))): f_sm
                     for f_sm, f_se in _function_table().items()}
    table = _SE_TO_SM
    memo = {} if memo is None else memo
    exprs = list(exprs)
    for node in postorder_unique(exprs):
        if node in memo:
            continue
        args = node.args
        if not args:
            if isinstance(node, se.Symbol):
                out = sm.Symbol(node.name)
            elif isinstance(node, se.Integer):
                out = sm.Integer(int(node))
            elif isinstance(node, se.Rational):
                p, q = node.get_num_den()
                out = sm.Rational(int(p), int(q))
            elif isinstance(node, se.RealDouble):
                out = sm.Float(float(node), 17)
            else:
                out = node._sympy_()
        else:
            sargs = [memo[a] for a in args]
            if isinstance(node, se.Add):
                out = _canonical(sm.Add, sargs) if small else sm.Add(*sargs)
            elif isinstance(node, se.Mul):
                out = _canonical(sm.Mul, sargs) if small else sm.Mul(*sargs)
            elif isinstance(node, se.Pow):
                out = sm.Pow(*sargs)
            elif type(node) in table:
                out = table[type(node)](*sargs)
            elif isinstance(node, se.Piecewise):   # args: expression, condition, ...
                out = sm.Piecewise(*((e, _condition(c))
                                     for e, c in zip(sargs[::2], sargs[1::2])))
            elif type(node).__name__ in LOGIC:
                out = getattr(sm, type(node).__name__)(*sargs)
            else:
                out = node._sympy_()
        memo[node] = out
    return [memo[e] for e in exprs]


def symengine_rebuilt(node, args):
    """Symengine ``node`` with new ``args``: ``node.func(*args)``, but a ``Piecewise`` holds
    its pairs flat (expression, condition, ...) and is built from pairs, and a relation or
    connective has no ``func``."""
    se = _se()
    if isinstance(node, se.Piecewise):
        return se.Piecewise(*zip(args[::2], args[1::2]))
    return getattr(se, type(node).__name__)(*args) if type(node).__name__ in LOGIC else \
        node.func(*args)


def _condition(c):
    """A ``Piecewise`` condition back from symengine: its CSE names a relation ``x`` and
    tests ``Eq(x, True)``; ``x`` holds 0 or 1 in the generated code, so that is ``x != 0``."""
    if isinstance(c, sm.Eq) and c.rhs is sm.true:
        return sm.Ne(c.lhs, 0)
    return c


def differentiate(exprs, variables) -> list[list[sm.Expr]]:
    """``[[d e / d v for v in variables] for e in exprs]``, differentiated by symengine.

    symengine differentiates the shared expression graph about a hundred times
    faster than ``sympy.diff`` (0.35 s against ~60 s for the 32-link pendulum's
    ``dR/dx``), and memoises by node.  The expressions cross to symengine and
    back through one memo each way (:func:`mbgen.symbolic.graph.to_symengine`), so a
    subexpression shared by several entries is converted once and the results
    share nodes again.
    """
    memo: dict = {}
    se_exprs = to_symengine(exprs, memo)
    svars = to_symengine(variables, memo)
    flat = []
    for se_e in se_exprs:
        free = se_e.free_symbols
        flat.extend(se_e.diff(v) if v in free else None for v in svars)
    nonzero = to_sympy([d for d in flat if d is not None], symbols_back(memo))
    it = iter(nonzero)
    values = [sm.S.Zero if d is None else next(it) for d in flat]
    nv = len(svars)
    return [values[i * nv:(i + 1) * nv] for i in range(len(se_exprs))]


#: What :func:`split_shared` never names: a Piecewise's pairs and conditions are no numbers.
_NOT_NAMED = (ExprCondPair, sm.logic.boolalg.Boolean)


def split_shared(exprs, prefix: str = "_s"):
    """``(replacements, reduced)``: every node with more than one parent becomes a temporary.

    Not an optimising CSE: it only names what the graph already shares, so
    printing the result costs what the graph costs.  Takes an expression, a
    list or a matrix and returns ``reduced`` in the same form (as
    ``sympy.cse(..., list=False)`` does).
    """
    if isinstance(exprs, sm.MatrixBase):
        reps, flat = split_shared(list(exprs), prefix)
        return reps, sm.ImmutableMatrix(exprs.rows, exprs.cols, flat)
    if isinstance(exprs, (list, tuple)):
        roots = [sm.sympify(e) for e in exprs]
        single = False
    else:
        roots = [sm.sympify(exprs)]
        single = True
    order = postorder_unique(roots)
    parents: dict = {}
    for node in order:
        for a in set(node.args):
            parents[a] = parents.get(a, 0) + 1
    for r in roots:
        parents[r] = parents.get(r, 0) + 1
    memo: dict = {}
    reps = []
    for node in order:
        if not node.args:
            memo[node] = node
            continue
        args = [memo[a] for a in node.args]
        rebuilt = node.func(*args) if any(n is not o for n, o in zip(args, node.args)) else node
        if parents.get(node, 0) > 1 and not isinstance(node, _NOT_NAMED):
            sym = sm.Symbol(f"{prefix}{len(reps)}")
            reps.append((sym, rebuilt))
            memo[node] = sym
        else:
            memo[node] = rebuilt
    reduced = [memo[r] for r in roots]
    return reps, (reduced[0] if single else reduced)
