r"""A chain's pair products (:mod:`mbgen.symbolic.pairs`) as loops in the generated code.

The ``jacobian`` of equations that carry :class:`~mbgen.symbolic.pairs.ChainPairs` stores
each body's vectors in two local arrays, component-major so that one component of every
body is contiguous (``name[row * n + body]``):

- ``PM`` (before the solve; ``12 n``): ``J`` (rows 0–5) and ``Fa`` (6–11), which the mass
  matrix's pairs read;
- ``PP`` (after it; ``30 n``): ``Aq`` (0–5), ``Vq`` (6–8), ``Av`` (9–14), ``T`` (15–17),
  ``Fq`` (18–23), ``Fv`` (24–29).

Two loop nests then compute every pair ``a < d`` (chain positions):

- the products whose row is the descendant's (``M``'s entry and ``R``'s two in row
  ``u_d``): ``d`` outer, the ancestors ``a < d`` inner;
- those whose row is the ancestor's (``R``'s two in row ``u_a``): ``a`` outer, the
  descendants ``d > a`` inner;

so that in the C, whose Jacobian's rows are row-major in the output
(:func:`~mbgen.codegen.targets.model._columns_in_place`), the inner loop stores
contiguously and gcc vectorises it.  The outer body's components are read into constants
first.  Each entry is the same sum in the same order in C and in Python (products of the
ancestor's component by the descendant's, summed left to right, negated last): the two agree
bit for bit.  The symbolic entries are left out of the kernel, so CSE never sees them.

Measured (32 bodies' worth of the five products with random data, module's flags, min of
15 x 2,000 calls): written out as the straight-line code the generator emitted, 6.6 µs and
23 s of gcc; as these loops, 2.0 µs, the same bits.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..abi import Output
from ..symbolic.equations import Equations
from ..symbolic.pairs import PRODUCTS, ChainPairs, Product
from .outputs import Block, Spec

#: Fewest speeds for the loops.  Spatial arm, ``jacobian``, module's flags, paired C loops,
#: the columns solved over the tree in the output's rows, written out / loops: 7 links
#: 1,077–1,079 / 1,104–1,107 ns, 8 1,337–1,359 / 1,359–1,363, 10 2,114–2,117 / 2,036–2,040, 12
#: 2,728–2,758 / 2,591–2,604; 16 4,566–4,576 / 3,715–3,728 and 32 17.2–18.0 / 13.3–13.4 µs
#: (gcc 10.5 / 5.5 and 28.1 / 19.8 s).
LOOPS_MIN = 10
#: Where each vector lives: name -> (array, first row).
LOCATION = {"J": ("PM", 0), "Fa": ("PM", 6), "Aq": ("PP", 0), "Vq": ("PP", 6),
            "Av": ("PP", 9), "T": ("PP", 15), "Fq": ("PP", 18), "Fv": ("PP", 24)}
#: The arrays' rows: ``PM`` before the solve, ``PP`` after it.
ROWS = {"PM": 12, "PP": 30}


def blocks(pairs: ChainPairs) -> tuple[Block, Block]:
    """``(PM, PP)``: the assignments of every body's vectors (the module docstring)."""
    n = pairs.n
    entries: dict = {"PM": [], "PP": []}
    for name, (array, first) in LOCATION.items():
        for body in range(n):
            for c, e in enumerate(pairs.vector(name, body)):
                entries[array].append(((first + c) * n + body, e))
    return tuple(Block(a, ROWS[a] * n, tuple(sorted(entries[a], key=lambda t: t[0])))
                 for a in ("PM", "PP"))


def with_pairs(eq: Equations, s: Spec) -> Spec:
    """``s`` with the pair products of ``eq``'s chain in loops: a ``jacobian`` or
    ``tangent_jacobian`` that solves columns with the analytic partials
    (:func:`mbgen.codegen.outputs.spec`) loses their entries of ``M`` and ``DT`` and gains
    the blocks ``PM`` and ``PP``; any other ``s`` is returned as it is, and so is a model
    under :data:`LOOPS_MIN` speeds."""
    if eq.pairs is None or not s.columns or eq.layout.n_u < LOOPS_MIN or \
            eq.contacts is not None or eq.constraints is not None:
        return s
    pairs = _in_columns(eq, s.output)
    if pairs is None:
        return s
    m_slots, r_slots = positions(pairs, s.columns - eq.layout.n_u, eq.layout.n_u)
    pm, pp = blocks(pairs)
    return replace(s, pre=_without(s.pre, "M", m_slots) + (pm,),
                   post=_without(s.post, "DT", r_slots) + (pp,), pairs=pairs)


