r"""The articulated-body recursion: ``u'`` at a cost linear in the number of bodies.

It applies when every speed belongs to exactly one joint (relative joint
coordinates).  With the per-body quantities of :class:`~mbgen.derivation.recursion.NewtonEuler`
(motion subspace ``S``, spatial inertia :math:`\mathcal I`, wrench ``g``, the
transforms ``X`` to the parent, and ``tau`` the generalized forces of loads on
massless parts), the inward pass (:func:`_aba_inward`, leaves first: one
:class:`ArticulatedJoint` per body) is

.. math::

    \mathcal I^A_b = \mathcal I_b + \sum_c X_c^T(\mathcal I^A_c - U_c D_c^{-1} U_c^T)X_c,
    \qquad
    p^A_b = -g_b + \sum_c X_c^T(p^A_c + U_c D_c^{-1} u_c)

with :math:`U = \mathcal I^A S`, :math:`D = S^T U + \operatorname{diag}(a)`,
:math:`u = \tau - S^T p^A` (``a`` the armature of the joint's speeds,
:meth:`mbgen.Model.armature`, on the pivots alone: with it, row and column ``m`` of
:math:`\mathcal I^A - U D^{-1} U^T` no longer vanish for ``S = e_m``), and
the outward pass (:func:`_aba_outward`, root first)
:math:`u'_b = D_b^{-1}(u_b - U_b^T X_b \hat a_p)`, :math:`\hat a_b = X_b \hat a_p + S_b u'_b`.
Pivots of ``D`` must be positive (they are checked in the generated code).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..symbolic.program import ProgramBuilder
from .joints import Body
from .recursion import NewtonEuler
from .spatial import ZERO6, dot6, force_to_parent, matvec6, motion_to_child, symmetric, vadd6, vneg6
from .tree import S0, add, mul


@dataclass(frozen=True)
class ArticulatedJoint:
    r"""One joint after the inward pass (Pinocchio's ``jdata.U()``, ``jdata.Dinv()``,
    ``data.Yaba``).

    Attributes
    ----------
    Ia : 6x6 rows
        What the body hands its parent: :math:`\mathcal I^A_b - U D^{-1} U^T` (the
        articulated inertia itself for a joint without speeds), body components.
    pa : 6-tuple
        The bias force handed to the parent: :math:`p^A_b + U D^{-1} u`.
    speeds : tuple of int
        The joint's speeds, in order (the keys of its motion subspace).
    U : list of 6-tuples
        :math:`\mathcal I^A S`, one column per speed.
    u : list
        :math:`\tau - S^T p^A`, one entry per speed.
    solve : callable or None
        :math:`D^{-1}` applied to a vector, by :class:`_SmallSolve` (None: no speeds).
    """

    Ia: tuple
    pa: tuple
    speeds: tuple
    U: list
    u: list
    solve: _SmallSolve | None


def speed_owners(ne: NewtonEuler) -> dict | None:
    """Speed -> owning body when every speed belongs to exactly one joint, else None."""
    owner = {}
    for b in ne.bodies:
        for k in ne.kin[b].S:
            if k in owner:
                return None
            owner[k] = b
    return owner if len(owner) == ne.nu else None


def articulated(ne: NewtonEuler) -> list | None:
    """``u'`` by the articulated-body recursion, or None when it does not apply."""
    if speed_owners(ne) is None:
        return None
    return _aba_outward(ne, _aba_inward(ne))


def _aba_inward(ne: NewtonEuler) -> dict[Body, ArticulatedJoint]:
    """The inward pass, leaves first: every body's :class:`ArticulatedJoint`."""
    tau = {k: add(*v) for k, v in ne.tau.items()}
    joint: dict[Body, ArticulatedJoint] = {}
    for b in reversed(ne.bodies):
        joint[b] = _articulated_body(ne, b, joint, tau)
    return joint


