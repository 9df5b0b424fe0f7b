"""Derivation pieces shared by Kane's method and Newton–Euler.

What a derivation is asked for (:class:`Wants`), and the energies, point
kinematics and geometry of springs and dampers, which depend on the model's
kinematic tree only, not on how the equations of motion are formed.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

import sympy as sm

from ..errors import ModelError
from ..symbolic.equations import PointKinematics
from ..symbolic.graph import count_ops_dag
from .prepare import Prepared
from .tree import S0, add, dot3, matvec, mul, vadd, vneg

NEG = sm.S.NegativeOne
HALF = sm.Rational(1, 2)


@dataclass(frozen=True)
class Wants:
    """What a derivation is asked to add to ``M u' = F`` and ``q' = G``.

    ``energy``: the kinetic and potential energy; ``points``: names of points
    whose Newtonian position and velocity to carry; ``reactions``: the joint
    reactions; ``jacobian``: the residual's state Jacobian where a derivation has
    an analytic one (:mod:`mbgen.derivation.rnea_partials`).
    """

    energy: bool = True
    points: tuple[str, ...] = ()
    reactions: bool = False
    jacobian: bool = False


class Grouping:
    """Which masses contain which atoms, and shared mass sums."""

    def __init__(self, prep: Prepared):
        self.masses = prep.masses
        self.bodies_of: dict[int, frozenset] = {}
        members = defaultdict(set)
        for k, me in enumerate(self.masses):
            for a in me.atoms:
                members[a.index].add(k)
        self.bodies_of = {i: frozenset(s) for i, s in members.items()}
        self.atom = {a.index: a for me in self.masses for a in me.atoms}
        # atoms that share at least one mass with atom i
        self.cooccur: dict[int, list[int]] = {}
        for i, ks in self.bodies_of.items():
            self.cooccur[i] = sorted({a.index for k in ks for a in self.masses[k].atoms})
        self._sums: dict[frozenset, sm.Expr] = {}

    def mass_sum(self, ks: frozenset) -> sm.Expr:
        hit = self._sums.get(ks)
        if hit is None:
            hit = add(*(self.masses[k].mass for k in sorted(ks)))
            self._sums[ks] = hit
        return hit


def point_kinematics(prep: Prepared, names) -> tuple[PointKinematics, ...]:
    """Position and velocity of each named point, summed over its atoms in Newtonian components."""
    tree = prep.tree
    root = prep.frame_nodes[prep.model.N]
    by_name = {p.name: p for p in prep.point_atoms}
    out = []
    for name in names:
        if name not in by_name:
            raise ModelError(f"model {prep.model.name!r} has no point {name!r}; points: "
                             f"{', '.join(sorted(by_name))}")
        atoms = prep.point_atoms[by_name[name]]
        pos = vadd(*(tree.express(a.c, a.frame, root) for a in atoms)) if atoms else (S0,) * 3
        vel = (vadd(*(tree.express(tree.atom_velocity(a), a.frame, root) for a in atoms))
               if atoms else (S0,) * 3)
        out.append(PointKinematics(name, sm.ImmutableMatrix(pos), sm.ImmutableMatrix(vel)))
    return tuple(out)


def line_geometry(tree, atoms):
    """Per-frame sums of the signed atoms of ``d = r_a - r_b``, and ``L**2``."""
    by_frame: dict = {}
    order = []
    for sign, a in atoms:
        c = a.c if sign > 0 else vneg(a.c)
        if a.frame not in by_frame:
            order.append(a.frame)
            by_frame[a.frame] = c
        else:
            by_frame[a.frame] = vadd(by_frame[a.frame], c)
    d = [(f, by_frame[f]) for f in order]
    L2 = add(*(mul(sm.Integer(1 if i == j else 2), tree.dot(ci, fi, cj, fj))
               for i, (fi, ci) in enumerate(d) for j, (fj, cj) in enumerate(d) if j >= i))
    return d, L2


def stretch(L2, L0):
    r"""``L - L0`` as :math:`(L^2 - L_0^2)/(L + L_0)`, without cancellation near ``L = L0``.

    Written as ``sqrt(L2) - L0``, a stiff spring near its natural length loses
    ``L0 * eps`` of stretch to rounding (the stress suite measured relative
    right-hand-side errors of 1e-9 at k = 1e8).  Expanding ``L2 - L0**2`` (when it
    is small) cancels the ``L0**2`` exactly: ``(l + s)**2 - l**2 -> s**2 + 2 l s``.
    """
    num = L2 - L0**2
    if count_ops_dag([num]) <= 400:
        num = sm.expand(num)
    return mul(num, 1 / (sm.sqrt(L2) + L0))


def line_coefficient(tree, el, atoms):
    r"""``(f, d)``: the force on point ``a`` of a spring/damper is :math:`f\,d`.

    ``d = r_a - r_b`` as per-frame terms ``[(frame, components)]`` and
    :math:`f = -k(L - L_0)/L - c\,(d\cdot\dot d)/L^2` (``-k`` when :math:`L_0=0`).
    ``f`` is ``None`` when the element has no length terms.
    """
    d, L2 = line_geometry(tree, atoms)
    if not d:
        return None, d
    coef = S0
    if el.stiffness != 0:
        if el.natural_length == 0:
            coef = mul(NEG, el.stiffness)
        else:
            L = sm.sqrt(L2)
            coef = mul(NEG, mul(el.stiffness, mul(stretch(L2, el.natural_length), 1 / L)))
    if el.damping != 0:
        ddot = add(*(mul(sm.Integer(s), tree.dot(tree.atom_velocity(a), a.frame, c, f))
                     for s, a in atoms for f, c in d))
        coef = add(coef, mul(NEG, mul(el.damping, mul(ddot, 1 / L2))))
    return coef, d


def energies(prep: Prepared, grp: Grouping):
    """Kinetic energy and the potential of gravity and springs."""
    return kinetic_energy(prep, grp), potential_energy(prep, grp)


def kinetic_energy(prep: Prepared, grp: Grouping):
    """``T`` from the atoms' velocities (Kane's derivation; Newton-Euler's is its recursion's)."""
    tree = prep.tree
    T = []
    for i in sorted(grp.bodies_of):
        a = grp.atom[i]
        va = tree.atom_velocity(a)
        for j in grp.cooccur[i]:
            if j < i:
                continue
            b = grp.atom[j]
            d = tree.dot(va, a.frame, tree.atom_velocity(b), b.frame)
            common = grp.bodies_of[i] & grp.bodies_of[j]
            T.append(mul(sm.Integer(1 if i == j else 2), mul(grp.mass_sum(common), d)))
    for me in prep.masses:
        if me.frame is not None:
            w = tree.omega(me.frame)
            T.append(dot3(w, matvec(me.inertia, w)))
    return mul(HALF, add(*T))


def potential_energy(prep: Prepared, grp: Grouping):
    """``V``: gravity's potential and the springs' energy."""
    tree = prep.tree
    V = []
    if prep.gravity:
        for i in sorted(grp.bodies_of):
            a = grp.atom[i]
            g = add(*(tree.dot(a.c, a.frame, gv, gf) for gf, gv in prep.gravity))
            V.append(mul(NEG, mul(grp.mass_sum(grp.bodies_of[i]), g)))
    for el, atoms in prep.lines:
        if el.stiffness == 0:
            continue
        _, L2 = line_geometry(tree, atoms)
        squared = L2 if el.natural_length == 0 else stretch(L2, el.natural_length) ** 2
        V.append(mul(HALF, mul(el.stiffness, squared)))
    return add(*V)
