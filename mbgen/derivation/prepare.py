"""From a user's :class:`~mbgen.model.builder.Model` to plain symbols and a kinematic tree.

This stage removes time dependence (``q1(t) -> q1``, ``q1'(t) -> G_1(q, u, t)``),
checks that every symbol is declared, solves the kinematic differential
equations for ``q'``, and builds the :class:`~mbgen.derivation.tree.KinematicTree`
with one atom per frame of every point offset.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial

import sympy as sm

from ..errors import ModelError
from ..model.builder import Model
from ..model.builder import t as TIME
from ..model.elements import Force, Gravity, LineElement, Torque
from ..symbolic.graph import applied_functions, free_symbols, walk_unique
from ..symbolic.layout import Layout
from .tree import Atom, FrameNode, KinematicTree, Vec3


@dataclass(frozen=True)
class MassElement:
    """A particle, or the mass part of a rigid body, in tree terms."""

    name: str
    atoms: tuple[Atom, ...]
    mass: sm.Expr
    frame: FrameNode | None = None
    inertia: tuple | None = None  # 3x3 rows in ``frame`` components
    point: object = None          # the model's Point (particle, or mass centre)


@dataclass(frozen=True, eq=False)
class Prepared:
    """Everything a derivation needs, in plain symbols: one value per model, built by
    :func:`prepare` and shared by the choice of method and every derivation of the model.

    Attributes
    ----------
    model : Model
    layout : Layout
    tree : KinematicTree
        Frames and atoms; it memoises what it computes, nothing else about it changes.
    qdot : dict
        Coordinate -> ``G(q, u, t)`` of ``q' = G``.
    frame_nodes : dict
        ReferenceFrame -> FrameNode.
    point_atoms : dict
        Point -> tuple of Atom (the offsets from the origin).
    masses : tuple of MassElement
    gravity : tuple of (FrameNode, Vec3), or None
    forces : tuple of (signed atoms, vector terms)
    torques : tuple of (FrameNode, sign, vector terms)
    lines : tuple of (LineElement, signed atoms)
    to_plain, known : dict, set
        Functions of time (and coordinates' derivatives) -> plain symbols (and ``G``), and
        every symbol an expression may hold: what :meth:`plain` reads.
    outward : NewtonEuler or None
        The Newton–Euler outward pass of the model where the choice of method has run it
        (:func:`mbgen.derivation.choose_method`), for the derivations to fork rather than
        run again (:func:`mbgen.derivation.recursion.outward_pass`); None before that.
    armature : tuple of (int, Expr)
        ``(k, a_k)``: the generalized inertia :math:`a_k` on speed ``k`` (layout order) of
        each :meth:`~mbgen.Model.armature`; every method adds it to :math:`M_{kk}`.
    """

    model: Model
    layout: Layout
    tree: KinematicTree
    qdot: dict
    frame_nodes: dict
    point_atoms: dict
    masses: tuple
    gravity: tuple | None
    forces: tuple = ()
    torques: tuple = ()
    lines: tuple = ()
    to_plain: dict = field(default_factory=dict, repr=False)
    known: frozenset = field(default_factory=frozenset, repr=False)
    outward: object = field(default=None, repr=False)
    armature: tuple = ()

    def plain(self, expr, where: str) -> sm.Expr:
        """``expr`` in plain symbols; :class:`ModelError` naming ``where`` if it holds
        undeclared symbols or other functions of time."""
        return _plain(expr, where, self.to_plain, self.known)

    def terms(self, vector, where: str) -> list[tuple[FrameNode, Vec3]]:
        """A sympy Vector as ``[(node, components)]``, one per frame, zeros dropped."""
        return _terms(vector, where, self.frame_nodes, self.plain)

    def armature_energy(self) -> sm.Expr:
        r""":math:`\tfrac12 \sum_k a_k u_k^2`, the kinetic energy of the armature."""
        speeds = self.layout.speeds
        return sm.Rational(1, 2) * sm.Add(*(a * speeds[k] ** 2 for k, a in self.armature))


def prepare(model: Model) -> Prepared:
    """Convert ``model`` to plain symbols and build its kinematic tree.

    In order: the layout and ``q' = G`` (:func:`_solve_kinematics`), the frames
    (:func:`_frame_nodes`, :func:`_angular_velocities`), the points' atoms, the masses
    and the loads.

    Raises
    ------
    ModelError
        Missing Newtonian frame or masses, unknown symbols, kinematic equations
        that do not determine ``q'``.
    """
    if model.N is None:
        raise ModelError(f"model {model.name!r} has no Newtonian frame; call model.newtonian()")
    if not model.particles and not model.bodies:
        raise ModelError(f"model {model.name!r} has no particles or bodies, so no mass matrix")
    if not model.coordinates_ or not model.speeds_:
        raise ModelError(f"model {model.name!r} needs coordinates and speeds "
                         f"(model.coordinates(...), model.speeds(...))")

    q_f, u_f, r_f = model.coordinates_, model.speeds_, model.inputs_
    q = tuple(sm.Symbol(str(s.func)) for s in q_f)
    u = tuple(sm.Symbol(str(s.func)) for s in u_f)
    r = tuple(sm.Symbol(str(s.func)) for s in r_f)
    time = sm.Symbol(str(TIME))
    layout = Layout(q, u, tuple(model.constants_), r, time)

    base = dict(zip(q_f, q)) | dict(zip(u_f, u)) | dict(zip(r_f, r))
    qdot = _solve_kinematics(model, base, q, u, layout)
    to_plain = {qf.diff(TIME): qdot[qs] for qf, qs in zip(q_f, q)} | base
    known = layout.symbols()
    plain = partial(_plain, to_plain=to_plain, known=known)

    tree = KinematicTree(q, u, qdot, time)
    nodes = _frame_nodes(model, tree, plain)
    terms = partial(_terms, nodes=nodes, plain=plain)
    _angular_velocities(model, tree, nodes, terms)
    point_atoms: dict = {}
    for point, pd in model.points.items():
        own = tuple(tree.add_atom(n, c, f"{point.name}/{n.name}")
                    for n, c in terms(pd.offset, f"the offset of point {point.name}"))
        point_atoms[point] = (point_atoms[pd.parent] if pd.parent is not None else ()) + own
    masses = _masses(model, point_atoms, nodes, plain)
    gravity, forces, torques, lines = _loads(model, point_atoms, nodes, plain, terms)
    armature = tuple((u_f.index(a.speed), plain(a.value, f"armature on {a.speed.func}"))
                     for a in model.armatures_)
    return Prepared(model, layout, tree, qdot, nodes, point_atoms, masses, gravity, forces,
                    torques, lines, to_plain, known, armature=armature)


def _plain(expr, where: str, to_plain: dict, known) -> sm.Expr:
    e = sm.sympify(expr).xreplace(to_plain)
    funcs = applied_functions([e])
    derivs = {n for n in walk_unique([e]) if isinstance(n, sm.Derivative)}
    if funcs or derivs:
        bad = sorted(map(str, funcs | derivs))
        raise ModelError(f"{where} contains {', '.join(bad)}: only declared coordinates, "
                         f"their first derivatives, speeds and inputs may depend on time")
    unknown = free_symbols([e]) - known
    if unknown:
        names = ", ".join(sorted(map(str, unknown)))
        raise ModelError(f"{where} contains unknown symbol(s) {names}; declare them with "
                         f"model.constants('{names.replace(',', '')}')")
    return e


def _terms(vector, where: str, nodes: dict, plain) -> list[tuple[FrameNode, Vec3]]:
    if isinstance(vector, (int, float)) or vector == 0:
        return []
    out = []
    for matrix, frame in vector.args:
        if frame not in nodes:
            raise ModelError(f"{where} uses frame {frame}, which is not part of the model")
        comps = tuple(plain(c, where) for c in matrix)
        if any(c != 0 for c in comps):
            out.append((nodes[frame], comps))
    return out


def _frame_nodes(model: Model, tree: KinematicTree, plain) -> dict:
    """ReferenceFrame -> FrameNode, parents first: simple rotations and direction cosines."""
    nodes: dict = {}
    for frame, fd in model.frames.items():
        if fd.parent is None:
            nodes[frame] = tree.add_root(frame.name)
        elif fd.dcm is not None:
            nodes[frame] = tree.add_dcm(frame.name, nodes[fd.parent], tuple(
                tuple(plain(fd.dcm[i, j], f"the rotation of frame {frame.name}")
                      for j in range(3)) for i in range(3)))
        else:
            angle = plain(fd.angle, f"the rotation angle of frame {frame.name}")
            nodes[frame] = tree.add_rotation(frame.name, nodes[fd.parent], fd.axis, angle)
    return nodes


def _angular_velocities(model: Model, tree: KinematicTree, nodes: dict, terms) -> None:
    """Stated angular velocities (``Model.orient(..., angular_velocity=)``) set on their nodes."""
    for frame, fd in model.frames.items():
        if fd.angular_velocity is not None:
            node = nodes[frame]
            w = [tree.express(c, n, node) for n, c in terms(fd.angular_velocity,
                                                             f"angular velocity of {frame}")]
            tree.set_omega(node, tuple(sm.Add(*(v[i] for v in w)) for i in range(3)) if w
                           else (sm.S.Zero,) * 3)


def _masses(model: Model, point_atoms: dict, nodes: dict, plain) -> tuple:
    """The particles, then the rigid bodies, as :class:`MassElement` values."""
    masses = [MassElement(p.name, point_atoms[p.point], plain(p.mass, f"mass of {p.name}"),
                          point=p.point) for p in model.particles]
    for b in model.bodies:
        inertia = tuple(tuple(plain(b.inertia[i, j], f"inertia of {b.name}") for j in range(3))
                        for i in range(3))
        masses.append(MassElement(b.name, point_atoms[b.center], plain(b.mass, f"mass of {b.name}"),
                                  nodes[b.frame], inertia, b.center))
    return tuple(masses)


def _loads(model: Model, point_atoms: dict, nodes: dict, plain, terms) -> tuple:
    """``(gravity, forces, torques, lines)`` of :class:`Prepared` from the model's loads."""
    gravity, forces, torques, lines = None, [], [], []
    for load in model.loads:
        if isinstance(load, Gravity):
            gravity = tuple(terms(load.vector, "gravity"))
        elif isinstance(load, Force):
            atoms = signed_atoms(point_atoms[load.point],
                                 point_atoms[load.reaction] if load.reaction is not None else ())
            forces.append((atoms, terms(load.vector, f"force at {load.point}")))
        elif isinstance(load, Torque):
            vec = terms(load.vector, f"torque on {load.frame}")
            torques.append((nodes[load.frame], 1, vec))
            if load.reaction is not None:
                torques.append((nodes[load.reaction], -1, vec))
        elif isinstance(load, LineElement):
            el = LineElement(load.name, load.a, load.b,
                             plain(load.stiffness, f"stiffness of {load.name}"),
                             plain(load.damping, f"damping of {load.name}"),
                             plain(load.natural_length, f"natural length of {load.name}"))
            lines.append((el, signed_atoms(point_atoms[load.a], point_atoms[load.b])))
        else:  # pragma: no cover - Model only creates the types above
            raise ModelError(f"unknown load {load!r}")
    return gravity, tuple(forces), tuple(torques), tuple(lines)


def signed_atoms(plus, minus) -> tuple[tuple[int, Atom], ...]:
    """Atoms of ``r_plus - r_minus`` with signs; atoms shared by both cancel."""
    shared = set(plus) & set(minus)
    return tuple([(1, a) for a in plus if a not in shared] +
                 [(-1, a) for a in minus if a not in shared])


def _solve_kinematics(model: Model, base: dict, q, u, layout: Layout) -> dict:
    """Solve the kinematic differential equations for ``q' = G(q, u, t)``.

    Coordinates whose derivative appears in no equation are paired, in order,
    with speeds that appear in no equation (``u_i = q_i'``).
    """
    qd = tuple(sm.Symbol(f"{s}_dot_") for s in q)
    sub = {qf.diff(TIME): d for qf, d in zip(model.coordinates_, qd)} | base
    eqs = [sm.sympify(e).xreplace(sub) for e in model.kinematic_equations_]
    used = free_symbols(eqs) if eqs else set()
    free_q = [i for i, d in enumerate(qd) if d not in used]
    free_u = [j for j, s in enumerate(u) if s not in used]
    if len(free_q) != len(free_u) and (free_q or free_u):
        raise ModelError(
            f"cannot pair coordinates {[str(q[i]) for i in free_q]} with speeds "
            f"{[str(u[j]) for j in free_u]} (u = q'): give kinematic equations with "
            f"model.kinematics({{q: ...}}) or model.kinematic_equations([...])")
    eqs += [qd[i] - u[j] for i, j in zip(free_q, free_u)]
    if len(eqs) != len(q):
        raise ModelError(f"{len(eqs)} kinematic equations for {len(q)} coordinates; "
                         f"need exactly one per coordinate")
    A, b = sm.linear_eq_to_matrix(eqs, qd)
    if free_symbols(list(A)) & set(qd):
        raise ModelError("the kinematic equations are not linear in the coordinate derivatives")
    if A == sm.eye(len(q)):
        sol = list(b)
    else:
        if A.det(method="berkowitz") == 0:
            raise ModelError("the kinematic equations do not determine every q' (singular system)")
        sol = list(A.LUsolve(b))
        sol = [_tidy(e) for e in sol]
    known = layout.symbols()
    for e in sol:
        unknown = e.free_symbols - known
        if unknown:
            raise ModelError(f"kinematic equations contain unknown symbol(s) "
                             f"{sorted(map(str, unknown))}; declare them with model.constants()")
    return dict(zip(q, sol))


def _tidy(expr: sm.Expr) -> sm.Expr:
    """Simplify a small kinematic expression (``trigsimp`` only when it is small)."""
    if sm.count_ops(expr) > 200:
        return expr
    simpler = sm.trigsimp(sm.cancel(sm.together(expr)))
    return simpler if sm.count_ops(simpler) <= sm.count_ops(expr) else expr
