r"""Analytic partial derivatives of inverse dynamics on a tree of revolute and prismatic joints.

The state Jacobian of ``u'`` is :math:`M^{-1}\,\partial R/\partial x` with
:math:`R = F - M u'` at ``u'`` held (:mod:`mbgen.codegen.outputs`).  Forward-mode
tangents through the Newton–Euler program cost one pass per variable, every body
below a joint carried in its own frame: :math:`O(n^2)` 6-vector transports of
about 200 operations each.  Here :math:`\partial\tau/\partial q` and
:math:`\partial\tau/\partial u` of the inverse dynamics
:math:`\tau = \mathrm{ID}(q, u, u')` come instead from the analytic derivatives of
Carpentier & Mansard (RSS 2018), with world-frame spatial quantities at the
world origin (motions ``(w, v)``, forces ``(n, f)``, angular part first), so that
a pair of joints costs a few 6-vector dot products.

**Where it applies** (:func:`screw_joints`): no constraints, and every body moves
relative to its parent by one coordinate ``q_k`` with ``q_k' = u_k``: turning about
a fixed axis through its joint point (revolute; constant rotations before and after
are allowed, the angle may be ``a q_k + b``) or sliding along a fixed axis
(prismatic).  A coordinate may move several bodies (a mimic joint): each body is a
column of its own and the coordinate's rows and columns sum theirs.  The root may be
free (:func:`free_root`: a floating base, six speeds along the body's unit twists, a
quaternion): its rows against every joint are the ancestor formulas below with its six
world columns; its own columns are the same formulas for a joint whose parent, the ground,
does not move, and whose columns move with it (:func:`inertial_partials`); its coordinates'
columns (a quaternion's four and a position's three) are its tangent columns times the body
twist of each coordinate (:func:`root_coordinates`).  Then ``S_b`` is constant in the body,
:math:`\partial(\cdot)/\partial q_k` of everything below joint ``k`` is the
twist ``S_k`` (world :math:`J_k`), and in the world frame

.. math::

    v_b = v_p + J_b u_b, \qquad a_b = a_p + J_b u'_b + (v_p\times J_b)\,u_b,
    \qquad a_{ground} = (0, -g),

    f_b = Y_b a_b + v_b\times^* Y_b v_b, \qquad
    B_b\,\delta = v_b\times^*(Y_b\delta) - Y_b(v_b\times\delta) + \delta\times^*(Y_b v_b).

Per joint: :math:`\dot V_q = v_p\times J`, :math:`\dot A_q = a_p\times J + v_p\times\dot V_q`,
:math:`\dot A_v = 2\,v_p\times J`.  Backward over composites ``Y^C, B^C, f^C``
(subtree sums): :math:`F_a = Y^C J`, :math:`F_q = B^C\dot V_q + Y^C\dot A_q`,
:math:`F_v = B^C J + Y^C\dot A_v`, :math:`T = B^{C\,T} J`; then for ``d`` a
strict descendant of ``b``

.. math::

    \partial\tau_d/\partial q_b = F_{a,d}\cdot\dot A_{q,b} + T_d\cdot\dot V_{q,b},\qquad
    \partial\tau_d/\partial u_b = F_{a,d}\cdot\dot A_{v,b} + T_d\cdot J_b,

    \partial\tau_b/\partial q_d = J_b\cdot(F_{q,d} + J_d\times^* f^C_d),\qquad
    \partial\tau_b/\partial u_d = J_b\cdot F_{v,d},

and on the diagonal :math:`J_b\cdot F_{q,b}`, :math:`J_b\cdot F_{v,b}`.  ``B`` needs
12 numbers, not 36 (:meth:`_World._coriolis`).  Loads
other than gravity (and generalized forces on massless parts) enter ``R`` as
:math:`\tau^{app}_k + \sum_b S_{b,k}\cdot G^{app}_b`, differentiated through the
program in forward mode (cheap: they touch few bodies).  A joint's armature adds
:math:`-a_k u'_k` to ``R`` (:meth:`~mbgen.derivation.recursion.NewtonEuler.residual`):
a constant times the held ``u'``, it changes neither partial.  Every per-body quantity
is a named intermediate: :math:`O(n)` 6x6 work and :math:`O(n^2)` dot products.

The Jacobians need ``u'`` first: they solve ``M u' = F`` with ``M`` and ``F`` from the same
world-frame quantities (:func:`mass_and_bias`: :math:`M_{bd} = J_b\cdot F_{a,d}`, a dot
product per pair), not the derivation's own, which carry forces up the chain in the
bodies' frames (G1's ``jacobian``: 22 % fewer operations, 14 % less time).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sm

from ..symbolic.pairs import ANCESTOR, DESCENDANT, ChainPairs
from ..symbolic.program import Program, derivatives
from .joints import Body
from .rnea_scope import free_root, screw_joints
from .spatial import ZERO6, dot6, fcross, join, matmul3, mcross, scale6, skew, split, vadd6
from .tree import S0, ZERO3, add, cross, dot3, matvec, mul, vadd, vneg, vscale

TWO = sm.Integer(2)

#: Fewest joints on the longest chain from the root (a free root not counted), or in all on a
#: free root, for which the analytic partials are used: below, forward mode through the
#: program gives fewer operations after CSE, its transports running down short chains only
#: (analytic / forward: spatial arm, Jacobian alone: 386 / 235 at n = 2, 2,341 / 2,036 at 4,
#: 3,479 / 3,526 at 5, 21,277 / 43,907 at 16).  On a free root forward mode pays one pass over
#: every body for each of the root's 13 columns, so the count there is of all the joints
#: (RHS, jacobian and tangent_jacobian: a hopper's 2 joints 7,768 / 5,195; legs of 3 joints
#: with tilted axes, 1, 2, 3, 4 of them: 13,762 / 14,693, 25,744 / 31,178, 37,025 / 46,974,
#: 48,713 / 63,234; Solo-12 36,260 / 39,828; ANYmal B 38,937 / 46,492; G1 122,496 / 242,063).
MIN_SPEEDS = 5


# ---------------------------------------------------------------- spatial algebra (world)
def inertia_action(Y, x) -> tuple:
    """``Y x`` for the inertia ``Y = (m, h, I)`` about the origin: ``(I w + h x v, m v - h x w)``
    (``x = (w, v)``)."""
    m, h, I = Y
    w, v = split(x)
    return join(vadd(matvec(I, w), cross(h, v)), vadd(vscale(m, v), vneg(cross(h, w))))


def coriolis_action(B, x) -> tuple:
    """``B x`` for ``B = (B_ww, p)`` (see :meth:`_World._coriolis`): ``(B_ww x_w, -2 p x x_w)``."""
    Bww, p = B
    w = x[:3]
    return join(matvec(Bww, w), vscale(-TWO, cross(p, w)))


def coriolis_transpose_action(B, x) -> tuple:
    """``B^T x``: ``(B_ww^T x_w + 2 p x x_v, 0)``."""
    Bww, p = B
    BT = tuple(tuple(Bww[j][i] for j in range(3)) for i in range(3))
    return join(vadd(matvec(BT, x[:3]), vscale(TWO, cross(p, x[3:]))), ZERO3)


# ---------------------------------------------------------------- where it applies
# screw_joints and free_root: mbgen.derivation.rnea_scope
def worth_it(ne, joints) -> bool:
    """Whether the analytic partials give fewer operations than forward mode (by
    :data:`MIN_SPEEDS`): the longest chain, or on a free root all the joints."""
    free = len(joints) < len(ne.bodies)     # screw_joints leaves out only a free root
    counted = len(joints) if free else longest_chain(ne, joints)
    return counted >= MIN_SPEEDS


def longest_chain(ne, joints) -> int:
    """Joints (bodies of ``joints``) on the longest path from the root to a leaf."""
    depth: dict = {}
    for b in ne.bodies:     # parents come first
        depth[b] = (b in joints) + (depth[b.parent] if b.parent is not None else 0)
    return max(depth.values(), default=0)


# ---------------------------------------------------------------- the partials
class _World:
    """Forward pass: each body's world rotation, joint point, ``J``, velocities, inertia."""

    def __init__(self, ne, joints, udot):
        self.ne, self.P = ne, ne.P
        g = ne.gravity
        self.ground_acc = ground_acc = join(ZERO3, vneg(g) if g is not None else ZERO3)
        self.R, self.c, self.J, self.v, self.a = {}, {}, {}, {}, {}
        self.a0, self.f0 = {}, {}     # a, f at u' = 0: the bias of the Jacobians' own F
        self.Y, self.B, self.f = {}, {}, {}
        self.Vq, self.Aq, self.Av = {}, {}, {}
        self.columns: dict = {}     # the free root's world columns, speed index -> J
        for b in ne.bodies:
            if b in joints:
                self._forward(b, joints[b][1], udot, ground_acc)
            else:
                self._free(b, udot, ground_acc)

    def _free(self, b, udot, ground_acc):
        """The free root: ``v = sum_k J_k u_k``, ``a = a_ground + sum_k J_k u'_k`` (its
        parent, the ground, does not move: the velocity product ``v_p x J u`` vanishes)."""
        ne, P = self.ne, self.P
        R = tuple(tuple(P.scalar(x) for x in row) for row in ne.rotation(b).matrix)
        c = P.vector(ne.kin[b].r)
        speeds = ne.prep.layout.speeds
        v, a = ZERO6, ground_acc
        for k, col in sorted(ne.kin[b].S.items()):
            sw, sv = split(col)
            w = P.vector(matvec(R, sw))
            J = join(w, P.vector(vadd(matvec(R, sv), cross(c, w))))
            self.columns[k] = J
            v = vadd6(v, scale6(speeds[k], J))
            a = vadd6(a, scale6(udot[k], J))
        v, a = P.vector(v), P.vector(a)
        Y = self._inertia(b, R, c)
        h = P.vector(inertia_action(Y, v))
        self.R[b], self.c[b], self.v[b], self.a[b], self.Y[b] = R, c, v, a, Y
        self.a0[b] = ground_acc
        self.f0[b] = P.vector(vadd6(inertia_action(Y, ground_acc), fcross(v, h)))
        self.B[b] = self._coriolis(split(v), Y, h)
        self.f[b] = P.vector(vadd6(inertia_action(Y, a), fcross(v, h)))

    def _forward(self, b, k, udot, ground_acc):
        ne, P = self.ne, self.P
        p = b.parent
        Rb = ne.rotation(b).matrix
        if p is None:
            R, c = Rb, ne.kin[b].r
            vp, ap, ap0 = ZERO6, ground_acc, ground_acc
        else:
            R = matmul3(self.R[p], Rb)
            c = vadd(self.c[p], matvec(self.R[p], ne.kin[b].r))
            vp, ap, ap0 = self.v[p], self.a[p], self.a0[p]
        R = tuple(tuple(P.scalar(x) for x in row) for row in R)
        c = P.vector(c)
        sw, sv = split(ne.kin[b].S[k])
        w = P.vector(matvec(R, sw))
        J = join(w, P.vector(vadd(matvec(R, sv), cross(c, w))))
        Vq = P.vector(mcross(vp, J))
        u, ud = ne.prep.layout.speeds[k], udot[k]
        v = P.vector(vadd6(vp, scale6(u, J)))
        a = P.vector(vadd6(vadd6(ap, scale6(ud, J)), scale6(u, Vq)))
        Aq = P.vector(vadd6(mcross(ap, J), mcross(vp, Vq)))
        Av = scale6(TWO, Vq)
        Y = self._inertia(b, R, c)
        h = P.vector(inertia_action(Y, v))
        f = P.vector(vadd6(inertia_action(Y, a), fcross(v, h)))
        B = self._coriolis(split(v), Y, h)
        self.R[b], self.c[b], self.J[b], self.v[b], self.a[b] = R, c, J, v, a
        self.Y[b], self.B[b], self.f[b] = Y, B, f
        self.a0[b] = a0 = P.vector(vadd6(ap0, scale6(u, Vq)))
        self.f0[b] = P.vector(vadd6(inertia_action(Y, a0), fcross(v, h)))
        self.Vq[b], self.Aq[b], self.Av[b] = Vq, Aq, Av

    def _coriolis(self, v, Y, h):
        r"""``B`` of one body as ``(B_ww, p)``: :math:`B = [[B_{ww}, 0], [-2[p\times], 0]]`
        for the velocity ``v = (w, v_l)``, the inertia ``Y = (m, h_O, I)`` (``h_O`` the
        first moment about the origin) and the momentum ``h = Y v = (h_n, p)``,

        .. math::

            B_{ww} = [w\times] I - I [w\times] + 2 (v_l\cdot h_O) 1 - h_O v_l^T - v_l h_O^T
                     - [h_n\times]

        (the right column vanishes: :math:`w\times h_O + m v_l = p`)."""
        P, (w, vl), (_, hO, I) = self.P, v, Y
        hn, p = split(h)
        wx = skew(w)
        WI, IW = matmul3(wx, I), matmul3(I, wx)
        two = mul(TWO, dot3(vl, hO))
        hnx = skew(hn)
        B = tuple(tuple(P.scalar(add(WI[i][j], mul(-1, IW[i][j]), two if i == j else S0,
                                     mul(-1, mul(hO[i], vl[j])), mul(-1, mul(vl[i], hO[j])),
                                     mul(-1, hnx[i][j])))
                        for j in range(3)) for i in range(3))
        return B, p

    def _inertia(self, b, R, c):
        r"""``(m, h_O, I_O)`` about the world origin: :math:`h_O = R h + m c`,
        :math:`I_O = R I_J R^T + (m\,c\cdot c + 2\,c\cdot h)\,1 - (m\,c c^T + c h^T + h c^T)`."""
        P, inn = self.P, self.ne.inertia[b]
        m = inn.m
        h = P.vector(matvec(R, inn.h))
        RI = matmul3(R, inn.IJ)
        RT = tuple(tuple(R[j][i] for j in range(3)) for i in range(3))
        IJ = matmul3(RI, RT)
        diag = add(mul(m, dot3(c, c)), mul(TWO, dot3(c, h)))
        mc = vscale(m, c)
        low = {}
        for i in range(3):
            for j in range(i + 1):
                term = add(IJ[i][j], diag if i == j else S0,
                           mul(-1, add(mul(mc[i], c[j]), mul(c[i], h[j]), mul(h[i], c[j]))))
                low[(i, j)] = P.scalar(term)
        I = tuple(tuple(low[(max(i, j), min(i, j))] for j in range(3)) for i in range(3))
        return m, P.vector(vadd(h, mc)), I


