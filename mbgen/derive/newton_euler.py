r"""Newton–Euler on the body tree: reaction forces, recursion, and the same ``M u' = F`` as Kane.

Every body ``b`` (see :mod:`mbgen.derive.joints`) is described at its joint
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
spatial inertia :math:`\mathcal I_b` about ``J_b`` (:mod:`mbgen.derive.spatial`)
and, with its applied loads, the wrench

.. math::

    g_b = \text{applied}_b - \mathcal I_b (\alpha^t_b, a^t_b)
          - (\omega_b \times I_J\omega_b,\ \omega_b\times(\omega_b\times h_b)).

Newton's and Euler's laws for the subtree of ``b`` give the **reaction** that
the parent exerts on ``b`` at ``J_b`` (the inward pass),

.. math::

    f_b = \mathcal I_b \hat a_b - g_b + \sum_{c} X_c^T f_c,
    \qquad \hat a_b = X_b \hat a_p + S_b u'_b,

and projecting it on the joint's free motions (where the reaction does no
work) gives the equations of motion, ``M u' = F`` with

.. math::

    F_r = \sum_b S_{b,r}\cdot G_b + \tau_r, \qquad G_b = g_b + \sum_c X_c^T G_c,
    \qquad M = \text{composite rigid bodies: } M_{ij} = S_i^T X^T \mathcal I^C_j S_j,

``tau`` the generalized forces of loads on massless parts.  These equal Kane's
``M`` and ``F``.  When every speed belongs to exactly one joint (relative
joint coordinates), the **articulated-body recursion** solves for ``u'``
with a cost linear in the number of bodies: inward
:math:`\mathcal I^A_b = \mathcal I_b + \sum_c X_c^T(\mathcal I^A_c - U_c D_c^{-1} U_c^T)X_c`,
:math:`p^A_b = -g_b + \sum_c X_c^T(p^A_c + U_c D_c^{-1} u_c)` with
:math:`U = \mathcal I^A S`, :math:`D = S^T U`, :math:`u = \tau - S^T p^A`; outward
:math:`u'_b = D_b^{-1}(u_b - U_b^T X_b \hat a_p)`.  Pivots of ``D`` must be
positive (they are checked in the generated code).

Every per-body quantity is a named intermediate (:class:`mbgen.symbolic.program.Program`),
so the recursion's size is linear in the number of bodies.
"""

from __future__ import annotations

from collections import defaultdict

import sympy as sm

from ..symbolic.equations import Equations, JointLoads, acceleration_symbols, lambda_symbols
from ..model.builder import Force, Model, Torque
from ..symbolic.program import ProgramBuilder
from .common import Grouping, energies, line_coefficient, point_kinematics
from .constraints import ordered
from .joints import GROUND, Body, BodyTree, build_bodies
from .prepare import Prepared, prepare, signed_atoms as _signed
from .spatial import (ZERO6, Rotation, congruence, dot6, force_to_parent, join, matvec6,
                      motion_to_child, spatial_inertia, split, symmetric)
from .tree import (S0, ZERO3, add, cross, dot3, is_zero, matvec, mul, transpose, unit, vadd, vneg,
                   vscale)

TWO = sm.Integer(2)


