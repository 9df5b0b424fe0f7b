r"""What each generated output computes, as blocks of expressions.

Every function follows one pattern (the templates render it):

1. *pre* blocks: expressions of ``t, x, p, r`` written to the output array or to
   local arrays ``M`` (lower triangle) and ``F``;
2. if ``solve``: factor ``M = L D L^T`` (:mod:`mbgen.codegen.solver`) and overwrite ``F`` with the
   accelerations ``u' = M^{-1} F``;
3. *post* blocks: expressions that may also use those accelerations;
4. if ``columns``: solve ``M Y = D`` column by column and write ``Y`` below
   the kinematic rows of the output.

Outputs
-------
``RHS``
    ``dxdt = [G; M^{-1} F]``, shape ``(n_x,)``.
``MASS_MATRIX``, ``FORCING``
    ``M`` (``n_u x n_u``, each symmetric pair computed once) and ``F``.
``ENERGY``
    ``[T, V]``.
``JACOBIAN``, ``PARAMETER_JACOBIAN``, ``TIME_DERIVATIVE``
    :math:`\partial f/\partial v` of the first-order right-hand side for
    ``v = x`` (``n_x x n_x``), ``v = p`` (``n_x x n_p``) or ``v = t`` (``n_x``).
    With :math:`R(v, a) = F - M a` and the accelerations ``a`` held fixed,

    .. math::

        \frac{\partial u'}{\partial v} = M^{-1} \frac{\partial R}{\partial v}
        = M^{-1}\Big(\frac{\partial F}{\partial v} - \frac{\partial M}{\partial v} a\Big),

    so ``M`` is factored once and :math:`\partial R/\partial v` is symbolic.
``POSITIONS``, ``VELOCITIES``
    Newtonian components of the named points' positions and velocities,
    shape ``(k, 3)`` (the points the equations were derived with).
``REACTIONS``
    For every joint (from the root), the force and moment the parent exerts
    on the child at the joint point, in the joint's frame: shape
    ``(n_joints, 6)``, ``[Fx, Fy, Fz, Mx, My, Mz]``.
``DOPRI5``, ``RK4``, ``ROSENBROCK``
    Integrators rendered into the C with the model (no expressions of their
    own); they pull in the outputs they call.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Iterable

import sympy as sm

from ..abi import EXPRESSION_OUTPUTS, INTEGRATORS, Output
from ..symbolic.equations import Equations, acceleration_symbols, lambda_symbols
from ..symbolic.program import Program, derivatives
from ..errors import ModelError
from ..symbolic.graph import differentiate, symbols_back, to_symengine, to_sympy


def with_dependencies(outputs: Iterable[Output], equations: Equations) -> tuple[Output, ...]:
    """``outputs`` plus what they call: integrators need the RHS, Rosenbrock the Jacobians."""
    wanted = set(Output.parse(outputs))
    if wanted & set(INTEGRATORS):
        wanted.add(Output.RHS)
    c = equations.constraints
    if wanted & set(INTEGRATORS) and c is not None and c.m_h:
        wanted |= {Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN}   # projection after each step
    if Output.ROSENBROCK in wanted:
        wanted.add(Output.JACOBIAN)
        if equations.layout.time in time_symbols(equations):
            wanted.add(Output.TIME_DERIVATIVE)
    return Output.parse(wanted)


def time_symbols(equations: Equations) -> set:
    return equations.uses(_motion_exprs(equations))


def _motion_exprs(eq: Equations) -> list:
    """Every expression the right-hand side may use (either form, constraints included)."""
    out = list(eq.mass_matrix) + list(eq.forcing) + list(eq.kinematics)
    if eq.accelerations is not None:
        out += list(eq.accelerations)
    if eq.constraints is not None:
        c = eq.constraints
        out += list(c.velocity_matrix) + list(c.velocity_bias) + list(c.acceleration_bias)
    return out


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

    @property
    def out_size(self) -> int:
        size = 1
        for n in self.out_shape:
            size *= n
        return size


def _mass_blocks(eq: Equations):
    """What the solve needs: ``M`` (lower triangle) and ``F``, and for a constrained model
    the acceleration bias ``BETA`` of ``A u' + beta = 0`` (over every speed)."""
    n = eq.layout.n_u + eq.layout.n_d
    M = eq.mass_matrix
    lower = tuple((i * n + j, M[i, j]) for i in range(n) for j in range(i + 1))
    blocks = (Block("M", n * n, lower), Block("F", n, tuple(enumerate(eq.forcing))))
    if eq.constraints is not None:
        blocks += (Block("BETA", eq.constraints.m,
                         tuple(enumerate(eq.constraints.acceleration_bias))),)
    return blocks