def _sum_inertia(P, Ys):
    m = P.scalar(add(*(Y[0] for Y in Ys)))
    h = P.vector(vadd(*(Y[1] for Y in Ys)))
    low = {(i, j): P.scalar(add(*(Y[2][i][j] for Y in Ys))) for i in range(3)
           for j in range(i + 1)}
    I = tuple(tuple(low[(max(i, j), min(i, j))] for j in range(3)) for i in range(3))
    return m, h, I


@dataclass(frozen=True)
class RootColumns:
    r"""A free root's own columns of :math:`\partial\tau`: ``tangent[i][k]`` is
    :math:`\partial\tau_i/\partial\delta_k` for the root moved along its ``k``-th speed's
    body twist (:math:`M \exp(S_k \delta_k)`); ``R``, ``c`` its world rotation and origin,
    ``S`` its speeds' body columns (speed index -> 6-vector)."""

    body: Body
    tangent: list
    R: tuple
    c: tuple
    S: dict


def _composite(P, W, b, kids, Yc, Bc, fc) -> None:
    """``Y^C, B^C, f^C`` of ``b``'s subtree: its own plus its children's."""
    if not kids:
        Yc[b], Bc[b], fc[b] = W.Y[b], W.B[b], W.f[b]
        return
    Yc[b] = _sum_inertia(P, [W.Y[b]] + [Yc[c] for c in kids])
    Bc[b] = (tuple(tuple(P.scalar(add(W.B[b][0][i][j], *(Bc[c][0][i][j] for c in kids)))
                         for j in range(3)) for i in range(3)),
             P.vector(vadd(W.B[b][1], *(Bc[c][1] for c in kids))))
    fc[b] = P.vector(tuple(add(W.f[b][i], *(fc[c][i] for c in kids)) for i in range(6)))