class _Relative:
    r"""Angular velocity, its partials and acceleration remainder of frames relative to ``base``.

    ``of(X)`` returns ``(omega, {r: partial}, alpha)`` of frame ``X`` relative to
    ``base``, in ``X`` components, with ``alpha`` the time derivative (in
    ``base``) of ``omega`` with every ``u' = 0``.  Frames below ``base`` recurse
    through their simple rotations; others go through the common ancestor ``A``:
    :math:`\omega_{X/P} = \omega_{X/A} - \omega_{P/A}` and
    :math:`\alpha_{X/P} = \alpha_{X/A} - \alpha_{P/A} - \omega_{P/A}\times\omega_{X/P}`.
    """

    def __init__(self, tree, base):
        self.tree, self.base = tree, base
        self._down: dict = {}

    def of(self, X):
        tree, P = self.tree, self.base
        A = tree.common_ancestor(X, P)
        if A is P:
            return self._from(A, X)
        wx, px, ax = self._from(A, X)
        wp, pp, ap = self._from(A, P)
        wpx = tree.express(wp, P, X)
        w = vadd(wx, vneg(wpx))
        parts = dict(px)
        for r, v in pp.items():
            parts[r] = vadd(parts.get(r, ZERO3), vneg(tree.express(v, P, X)))
        parts = {r: v for r, v in parts.items() if not is_zero(v)}
        alpha = vadd(ax, vneg(tree.express(ap, P, X)), vneg(cross(wpx, w)))
        return w, parts, alpha

    def _from(self, A, X):
        """Relative to ``A``, an ancestor of ``X`` (or ``X`` itself)."""
        key = (A, X)
        hit = self._down.get(key)
        if hit is not None:
            return hit
        tree = self.tree
        if X is A:
            out = (ZERO3, {}, ZERO3)
        elif X.omega_override is not None:
            wa = tree.express(tree.omega(A), A, X)
            w = vadd(X.omega_override, vneg(wa))
            parts = {}
            for r in range(len(tree.speeds)):
                v = tree.d_du(X.omega_override, r)
                pa = tree.omega_partials(A).get(r)
                if pa is not None:
                    v = vadd(v, vneg(tree.express(pa, A, X)))
                if not is_zero(v):
                    parts[r] = v
            alpha = vadd(tree.alpha_rest(X), vneg(tree.express(tree.alpha_rest(A), A, X)),
                         vneg(cross(wa, w)))
            out = (w, parts, alpha)
        else:
            wy, py, ay = self._from(A, X.parent)
            rate, partial, acc = tree.theta_dot(X)
            RT = transpose(X.R_parent)
            e = unit(X.axis)
            wy_x = matvec(RT, wy)
            w = vadd(wy_x, vscale(rate, e))
            parts = {r: matvec(RT, v) for r, v in py.items()}
            for r, c in partial.items():
                parts[r] = vadd(parts.get(r, ZERO3), vscale(c, e))
            parts = {r: v for r, v in parts.items() if not is_zero(v)}
            alpha = vadd(matvec(RT, ay), vscale(acc, e), cross(wy_x, vscale(rate, e)))
            out = (w, parts, alpha)
        self._down[key] = out
        return out


