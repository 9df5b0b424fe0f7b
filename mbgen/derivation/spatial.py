r"""Spatial (6-vector) algebra on symbolic components, zeros folded.

A *motion* vector is ``(w, v)``: angular velocity (or acceleration) and the
velocity (acceleration) of a reference point; a *force* vector is ``(n, f)``:
the moment about the reference point and the force.  Each half is three
components in a body frame.  Their product ``w.n + v.f`` is power.

Between a parent body (reference point ``J_p``, frame ``P``) and a child
(``J_c``, frame ``C``) with ``r`` the vector from ``J_p`` to ``J_c`` in ``P``
components and ``R`` the map from ``P`` to ``C`` components:

.. math::

    \text{motion to child:}\quad (w, v) &\mapsto (R w,\; R(v + w\times r)) \\
    \text{force to parent:}\quad (n, f) &\mapsto (R^T n + r\times R^T f,\; R^T f)

(the moment about ``J_p`` of a force ``f`` at ``J_c`` is ``r x f``).  The
spatial inertia of masses ``m`` with first moment ``h`` and inertia ``I_J``
about ``J`` maps an acceleration ``(a, alpha)`` to the force
``(I_J alpha + h x a,  m a - h x alpha)``:

.. math::

    \mathcal{I} = \begin{bmatrix} I_J & [h\times] \\ [h\times]^T & m\,1 \end{bmatrix}.
"""

from __future__ import annotations

import sympy as sm

from .tree import S0, add, cross, mul, vadd

ZERO6 = (S0,) * 6


def split(x):
    return x[:3], x[3:]


def join(a, b) -> tuple:
    return tuple(a) + tuple(b)


def dot6(a, b):
    return add(*(mul(x, y) for x, y in zip(a, b)))


def vadd6(a, b) -> tuple:
    return tuple(add(x, y) for x, y in zip(a, b))


def vneg6(a) -> tuple:
    return tuple(mul(-1, x) for x in a)


def scale6(s, x) -> tuple:
    return tuple(mul(s, e) for e in x)


def skew(a) -> tuple:
    """``[a x]`` (rows): ``skew(a) b = a x b``."""
    return ((S0, mul(-1, a[2]), a[1]), (a[2], S0, mul(-1, a[0])), (mul(-1, a[1]), a[0], S0))


def mcross(a, b) -> tuple:
    """Motion cross product ``a x b``: ``(w x wb, w x vb + v x wb)``."""
    w, v = split(a)
    wb, vb = split(b)
    return join(cross(w, wb), vadd(cross(w, vb), cross(v, wb)))


def fcross(a, f) -> tuple:
    """Motion ``a`` acting on force ``f``: ``(w x n + v x fl, w x fl)``."""
    w, v = split(a)
    n, fl = split(f)
    return join(vadd(cross(w, n), cross(v, fl)), cross(w, fl))


def motion_to_child(m, to_child, r) -> tuple:
    """``(R w, R(v + w x r))``; ``to_child`` maps parent to child components."""
    w, v = split(m)
    return join(to_child(w), to_child(vadd(v, cross(w, r))))


def force_to_parent(f, to_parent, r) -> tuple:
    """``(R^T n + r x R^T f, R^T f)``; ``to_parent`` maps child to parent components."""
    n, ff = split(f)
    fp = to_parent(ff)
    return join(vadd(to_parent(n), cross(r, fp)), fp)


def spatial_inertia(m, h, IJ) -> tuple:
    """6x6 rows of the spatial inertia about the reference point (see module docstring)."""
    hx = skew(h)
    rows = [tuple(IJ[i]) + hx[i] for i in range(3)]
    rows += [tuple(hx[j][i] for j in range(3)) + tuple(m if i == k else S0 for k in range(3))
             for i in range(3)]
    return tuple(rows)


def matvec6(A, x) -> tuple:
    return tuple(add(*(mul(A[i][j], x[j]) for j in range(6))) for i in range(6))


def symmetric(lower) -> tuple:
    """6x6 rows from ``lower[(i, j)]``, ``i >= j``."""
    return tuple(tuple(lower[(i, j)] if i >= j else lower[(j, i)] for j in range(6))
                 for i in range(6))


