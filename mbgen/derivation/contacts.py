r"""Rigid point contacts: the rows :math:`J u' + c = 0` of :meth:`mbgen.Model.contact`.

A contact holds a point :math:`P` of the model fixed in the Newtonian frame ``N``.  Unlike
the constraints of :mod:`mbgen.derivation.constraints`, which eliminate dependent speeds,
it keeps every speed a state and acts on the accelerations (what legged-robot MPC
evaluates: Pinocchio's ``constraintDynamics`` with ``CONTACT_3D`` in
``LOCAL_WORLD_ALIGNED``, Crocoddyl's ``DifferentialActionModelContactFwdDynamics``).  In
``N`` components, from the kinematic tree's atoms of :math:`P` (the point kinematics that
both derivations share, :mod:`mbgen.derivation.tree`):

* :math:`r_P = \sum_a R_{Na} c_a`, its position;
* :math:`J = \partial v_P/\partial u` (``3 x n_u``), from the atoms' partial velocities
  :math:`v_{a,r} = \partial\dot c_a/\partial u_r + \omega_{F,r}\times c_a`;
* :math:`v_P = \sum_a R_{Na}(\dot c_a + \omega_F\times c_a)`, its velocity (``J u`` for a
  point whose motion depends on ``q`` and ``u`` alone);
* :math:`\gamma = \sum_a R_{Na} a^t_a`, its acceleration with every :math:`u' = 0` (the
  atoms' acceleration remainders: :math:`\dot J u` and the explicit time terms).

The contact's acceleration :math:`a_P = J u' + \gamma` is held to Baumgarte's correction,

.. math::

    J u' + c = 0, \qquad c = \gamma + k_d\, v_P + k_p\, (r_P - r_0),

with the gains :math:`k_p, k_d` (the constants ``contact_kp``, ``contact_kd``, default 0)
and the anchor :math:`r_0` (``<name>_x0, _y0, _z0``, default the origin: Pinocchio's
``joint2_placement``, the identity unless given) parameters of the generated code.  The
ground's force :math:`\lambda` on the model at :math:`P` (three components in ``N``) enters
as :math:`M u' = F + J^T\lambda`; checked against ``pin.constraintDynamics``, whose
``lambda_c`` is this force and whose corrector is :math:`a_P = -K_d v_P - K_p (r_P - r_0)`.

The generated code solves the pair per call (``templates/runtime/contact.c.j2``):
``M = L D L^T``, :math:`a_0 = M^{-1} F`, :math:`Y = M^{-1} J^T`, the Delassus matrix
:math:`G = J Y` factored (a rank-deficient ``G`` -- two contacts on one point, a leg
stretched straight -- is the status ``CONTACT_SINGULAR``), :math:`\lambda = -G^{-1}(J a_0 +
c)`, :math:`u' = a_0 + Y\lambda`.  The derivation's ``M`` and ``F`` are the unconstrained
ones (the Newton–Euler recursion's where it is chosen, its inverse-dynamics ``residual``
kept for the Jacobians), and the articulated-body accelerations are dropped: the
recursion knows no contact.

Contacts coexist with no stated constraint yet: a model with both is refused.
"""

from __future__ import annotations

from dataclasses import replace

import sympy as sm

from ..errors import ModelError
from ..symbolic.equations import Contacts, Equations
from .joints import Body
from .prepare import Prepared
from .recursion import NewtonEuler
from .relative import cancelled
from .spatial import matmul3
from .tree import ZERO3, add, cross, matvec, mul, unit, vadd