def inertial_partials(ne, joints, udot) -> tuple[list, list, RootColumns | None, tuple,
                                                  ChainPairs | None]:
    r"""``(dtau_dq, dtau_du, root, (M, C), pairs)``: :math:`\partial\tau/\partial q`
    (``n_u x n_q``) and :math:`\partial\tau/\partial u` (``n_u x n_u``) of the inverse dynamics with
    gravity, ``u'`` the placeholders ``udot`` (rows of sympy expressions); a free root's
    speed columns are in ``dtau_du``, its coordinates' columns left zero and its tangent
    columns in ``root`` (:func:`root_coordinates` maps them).

    The root's own columns (:func:`free_root`; everything moves with it, the ground does
    not): :math:`\dot V_q = 0`, :math:`\dot A_q = a_{ground}\times J_k`,
    :math:`\dot A_v = v_{root}\times J_k` (:math:`\partial a_d/\partial u_k =
    J_k\times(v_d - v_{root})`); a descendant's row takes the formulas above, the root's
    rows :math:`J_j\cdot Y^C\dot A_q` and :math:`J_j\cdot(B^C J_k + Y^C\dot A_v)`: its
    columns move with it, and :math:`(J_k\times J_j)\cdot f^C` cancels
    :math:`J_j\cdot(J_k\times^* f^C)`.  ``(M, C)``: :func:`mass_and_bias`; ``pairs``: the
    vectors of the pair products on a chain (:func:`chain_pairs`), which ``dtau`` and ``M``
    hold too."""
    P, L = ne.P, ne.prep.layout
    W = _World(ne, joints, udot)
    dq = [[S0] * L.n_q for _ in range(L.n_u)]
    du = [[S0] * L.n_u for _ in range(L.n_u)]
    root = None
    Yc, Bc, fc, Fa, T, Fq, Fv, below = {}, {}, {}, {}, {}, {}, {}, {}
    for b in reversed(ne.bodies):
        kids = b.children
        below[b] = [d for c in kids for d in [c] + below[c]]
        _composite(P, W, b, kids, Yc, Bc, fc)
        if b not in joints:     # the free root: its rows against every column, and its own
            root = _root_columns(P, W, b, joints, below[b], (Yc[b], Bc[b], Fa, T, Fq, Fv),
                                 dq, du)
            continue
        J, Vq, Aq, Av = W.J[b], W.Vq[b], W.Aq[b], W.Av[b]
        qb, kb = joints[b]
        Fa[b] = P.vector(inertia_action(Yc[b], J))
        T[b] = P.vector(coriolis_transpose_action(Bc[b], J))
        Fq0 = P.vector(vadd6(coriolis_action(Bc[b], Vq), inertia_action(Yc[b], Aq)))
        Fq[b] = P.vector(vadd6(Fq0, fcross(J, fc[b])))
        Fv[b] = P.vector(vadd6(coriolis_action(Bc[b], J), inertia_action(Yc[b], Av)))
        dq[kb][qb] = add(dq[kb][qb], dot6(J, Fq0))
        du[kb][kb] = add(du[kb][kb], dot6(J, Fv[b]))
        for d in below[b]:     # summed: a coordinate may move several bodies (mimic joints)
            qd, kd = joints[d]
            dq[kd][qb] = add(dq[kd][qb], dot6(Fa[d], Aq), dot6(T[d], Vq))
            du[kd][kb] = add(du[kd][kb], dot6(Fa[d], Av), dot6(T[d], J))
            dq[kb][qd] = add(dq[kb][qd], dot6(J, Fq[d]))
            du[kb][kd] = add(du[kb][kd], dot6(J, Fv[d]))
    pairs = chain_pairs(ne, joints, W, (Fa, T, Fq, Fv))    # None with a free root
    return dq, du, root, mass_and_bias(ne, W, joints, below, Fa, Yc), pairs