def congruence(I, rotation, r) -> dict:
    """Lower triangle ``{(i, j): X^T I X}`` of a child's inertia seen from its parent.

    ``rotation`` is the child-to-parent rotation: ``Rotation.axis(k, c, s)`` for
    a simple rotation about axis ``k`` (cosine ``c``, sine ``s``), or a 3x3
    matrix; ``r`` the vector from the parent's to the child's reference point
    in parent components.  With ``I = [[A, B], [B^T, C]]`` the result is, after
    rotating every block to the parent's axes (``A1 = R A R^T``, ...) and with
    ``S = [r x]``::

        [[A1 + Q + Q^T + S C1 S^T,  B1 + S C1],
         [      .       ,               C1  ]],      Q = S B1^T.
    """
    A = tuple(tuple(I[i][j] for j in range(3)) for i in range(3))
    B = tuple(tuple(I[i][3 + j] for j in range(3)) for i in range(3))
    C = tuple(tuple(I[3 + i][3 + j] for j in range(3)) for i in range(3))
    A1, B1, C1 = rotation.sym(A), rotation.full(B), rotation.sym(C)
    S = skew(r)
    SC = matmul3(S, C1)
    out = {}
    for i in range(3):
        for j in range(i + 1):
            q_ij = add(*(mul(S[i][k], B1[j][k]) for k in range(3)))      # (S B1^T)_ij
            q_ji = add(*(mul(S[j][k], B1[i][k]) for k in range(3)))      # (S B1^T)_ji
            scs = add(*(mul(SC[i][k], S[j][k]) for k in range(3)))          # (S C1 S^T)_ij
            out[(i, j)] = add(A1[i][j], q_ij, q_ji, scs)
    for i in range(3):
        for j in range(3):
            out[(3 + i, j)] = add(B1[j][i], SC[j][i])   # (B1 + S C1)^T: row 3+i, column j
        for j in range(i + 1):
            out[(3 + i, 3 + j)] = C1[i][j]
    return out


def matmul3(X, Y) -> tuple:
    """``X Y`` of two 3x3 (rows), zeros and ones folded."""
    return tuple(tuple(add(*(mul(X[i][k], Y[k][j]) for k in range(3))) for j in range(3))
                 for i in range(3))


class Rotation:
    """A child-to-parent rotation ``R`` (parent components = ``R`` child components).

    Built from a matrix, or for a simple rotation about one axis from its
    cosine and sine, whose symmetric congruence ``R A R^T`` then costs about a
    dozen operations (double-angle form).
    """

    def __init__(self, matrix=None, axis=None, c=None, s=None, builder=None):
        self.matrix, self.axis, self.c, self.s, self._builder = matrix, axis, c, s, builder
        self._double = None

    @classmethod
    def simple(cls, axis: int, c, s, builder) -> Rotation:
        R = ((1, 0, 0), (0, 1, 0), (0, 0, 1))
        a, b = {1: (1, 2), 2: (2, 0), 3: (0, 1)}[axis]
        rows = [list(r) for r in R]
        rows[a][a], rows[a][b], rows[b][a], rows[b][b] = c, mul(-1, s), s, c
        matrix = tuple(tuple(sm.sympify(x) for x in row) for row in rows)
        return cls(matrix, axis, c, s, builder)

    def full(self, X):
        """``R X R^T`` for a general 3x3 ``X``."""
        R = self.matrix
        RT = tuple(tuple(R[j][i] for j in range(3)) for i in range(3))
        return matmul3(matmul3(R, X), RT)

    def sym(self, X):
        """``R X R^T`` for a symmetric ``X`` (rows of a full symmetric matrix)."""
        if self.axis is None:
            Y = self.full(X)
            return tuple(tuple(Y[max(i, j)][min(i, j)] for j in range(3)) for i in range(3))
        a, b = {1: (1, 2), 2: (2, 0), 3: (0, 1)}[self.axis]
        k = 3 - a - b
        c, s = self.c, self.s
        if self._double is None:
            P = self._builder
            self._double = (P.scalar(add(mul(c, c), mul(-1, mul(s, s)))),
                            P.scalar(mul(2, mul(c, s))))
        c2, s2 = self._double
        half = mul(sm.Rational(1, 2), add(X[a][a], mul(-1, X[b][b])))
        aa = add(mul(sm.Rational(1, 2), add(X[a][a], X[b][b])), mul(half, c2),
                 mul(-1, mul(X[a][b], s2)))
        Y = [[S0] * 3 for _ in range(3)]
        Y[a][a] = aa
        Y[b][b] = add(X[a][a], X[b][b], mul(-1, aa))
        Y[a][b] = Y[b][a] = add(mul(half, s2), mul(X[a][b], c2))
        Y[a][k] = Y[k][a] = add(mul(c, X[a][k]), mul(-1, mul(s, X[b][k])))
        Y[b][k] = Y[k][b] = add(mul(s, X[a][k]), mul(c, X[b][k]))
        Y[k][k] = X[k][k]
        return tuple(tuple(row) for row in Y)
