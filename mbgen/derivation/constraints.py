r"""Constraints and reduced speeds: the velocity, acceleration and configuration forms.

A model's stated constraints (:meth:`mbgen.Model.holonomic`,
:meth:`~mbgen.Model.nonholonomic`, :meth:`~mbgen.Model.no_slip`,
:meth:`~mbgen.Model.coincident`) become, in plain symbols, with ``u = [u_s; u_r]``
(independent speeds, then one dependent speed per constraint):

* holonomic rows :math:`f_h(q, t) = 0` and their Jacobian :math:`\partial f_h/\partial q`;
* the velocity form ``A u + b = 0``: a holonomic row's time derivative
  :math:`\sum_j \partial f/\partial q_j\, G_j(q, u, t) + \partial f/\partial t`, a motion
  constraint as stated (``q'`` replaced by ``G``), both linear in ``u``
  (``A = dc/du``, ``b = c(u = 0)``);
* the acceleration form ``A u' + beta = 0`` with :math:`\beta = \sum_j \partial(Au+b)/
  \partial q_j\, G_j + \partial(Au+b)/\partial t` (``u`` held fixed).

Nothing is inverted here: the generated code factors the dependent block
``A_r`` numerically (LU with partial pivoting) to get ``u_r = -A_r^{-1}(A_s u_s + b)``
and reduces ``M u' = F + A^T lambda`` to the independent speeds (see
:mod:`mbgen.codegen.outputs`).  The unconstrained ``M`` and ``F`` are reordered so that
the dependent speeds come last.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import sympy as sm

from ..errors import ModelError
from ..symbolic.equations import Constraints, Equations, acceleration_symbols
from ..symbolic.graph import free_symbols, xreplace_dag
from ..symbolic.layout import Layout
from ..symbolic.program import Program
from .prepare import Prepared, signed_atoms
from .tree import cross, unit

#: ``Constraint.kind`` of a configuration constraint ``f(q, t) = 0``; the other kind,
#: ``"motion"``, is ``f(q, u, t) = 0`` (:class:`mbgen.model.elements.Constraint`).
HOLONOMIC = "holonomic"


def configuration(c) -> bool:
    """Whether the stated constraint ``c`` constrains the configuration (the one place the
    derivation reads ``Constraint.kind``)."""
    return c.kind == HOLONOMIC


@dataclass(frozen=True)
class _Row:
    """One stated constraint in plain symbols.

    ``row`` is its velocity form ``c(q, u, t)`` (to be linear in ``u``), ``speed`` its
    dependent speed, ``load`` what :attr:`Constraints.loads` records of a point
    constraint (None for an expression); a configuration constraint also has ``f(q, t)``
    (``holonomic``) and its dependent ``coordinate``.
    """

    name: str
    row: sm.Expr
    speed: sm.Symbol
    load: tuple | None
    holonomic: sm.Expr | None = None
    coordinate: sm.Symbol | None = None


def constrain(eq: Equations, prep: Prepared) -> Equations:
    """``eq`` (derived over every speed) with the model's constraints; unchanged without any.

    Three steps: :func:`_rows` (each constraint in plain symbols), :func:`_check` (the
    velocity form ``A u + b``, refused where it cannot determine the dependent speeds)
    and :func:`_reorder` (the dependent speeds last, the acceleration form).
    """
    stated = ordered(prep.model)
    if not stated:
        return eq
    rows = _rows(stated, prep, eq.layout)
    A, b = _check(rows, eq)
    return _reorder(eq, prep, rows, A, b)


def _rows(stated, prep: Prepared, L: Layout) -> list[_Row]:
    """The stated constraints, in the order of their rows, as :class:`_Row` values."""
    model = prep.model
    to_plain = {f: sm.Symbol(str(f.func)) for f in model.coordinates_ + model.speeds_}
    return [_configuration_row(c, prep, L, to_plain) if configuration(c)
            else _motion_row(c, prep, to_plain) for c in stated]


def _configuration_row(c, prep: Prepared, L: Layout, to_plain: dict) -> _Row:
    """``f(q, t)``, its time derivative along ``q' = G`` and its dependent coordinate and speed."""
    where = f"constraint {c.name!r}"
    tree, qdot = prep.tree, prep.qdot
    speeds, coords = list(L.speeds), list(L.coordinates)
    if c.points:
        a, b = c.points
        fnode = prep.frame_nodes[c.frame]
        atoms = signed_atoms(prep.point_atoms[a], prep.point_atoms[b])
        e = unit(c.axis)
        f = sm.Add(*(s * tree.dot(atom.c, atom.frame, e, fnode) for s, atom in atoms))
        load = ("coincident", (a.name, b.name), c.frame.name, c.axis)
    else:
        f = prep.plain(c.expression, where)
        load = None
    if free_symbols([f]) & set(speeds):
        raise ModelError(f"{where} contains speeds; a configuration constraint may "
                         f"depend on coordinates and time only (state it with "
                         f"model.nonholonomic)")
    if f == 0:
        raise ModelError(f"{where} is identically zero; leave it out")
    q = to_plain[c.dependent]
    if q not in free_symbols([f]):
        raise ModelError(f"{where} does not contain its dependent coordinate {q}; "
                         f"choose a coordinate the constraint determines")
    row = sm.Add(*(f.diff(qj) * qdot[qj] for qj in coords if qj in free_symbols([f])),
                 f.diff(L.time))
    if c.speed is not None:
        speed = to_plain[c.speed]
    else:
        match = [u for u in speeds if qdot[q] == u]
        if not match:
            raise ModelError(f"{where}: no speed u with {q}' = u; name the dependent "
                             f"speed with speeds=[...]")
        speed = match[0]
    return _Row(c.name, row, speed, load, f, q)