def chain_pairs(ne, joints, W, vectors) -> ChainPairs | None:
    """The pair products' vectors (:class:`~mbgen.symbolic.pairs.ChainPairs`) where every
    body has a joint (no free root) and they form one chain of at least two bodies in the
    layout's order (body ``i``: coordinate ``q0 + i``, speed ``u0 + i``), else None."""
    bodies = list(ne.bodies)
    if len(bodies) < 2 or any(b not in joints for b in bodies) or \
            any(b.parent is not (bodies[i - 1] if i else None) for i, b in enumerate(bodies)):
        return None
    q0, u0 = joints[bodies[0]]
    if any(joints[b] != (q0 + i, u0 + i) for i, b in enumerate(bodies)):
        return None
    Fa, T, Fq, Fv = vectors
    own = {"J": W.J, "Aq": W.Aq, "Vq": W.Vq, "Av": W.Av, "Fa": Fa, "T": T, "Fq": Fq, "Fv": Fv}

    def rows(names):
        return sm.ImmutableMatrix([[own[name][b][c] for b in bodies]
                                   for name, (_, size) in names.items() for c in range(size)])
    return ChainPairs(len(bodies), q0, u0, rows(ANCESTOR), rows(DESCENDANT))


def mass_and_bias(ne, W, joints, below, Fa, Yc) -> tuple[list, list]:
    r"""``(M, C)``: the mass matrix (rows, ``n_u x n_u``) and the inertial bias
    :math:`C = \tau(q, u, 0)` with gravity, in the world-frame quantities the partials hold,
    for the Jacobians' own solve of :math:`M u' = F` with :math:`F = R^{app} - C`.

    :math:`M_{kl} = \sum J_b\cdot F_{a,d}` over the bodies ``b`` of ``k`` and ``d`` of
    ``l``, one an ancestor of the other or the same (:math:`F_a = Y^C J`: a dot product per
    pair, where the composite-rigid-body pass in the bodies' frames carries a force up the
    chain per pair), the armature on the diagonal; :math:`C_k = \sum J_b\cdot f^C_{0,b}`,
    :math:`f_0 = Y a_0 + v\times^* Y v` with :math:`a_0` the accelerations at
    :math:`u' = 0`.  A free root's columns ``J_k`` are joints of the root's body, its own
    block :math:`J_k\cdot Y^C J_l`."""
    P, n = ne.P, ne.nu
    M = [[S0] * n for _ in range(n)]
    C = [S0] * n
    fc0: dict = {}
    for b in reversed(ne.bodies):
        fc0[b] = P.vector(tuple(add(W.f0[b][i], *(fc0[c][i] for c in b.children))
                                for i in range(6))) if b.children else W.f0[b]
        if b in joints:
            pairs = [(joints[b][1], W.J[b])]
        else:        # the free root: its columns, and its own block
            pairs = list(W.columns.items())
            for k, Jk in pairs:
                YJ = P.vector(inertia_action(Yc[b], Jk))
                for m, Jm in pairs:
                    M[m][k] = add(M[m][k], dot6(Jm, YJ))
        for k, J in pairs:
            C[k] = add(C[k], dot6(J, fc0[b]))
            if b in joints:
                M[k][k] = add(M[k][k], dot6(J, Fa[b]))
            for d in below[b]:
                kd = joints[d][1]
                x = dot6(J, Fa[d])
                M[k][kd] = add(M[k][kd], x)
                M[kd][k] = add(M[kd][k], x)
    for k, a in ne.armature.items():
        M[k][k] = add(M[k][k], a)
    return M, C


