r"""The contact solve as straight-line code for the sparsity of ``M`` and ``J``.

A model with rigid point contacts (:mod:`mbgen.derivation.contacts`) solves, per call,

.. math::

    M a = f + J^T\lambda, \qquad J a + c = 0

(``n = n_u`` speeds, ``m`` contact rows).  With ``M = P^T L D L^T P`` (``P`` the elimination
order, ``L`` unit lower triangular in that order) and :math:`W = L^{-1} P J^T` (``n x m``),

.. math::

    G = J M^{-1} J^T = W^T D^{-1} W, \qquad
    \lambda = -G^{-1}\big(c + W^T D^{-1} \tilde f\big), \qquad
    a = P^T L^{-T} D^{-1}\big(\tilde f + W\lambda\big), \quad \tilde f = L^{-1} P f,

so one forward and one backward substitution give ``a`` (no ``M^{-1} J^T`` is formed) and
the Delassus matrix ``G`` costs a product over the common support of two columns of ``W``.

Order and sparsity.  On a tree of joints ``M_ij`` is nonzero only where one speed's body is
an ancestor of the other's; eliminating the leaves first (the layout reversed, for a
layout that lists parents first, as ``from_urdf`` and ``from_mjcf`` do) fills nothing in,
so ``L`` has the pattern of ``M``, and a contact row of ``J`` -- nonzero on the speeds
between the foot and the root -- keeps that support in ``W``.  :func:`elimination_order`
takes the layout's order or its reverse, whichever fills in less; the factor of ``M`` and
its substitutions are :class:`~mbgen.codegen.tree_solve.TreeFactor`'s, shared with the
Jacobian's column solve of a branched model.  Every statement below
touches a structural nonzero only: for Solo-12 with four feet (``n = 18, m = 12``) the
factorisation is a few hundred multiplications, where dense loops take about 8000.

Storage (row-major, original indices): ``M`` (``n x n``, its lower triangle read and
overwritten: ``D`` on the diagonal, ``L_pq`` at the slot of the pair ``{p, q}``), ``ID``
(``n``: ``1/d_p``), ``W`` and ``V = D^{-1} W`` (``m x n``, row ``r`` at ``r n``; entries
off their support are never written or read), ``G`` (``m x m``, lower triangle: its
``L``, and ``1/d`` on the diagonal).  Pivots: the mass matrix's rule
(:mod:`mbgen.codegen.solver`), ``d_p <= 16 n eps M_pp`` not positive definite, and for ``G``
``16 (n + m) eps G_rr``: the contact forces are undetermined (``CONTACT_SINGULAR``).

The statements are :class:`mbgen.codegen.solver.Statement` values, printed in C and Python
by the same functions as the ``L D L^T``'s (:func:`~mbgen.codegen.solver.c_lines`,
:func:`~mbgen.codegen.solver.py_lines`), so both do the same operations in the same order.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, partial

from .solver import Statement, pivot_factor
from .tree_solve import TreeFactor, elimination_order, vector_lines

#: Columns solved at once are padded to a multiple of this: a double's lanes in AVX-512, so
#: that ``-O2``'s vectoriser (gcc's "very cheap" model: no remainder loop) takes every loop.
LANES = 8


def padded(columns: int) -> int:
    """``columns`` rounded up to a multiple of :data:`LANES`."""
    return -(-columns // LANES) * LANES


@dataclass(frozen=True)
class ContactSolver:
    """The statements of one model's contact solve (see the module docstring).

    ``pattern``: the structural nonzeros ``(i, j)``, ``i > j``, of ``M``; ``rows``: per
    contact row, the speeds where ``J`` is a structural nonzero.
    """

    n: int
    m: int
    pattern: frozenset
    rows: tuple

    @cached_property
    def tree(self) -> TreeFactor:
        """``M``'s factor over the tree's structural nonzeros (:mod:`mbgen.codegen.tree_solve`)."""
        return TreeFactor(self.n, self.pattern)

    @property
    def order(self) -> tuple[int, ...]:
        return self.tree.order

    @property
    def later(self) -> dict[int, tuple[int, ...]]:
        return self.tree.later

    @property
    def earlier(self) -> dict[int, tuple[int, ...]]:
        """``{p: q eliminated before p with L_pq nonzero}``, in elimination order."""
        return self.tree.earlier

    @cached_property
    def support(self) -> tuple[tuple[int, ...], ...]:
        """Per contact row, the structural nonzeros of its column of ``W``, in order."""
        out = []
        for row in self.rows:
            s = set(row)
            for p in self.order:
                if any(q in s for q in self.earlier[p]):
                    s.add(p)
            out.append(tuple(p for p in self.order if p in s))
        return tuple(out)

    def _m(self, p: int, q: int) -> str:
        return self.tree.m(p, q)

    def _w(self, name: str, r: int, p: int) -> str:
        return f"{name}[{r * self.n + p}]"

    def _g(self, r: int, s: int) -> str:
        return f"G[{max(r, s) * self.m + min(r, s)}]"

    # ------------------------------------------------------------------ factor
    def factor_mass(self) -> list[Statement]:
        """``M = P^T L D L^T P`` in place, ``ID = 1/d``; a check per pivot."""
        return self.tree.factor()

    def factor_rows(self) -> list[Statement]:
        """``W = L^{-1} P J^T``, ``V = D^{-1} W`` and ``G = W^T V`` (lower triangle)."""
        out: list[Statement] = []
        for r, row in enumerate(self.rows):
            own = set(row)
            for p in self.support[r]:
                terms = [f"{self._m(p, q)}*{self._w('W', r, q)}" for q in self.earlier[p]
                         if q in self.support[r]]
                first = [self._w("J", r, p)] if p in own else []
                value = " - ".join(first + terms) if first else "-" + " - ".join(terms)
                out.append(Statement("set", self._w("W", r, p), value))
                out.append(Statement("set", self._w("V", r, p), f"{self._w('W', r, p)}*ID[{p}]"))
        for r in range(self.m):
            for s in range(r + 1):
                common = [p for p in self.support[r] if p in set(self.support[s])]
                value = " + ".join(f"{self._w('W', r, p)}*{self._w('V', s, p)}" for p in common)
                out.append(Statement("set", self._g(r, s), value or "0.0"))
        return out

    def factor_delassus(self) -> list[Statement]:
        """``G = L D L^T`` in place (dense: the base couples every contact), its pivots
        checked, then ``1/d`` on its diagonal."""
        out: list[Statement] = []
        m = self.m
        for j in range(m):
            out.append(Statement("let", f"gtol{j}", f"{pivot_factor(self.n + m)} * "
                                                    f"{self._g(j, j)}"))
            for k in range(j):
                out.append(Statement("let", f"g{j}_{k}", f"{self._g(j, k)}*{self._g(k, k)}"))
            if j:
                out.append(Statement("set", self._g(j, j), " - ".join(
                    [self._g(j, j)] + [f"{self._g(j, k)}*g{j}_{k}" for k in range(j)])))
            out.append(Statement("check", self._g(j, j), f"gtol{j}"))
            for i in range(j + 1, m):
                num = " - ".join([self._g(i, j)] + [f"{self._g(i, k)}*g{j}_{k}"
                                                     for k in range(j)])
                out.append(Statement("set", self._g(i, j), f"({num})/{self._g(j, j)}"
                                     if j else f"{num}/{self._g(j, j)}"))
        out += [Statement("set", self._g(j, j), f"1.0/{self._g(j, j)}") for j in range(m)]
        return out

    # ------------------------------------------------------------------- solve
    def solve(self, b=lambda p: f"b[{p}]", c=lambda r: f"c[{r}]",
              lam=lambda r: f"lam[{r}]", arrays=None) -> list[Statement]:
        """``lam = -G^{-1}(c + W^T D^{-1} L^{-1} P b)`` and ``b <- M^{-1}(b + J^T lam)`` in place.

        ``b``, ``c``, ``lam``: the text of entry ``p`` (``r``) of each; ``arrays``: the names
        of the factors ``{"M", "ID", "W", "V", "G"}`` where they are called otherwise.
        """
        name = {"M": "M", "ID": "ID", "W": "W", "V": "V", "G": "G", **(arrays or {})}
        return (self._forward(b, name) + self._multipliers(b, c, lam, name)
                + self._backward(b, lam, name))

    def _g_as(self, name, r, s):
        return self._g(r, s).replace("G[", f"{name['G']}[", 1)

    def _forward(self, b, name) -> list[Statement]:
        """``b <- D^{-1} L^{-1} P b``."""
        return self.tree.forward(b, name)

    def _multipliers(self, b, c, lam, name) -> list[Statement]:
        """``lam = -G^{-1}(c + W^T b)`` with ``G``'s factors."""
        out: list[Statement] = []
        for r in range(self.m):
            terms = [f"{self._w(name['W'], r, p)}*{b(p)}" for p in self.support[r]]
            out.append(Statement("set", lam(r), " - ".join([f"-{c(r)}"] + terms)))
        g = partial(self._g_as, name)
        for i in range(1, self.m):
            out.append(Statement("set", lam(i), " - ".join(
                [lam(i)] + [f"{g(i, k)}*{lam(k)}" for k in range(i)])))
        out += [Statement("set", lam(i), f"{lam(i)}*{g(i, i)}") for i in range(self.m)]
        for i in reversed(range(self.m - 1)):
            out.append(Statement("set", lam(i), " - ".join(
                [lam(i)] + [f"{g(k, i)}*{lam(k)}" for k in range(i + 1, self.m)])))
        return out

    def _backward(self, b, lam, name) -> list[Statement]:
        """``b <- P^T L^{-T}(b + V lam)``."""
        out: list[Statement] = []
        for p in self.order:
            terms = [f"{self._w(name['V'], r, p)}*{lam(r)}" for r in range(self.m)
                     if p in set(self.support[r])]
            if terms:
                out.append(Statement("set", b(p), " + ".join([b(p)] + terms)))
        return out + self.tree.backward(b, name)

    def columns_c(self, stride: int, arrays: dict) -> list[str]:
        """C lines that solve ``stride`` columns at once (row-major ``DT``: ``n x stride``,
        ``DC`` and ``DL``: ``m x stride``): :meth:`solve` as vector loops
        (:func:`~mbgen.codegen.tree_solve.vector_lines`; ``stride`` a multiple of
        :data:`LANES`); per column the operations of :meth:`solve` in its order."""
        program = self.solve(b=lambda p: f"DT[{p * stride} + j]",
                             c=lambda r: f"DC[{r * stride} + j]",
                             lam=lambda r: f"DL[{r * stride} + j]", arrays=arrays)
        return vector_lines(program, stride, arrays.values())

    def locals(self) -> int:
        """Doubles the factor declares (``let``): its stack beyond the arrays."""
        return sum(1 for s in self.factor_mass() + self.factor_delassus() if s.kind == "let")


def contact_solver(equations) -> ContactSolver:
    """The :class:`ContactSolver` of equations with contacts: ``M``'s and ``J``'s structural
    nonzeros."""
    M, J = equations.mass_matrix, equations.contacts.jacobian
    n = M.rows
    pattern = frozenset((i, j) for i in range(n) for j in range(i) if M[i, j] != 0)
    rows = tuple(tuple(i for i in range(n) if J[r, i] != 0) for r in range(J.rows))
    return ContactSolver(n, J.rows, pattern, rows)


__all__ = ["ContactSolver", "LANES", "contact_solver", "elimination_order", "padded"]