def with_contacts(eq: Equations, prep: Prepared) -> Equations:
    """``eq`` with the model's contacts (:class:`~mbgen.symbolic.equations.Contacts`);
    unchanged without any.

    Raises
    ------
    ModelError
        The model also states constraints (holonomic, motion, ``no_slip``, ``coincident``).
    """
    model = prep.model
    stated = getattr(model, "contacts_", ())
    if not stated:
        return eq
    if model.constraints_:
        raise ModelError(
            f"model {model.name!r} has contacts ({', '.join(c.name for c in stated)}) and "
            f"constraints ({', '.join(c.name for c in model.constraints_)}): mbgen does not "
            f"solve both kinds together yet; state the loop or rolling constraints as "
            f"contacts, or leave the contacts out")
    if eq.contacts is None:   # Kane's method (Newton-Euler's own: recursive_contacts)
        rows_J, rows_c = [], []
        for c in stated:
            J, drift = contact_rows(prep, c)
            rows_J += J
            rows_c += drift
        eq = replace(eq, contacts=Contacts(
            tuple(c.name for c in stated), tuple(c.point.name for c in stated),
            sm.ImmutableMatrix(rows_J), sm.ImmutableMatrix(len(rows_c), 1, rows_c)))
    J = eq.contacts.jacobian
    for i, c in enumerate(stated):
        if all(x == 0 for x in J[3 * i:3 * i + 3, :]):
            raise ModelError(f"contact {c.name!r}: point {c.point.name!r} does not move with "
                             f"any speed (it is fixed in N already); leave the contact out")
    return replace(eq, accelerations=None)


def recursive_contacts(ne: NewtonEuler) -> Contacts | None:
    """The model's contacts in the quantities of the Newton–Euler recursion ``ne`` (its outward
    pass and rotations, in its program: :func:`body_rows`), where every contact point is fixed
    in a body; None otherwise (the derivation falls back on the tree's rows)."""
    stated = getattr(ne.prep.model, "contacts_", ())
    if not stated or not all(isinstance(ne.bt.body_of_point(c.point), Body) for c in stated):
        return None
    rows_J, rows_c = [], []
    world = _World(ne)
    for c in stated:
        J, drift = body_rows(ne, world, c)
        rows_J += J
        rows_c += drift
    return Contacts(tuple(c.name for c in stated), tuple(c.point.name for c in stated),
                    sm.ImmutableMatrix(rows_J), sm.ImmutableMatrix(len(rows_c), 1, rows_c))


class _World:
    r"""Rotations :math:`R_{N,b}` (body to Newtonian components) of the bodies, built along
    the chain from the ground's rotation and each joint's (``ne.rotation``), as program
    symbols, memoised; and the ground's :math:`R_{N,g}`."""

    def __init__(self, ne: NewtonEuler):
        self.ne = ne
        tree, ground = ne.tree, ne.bt.ground_frame
        root = ne.prep.frame_nodes[ne.prep.model.N]
        cols = [tree.express(unit(j + 1), ground, root) for j in range(3)]
        self.ground = tuple(tuple(cols[j][i] for j in range(3)) for i in range(3))
        self._of: dict = {}

    def of(self, b: Body) -> tuple:
        hit = self._of.get(b)
        if hit is None:
            up = self.of(b.parent) if b.parent is not None else self.ground
            R = matmul3(up, self.ne.rotation(b).matrix)
            hit = tuple(self.ne.P.vector(row) for row in R)
            self._of[b] = hit
        return hit