def _motion_row(c, prep: Prepared, to_plain: dict) -> _Row:
    """A motion constraint's row as stated (``q'`` replaced by ``G``) and its dependent speed."""
    where = f"constraint {c.name!r}"
    if c.points:
        P, = c.points
        row = _material_velocity(prep, P, c.body, prep.frame_nodes[c.frame], c.axis)
        load = ("no_slip", (P.name,), c.frame.name, c.axis)
    else:
        row = prep.plain(c.expression, where)
        load = None
    if row == 0:
        raise ModelError(f"{where} is identically zero (the point cannot move along "
                         f"that axis); leave it out")
    return _Row(c.name, row, to_plain[c.dependent], load)


def _check(rows: list[_Row], eq: Equations) -> tuple[list, list]:
    """``(A, b)`` of the velocity form ``A u + b = 0`` (``A`` rows over every speed), after
    refusing constraints that cannot determine their dependent coordinates and speeds."""
    L = eq.layout
    speeds, coords = list(L.speeds), list(L.coordinates)
    moving_u = set(speeds)
    dep_q = [r.coordinate for r in rows if r.holonomic is not None]
    dep_u = [r.speed for r in rows]
    names = [r.name for r in rows]
    m, mh = len(rows), len(dep_q)
    _distinct(dep_q, "dependent coordinate")
    _distinct(dep_u, "dependent speed")
    if m >= len(speeds):
        raise ModelError(f"{m} constraints for {len(speeds)} speeds: at least one speed must "
                         f"stay independent")
    if mh >= len(coords):
        raise ModelError(f"{mh} configuration constraints for {len(coords)} coordinates: at "
                         f"least one coordinate must stay independent")
    A = [[r.row.diff(u) for u in speeds] for r in rows]
    if free_symbols([e for r in A for e in r]) & moving_u:
        bad = [n for n, r in zip(names, A) if free_symbols(r) & moving_u]
        raise ModelError(f"constraint(s) {bad} are not linear in the speeds; motion constraints "
                         f"must be A(q, t) u + b(q, t) = 0")
    zero = {u: sm.S.Zero for u in speeds}
    b = xreplace_dag([r.row for r in rows], zero)
    for u in dep_u:
        if all(A[i][speeds.index(u)] == 0 for i in range(m)):
            raise ModelError(f"dependent speed {u} appears in no constraint; choose speeds the "
                             f"constraints determine")
    _check_rank(A, [speeds.index(u) for u in dep_u], names, eq, L)
    return A, b