def _velocity_blocks(eq: Equations) -> tuple[Block, ...]:
    """``CA = A`` (row-major ``m x (n_u + n_d)``) and ``CB = b`` of ``A u + b = 0``."""
    c = eq.constraints
    A = c.velocity_matrix
    n = A.cols
    return (Block("CA", c.m * n, tuple((i * n + j, A[i, j]) for i in range(c.m) for j in range(n))),
            Block("CB", c.m, tuple(enumerate(c.velocity_bias))))


def spec(eq: Equations, output: Output, form: Form = Form.SOLVE) -> Spec:
    """What ``output`` computes for ``eq`` (integrators have no spec: see :data:`INTEGRATORS`).

    ``form`` chooses how outputs that need the accelerations get them.  For a
    constrained model, every output whose expressions use a dependent speed
    first solves the velocity constraints for them (``Spec.velocity``).
    """
    out = _spec(eq, output, form)
    if eq.constraints is not None and not out.velocity:
        exprs = [e for b in out.pre + out.post for _, e in b.entries]
        exprs += [e for _, e in out.extra.assignments]
        if out.solve or set(eq.layout.dependent_speeds) & eq.uses(exprs):
            from dataclasses import replace

            out = replace(out, velocity=_velocity_blocks(eq))
    return out


def _constraint_output(eq: Equations, output: Output) -> Spec:
    c = eq.constraints
    if c is None:
        raise ModelError(f"the model {eq.name!r} has no constraints, so no {output.value}")
    if output is Output.CONSTRAINT_FORCES:
        lam = lambda_symbols(c.m)
        return Spec(output, "lam", (c.m,), tuple(f"lambda[{n}]" for n in c.names),
                    _mass_blocks(eq), solve=True,
                    post=(Block("out", c.m, tuple(enumerate(lam))),),
                    velocity=_velocity_blocks(eq),
                    doc="Constraint multipliers lambda of M u' = F + A^T lambda, one per "
                        "constraint (a point constraint's: the force on the body at the point "
                        "along the frame axis).")
    if c.m_h == 0:
        raise ModelError(f"the model {eq.name!r} has no configuration (holonomic) constraints")
    if output is Output.HOLONOMIC:
        return Spec(output, "fh", (c.m_h,), c.names[:c.m_h],
                    (Block("out", c.m_h, tuple(enumerate(c.holonomic))),),
                    doc="Residual f_h(q, t) of the configuration constraints (zero on the "
                        "constraint manifold).")
    L = eq.layout
    H = c.holonomic_jacobian
    labels = tuple(f"d({n})/d({q})" for n in c.names[:c.m_h] for q in L.coordinates)
    return Spec(output, "dfh", (c.m_h, L.n_q), labels,
                (Block("out", c.m_h * L.n_q, tuple(enumerate(H))),),
                doc="Jacobian of the configuration constraints, df_h/dq, row-major m_h x n_q.")