def body_rows(ne: NewtonEuler, world: _World, contact) -> tuple[list, list]:
    r"""``(J, c)`` of a contact at a point fixed in body ``b``, from the recursion.

    With :math:`\rho` the point's offset from the joint point :math:`J_b` and, per body
    ``j`` on the path to the ground, :math:`d_j` the vector from :math:`J_j` to the point
    (``j`` components: :math:`d_b = \rho`, :math:`d_p = r_c + R_{pc} d_c`), in ``N``:

    * ``J``'s column ``k`` sums, over the bodies ``j`` whose joint ``k`` moves (motion
      subspace column :math:`(\omega_k, v_k)` at :math:`J_j`), :math:`R_{N,j}(v_k +
      \omega_k\times d_j)`;
    * :math:`\gamma = R_{N,b}(a_b + \alpha_b\times\rho + \omega_b\times(\omega_b
      \times\rho)) + g`: the outward pass's acceleration of :math:`J_b` at :math:`u' = 0`
      (in which the ground accelerates at :math:`-g`) carried to the point;
    * :math:`v_P = R_{N,b}(v_b + \omega_b\times\rho)` with :math:`v_b` the joint point's
      velocity, :math:`r_P = R_{N,g} r_{root} + R_{N,root} d_{root}`.
    """
    P, bt = ne.P, ne.bt
    b = bt.body_of_point(contact.point)
    rho = P.vector(ne._offset(bt.atoms_between(b.point, contact.point), b.frame))
    path, d = [b], {b: rho}
    while path[-1].parent is not None:
        c = path[-1]
        d[c.parent] = P.vector(vadd(ne.kin[c].r, matvec(ne.rotation(c).matrix, d[c])))
        path.append(c.parent)
    n = ne.nu
    columns = [ZERO3] * n
    for j in path:
        R = world.of(j)
        for k, col in ne.kin[j].S.items():
            w, v = col[:3], col[3:]
            columns[k] = vadd(columns[k], matvec(R, vadd(v, cross(w, d[j]))))
    kin = ne.kin[b]
    Rb = world.of(b)
    acc = vadd(kin.acc, cross(kin.alpha, rho), cross(kin.omega, cross(kin.omega, rho)))
    g = matvec(world.ground, ne.gravity) if ne.gravity is not None else ZERO3
    gamma = vadd(matvec(Rb, acc), g)
    velocity = matvec(Rb, vadd(_joint_velocity(ne, b), cross(kin.omega, rho)))
    root = path[-1]
    position = vadd(matvec(world.ground, ne.kin[root].r), matvec(world.of(root), d[root]))
    J = [[P.scalar(columns[k][i]) for k in range(n)] for i in range(3)]
    return J, _drift(contact, position, velocity, gamma)


def _joint_velocity(ne: NewtonEuler, b: Body) -> tuple:
    """Velocity of the joint point :math:`J_b` in N, ``b`` components (the outward recursion
    of :meth:`~mbgen.derivation.recursion.NewtonEuler.kinetic_energy`)."""
    k = ne.kin[b]
    if b.parent is not None:
        p = ne.kin[b.parent]
        v = vadd(_joint_velocity(ne, b.parent), cross(p.omega, k.r), k.v_rel)
    else:
        v = k.v_rel
    v = ne.to_child(b)(v)
    return ne.P.vector(cancelled(v) if k.through else v)


def _drift(contact, position, velocity, gamma) -> list:
    r""":math:`c = \gamma + k_d v_P + k_p (r_P - r_0)`, three entries."""
    kp, kd = contact.gains
    return [add(gamma[i], mul(kd, velocity[i]), mul(kp, add(position[i], -r0)))
            for i, r0 in enumerate(contact.anchor)]


def contact_rows(prep: Prepared, contact) -> tuple[list, list]:
    """``(J, c)`` of one contact: three rows of :math:`J` (``n_u`` entries each) and the
    three entries of :math:`c = \\gamma + k_d v_P + k_p (r_P - r_0)`, in ``N`` components."""
    tree, model = prep.tree, prep.model
    root = prep.frame_nodes[model.N]
    atoms = prep.point_atoms[contact.point]
    n = prep.layout.n_u
    position, velocity, gamma = ZERO3, ZERO3, ZERO3
    columns = [ZERO3] * n
    for a in atoms:
        position = vadd(position, tree.express(a.c, a.frame, root))
        velocity = vadd(velocity, tree.express(tree.atom_velocity(a), a.frame, root))
        gamma = vadd(gamma, tree.express(tree.atom_acceleration_rest(a), a.frame, root))
        for k, v in tree.atom_partials(a).items():
            columns[k] = vadd(columns[k], tree.express(v, a.frame, root))
    drift = _drift(contact, position, velocity, gamma)
    J = [[columns[k][i] for k in range(n)] for i in range(3)]
    return J, drift


__all__ = ["with_contacts", "contact_rows", "recursive_contacts", "body_rows"]
