r"""The Newton–Euler passes over the body tree that give ``M u' = F``.

Every body ``b`` (see :mod:`mbgen.derivation.joints`) is described at its joint
point ``J`` in its own frame.  With ``p`` its parent, ``r`` the vector from
``J_p`` to ``J_b``, and ``rel`` quantities of the joint (relative to the
parent's frame), the **outward pass** gives angular velocity, and the
remainders (every ``u' = 0``) of the angular and linear acceleration:

.. math::

    \omega_b &= \omega_p + \omega_{rel} \\
    \alpha^t_b &= \alpha^t_p + \alpha^t_{rel} + \omega_p\times\omega_{rel} \\
    a^t_b &= a^t_p + \alpha^t_p\times r + \omega_p\times(\omega_p\times r)
             + 2\,\omega_p\times v_{rel} + a^t_{rel}

and the joint's motion subspace ``S_b``: column ``r`` is the partial velocity
``(d omega_rel / d u_r, d v_rel / d u_r)``.  Each body's masses give its
spatial inertia :math:`\mathcal I_b` about ``J_b`` (:mod:`mbgen.derivation.spatial`)
and, with its applied loads, the wrench

.. math::

    g_b = \text{applied}_b - \mathcal I_b (\alpha^t_b, a^t_b)
          - (\omega_b \times I_J\omega_b,\ \omega_b\times(\omega_b\times h_b)).

The **inward pass** sums the wrenches of each subtree and projects them on the
joints' free motions; **composite rigid bodies** give the mass matrix:

.. math::

    F_r = \sum_b S_{b,r}\cdot G_b + \tau_r, \qquad G_b = g_b + \sum_c X_c^T G_c,
    \qquad M_{ij} = S_i^T X^T \mathcal I^C_j S_j,

``tau`` the generalized forces of loads on massless parts (why these are the
equations of motion: :mod:`mbgen.derivation.newton_euler`).  A joint's armature
:math:`a_k` (:meth:`mbgen.Model.armature`) is no body: it adds to the joint's own
diagonal, :math:`M_{kk} \mathrel{+}= a_k`, and :math:`-a_k u'_k` to the inverse
dynamics' residual (and to the articulated-body pivot, :mod:`mbgen.derivation.articulated`).

Every per-body quantity is a named intermediate (:class:`mbgen.symbolic.program.Program`),
so the recursion's size is linear in the number of bodies.
"""

from __future__ import annotations

import copy
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass

import sympy as sm

from ..model.elements import Force, Torque
from ..symbolic.program import ProgramBuilder
from .common import line_coefficient
from .joints import GROUND, Body, BodyTree, build_bodies
from .prepare import Prepared
from .relative import Relative, cancelled, ops, through_matrix
from .spatial import (
    ZERO6,
    Rotation,
    congruence,
    dot6,
    force_to_parent,
    join,
    matvec6,
    motion_to_child,
    spatial_inertia,
    symmetric,
    vadd6,
    vneg6,
)
from .tree import S0, ZERO3, Vec3, add, cross, dot3, is_zero, matvec, mul, unit, vadd, vneg, vscale

TWO = sm.Integer(2)


@dataclass(frozen=True)
class BodyKinematics:
    r"""One body's outward-pass quantities at its joint point ``J`` (what Pinocchio keeps per
    joint in ``data`` and ``jdata``: velocity, bias acceleration, ``jdata.S()``).

    Attributes
    ----------
    omega : Vec3
        Angular velocity :math:`\omega_b`, body components.
    alpha, acc : Vec3
        Angular acceleration and acceleration of ``J`` with every ``u' = 0`` (the ground
        accelerating at ``-g``), body components.
    r : Vec3
        From the parent's joint point (the origin, for a root) to ``J``, parent components.
    S : mapping of int to 6-tuple
        The joint's motion subspace: speed index -> its column ``(angular, linear)``, body
        components; only the speeds that move the joint.
    v_rel : Vec3
        The joint's own velocity of ``J`` relative to the parent's frame, parent components.
    through : bool
        A rotation given as a matrix lies between the parent's frame and the body's
        (:func:`~mbgen.derivation.relative.through_matrix`).
    """

    omega: Vec3
    alpha: Vec3
    acc: Vec3
    r: Vec3
    S: Mapping[int, tuple]
    v_rel: Vec3
    through: bool


