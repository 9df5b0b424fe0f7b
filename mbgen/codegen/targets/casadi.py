r"""The ``casadi`` target: the model's C behind CasADi's external-function interface.

``<prefix>_casadi.c`` (``templates/casadi/casadi.c.j2``) wraps a generated function
``<prefix>_<output>`` as a CasADi function ``<name>`` (default ``<prefix>_<output>_casadi``)
with the symbols ``casadi.external(name, library)`` looks up::

    int        <name>(const double **arg, double **res, casadi_int *iw, double *w, int mem)
    casadi_int <name>_n_in(void), <name>_n_out(void)
    const char *<name>_name_in(casadi_int i), *<name>_name_out(casadi_int i)
    const casadi_int *<name>_sparsity_in(casadi_int i), *<name>_sparsity_out(casadi_int i)
    int        <name>_work(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw,
                           casadi_int *sz_w)

Inputs ``t`` (1), ``x`` (n_x), ``p`` (n_p) and ``r`` (n_r), as in the runtime, always four
(``p`` or ``r`` may be 0 x 1); a ``NULL`` input is zeros, a ``NULL`` output is not
computed.  For the right-hand side, ``jac_<name>`` is CasADi's Jacobian of it
(``Function.jacobian()``'s signature: inputs ``t, x, p, r, out_<out>``, the last without
nonzeros; outputs ``jac_<out>_t``, ``_x``, ``_p``, ``_r``), filled by mbgen's analytic
``time_derivative``, ``jacobian``, ``parameter_jacobian`` and ``input_jacobian``: CasADi takes
its forward and reverse derivatives from it and never differentiates numerically.  A block
whose output was not generated is refused (:meth:`CasadiTarget.unavailable`), except
``df/dt`` of a model that does not depend on ``t`` (structurally zero).

Sparsity: CasADi stores a matrix by columns (compressed column storage: ``[rows, cols,
colind[cols + 1], row[nnz]]``); mbgen writes row-major arrays, so every output is a
:class:`Piece` whose ``nonzeros`` list, in CasADi's order, the index each value is read from
in the C output (copied through the work vector ``w``; a dense vector is written in place).
With the kernel at hand the pattern is the output's true one (:func:`pattern`): the entries
its expressions leave structurally zero, and for the rows ``M^{-1} D`` of a sensitivity the
columns of ``D`` that reach a row through ``M``'s coupling (its connected components);
without (a compiled model) every block is dense.

A parameter Jacobian has a column per parameter that the motion uses (``n_pd``): it is
placed into the columns of those parameters in ``p`` by name (its labels ``d(x')/d(name)``).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..._version import __version__
from ...abi import OUTPUT_INFO, Output
from ...symbolic.availability import time_symbols
from ..pairs import dt_slots
from ..templating import environment
from .base import Job, Target

#: The derivative of the right-hand side that fills each block of ``jac_<name>``, by input.
DERIVATIVES = (("t", Output.TIME_DERIVATIVE), ("x", Output.JACOBIAN),
               ("p", Output.PARAMETER_JACOBIAN), ("r", Output.INPUT_JACOBIAN))
#: The inputs of every CasADi function, as in the runtime.
INPUTS = ("t", "x", "p", "r")


@dataclass(frozen=True)
class Piece:
    """One output of a CasADi function, and where its values come from.

    Attributes
    ----------
    rows, cols : int
        Its shape in CasADi.
    nonzeros : tuple of (int, int, int)
        ``(row, col, index in the C output)`` of each structural nonzero, in CasADi's
        column-major order.
    function : str
        The C function that computes it ("" for a block without nonzeros).
    args : tuple of str
        That function's arguments (``t, x`` and ``p``, ``r`` where it has them).
    size : int
        Doubles that function writes.
    """

    rows: int
    cols: int
    nonzeros: tuple = ()
    function: str = ""
    args: tuple = ()
    size: int = 0

    @property
    def sparsity(self) -> tuple[int, ...]:
        """CasADi's compressed column storage of the pattern."""
        colind = [0] * (self.cols + 1)
        for _, c, _ in self.nonzeros:
            colind[c + 1] += 1
        for c in range(self.cols):
            colind[c + 1] += colind[c]
        return (self.rows, self.cols, *colind, *(r for r, _, _ in self.nonzeros))

    @property
    def in_place(self) -> bool:
        """The C output is the nonzeros themselves (a dense vector): written in place."""
        return bool(self.function) and len(self.nonzeros) == self.size and all(
            k == i for k, (_, _, i) in enumerate(self.nonzeros))

    @property
    def gather(self) -> list[int]:
        return [i for _, _, i in self.nonzeros]