def _spec(eq: Equations, output: Output, form: Form) -> Spec:
    L = eq.layout
    n = L.n_u
    names = L.state_names
    form = Form(form)
    if form is Form.RECURSIVE and eq.accelerations is None:
        raise ModelError(f"the equations of {eq.name!r} have no recursive accelerations; "
                         + (_IMPORTED.format(what="Form.RECURSIVE") + "; use Form.SOLVE"
                            if _imported(eq) else
                            "derive with Method.NEWTON_EULER (relative joints) or use "
                            "Form.SOLVE"))
    if output is Output.RHS:
        if form is Form.RECURSIVE:
            entries = tuple(enumerate(list(eq.kinematics) + list(eq.accelerations)))
            return Spec(output, "dxdt", (L.n_x,), L.derivative_names,
                        (Block("out", L.n_x, entries),),
                        doc="First-order right-hand side dxdt = [G(q,u,t); u'] with u' from "
                            "the articulated-body recursion.")
        g = Block("out", L.n_x, tuple(enumerate(eq.kinematics)))
        if eq.constraints is not None:
            return Spec(output, "dxdt", (L.n_x,), L.derivative_names, (g, *_mass_blocks(eq)),
                        solve=True, velocity=_velocity_blocks(eq),
                        doc="First-order right-hand side dxdt = [G(q,u,t); u_s'] of the "
                            "constrained system: u_r from A u + b = 0 (LU of A_r), u_s' from "
                            "the reduced equations T^T M T u_s' = T^T (F - M [0; d]).")
        return Spec(output, "dxdt", (L.n_x,), L.derivative_names, (g, *_mass_blocks(eq)),
                    solve=True,
                    doc="First-order right-hand side dxdt = [G(q,u,t); M^-1 F]; M solved by "
                        "L D L^T.")
    if output in (Output.CONSTRAINT_FORCES, Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN):
        return _constraint_output(eq, output)
    if output is Output.REACTIONS:
        return _reactions(eq, form)
    if output is Output.MASS_MATRIX:
        M = eq.mass_matrix
        n, sp = M.rows, L.all_speeds
        lower = tuple((i * n + j, M[i, j]) for i in range(n) for j in range(i + 1))
        mirror = tuple((j * n + i, i * n + j) for i in range(n) for j in range(i))
        labels = tuple(f"M[{sp[i]},{sp[j]}]" for i in range(n) for j in range(n))
        return Spec(output, "M", (n, n), labels, (Block("out", n * n, lower, mirror),),
                    doc="Mass matrix M(q,t), row-major, symmetric" + (
                        " (of every speed, the dependent ones last: M u' = F + A^T lambda)."
                        if eq.constraints is not None else "."))
    if output is Output.FORCING:
        return Spec(output, "F", (L.n_u + L.n_d,), tuple(f"F[{s}]" for s in L.all_speeds),
                    (Block("out", L.n_u + L.n_d, tuple(enumerate(eq.forcing))),),
                    doc="Forcing F(q,u,r,t) of M u' = F" + (
                        " + A^T lambda (every speed, the dependent ones last)."
                        if eq.constraints is not None else "."))
    if output is Output.ENERGY:
        if eq.kinetic_energy is None:
            raise ModelError(f"the equations of {eq.name!r} carry no energy expressions; "
                             + (_IMPORTED.format(what="Output.ENERGY") if _imported(eq) else
                                "derive with energy=True or leave Output.ENERGY out"))
        pot = eq.potential_energy if eq.potential_energy is not None else sm.S.Zero
        return Spec(output, "energy", (2,), ("T", "V"),
                    (Block("out", 2, ((0, eq.kinetic_energy), (1, pot))),),
                    doc="Kinetic energy T and potential energy V (gravity, springs).")
    if output in (Output.POSITIONS, Output.VELOCITIES):
        if not eq.points:
            raise ModelError(f"the equations of {eq.name!r} carry no points; "
                             + (_IMPORTED.format(what=f"Output.{output.name}")
                                if _imported(eq) else
                                "list the points to report in the scene (Scene.points) or "
                                "derive with points=..."))
        position = output is Output.POSITIONS
        entries = tuple((3 * k + i, (pk.position if position else pk.velocity)[i])
                        for k, pk in enumerate(eq.points) for i in range(3))
        labels = tuple(f"{'r' if position else 'v'}_{pk.name}.{axis}"
                       for pk in eq.points for axis in ("x", "y", "z"))
        name = "positions" if position else "velocities"
        return Spec(output, name, (len(eq.points), 3), labels,
                    (Block("out", 3 * len(eq.points), entries),),
                    doc=f"{'Positions' if position else 'Velocities'} of "
                        f"{', '.join(pk.name for pk in eq.points)} in Newtonian components, "
                        f"row-major k x 3.")
    if output is Output.JACOBIAN:
        return _sensitivity(eq, output, L.states, "J", names,
                            "Jacobian df/dx of the first-order right-hand side, row-major "
                            "n_x x n_x.", form)
    if output is Output.PARAMETER_JACOBIAN:
        variables = dynamic_parameters(eq)
        if not variables:
            raise ModelError(f"the equations of motion of {eq.name!r} have no parameters, so "
                             f"no parameter Jacobian")
        return _sensitivity(eq, output, variables, "Jp", tuple(map(str, variables)),
                            "Parameter Jacobian df/dp of the right-hand side, row-major "
                            "n_x x n_p.", form)
    if output is Output.TIME_DERIVATIVE:
        return _sensitivity(eq, output, (L.time,), "dfdt", ("t",),
                            "Partial time derivative df/dt of the right-hand side.", form)
    if output is Output.INPUT_JACOBIAN:
        if not L.inputs:
            raise ModelError(f"the model {eq.name!r} has no inputs, so no input Jacobian")
        return _sensitivity(eq, output, L.inputs, "Jr", L.input_names,
                            "Input Jacobian df/dr of the right-hand side (B of a "
                            "linearisation), row-major n_x x n_r.", form)
    raise ModelError(f"output {output.value!r} has no expressions of its own")