@dataclass(frozen=True)
class BodyInertia:
    r"""One body's masses about its joint point ``J``, body components (Pinocchio's ``Y``).

    Attributes
    ----------
    m : Expr
        Mass.
    h : Vec3
        First moment :math:`\sum m_k \rho_k` about ``J``.
    IJ : 3x3 rows
        Rotational inertia about ``J``.
    spatial : 6x6 rows
        :math:`\mathcal I_b` (:func:`~mbgen.derivation.spatial.spatial_inertia`).
    """

    m: object
    h: Vec3
    IJ: tuple
    spatial: tuple


class NewtonEuler:
    """The Newton–Euler quantities of one model, built into one program.

    Construction runs the outward pass and collects every body's inertia and
    loads; :meth:`forcing` (the inward pass) and :meth:`mass_matrix` (composite
    rigid bodies) build on it, and so do the articulated-body recursion
    (:mod:`mbgen.derivation.articulated`) and the joint reactions
    (:mod:`mbgen.derivation.reactions`).  Per body, :attr:`kin` holds its
    :class:`BodyKinematics`, :attr:`inertia` its :class:`BodyInertia` and :attr:`g` its
    wrench ``g_b``; every later pass only adds to the program :attr:`P`, so one outward
    pass serves several derivations through :meth:`fork`.
    """

    def __init__(self, prep: Prepared, bodies: BodyTree | None = None):
        self.prep = prep
        self.tree = prep.tree
        self.bt = bodies or build_bodies(prep)
        self.bodies: list[Body] = self.bt.bodies
        self.nu = prep.layout.n_u
        #: speed index -> its armature a_k (Model.armature)
        self.armature: dict = dict(prep.armature)
        self.P = ProgramBuilder("ne")
        self._rotations: dict = {}
        g = prep.gravity
        #: gravity in ground components (None: none)
        self.gravity = (vadd(*(self.tree.express(c, n, self.bt.ground_frame) for n, c in g))
                        if g else None)
        self.tau: dict = defaultdict(list)         # generalized forces of loads on massless parts
        self._loads: dict = defaultdict(list)      # body -> [(moment, force)] in body components
        self._collect_loads()
        self.kin: dict[Body, BodyKinematics] = {}
        for b in self.bodies:
            self.kin[b] = self._outward(b)
        self.inertia: dict[Body, BodyInertia] = {b: self._inertia(b) for b in self.bodies}
        self.g = {b: self._wrench(b) for b in self.bodies}

    def fork(self) -> NewtonEuler:
        """A copy whose program grows apart from this one's, the outward pass not run again.

        The per-body records are frozen and shared; the program builder and the cache of
        rotations (which adds to the program) are copied, so that the passes run on the
        copy (``forcing``, ``mass_matrix``, the recursion, the reactions) leave this one as
        it was: each derivation of one model forks the outward pass that chose its method.
        """
        other = copy.copy(self)
        other.P = ProgramBuilder(self.P.tag)
        other.P.assignments = list(self.P.assignments)
        other.P.checks = set(self.P.checks)
        other._rotations = dict(self._rotations)
        return other

    # ------------------------------------------------------------------ geometry
    def to_child(self, b: Body):
        """Map from the components of the parent of ``b`` (or the ground) to those of ``b``."""
        src = b.parent.frame if b.parent is not None else self.bt.ground_frame
        return lambda v: self.tree.express(v, src, b.frame)

    def to_parent(self, b: Body):
        """Map from the components of ``b`` to those of its parent (or the ground)."""
        dst = b.parent.frame if b.parent is not None else self.bt.ground_frame
        return lambda v: self.tree.express(v, b.frame, dst)

    def rotation(self, b: Body) -> Rotation:
        """Child-to-parent rotation of ``b`` (a simple rotation when the joint is one)."""
        hit = self._rotations.get(b)
        if hit is None:
            node = b.frame
            parent = b.parent.frame if b.parent is not None else self.bt.ground_frame
            if node.parent is parent and node.omega_override is None and node.axis:
                hit = Rotation.simple(node.axis, sm.cos(node.angle), sm.sin(node.angle), self.P)
            else:
                to_parent = self.to_parent(b)
                cols = [to_parent(unit(j + 1)) for j in range(3)]
                hit = Rotation(tuple(tuple(cols[j][i] for j in range(3)) for i in range(3)))
            self._rotations[b] = hit
        return hit

    def child_congruence(self, c: Body, I):
        """``X_c^T I X_c``: the 6x6 inertia ``I`` of child ``c`` seen from its parent (lower)."""
        return congruence(I, self.rotation(c), self.kin[c].r)

    def _offset(self, atoms, frame):
        """Sum of atoms' components, expressed in ``frame``."""
        tree = self.tree
        return vadd(ZERO3, *(tree.express(a.c, a.frame, frame) for a in atoms))

    # ------------------------------------------------------------------ outward pass
    def _outward(self, b: Body) -> BodyKinematics:
        """The outward pass at ``b``, its parent's :class:`BodyKinematics` known."""
        tree, P = self.tree, self.P
        p = b.parent
        base = p.frame if p is not None else self.bt.ground_frame
        if p is not None:
            wp, ap_ang, ap_lin = self.kin[p].omega, self.kin[p].alpha, self.kin[p].acc
        else:   # gravity enters as an upward acceleration of the ground (see _wrench)
            wp = ap_ang = ZERO3
            ap_lin = vneg(self.gravity) if self.gravity is not None else ZERO3
        rel = Relative(tree, base)
        w_rel, w_parts, a_rel_ang = rel.of(b.frame)
        r = ZERO3
        v_rel = ZERO3
        a_rel = ZERO3
        v_parts: dict = {}
        for atom in b.joint_atoms:
            F = atom.frame
            wa, pa, aa = rel.of(F)
            c = atom.c
            cdot = tree.atom_rate(atom)
            cddot = tree.dt_rest(cdot)
            r = vadd(r, tree.express(c, F, base))
            v_rel = vadd(v_rel, tree.express(vadd(cdot, cross(wa, c)), F, base))
            acc = vadd(cddot, cross(aa, c), vscale(TWO, cross(wa, cdot)), cross(wa, cross(wa, c)))
            a_rel = vadd(a_rel, tree.express(acc, F, base))
            for k in range(self.nu):
                v = tree.d_du(cdot, k)
                if k in pa:
                    v = vadd(v, cross(pa[k], c))
                if not is_zero(v):
                    v_parts[k] = vadd(v_parts.get(k, ZERO3), tree.express(v, F, base))
        to_child = self.to_child(b)
        r = P.vector(r)
        wp_b = to_child(wp)
        omega = P.vector(vadd(wp_b, w_rel))
        alpha = P.vector(vadd(to_child(ap_ang), a_rel_ang, cross(wp_b, w_rel)))
        acc = to_child(vadd(ap_lin, cross(ap_ang, r), cross(wp, cross(wp, r)),
                            vscale(TWO, cross(wp, v_rel)), a_rel))
        v_child = {k: to_child(v) for k, v in v_parts.items()}
        through = through_matrix(tree, base, b.frame)
        if through:
            acc, v_child = self._in_child(to_child, (ap_lin, ap_ang, wp, r), v_rel, w_rel,
                                          acc, v_child)
        acc = P.vector(acc)
        S = {}
        for k in sorted(set(w_parts) | set(v_parts)):
            col = join(w_parts.get(k, ZERO3), v_child.get(k, ZERO3))
            if not all(x == 0 for x in col):
                S[k] = P.vector(col)
        return BodyKinematics(omega, alpha, acc, r, S, v_rel, through)

    def _in_child(self, to_child, parent, v_rel, w_rel, acc, v_child):
        r"""The joint's velocity terms taken in the child's frame, where that is smaller.

        Through a rotation given as a matrix ``R`` (:meth:`mbgen.Model.orient`, e.g.
        a floating base's quaternion), ``R^T R v`` and ``R^T R' v`` are ``v`` and
        :math:`\omega\times v` only up to an identity that no term-by-term algebra
        sees.  Here the joint's velocity in child components, ``v_c``, is put over a
        common denominator and cancelled (a few small rational functions), and its
        acceleration follows by the transport theorem in the child frame,
        :math:`a = \dot v_c + \omega_{rel}\times v_c` (with ``u' = 0``), its
        partials :math:`\partial v_c/\partial u` giving ``S``: the free-flyer's
        linear columns are then unit vectors and its bias :math:`\omega\times v`.
        Each form is kept only where it has fewer operations (a free joint with
        world-frame speeds, MuJoCo's, keeps the parent-frame one).
        """
        ap_lin, ap_ang, wp, r = parent
        v_c = cancelled(to_child(v_rel))
        wp_b = to_child(wp)
        rest = vadd(self.tree.dt_rest(v_c), cross(w_rel, v_c), vscale(TWO, cross(wp_b, v_c)))
        alt = vadd(to_child(vadd(ap_lin, cross(ap_ang, r), cross(wp, cross(wp, r)))), rest)
        if ops(alt) < ops(acc):
            acc = alt
        cols = {k: self.tree.d_du(v_c, k) for k in range(self.nu)}
        cols = {k: v for k, v in cols.items() if not is_zero(v)}
        if set(cols) == set(v_child) and ops(*cols.values()) < ops(*v_child.values()):
            v_child = cols
        return acc, v_child

    # ------------------------------------------------------------------ inertia and loads
    def _inertia(self, b: Body) -> BodyInertia:
        """Spatial inertia of ``b`` about its joint point, in its frame (6x6 rows)."""
        tree, P = self.tree, self.P
        m, h = [], [ZERO3]
        IJ = [[S0] * 3 for _ in range(3)]
        for me, atoms in b.elements:
            rho = self._offset(atoms, b.frame)
            m.append(me.mass)
            h.append(vscale(me.mass, rho))
            if me.inertia is not None:
                cols = []
                for j in range(3):
                    e = tree.express(unit(j + 1), b.frame, me.frame)
                    cols.append(tree.express(matvec(me.inertia, e), me.frame, b.frame))
                for i in range(3):
                    for j in range(3):
                        IJ[i][j] = add(IJ[i][j], cols[j][i])
            if not is_zero(rho):
                rr = dot3(rho, rho)
                for i in range(3):
                    for j in range(3):
                        shift = add(rr if i == j else S0, mul(-1, mul(rho[i], rho[j])))
                        IJ[i][j] = add(IJ[i][j], mul(me.mass, shift))
        mass = P.scalar(add(*m))
        h = P.vector(vadd(*h))
        low = {(i, j): P.scalar(IJ[i][j]) for i in range(3) for j in range(i + 1)}
        IJ = tuple(tuple(low[(max(i, j), min(i, j))] for j in range(3)) for i in range(3))
        return BodyInertia(mass, h, IJ, spatial_inertia(mass, h, IJ))

    def _collect_loads(self) -> None:
        prep, tree = self.prep, self.tree
        at_point, on_frame = self._load_at_point, self._load_on_frame
        for load in prep.model.loads:
            if isinstance(load, Force):
                vec = prep.terms(load.vector, f"force at {load.point}")
                at_point(load.point, vec, 1)
                if load.reaction is not None:
                    at_point(load.reaction, vec, -1)
            elif isinstance(load, Torque):
                vec = prep.terms(load.vector, f"torque on {load.frame}")
                on_frame(prep.frame_nodes[load.frame], vec, 1)
                if load.reaction is not None:
                    on_frame(prep.frame_nodes[load.reaction], vec, -1)
        for el, atoms in prep.lines:
            coef, d = line_coefficient(tree, el, atoms)
            if not d or coef == 0:
                continue
            coef = self.P.scalar(coef)
            vec = [(n, vscale(coef, c)) for n, c in d]
            at_point(el.a, vec, 1)
            at_point(el.b, vec, -1)

    def _load_at_point(self, point, vector_terms, sign) -> None:
        """The force ``sign * vector_terms`` at ``point``: a load on the body that carries
        the point, or (a massless point) generalized forces from its partial velocities."""
        prep, bt, tree = self.prep, self.bt, self.tree
        target = bt.body_of_point(point)
        if target is GROUND or not vector_terms:
            return
        if target is None:   # a massless point: generalized forces from its partial velocities
            for a in prep.point_atoms[point]:
                for k, va in tree.atom_partials(a).items():
                    f = add(*(tree.dot(va, a.frame, c, n) for n, c in vector_terms))
                    self.tau[k].append(f if sign > 0 else mul(-1, f))
            return
        f = vadd(*(tree.express(c, n, target.frame) for n, c in vector_terms))
        f = vscale(sm.Integer(sign), f)
        rho = self._offset(bt.atoms_between(target.point, point), target.frame)
        self._loads[target].append((cross(rho, f), f))

    def _load_on_frame(self, node, vector_terms, sign) -> None:
        """The torque ``sign * vector_terms`` on frame ``node``: a load on the body fixed in
        it, or (no body) generalized forces from its partial angular velocities."""
        bt, tree = self.bt, self.tree
        if not vector_terms or bt.rigid[node] is bt.rigid[bt.ground_frame]:
            return
        target = bt.body_of_frame(node)
        if target is None:
            T = vadd(*(tree.express(c, n, node) for n, c in vector_terms))
            for k, w in tree.omega_partials(node).items():
                f = dot3(w, T)
                self.tau[k].append(f if sign > 0 else mul(-1, f))
            return
        T = vadd(*(tree.express(c, n, target.frame) for n, c in vector_terms))
        self._loads[target].append((vscale(sm.Integer(sign), T), ZERO3))

    def _wrench(self, b: Body):
        """``g_b``: applied minus inertial (with ``u' = 0``) force about ``J_b``, body components.

        Gravity is not among the applied loads: the outward pass starts from a
        ground accelerating at ``-g``, which shifts every body's acceleration by
        ``-g`` and so adds exactly ``(h x g, m g)`` to ``g_b``, one vector per
        tree rather than one per body.
        """
        k, inn = self.kin[b], self.inertia[b]
        w, alpha, acc = k.omega, k.alpha, k.acc
        m, h, IJ = inn.m, inn.h, inn.IJ
        n_in = vadd(matvec(IJ, alpha), cross(h, acc), cross(w, matvec(IJ, w)))
        f_in = vadd(vscale(m, acc), cross(alpha, h), cross(w, cross(w, h)))
        return self.P.vector(vadd6(self.applied_wrench(b), vneg6(join(n_in, f_in))))

    def applied_wrench(self, b: Body) -> tuple:
        """The loads applied to ``b`` (gravity aside): moment about ``J_b`` and force."""
        return join(*(vadd(ZERO3, *(w[i] for w in self._loads.get(b, ()))) for i in (0, 1)))

    def kinetic_energy(self):
        r"""``T``: :math:`\tfrac12\sum_b V_b^T \mathcal I_b V_b` with the spatial velocity
        :math:`V_b = (\omega_b, v_b)` of each body at its joint point, in its frame, from the
        outward pass :math:`v_b = R_b (v_p + \omega_p\times r_b + v_{rel})` (each ``v_b`` a
        named intermediate: linear in the number of bodies)."""
        P, vel, terms = self.P, {}, []
        for b in self.bodies:
            k = self.kin[b]
            if b.parent is not None:
                p = self.kin[b.parent]
                v = vadd(vel[b.parent], cross(p.omega, k.r), k.v_rel)
            else:
                v = k.v_rel
            v = self.to_child(b)(v)
            vel[b] = P.vector(cancelled(v) if k.through else v)
            V = join(k.omega, vel[b])
            terms.append(dot6(V, matvec6(self.inertia[b].spatial, V)))
        return add(mul(sm.Rational(1, 2), add(*terms)), self.prep.armature_energy())

    # ------------------------------------------------------------------ equations of motion
    def children_sum(self, b: Body, of: dict):
        """``sum_c X_c^T of[c]`` over the children of ``b``."""
        terms = [force_to_parent(of[c], self.to_parent(c), self.kin[c].r) for c in b.children]
        return tuple(add(*(t[i] for t in terms)) for i in range(6)) if terms else ZERO6

    def forcing(self, wrenches: dict | None = None) -> list:
        """``F``: ``tau`` + the inward sums of ``wrenches`` (default ``g``) on the free motions."""
        wrenches, G = self.g if wrenches is None else wrenches, {}
        for b in reversed(self.bodies):
            G[b] = self.P.vector(vadd6(wrenches[b], self.children_sum(b, G)))
        F = [list(self.tau.get(k, ())) for k in range(self.nu)]
        for b in self.bodies:
            for k, s in self.kin[b].S.items():
                F[k].append(dot6(s, G[b]))
        return [add(*f) for f in F]

    def body_forces(self, udot, extra=None) -> dict:
        r"""Body -> the wrench :math:`f_b` its parent exerts on it at the joint point, for the
        accelerations ``udot`` (placeholders): the outward pass
        :math:`\hat a_b = X_b \hat a_p + S_b u'_b`, then the inward pass
        :math:`f_b = \mathcal I_b \hat a_b - g_b - e_b + \sum_c X_c^T f_c` (``extra``:
        body -> ``[(moment, force)]`` of further loads ``e_b``, e.g. constraint forces)."""
        P, accel, f = self.P, {}, {}
        for b in self.bodies:
            a = (motion_to_child(accel[b.parent], self.to_child(b), self.kin[b].r)
                 if b.parent is not None else ZERO6)
            for k, s in self.kin[b].S.items():
                a = vadd6(a, tuple(mul(udot[k], x) for x in s))
            accel[b] = P.vector(a)
        extra = extra or {}
        for b in reversed(self.bodies):
            own = vadd6(matvec6(self.inertia[b].spatial, accel[b]), vneg6(self.g[b]))
            for n, force in extra.get(b, ()):
                own = vadd6(own, vneg6(join(n, force)))
            f[b] = P.vector(vadd6(own, self.children_sum(b, f)))
        return f

    def residual(self, udot) -> list:
        r"""``F - M u'`` for the accelerations ``udot`` by inverse dynamics (linear in the
        number of bodies): :math:`(F - M u')_k = \tau_k - a_k u'_k - \sum_b S_{b,k}^T
        f_b(u')` with :meth:`body_forces` (``a_k`` the armature).  Its derivatives with
        ``u'`` held are those of :math:`R = F - M u'` that the Jacobians need
        (:mod:`mbgen.codegen.outputs`), without differentiating ``M``."""
        f = self.body_forces(udot)
        rows = [list(self.tau.get(k, ())) for k in range(self.nu)]
        for k, a in self.armature.items():
            rows[k].append(mul(-1, mul(a, udot[k])))
        for b in self.bodies:
            for k, s in self.kin[b].S.items():
                rows[k].append(mul(-1, dot6(s, f[b])))
        return [self.P.scalar(add(*r)) for r in rows]

    def mass_matrix(self) -> list:
        """``M`` by composite rigid bodies, the armature on its diagonal (rows of sympy
        expressions; the lower triangle, None above it)."""
        P = self.P
        IC = {}
        for b in reversed(self.bodies):
            low = {(i, j): self.inertia[b].spatial[i][j] for i in range(6) for j in range(i + 1)}
            for c in b.children:
                con = self.child_congruence(c, IC[c])
                low = {key: add(v, con[key]) for key, v in low.items()}
            IC[b] = symmetric({key: P.scalar(v) for key, v in low.items()})
        M = [[[] for _ in range(self.nu)] for _ in range(self.nu)]
        for k, a in self.armature.items():
            M[k][k].append(a)
        for j in self.bodies:
            for s, col in self.kin[j].S.items():
                f = P.vector(matvec6(IC[j], col))
                i = j
                while i is not None:
                    for r, row in self.kin[i].S.items():
                        term = dot6(row, f)
                        M[r][s].append(term)
                        if i is not j:
                            M[s][r].append(term)
                    if i.parent is not None:
                        f = P.vector(force_to_parent(f, self.to_parent(i), self.kin[i].r))
                    i = i.parent
        return [[add(*M[r][s]) if r >= s else None for s in range(self.nu)]
                for r in range(self.nu)]


def outward_pass(prep: Prepared) -> NewtonEuler:
    """The :class:`NewtonEuler` of ``prep`` to derive with: a :meth:`~NewtonEuler.fork` of the
    outward pass ``prep`` carries (the choice of method ran it), else a new one."""
    return prep.outward.fork() if prep.outward is not None else NewtonEuler(prep)


__all__ = ["BodyInertia", "BodyKinematics", "NewtonEuler", "outward_pass"]