def piece(function: str, args, shape: tuple, entries, cols: int | None = None,
          column_of=None) -> Piece:
    """A :class:`Piece` of the C output of ``shape`` (row-major) with the nonzero ``entries``
    ``(row, col)``; ``column_of`` maps its columns to the CasADi block's (``cols`` wide)."""
    n_rows = shape[0]
    n_cols = shape[1] if len(shape) == 2 else 1
    column_of = column_of or list(range(n_cols))
    cols = n_cols if cols is None else cols
    nz = sorted(((r, column_of[c], r * n_cols + c) for r, c in entries),
                key=lambda e: (e[1], e[0]))
    if not nz:          # structurally zero (df/dt of a model without t): nothing to call
        return Piece(n_rows, cols)
    return Piece(n_rows, cols, tuple(nz), function, tuple(args), n_rows * n_cols)


def pattern(kernel, fn) -> frozenset:
    """``(row, col)`` of the structural nonzeros of a kernel function's output (row-major
    ``spec.out_shape``; a vector's column is 0).  See the module docstring."""
    s = fn.spec
    L = kernel.layout
    n_cols = s.out_shape[1] if len(s.out_shape) == 2 else 1
    flat = set()
    blocks = {b.name: b for b in fn.pre + fn.post if b.name != "out"}
    for b in fn.pre + fn.post:
        if b.name == "out":
            flat |= {i for i, e in b.entries if e != 0}
            flat |= {d for d, src in b.mirror if src in flat}
    nq, nu = L.n_q, L.n_u
    if s.implicit or (s.solve and kernel.equations.constraints is not None):
        rows = range(nq, s.out_shape[0])
        flat |= {r * n_cols + c for r in rows for c in range(n_cols)}
    elif s.solve or s.columns:
        group = _components(nu, kernel.mass_pattern)
        if s.output is Output.RHS:
            live = {k for k, e in blocks["F"].entries if e != 0}
            flat |= {nq + i for i in range(nu) if live & group[i]}
        if s.columns:
            live = {(k // nu, k % nu) for k, e in blocks["DT"].entries if e != 0}
            live |= {(k // nu, k % nu) for k in dt_slots(s, nu)}   # the pair loops' entries
            flat |= {(nq + i) * n_cols + j for i in range(nu) for j in range(s.columns)
                     if any((j, k) in live for k in group[i])}
    return frozenset((i // n_cols, i % n_cols) for i in flat)


def _components(n: int, lower: frozenset) -> list[set]:
    """The speeds each speed is coupled to through ``M`` (its connected component)."""
    parent = list(range(n))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in lower:
        parent[root(i)] = root(j)
    groups: dict[int, set] = {}
    for i in range(n):
        groups.setdefault(root(i), set()).add(i)
    return [groups[root(i)] for i in range(n)]


def column_names(labels, n_cols: int) -> list[str]:
    """The variables of a sensitivity's columns, from its first row's labels
    ``d(<state>')/d(<variable>)``."""
    return [label[label.rindex("/d(") + 3:-1] for label in labels[:n_cols]]


@dataclass(frozen=True)
class External:
    """What one CasADi function is: its name, inputs and outputs (:class:`Piece`)."""

    name: str
    inputs: tuple        # (name, rows) of each input
    outputs: tuple       # (name, Piece) of each output

    @property
    def work(self) -> int:
        """Doubles of ``w``: the largest C output copied through it."""
        return max((p.size for _, p in self.outputs if p.function and not p.in_place),
                   default=0)


def externals(rendered, output: Output, name: str, kernel=None, sparse: bool = True,
              jacobian: bool = True) -> tuple[External, ...]:
    """The CasADi function ``name`` of ``output`` and, for the right-hand side with
    ``jacobian``, ``jac_<name>``.  ``kernel``: the pattern's source (None, or ``sparse``
    False: dense blocks)."""
    L = rendered.layout
    infos = {Output(f.output): f for f in rendered.functions}
    fns = {f.output: f for f in kernel.functions} if kernel is not None else {}
    sizes = {"t": 1, "x": L.n_x, "p": L.n_p, "r": L.n_r}
    inputs = tuple((a, sizes[a]) for a in INPUTS)

    def entries(o, shape):
        if sparse and o in fns:
            return sorted(pattern(kernel, fns[o]))
        return [(r, c) for r in range(shape[0]) for c in range(shape[1] if len(shape) == 2
                                                                else 1)]

    info = infos[output]
    shape = tuple(info.out_shape)
    main = External(name, inputs, ((OUTPUT_INFO[output].array,
                                    piece(info.c_name, info.args, shape, entries(output, shape))),))
    if not (jacobian and output is Output.RHS):
        return (main,)
    out = OUTPUT_INFO[output].array
    blocks = []
    for arg, o in DERIVATIVES:
        label = f"jac_{out}_{arg}"
        d = infos.get(o)
        if d is None or not sizes[arg]:
            blocks.append((label, Piece(L.n_x, sizes[arg])))
            continue
        dshape = tuple(d.out_shape)
        column_of = None
        if arg in ("p", "r"):
            names = L.parameter_names if arg == "p" else L.input_names
            column_of = [names.index(v) for v in column_names(d.out_labels, dshape[1])]
        blocks.append((label, piece(d.c_name, d.args, dshape, entries(o, dshape), sizes[arg],
                                    column_of)))
    jac = External(f"jac_{name}", inputs + ((f"out_{out}", -L.n_x),), tuple(blocks))
    return main, jac


def missing_derivatives(layout, outputs, time_dependent: bool) -> list[str]:
    """The derivative outputs ``jac_<name>`` of the right-hand side needs and ``outputs``
    lack (``time_derivative`` only for a time-dependent model)."""
    have = set(Output.parse([o for o in outputs]))
    need = {"t": time_dependent, "x": True, "p": layout.n_p > 0, "r": layout.n_r > 0}
    return [o.value for arg, o in DERIVATIVES if need[arg] and o not in have]


def render_glue(rendered, functions: tuple[External, ...]) -> str:
    """The text of ``<prefix>_casadi.c`` for ``functions``."""
    L = rendered.layout
    views = []
    for f in functions:
        outs = [dict(index=k, name=n, sparsity=list(p.sparsity), nnz=len(p.nonzeros),
                     function=p.function, args=list(p.args), in_place=p.in_place,
                     gather=p.gather) for k, (n, p) in enumerate(f.outputs)]
        ins = [dict(name=n, sparsity=_input_sparsity(rows)) for n, rows in f.inputs]
        views.append(dict(name=f.name, inputs=ins, outputs=outs, work=f.work))
    return environment().get_template("casadi/casadi.c.j2").render(
        version=__version__, prefix=rendered.prefix, functions=views,
        zeros=max(1, L.n_x, L.n_p, L.n_r), n_p=L.n_p, n_r=L.n_r)


def _input_sparsity(rows: int) -> list[int]:
    """A dense column of ``rows``; ``-rows``: a column without nonzeros (``out_<name>``)."""
    if rows < 0:
        return [-rows, 1, 0, 0]
    return [rows, 1, 0, rows, *range(rows)]


def default_name(prefix: str, output: Output) -> str:
    """The CasADi function's name unless given: ``<prefix>_<output>_casadi`` (the model's own
    C function is ``<prefix>_<output>``)."""
    return f"{prefix}_{Output(output).value}_casadi"


def render_loader(prefix: str, name: str) -> str:
    """``<prefix>_casadi.py``: compiles the two C files once and loads ``name``."""
    return environment().get_template("casadi/loader.py.j2").render(
        version=__version__, prefix=prefix, name=name)


class CasadiTarget(Target):
    """``<prefix>_casadi.c`` and its loader ``<prefix>_casadi.py``, with the model's C."""

    name = "casadi"
    files = (("casadi.c.j2", "{prefix}_casadi.c"), ("loader.py.j2", "{prefix}_casadi.py"))
    needs = ("c",)

    def wanted(self, kernel, targets) -> bool:
        return False

    def unavailable(self, kernel) -> str | None:
        if Output.RHS not in kernel.outputs:
            return "the CasADi function wraps the right-hand side: add rhs to --outputs"
        L = kernel.layout
        missing = missing_derivatives(L, kernel.outputs,
                                      L.time in time_symbols(kernel.equations))
        if missing:
            return (f"its Jacobian (jac_<name>, CasADi's derivatives) needs the outputs "
                    f"{', '.join(missing)}: add them, e.g. --outputs "
                    f"{','.join(o.value for o in kernel.outputs)},"
                    f"{','.join(missing)}")
        return None

    def export(self, job: Job) -> dict[str, str]:
        R = job.rendered
        name = default_name(R.prefix, Output.RHS)
        functions = externals(R, Output.RHS, name, job.kernel)
        [(glue, _), (loader, _)] = [(w, t) for t, w in self.templates(R.prefix)]
        return {glue: render_glue(R, functions), loader: render_loader(R.prefix, name)}


#: The CasADi target.
CASADI = CasadiTarget()

__all__ = ["CASADI", "CasadiTarget", "Piece", "External", "externals", "pattern", "piece",
           "render_glue", "render_loader", "default_name", "missing_derivatives",
           "column_names", "DERIVATIVES", "INPUTS"]