def dynamic_parameters(eq: Equations) -> tuple:
    """Parameters that ``M``, ``F``, ``G`` (or the recursion) use: the others have zero sensitivity."""
    used = eq.uses(_motion_exprs(eq))
    return tuple(p for p in eq.layout.parameters if p in used)


def applicable(eq: Equations) -> tuple[Output, ...]:
    """Every expression output the equations can give (energy, parameters, points permitting)."""
    skip = set()
    if eq.kinetic_energy is None:
        skip.add(Output.ENERGY)
    if not dynamic_parameters(eq):
        skip.add(Output.PARAMETER_JACOBIAN)
    if not eq.points:
        skip |= {Output.POSITIONS, Output.VELOCITIES}
    if eq.reactions is None or not eq.reactions.names:
        skip.add(Output.REACTIONS)
    if not eq.layout.inputs:
        skip.add(Output.INPUT_JACOBIAN)
    if eq.constraints is None:
        skip |= {Output.CONSTRAINT_FORCES, Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN}
    elif eq.constraints.m_h == 0:
        skip |= {Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN}
    return tuple(o for o in EXPRESSION_OUTPUTS if o not in skip)


def _sensitivity(eq: Equations, output: Output, variables, out_name: str, var_names,
                 doc: str, form: Form = Form.SOLVE) -> Spec:
    r"""``df/dv``: kinematic rows symbolic, dynamic rows from :math:`M^{-1}\,\partial R/\partial v`.

    In the recursive form the accelerations themselves are differentiated
    through the program (forward mode, :func:`mbgen.symbolic.program.derivatives`).
    """
    L = eq.layout
    nq, nu, nv = L.n_q, L.n_u, len(variables)
    shape = (L.n_x,) if output is Output.TIME_DERIVATIVE else (L.n_x, nv)
    labels = tuple(f"d({s}')/d({v})" for s in L.state_names for v in var_names)
    tag = f"{out_name.lower()}_"
    if form is Form.RECURSIVE:
        extra, d = derivatives(eq.program, list(eq.kinematics) + list(eq.accelerations),
                               variables, tag)
        entries = tuple((i * nv + j, d[i][j]) for i in range(L.n_x) for j in range(nv))
        return Spec(output, out_name, shape, labels, (Block("out", L.n_x * nv, entries),),
                    doc=doc, variables=tuple(variables), extra=extra)
    if eq.constraints is not None:
        return _implicit_sensitivity(eq, output, variables, out_name, shape, labels, doc, tag)
    acc = acceleration_symbols(nu)
    M, F = eq.mass_matrix, eq.forcing
    rows = [F[i] - sm.Add(*(M[i, k] * acc[k] for k in range(nu))) for i in range(nu)]
    if eq.program:
        extra, d = derivatives(eq.program, list(eq.kinematics) + rows, variables, tag)
        dG, dR = d[:nq], d[nq:]
    else:
        extra = Program()
        dG = differentiate(list(eq.kinematics), variables)
        dR = differentiate(rows, variables)
    g_entries = tuple((i * nv + j, dG[i][j]) for i in range(nq) for j in range(nv))
    d_entries = tuple((j * nu + i, dR[i][j]) for j in range(nv) for i in range(nu))
    if all(e == 0 for _, e in d_entries):  # u' does not depend on v: no solve needed
        rows = g_entries + tuple(((nq + i) * nv + j, sm.S.Zero)
                                 for i in range(nu) for j in range(nv))
        return Spec(output, out_name, shape, labels, (Block("out", L.n_x * nv, rows),), doc=doc,
                    variables=tuple(variables), extra=extra)
    return Spec(output, out_name, shape, labels, (Block("out", L.n_x * nv, g_entries),
                                                  *_mass_blocks(eq)),
                solve=True, post=(Block("DT", nv * nu, d_entries),), columns=nv, doc=doc,
                variables=tuple(variables), extra=extra)


