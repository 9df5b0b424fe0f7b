r"""The ancestor–descendant dot products of a serial chain's analytic Jacobian, as loops.

On a chain of ``n`` screw joints every earlier body is an ancestor of every later one, and
the analytic partials (:mod:`mbgen.derivation.rnea_partials`) give each pair ``a < d`` (chain
positions) five dot products of per-body 6-vectors: the mass matrix's entry and four of
:math:`\partial R/\partial x`'s,

.. math::

    M_{u_d, u_a} = J_a\cdot F_{a,d}, \qquad
    R_{u_d, q_a} = -(F_{a,d}\cdot\dot A_{q,a} + T_d\cdot\dot V_{q,a}), \qquad
    R_{u_d, \dot q_a} = -(F_{a,d}\cdot\dot A_{v,a} + T_d\cdot J_a),

    R_{u_a, q_d} = -J_a\cdot F_{q,d}, \qquad R_{u_a, \dot q_d} = -J_a\cdot F_{v,d}

(``T`` has no linear part: those dot products take the angular three).  Written out, the
:math:`n (n - 1) / 2` pairs are 63 % of the 32-link arm's Jacobian; as loops over
structure-of-arrays vectors a compiler vectorises them (:mod:`mbgen.codegen.pairs`).

:class:`ChainPairs` holds the vectors, one row per component and one column per body
(:data:`ANCESTOR` and :data:`DESCENDANT` name the rows), and where the chain's coordinates
and speeds start.  The equations' ``residual_jacobian`` and ``partials_solve`` still hold
every entry: this is a second form of the same numbers (:meth:`ChainPairs.products`), for
the generated code.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sm

#: Rows of :attr:`ChainPairs.ancestor`: name -> (first row, components).
ANCESTOR = {"J": (0, 6), "Aq": (6, 6), "Vq": (12, 3), "Av": (15, 6)}
#: Rows of :attr:`ChainPairs.descendant`: name -> (first row, components).
DESCENDANT = {"Fa": (0, 6), "T": (6, 3), "Fq": (9, 6), "Fv": (15, 6)}
ANCESTOR_ROWS = 21
DESCENDANT_ROWS = 21


@dataclass(frozen=True)
class Product:
    """One output of a pair: ``target[row, col] = sign * sum(dots)``; a dot ``(ancestor
    vector, descendant vector, components)``; ``row``/``col`` name whose index it is
    (``"a"``/``"d"``) and where: ``"u"`` (a speed), ``"q"`` (a coordinate), ``"qd"`` (the
    ``n_q + speed`` column of ``R``)."""

    target: str           # "M" or "R"
    row: tuple[str, str]
    col: tuple[str, str]
    sign: int
    dots: tuple[tuple[str, str, int], ...]

    @property
    def operations(self) -> int:
        """Multiplications and additions (and the negation) of one pair."""
        terms = sum(k for _, _, k in self.dots)
        return 2 * terms - 1 + (self.sign < 0)


#: The five products of each pair ``a < d``, in the order the generated code computes them.
PRODUCTS = (
    Product("M", ("d", "u"), ("a", "u"), 1, (("J", "Fa", 6),)),
    Product("R", ("d", "u"), ("a", "q"), -1, (("Aq", "Fa", 6), ("Vq", "T", 3))),
    Product("R", ("d", "u"), ("a", "qd"), -1, (("Av", "Fa", 6), ("J", "T", 3))),
    Product("R", ("a", "u"), ("d", "q"), -1, (("J", "Fq", 6),)),
    Product("R", ("a", "u"), ("d", "qd"), -1, (("J", "Fv", 6),)),
)


@dataclass(frozen=True)
class ChainPairs:
    """The per-body vectors of a chain's pair products (the module docstring).

    Attributes
    ----------
    n : int
        Bodies on the chain, root first; body ``i`` turns or slides with coordinate
        ``q0 + i`` and speed ``u0 + i``.
    q0, u0 : int
        The first body's coordinate and speed (layout indices).
    ancestor : ImmutableMatrix, shape (21, n)
        ``J``, ``Aq``, ``Vq`` (angular part), ``Av`` of each body (:data:`ANCESTOR`).
    descendant : ImmutableMatrix, shape (21, n)
        ``Fa``, ``T`` (angular part), ``Fq``, ``Fv`` of each body (:data:`DESCENDANT`).
    """

    n: int
    q0: int
    u0: int
    ancestor: sm.ImmutableMatrix
    descendant: sm.ImmutableMatrix

    def __post_init__(self):
        if self.ancestor.shape != (ANCESTOR_ROWS, self.n) or \
                self.descendant.shape != (DESCENDANT_ROWS, self.n):
            raise ValueError(f"ChainPairs of {self.n} bodies: vectors of shapes "
                             f"{self.ancestor.shape} and {self.descendant.shape}, expected "
                             f"({ANCESTOR_ROWS}, {self.n}) and ({DESCENDANT_ROWS}, {self.n})")

    @property
    def pairs(self) -> int:
        return self.n * (self.n - 1) // 2

    @property
    def operations(self) -> int:
        """Operations of every product of every pair."""
        return self.pairs * sum(p.operations for p in PRODUCTS)

    def index(self, where: str, body: int, n_q: int) -> int:
        """The row or column index of ``body``'s coordinate (``"q"``), speed (``"u"``), or
        speed column of ``R`` (``"qd"``: ``n_q`` on)."""
        return {"q": self.q0, "u": self.u0, "qd": n_q + self.u0}[where] + body

    def vector(self, name: str, body: int) -> list:
        """The components of ``body``'s vector ``name``."""
        rows, matrix = (ANCESTOR, self.ancestor) if name in ANCESTOR else \
            (DESCENDANT, self.descendant)
        first, size = rows[name]
        return [matrix[first + c, body] for c in range(size)]

    def entries(self, n_q: int):
        """``(product, a, d, (target, row, col))`` for every product of every pair ``a < d``,
        ``R``'s speed columns from ``n_q`` on."""
        for d in range(self.n):
            for a in range(d):
                who = {"a": a, "d": d}
                for p in PRODUCTS:
                    yield p, a, d, (p.target, self.index(p.row[1], who[p.row[0]], n_q),
                                    self.index(p.col[1], who[p.col[0]], n_q))

    def positions(self, n_q: int) -> dict[str, set]:
        """``{"M": {(row, col)}, "R": {(row, col)}}``: the entries the pairs compute."""
        out: dict[str, set] = {"M": set(), "R": set()}
        for _, _, _, (target, row, col) in self.entries(n_q):
            out[target].add((row, col))
        return out

    def products(self, n_q: int) -> dict[tuple, sm.Expr]:
        """``{(target, row, col): expression}``: every product as a sympy expression (to
        check against the equations' entries)."""
        out = {}
        for p, a, d, key in self.entries(n_q):
            total = sm.Add(*(x * y for av, dv, k in p.dots for x, y in
                             zip(self.vector(av, a)[:k], self.vector(dv, d)[:k])))
            out[key] = p.sign * total
        return out


__all__ = ["ANCESTOR", "DESCENDANT", "PRODUCTS", "ChainPairs", "Product"]
