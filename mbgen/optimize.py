r"""Optimisation: ``Equations + outputs -> Kernel``.

Only the outputs a scene asks for are kept.  Every expression those outputs
need goes through **one** common-subexpression-elimination pass; each generated
function then takes the temporaries its own expressions depend on.  Operation
counts before (expressions printed as trees) and after (temporaries plus
reduced outputs) are recorded per function.

Outputs
-------
``RHS``
    ``dxdt = [G; M^{-1} F]`` of length ``n_x``.  ``M`` is filled in its lower
    triangle only and solved numerically (Cholesky) in the generated code.
``MASS_MATRIX``
    ``M`` (``n_u x n_u``, row-major), each symmetric pair computed once.
``FORCING``
    ``F`` (``n_u``).
``ENERGY``
    ``[T, V]``: kinetic energy and the potential of gravity and springs.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Iterable

import sympy as sm

from .equations import Equations
from .errors import ModelError
from .symbolic import count_ops_dag, count_ops_tree, free_symbols


class Output(str, Enum):
    """What a generated model computes."""

    RHS = "rhs"
    MASS_MATRIX = "mass_matrix"
    FORCING = "forcing"
    ENERGY = "energy"

    @classmethod
    def parse(cls, values: Iterable) -> tuple["Output", ...]:
        """Outputs from enum members or their names, in canonical (declaration) order."""
        wanted = set()
        for v in values:
            try:
                wanted.add(v if isinstance(v, cls) else cls(str(v).lower()))
            except ValueError:
                raise ModelError(f"unknown output {v!r}; choose from "
                                 f"{', '.join(o.value for o in cls)}") from None
        return tuple(o for o in cls if o in wanted)


class CseBackend(str, Enum):
    """Which library performs common-subexpression elimination."""

    SYMENGINE = "symengine"
    SYMPY = "sympy"


@dataclass(frozen=True)
class Block:
    """Assignments to one array: ``name[index] = expr`` for each entry.

    ``mirror`` lists ``(dst, src)`` index pairs copied after the block is
    computed (the upper triangle of a symmetric matrix).
    """

    name: str
    size: int
    entries: tuple[tuple[int, sm.Expr], ...]
    mirror: tuple[tuple[int, int], ...] = ()
    labels: tuple[str, ...] = ()


@dataclass(frozen=True)
class KernelFunction:
    """One generated function.

    ``blocks`` are local arrays (``M``, ``F``) or the output array itself;
    ``solve`` means: after the blocks, solve ``M y = F`` (Cholesky, lower
    triangle of ``M``) and write ``y`` to ``out[n_q:]``.
    """

    output: Output
    out_name: str
    out_size: int
    out_labels: tuple[str, ...]
    temporaries: tuple[tuple[sm.Symbol, sm.Expr], ...]
    blocks: tuple[Block, ...]
    local_blocks: tuple[str, ...]
    solve: bool
    uses: frozenset            # subset of {"t", "x", "p", "r"}
    symbols_used: tuple        # layout symbols the function reads
    ops_before: int
    ops_after: int
    doc: str


@dataclass(frozen=True)
class Kernel:
    """Optimised, ready-to-print functions of one model."""

    equations: Equations
    functions: tuple[KernelFunction, ...]
    cse_backend: CseBackend
    temp_prefix: str

    @property
    def layout(self):
        return self.equations.layout

    @property
    def ops_before(self) -> int:
        return sum(f.ops_before for f in self.functions)

    @property
    def ops_after(self) -> int:
        return sum(f.ops_after for f in self.functions)

    def function(self, output: Output) -> KernelFunction:
        for f in self.functions:
            if f.output is output:
                return f
        raise KeyError(output)


def _temp_prefix(equations: Equations) -> str:
    names = set(equations.layout.identifiers.values())
    for prefix in ("v", "w", "tmp", "cse"):
        if not any(n.startswith(prefix) and n[len(prefix):].isdigit() for n in names):
            return prefix
    return "mbgen_tmp"  # pragma: no cover


def _blocks(equations: Equations, output: Output):
    """``(out name, out size, out labels, blocks, local blocks, solve, doc)`` of an output."""
    L = equations.layout
    n = L.n_u
    M = equations.mass_matrix
    lower = tuple((i * n + j, M[i, j]) for i in range(n) for j in range(i + 1))
    mirror = tuple((j * n + i, i * n + j) for i in range(n) for j in range(i))
    m_labels = tuple(f"M[{L.speeds[i]},{L.speeds[j]}]" for i in range(n) for j in range(n))
    f_labels = tuple(f"F[{s}]" for s in L.speeds)
    if output is Output.RHS:
        g = Block("out", L.n_x, tuple((i, e) for i, e in enumerate(equations.kinematics)))
        return ("dxdt", L.n_x, L.derivative_names,
                (g, Block("M", n * n, lower, (), m_labels),
                 Block("F", n, tuple(enumerate(equations.forcing)), (), f_labels)),
                ("M", "F"), True,
                "First-order right-hand side dxdt = [G(q,u,t); M^-1 F]; M solved by Cholesky.")
    if output is Output.MASS_MATRIX:
        return ("M", n * n, m_labels, (Block("out", n * n, lower, mirror),), (), False,
                "Mass matrix M(q,t), row-major n_u x n_u, symmetric.")
    if output is Output.FORCING:
        return ("F", n, f_labels, (Block("out", n, tuple(enumerate(equations.forcing))),), (),
                False, "Forcing F(q,u,r,t) of M u' = F.")
    if output is Output.ENERGY:
        if equations.kinetic_energy is None:
            raise ModelError(f"model {equations.name!r} has no energy expressions; "
                             f"leave Output.ENERGY out")
        pot = equations.potential_energy if equations.potential_energy is not None else sm.S.Zero
        return ("energy", 2, ("T", "V"),
                (Block("out", 2, ((0, equations.kinetic_energy), (1, pot))),), (), False,
                "Kinetic energy T and potential energy V (gravity, springs).")
    raise ModelError(f"output {output} is not supported")  # pragma: no cover


def _cse(exprs: list, prefix: str, backend: CseBackend):
    """One CSE pass: ``(replacements, reduced)`` with temporaries ``prefix0, prefix1, ...``."""
    symbols = sm.numbered_symbols(prefix)
    if backend is CseBackend.SYMENGINE:
        import symengine as se

        reps, reduced = se.cse([se.sympify(e) for e in exprs])
        sub: dict = {}
        out_reps = []
        for old, expr in reps:
            new = next(symbols)
            sub[sm.sympify(old)] = new
            out_reps.append((new, sm.sympify(expr).xreplace(sub)))
        return _hoist_power_bases(out_reps, [sm.sympify(e).xreplace(sub) for e in reduced],
                                  symbols)
    reps, reduced = sm.cse(exprs, symbols=symbols, order="none")
    return _hoist_power_bases(list(reps), list(reduced), symbols)


def _hoist_power_bases(reps, reduced, symbols):
    """Give every compound base of a small integer power its own temporary.

    Powers print as repeated multiplication (``b*b*b``); a compound ``b``
    (``cos(q1)``, ``q1 + q2``) would then be evaluated once per factor.  The new
    temporary is placed right after the last temporary its base depends on.
    """
    from .printing import MAX_UNROLLED_POWER
    from .symbolic import walk_unique

    bases = []
    seen = set()
    for node in walk_unique([e for _, e in reps] + list(reduced)):
        if (isinstance(node, sm.Pow) and node.exp.is_Integer and node.base.args
                and 2 <= abs(int(node.exp)) <= MAX_UNROLLED_POWER and node.base not in seen):
            seen.add(node.base)
            bases.append(node.base)
    if not bases:
        return reps, reduced
    bases.reverse()  # nested bases (descendants) before the bases that contain them
    position = {s: i for i, (s, _) in enumerate(reps)}
    new_of = {b: next(symbols) for b in bases}
    sub = {sm.Pow(b, k): sm.Pow(new_of[b], k) for b in bases
           for k in range(-MAX_UNROLLED_POWER, MAX_UNROLLED_POWER + 1) if abs(k) >= 2}
    inserts: dict[int, list] = {}
    for base in bases:
        deps = [position[s] for s in base.free_symbols if s in position]
        inserts.setdefault(max(deps) if deps else -1, []).append((new_of[base], base.xreplace(sub)))
    out = list(inserts.get(-1, []))
    for i, (s, e) in enumerate(reps):
        out.append((s, e.xreplace(sub)))
        out.extend(inserts.get(i, []))
    return out, [e.xreplace(sub) for e in reduced]


def optimize(equations: Equations, outputs=(Output.RHS,),
             cse_backend: CseBackend = CseBackend.SYMENGINE) -> Kernel:
    """Select ``outputs`` of ``equations`` and eliminate common subexpressions once.

    Parameters
    ----------
    equations : Equations
    outputs : iterable of Output (or names)
        What to emit; default ``(Output.RHS,)``.
    cse_backend : CseBackend
        ``SYMENGINE`` (default; faster and finds more sharing) or ``SYMPY``.

    Returns
    -------
    Kernel
    """
    outputs = Output.parse(outputs)
    if not outputs:
        raise ModelError("no outputs requested; ask for at least Output.RHS")
    cse_backend = CseBackend(cse_backend)
    prefix = _temp_prefix(equations)
    specs = [(o, *_blocks(equations, o)) for o in outputs]

    # one CSE pass over every distinct expression of every output
    distinct: dict = {}
    for spec in specs:
        for block in spec[4]:
            for _, e in block.entries:
                if e.args and e not in distinct:
                    distinct[e] = len(distinct)
    exprs = list(distinct)
    reps, reduced = _cse(exprs, prefix, cse_backend) if exprs else ([], [])
    reduced_of = {e: reduced[i] for e, i in distinct.items()}
    rep_expr = dict(reps)
    order = {s: i for i, (s, _) in enumerate(reps)}

    functions = []
    layout_syms = equations.layout.symbols()
    for output, out_name, out_size, labels, blocks, local, solve, doc in specs:
        new_blocks = tuple(
            Block(b.name, b.size, tuple((i, reduced_of.get(e, e)) for i, e in b.entries),
                  b.mirror, b.labels) for b in blocks)
        roots = [e for b in new_blocks for _, e in b.entries]
        needed = _closure(roots, rep_expr)
        temps = tuple(sorted(((s, rep_expr[s]) for s in needed), key=lambda se: order[se[0]]))
        used = free_symbols(roots + [e for _, e in temps]) & layout_syms
        L = equations.layout
        symbols_used = tuple(s for s in L.states + L.parameters + L.inputs + (L.time,)
                             if s in used)
        uses = frozenset(k for k, group in (("t", {L.time}), ("x", set(L.states)),
                                            ("p", set(L.parameters)), ("r", set(L.inputs)))
                         if used & group)
        before = count_ops_tree([e for b in blocks for _, e in b.entries])
        after = count_ops_dag([e for _, e in temps]) + sum(count_ops_dag([e]) for e in roots)
        functions.append(KernelFunction(output, out_name, out_size, labels, temps, new_blocks,
                                        local, solve, uses, symbols_used, before, after, doc))
    return Kernel(equations, tuple(functions), cse_backend, prefix)


def _closure(roots, rep_expr) -> set:
    """Temporaries reachable from ``roots`` through ``rep_expr``."""
    needed: set = set()
    stack = list(free_symbols(roots) & rep_expr.keys())
    while stack:
        s = stack.pop()
        if s in needed:
            continue
        needed.add(s)
        stack.extend(free_symbols([rep_expr[s]]) & rep_expr.keys() - needed)
    return needed
