r"""Equations of motion: one frozen value.

.. math::

    M(q, t)\,u' = F(q, u, r, t), \qquad q' = G(q, u, t)

with ``M`` symmetric positive definite (``n_u x n_u``), ``F`` of length ``n_u``
and ``G`` of length ``n_q``.  Time dependence is gone: ``q1(t)`` is the plain
symbol ``q1`` here, and every symbol is in :attr:`Equations.layout`.
"""

from __future__ import annotations

import html
from collections.abc import Mapping
from dataclasses import dataclass, field

import sympy as sm

from ..errors import ModelError
from ..summary import names, table
from .graph import count_ops_dag, free_symbols, leaves
from .layout import Layout
from .pairs import ChainPairs
from .program import Program

#: How generated headers and summaries name a derivation method (``Equations.method``);
#: ASCII, as generated C comments are.
METHOD_TITLES = {"kane": "Kane's method", "newton_euler": "Newton-Euler"}


def acceleration_symbols(n: int) -> tuple[sm.Symbol, ...]:
    """Placeholders for the accelerations ``u'`` (expressions that need them, e.g. joint
    reactions, are evaluated after ``M u' = F`` is solved)."""
    return tuple(sm.Symbol(f"mbgen:acc{i}") for i in range(n))


def lambda_symbols(m: int) -> tuple[sm.Symbol, ...]:
    """Placeholders for the constraint multipliers ``lambda`` (solved with the accelerations)."""
    return tuple(sm.Symbol(f"mbgen:lam{i}") for i in range(m))


@dataclass(frozen=True)
class Constraints:
    r"""Holonomic and motion constraints of a model, in the form the generated code solves.

    With ``u = [u_s; u_r]`` (independent speeds, then ``layout.dependent_speeds``):

    * configuration: ``holonomic`` :math:`f_h(q, t) = 0` (shape ``(m_h, 1)``), one
      ``dependent_coordinates`` each, and its Jacobian ``holonomic_jacobian``
      :math:`\partial f_h/\partial q` (``(m_h, n_q)``);
    * velocity: ``A u + b = 0``, ``velocity_matrix`` ``A`` (``(m, n_u + n_d)``) and
      ``velocity_bias`` ``b`` (``(m, 1)``), the holonomic rows first (their time
      derivative), then the motion constraints; the block of ``A`` for the
      dependent speeds must be invertible (checked numerically at run time);
    * acceleration: ``A u' + acceleration_bias = 0`` (``(m, 1)``: the time
      derivative of ``A u + b`` with ``u' = 0``).

    ``names`` name the rows (and their multipliers, ``constraint_forces``).  With
    ``lambda`` the multipliers, the equations of motion are
    :math:`M u' = F + A^T\lambda`.  ``loads`` lists, per row, the point
    realisation of point constraints ``(kind, point names, frame name, axis)`` or
    None.
    """

    names: tuple[str, ...]
    holonomic: sm.ImmutableMatrix
    dependent_coordinates: tuple
    holonomic_jacobian: sm.ImmutableMatrix
    velocity_matrix: sm.ImmutableMatrix
    velocity_bias: sm.ImmutableMatrix
    acceleration_bias: sm.ImmutableMatrix
    loads: tuple = ()

    @property
    def m(self) -> int:
        return len(self.names)

    @property
    def m_h(self) -> int:
        return self.holonomic.rows

    def expressions(self) -> list:
        return (list(self.holonomic) + list(self.holonomic_jacobian) + list(self.velocity_matrix)
                + list(self.velocity_bias) + list(self.acceleration_bias))


