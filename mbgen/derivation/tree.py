r"""The kinematic tree: frames, points and their time derivatives, in local components.

This is the engine under :mod:`mbgen.derivation.kane`.  It works on plain symbols
(``q1`` rather than ``q1(t)``) and keeps every vector as three components in a
known frame of the tree, so no quantity is ever re-expressed in the Newtonian
frame unless a dot product needs it.  Quantities are built recursively and
memoised, so expressions share subtrees instead of growing.

Frames
------
A frame ``F`` made by a simple rotation of its parent ``P`` by angle
:math:`\theta(q, t)` about unit axis :math:`e` (same components in ``P`` and ``F``)
has, in ``F`` components,

.. math::

    \omega_F &= R_{FP}\,\omega_P + \dot\theta\, e \\
    \omega_{F,r} &= R_{FP}\,\omega_{P,r} + \frac{\partial\dot\theta}{\partial u_r} e \\
    \alpha^t_F &= R_{FP}\,\alpha^t_P + \ddot\theta^t e + (R_{FP}\omega_P) \times \dot\theta e

where :math:`\omega_{F,r}` is the partial angular velocity and :math:`\alpha^t`
the angular acceleration with every :math:`u'` set to zero (the remainder).
:math:`R_{PF}` maps ``F`` components to ``P`` components (its columns are the
``F`` basis vectors in ``P``), :math:`R_{FP} = R_{PF}^T`.

Points
------
A point's position is a sum of *atoms* ``(F, c)``: components ``c(q, t)`` in
frame ``F``, one per frame of each offset along the chain of parent points.
Atoms are shared by every point placed after them, which is what lets
:mod:`mbgen.derivation.kane` group terms.  For an atom,

.. math::

    v &= \dot c + \omega_F \times c \\
    v_r &= \partial \dot c / \partial u_r + \omega_{F,r} \times c \\
    a^t &= \ddot c^t + \alpha^t_F \times c + 2\,\omega_F\times\dot c
           + \omega_F\times(\omega_F\times c)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import sympy as sm

from ..errors import ModelError
from ..symbolic.build import product, total

S0 = sm.S.Zero
Vec3 = tuple  # three sympy expressions
ZERO3: Vec3 = (S0, S0, S0)


# ----------------------------------------------------------------- vector algebra
def _equals(x, value: int) -> bool:
    """``x == value`` for a sympy term; only a number can be (a comparison of any other
    expression sympifies ``value`` first: a tenth of deriving the 32-link arm)."""
    return (x.is_Number if isinstance(x, sm.Basic) else True) and x == value


def add(*terms):
    """Sum of sympy terms, skipping exact zeros."""
    nz = [x for x in terms if x is not S0 and not _equals(x, 0)]
    if not nz:
        return S0
    if len(nz) == 1:
        return nz[0]
    return total(nz) if all(isinstance(x, sm.Basic) for x in nz) else sm.Add(*nz)


def mul(a, b):
    """Product of two sympy terms, short-circuiting exact zeros and ones."""
    if a is S0 or b is S0 or _equals(a, 0) or _equals(b, 0):
        return S0
    if _equals(a, 1):
        return b
    if _equals(b, 1):
        return a
    return product(a, b) if isinstance(a, sm.Basic) and isinstance(b, sm.Basic) \
        else sm.Mul(a, b)


def vadd(*vs: Vec3) -> Vec3:
    return tuple(add(*(v[i] for v in vs)) for i in range(3))


def vscale(s, v: Vec3) -> Vec3:
    return tuple(mul(s, x) for x in v)


def vneg(v: Vec3) -> Vec3:
    return vscale(sm.S.NegativeOne, v)


def is_zero(v: Vec3) -> bool:
    return all(x is S0 or _equals(x, 0) for x in v)


def cross(a: Vec3, b: Vec3) -> Vec3:
    return (add(mul(a[1], b[2]), -mul(a[2], b[1])),
            add(mul(a[2], b[0]), -mul(a[0], b[2])),
            add(mul(a[0], b[1]), -mul(a[1], b[0])))


def dot3(a: Vec3, b: Vec3):
    return add(*(mul(x, y) for x, y in zip(a, b)))


def matvec(R, v: Vec3) -> Vec3:
    """``R @ v`` for a 3x3 tuple-of-rows ``R``, skipping zeros."""
    return tuple(add(*(mul(R[i][j], v[j]) for j in range(3))) for i in range(3))


def transpose(R):
    return tuple(tuple(R[j][i] for j in range(3)) for i in range(3))


def simple_rotation(axis: int, angle) -> tuple:
    """``R_PF`` of a rotation by ``angle`` about axis 1, 2 or 3 (lecture notes' convention)."""
    c, s = sm.cos(angle), sm.sin(angle)
    one = sm.S.One
    if axis == 1:
        return ((one, S0, S0), (S0, c, -s), (S0, s, c))
    if axis == 2:
        return ((c, S0, s), (S0, one, S0), (-s, S0, c))
    return ((c, -s, S0), (s, c, S0), (S0, S0, one))


def unit(axis: int) -> Vec3:
    return tuple(sm.S.One if i == axis - 1 else S0 for i in range(3))


# ------------------------------------------------------------------------ nodes
@dataclass(eq=False)
class FrameNode:
    """A frame of the tree.  ``R_parent`` is ``R_PF`` (F components -> parent components)."""

    name: str
    parent: FrameNode | None = None
    axis: int | None = None
    angle: sm.Expr | None = None
    omega_override: Vec3 | None = None
    depth: int = 0
    R_parent: tuple | None = None

    def __repr__(self) -> str:
        return f"FrameNode({self.name})"


@dataclass(eq=False)
class Atom:
    """One term of a position: components ``c`` in ``frame`` (functions of q, t)."""

    index: int
    frame: FrameNode
    c: Vec3
    label: str = ""

    def __repr__(self) -> str:
        return f"Atom#{self.index}({self.label} in {self.frame.name})"


# ------------------------------------------------------------------------ tree
@dataclass(eq=False)
class KinematicTree:
    """Frames, atoms and their derivatives for one model (plain symbols throughout).

    Parameters
    ----------
    coordinates, speeds : sequence of Symbol
        ``q`` and ``u``.
    qdot : mapping Symbol -> Expr
        Kinematic differential equations ``q' = G(q, u, t)``.
    time : Symbol
        The time symbol.
    """

    coordinates: Sequence[sm.Symbol]
    speeds: Sequence[sm.Symbol]
    qdot: Mapping[sm.Symbol, sm.Expr]
    time: sm.Symbol
    frames: dict = field(default_factory=dict)
    atoms: list = field(default_factory=list)

    def __post_init__(self):
        self._u = list(self.speeds)
        self._uset = set(self.speeds)
        self._dt_cache: dict = {}
        self._cache: dict = {}
        self._express_cache: dict = {}

    # ------------------------------------------------------------ construction
    def add_root(self, name: str) -> FrameNode:
        node = FrameNode(name)
        self.frames[name] = node
        return node

    def add_rotation(self, name: str, parent: FrameNode, axis: int, angle) -> FrameNode:
        if self.free(angle) & self._uset:
            raise ModelError(f"the rotation angle of frame {name} depends on a speed: {angle}")
        node = FrameNode(name, parent, axis, angle, None, parent.depth + 1,
                         simple_rotation(axis, angle))
        self.frames[name] = node
        return node

    def add_dcm(self, name: str, parent: FrameNode, R_parent: tuple) -> FrameNode:
        """A frame at the rotation ``R_parent`` (``R_PF``, rows, functions of q and t) from
        ``parent``; its angular velocity must be set (:meth:`set_omega`: body rates)."""
        if self.free(*(x for row in R_parent for x in row)) & self._uset:
            raise ModelError(f"the rotation of frame {name} depends on a speed")
        node = FrameNode(name, parent, None, None, None, parent.depth + 1, R_parent)
        self.frames[name] = node
        return node

    def set_omega(self, node: FrameNode, omega: Vec3) -> None:
        """Override the angular velocity of ``node`` in N (components in ``node``)."""
        node.omega_override = tuple(sm.sympify(w) for w in omega)

    def add_atom(self, frame: FrameNode, c: Vec3, label: str = "") -> Atom:
        c = tuple(sm.sympify(x) for x in c)
        if self.free(*c) & self._uset:
            raise ModelError(f"position term {label} depends on a speed; positions may depend "
                             f"only on coordinates, constants and time")
        atom = Atom(len(self.atoms), frame, c, label)
        self.atoms.append(atom)
        return atom

    @staticmethod
    def free(*exprs) -> set:
        out: set = set()
        for e in exprs:
            out |= sm.sympify(e).free_symbols
        return out

    # --------------------------------------------------------- time derivative
    def dt(self, f):
        r"""Total time derivative of scalar ``f(q, u, t)``.

        Returns ``(rest, coeffs)`` with :math:`\dot f = rest + \sum_r coeffs[r]\,u_r'`,
        ``rest = sum_j df/dq_j G_j + df/dt``, ``coeffs[r] = df/du_r``.
        """
        f = sm.sympify(f)
        hit = self._dt_cache.get(f)
        if hit is not None:
            return hit
        free = f.free_symbols
        rest = [mul(f.diff(q), self.qdot[q]) for q in self.coordinates if q in free]
        if self.time in free:
            rest.append(f.diff(self.time))
        coeffs = {r: f.diff(u) for r, u in enumerate(self._u) if u in free}
        out = (add(*rest), {r: c for r, c in coeffs.items() if c != 0})
        self._dt_cache[f] = out
        return out

    def dt_rest(self, v: Vec3) -> Vec3:
        return tuple(self.dt(x)[0] for x in v)

    def d_du(self, v: Vec3, r: int) -> Vec3:
        u = self._u[r]
        return tuple(x.diff(u) if u in sm.sympify(x).free_symbols else S0 for x in v)

    # ---------------------------------------------------------- frame kinematics
    def _memo(self, key, make):
        hit = self._cache.get(key)
        if hit is None:
            hit = make()
            self._cache[key] = hit
        return hit

    def theta_dot(self, node: FrameNode):
        """``(theta', {r: d theta'/d u_r}, theta''^t)`` for a rotation node."""
        def make():
            rate, coeffs = self.dt(node.angle)
            if coeffs:   # the angle's rate would hold u' terms: it must be a function of q and t
                raise ModelError(f"the rotation angle of frame {node.name!r} depends on speeds "
                                 f"({', '.join(sorted(map(str, coeffs)))}); write it in "
                                 f"coordinates and time only")
            acc, partial = self.dt(rate)
            return rate, partial, acc
        return self._memo(("theta", node), make)

    def omega(self, node: FrameNode) -> Vec3:
        """Angular velocity of ``node`` in N, ``node`` components."""
        def make():
            if node.omega_override is not None:
                return node.omega_override
            if node.parent is None:
                return ZERO3
            rate, _, _ = self.theta_dot(node)
            base = matvec(transpose(node.R_parent), self.omega(node.parent))
            return vadd(base, vscale(rate, unit(node.axis)))
        return self._memo(("omega", node), make)

    def omega_partials(self, node: FrameNode) -> dict[int, Vec3]:
        """Partial angular velocities ``{r: d omega / d u_r}`` (nonzero only), in ``node``'s
        components."""
        def make():
            if node.omega_override is not None:
                out = {}
                for r in range(len(self._u)):
                    v = self.d_du(node.omega_override, r)
                    if not is_zero(v):
                        out[r] = v
                return out
            if node.parent is None:
                return {}
            _, partial, _ = self.theta_dot(node)
            RT = transpose(node.R_parent)
            out = {r: matvec(RT, w) for r, w in self.omega_partials(node.parent).items()}
            for r, c in partial.items():
                out[r] = vadd(out.get(r, ZERO3), vscale(c, unit(node.axis)))
            return {r: v for r, v in out.items() if not is_zero(v)}
        return self._memo(("omega_r", node), make)

    def alpha_rest(self, node: FrameNode) -> Vec3:
        """Angular acceleration of ``node`` in N with all ``u' = 0``, ``node`` components."""
        def make():
            if node.omega_override is not None:
                return self.dt_rest(node.omega_override)
            if node.parent is None:
                return ZERO3
            rate, _, acc = self.theta_dot(node)
            RT = transpose(node.R_parent)
            e = unit(node.axis)
            w_parent = matvec(RT, self.omega(node.parent))
            return vadd(matvec(RT, self.alpha_rest(node.parent)), vscale(acc, e),
                        cross(w_parent, vscale(rate, e)))
        return self._memo(("alpha", node), make)

    # ------------------------------------------------------------ re-expression
    def path_to_root(self, node: FrameNode) -> list[FrameNode]:
        out = [node]
        while out[-1].parent is not None:
            out.append(out[-1].parent)
        return out

    def common_ancestor(self, a: FrameNode, b: FrameNode) -> FrameNode:
        up = set(self.path_to_root(a))
        for n in self.path_to_root(b):
            if n in up:
                return n
        raise ModelError(f"frames {a.name} and {b.name} are not connected")

    def express(self, v: Vec3, src: FrameNode, dst: FrameNode) -> Vec3:
        """Components of vector ``v`` (given in ``src``) in frame ``dst``."""
        if src is dst:
            return v
        key = (v, src, dst)
        hit = self._express_cache.get(key)
        if hit is not None:
            return hit
        anc = self.common_ancestor(src, dst)
        if src is not anc:  # one step up, then recurse
            out = self.express(matvec(src.R_parent, v), src.parent, dst)
        else:  # src is an ancestor of dst: go down from dst's parent
            out = matvec(transpose(dst.R_parent), self.express(v, src, dst.parent))
        self._express_cache[key] = out
        return out

    def dot(self, a: Vec3, fa: FrameNode, b: Vec3, fb: FrameNode):
        """Dot product of ``a`` (in ``fa``) and ``b`` (in ``fb``), computed in their common
        ancestor."""
        if is_zero(a) or is_zero(b):
            return S0
        if fa is fb:
            return dot3(a, b)
        anc = self.common_ancestor(fa, fb)
        return dot3(self.express(a, fa, anc), self.express(b, fb, anc))

    # ------------------------------------------------------------ atom kinematics
    def atom_rate(self, atom: Atom) -> Vec3:
        """Frame-relative rate ``c'`` of an atom's components."""
        return self._memo(("cdot", atom), lambda: self.dt_rest(atom.c))

    def atom_velocity(self, atom: Atom) -> Vec3:
        """``v = c' + omega_F x c`` in the atom's frame."""
        return self._memo(("v", atom), lambda: vadd(self.atom_rate(atom),
                                                    cross(self.omega(atom.frame), atom.c)))

    def atom_partials(self, atom: Atom) -> dict[int, Vec3]:
        """Partial velocities ``{r: dv/du_r}`` (nonzero only) in the atom's frame."""
        def make():
            cdot = self.atom_rate(atom)
            out = {}
            for r in range(len(self._u)):
                v = self.d_du(cdot, r)
                w = self.omega_partials(atom.frame).get(r)
                if w is not None:
                    v = vadd(v, cross(w, atom.c))
                if not is_zero(v):
                    out[r] = v
            return out
        return self._memo(("v_r", atom), make)

    def atom_acceleration_rest(self, atom: Atom) -> Vec3:
        """Acceleration remainder ``a^t`` (all ``u' = 0``) in the atom's frame."""
        def make():
            c = atom.c
            cdot = self.atom_rate(atom)
            w = self.omega(atom.frame)
            cddot = self.dt_rest(cdot)
            return vadd(cddot, cross(self.alpha_rest(atom.frame), c),
                        vscale(sm.Integer(2), cross(w, cdot)), cross(w, cross(w, c)))
        return self._memo(("a_t", atom), make)
