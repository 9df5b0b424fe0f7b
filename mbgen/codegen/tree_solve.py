r"""The mass matrix's ``L D L^T`` over the structural nonzeros of a kinematic tree.

On a tree of joints ``M_ij`` is nonzero only where one speed's body is an ancestor of the
other's.  Eliminating the leaves first (Featherstone's ``L^T D L``; here ``M = P^T L D L^T P``
with ``P`` the elimination order and ``L`` unit lower triangular in that order) fills
nothing in: ``L_pq`` is a structural nonzero only where ``M_pq`` is, so a factor and a solve
that touch those entries only cost, per speed, its ancestors' count instead of ``n``.
:func:`elimination_order` takes the layout's order or its reverse, whichever fills in less
(the reverse, leaves first, for a layout that lists parents first, as ``from_urdf`` and
``from_mjcf`` do).  Algorithm, ``p`` in elimination order, ``w_q = L_pq d_q``::

    d_p  = M_pp - sum_q L_pq w_q            (q eliminated before p; singular unless d_p > tol_p)
    L_rp = (M_rp - sum_q L_rq w_q) / d_p    (r eliminated after p)
    solve: b_p -= sum_q L_pq b_q (order);  b_p *= 1/d_p;  b_p -= sum_r L_rp b_r (reverse order)

Storage (row-major, original indices): ``M`` (``n x n``, its lower triangle read and
overwritten: ``D`` on the diagonal, ``L_pq`` at the slot of the pair ``{p, q}``), ``ID``
(``n``: ``1/d_p``).  Pivots: the mass matrix's rule (:mod:`mbgen.codegen.solver`).

Users: the contact solve (:mod:`mbgen.codegen.contacts`) builds on :class:`TreeFactor`, and a
model function that solves many columns (the Jacobian's ``M^{-1} [columns]``) of a model of
at least :data:`TREE_MIN` speeds whose factor is sparse or small enough
(:func:`tree_factor`: at most :data:`TREE_FILL` of the dense count or
:data:`TREE_DENSE_MAX` nonzeros) factors ``M`` with
:meth:`TreeFactor.factor` (the runtime routine ``tree``) and solves its columns with
:func:`vector_lines` of :meth:`TreeFactor.solve`: one loop over the columns per statement.
The statements are :class:`~mbgen.codegen.solver.Statement` values, printed in C and in
Python by the same functions, so both do the same operations in the same order.

Measured on G1 (35 speeds, 71 columns; paired C loops, the module's flags): the Jacobian in
0.80x the time of the dense ``ldl`` + ``ldl_solve_columns`` (Solo-12: 0.77x).  Below
:data:`~mbgen.codegen.solver.UNROLL_MAX` speeds too it beats the unrolled ``ldl_solve`` per
column into a local ``DT`` copied to the output (:data:`TREE_MIN`).  The column
solve is straight-line vector loops in a function of its own: the same loops inline in the
long public function ran 5 % slower and compiled 4 s longer, and a loop over index lists
(row, ``L``'s slot, column) ran 1.12x slower than the straight-line loops.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cached_property

from .solver import Statement, pivot_factor

#: Fewest speeds for the tree's factor and column solve.  Spatial arm, ``jacobian``, module's
#: flags, paired C loops, unrolled ``ldl_solve`` per column / the tree's: 2 links 80–94 / 64–71
#: ns, 3 210–214 / 184–187, 4 431–433 / 371, 5 643–668 / 554–556, 6 979–1,007 / 887–907
#: (the pair loops too), 8 1,906–1,923 / 1,337–1,359, 10 2,923–2,941 / 2,114–2,117, 12
#: 4,684–4,705 / 2,728–2,758 (without the pair loops); gcc within noise at 2–4 links (0.09–0.14
#: s at 2), 3.0–3.7 against 4.0–4.7 s at 8.
TREE_MIN = 2
#: A model of ``TREE_MIN`` speeds or more takes the tree factor for its column solves when ``L``
#: has at most this fraction of the dense ``n (n - 1) / 2`` structural nonzeros (G1: 306 of
#: 595, Solo-12: 99 of 153; a chain: all of them) ...
TREE_FILL = 0.75
#: ... or at most this many (a chain of 33 speeds): the straight-line solve beats the dense
#: loops there too (spatial arm, jacobian, module's flags, paired C loops: 16 links 5.63 ->
#: 4.95 us, 32 links 20.3 -> 18.6 us; gcc 6.2 -> 6.5 s and 31.0 -> 31.8 s), and its factor's
#: straight-line code, about n^3 / 6 statements for a chain, stays bounded.
TREE_DENSE_MAX = 528


def _fill(n: int, pattern: frozenset, order: tuple) -> dict[int, tuple[int, ...]]:
    """``{p: later neighbours of p}`` after eliminating in ``order``: ``L``'s pattern (``r`` in
    ``later[p]``: ``L_rp`` is a structural nonzero)."""
    adjacent = {i: set() for i in range(n)}
    for i, j in pattern:
        adjacent[i].add(j)
        adjacent[j].add(i)
    position = {p: k for k, p in enumerate(order)}
    done: set = set()
    later = {}
    for p in order:
        rest = adjacent[p] - done
        later[p] = tuple(sorted(rest, key=position.__getitem__))
        for a in rest:
            adjacent[a] |= rest - {a}
        done.add(p)
    return later


def elimination_order(n: int, pattern: frozenset) -> tuple[int, ...]:
    """The layout's order or its reverse, whichever gives ``L`` fewer structural nonzeros (a
    tie: the reverse, leaves first for a layout that lists parents first)."""
    orders = (tuple(reversed(range(n))), tuple(range(n)))
    return min(orders, key=lambda o: sum(len(v) for v in _fill(n, pattern, o).values()))


@dataclass(frozen=True)
class TreeFactor:
    """The statements of ``M = P^T L D L^T P`` and of its solve (the module docstring).

    ``pattern``: the structural nonzeros ``(i, j)``, ``i > j``, of ``M``.
    """

    n: int
    pattern: frozenset

    @cached_property
    def order(self) -> tuple[int, ...]:
        return elimination_order(self.n, self.pattern)

    @cached_property
    def later(self) -> dict[int, tuple[int, ...]]:
        return _fill(self.n, self.pattern, self.order)

    @cached_property
    def earlier(self) -> dict[int, tuple[int, ...]]:
        """``{p: q eliminated before p with L_pq nonzero}``, in elimination order."""
        out: dict = {p: [] for p in range(self.n)}
        for q in self.order:
            for p in self.later[q]:
                out[p].append(q)
        return {p: tuple(v) for p, v in out.items()}

    @property
    def nonzeros(self) -> int:
        """Structural nonzeros of ``L`` below its diagonal."""
        return sum(len(v) for v in self.later.values())

    def m(self, p: int, q: int, name: str = "M") -> str:
        """The text of the slot of ``{p, q}`` in ``M``'s lower triangle."""
        return f"{name}[{max(p, q) * self.n + min(p, q)}]"

    def factor(self) -> list[Statement]:
        """``M = P^T L D L^T P`` in place, ``ID = 1/d``; a check per pivot."""
        out: list[Statement] = []
        m = self.m
        for p in self.order:
            ks = self.earlier[p]
            out.append(Statement("let", f"tol{p}", f"{pivot_factor(self.n)} * {m(p, p)}"))
            for q in ks:
                out.append(Statement("let", f"w{p}_{q}", f"{m(p, q)}*{m(q, q)}"))
            if ks:
                out.append(Statement("set", m(p, p), " - ".join(
                    [m(p, p)] + [f"{m(p, q)}*w{p}_{q}" for q in ks])))
            out.append(Statement("check", m(p, p), f"tol{p}"))
            out.append(Statement("set", f"ID[{p}]", f"1.0/{m(p, p)}"))
            for r in self.later[p]:
                terms = [f"{m(r, q)}*w{p}_{q}" for q in ks if r in self.later[q]]
                first = [m(r, p)] if (max(r, p), min(r, p)) in self.pattern else []
                num = " - ".join(first + terms) if first else "-" + " - ".join(terms)
                out.append(Statement("set", m(r, p), f"({num})*ID[{p}]"))
        return out

    def forward(self, b, name: dict) -> list[Statement]:
        """``b <- D^{-1} L^{-1} P b``; ``b(p)``: the text of entry ``p``, ``name``: the
        factors' arrays ``{"M": ..., "ID": ...}``."""
        out: list[Statement] = []
        for p in self.order:
            ks = self.earlier[p]
            if ks:
                out.append(Statement("set", b(p), " - ".join(
                    [b(p)] + [f"{self.m(p, q, name['M'])}*{b(q)}" for q in ks])))
        return out + [Statement("set", b(p), f"{b(p)}*{name['ID']}[{p}]") for p in self.order]

    def backward(self, b, name: dict) -> list[Statement]:
        """``b <- P^T L^{-T} b``."""
        out: list[Statement] = []
        for p in reversed(self.order):
            rs = self.later[p]
            if rs:
                out.append(Statement("set", b(p), " - ".join(
                    [b(p)] + [f"{self.m(r, p, name['M'])}*{b(r)}" for r in rs])))
        return out

    def solve(self, b=lambda p: f"b[{p}]", arrays=None) -> list[Statement]:
        """``b <- M^{-1} b`` in place with the factors of :meth:`factor`."""
        name = {"M": "M", "ID": "ID", **(arrays or {})}
        return self.forward(b, name) + self.backward(b, name)

    def locals(self) -> int:
        """Doubles the factor declares (``let``): its stack beyond the arrays."""
        return sum(1 for s in self.factor() if s.kind == "let")


