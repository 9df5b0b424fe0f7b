r"""What each generated output computes, as blocks of expressions.

Every function follows one pattern (the templates render it):

1. *pre* blocks: expressions of ``t, x, p, r`` written to the output array or to
   local arrays ``M`` (lower triangle) and ``F``;
2. if ``solve``: factor ``M = L D L^T`` (:mod:`mbgen.codegen.solver`) and overwrite ``F`` with the
   accelerations ``u' = M^{-1} F``;
3. *post* blocks: expressions that may also use those accelerations;
4. if ``columns``: solve ``M Y = D`` column by column and write ``Y`` below
   the kinematic rows of the output.

What each output is -- its C array, shape, description, what it needs of the
equations and what a sensitivity differentiates by -- is its row of
:data:`mbgen.abi.OUTPUT_INFO`.  Here each expression output has only its builder, a
row of :data:`BUILDERS` that returns its :class:`Spec`; a builder states the
generated comment (``Spec.doc``) only where it depends on the equations (the form,
the constraints, the point and joint names), else :func:`spec` writes the row's.
The integrators have no expressions of their own and pull in the outputs they call
(:func:`with_dependencies`).

The sensitivities :math:`\partial f/\partial v` of the first-order right-hand side
(``v`` is ``x``, ``p``, ``t`` or ``r``: the row's ``wrt``) share one builder,
:func:`_sensitivity`.  With :math:`R(v, a) = F - M a` and the accelerations ``a``
held fixed,

.. math::

    \frac{\partial u'}{\partial v} = M^{-1} \frac{\partial R}{\partial v}
    = M^{-1}\Big(\frac{\partial F}{\partial v} - \frac{\partial M}{\partial v} a\Big),

so ``M`` is factored once and :math:`\partial R/\partial v` is symbolic.

How to add an output
--------------------
1. ``mbgen/abi.py``: a member of :class:`~mbgen.abi.Output` (the function's name
   ``<prefix>_<value>``) and its :class:`~mbgen.abi.OutputInfo` row of ``OUTPUT_INFO``
   (array, shape, doc, needs, ``wrt`` for a ``df/dv``).  A need that is new:
   a :class:`~mbgen.abi.Need` member and its test in
   ``mbgen/symbolic/availability.py`` (``CONDITIONS``).
2. Here: its builder, a row of :data:`BUILDERS` (a ``df/dv`` reuses ``_sensitivity``).
3. ``mbgen/runtime/lambdified.py``: its row of ``REFERENCES``, how the reference
   computes it from the unoptimised equations.
4. ``mbgen/runtime/base.py``: its accessor line in :class:`~mbgen.runtime.base.ModelBase`
   (``<value> = _accessor(Output.<NAME>)``; the docstring comes from the row).
5. ``tests/codegen/test_outputs.py`` fails while an output misses a row in any of these
   tables, and prints the table of ``docs/modelling.md`` ("Outputs and their shapes")
   that the rows give; ``tests/verify/test_golden.py`` then shows what the generated
   code gained.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from enum import Enum

import sympy as sm

from ..abi import INTEGRATORS, OUTPUT_INFO, Output, OutputInfo
from ..errors import ModelError
from ..integrators import METHODS
from ..symbolic.availability import SENSITIVITIES, imported, imported_hint, require, time_symbols
from ..symbolic.equations import Equations, acceleration_symbols, lambda_symbols
from ..symbolic.graph import differentiate
from ..symbolic.pairs import ChainPairs
from ..symbolic.program import Program, derivatives
from .contacts import padded


def with_dependencies(outputs: Iterable[Output], equations: Equations) -> tuple[Output, ...]:
    """``outputs`` plus what they call: what each integrator ``needs`` (the RHS; an implicit
    one the Jacobian, and ``df/dt`` when the equations depend on ``t`` explicitly), and the
    projection onto configuration constraints after each step."""
    wanted = set(Output.parse(outputs))
    methods = [METHODS[o] for o in INTEGRATORS if o in wanted]
    for m in methods:
        wanted |= set(m.needs)
        if m.implicit and equations.layout.time in time_symbols(equations):
            wanted.add(Output.TIME_DERIVATIVE)
    c = equations.constraints
    if methods and c is not None and c.m_h:
        wanted |= {Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN}   # projection after each step
    return Output.parse(wanted)


def needs_jacobian(outputs: Iterable[Output]) -> bool:
    """Whether ``outputs`` include ``df/dx`` or its tangent-space form, asked for or called by
    an implicit integrator (what a derivation is asked for with ``derive(..., jacobian=True)``:
    both read its analytic ``residual_jacobian`` where it writes one)."""
    wanted = set(Output.parse(outputs))
    return bool({Output.JACOBIAN, Output.TANGENT_JACOBIAN} & wanted) or any(
        Output.JACOBIAN in METHODS[o].needs for o in INTEGRATORS if o in wanted)


class Form(str, Enum):
    """How the generated code gets the accelerations ``u'``.

    ``SOLVE``: evaluate ``M`` and ``F`` and solve ``M u' = F`` by ``L D L^T``.
    ``RECURSIVE``: the articulated-body recursion of Newton–Euler equations
    (:attr:`Equations.accelerations`), linear in the number of bodies.
    """

    SOLVE = "solve"
    RECURSIVE = "recursive"


@dataclass(frozen=True)
class Block:
    """Assignments ``name[index] = expr``; ``mirror`` copies ``(dst, src)`` afterwards."""

    name: str
    size: int
    entries: tuple[tuple[int, sm.Expr], ...]
    mirror: tuple[tuple[int, int], ...] = ()


@dataclass(frozen=True)
class Spec:
    """The expressions and steps of one output before CSE (see the module docstring)."""

    output: Output
    out_name: str
    out_shape: tuple[int, ...]
    labels: tuple[str, ...]
    pre: tuple[Block, ...]
    solve: bool = False
    post: tuple[Block, ...] = ()
    columns: int = 0
    doc: str = ""
    variables: tuple = ()   # symbols differentiated by (sensitivity outputs)
    extra: Program = Program()   # assignments of this output only (derivatives through the program)
    velocity: tuple[Block, ...] = ()   # constrained: CA, CB, evaluated before u_r is solved
    implicit: int = 0   # constrained sensitivities: columns by implicit differentiation
    pivots: bool = False   # reads the recursion's u': every pivot is checked, used or not
    contact: int = 0   # contact rows m: the solve adds the contacts' (u', lambda) to the L D L^T
    forces: bool = False   # contact columns: write dlambda (else du') for each column
    stride: int = 0    # contact columns: DT, DC row-major with this many (padded) columns
    first_row: int | None = None   # columns: the solved rows' first row (spec's default: n_q)
    pairs: ChainPairs | None = None   # M's and DT's pair entries in loops (mbgen.codegen.pairs)

    @property
    def out_size(self) -> int:
        size = 1
        for n in self.out_shape:
            size *= n
        return size


def spec(eq: Equations, output: Output, form: Form = Form.SOLVE) -> Spec:
    """What ``output`` computes for ``eq`` (integrators have no spec: see :data:`INTEGRATORS`).

    ``form`` chooses how outputs that need the accelerations get them.  For a
    constrained model, every output whose expressions use a dependent speed
    first solves the velocity constraints for them (``Spec.velocity``).

    Raises
    ------
    ModelError
        The equations cannot give ``output`` (its row's ``needs``, see
        :mod:`mbgen.symbolic.availability`), or have no recursion for
        ``Form.RECURSIVE``.
    """
    form = Form(form)
    if form is Form.RECURSIVE and eq.accelerations is None:
        raise ModelError(f"the equations of {eq.name!r} have no recursive accelerations; "
                         + (imported_hint("Form.RECURSIVE") + "; use Form.SOLVE"
                            if imported(eq) else
                            "derive with Method.NEWTON_EULER (relative joints) or use "
                            "Form.SOLVE"))
    build = BUILDERS.get(output)
    if build is None:
        raise ModelError(f"output {output.value!r} has no expressions of its own")
    require(eq, output)
    info = OUTPUT_INFO[output]
    out = build(eq, info, form)
    if not out.doc:
        out = replace(out, doc=_comment(info))
    if eq.constraints is not None and not out.velocity:
        exprs = [e for b in out.pre + out.post for _, e in b.entries]
        exprs += [e for _, e in out.extra.assignments]
        if out.solve or set(eq.layout.dependent_speeds) & eq.uses(exprs):
            out = replace(out, velocity=_velocity_blocks(eq))
    if out.first_row is None:   # the solved rows below the kinematic ones
        out = replace(out, first_row=eq.layout.n_q)
    return out


def _comment(info: OutputInfo) -> str:
    """The generated function's comment from the row: its doc, and a 2-D array's layout."""
    layout = f", row-major {' x '.join(info.shape)}" if len(info.shape) == 2 else ""
    return f"{info.doc}{layout}."


def _mass_blocks(eq: Equations, partials: bool = False):
    """What the solve needs: ``M`` (lower triangle) and ``F``, and for a constrained model
    the acceleration bias ``BETA`` of ``A u' + beta = 0`` (over every speed); ``partials``:
    a Jacobian that reads the analytic ``residual_jacobian``, which solves with the
    equations' ``partials_solve`` where they carry it (the same ``M`` and ``F`` from the
    partials' own kinematics)."""
    n = eq.layout.n_u + eq.layout.n_d
    own = partials and eq.partials_solve is not None and eq.contacts is None
    M, F = eq.partials_solve if own else (eq.mass_matrix, eq.forcing)
    lower = tuple((i * n + j, M[i, j]) for i in range(n) for j in range(i + 1))
    blocks = (Block("M", n * n, lower), Block("F", n, tuple(enumerate(F))))
    if eq.constraints is not None:
        blocks += (Block("BETA", eq.constraints.m,
                         tuple(enumerate(eq.constraints.acceleration_bias))),)
    if eq.contacts is not None:   # the contact solve reads structural nonzeros only
        J, c = eq.contacts.jacobian, eq.contacts.drift
        blocks = (Block("M", n * n, tuple((k, e) for k, e in lower if e != 0 or k % (n + 1) == 0)),
                  blocks[1],
                  Block("CJ", J.rows * n, tuple((i * n + j, J[i, j]) for i in range(J.rows)
                                                for j in range(n) if J[i, j] != 0)),
                  Block("CB", J.rows, tuple(enumerate(c))))
    return blocks