def _implicit_sensitivity(eq, output, variables, out_name, shape, labels, doc, tag) -> Spec:
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
    return Spec(output, out_name, shape, labels, _mass_blocks(eq), solve=True, post=post,
                doc=doc, variables=tuple(variables), extra=extra,
                velocity=_velocity_blocks(eq), implicit=nv)


_IMPORTED = ("they come from from_sympy(), which converts the equations of motion only "
             "(from_sympy(obj, name=, parameters=, dependent=) takes no option for more): leave "
             "{what} out, or build the model with mbgen.Model to get it")


def _imported(eq: Equations) -> bool:
    """Equations converted by :func:`mbgen.from_sympy` (their ``method`` is ``sympy.*``)."""
    return str(eq.method).startswith("sympy.")


def _reactions(eq: Equations, form: Form) -> Spec:
    """Joint reactions: after the solve (they hold for the actual accelerations)."""
    J = eq.reactions
    if J is None or not J.names:
        raise ModelError(f"the equations of {eq.name!r} carry no joint reactions; "
                         + (_IMPORTED.format(what="Output.REACTIONS") if _imported(eq) else
                            "derive with reactions=True (Output.REACTIONS asks for it) from an "
                            "mbgen.Model with at least one body"))
    nj = len(J.names)
    entries = tuple(enumerate(J.matrix))
    doc = (f"Joint reactions, row-major {nj} x 6: for each joint, the force and the moment "
           f"(about the joint point) that the parent exerts on the child, in the joint's "
           f"frame: Fx, Fy, Fz, Mx, My, Mz.")
    if form is Form.RECURSIVE:
        acc = acceleration_symbols(eq.layout.n_u)
        defs = Program(tuple(zip(acc, eq.accelerations)))
        return Spec(Output.REACTIONS, "reactions", (nj, 6), J.labels(),
                    (Block("out", 6 * nj, entries),), doc=doc, extra=defs)
    return Spec(Output.REACTIONS, "reactions", (nj, 6), J.labels(), _mass_blocks(eq),
                solve=True, post=(Block("out", 6 * nj, entries),), doc=doc)
