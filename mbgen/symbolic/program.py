r"""Straight-line programs: named intermediate quantities of a recursive derivation.

A recursion over a body tree (Newton–Euler, the articulated-body algorithm)
computes the same kind of quantity again and again from the one before it.
Written as nested expressions, every sum along the tree is flattened by sympy
into ever longer sums; written as a :class:`Program`, every quantity is a new
symbol defined by a small expression of earlier ones, so its size grows
linearly with the tree.

A program is ``assignments``: pairs ``(s, e)`` evaluated in order, ``s`` a
fresh symbol (named ``mbgen:...``, renamed when code is generated), ``e`` an
expression of the layout's symbols and earlier ``s``.  ``checks`` are symbols
that must be positive (the pivots of a recursion: a non-positive one means
the mass matrix is not positive definite).

:func:`derivatives` differentiates expressions through a program in forward
mode: with local partials :math:`\partial e_k/\partial s` computed once, the
derivative of every assignment with respect to a variable ``v`` is

.. math::

    \frac{d s_k}{d v} = \sum_{s \in e_k} \frac{\partial e_k}{\partial s}\,\frac{d s}{d v},

one new assignment per nonzero derivative; the cost per variable is the size
of the part of the program that the expressions read, never that of the
expanded expressions.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import sympy as sm
from sympy.functions.elementary.piecewise import ExprCondPair

from .graph import (
    free_symbols,
    leaves,
    postorder_unique,
    reachable,
    symbols_back,
    to_symengine,
    to_sympy,
    xreplace_dag,
)


@dataclass(frozen=True)
class Program:
    """Assignments ``((symbol, expr), ...)`` in evaluation order, and positivity checks."""

    assignments: tuple[tuple[sm.Symbol, sm.Expr], ...] = ()
    checks: frozenset = field(default_factory=frozenset)

    def __bool__(self) -> bool:
        return bool(self.assignments)

    def __len__(self) -> int:
        return len(self.assignments)

    @property
    def symbols(self) -> tuple[sm.Symbol, ...]:
        return tuple(s for s, _ in self.assignments)

    @functools.cached_property
    def leaves(self) -> tuple[set, set]:
        """``(free symbols, applied functions)`` of the definitions (walked once, kept)."""
        return leaves([e for _, e in self.assignments])

    def inline(self, exprs: Iterable, evaluate: bool = True) -> list:
        """``exprs`` with every program symbol replaced by its definition (a shared graph).

        ``evaluate=False`` rebuilds without re-evaluating, so that sums along
        a recursion stay nested (linear in size) rather than being flattened.
        """
        memo: dict = {}
        defs: dict = {}
        for s, e in self.assignments:
            defs[s] = _rebuild(e, defs, memo, evaluate)
        return [_rebuild(sm.sympify(e), defs, memo, evaluate) for e in exprs]

    def closure(self, exprs: Iterable) -> set:
        """Symbols of ``exprs`` that are not program symbols, following program symbols."""
        defs = dict(self.assignments)
        out: set = set()
        stack = list(free_symbols(exprs))
        seen: set = set()
        while stack:
            s = stack.pop()
            if s in seen:
                continue
            seen.add(s)
            if s in defs:
                stack.extend(free_symbols([defs[s]]))
            else:
                out.add(s)
        return out

    def xreplace(self, mapping: dict) -> Program:
        """The program with ``mapping`` applied to every definition (one shared memo)."""
        if not self.assignments:
            return self
        memo: dict = {}
        values = xreplace_dag([e for _, e in self.assignments], mapping, memo)
        return Program(tuple(zip(self.symbols, values)), self.checks)


def _rebuild(expr, defs, memo, evaluate):
    for node in postorder_unique([expr]):
        if node in memo:
            continue
        if node in defs:
            memo[node] = defs[node]
        elif not node.args:
            memo[node] = node
        else:
            args = [memo[a] for a in node.args]
            if all(n is o for n, o in zip(args, node.args)):
                memo[node] = node
            else:
                memo[node] = node.func(*args) if evaluate or isinstance(node, ExprCondPair) \
                    else node.func(*args, evaluate=False)   # (a Piecewise's pair takes no flag)
    return memo[expr]


class ProgramBuilder:
    """Collects assignments; small expressions stay inline, others get a symbol.

    Parameters
    ----------
    tag : str
        Symbols are named ``mbgen:<tag><k>``.
    """

    def __init__(self, tag: str):
        self.tag = tag
        self.assignments: list[tuple[sm.Symbol, sm.Expr]] = []
        self.checks: set = set()

    def scalar(self, expr, check: bool = False):
        """A symbol for ``expr`` (or ``expr`` itself when it is a number, a symbol or
        ``-symbol``)."""
        expr = sm.sympify(expr)
        if not check and _trivial(expr):
            return expr
        s = sm.Symbol(f"mbgen:{self.tag}{len(self.assignments)}")
        self.assignments.append((s, expr))
        if check:
            self.checks.add(s)
        return s

    def vector(self, v) -> tuple:
        return tuple(self.scalar(x) for x in v)

    def build(self) -> Program:
        return Program(tuple(self.assignments), frozenset(self.checks))


def _trivial(expr) -> bool:
    if expr.is_Number or expr.is_Symbol:
        return True
    return (isinstance(expr, sm.Mul) and len(expr.args) == 2 and expr.args[0].is_Number
            and expr.args[1].is_Symbol)


def derivatives(program: Program, exprs: Sequence, variables: Sequence,
                tag: str = "d") -> tuple[Program, list[list[sm.Expr]]]:
    """Forward-mode derivatives of ``exprs`` with respect to ``variables`` through ``program``.

    Returns
    -------
    extra : Program
        New assignments (derivatives of program symbols, named ``mbgen:<tag><k>``),
        to be evaluated after ``program``.
    jac : list of lists, shape (len(exprs), len(variables))
        ``d expr_i / d variable_j`` in terms of layout, program and ``extra`` symbols.
    """
    import symengine as se

    memo: dict = {}
    needed = reachable(list(exprs), dict(program.assignments))   # only what exprs read
    kept = [(s, e) for s, e in program.assignments if s in needed]
    syms = to_symengine([s for s, _ in kept], memo)
    defs = to_symengine([e for _, e in kept], memo)
    svars = to_symengine(list(variables), memo)
    sexprs = to_symengine(list(exprs), memo)
    tracked = set(syms) | set(svars)
    def_partials = [_partials(e, tracked) for e in defs]
    expr_partials = [_partials(e, tracked) for e in sexprs]
    one = se.Integer(1)
    new: list = []
    named: dict = {}   # id of a compound partial -> its symbol (assigned once, at first use)

    def name(p):
        if p.is_Number or p.is_Symbol:
            return p
        s = named.get(id(p))
        if s is None:
            s = named[id(p)] = se.Symbol(f"mbgen:{tag}{len(new)}")
            new.append((s, p))
        return s

    def chain(parts, D):
        terms = [name(p) if D[f] == one else name(p) * D[f] for f, p in parts.items() if f in D]
        return se.Add(*terms) if terms else None

    jac: list = [[None] * len(svars) for _ in sexprs]
    for j, v in enumerate(svars):
        D = {v: one}
        for s, parts in zip(syms, def_partials):
            d = chain(parts, D)
            if d is None or d == 0:
                continue
            if d.is_Number or d.is_Symbol:
                D[s] = d
            else:
                t = se.Symbol(f"mbgen:{tag}{len(new)}")
                new.append((t, d))
                D[s] = t
        for i, parts in enumerate(expr_partials):
            jac[i][j] = chain(parts, D)
    return _back_to_sympy(new, jac, memo)


def _partials(e, tracked: set) -> dict:
    """``{s: de/ds}`` for the tracked symbols ``s`` of ``e`` (symengine; computed once)."""
    out = {}
    for s in e.free_symbols:
        if s in tracked:
            d = e.diff(s)
            if d != 0:
                out[s] = d
    return out


def _back_to_sympy(new: list, jac: list, memo: dict) -> tuple[Program, list[list[sm.Expr]]]:
    """:func:`derivatives`' result in sympy: the new assignments (symengine ``(symbol,
    value)`` pairs) as a :class:`Program`, and the Jacobian (None: zero)."""
    back = symbols_back(memo)
    new_syms = [sm.Symbol(str(t)) for t, _ in new]
    for (t, _), s in zip(new, new_syms):
        back[t] = s
    values = to_sympy([d for _, d in new], back, small=True)
    flat = [d for row in jac for d in row if d is not None]
    it = iter(to_sympy(flat, back, small=True))
    out = [[sm.S.Zero if d is None else next(it) for d in row] for row in jac]
    return Program(tuple(zip(new_syms, values))), out