def _reorder(eq: Equations, prep: Prepared, rows: list[_Row], A: list, b: list) -> Equations:
    r"""``eq`` with the dependent speeds last (``M``, ``F``, the program's and the reactions'
    acceleration placeholders reordered) and its :class:`Constraints`: the velocity form in
    the new order and its acceleration bias :math:`\beta`."""
    L, qdot = eq.layout, prep.qdot
    speeds, coords = list(L.speeds), list(L.coordinates)
    holonomic = [r.holonomic for r in rows if r.holonomic is not None]
    dep_q = tuple(r.coordinate for r in rows if r.holonomic is not None)
    dep_u = [r.speed for r in rows]
    m, mh = len(rows), len(holonomic)
    independent = [u for u in speeds if u not in dep_u]
    order = [speeds.index(u) for u in independent + dep_u]
    A_new = [[r[k] for k in order] for r in A]
    vel = [sm.Add(*(a * speeds[k] for a, k in zip(r, order))) + bi for r, bi in zip(A_new, b)]
    beta = [sm.Add(*(c.diff(qj) * qdot[qj] for qj in coords if qj in free_symbols([c])),
                   c.diff(L.time)) for c in vel]

    layout = Layout(L.coordinates, tuple(independent), L.parameters, L.inputs, L.time,
                    tuple(dep_u))
    n = len(speeds)
    M, F = eq.mass_matrix, eq.forcing
    acc_old = acceleration_symbols(n)
    acc_map = {acc_old[k]: acc_old[i] for i, k in enumerate(order)}
    program = eq.program.xreplace(acc_map) if eq.program else eq.program
    reactions = eq.reactions
    if reactions is not None:
        reactions = replace(reactions, matrix=sm.ImmutableMatrix(
            reactions.matrix.rows, reactions.matrix.cols,
            xreplace_dag(list(reactions.matrix), acc_map)))
    cons = Constraints(
        names=tuple(r.name for r in rows),
        holonomic=sm.ImmutableMatrix(mh, 1, holonomic),
        dependent_coordinates=dep_q,
        holonomic_jacobian=sm.ImmutableMatrix(mh, len(coords),
                                              [f.diff(q) for f in holonomic for q in coords]),
        velocity_matrix=sm.ImmutableMatrix(A_new),
        velocity_bias=sm.ImmutableMatrix(m, 1, b),
        acceleration_bias=sm.ImmutableMatrix(m, 1, beta),
        loads=tuple(r.load for r in rows))
    return replace(eq, layout=layout,
                   mass_matrix=sm.ImmutableMatrix(n, n, [M[i, j] for i in order for j in order]),
                   forcing=sm.ImmutableMatrix(n, 1, [F[i] for i in order]),
                   program=program if isinstance(program, Program) else Program(),
                   accelerations=None, reactions=reactions, constraints=cons, residual=None,
                   residual_jacobian=None, pairs=None)


def ordered(model) -> list:
    """The model's constraints in the order of their rows: configuration ones first."""
    return ([c for c in model.constraints_ if configuration(c)]
            + [c for c in model.constraints_ if not configuration(c)])


def _material_velocity(prep: Prepared, P, body, fnode, axis):
    """``v . e_axis`` of the point of ``body`` at ``P``: ``v_G + w x (r_P - r_G)``."""
    tree = prep.tree
    e = unit(axis)
    G = body.center if hasattr(body, "center") else body.point
    terms = [tree.dot(tree.atom_velocity(a), a.frame, e, fnode) for a in prep.point_atoms[G]]
    if hasattr(body, "frame"):
        B = prep.frame_nodes[body.frame]
        w = tree.omega(B)
        for s, a in signed_atoms(prep.point_atoms[P], prep.point_atoms[G]):
            wa = tree.express(w, B, a.frame)
            terms.append(s * tree.dot(cross(wa, a.c), a.frame, e, fnode))
    return sm.Add(*terms)


def _distinct(symbols, what):
    seen = set()
    for s in symbols:
        if s in seen:
            raise ModelError(f"{s} is the {what} of two constraints; each constraint needs its own")
        seen.add(s)


def _check_rank(A, dep_cols, names, eq, L) -> None:
    """Refuse redundant constraints: ``A_r`` singular at random states (all three tried)."""
    m = len(A)
    Ar = sm.Matrix([[row[k] for k in dep_cols] for row in A])
    symbols = sorted(free_symbols(list(Ar)), key=str)
    if not symbols:
        numeric = np.array(Ar.tolist(), dtype=float)
        if np.linalg.matrix_rank(numeric) < m:
            raise ModelError(_redundant(names))
        return
    f = sm.lambdify(symbols, Ar, modules="numpy")
    rng = np.random.default_rng(12345)
    defaults = eq.defaults
    for _ in range(3):
        values = [defaults.get(str(s), rng.uniform(0.3, 1.7)) for s in symbols]
        values = [v if str(s) in defaults else rng.uniform(-1.3, 1.3) if s in L.states else v
                  for s, v in zip(symbols, values)]
        with np.errstate(all="ignore"):
            numeric = np.array(f(*values), dtype=float)
        if np.all(np.isfinite(numeric)) and np.linalg.matrix_rank(numeric) == m:
            return
    raise ModelError(_redundant(names))


def _redundant(names) -> str:
    return (f"the constraints {list(names)} are redundant or do not determine their dependent "
            f"speeds (the dependent block of the constraint Jacobian is singular at random "
            f"states); drop a redundant constraint or choose other dependent speeds")
