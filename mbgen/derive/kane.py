r"""Kane's method on the kinematic tree, with terms grouped by shared atoms.

With partial velocities :math:`v_{k,r} = \partial v_k/\partial u_r` and partial
angular velocities :math:`\omega_{k,r}` (the lecture notes' "tangent vectors"),
Kane's equations :math:`F_r + F_r^* = 0` give :math:`M u' = F` with

.. math::

    M_{rs} &= \sum_k m_k\, v_{k,r}\cdot v_{k,s} + \omega_{k,r}\cdot I_k\,\omega_{k,s} \\
    F_r &= \sum_k v_{k,r}\cdot(R_k - m_k a^t_k)
          + \omega_{k,r}\cdot(T_k - I_k\alpha^t_k - \omega_k\times I_k\omega_k)

where :math:`a^t, \alpha^t` are accelerations with every :math:`u' = 0`.

A mass centre's velocity is a sum of atom velocities (see
:mod:`mbgen.derive.tree`), so the translational sums regroup as

.. math::

    M_{rs} = \sum_{a, b} \Big(\sum_{k \ni a, b} m_k\Big)\, v_{a,r}\cdot v_{b,s},
    \qquad
    F_r \mathrel{+}= -\sum_{a, b} \Big(\sum_{k \ni a, b} m_k\Big)\, v_{a,r}\cdot a^t_b

over pairs of atoms, each mass sum built once and shared.  For a chain whose
atoms each depend on one speed (the n-link pendulum on a cart) this makes
``M`` and ``F`` of size O(n^2) rather than O(n^3).
"""

from __future__ import annotations

from collections import defaultdict

import sympy as sm

from ..equations import Equations, PointKinematics
from ..errors import ModelError
from ..model import Model
from ..symbolic import count_ops_dag
from .prepare import Prepared, prepare
from .tree import S0, add, cross, dot3, matvec, mul, vadd, vneg

NEG = sm.S.NegativeOne
HALF = sm.Rational(1, 2)


class _Grouping:
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


def kane(model: Model, energy: bool = True, points=()) -> Equations:
    """Derive ``M u' = F``, ``q' = G`` for ``model`` with Kane's method.

    With ``energy`` the kinetic energy and the potential of gravity and springs
    are derived too (about a fifth of the derivation time on a long chain).
    ``points`` names points whose position and velocity (Newtonian components)
    the equations should carry.
    """
    prep = prepare(model)
    tree, layout = prep.tree, prep.layout
    nu = layout.n_u
    grp = _Grouping(prep)

    # atoms with a nonzero partial velocity for each speed (mass atoms only)
    with_partial: list[list[int]] = [[] for _ in range(nu)]
    for i in sorted(grp.bodies_of):
        for r in tree.atom_partials(grp.atom[i]):
            with_partial[r].append(i)

    M = [[S0] * nu for _ in range(nu)]
    F = [[] for _ in range(nu)]

    # translational inertia --------------------------------------------------
    for r in range(nu):
        for s in range(r + 1):
            terms = []
            for i in with_partial[r]:
                a = grp.atom[i]
                va = tree.atom_partials(a)[r]
                for j in with_partial[s]:
                    common = grp.bodies_of[i] & grp.bodies_of[j]
                    if common:
                        b = grp.atom[j]
                        d = tree.dot(va, a.frame, tree.atom_partials(b)[s], b.frame)
                        terms.append(mul(grp.mass_sum(common), d))
            M[r][s] = add(*terms)
        for i in with_partial[r]:
            a = grp.atom[i]
            va = tree.atom_partials(a)[r]
            for j in grp.cooccur[i]:
                b = grp.atom[j]
                d = tree.dot(va, a.frame, tree.atom_acceleration_rest(b), b.frame)
                if d != 0:
                    common = grp.bodies_of[i] & grp.bodies_of[j]
                    F[r].append(mul(NEG, mul(grp.mass_sum(common), d)))
            if prep.gravity:
                g = add(*(tree.dot(va, a.frame, gv, gf) for gf, gv in prep.gravity))
                F[r].append(mul(grp.mass_sum(grp.bodies_of[i]), g))

    # rotational inertia ---------------------------------------------------------
    for me in prep.masses:
        if me.frame is None:
            continue
        I, B = me.inertia, me.frame
        w = tree.omega(B)
        wr = tree.omega_partials(B)
        Iw = {r: matvec(I, v) for r, v in wr.items()}
        torque = vneg(vadd(matvec(I, tree.alpha_rest(B)), cross(w, matvec(I, w))))
        for r, v in wr.items():
            for s in wr:
                if s <= r:
                    M[r][s] = add(M[r][s], dot3(v, Iw[s]))
            F[r].append(dot3(v, torque))

    # applied loads --------------------------------------------------------------
    for atoms, vec in prep.forces:
        for sign, a in atoms:
            for r, va in tree.atom_partials(a).items():
                f = add(*(tree.dot(va, a.frame, c, n) for n, c in vec))
                F[r].append(f if sign > 0 else mul(NEG, f))
    for node, sign, vec in prep.torques:
        T = vadd(*(tree.express(c, n, node) for n, c in vec)) if vec else None
        if T is None:
            continue
        for r, w in tree.omega_partials(node).items():
            f = dot3(w, T)
            F[r].append(f if sign > 0 else mul(NEG, f))
    for el, atoms in prep.lines:
        for r, f in _line_forces(tree, el, atoms).items():
            F[r].append(f)

    for r in range(nu):
        for s in range(r):
            M[s][r] = M[r][s]
    kinetic, potential = _energies(prep, grp) if energy else (None, None)
    return Equations(
        name=model.name,
        layout=layout,
        mass_matrix=sm.ImmutableMatrix(M),
        forcing=sm.ImmutableMatrix([add(*f) for f in F]),
        kinematics=sm.ImmutableMatrix([prep.qdot[q] for q in layout.coordinates]),
        kinetic_energy=kinetic,
        potential_energy=potential,
        points=_point_kinematics(prep, points),
        source=f"mbgen.Model {model.name!r}",
        method="kane",
    )