def vector_lines(program: list[Statement], stride: int, factors) -> list[str]:
    """C lines that run ``program`` on ``stride`` columns at once: each statement a loop over
    ``j`` (its targets written with ``j``), the factors' entries it reads (arrays named in
    ``factors``) read into constants first, so that the compiler vectorises the loop; per
    column the operations of ``program`` in its order (the bits of separate solves)."""
    names = "|".join(re.escape(a) for a in factors)
    pattern = re.compile(rf"\b(?:{names})\[\d+\]")
    out = []
    for st in program:
        refs = list(dict.fromkeys(pattern.findall(st.value)))
        value = st.value
        for k, ref in enumerate(refs):   # _k: no user's name (names start with a letter)
            value = re.sub(rf"\b{re.escape(ref)}(?![\d\]])", f"_k{k}", value)
        head = f"const double {', '.join(f'_k{k} = {r}' for k, r in enumerate(refs))}; " \
            if refs else ""
        out.append(f"{{ {head}for (j = 0; j < {stride}; ++j) {st.target} = {value}; }}")
    return out


def tree_factor(n: int, pattern: frozenset) -> TreeFactor | None:
    """The :class:`TreeFactor` a model of ``n`` speeds solves its columns with, or ``None``
    (the dense loops, or a single speed's unrolled solve): at least :data:`TREE_MIN` speeds
    and ``L`` at most :data:`TREE_FILL` of dense or at most :data:`TREE_DENSE_MAX` nonzeros."""
    if n < TREE_MIN:
        return None
    tree = TreeFactor(n, pattern)
    small = tree.nonzeros <= max(TREE_FILL * n * (n - 1) / 2, TREE_DENSE_MAX)
    return tree if small else None


__all__ = ["TREE_DENSE_MAX", "TREE_FILL", "TREE_MIN", "TreeFactor", "elimination_order",
           "tree_factor", "vector_lines"]