class NewtonEuler:
    """The Newton–Euler quantities of one model, built into one program.

    Construction runs the outward pass and collects every body's inertia and
    loads; :meth:`mass_matrix`, :meth:`forcing`, :meth:`articulated` and
    :meth:`reactions` build on it.
    """

    def __init__(self, prep: Prepared, bodies: BodyTree | None = None):
        self.prep = prep
        self.tree = prep.tree
        self.bt = bodies or build_bodies(prep)
        self.bodies: list[Body] = self.bt.bodies
        self.nu = prep.layout.n_u
        self.P = ProgramBuilder("ne")
        self._rotations: dict = {}
        g = prep.gravity
        self._gravity = (vadd(*(self.tree.express(c, n, self.bt.ground_frame) for n, c in g))
                         if g else None)
        self.tau: dict = defaultdict(list)         # generalized forces of loads on massless parts
        self._loads: dict = defaultdict(list)      # body -> [(moment, force)] in body components
        self._collect_loads()
        self.kin: dict = {}
        for b in self.bodies:
            self._outward(b)
        self.inertia = {b: self._inertia(b) for b in self.bodies}
        self.g = {b: self._wrench(b) for b in self.bodies}

    # ------------------------------------------------------------------ geometry
    def _to_child(self, b: Body):
        src = b.parent.frame if b.parent is not None else self.bt.ground_frame
        return lambda v: self.tree.express(v, src, b.frame)

    def _to_parent(self, b: Body):
        dst = b.parent.frame if b.parent is not None else self.bt.ground_frame
        return lambda v: self.tree.express(v, b.frame, dst)

    def _rotation(self, b: Body) -> Rotation:
        """Child-to-parent rotation of ``b`` (a simple rotation when the joint is one)."""
        hit = self._rotations.get(b)
        if hit is None:
            node = b.frame
            parent = b.parent.frame if b.parent is not None else self.bt.ground_frame
            if node.parent is parent and node.omega_override is None and node.axis:
                hit = Rotation.simple(node.axis, sm.cos(node.angle), sm.sin(node.angle), self.P)
            else:
                to_parent = self._to_parent(b)
                cols = [to_parent(unit(j + 1)) for j in range(3)]
                hit = Rotation(tuple(tuple(cols[j][i] for j in range(3)) for i in range(3)))
            self._rotations[b] = hit
        return hit

    def _congruence(self, c: Body, I):
        return congruence(I, self._rotation(c), self.kin[c]["r"])

    def _offset(self, atoms, frame):
        """Sum of atoms' components, expressed in ``frame``."""
        tree = self.tree
        return vadd(ZERO3, *(tree.express(a.c, a.frame, frame) for a in atoms))

    # ------------------------------------------------------------------ outward pass
    def _outward(self, b: Body) -> None:
        tree, P = self.tree, self.P
        p = b.parent
        base = p.frame if p is not None else self.bt.ground_frame
        if p is not None:
            wp, ap_ang, ap_lin = self.kin[p]["omega"], self.kin[p]["alpha"], self.kin[p]["acc"]
        else:   # gravity enters as an upward acceleration of the ground (see _wrench)
            wp = ap_ang = ZERO3
            ap_lin = vneg(self._gravity) if self._gravity is not None else ZERO3
        rel = _Relative(tree, base)
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
        to_child = self._to_child(b)
        r = P.vector(r)
        wp_b = to_child(wp)
        omega = P.vector(vadd(wp_b, w_rel))
        alpha = P.vector(vadd(to_child(ap_ang), a_rel_ang, cross(wp_b, w_rel)))
        acc = to_child(vadd(ap_lin, cross(ap_ang, r), cross(wp, cross(wp, r)),
                            vscale(TWO, cross(wp, v_rel)), a_rel))
        acc = P.vector(acc)
        S = {}
        for k in sorted(set(w_parts) | set(v_parts)):
            col = join(w_parts.get(k, ZERO3), to_child(v_parts.get(k, ZERO3)))
            if not all(x == 0 for x in col):
                S[k] = P.vector(col)
        self.kin[b] = dict(omega=omega, alpha=alpha, acc=acc, r=r, S=S)

    # ------------------------------------------------------------------ inertia and loads
    def _inertia(self, b: Body):
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
        return dict(m=mass, h=h, IJ=IJ, spatial=spatial_inertia(mass, h, IJ))

    def _collect_loads(self) -> None:
        prep, bt, tree = self.prep, self.bt, self.tree
        root = bt.ground_frame

        def at_point(point, vector_terms, sign):
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

        def on_frame(node, vector_terms, sign):
            if not vector_terms or bt.rigid[node] is bt.rigid[root]:
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

    def _wrench(self, b: Body):
        """``g_b``: applied minus inertial (with ``u' = 0``) force about ``J_b``, body components.

        Gravity is not among the applied loads: the outward pass starts from a
        ground accelerating at ``-g``, which shifts every body's acceleration by
        ``-g`` and so adds exactly ``(h x g, m g)`` to ``g_b``, one vector per
        tree rather than one per body.
        """
        k, inn = self.kin[b], self.inertia[b]
        w, alpha, acc = k["omega"], k["alpha"], k["acc"]
        m, h, IJ = inn["m"], inn["h"], inn["IJ"]
        n_in = vadd(matvec(IJ, alpha), cross(h, acc), cross(w, matvec(IJ, w)))
        f_in = vadd(vscale(m, acc), cross(alpha, h), cross(w, cross(w, h)))
        n_app, f_app = [ZERO3], [ZERO3]
        for n, f in self._loads.get(b, ()):
            n_app.append(n)
            f_app.append(f)
        return self.P.vector(join(vadd(*n_app, vneg(n_in)), vadd(*f_app, vneg(f_in))))

    # ------------------------------------------------------------------ equations of motion
    def _children_sum(self, b: Body, of: dict):
        """``sum_c X_c^T of[c]`` over the children of ``b``."""
        terms = [force_to_parent(of[c], self._to_parent(c), self.kin[c]["r"]) for c in b.children]
        return tuple(add(*(t[i] for t in terms)) for i in range(6)) if terms else ZERO6

    def forcing(self) -> list:
        """``F``: projections of the inward sums of ``g`` on the joints' free motions."""
        G = {}
        for b in reversed(self.bodies):
            G[b] = self.P.vector(vadd6(self.g[b], self._children_sum(b, G)))
        F = [list(self.tau.get(k, ())) for k in range(self.nu)]
        for b in self.bodies:
            for k, s in self.kin[b]["S"].items():
                F[k].append(dot6(s, G[b]))
        return [add(*f) for f in F]

    def mass_matrix(self) -> list:
        """``M`` by composite rigid bodies (rows of sympy expressions)."""
        P = self.P
        IC = {}
        for b in reversed(self.bodies):
            low = {(i, j): self.inertia[b]["spatial"][i][j] for i in range(6) for j in range(i + 1)}
            for c in b.children:
                con = self._congruence(c, IC[c])
                low = {key: add(v, con[key]) for key, v in low.items()}
            IC[b] = symmetric({key: P.scalar(v) for key, v in low.items()})
        M = [[[] for _ in range(self.nu)] for _ in range(self.nu)]
        for j in self.bodies:
            for s, col in self.kin[j]["S"].items():
                f = P.vector(matvec6(IC[j], col))
                i = j
                while i is not None:
                    for r, row in self.kin[i]["S"].items():
                        term = dot6(row, f)
                        M[r][s].append(term)
                        if i is not j:
                            M[s][r].append(term)
                    if i.parent is not None:
                        f = P.vector(force_to_parent(f, self._to_parent(i), self.kin[i]["r"]))
                    i = i.parent
        return [[add(*M[r][s]) if r >= s else None for s in range(self.nu)]
                for r in range(self.nu)]

    # ------------------------------------------------------------------ articulated bodies
    def owners(self) -> dict | None:
        """Speed -> owning body when every speed belongs to exactly one joint, else None."""
        owner = {}
        for b in self.bodies:
            for k in self.kin[b]["S"]:
                if k in owner:
                    return None
                owner[k] = b
        return owner if len(owner) == self.nu else None

    def articulated(self) -> list | None:
        """``u'`` by the articulated-body recursion, or None when it does not apply."""
        if self.owners() is None:
            return None
        P = self.P
        tau = {k: add(*v) for k, v in self.tau.items()}
        IA, pA, joint = {}, {}, {}
        for b in reversed(self.bodies):
            low = {(i, j): self.inertia[b]["spatial"][i][j] for i in range(6) for j in range(i + 1)}
            bias = vneg6(self.g[b])
            for c in b.children:
                Ia, pa = joint[c]["Ia"], joint[c]["pa"]
                con = self._congruence(c, Ia)
                low = {key: add(v, con[key]) for key, v in low.items()}
                bias = vadd6(bias, force_to_parent(pa, self._to_parent(c), self.kin[c]["r"]))
            I = symmetric({key: P.scalar(v) for key, v in low.items()})
            p = P.vector(bias)
            IA[b], pA[b] = I, p
            S = self.kin[b]["S"]
            ks = sorted(S)
            U = [P.vector(matvec6(I, S[k])) for k in ks]
            D = [[dot6(S[ks[i]], U[j]) for j in range(len(ks))] for i in range(len(ks))]
            u = [add(tau.get(k, S0), mul(-1, dot6(S[k], p))) for k in ks]
            solve = _SmallSolve(P, D) if ks else None
            if ks:
                Dinv_u = solve(u)
                W = [solve([U[i][row] for i in range(len(ks))]) for row in range(6)]
                low = {(i, j): add(I[i][j], mul(-1, add(*(mul(U[k][i], W[j][k])
                                                          for k in range(len(ks))))))
                       for i in range(6) for j in range(i + 1)}
                pa = vadd6(p, tuple(add(*(mul(U[k][i], Dinv_u[k]) for k in range(len(ks))))
                                    for i in range(6)))
                m = _unit_index(S[ks[0]]) if len(ks) == 1 else None
                if m is not None:
                    # S = e_m: row and column m of I - U U^T / D vanish exactly, and
                    # component m of the bias is the joint's generalized force.
                    low = {(i, j): S0 if m in (i, j) else v for (i, j), v in low.items()}
                    pa = tuple(mul(S[ks[0]][m], tau.get(ks[0], S0)) if i == m else v
                               for i, v in enumerate(pa))
                Ia = symmetric({key: P.scalar(v) for key, v in low.items()})
                pa = P.vector(pa)
            else:
                Ia, pa = I, p
            joint[b] = dict(Ia=Ia, pa=pa, U=U, u=u, solve=solve, ks=ks)
        accel = {}
        udot = [S0] * self.nu
        for b in self.bodies:
            if b.parent is not None:
                a = motion_to_child(accel[b.parent], self._to_child(b), self.kin[b]["r"])
            else:
                a = ZERO6
            jt = joint[b]
            ks = jt["ks"]
            if ks:
                rhs = [add(jt["u"][i], mul(-1, dot6(jt["U"][i], a))) for i in range(len(ks))]
                qdd = [P.scalar(x) for x in jt["solve"](rhs)]
                for k, x in zip(ks, qdd):
                    udot[k] = x
                    a = vadd6(a, tuple(mul(x, s) for s in self.kin[b]["S"][k]))
            accel[b] = P.vector(a)
        return udot

    # ------------------------------------------------------------------ reactions
    def constraint_loads(self, constraints) -> dict:
        """Body -> [(moment, force)] of point constraints' forces, in multiplier placeholders.

        ``constraints`` in the order of their rows (multiplier ``k`` belongs to
        row ``k``): a ``no_slip`` row's force ``lambda_k e`` acts on its body at the
        contact point, a ``coincident`` row's ``lambda_k e`` on the body holding
        the first point and ``-lambda_k e`` on the body holding the second.
        Stated (expression) constraints have no point of application and give none.
        """
        prep, bt, tree = self.prep, self.bt, self.tree
        lam = lambda_symbols(len(constraints))
        out: dict = defaultdict(list)
        by_element = {me.name: b for b in self.bodies for me, _ in b.elements}
        for k, c in enumerate(constraints):
            if not c.points:
                continue
            node = prep.frame_nodes[c.frame]
            e = vscale(lam[k], unit(c.axis))
            if c.kind == "holonomic":
                targets = [(c.points[0], bt.body_of_point(c.points[0]), 1),
                           (c.points[1], bt.body_of_point(c.points[1]), -1)]
            else:
                targets = [(c.points[0], by_element.get(c.body.name), 1)]
            for point, body, sign in targets:
                if not isinstance(body, Body):
                    continue
                f = vscale(sm.Integer(sign), tree.express(e, node, body.frame))
                rel = [(s, a) for s, a in _signed(prep.point_atoms[point],
                                                   prep.point_atoms[body.point])]
                rho = vadd(ZERO3, *(vscale(sm.Integer(s), tree.express(a.c, a.frame, body.frame))
                                    for s, a in rel))
                out[body].append((cross(rho, f), f))
        return out

    def reactions(self, udot=None, extra=None) -> JointLoads:
        """Force and moment of every joint (parent on child, at the joint point).

        ``udot``: the accelerations (default: the placeholders of
        :func:`~mbgen.symbolic.equations.acceleration_symbols`, so that the reactions
        hold for whatever ``M u' = F`` gives).  ``extra``: further loads on
        bodies (:meth:`constraint_loads`), which do not enter ``F``.
        """
        P, tree = self.P, self.tree
        udot = acceleration_symbols(self.nu) if udot is None else udot
        accel = {}
        for b in self.bodies:
            a = (motion_to_child(accel[b.parent], self._to_child(b), self.kin[b]["r"])
                 if b.parent is not None else ZERO6)
            for k, s in self.kin[b]["S"].items():
                a = vadd6(a, tuple(mul(udot[k], x) for x in s))
            accel[b] = P.vector(a)
        f = {}
        extra = extra or {}
        for b in reversed(self.bodies):
            own = vadd6(matvec6(self.inertia[b]["spatial"], accel[b]), vneg6(self.g[b]))
            for n, force in extra.get(b, ()):
                own = vadd6(own, vneg6(join(n, force)))
            f[b] = P.vector(vadd6(own, self._children_sum(b, f)))
        rows = []
        for b in self.bodies:
            n, force = split(f[b])
            rows.append(tuple(tree.express(force, b.frame, b.reaction_frame)) +
                        tuple(tree.express(n, b.frame, b.reaction_frame)))
        return JointLoads(
            names=tuple(b.joint for b in self.bodies),
            children=tuple(b.name for b in self.bodies),
            parents=tuple(b.parent.name if b.parent is not None else None for b in self.bodies),
            points=tuple(b.point.name for b in self.bodies),
            frames=tuple(b.reaction_frame.name for b in self.bodies),
            matrix=sm.ImmutableMatrix(rows) if rows else sm.ImmutableMatrix(0, 6, []))


