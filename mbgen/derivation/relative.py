r"""How one frame moves relative to another: angular velocity, its partials, acceleration.

The Newton–Euler outward pass (:mod:`mbgen.derivation.recursion`) needs, for each
joint, the motion of the child's frame (and of the frames its joint atoms are given
in) relative to the parent's frame.  :class:`Relative` gives it from the kinematic
tree (:mod:`mbgen.derivation.tree`), through the simple rotations below the parent's
frame or through the two frames' common ancestor; :func:`through_matrix` says when a
rotation given as a matrix lies between them, and :func:`cancelled` tidies what such a
rotation leaves.
"""

from __future__ import annotations

import sympy as sm

from .tree import ZERO3, cross, is_zero, matvec, transpose, unit, vadd, vneg, vscale


class Relative:
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


def through_matrix(tree, base, node) -> bool:
    """True when a frame between ``base`` and ``node`` is turned by a matrix (``Model.orient``)."""
    top = tree.common_ancestor(base, node)
    for n in (base, node):
        while n is not top:
            if n.axis is None:
                return True
            n = n.parent
    return False


def cancelled(v) -> tuple:
    """Components put over a common denominator and cancelled, where that is smaller (what a
    rotation given as a matrix leaves for term-by-term algebra to miss)."""
    out = []
    for x in v:
        # polynomial gcds over floating-point coefficients are not exact: those stay
        y = sm.cancel(x) if x.free_symbols and not x.has(sm.Float) else x
        out.append(y if ops(y) <= ops(x) else x)
    return tuple(out)


def ops(*exprs) -> int:
    """Operations of expressions and tuples of them (``sympy.count_ops``, each counted)."""
    return sum(sm.count_ops(x) for v in exprs for x in (v if isinstance(v, tuple) else (v,)))


__all__ = ["Relative", "cancelled", "ops", "through_matrix"]