def _root_columns(P, W, b, joints, below, parts, dq, du) -> RootColumns:
    """The free root ``b``'s rows against the joints' columns (into ``dq``, ``du``), its
    speeds' columns (into ``du``) and its tangent columns (returned); see
    :func:`inertial_partials`."""
    Yc, Bc, Fa, T, Fq, Fv = parts
    tangent = [dict.fromkeys(W.columns, S0) for _ in du]
    for k, Jk in W.columns.items():
        for d in below:
            qd, kd = joints[d]
            dq[k][qd] = add(dq[k][qd], dot6(Jk, Fq[d]))
            du[k][kd] = add(du[k][kd], dot6(Jk, Fv[d]))
        Aq = P.vector(mcross(W.ground_acc, Jk))
        Av = P.vector(mcross(W.v[b], Jk))
        Fq0 = P.vector(inertia_action(Yc, Aq))
        Fv0 = P.vector(vadd6(coriolis_action(Bc, Jk), inertia_action(Yc, Av)))
        for d in below:
            kd = joints[d][1]
            tangent[kd][k] = add(tangent[kd][k], dot6(Fa[d], Aq))
            du[kd][k] = add(du[kd][k], dot6(Fa[d], Av), dot6(T[d], Jk))
        for j, Jj in W.columns.items():
            tangent[j][k] = add(tangent[j][k], dot6(Jj, Fq0))
            du[j][k] = add(du[j][k], dot6(Jj, Fv0))
    return RootColumns(b, tangent, W.R[b], W.c[b], dict(W.ne.kin[b].S))