def _without(bs: tuple[Block, ...], name: str, slots: set) -> tuple[Block, ...]:
    """``bs`` with block ``name``'s entries at ``slots`` left out."""
    return tuple(replace(b, entries=tuple((i, e) for i, e in b.entries if i not in slots))
                 if b.name == name else b for b in bs)


def _in_columns(eq: Equations, output: Output) -> ChainPairs | None:
    """The chain's pairs in ``output``'s columns: the ``jacobian``'s (``q``, then ``u``), or
    the ``tangent_jacobian``'s (``delta``, then ``u``) where each chain coordinate's rate is
    its speed and no other rate reads it (``G``'s column a unit one: its ``delta`` column is
    the coordinate's); else None."""
    P, L = eq.pairs, eq.layout
    if output is Output.JACOBIAN:
        return P
    if output is not Output.TANGENT_JACOBIAN or eq.residual_tangent is not None:
        return None
    chain = {P.q0 + i: L.speeds[P.u0 + i] for i in range(P.n)}
    speeds = set(chain.values())
    for j, rate in enumerate(eq.kinematics):
        if rate != chain[j] if j in chain else rate.free_symbols & speeds:
            return None
    return replace(P, q0=P.u0)


def lines(s: Spec, n_u: int, stage: str, target: Target, language: str) -> list[str]:
    """:func:`loops` of a spec's pairs (none without), its ``R``'s speed columns last."""
    return loops(s.pairs, s.columns - n_u, stage, target, language) if s.pairs else []


def dt_slots(s: Spec, n_u: int) -> set:
    """The slots of ``DT`` the spec's pair loops write (none without)."""
    return positions(s.pairs, s.columns - n_u, n_u)[1] if s.pairs else set()


@dataclass(frozen=True)
class Target:
    """How a target writes the entries: ``(array, row stride, column stride, offset)`` of
    ``M`` and of ``R`` (the Jacobian's right-hand sides): entry ``(i, j)`` at ``offset +
    i * row + j * col``."""

    M: tuple[str, int, int, int]
    R: tuple[str, int, int, int]


def columns_target(n_u: int) -> Target:
    """``M`` row-major, ``R`` into ``DT`` (column-major ``columns x n_u``)."""
    return Target(("M", n_u, 1, 0), ("DT", 1, n_u, 0))


def _index(where: tuple[str, int, int, int], row: tuple, col: tuple, var: dict) -> str:
    """The text of the index of ``(row, col)``, each ``(base, loop variable)``."""
    _, rs, cs, off = where
    const = off + row[0] * rs + col[0] * cs
    terms = [f"{var[row[1]]}*{rs}" if rs != 1 else var[row[1]],
             f"{var[col[1]]}*{cs}" if cs != 1 else var[col[1]]]
    return " + ".join(([str(const)] if const else []) + terms)


@dataclass(frozen=True)
class Nest:
    """One loop nest, as plain text: ``outer`` runs over ``outer_range``, ``inner`` over
    ``inner_range`` (each ``(first, end)``, the end excluded); ``loads`` are the outer body's
    components read first (``(name, text)``), ``body`` the assignments."""

    outer: str
    outer_range: tuple[str, str]
    inner: str
    inner_range: tuple[str, str]
    loads: tuple[tuple[str, str], ...]
    body: tuple[str, ...]