@dataclass(frozen=True)
class Contacts:
    r"""Rigid point contacts held fixed in the Newtonian frame, at the acceleration level.

    Every speed stays a state (nothing is reduced, unlike :class:`Constraints`).  Contact
    ``i`` is the point :math:`P_i` and three rows: with :math:`J` (``jacobian``, shape
    ``(m, n_u)``, ``m = 3 k``) the points' velocity Jacobian :math:`\partial v_P/\partial u`
    and ``drift`` (``(m, 1)``) the rest of the constraint,

    .. math::

        J u' + c = 0, \qquad c = \gamma + k_d\, v_P + k_p (r_P - r_0),

    :math:`\gamma` the points' accelerations at :math:`u' = 0`, :math:`v_P` and
    :math:`r_P` their velocities and positions, :math:`r_0` the anchors and
    :math:`k_p, k_d` the Baumgarte gains (parameters), all in Newtonian components.  The
    multipliers :math:`\lambda` (the placeholders :func:`lambda_symbols`, three per
    contact) are the forces the ground exerts on the model at the points:
    :math:`M u' = F + J^T\lambda`.  ``names`` name the contacts, ``points`` their points.
    """

    names: tuple[str, ...]
    points: tuple[str, ...]
    jacobian: sm.ImmutableMatrix
    drift: sm.ImmutableMatrix

    @property
    def m(self) -> int:
        """Rows: three per contact."""
        return self.jacobian.rows

    def labels(self) -> tuple[str, ...]:
        """One label per row: ``FL_FOOT.x`` ... (the force's Newtonian components)."""
        return tuple(f"{n}.{axis}" for n in self.names for axis in "xyz")

    def expressions(self) -> list:
        return list(self.jacobian) + list(self.drift)

    def generalized_force(self, lam) -> list:
        r""":math:`J^T\lambda` (``n_u``): the generalized force of the contact forces ``lam``."""
        J = self.jacobian
        return [sm.Add(*(J[r, i] * lam[r] for r in range(J.rows) if J[r, i] != 0))
                for i in range(J.cols)]

    def acceleration(self, acc) -> list:
        r""":math:`J a + c` (``m``): the contact rows at the accelerations ``acc``."""
        J = self.jacobian
        return [sm.Add(*(J[r, i] * acc[i] for i in range(J.cols) if J[r, i] != 0),
                       self.drift[r]) for r in range(J.rows)]