def _articulated_body(ne: NewtonEuler, b: Body, joint: dict, tau: dict) -> ArticulatedJoint:
    r""":math:`\mathcal I^A_b` and :math:`p^A_b` from the children's joints, then projected out
    of the body's own joint."""
    P = ne.P
    low = {(i, j): ne.inertia[b].spatial[i][j] for i in range(6) for j in range(i + 1)}
    bias = vneg6(ne.g[b])
    for c in b.children:
        con = ne.child_congruence(c, joint[c].Ia)
        low = {key: add(v, con[key]) for key, v in low.items()}
        bias = vadd6(bias, force_to_parent(joint[c].pa, ne.to_parent(c), ne.kin[c].r))
    I = symmetric({key: P.scalar(v) for key, v in low.items()})
    p = P.vector(bias)
    S = ne.kin[b].S
    ks = tuple(sorted(S))
    U = [P.vector(matvec6(I, S[k])) for k in ks]
    D = [[dot6(S[ks[i]], U[j]) for j in range(len(ks))] for i in range(len(ks))]
    for i, k in enumerate(ks):
        D[i][i] = add(D[i][i], ne.armature.get(k, S0))
    u = [add(tau.get(k, S0), mul(-1, dot6(S[k], p))) for k in ks]
    if not ks:
        return ArticulatedJoint(I, p, ks, U, u, None)
    solve = _SmallSolve(P, D)
    Ia, pa = _handed_on(P, I, p, S, ks, U, u, solve, tau, ne.armature)
    return ArticulatedJoint(Ia, pa, ks, U, u, solve)


def _handed_on(P: ProgramBuilder, I, p, S, ks, U, u, solve, tau, armature) -> tuple:
    r""":math:`(\mathcal I^A - U D^{-1} U^T,\ p^A + U D^{-1} u)`, the joint's free motions
    projected out: what the parent receives (``armature``: speed -> a_k, in ``D``)."""
    n = len(ks)
    Dinv_u = solve(u)
    W = [solve([U[i][row] for i in range(n)]) for row in range(6)]
    low = {(i, j): add(I[i][j], mul(-1, add(*(mul(U[k][i], W[j][k]) for k in range(n)))))
           for i in range(6) for j in range(i + 1)}
    pa = vadd6(p, tuple(add(*(mul(U[k][i], Dinv_u[k]) for k in range(n))) for i in range(6)))
    m = _unit_index(S[ks[0]]) if n == 1 and ks[0] not in armature else None
    if m is not None:
        # S = e_m and D = I_mm (no armature): row and column m of I - U U^T / D vanish
        # exactly, and component m of the bias is the joint's generalized force.
        low = {(i, j): S0 if m in (i, j) else v for (i, j), v in low.items()}
        pa = tuple(mul(S[ks[0]][m], tau.get(ks[0], S0)) if i == m else v
                   for i, v in enumerate(pa))
    return symmetric({key: P.scalar(v) for key, v in low.items()}), P.vector(pa)


def _aba_outward(ne: NewtonEuler, joint: dict[Body, ArticulatedJoint]) -> list:
    r"""The outward pass, root first: :math:`u'_b = D_b^{-1}(u_b - U_b^T X_b \hat a_p)` and
    :math:`\hat a_b = X_b \hat a_p + S_b u'_b`; returns ``u'`` by speed."""
    P = ne.P
    accel = {}
    udot = [S0] * ne.nu
    for b in ne.bodies:
        if b.parent is not None:
            a = motion_to_child(accel[b.parent], ne.to_child(b), ne.kin[b].r)
        else:
            a = ZERO6
        jt = joint[b]
        if jt.speeds:
            rhs = [add(jt.u[i], mul(-1, dot6(jt.U[i], a))) for i in range(len(jt.speeds))]
            qdd = [P.scalar(x) for x in jt.solve(rhs)]
            for k, x in zip(jt.speeds, qdd):
                udot[k] = x
                a = vadd6(a, tuple(mul(x, s) for s in ne.kin[b].S[k]))
        accel[b] = P.vector(a)
    return udot


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


__all__ = ["articulated", "speed_owners"]