def root_coordinates(ne, root: RootColumns, coordinates) -> tuple[dict, Program]:
    r"""``({j: {k: e_kj}}, extra)``: each root coordinate ``q_j`` of ``coordinates`` (layout
    indices) as a body twist, :math:`\partial\delta_k/\partial q_j`, so that
    :math:`\partial\tau/\partial q_j = \sum_k \partial\tau/\partial\delta_k\,e_{kj}`;
    ``extra``: the forward-mode assignments of :math:`\partial R/\partial q_j`,
    :math:`\partial c/\partial q_j`.  The body twist of a change of ``q_j`` is
    :math:`(\omega, v) = (\mathrm{vex}(R^T \partial R/\partial q_j), R^T\partial c/\partial
    q_j)` (:math:`R^T\partial R` is skew: ``R`` is a rotation at every ``q``,
    :func:`free_root`), and ``e_kj = S_k\cdot(\omega, v)`` (the ``S_k`` orthonormal)."""
    L = ne.prep.layout
    R, c = root.R, root.c
    variables = [L.coordinates[j] for j in coordinates]
    extra, d = derivatives(ne.P.build(), [x for row in R for x in row] + list(c), variables,
                           "nert")

    def RT(i, x):     # (R^T x)_i
        return add(*(mul(R[m][i], x[m]) for m in range(3)))

    out = {}
    for col, j in enumerate(coordinates):
        dR = [[d[3 * m + i][col] for i in range(3)] for m in range(3)]
        dc = [d[9 + m][col] for m in range(3)]
        w = (RT(2, [dR[m][1] for m in range(3)]), RT(0, [dR[m][2] for m in range(3)]),
             RT(1, [dR[m][0] for m in range(3)]))
        twist = w + tuple(RT(i, dc) for i in range(3))
        out[j] = {k: add(*(mul(s, t) for s, t in zip(S_k, twist) if s != 0))
                  for k, S_k in root.S.items()}
    return out, extra