def _nests(pairs: ChainPairs, n_q: int, stage: str, target: Target) -> list[Nest]:
    """The nests of ``stage`` (``"pre"``: ``M``'s products; ``"post"``: ``R``'s): the
    products in the descendant's row with ``d`` outer, those in the ancestor's with ``a``."""
    n, var = pairs.n, {"a": "_a", "d": "_d"}
    mine = [p for p in PRODUCTS if (p.target == "M") == (stage == "pre")]
    out = []
    for outer in ("d", "a"):
        products = [p for p in mine if p.row[0] == outer]
        if not products:
            continue
        sizes: dict = {}
        for p in products:
            for av, dv, k in p.dots:
                name = av if outer == "a" else dv
                sizes[name] = max(k, sizes.get(name, 0))
        hoisted = {(name, c): f"_{name}{c}" for name in sorted(sizes) for c in range(sizes[name])}
        body = []
        for p in products:
            where = getattr(target, p.target)
            row = (pairs.index(p.row[1], 0, n_q), p.row[0])
            col = (pairs.index(p.col[1], 0, n_q), p.col[0])
            body.append(f"{where[0]}[{_index(where, row, col, var)}] = "
                        f"{_value(p, n, var, hoisted)}")
        o = var[outer]
        out.append(Nest(o, ("1", str(n)) if outer == "d" else ("0", str(n - 1)),
                        var["a" if outer == "d" else "d"],
                        ("0", o) if outer == "d" else (f"{o} + 1", str(n)),
                        tuple((h, f"{_at(name, c, n)}{o}]") for (name, c), h in hoisted.items()),
                        tuple(body)))
    return out


def _value(p: Product, n: int, var: dict, hoisted: dict) -> str:
    """``p``'s sum at the pair ``(a, d)``: the ancestor's component times the descendant's,
    left to right, negated last."""
    terms = []
    for av, dv, k in p.dots:
        for c in range(k):
            x = hoisted.get((av, c)) or f"{_at(av, c, n)}{var['a']}]"
            y = hoisted.get((dv, c)) or f"{_at(dv, c, n)}{var['d']}]"
            terms.append(f"{x}*{y}")
    total = " + ".join(terms)
    return f"-({total})" if p.sign < 0 else total


def _at(name: str, c: int, n: int) -> str:
    array, first = LOCATION[name]
    return f"{array}[{(first + c) * n} + " if first + c else f"{array}["


def _c(nests: list[Nest]) -> list[str]:
    out = ["{   /* the chain's pair products (mbgen/codegen/pairs.py) */", "    int _a, _d;"]
    for t in nests:
        (o0, o1), (i0, i1) = t.outer_range, t.inner_range
        out += [f"    for ({t.outer} = {o0}; {t.outer} < {o1}; ++{t.outer}) {{",
                "        const double " + ", ".join(f"{h} = {e}" for h, e in t.loads) + ";",
                f"        for ({t.inner} = {i0}; {t.inner} < {i1}; ++{t.inner}) {{"]
        out += [f"            {line};" for line in t.body] + ["        }", "    }"]
    return out + ["}"]


def _python(nests: list[Nest]) -> list[str]:
    def span(first, end):
        return end if first == "0" else f"{first}, {end}"
    out = []
    for t in nests:
        out.append(f"for {t.outer} in range({span(*t.outer_range)}):")
        out += [f"    {h} = {e}" for h, e in t.loads]
        out.append(f"    for {t.inner} in range({span(*t.inner_range)}):")
        out += [f"        {line}" for line in t.body]
    return out


#: How each language prints the nests (C also for C++; JAX as Python).
PRINTERS = {"c": _c, "python": _python}


def loops(pairs: ChainPairs, n_q: int, stage: str, target: Target, language: str) -> list[str]:
    """The lines of ``stage``'s loop nests in ``language`` (a :data:`PRINTERS` key); ``n_q``:
    the columns of ``R`` before its speeds' (``R``'s ``qd`` columns start there)."""
    return PRINTERS[language](_nests(pairs, n_q, stage, target))


def positions(pairs: ChainPairs, n_q: int, n_u: int) -> tuple[set, set]:
    """``(M's slots, DT's slots)``: the flat indices the loops write (``M`` row-major,
    ``DT`` column-major ``columns x n_u``), left out of the blocks."""
    at = pairs.positions(n_q)
    return ({i * n_u + j for i, j in at["M"]}, {j * n_u + i for i, j in at["R"]})


__all__ = ["LOCATION", "LOOPS_MIN", "PRINTERS", "ROWS", "Nest", "Target", "blocks",
           "columns_target", "dt_slots", "lines", "loops", "positions", "with_pairs"]