def _unit_index(col):
    """Index ``m`` when ``col`` is ``+-e_m`` (one entry of absolute value 1, the rest zero)."""
    nz = [i for i, x in enumerate(col) if x != 0]
    if len(nz) == 1 and abs(col[nz[0]]) == 1:
        return nz[0]
    return None


class _SmallSolve:
    """Solve ``D x = b`` for a small symmetric positive definite ``D`` by ``L D L^T``.

    Pivots become checked program symbols (a non-positive pivot means the
    articulated inertia is not positive definite).
    """

    def __init__(self, P: ProgramBuilder, D):
        n = len(D)
        L = [[S0] * n for _ in range(n)]
        d = [S0] * n
        inv = [S0] * n
        for j in range(n):
            dj = add(D[j][j], *(mul(-1, mul(mul(L[j][k], L[j][k]), d[k])) for k in range(j)))
            d[j] = P.scalar(dj, check=True)
            inv[j] = P.scalar(1 / d[j])
            for i in range(j + 1, n):
                lij = add(D[i][j], *(mul(-1, mul(mul(L[i][k], L[j][k]), d[k])) for k in range(j)))
                L[i][j] = P.scalar(mul(lij, inv[j]))
        self.n, self.L, self.inv = n, L, inv

    def __call__(self, b) -> list:
        n, L = self.n, self.L
        y = list(b)
        for i in range(n):
            y[i] = add(y[i], *(mul(-1, mul(L[i][k], y[k])) for k in range(i)))
        y = [mul(y[i], self.inv[i]) for i in range(n)]
        for i in reversed(range(n)):
            y[i] = add(y[i], *(mul(-1, mul(L[k][i], y[k])) for k in range(i + 1, n)))
        return y