def applied_residual(ne) -> list:
    r"""``R^{app}_k = \tau_k + \sum_b S_{b,k}\cdot G^{app}_b``: the inward pass of
    :meth:`~mbgen.derivation.recursion.NewtonEuler.forcing` over the applied loads alone."""
    return ne.forcing({b: ne.applied_wrench(b) for b in ne.bodies})


@dataclass(frozen=True)
class Partials:
    r"""What :func:`residual_jacobian` derives: ``jacobian`` :math:`\partial R/\partial x`
    (``n_u x n_x``), ``tangent`` :math:`\partial R/\partial\delta` (``n_u x n_u``) or None,
    ``mass`` and ``forcing``, ``M`` and ``F`` for the Jacobians' own solve
    (:func:`mass_and_bias`), ``extra``, the forward-mode assignments that follow ``ne``'s
    program, and ``pairs``, the pair products of a chain as vectors (:func:`chain_pairs`;
    None where an applied load's derivative falls on a pair's entry)."""

    jacobian: sm.ImmutableMatrix
    tangent: sm.ImmutableMatrix | None
    mass: sm.ImmutableMatrix
    forcing: sm.ImmutableMatrix
    extra: Program
    pairs: ChainPairs | None = None


def residual_jacobian(ne, udot) -> Partials | None:
    r""":math:`\partial R/\partial x` (``n_u x n_x``) of :math:`R = F - M u'` at ``u'`` held
    (:class:`Partials`); its speeds' tangent columns :math:`\partial R/\partial\delta` (a
    joint's its coordinate's column, a free root's its tangent columns, so that
    ``tangent_jacobian`` sums no :math:`\partial R/\partial q\,G` over the root's
    coordinates; None where the applied loads depend on the root's coordinates); ``M`` and
    ``F`` from the same quantities; and the forward-mode assignments of the applied part and
    of a free root's rotation and position.  None where :func:`screw_joints` does not apply,
    where forward mode gives fewer operations (:func:`worth_it`), or where a state that no
    joint holds has no free root to hold it.

    A free root's speeds' columns are analytic (:func:`inertial_partials`), and so are its
    coordinates' through its tangent columns (:func:`root_coordinates`)."""
    if ne.nu < MIN_SPEEDS:
        return None
    joints = screw_joints(ne)
    if joints is None or not worth_it(ne, joints):
        return None
    L = ne.prep.layout
    held = {q for q, _ in joints.values()} | {L.n_q + k for _, k in joints.values()}
    free = [j for j in range(L.n_q) if j not in held]
    dq, du, root, (mass, bias), pairs = inertial_partials(ne, joints, udot)
    if root is None and len(held) < L.n_x:
        return None
    applied = applied_residual(ne)
    extra = Program()
    if any(r != 0 for r in applied):
        extra, d = derivatives(ne.P.build(), applied, list(L.states), "nea")
    else:
        d = [[S0] * L.n_x for _ in range(L.n_u)]
    coordinate = {k: q for q, k in joints.values()}
    tangent = None
    if root is not None and free:     # its speeds are in du; its coordinates through its tangent
        e, more = root_coordinates(ne, root, free)
        extra = Program(extra.assignments + more.assignments, extra.checks | more.checks)
        for i in range(L.n_u):
            for j, ej in e.items():
                dq[i][j] = add(*(mul(root.tangent[i][k], x) for k, x in ej.items()))
        if (set(root.S) | set(coordinate) == set(range(L.n_u))
                and all(d[i][j] == 0 for i in range(L.n_u) for j in free)):
            tangent = [[mul(-1, root.tangent[i][k]) if k in root.S else
                        add(mul(-1, dq[i][coordinate[k]]), d[i][coordinate[k]])
                        for k in range(L.n_u)] for i in range(L.n_u)]
    rows = [[add(mul(-1, x), d[i][j]) for j, x in enumerate(dq[i] + du[i])]
            for i in range(L.n_u)]
    if pairs is not None and any(d[i][j] != 0 for i, j in pairs.positions(L.n_q)["R"]):
        pairs = None    # an applied load couples a pair: its entries stay written out
    forcing = [add(applied[k], mul(-1, bias[k])) for k in range(L.n_u)]
    return Partials(sm.ImmutableMatrix(rows),
                    sm.ImmutableMatrix(tangent) if tangent is not None else None,
                    sm.ImmutableMatrix(mass), sm.ImmutableMatrix(forcing), extra, pairs)


__all__ = ["MIN_SPEEDS", "Partials", "chain_pairs", "RootColumns", "applied_residual", "free_root",
           "inertial_partials", "longest_chain", "mass_and_bias", "residual_jacobian",
           "root_coordinates", "screw_joints", "worth_it"]
