r"""Kane's method on the kinematic tree, with terms grouped by shared atoms.

With partial velocities :math:`v_{k,r} = \partial v_k/\partial u_r` and partial
angular velocities :math:`\omega_{k,r}` (the lecture notes' "tangent vectors"),
Kane's equations :math:`F_r + F_r^* = 0` give :math:`M u' = F` with

.. math::

    M_{rs} &= \sum_k m_k\, v_{k,r}\cdot v_{k,s} + \omega_{k,r}\cdot I_k\,\omega_{k,s} \\
    F_r &= \sum_k v_{k,r}\cdot(R_k - m_k a^t_k)
          + \omega_{k,r}\cdot(T_k - I_k\alpha^t_k - \omega_k\times I_k\omega_k)

where :math:`a^t, \alpha^t` are accelerations with every :math:`u' = 0`; a speed's
armature :math:`a_k` (:meth:`mbgen.Model.armature`) adds to :math:`M_{kk}` alone.

A mass centre's velocity is a sum of atom velocities (see
:mod:`mbgen.derivation.tree`), so the translational sums regroup as

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

from ..symbolic.equations import Equations
from ..symbolic.program import Program
from .common import Grouping, Wants, energies, line_coefficient, point_kinematics
from .prepare import Prepared
from .reactions import reactions_for
from .tree import S0, add, cross, dot3, matvec, mul, vadd, vneg

NEG = sm.S.NegativeOne


def kane(prep: Prepared, wants: Wants) -> Equations:
    """Derive ``M u' = F``, ``q' = G`` for a prepared model with Kane's method.

    With ``wants.energy`` the kinetic energy and the potential of gravity and
    springs are derived too (about a fifth of the derivation time on a long
    chain).  ``wants.points`` names points whose position and velocity
    (Newtonian components) the equations should carry.  With
    ``wants.reactions`` the joint reactions are derived by the Newton–Euler
    inward pass (:func:`mbgen.derivation.reactions.reactions_for`).

    ``M`` (its lower triangle) and the terms of ``F`` are gathered in three passes,
    in this order: :func:`_translational`, :func:`_rotational`, :func:`_applied`.
    """
    model = prep.model
    layout = prep.layout
    nu = layout.n_u
    grp = Grouping(prep)
    M = [[S0] * nu for _ in range(nu)]
    F: list[list] = [[] for _ in range(nu)]
    _translational(prep, grp, M, F)
    _rotational(prep, M, F)
    _applied(prep, F)
    for k, a in prep.armature:      # armature: M_kk += a_k
        M[k][k] = add(M[k][k], a)
    for r in range(nu):
        for s in range(r):
            M[s][r] = M[r][s]
    kinetic, potential = energies(prep, grp) if wants.energy else (None, None)
    if kinetic is not None and prep.armature:
        kinetic = add(kinetic, prep.armature_energy())
    program, loads = reactions_for(prep) if wants.reactions else (Program(), None)
    return Equations(
        name=model.name,
        layout=layout,
        mass_matrix=sm.ImmutableMatrix(M),
        forcing=sm.ImmutableMatrix([add(*f) for f in F]),
        kinematics=sm.ImmutableMatrix([prep.qdot[q] for q in layout.coordinates]),
        kinetic_energy=kinetic,
        potential_energy=potential,
        points=point_kinematics(prep, wants.points),
        source=f"mbgen.Model {model.name!r}",
        method="kane",
        program=program,
        reactions=loads,
    )


def _translational(prep: Prepared, grp: Grouping, M: list, F: list) -> None:
    r"""The masses' translational terms, over pairs of atoms (see the module docstring):
    sets ``M[r][s]`` (``s <= r``) and adds
    :math:`-\sum (\sum m)\, v_{a,r}\cdot a^t_b` and gravity's share to ``F[r]``."""
    tree = prep.tree
    nu = len(M)
    # atoms with a nonzero partial velocity for each speed (mass atoms only)
    with_partial: list[list[int]] = [[] for _ in range(nu)]
    for i in sorted(grp.bodies_of):
        for r in tree.atom_partials(grp.atom[i]):
            with_partial[r].append(i)
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


def _rotational(prep: Prepared, M: list, F: list) -> None:
    r"""The rigid bodies' rotational terms: adds :math:`\omega_{k,r}\cdot I_k\omega_{k,s}`
    to ``M[r][s]`` (``s <= r``) and
    :math:`-\omega_{k,r}\cdot(I_k\alpha^t_k + \omega_k\times I_k\omega_k)` to ``F[r]``."""
    tree = prep.tree
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


def _applied(prep: Prepared, F: list) -> None:
    """The generalized forces of the applied loads (gravity aside: :func:`_translational`):
    forces through the partial velocities of their points, torques through the partial
    angular velocities of their frames, springs and dampers (:func:`_line_forces`)."""
    tree = prep.tree
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


def _line_forces(tree, el, atoms) -> dict[int, sm.Expr]:
    r"""Generalized forces of a spring/damper: :math:`F_r = f\,(d\cdot v_{d,r})` (see
    :func:`~mbgen.derivation.common.line_coefficient`)."""
    coef, d = line_coefficient(tree, el, atoms)
    if not d:
        return {}
    out: dict[int, list] = defaultdict(list)
    for s, a in atoms:
        for r, va in tree.atom_partials(a).items():
            proj = add(*(tree.dot(va, a.frame, c, f) for f, c in d))
            out[r].append(proj if s > 0 else mul(NEG, proj))
    return {r: mul(coef, add(*terms)) for r, terms in sorted(out.items())}