@dataclass(frozen=True)
class JointLoads:
    r"""The force and moment that every joint's parent exerts on its child.

    Row ``i`` of ``matrix`` (shape ``(n_joints, 6)``) is joint ``names[i]``:
    force components, then moment components about the joint point
    ``points[i]``, all in frame ``frames[i]``.  Entries may contain the
    acceleration placeholders :func:`acceleration_symbols` (they hold for the
    actual accelerations) and program symbols.  Joints are in order from the
    root: every parent before its children.  ``parents[i]`` is ``None`` for a
    joint to the ground.
    """

    names: tuple[str, ...]
    children: tuple[str, ...]
    parents: tuple
    points: tuple[str, ...]
    frames: tuple[str, ...]
    matrix: sm.ImmutableMatrix

    def labels(self) -> tuple[str, ...]:
        """One label per entry, row-major: ``hitch.Fx [car]`` ... ``hitch.Mz [car]``."""
        out = []
        for name, frame in zip(self.names, self.frames):
            out += [f"{name}.{c} [{frame}]" for c in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")]
        return tuple(out)


@dataclass(frozen=True)
class PointKinematics:
    """Position and velocity of a named point, 3x1 each, in Newtonian-frame components."""

    name: str
    position: sm.ImmutableMatrix
    velocity: sm.ImmutableMatrix


@dataclass(frozen=True)
class Equations:
    """Mass matrix, forcing and kinematics of a model, plus optional extras.

    Attributes
    ----------
    name : str
        Model name (the C prefix is derived from it).
    layout : Layout
        Order of states, parameters and inputs.
    mass_matrix : ImmutableMatrix, shape (n_u, n_u)
        ``M(q, t)``, symmetric.
    forcing : ImmutableMatrix, shape (n_u, 1)
        ``F(q, u, r, t)``.
    kinematics : ImmutableMatrix, shape (n_q, 1)
        ``G(q, u, t)`` with ``q' = G``.
    kinetic_energy, potential_energy : Expr or None
        Energies when the derivation knows them (potential: gravity and springs).
    points : tuple of PointKinematics
        Positions and velocities of the points asked for at derivation.
    source : str
        Where the equations came from (shown in generated headers).
    method : str
        Derivation method (``"kane"``, ``"sympy.KanesMethod"``, ...).
    method_reason : str
        Why that method: named by the caller or the scene, or chosen by
        :func:`mbgen.derivation.choose_method` and the pipeline (e.g. ``"chosen: 537
        operations with the L D L^T solve, against Kane's 973"``); empty for
        equations that came from elsewhere.
    defaults : mapping
        Default numeric values of parameters, by symbol name (may be partial).
    program : Program
        Named intermediate quantities (a recursive derivation's per-body
        quantities); every other expression may use its symbols.  Empty for
        Kane's method.
    accelerations : ImmutableMatrix, shape (n_u, 1), or None
        ``u'`` computed by a recursion (the articulated-body algorithm) in
        program symbols: the alternative to solving ``M u' = F``.
    residual : ImmutableMatrix, shape (n_u, 1), or None
        ``F - M u'`` with ``u'`` the placeholders of :func:`acceleration_symbols`, by
        inverse dynamics in program symbols (a Newton–Euler derivation without
        constraints): what the Jacobians differentiate, at a cost linear in the
        number of bodies per variable, instead of ``F`` and ``M``.
    residual_jacobian : ImmutableMatrix, shape (n_u, n_q + n_u), or None
        ``dR/dx`` of the ``residual`` at ``u'`` held, where the
        derivation has it analytically (:mod:`mbgen.derivation.rnea_partials`; asked for
        with ``derive(..., jacobian=True)``); ``Output.JACOBIAN`` then uses it instead
        of differentiating ``residual`` through the program.
    residual_tangent : ImmutableMatrix, shape (n_u, n_u), or None
        ``dR/d delta`` at ``u'`` held, the configuration moved along each speed
        (the sum over ``j`` of ``dR/dq_j G_jk``, ``G = dq'/du``), where the
        derivation has it without that sum (a free root's tangent columns,
        :mod:`mbgen.derivation.rnea_partials`); ``Output.TANGENT_JACOBIAN`` then uses it.
    partials_solve : (ImmutableMatrix, ImmutableMatrix), shapes (n_u, n_u) and (n_u, 1), or None
        ``M`` and ``F`` again, from the quantities the analytic ``residual_jacobian`` holds
        (:func:`mbgen.derivation.rnea_partials.mass_and_bias`): the Jacobians that read it
        solve with these, which share its kinematics, instead of ``mass_matrix`` and
        ``forcing``.
    pairs : ChainPairs or None
        The ancestor–descendant products of a chain's ``residual_jacobian`` and
        ``partials_solve`` as per-body vectors (:mod:`mbgen.symbolic.pairs`), where the
        derivation has them: the generated ``jacobian`` computes those entries in loops.
    reactions : JointLoads or None
        Joint reaction forces and moments, when derived.
    constraints : Constraints or None
        Holonomic and motion constraints (None: an unconstrained model).  ``M``
        and ``F`` are then those of the unconstrained system over every speed,
        independent and dependent (``layout.all_speeds``).
    contacts : Contacts or None
        Rigid point contacts (None: none): ``M u' = F + J^T lambda`` with ``J u' + c = 0``;
        ``M``, ``F`` and the ``residual`` stay those without the contacts' forces, and
        ``accelerations`` is None (the recursion knows no contact).
    """

    name: str
    layout: Layout
    mass_matrix: sm.ImmutableMatrix
    forcing: sm.ImmutableMatrix
    kinematics: sm.ImmutableMatrix
    kinetic_energy: sm.Expr | None = None
    potential_energy: sm.Expr | None = None
    points: tuple[PointKinematics, ...] = ()
    source: str = ""
    method: str = ""
    method_reason: str = ""
    defaults: Mapping[str, float] = field(default_factory=dict)
    program: Program = field(default_factory=Program)
    accelerations: sm.ImmutableMatrix | None = None
    reactions: JointLoads | None = None
    residual: sm.ImmutableMatrix | None = None
    constraints: Constraints | None = None
    residual_jacobian: sm.ImmutableMatrix | None = None
    contacts: Contacts | None = None
    residual_tangent: sm.ImmutableMatrix | None = None
    partials_solve: tuple[sm.ImmutableMatrix, sm.ImmutableMatrix] | None = None
    pairs: ChainPairs | None = None

    def __post_init__(self):
        self._check_shapes()
        checked, known = self._checked_parts()
        for what, exprs in checked:
            # a program's leaves are walked once per Program (dataclasses.replace keeps it)
            symbols, funcs = exprs.leaves if isinstance(exprs, Program) else leaves(exprs)
            unknown = symbols - known
            if unknown:
                names = ", ".join(sorted(map(str, unknown)))
                raise ModelError(f"the {what} contains symbol(s) {names} that are neither "
                                 f"coordinates, speeds, parameters, inputs nor time; declare "
                                 f"them (e.g. model.constants('{names.split(', ')[0]}'))")
            if funcs:
                raise ModelError(f"the {what} still contains function(s) of time "
                                 f"{sorted(map(str, funcs))}; declare them as coordinates, "
                                 f"speeds or inputs")

    def _check_shapes(self) -> None:
        """The shapes of the matrices, and one dependent speed per constraint."""
        L = self.layout
        n = L.n_u + L.n_d
        if self.mass_matrix.shape != (n, n):
            raise ModelError(f"mass matrix has shape {self.mass_matrix.shape}, "
                             f"expected ({n}, {n})")
        if self.forcing.shape != (n, 1):
            raise ModelError(f"forcing has shape {self.forcing.shape}, expected ({n}, 1)")
        if L.n_d != (self.constraints.m if self.constraints is not None else 0):
            raise ModelError(f"{L.n_d} dependent speeds for "
                             f"{self.constraints.m if self.constraints else 0} constraints")
        if self.kinematics.shape != (L.n_q, 1):
            raise ModelError(f"kinematics has shape {self.kinematics.shape}, "
                             f"expected ({L.n_q}, 1)")
        if self.accelerations is not None and self.accelerations.shape != (n, 1):
            raise ModelError(f"accelerations have shape {self.accelerations.shape}, "
                             f"expected ({L.n_u}, 1)")
        c = self.contacts
        if c is not None and (c.jacobian.shape != (c.m, n) or c.drift.shape != (c.m, 1)
                              or c.m != 3 * len(c.names)):
            raise ModelError(f"contacts: Jacobian {c.jacobian.shape} and drift {c.drift.shape} "
                             f"for {len(c.names)} contacts, expected ({3 * len(c.names)}, {n}) "
                             f"and ({3 * len(c.names)}, 1)")

    def _analytic_parts(self, n: int) -> list:
        """The derivation's analytic Jacobian parts (``residual_jacobian``, ``residual_tangent``,
        ``partials_solve``) as checked parts, their shapes checked."""
        L = self.layout
        out: list = []
        if self.residual_jacobian is not None:
            if self.residual is None or self.residual_jacobian.shape != (n, L.n_x):
                raise ModelError(f"residual_jacobian has shape {self.residual_jacobian.shape}, "
                                 f"expected ({n}, {L.n_x}) with a residual")
            out.append(("residual Jacobian", self.residual_jacobian))
        if self.residual_tangent is not None:
            if self.residual_jacobian is None or self.residual_tangent.shape != (n, n):
                raise ModelError(f"residual_tangent has shape {self.residual_tangent.shape}, "
                                 f"expected ({n}, {n}) with a residual Jacobian")
            out.append(("residual tangent", self.residual_tangent))
        if self.partials_solve is not None:
            M, F = self.partials_solve
            if self.residual_jacobian is None or M.shape != (n, n) or F.shape != (n, 1):
                raise ModelError(f"partials_solve has shapes {M.shape} and {F.shape}, expected "
                                 f"({n}, {n}) and ({n}, 1) with a residual Jacobian")
            out += [("partials' mass matrix", M), ("partials' forcing", F)]
        if self.pairs is not None:
            if self.partials_solve is None:
                raise ModelError("pairs without partials_solve: the pair products are entries "
                                 "of the analytic residual Jacobian and its mass matrix")
            out += [("pairs' ancestor vectors", self.pairs.ancestor),
                    ("pairs' descendant vectors", self.pairs.descendant)]
        return out

    def _checked_parts(self) -> tuple[list, set]:
        """``(checked, known)``: the named parts whose symbols are checked (the residual's
        and its Jacobian's shapes on the way), and the symbols they may contain."""
        L = self.layout
        n = L.n_u + L.n_d
        known = L.symbols() | set(self.program.symbols)
        checked = [("mass matrix", self.mass_matrix), ("forcing", self.forcing),
                   ("kinematics", self.kinematics)]
        if self.program:
            checked.append(("program", self.program))
            # the placeholders of solved quantities (accelerations, multipliers) are internal
            known = known | {s for s in self.program.leaves[0] if s.name.startswith("mbgen:")}
        if self.accelerations is not None:
            checked.append(("accelerations", self.accelerations))
        if self.residual is not None:
            if self.residual.shape != (n, 1):
                raise ModelError(f"residual has shape {self.residual.shape}, expected ({n}, 1)")
            checked.append(("residual", self.residual))
            known = known | set(acceleration_symbols(n))
        checked += self._analytic_parts(n)
        if self.constraints is not None:
            checked.append(("constraints", self.constraints.expressions()))
        if self.contacts is not None:
            checked.append(("contacts", self.contacts.expressions()))
        return checked, known

    @property
    def derivation(self) -> str:
        """The method in words and why it was used: ``Newton-Euler (chosen: ...)``."""
        title = METHOD_TITLES.get(self.method, self.method or "-")
        return f"{title} ({self.method_reason})" if self.method_reason else title

    def uses(self, exprs) -> set:
        """Layout symbols that ``exprs`` depend on, through the program's definitions."""
        return self.program.closure(exprs) if self.program else free_symbols(exprs)

    @property
    def energy(self) -> sm.Expr | None:
        """Total mechanical energy ``T + V`` when both are known."""
        if self.kinetic_energy is None or self.potential_energy is None:
            return None
        return self.kinetic_energy + self.potential_energy

    def mass_matrix_full(self) -> sm.ImmutableMatrix:
        """Block-diagonal ``diag(I_nq, M)`` of the first-order system ``[I 0; 0 M] x' = [G; F]``."""
        L = self.layout
        out = sm.zeros(L.n_x, L.n_x)
        out[:L.n_q, :L.n_q] = sm.eye(L.n_q)
        out[L.n_q:, L.n_q:] = self.mass_matrix
        return sm.ImmutableMatrix(out)

    def forcing_full(self) -> sm.ImmutableMatrix:
        """``[G; F]`` of length ``n_x``."""
        return sm.ImmutableMatrix(sm.Matrix.vstack(sm.Matrix(self.kinematics),
                                                   sm.Matrix(self.forcing)))

    def _repr_html_(self) -> str:
        """Notebook summary: sizes, symbols, operation counts; never the matrices."""
        return equations_html(self)


def equations_html(eq: Equations) -> str:
    """Notebook summary of :class:`mbgen.Equations`: sizes, symbols, operation counts.

    The counts are those of the expressions as a graph (:func:`count_ops_dag`: each
    distinct subexpression once), computed in one pass linear in the graph.
    """
    L = eq.layout
    n = L.n_u + L.n_d
    rows = [("derivation", html.escape(eq.derivation)),
            ("states x", f"{L.n_x}: {names(L.state_names)}"),
            ("parameters p", f"{L.n_p}: {names(L.parameter_names)}"),
            ("inputs r", f"{L.n_r}: {names(L.input_names)}"),
            ("M u' = F", f"M {n} x {n} ({count_ops_dag(list(eq.mass_matrix))} ops), "
                         f"F {n} ({count_ops_dag(list(eq.forcing))} ops)"),
            ("q' = G", f"G {L.n_q} ({count_ops_dag(list(eq.kinematics))} ops)")]
    if eq.energy is not None:
        rows.append(("energy", f"T, V ({count_ops_dag([eq.kinetic_energy, eq.potential_energy])}"
                               f" ops)"))
    if eq.points:
        rows.append(("points", names(p.name for p in eq.points)))
    if eq.program:
        rows.append(("program", f"{len(eq.program.assignments)} named intermediates"))
    if eq.reactions is not None:
        rows.append(("joint reactions", names(eq.reactions.names)))
    if eq.constraints is not None:
        c = eq.constraints
        rows.append(("constraints", f"{c.m} ({c.m_h} configuration): {names(c.names)}; "
                                    f"dependent speeds {names(L.dependent_speeds)}"))
    if eq.contacts is not None:
        rows.append(("contacts", f"{len(eq.contacts.names)} rigid point contacts: "
                                 f"{names(eq.contacts.names)}"))
    if eq.source:
        rows.append(("source", html.escape(eq.source)))
    return table(f"Equations {eq.name!r}", rows)
