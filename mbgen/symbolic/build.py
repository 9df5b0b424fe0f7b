"""Sums and products built as sympy would build them, without sympy's evaluation where the
result is known.

``sympy.Mul(a, b)`` and ``sympy.Add(*terms)`` run ``flatten``: every factor split into base
and exponent, like bases gathered, numbers multiplied, the rest sorted, and the new node's
assumptions deduced -- about 25 us per call on this machine, half of deriving the 8-link
arm.  In most of a derivation's products and sums nothing combines: two distinct symbols or
function values, or a product and one more such factor, or terms that share no monomial.
Then ``flatten`` only sorts, and :func:`product` and :func:`total` build the node from its
sorted arguments directly (``_from_args``), the same node sympy builds: equal, with equal
arguments in the same order (``tests/symbolic/test_build.py`` compares the two on every
call of several derivations).  :func:`rebuilt` does the same for a node whose arguments
baking replaced (:func:`mbgen.codegen.slicing.bake`, through
:func:`~mbgen.symbolic.graph.xreplace_dag`).  A number times one sum, which sympy
distributes over the sum's terms, :func:`product` distributes the same way (a robot's Float
offsets make it common).  Anything else goes to sympy itself, and so does everything
outside an :func:`interned` block, whose table keeps one node per value.

sympy's canonical order (``Mul.flatten``'s ``_mulsort``, ``Add.flatten``'s ``_addsort``):
the number first, then the arguments sorted by ``Basic.compare``.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cmp_to_key

import sympy as sm
from sympy.core.mul import _keep_coeff
from sympy.core.parameters import global_parameters

#: sympy's canonical order of a sum's or product's arguments (``_addsort``, ``_mulsort``).
ORDER = cmp_to_key(sm.Basic.compare)
_local = threading.local()


#: Nodes the table keeps between the outermost ``interned`` blocks of a thread, at most; past
#: this it is emptied when the block ends (the 32-link arm's RHS: 21,418 nodes derived, 28,890
#: after baking).
TABLE_MAX = 50_000


@contextmanager
def interned() -> Iterator[None]:
    """Inside, :func:`product`, :func:`total` and :func:`rebuilt` build nodes directly, each
    distinct node once (a table of the nodes built, this thread's); outside they leave
    building to sympy.

    Why a table: sympy's constructors are cached, so a node built twice is usually one
    object, and comparing two equal expressions stops at the first shared node.  Two equal
    nodes built apart are compared argument by argument, and two equal graphs built apart
    as trees: exponential in the depth of a shared graph.  The table keeps the nodes built
    here one object per value, as sympy's cache does, and keeps them between blocks (two
    derivations of one model give the same nodes) up to :data:`TABLE_MAX` nodes.
    """
    depth = getattr(_local, "depth", 0)
    if depth == 0 and getattr(_local, "table", None) is None:
        _local.table = {}
    _local.depth = depth + 1
    try:
        yield
    finally:
        _local.depth = depth
        if depth == 0 and len(_local.table) > TABLE_MAX:
            _local.table = {}


def _active() -> bool:
    return getattr(_local, "depth", 0) > 0


def _node(cls, args: tuple):
    """The one node ``cls._from_args(args)`` of the table (see :func:`interned`)."""
    if len(args) == 1:
        return args[0]
    table = _local.table
    key = (cls, args)
    node = table.get(key)
    if node is None:
        node = table[key] = cls._from_args(args, True)
    return node


def _plain(x) -> bool:
    """A factor ``Mul.flatten`` only sorts in: a commutative symbol, a function's value other
    than ``exp`` (whose products combine) or a sum -- or a power of one of those to a
    number.  (A number times a lone sum distributes: :func:`_distributed`.)"""
    if x.is_Pow:
        return x.exp.is_Number and _plain(x.base)
    return (x.is_Symbol or x.is_Add or (x.is_Function and not isinstance(x, sm.exp))) \
        and x.is_commutative is True


def _base(x):
    return x.base if x.is_Pow else x


def _finite_number(x) -> bool:
    """A finite, nonzero number (a Float is finite: sympy makes inf ``oo``; ``Float(0.0)``
    is no ``S.Zero``, and sympy's product with it is).

    Read from the number itself (a Float's ``bool``, a Rational's numerator), as sympy's
    ``_eval_is_zero`` does: ``x.is_zero`` runs the assumption system once for every new
    number, 0.7 of the 9.4 profiled seconds of generating Solo-12."""
    if x.is_Float:
        return bool(x)
    return x.is_Rational and x.p != 0


def product(a, b):
    """``sympy.Mul(a, b)`` for two sympy expressions, neither zero nor one."""
    if not _active():
        return sm.Mul(a, b)
    factors = [f for x in (a, b) for f in (x.args if x.is_Mul else (x,))]
    split = _numbers_and_rest(factors, sm.Mul)
    node = None if split is None else _product_of(*split)
    if node is None and split is not None:
        node = _distributed(a, b, *split)
    return sm.Mul(a, b) if node is None else node


def _distributed(a, b, numbers: list, rest: list):
    """A number times one sum, distributed over its terms as ``Mul.flatten`` does it, the
    terms and the sum built by :func:`product` and :func:`total`; None where sympy must
    decide.

    - A Rational ``a`` times a sum ``b`` (or ``b`` times ``a``) takes ``flatten``'s
      two-argument path: ``Add(*[_keep_coeff(a, t) for t in b.args])``.
    - Otherwise (a robot's Float offsets and inertias times a sum) the general one:
      ``Add(*[c*t for t in sum.args])``, ``c`` the factors' numbers multiplied.
    """
    if len(rest) != 1 or not rest[0].is_Add or rest[0].is_commutative is not True \
            or not global_parameters.distribute:
        return None
    if a.is_Rational or b.is_Rational:
        a, b = (b, a) if b.is_Rational else (a, b)
        if b is not rest[0]:   # a product holding the sum: flatten keeps it whole or evaluates
            return None
        return total([_keep_coeff(a, t) for t in b.args])
    c = _coefficient(numbers)
    if c is sm.S.One or not _finite_number(c):
        return None
    return total([product(c, t) for t in rest[0].args])


def _coefficient(numbers: list):
    """The product of ``numbers`` in their order, from one, as ``Mul.flatten`` multiplies
    them (so that Floats round the same way)."""
    c = sm.S.One
    for n in numbers:
        c = c * n
    return c


def _monomial(term):
    """The term without its number, as the tuple of its factors (like terms: equal tuples)."""
    if term.is_Mul:
        return term.args[1:] if term.args[0].is_Number else term.args
    return (term,)


def _kept(term) -> bool:
    """A term ``Add.flatten`` keeps as it is (unless a like term joins it): commutative, not a
    number's power (``sqrt(2)`` is evaluated), and a product's number finite."""
    if term.is_Pow:
        return not term.base.is_Number and term.is_commutative is True
    if term.is_Mul and term.args[0].is_Number:
        return _finite_number(term.args[0]) and term.is_commutative is True
    return term.is_commutative is True and not term.is_Order


def total(terms):
    """``sympy.Add(*terms)`` for two or more sympy expressions, none zero."""
    if not _active():
        return sm.Add(*terms)
    flat = [t for x in terms for t in (x.args if x.is_Add else (x,))]
    split = _numbers_and_rest(flat, sm.Add)
    node = None if split is None else _sum_of(*split)
    return sm.Add(*terms) if node is None else node


def _numbers_and_rest(args, op):
    """``args`` split into their numbers (finite, nonzero) and the rest, or None where sympy
    must decide (a nested node of ``op``, or another number)."""
    numbers, rest = [], []
    for a in args:
        if a.is_Number:
            if not _finite_number(a):
                return None
            numbers.append(a)
        elif a.func is op:
            return None
        else:
            rest.append(a)
    return numbers, rest


def rebuilt(node, args: list, keep_sums: bool = False):
    """``node.func(*args)``: ``node`` with new arguments, as sympy evaluates it (inside
    :func:`interned`; outside, sympy builds it).

    A product or sum whose arguments do not combine is built directly, its numbers
    multiplied in the order sympy's ``flatten`` meets them (so that Floats round the same
    way); anything else by sympy.  ``keep_sums``: a number times one sum stays one product
    (:func:`mbgen.symbolic.graph.xreplace_dag`).
    """
    fast = _active() and (node.is_Mul or node.is_Add)
    split = _numbers_and_rest(args, node.func) if fast else None
    if split is not None:
        out = _sum_of(*split) if node.is_Add else _product_of(*split, keep_sums)
        if out is not None:
            return out
    return _sympys(node, args, keep_sums)


def _sum_of(numbers: list, rest: list):
    """The sum of at most one number and terms no two of which are like terms, or None."""
    if len(numbers) > 1 or not all(_kept(t) for t in rest) \
            or len({_monomial(t) for t in rest}) != len(rest):
        return None
    return _node(sm.Add, tuple(numbers + sorted(rest, key=ORDER)))


def _product_of(numbers: list, rest: list, keep_sums: bool = False):
    """The product of ``numbers`` (multiplied in their order) and plain factors of distinct
    bases, or None; a number times a lone sum only with ``keep_sums`` (sympy distributes)."""
    c = _coefficient(numbers)
    if not _finite_number(c) or not all(_plain(f) for f in rest) \
            or len({_base(f) for f in rest}) != len(rest):
        return None
    if len(rest) == 1 and rest[0].is_Add and c is not sm.S.One:   # a number times a sum
        return _node(sm.Mul, (c, rest[0])) if keep_sums and c is not sm.S.NegativeOne \
            else None
    ordered = tuple(sorted(rest, key=ORDER))
    return _node(sm.Mul, ordered if c is sm.S.One else (c,) + ordered) if ordered else c


def _sympys(node, args, keep_sums):
    return kept_product(args) if keep_sums and node.is_Mul else node.func(*args)


def kept_product(args: list) -> sm.Expr:
    """``Mul(*args)``, but a number times a single sum stays undistributed."""
    rest = [a for a in args if not a.is_Number]
    if len(rest) == 1 and rest[0].is_Add:
        c = sm.Mul(*[a for a in args if a.is_Number])
        if c.is_Number and c.is_finite and c not in (sm.S.Zero, sm.S.One, sm.S.NegativeOne):
            return sm.Mul._from_args((c, rest[0]))
    return sm.Mul(*args)


__all__ = ["ORDER", "interned", "kept_product", "product", "rebuilt", "total"]