def _point_kinematics(prep: Prepared, names) -> tuple[PointKinematics, ...]:
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


def _line_geometry(tree, atoms):
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


def _stretch(L2, L0):
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


def _line_forces(tree, el, atoms) -> dict[int, sm.Expr]:
    r"""Generalized forces of a spring/damper: :math:`F_r = f\,(d\cdot v_{d,r})`.

    The force on point ``a`` is :math:`f\,d` with
    :math:`f = -k(L - L_0)/L - c\,(d\cdot\dot d)/L^2` (``-k`` when :math:`L_0=0`).
    """
    d, L2 = _line_geometry(tree, atoms)
    if not d:
        return {}
    coef = S0
    if el.stiffness != 0:
        if el.natural_length == 0:
            coef = mul(NEG, el.stiffness)
        else:
            L = sm.sqrt(L2)
            coef = mul(NEG, mul(el.stiffness, mul(_stretch(L2, el.natural_length), 1 / L)))
    if el.damping != 0:
        ddot = add(*(mul(sm.Integer(s), tree.dot(tree.atom_velocity(a), a.frame, c, f))
                     for s, a in atoms for f, c in d))
        coef = add(coef, mul(NEG, mul(el.damping, mul(ddot, 1 / L2))))
    out: dict[int, list] = defaultdict(list)
    for s, a in atoms:
        for r, va in tree.atom_partials(a).items():
            proj = add(*(tree.dot(va, a.frame, c, f) for f, c in d))
            out[r].append(proj if s > 0 else mul(NEG, proj))
    return {r: mul(coef, add(*terms)) for r, terms in sorted(out.items())}


def _energies(prep: Prepared, grp: _Grouping):
    """Kinetic energy and the potential of gravity and springs."""
    tree = prep.tree
    ids = sorted(grp.bodies_of)
    T = []
    for i in ids:
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
    V = []
    if prep.gravity:
        for i in ids:
            a = grp.atom[i]
            g = add(*(tree.dot(a.c, a.frame, gv, gf) for gf, gv in prep.gravity))
            V.append(mul(NEG, mul(grp.mass_sum(grp.bodies_of[i]), g)))
    for el, atoms in prep.lines:
        if el.stiffness == 0:
            continue
        _, L2 = _line_geometry(tree, atoms)
        stretch = L2 if el.natural_length == 0 else _stretch(L2, el.natural_length) ** 2
        V.append(mul(HALF, mul(el.stiffness, stretch)))
    return mul(HALF, add(*T)), add(*V)
