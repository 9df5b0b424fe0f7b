r"""Joint reactions: the force and moment each joint's parent exerts on its child.

Newton's and Euler's laws for the subtree of body ``b`` give the reaction
that the parent exerts on ``b`` at its joint point ``J_b`` (the inward pass over
the quantities of :class:`~mbgen.derivation.recursion.NewtonEuler`),

.. math::

    f_b = \mathcal I_b \hat a_b - g_b - e_b + \sum_{c} X_c^T f_c,
    \qquad \hat a_b = X_b \hat a_p + S_b u'_b,

with ``u'`` the acceleration placeholders (the reactions hold for whatever
``M u' = F`` gives) and ``e_b`` the forces of point constraints on ``b``, in
multiplier placeholders.  Both derivation methods report reactions this way
(:func:`reactions_for`).
"""

from __future__ import annotations

from collections import defaultdict

import sympy as sm

from ..symbolic.equations import JointLoads, acceleration_symbols, lambda_symbols
from .constraints import configuration, ordered
from .joints import Body
from .prepare import Prepared, signed_atoms
from .recursion import NewtonEuler, outward_pass
from .spatial import split
from .tree import ZERO3, cross, unit, vadd, vscale


def constraint_loads(ne: NewtonEuler, constraints) -> dict:
    """Body -> [(moment, force)] of point constraints' forces, in multiplier placeholders.

    ``constraints`` in the order of their rows (multiplier ``k`` belongs to
    row ``k``): a ``no_slip`` row's force ``lambda_k e`` acts on its body at the
    contact point, a ``coincident`` row's ``lambda_k e`` on the body holding
    the first point and ``-lambda_k e`` on the body holding the second.
    Stated (expression) constraints have no point of application and give none.
    """
    prep, bt, tree = ne.prep, ne.bt, ne.tree
    lam = lambda_symbols(len(constraints))
    out: dict = defaultdict(list)
    by_element = {me.name: b for b in ne.bodies for me, _ in b.elements}
    for k, c in enumerate(constraints):
        if not c.points:
            continue
        node = prep.frame_nodes[c.frame]
        e = vscale(lam[k], unit(c.axis))
        if configuration(c):
            targets = [(c.points[0], bt.body_of_point(c.points[0]), 1),
                       (c.points[1], bt.body_of_point(c.points[1]), -1)]
        else:
            targets = [(c.points[0], by_element.get(c.body.name), 1)]
        for point, body, sign in targets:
            if not isinstance(body, Body):
                continue
            f = vscale(sm.Integer(sign), tree.express(e, node, body.frame))
            rel = [(s, a) for s, a in signed_atoms(prep.point_atoms[point],
                                                   prep.point_atoms[body.point])]
            rho = vadd(ZERO3, *(vscale(sm.Integer(s), tree.express(a.c, a.frame, body.frame))
                                for s, a in rel))
            out[body].append((cross(rho, f), f))
    return out


def joint_reactions(ne: NewtonEuler, udot=None, extra=None) -> JointLoads:
    """Force and moment of every joint (parent on child, at the joint point).

    ``udot``: the accelerations (default: the placeholders of
    :func:`~mbgen.symbolic.equations.acceleration_symbols`, so that the reactions
    hold for whatever ``M u' = F`` gives).  ``extra``: further loads on
    bodies (:func:`constraint_loads`), which do not enter ``F``.
    """
    tree = ne.tree
    udot = acceleration_symbols(ne.nu) if udot is None else udot
    f = ne.body_forces(udot, extra)
    rows = []
    for b in ne.bodies:
        n, force = split(f[b])
        rows.append(tuple(tree.express(force, b.frame, b.reaction_frame)) +
                    tuple(tree.express(n, b.frame, b.reaction_frame)))
    return JointLoads(
        names=tuple(b.joint for b in ne.bodies),
        children=tuple(b.name for b in ne.bodies),
        parents=tuple(b.parent.name if b.parent is not None else None for b in ne.bodies),
        points=tuple(b.point.name for b in ne.bodies),
        frames=tuple(b.reaction_frame.name for b in ne.bodies),
        matrix=sm.ImmutableMatrix(rows) if rows else sm.ImmutableMatrix(0, 6, []))


def reactions_for(prep: Prepared) -> tuple:
    """``(program, JointLoads)`` of the joint reactions of a prepared model.

    For any derivation method: the reactions need only the body tree's
    Newton–Euler quantities, built here in a program of their own (on the outward pass that
    the choice of method ran, where it did).
    """
    ne = outward_pass(prep)
    loads = joint_reactions(ne, extra=constraint_loads(ne, ordered(prep.model)))
    return ne.P.build(), loads


__all__ = ["constraint_loads", "joint_reactions", "reactions_for"]