def vadd6(a, b) -> tuple:
    return tuple(add(x, y) for x, y in zip(a, b))


def vneg6(a) -> tuple:
    return tuple(mul(-1, x) for x in a)


def newton_euler(model: Model, energy: bool = True, points=(), reactions: bool = True,
                 articulated: bool = True, prep=None) -> Equations:
    """Derive ``M u' = F``, ``q' = G`` by Newton–Euler over the body tree.

    With ``reactions`` the joint reactions are derived too; with
    ``articulated`` the articulated-body recursion for ``u'`` when every speed
    belongs to exactly one joint.
    """
    prep = prep or prepare(model)
    ne = NewtonEuler(prep)
    layout = prep.layout
    F = ne.forcing()
    rows = ne.mass_matrix()
    nu = layout.n_u
    M = [[rows[max(r, s)][min(r, s)] for s in range(nu)] for r in range(nu)]
    udot = ne.articulated() if articulated else None
    loads = ne.reactions(extra=ne.constraint_loads(ordered(model))) if reactions else None
    kinetic, potential = energies(prep, Grouping(prep)) if energy else (None, None)
    return Equations(
        name=model.name,
        layout=layout,
        mass_matrix=sm.ImmutableMatrix(M),
        forcing=sm.ImmutableMatrix(F),
        kinematics=sm.ImmutableMatrix([prep.qdot[q] for q in layout.coordinates]),
        kinetic_energy=kinetic,
        potential_energy=potential,
        points=point_kinematics(prep, points),
        source=f"mbgen.Model {model.name!r}",
        method="newton_euler",
        program=ne.P.build(),
        accelerations=sm.ImmutableMatrix(udot) if udot is not None else None,
        reactions=loads,
    )


def reactions_for(prep: Prepared) -> tuple:
    """``(program, JointLoads)`` for a model derived by another method (Kane)."""
    ne = NewtonEuler(prep)
    loads = ne.reactions(extra=ne.constraint_loads(ordered(prep.model)))
    return ne.P.build(), loads


__all__ = ["NewtonEuler", "newton_euler", "reactions_for"]
