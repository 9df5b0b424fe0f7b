r"""What each generated output computes, as blocks of expressions.

Every function follows one pattern (the templates render it):

1. *pre* blocks: expressions of ``t, x, p, r`` written to the output array or to
   local arrays ``M`` (lower triangle) and ``F``;
2. if ``solve``: factor ``M = L D L^T`` (:mod:`mbgen.solver`) and overwrite ``F`` with the
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
``DOPRI5``, ``RK4``, ``ROSENBROCK``
    Integrators rendered into the C with the model (no expressions of their
    own); they pull in the outputs they call.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Iterable

import sympy as sm

from .equations import Equations
from .errors import ModelError
from .symbolic import symbols_back, to_symengine, to_sympy


class Output(str, Enum):
    """What a generated model computes."""

    RHS = "rhs"
    MASS_MATRIX = "mass_matrix"
    FORCING = "forcing"
    ENERGY = "energy"
    JACOBIAN = "jacobian"
    PARAMETER_JACOBIAN = "parameter_jacobian"
    TIME_DERIVATIVE = "time_derivative"
    POSITIONS = "positions"
    VELOCITIES = "velocities"
    DOPRI5 = "dopri5"
    RK4 = "rk4"
    ROSENBROCK = "rosenbrock"

    @property
    def is_integrator(self) -> bool:
        return self in INTEGRATORS

    @classmethod
    def parse(cls, values: Iterable) -> tuple["Output", ...]:
        """Outputs from enum members or their names, in canonical (declaration) order."""
        if isinstance(values, (str, Output)):
            values = (values,)
        wanted = set()
        for v in values:
            try:
                wanted.add(v if isinstance(v, cls) else cls(str(v).lower()))
            except ValueError:
                raise ModelError(f"unknown output {v!r}; choose from "
                                 f"{', '.join(o.value for o in cls)}") from None
        return tuple(o for o in cls if o in wanted)


INTEGRATORS = (Output.DOPRI5, Output.RK4, Output.ROSENBROCK)
#: Outputs that are expressions of the equations (everything but the integrators).
EXPRESSION_OUTPUTS = tuple(o for o in Output if o not in INTEGRATORS)


def with_dependencies(outputs: Iterable[Output], equations: Equations) -> tuple[Output, ...]:
    """``outputs`` plus what they call: integrators need the RHS, Rosenbrock the Jacobians."""
    wanted = set(Output.parse(outputs))
    if wanted & set(INTEGRATORS):
        wanted.add(Output.RHS)
    if Output.ROSENBROCK in wanted:
        wanted.add(Output.JACOBIAN)
        if equations.layout.time in _time_symbols(equations):
            wanted.add(Output.TIME_DERIVATIVE)
    return Output.parse(wanted)


def _time_symbols(equations: Equations) -> set:
    from .symbolic import free_symbols

    return free_symbols(list(equations.mass_matrix) + list(equations.forcing)
                        + list(equations.kinematics))


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

    @property
    def out_size(self) -> int:
        size = 1
        for n in self.out_shape:
            size *= n
        return size


def acceleration_symbols(n: int) -> tuple[sm.Symbol, ...]:
    """Placeholders for the solved accelerations (printed as ``F[i]``)."""
    return tuple(sm.Symbol(f"mbgen:acc{i}") for i in range(n))


def _mass_blocks(eq: Equations):
    n = eq.layout.n_u
    M = eq.mass_matrix
    lower = tuple((i * n + j, M[i, j]) for i in range(n) for j in range(i + 1))
    return (Block("M", n * n, lower), Block("F", n, tuple(enumerate(eq.forcing))))


def spec(eq: Equations, output: Output) -> Spec:
    """What ``output`` computes for ``eq`` (integrators have no spec: see :data:`INTEGRATORS`)."""
    L = eq.layout
    n = L.n_u
    names = L.state_names
    if output is Output.RHS:
        g = Block("out", L.n_x, tuple(enumerate(eq.kinematics)))
        return Spec(output, "dxdt", (L.n_x,), L.derivative_names, (g, *_mass_blocks(eq)),
                    solve=True,
                    doc="First-order right-hand side dxdt = [G(q,u,t); M^-1 F]; M solved by "
                        "L D L^T.")
    if output is Output.MASS_MATRIX:
        M = eq.mass_matrix
        lower = tuple((i * n + j, M[i, j]) for i in range(n) for j in range(i + 1))
        mirror = tuple((j * n + i, i * n + j) for i in range(n) for j in range(i))
        labels = tuple(f"M[{L.speeds[i]},{L.speeds[j]}]" for i in range(n) for j in range(n))
        return Spec(output, "M", (n, n), labels, (Block("out", n * n, lower, mirror),),
                    doc="Mass matrix M(q,t), row-major n_u x n_u, symmetric.")
    if output is Output.FORCING:
        return Spec(output, "F", (n,), tuple(f"F[{s}]" for s in L.speeds),
                    (Block("out", n, tuple(enumerate(eq.forcing))),),
                    doc="Forcing F(q,u,r,t) of M u' = F.")
    if output is Output.ENERGY:
        if eq.kinetic_energy is None:
            raise ModelError(f"the equations of {eq.name!r} carry no energy expressions; "
                             f"derive with energy=True or leave Output.ENERGY out")
        pot = eq.potential_energy if eq.potential_energy is not None else sm.S.Zero
        return Spec(output, "energy", (2,), ("T", "V"),
                    (Block("out", 2, ((0, eq.kinetic_energy), (1, pot))),),
                    doc="Kinetic energy T and potential energy V (gravity, springs).")
    if output in (Output.POSITIONS, Output.VELOCITIES):
        if not eq.points:
            raise ModelError(f"the equations of {eq.name!r} carry no points; list the points "
                             f"to report in the scene (Scene.points) or derive with points=...")
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
                            "n_x x n_x.")
    if output is Output.PARAMETER_JACOBIAN:
        variables = dynamic_parameters(eq)
        if not variables:
            raise ModelError(f"the equations of motion of {eq.name!r} have no parameters, so "
                             f"no parameter Jacobian")
        return _sensitivity(eq, output, variables, "Jp", tuple(map(str, variables)),
                            "Parameter Jacobian df/dp of the right-hand side, row-major "
                            "n_x x n_p.")
    if output is Output.TIME_DERIVATIVE:
        return _sensitivity(eq, output, (L.time,), "dfdt", ("t",),
                            "Partial time derivative df/dt of the right-hand side.")
    raise ModelError(f"output {output.value!r} has no expressions of its own")


def dynamic_parameters(eq: Equations) -> tuple:
    """Parameters that appear in ``M``, ``F`` or ``G`` (the others have zero sensitivity)."""
    from .symbolic import free_symbols

    used = free_symbols(list(eq.mass_matrix) + list(eq.forcing) + list(eq.kinematics))
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
    return tuple(o for o in EXPRESSION_OUTPUTS if o not in skip)


def _derivatives(exprs, variables) -> list[list[sm.Expr]]:
    """``[[d e / d v for v in variables] for e in exprs]``, differentiated by symengine.

    symengine differentiates the shared expression graph about a hundred times
    faster than ``sympy.diff`` (0.35 s against ~60 s for the 32-link pendulum's
    ``dR/dx``), and memoises by node.  The expressions cross to symengine and
    back through one memo each way (:func:`mbgen.symbolic.to_symengine`), so a
    subexpression shared by several entries is converted once and the results
    share nodes again.
    """
    memo: dict = {}
    se_exprs = to_symengine(exprs, memo)
    svars = to_symengine(variables, memo)
    flat = []
    for se_e in se_exprs:
        free = se_e.free_symbols
        flat.extend(se_e.diff(v) if v in free else None for v in svars)
    nonzero = to_sympy([d for d in flat if d is not None], symbols_back(memo))
    it = iter(nonzero)
    values = [sm.S.Zero if d is None else next(it) for d in flat]
    nv = len(svars)
    return [values[i * nv:(i + 1) * nv] for i in range(len(se_exprs))]


def _sensitivity(eq: Equations, output: Output, variables, out_name: str, var_names,
                 doc: str) -> Spec:
    r"""``df/dv``: kinematic rows symbolic, dynamic rows from :math:`M^{-1}\,\partial R/\partial v`."""
    L = eq.layout
    nq, nu, nv = L.n_q, L.n_u, len(variables)
    acc = acceleration_symbols(nu)
    M, F = eq.mass_matrix, eq.forcing
    rows = [F[i] - sm.Add(*(M[i, k] * acc[k] for k in range(nu))) for i in range(nu)]
    dG = _derivatives(list(eq.kinematics), variables)
    dR = _derivatives(rows, variables)
    g_entries = tuple((i * nv + j, dG[i][j]) for i in range(nq) for j in range(nv))
    d_entries = tuple((j * nu + i, dR[i][j]) for j in range(nv) for i in range(nu))
    shape = (L.n_x,) if output is Output.TIME_DERIVATIVE else (L.n_x, nv)
    labels = tuple(f"d({s}')/d({v})" for s in L.state_names for v in var_names)
    if all(e == 0 for _, e in d_entries):  # u' does not depend on v: no solve needed
        rows = g_entries + tuple(((nq + i) * nv + j, sm.S.Zero)
                                 for i in range(nu) for j in range(nv))
        return Spec(output, out_name, shape, labels, (Block("out", L.n_x * nv, rows),), doc=doc,
                    variables=tuple(variables))
    return Spec(output, out_name, shape, labels, (Block("out", L.n_x * nv, g_entries),
                                                  *_mass_blocks(eq)),
                solve=True, post=(Block("DT", nv * nu, d_entries),), columns=nv, doc=doc,
                variables=tuple(variables))