def _velocity_blocks(eq: Equations) -> tuple[Block, ...]:
    """``CA = A`` (row-major ``m x (n_u + n_d)``) and ``CB = b`` of ``A u + b = 0``."""
    c = eq.constraints
    A = c.velocity_matrix
    n = A.cols
    return (Block("CA", c.m * n, tuple((i * n + j, A[i, j]) for i in range(c.m) for j in range(n))),
            Block("CB", c.m, tuple(enumerate(c.velocity_bias))))


def _rhs(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    L = eq.layout
    if form is Form.RECURSIVE:
        entries = tuple(enumerate(list(eq.kinematics) + list(eq.accelerations)))
        return Spec(info.output, info.array, (L.n_x,), L.derivative_names,
                    (Block("out", L.n_x, entries),), pivots=True,
                    doc="First-order right-hand side dxdt = [G(q,u,t); u'] with u' from "
                        "the articulated-body recursion.")
    g = Block("out", L.n_x, tuple(enumerate(eq.kinematics)))
    if eq.contacts is not None:
        return Spec(info.output, info.array, (L.n_x,), L.derivative_names, (g, *_mass_blocks(eq)),
                    solve=True, contact=eq.contacts.m,
                    doc="First-order right-hand side dxdt = [G(q,u,t); u'] with rigid point "
                        "contacts: M = L D L^T, u' = M^-1 (F + J^T lambda) with lambda from "
                        "J u' + c = 0 (the Delassus matrix J M^-1 J^T by L D L^T).")
    if eq.constraints is not None:
        return Spec(info.output, info.array, (L.n_x,), L.derivative_names, (g, *_mass_blocks(eq)),
                    solve=True, velocity=_velocity_blocks(eq),
                    doc="First-order right-hand side dxdt = [G(q,u,t); u_s'] of the "
                        "constrained system: u_r from A u + b = 0 (LU of A_r), u_s' from "
                        "the reduced equations T^T M T u_s' = T^T (F - M [0; d]).")
    return Spec(info.output, info.array, (L.n_x,), L.derivative_names, (g, *_mass_blocks(eq)),
                solve=True,
                doc="First-order right-hand side dxdt = [G(q,u,t); M^-1 F]; M solved by "
                    "L D L^T.")


def _mass_matrix(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    M = eq.mass_matrix
    n, sp = M.rows, eq.layout.all_speeds
    lower = tuple((i * n + j, M[i, j]) for i in range(n) for j in range(i + 1))
    mirror = tuple((j * n + i, i * n + j) for i in range(n) for j in range(i))
    labels = tuple(f"M[{sp[i]},{sp[j]}]" for i in range(n) for j in range(n))
    return Spec(info.output, info.array, (n, n), labels, (Block("out", n * n, lower, mirror),),
                doc="Mass matrix M(q,t), row-major, symmetric" + (
                    " (of every speed, the dependent ones last: M u' = F + A^T lambda)."
                    if eq.constraints is not None else "."))


def _forcing(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    L = eq.layout
    return Spec(info.output, info.array, (L.n_u + L.n_d,), tuple(f"F[{s}]" for s in L.all_speeds),
                (Block("out", L.n_u + L.n_d, tuple(enumerate(eq.forcing))),),
                doc="Forcing F(q,u,r,t) of M u' = F" + (
                    " + A^T lambda (every speed, the dependent ones last)."
                    if eq.constraints is not None else "."))


def _energy(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    pot = eq.potential_energy if eq.potential_energy is not None else sm.S.Zero
    return Spec(info.output, info.array, (2,), ("T", "V"),
                (Block("out", 2, ((0, eq.kinetic_energy), (1, pot))),))


def _positions(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    return _point_spec(eq, info, "position", "r", "Positions")


def _velocities(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    return _point_spec(eq, info, "velocity", "v", "Velocities")


def _point_spec(eq: Equations, info: OutputInfo, attribute: str, letter: str, what: str) -> Spec:
    """``attribute`` (of :class:`PointKinematics`) of the equations' points, ``k x 3``."""
    entries = tuple((3 * k + i, getattr(pk, attribute)[i])
                    for k, pk in enumerate(eq.points) for i in range(3))
    labels = tuple(f"{letter}_{pk.name}.{axis}" for pk in eq.points for axis in ("x", "y", "z"))
    return Spec(info.output, info.array, (len(eq.points), 3), labels,
                (Block("out", 3 * len(eq.points), entries),),
                doc=f"{what} of {', '.join(pk.name for pk in eq.points)} in Newtonian "
                    f"components, row-major k x 3.")


def _reactions(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    """Joint reactions: after the solve (they hold for the actual accelerations)."""
    if eq.contacts is not None:
        raise ModelError(f"the model {eq.name!r} has contacts: mbgen does not yet add their "
                         f"forces to the joint reactions; leave Output.REACTIONS out (the "
                         f"contact forces are Output.CONSTRAINT_FORCES)")
    J = eq.reactions
    nj = len(J.names)
    entries = tuple(enumerate(J.matrix))
    doc = (f"Joint reactions, row-major {nj} x 6: for each joint, the force and the moment "
           f"(about the joint point) that the parent exerts on the child, in the joint's "
           f"frame: Fx, Fy, Fz, Mx, My, Mz.")
    if form is Form.RECURSIVE:
        acc = acceleration_symbols(eq.layout.n_u)
        defs = Program(tuple(zip(acc, eq.accelerations)))
        return Spec(info.output, info.array, (nj, 6), J.labels(),
                    (Block("out", 6 * nj, entries),), doc=doc, extra=defs, pivots=True)
    return Spec(info.output, info.array, (nj, 6), J.labels(), _mass_blocks(eq),
                solve=True, post=(Block("out", 6 * nj, entries),), doc=doc)


def _constraint_forces(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    if eq.contacts is not None:
        k = eq.contacts
        return Spec(info.output, info.array, (k.m,), tuple(f"lambda[{n}]" for n in k.labels()),
                    _mass_blocks(eq), solve=True, contact=k.m,
                    post=(Block("out", k.m, tuple(enumerate(lambda_symbols(k.m)))),),
                    doc=f"Contact forces lambda: the force the ground exerts at "
                        f"{', '.join(k.names)}, Newtonian components (x, y, z of each), of "
                        f"M u' = F + J^T lambda with J u' + c = 0.")
    c = eq.constraints
    lam = lambda_symbols(c.m)
    return Spec(info.output, info.array, (c.m,), tuple(f"lambda[{n}]" for n in c.names),
                _mass_blocks(eq), solve=True, post=(Block("out", c.m, tuple(enumerate(lam))),),
                velocity=_velocity_blocks(eq))


def _holonomic(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    c = eq.constraints
    return Spec(info.output, info.array, (c.m_h,), c.names[:c.m_h],
                (Block("out", c.m_h, tuple(enumerate(c.holonomic))),))


def _holonomic_jacobian(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    c, L = eq.constraints, eq.layout
    labels = tuple(f"d({n})/d({q})" for n in c.names[:c.m_h] for q in L.coordinates)
    return Spec(info.output, info.array, (c.m_h, L.n_q), labels,
                (Block("out", c.m_h * L.n_q, tuple(enumerate(c.holonomic_jacobian))),))


def _sensitivity(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    r"""``df/dv``: kinematic rows symbolic, dynamic rows from :math:`M^{-1}\,\partial R/\partial v`.

    ``v``: the output's :data:`~mbgen.symbolic.availability.SENSITIVITIES` row.
    :math:`R = F - M u'` is the equations' inverse-dynamics ``residual`` where they carry
    one (a Newton–Euler derivation, in either form), differentiated through the program
    (forward mode, :func:`mbgen.symbolic.program.derivatives`), so neither ``M`` nor the
    articulated inertias are differentiated; for ``df/dx``, the equations'
    ``residual_jacobian`` where the derivation wrote it analytically
    (:mod:`mbgen.derivation.rnea_partials`).  A recursion without a residual has its
    accelerations differentiated through the program instead.
    """
    L = eq.layout
    sensitivity = SENSITIVITIES[info.output]
    variables = tuple(sensitivity.variables(eq, L))
    var_names = ("t",) if sensitivity.vector else tuple(map(str, variables))
    nq, nu, nv = L.n_q, L.n_u, len(variables)
    shape = (L.n_x,) if sensitivity.vector else (L.n_x, nv)
    labels = tuple(f"d({s}')/d({v})" for s in L.state_names for v in var_names)
    tag = f"{info.array.lower()}_"
    if form is Form.RECURSIVE and eq.residual is None:
        extra, d = derivatives(eq.program, list(eq.kinematics) + list(eq.accelerations),
                               variables, tag)
        entries = tuple((i * nv + j, d[i][j]) for i in range(L.n_x) for j in range(nv))
        return Spec(info.output, info.array, shape, labels, (Block("out", L.n_x * nv, entries),),
                    variables=variables, extra=extra, pivots=True)
    if eq.constraints is not None:
        return _implicit_sensitivity(eq, info, variables, shape, labels, tag)
    if eq.contacts is not None:
        return _contact_sensitivity(eq, info, variables, shape, labels, tag)
    analytic = info.output is Output.JACOBIAN and eq.residual_jacobian is not None
    extra, dG, dR = _partials(eq, variables, tag, analytic)
    g_entries = tuple((i * nv + j, dG[i][j]) for i in range(nq) for j in range(nv))
    d_entries = tuple((j * nu + i, dR[i][j]) for j in range(nv) for i in range(nu))
    if all(e == 0 for _, e in d_entries):  # u' does not depend on v: no solve needed
        rows = g_entries + tuple(((nq + i) * nv + j, sm.S.Zero)
                                 for i in range(nu) for j in range(nv))
        # a recursion's pivots are still checked: a singular M is an error, not zeros
        return Spec(info.output, info.array, shape, labels, (Block("out", L.n_x * nv, rows),),
                    variables=variables, extra=extra, pivots=eq.accelerations is not None)
    return Spec(info.output, info.array, shape, labels,
                (Block("out", L.n_x * nv, g_entries), *_mass_blocks(eq, analytic)),
                solve=True, post=(Block("DT", nv * nu, d_entries),), columns=nv,
                variables=variables, extra=extra)


def _partials(eq: Equations, variables, tag: str, by_state: bool):
    """``(extra, dG, dR)``: the program's added assignments and the partial derivatives of
    ``q' = G`` (``n_q`` rows) and of the residual :math:`R = F - M a` (``n_u`` rows) by
    ``variables``; ``by_state`` (the variables are the states): the derivation's analytic
    ``residual_jacobian`` where it wrote one (:mod:`mbgen.derivation.rnea_partials`), so only
    ``q' = G`` goes through the program."""
    nq, nu = eq.layout.n_q, eq.layout.n_u
    if by_state and eq.residual_jacobian is not None:
        extra, dG = derivatives(eq.program, list(eq.kinematics), variables, tag)
        return extra, dG, [list(eq.residual_jacobian.row(i)) for i in range(nu)]
    acc = acceleration_symbols(nu)
    M, F = eq.mass_matrix, eq.forcing
    rows = (list(eq.residual) if eq.residual is not None else
            [F[i] - sm.Add(*(M[i, k] * acc[k] for k in range(nu))) for i in range(nu)])
    if eq.program:
        extra, d = derivatives(eq.program, list(eq.kinematics) + rows, variables, tag)
        return extra, d[:nq], d[nq:]
    return Program(), differentiate(list(eq.kinematics), variables), differentiate(rows,
                                                                                   variables)


def _tangent(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    r"""``[du'/d delta, du'/du]`` (``n_u x 2 n_u``): the accelerations' Jacobian in the
    speeds' tangent space.

    A configuration moved along the speeds, :math:`q \oplus \delta = q + G(q)\,\delta`
    with :math:`G = \partial q'/\partial u` (``q' = G(q) u``), gives the columns

    .. math::

        \frac{\partial u'}{\partial \delta_k} = \sum_j \frac{\partial u'}{\partial q_j}
        G_{jk} = M^{-1} \sum_j \frac{\partial R}{\partial q_j} G_{jk}

    summed over ``G``'s structural nonzeros before the solve, so the ``2 n_u`` columns are
    solved as the ``jacobian``'s ``n_q + n_u`` are (one factor, the tree's column solve
    where it applies) and the product :math:`J_q G` is never formed at run time.  For a
    floating base this is Pinocchio's ``ddq_dq`` of ``computeABADerivatives``; a recursion
    without a residual sums the accelerations' own derivatives.
    """
    L = eq.layout
    nq, nu = L.n_q, L.n_u
    variables = tuple(L.states)
    speeds = L.state_names[nq:]
    labels = tuple(f"d({a}')/d({v})" for a in speeds
                   for v in (*(f"delta_{b}" for b in speeds), *speeds))
    tag = f"{info.array.lower()}_"
    recursive = form is Form.RECURSIVE and eq.residual is None
    if not recursive and eq.residual_tangent is not None:   # the derivation's, no sum over G
        extra = Program()
        T = [list(eq.residual_tangent.row(i)) + list(eq.residual_jacobian.row(i))[nq:]
             for i in range(nu)]
    else:
        if recursive:
            extra, d = derivatives(eq.program, list(eq.kinematics) + list(eq.accelerations),
                                   variables, tag)
            dG, dR = d[:nq], d[nq:]
        else:
            extra, dG, dR = _partials(eq, variables, tag, True)
        G = [[(j, dG[j][nq + k]) for j in range(nq) if dG[j][nq + k] != 0] for k in range(nu)]
        T = [[sm.Add(*(row[j] * g for j, g in G[k] if row[j] != 0)) for k in range(nu)]
             + list(row[nq:]) for row in dR]
    size, columns = nu * 2 * nu, 2 * nu
    if recursive or all(e == 0 for row in T for e in row):
        entries = tuple((i * columns + k, T[i][k] if recursive else sm.S.Zero)
                        for i in range(nu) for k in range(columns))
        return Spec(info.output, info.array, (nu, columns), labels,
                    (Block("out", size, entries),), variables=variables, extra=extra,
                    pivots=eq.accelerations is not None)
    post = Block("DT", size, tuple((k * nu + i, T[i][k]) for k in range(columns)
                                   for i in range(nu)))
    return Spec(info.output, info.array, (nu, columns), labels,
                (Block("out", size, ()), *_mass_blocks(eq, not recursive)), solve=True,
                post=(post,), columns=columns, variables=variables, extra=extra, first_row=0)


def _implicit_sensitivity(eq: Equations, info: OutputInfo, variables, shape, labels,
                          tag) -> Spec:
    r"""``df/dv`` of a constrained model by implicit differentiation (evaluated in C).

    The right-hand side solves, at fixed ``x``: ``C = A u + b = 0`` for ``u_r``,
    then ``E = M a - F - A^T lambda = 0`` and ``B = A a + beta = 0`` for ``a``
    and ``lambda``.  Their partial derivatives, symbolic with ``u_r``, ``a``
    and ``lambda`` held, are post blocks: ``PC, PG, PGR, PE, PER, PB, PBR``
    (``R``: with respect to ``u_r``).  Column ``j`` is then
    ``du_r = -A_r^{-1} PC_j``, ``[M -A^T; A 0] [da; dlambda] = -[PE_j + PER du_r;
    PB_j + PBR du_r]``, ``dq'/dv_j = PG_j + PGR du_r``, ``du_s'/dv_j = da_s``.
    """
    L, c = eq.layout, eq.constraints
    n, m, nq, nv = L.n_u + L.n_d, c.m, L.n_q, len(variables)
    A, b, beta = c.velocity_matrix, c.velocity_bias, c.acceleration_bias
    M, F, G = eq.mass_matrix, eq.forcing, eq.kinematics
    u, acc, lam = L.all_speeds, acceleration_symbols(n), lambda_symbols(m)
    C = [sm.Add(*(A[i, j] * u[j] for j in range(n)), b[i]) for i in range(m)]
    E = [sm.Add(*(M[i, k] * acc[k] for k in range(n)), -F[i],
                *(-A[k, i] * lam[k] for k in range(m))) for i in range(n)]
    B = [sm.Add(*(A[i, j] * acc[j] for j in range(n)), beta[i]) for i in range(m)]
    everything = list(variables) + list(L.dependent_speeds)
    exprs = C + list(G) + E + B
    if eq.program:
        extra, d = derivatives(eq.program, exprs, everything, tag)
    else:
        extra, d = Program(), differentiate(exprs, everything)

    def block(name, rows, first, count):
        return Block(name, len(rows) * count, tuple(
            (i * count + j, rows[i][first + j]) for i in range(len(rows)) for j in range(count)))

    dC, dG, dE, dB = d[:m], d[m:m + nq], d[m + nq:m + nq + n], d[m + nq + n:]
    post = (block("PC", dC, 0, nv), block("PG", dG, 0, nv), block("PGR", dG, nv, m),
            block("PE", dE, 0, nv), block("PER", dE, nv, m), block("PB", dB, 0, nv),
            block("PBR", dB, nv, m))
    return Spec(info.output, info.array, shape, labels, _mass_blocks(eq), solve=True, post=post,
                variables=variables, extra=extra, velocity=_velocity_blocks(eq), implicit=nv)


def _contact_sensitivity(eq: Equations, info: OutputInfo, variables, shape, labels, tag,
                         forces: bool = False) -> Spec:
    r"""``df/dv`` (and, ``forces``, :math:`\partial\lambda/\partial v` below it) of a model
    with contacts, by implicit differentiation of

    .. math::

        R = F - M a + J^T\lambda = 0, \qquad C = J a + c = 0

    with ``a`` and :math:`\lambda` held: ``DT`` (:math:`\partial R/\partial v`, ``n_u`` rows of
    ``stride`` columns, the variables' padded to a multiple of
    :data:`~mbgen.codegen.contacts.LANES`) and ``DC`` (:math:`\partial C/\partial v`, ``m`` rows)
    are post blocks, and the
    generated code solves each column as the contact dynamics itself (same factors):
    :math:`z = M^{-1}\,\partial_j R`, :math:`d\lambda = -G^{-1}(J z + \partial_j C)`,
    :math:`da = z + Y d\lambda`.  ``R`` is the inverse-dynamics ``residual`` plus
    :math:`J^T\lambda` where the equations carry one (differentiated through the program, or
    its analytic Jacobian :mod:`mbgen.derivation.rnea_partials` plus that of
    :math:`J^T\lambda`).
    """
    L, k = eq.layout, eq.contacts
    nq, nu, nv, m = L.n_q, L.n_u, len(variables), k.m
    acc, lam = acceleration_symbols(nu), lambda_symbols(m)
    JTl, C = k.generalized_force(lam), k.acceleration(acc)
    analytic = info.output is Output.JACOBIAN and eq.residual_jacobian is not None
    if analytic:
        rows = JTl
    elif eq.residual is not None:
        rows = [sm.Add(r, f) for r, f in zip(eq.residual, JTl)]
    else:
        M, F = eq.mass_matrix, eq.forcing
        rows = [sm.Add(F[i], *(-M[i, j] * acc[j] for j in range(nu)), JTl[i])
                for i in range(nu)]
    exprs = list(eq.kinematics) + rows + C
    if eq.program:
        extra, d = derivatives(eq.program, exprs, variables, tag)
    else:
        extra, d = Program(), differentiate(exprs, variables)
    dG, dR, dC = d[:nq], d[nq:nq + nu], d[nq + nu:]
    if analytic:
        dR = [[sm.Add(a, b) for a, b in zip(eq.residual_jacobian.row(i), dR[i])]
              for i in range(nu)]
    stride = padded(nv)   # row-major, columns padded: the C solves them as vector loops
    post = (Block("DT", nu * stride, tuple((i * stride + j, dR[i][j]) for i in range(nu)
                                           for j in range(nv))),
            Block("DC", m * stride, tuple((r * stride + j, dC[r][j]) for r in range(m)
                                          for j in range(nv))))
    size = (L.n_x + (m if forces else 0)) * nv
    pre = (Block("out", size, tuple((i * nv + j, dG[i][j]) for i in range(nq)
                                    for j in range(nv))),) + _mass_blocks(eq)
    return Spec(info.output, info.array, shape, labels, pre, solve=True, post=post, columns=nv,
                variables=tuple(variables), extra=extra, contact=m, forces=forces,
                stride=stride)


def _contact_jacobian(eq: Equations, info: OutputInfo, form: Form) -> Spec:
    r""":math:`\partial f/\partial x` and below it :math:`\partial\lambda/\partial x` of the
    contact forces, from one set of column solves (:func:`_contact_sensitivity`)."""
    L, k = eq.layout, eq.contacts
    labels = tuple(f"d({s}')/d({v})" for s in L.state_names for v in L.state_names)
    labels += tuple(f"d(lambda[{n}])/d({v})" for n in k.labels() for v in L.state_names)
    return _contact_sensitivity(eq, info, L.states, (L.n_x + k.m, L.n_x), labels,
                                f"{info.array.lower()}_", forces=True)


#: How the kernel computes every expression output: ``build(eq, info, form) -> Spec``, with
#: ``info`` the output's row of :data:`mbgen.abi.OUTPUT_INFO`.
BUILDERS: dict[Output, Callable[[Equations, OutputInfo, Form], Spec]] = {
    Output.RHS: _rhs,
    Output.MASS_MATRIX: _mass_matrix,
    Output.FORCING: _forcing,
    Output.ENERGY: _energy,
    Output.JACOBIAN: _sensitivity,
    Output.PARAMETER_JACOBIAN: _sensitivity,
    Output.TIME_DERIVATIVE: _sensitivity,
    Output.POSITIONS: _positions,
    Output.VELOCITIES: _velocities,
    Output.REACTIONS: _reactions,
    Output.INPUT_JACOBIAN: _sensitivity,
    Output.CONSTRAINT_FORCES: _constraint_forces,
    Output.HOLONOMIC: _holonomic,
    Output.HOLONOMIC_JACOBIAN: _holonomic_jacobian,
    Output.CONTACT_JACOBIAN: _contact_jacobian,
    Output.TANGENT_JACOBIAN: _tangent,
}
