r"""Where the analytic partials of :mod:`mbgen.derivation.rnea_partials` apply: which bodies
are screw joints (one coordinate along one constant column, revolute or prismatic, a mimic's
coordinate shared), and which root is free (six orthonormal body columns, a rotation at every
``q``).  Each test looks through the Newton–Euler program's definitions (:class:`Look`) and,
where an identity must hold for every value of the constants, checks it at random points.
"""

from __future__ import annotations

import random

import sympy as sm

from .joints import Body
from .tree import S0, is_zero, matvec, mul


def screw_joints(ne) -> dict[Body, tuple[int, int]] | None:
    """Body -> ``(coordinate index, speed index)`` of its joint, or None.

    None unless every body moves relative to its parent by exactly one coordinate
    ``q_k`` with ``q_k' = u_k`` along one constant motion-subspace column (a coordinate may
    move several bodies, as a mimic joint's does: their terms are summed): a
    revolute joint (a chain of simple rotations, one by ``a q_k + b``, the others by
    constant angles; a constant offset from the parent's joint point) or a
    prismatic one (constant rotations; the offset ``r0 + q_k d`` with ``d`` the
    column's direction).  See the module docstring.
    """
    L = ne.prep.layout
    coords = {q: i for i, q in enumerate(L.coordinates)}
    speeds = {u: i for i, u in enumerate(L.speeds)}
    moving = frozenset(L.coordinates) | frozenset(L.speeds) | {L.time}
    look = Look(dict(ne.P.assignments), moving)
    out: dict = {}
    root = free_root(ne)
    for b in ne.bodies:
        if b is root:
            continue
        k = ne.kin[b]
        if len(k.S) != 1 or k.through:
            return None
        (s_index, col), = k.S.items()
        angle = _turning(ne, b, moving)
        if angle is False or any(look.varies(x) for x in col):
            return None
        if angle is not None:    # revolute: fixed offset, no sliding
            q = angle if angle in coords and is_zero(col[3:]) else None
            if any(look.varies(x) for x in k.r) or not is_zero(k.v_rel):
                return None
        else:                    # prismatic
            q = _sliding(ne, b, col, look) if is_zero(col[:3]) else None
        if q is None or q not in coords or ne.prep.qdot.get(q) not in speeds:
            return None
        if speeds[ne.prep.qdot[q]] != s_index:
            return None
        out[b] = (coords[q], s_index)
    return out or None


def free_root(ne) -> Body | None:
    """The one root body of a tree moved by six speeds along orthonormal constant columns (a
    floating base: ``S`` the unit twists in the body) whose rotation ``R(q)`` is one at every
    ``q`` (checked at a random point: off the unit sphere, a quaternion's matrix is one only
    where it is normalised where read), else None.  Every other body reads it as its parent
    (:func:`inertial_partials`, :func:`root_coordinates`)."""
    roots = [b for b in ne.bodies if b.parent is None]
    if len(roots) != 1:
        return None
    b = roots[0]
    S = [tuple(sm.sympify(x) for x in col) for col in ne.kin[b].S.values()]
    if len(S) != 6 or not all(x.is_Number for col in S for x in col) or any(
            sum((x * y for x, y in zip(S[i], S[j])), S0) != (i == j)
            for i in range(6) for j in range(6)):
        return None
    L = ne.prep.layout
    moving = frozenset(L.coordinates) | frozenset(L.speeds) | {L.time}
    look = Look(dict(ne.P.assignments), moving)
    R = sm.Matrix([[look.inline(x) for x in row] for row in ne.rotation(b).matrix])
    rng = random.Random(6)
    point = {c: sm.Float(rng.uniform(0.5, 1.5)) for c in sorted(R.free_symbols, key=str)}
    RtR = (R.xreplace(point).T * R.xreplace(point)).evalf()
    return b if max(abs(complex(x)) for x in RtR - sm.eye(3)) < 1e-9 else None


def _turning(ne, b, moving):
    """The coordinate that turns ``b`` against its parent (None: no turning; False: not a
    chain of simple rotations with at most one non-constant angle, ``a q + b`` with ``a``
    and ``b`` constant)."""
    base = b.parent.frame if b.parent is not None else ne.bt.ground_frame
    angle, node = None, b.frame
    while node is not base:
        if node is None or node.axis is None or node.omega_override is not None:
            return False
        free = sm.sympify(node.angle).free_symbols & moving
        if free:   # the angle must be a q_k + b, a and b constant
            if angle is not None or len(free) != 1:
                return False
            angle, = free
            if node.angle.diff(angle).free_symbols & moving:
                return False
        node = node.parent
    return angle


def _sliding(ne, b, col, look):
    """The coordinate ``q`` of a prismatic joint: ``r = r0 + q d`` in parent components with
    ``d = R s`` (``s`` the column's linear part, ``R`` the constant child-to-parent rotation)
    and ``v_rel = d u``; checked at two random points of the constants (None: not so)."""
    r = [look.inline(x) for x in ne.kin[b].r]
    free = set().union(*(x.free_symbols for x in r)) & look.moving
    if len(free) != 1:
        return None
    q, = free
    d = [x.diff(q) for x in r]
    if any(x.free_symbols & look.moving for x in d):
        return None
    R = ne.rotation(b).matrix
    Rs = matvec(R, col[3:])
    u = ne.prep.qdot.get(q)
    checks = [a - e for a, e in zip(d, Rs)]
    checks += [sm.sympify(a) - mul(u, e) for a, e in zip(ne.kin[b].v_rel, d)]
    consts = sorted(set().union(*(sm.sympify(x).free_symbols for x in checks)) - look.moving,
                    key=str)
    rng = random.Random(len(consts))
    for _ in range(2):
        point = {c: sm.Float(rng.uniform(0.5, 1.5)) for c in consts}
        point.update({s: sm.Float(rng.uniform(-1, 1)) for s in look.moving})
        values = [complex(sm.sympify(x).xreplace(point).evalf()) for x in checks]
        if max(map(abs, values), default=0.0) > 1e-9:
            return None
    return q


class Look:
    """Program definitions looked through: what an expression depends on, inlined."""

    def __init__(self, defs, moving):
        self.defs, self.moving = defs, moving
        self._varies: dict = {}
        self._inline: dict = {}

    def varies(self, x) -> bool:
        """Whether ``x`` depends on q, u or t (through program symbols, each looked at once)."""
        for s in sm.sympify(x).free_symbols:
            if s in self.moving:
                return True
            if s in self.defs:
                hit = self._varies.get(s)
                if hit is None:
                    hit = self._varies[s] = self.varies(self.defs[s])
                if hit:
                    return True
        return False

    def inline(self, x):
        """``x`` with program symbols replaced by their definitions (memoised)."""
        x = sm.sympify(x)
        subs = {}
        for s in x.free_symbols:
            if s in self.defs:
                hit = self._inline.get(s)
                if hit is None:
                    hit = self._inline[s] = self.inline(self.defs[s])
                subs[s] = hit
        return x.xreplace(subs) if subs else x


__all__ = ["Look", "free_root", "screw_joints"]
