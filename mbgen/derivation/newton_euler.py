r"""Newton–Euler on the body tree: the same ``M u' = F`` as Kane, the recursion, the reactions.

Newton's and Euler's laws for the subtree of body ``b`` give the reaction that
the parent exerts on ``b`` at its joint point ``J_b``,

.. math::

    f_b = \mathcal I_b \hat a_b - g_b + \sum_{c} X_c^T f_c,
    \qquad \hat a_b = X_b \hat a_p + S_b u'_b,

(:math:`\mathcal I_b` the spatial inertia, ``g_b`` the applied minus the
velocity-dependent inertial wrench, ``S_b`` the joint's motion subspace, ``X``
the transform to the parent).  Projecting it on the joint's free motions, where
the reaction does no work, gives the equations of motion ``M u' = F``; these
equal Kane's ``M`` and ``F``.  The derivation runs in passes over the tree, each
in its own module:

1. :mod:`mbgen.derivation.recursion` -- the outward pass (angular velocities,
   acceleration remainders, motion subspaces; each joint's relative motion from
   :mod:`mbgen.derivation.relative`), each body's spatial inertia and wrench (one
   frozen record of each per body), the inward pass for ``F`` and composite rigid
   bodies for ``M``;
2. :mod:`mbgen.derivation.articulated` -- the articulated-body recursion, which
   gives ``u'`` directly when every speed belongs to exactly one joint;
3. :mod:`mbgen.derivation.reactions` -- the joint reactions ``f_b`` above;
4. :mod:`mbgen.derivation.rnea_partials` -- the analytic state Jacobian of the
   inverse dynamics, and ``M`` and ``F`` for its solve, where every joint is revolute or
   prismatic and the root fixed or free (:mod:`mbgen.derivation.rnea_scope`; asked for by
   ``wants.jacobian``).

Every per-body quantity is a named intermediate of one program
(:class:`mbgen.symbolic.program.Program`), so the equations' size is linear in
the number of bodies.
"""

from __future__ import annotations

import sympy as sm

from ..symbolic.equations import Equations, acceleration_symbols
from ..symbolic.program import Program
from .articulated import articulated
from .common import Grouping, Wants, point_kinematics, potential_energy
from .constraints import ordered
from .contacts import recursive_contacts
from .prepare import Prepared
from .reactions import constraint_loads, joint_reactions
from .recursion import outward_pass
from .rnea_partials import residual_jacobian


def newton_euler(prep: Prepared, wants: Wants) -> Equations:
    """Derive ``M u' = F``, ``q' = G`` by Newton–Euler over the body tree.

    Unless the model has constraints, the articulated-body recursion gives
    ``u'`` too where it applies (``Equations.accelerations``); ``wants`` adds
    the energies, points and joint reactions.
    """
    model, layout = prep.model, prep.layout
    ne = outward_pass(prep)
    F = ne.forcing()
    rows = ne.mass_matrix()
    nu = layout.n_u
    M = [[rows[max(r, s)][min(r, s)] for s in range(nu)] for r in range(nu)]
    contacts = recursive_contacts(ne) if getattr(model, "contacts_", ()) else None
    udot = articulated(ne) if not model.constraints_ and not contacts else None
    residual = ne.residual(acceleration_symbols(nu)) if not model.constraints_ else None
    loads = (joint_reactions(ne, extra=constraint_loads(ne, ordered(model)))
             if wants.reactions else None)
    kinetic, potential = ((ne.kinetic_energy(), potential_energy(prep, Grouping(prep)))
                          if wants.energy else (None, None))
    partials = (residual_jacobian(ne, acceleration_symbols(nu))
                if wants.jacobian and residual is not None else None)
    program = ne.P.build()
    if partials is not None:
        program = Program(program.assignments + partials.extra.assignments, program.checks)
    return Equations(
        name=model.name,
        layout=layout,
        mass_matrix=sm.ImmutableMatrix(M),
        forcing=sm.ImmutableMatrix(F),
        kinematics=sm.ImmutableMatrix([prep.qdot[q] for q in layout.coordinates]),
        kinetic_energy=kinetic,
        potential_energy=potential,
        points=point_kinematics(prep, wants.points),
        source=f"mbgen.Model {model.name!r}",
        method="newton_euler",
        program=program,
        accelerations=sm.ImmutableMatrix(udot) if udot is not None else None,
        reactions=loads,
        residual=sm.ImmutableMatrix(residual) if residual is not None else None,
        residual_jacobian=partials.jacobian if partials is not None else None,
        residual_tangent=partials.tangent if partials is not None else None,
        partials_solve=(partials.mass, partials.forcing) if partials is not None else None,
        pairs=partials.pairs if partials is not None else None,
        contacts=contacts,
    )


__all__ = ["newton_euler"]
