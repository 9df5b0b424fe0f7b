"""Particle sliding on the paraboloid x3 = k (x1^2 + x2^2) under gravity (lecture 1, example 1).

Coordinates: ``q1`` is the distance from the vertical axis N3, ``q2`` the
azimuth about N3 (speeds ``u1 = q1'``, ``u2 = q2'``).  With the frame ``B``
turned by ``q2`` about N3, the particle of mass ``m`` is at (notes, section
1.4.1)::

    r = q1 cos(q2) n1 + q1 sin(q2) n2 + k q1^2 n3 = q1 b1 + k q1^2 b3

and gravity is ``-g n3``.  The surface is smooth, so the normal reaction does
no work and Kane's method drops it.  Energies and equations::

    T = m/2 ((1 + 4 k^2 q1^2) q1'^2 + q1^2 q2'^2),   V = m g k q1^2
    (1 + 4 k^2 q1^2) q1'' = q1 q2'^2 - 4 k^2 q1 q1'^2 - 2 g k q1
    q1^2 q2'' = -2 q1 q1' q2'        (q1^2 q2' is conserved)

A circular orbit has ``q2'^2 = 2 g k``; the default start spins slower, so
the particle oscillates between two heights.  The mass matrix
``diag(m (1 + 4 k^2 q1^2), m q1^2)`` is singular on the axis ``q1 = 0``,
which the motion never reaches while ``q1^2 q2' != 0``.
"""

from .. import Model, Output, Scene


def build_model() -> Model:
    """The particle on the paraboloid; constants ``k, g, m``."""
    m = Model("paraboloid")
    q1, q2 = m.coordinates("q1 q2")
    m.speeds("u1 u2")
    k, g, mass = m.constants("k g m")
    N = m.newtonian("N")
    B = m.rotate(N, "B", 3, q2)
    P = m.point("P", m.origin, q1 * B.x + k * q1**2 * B.z)
    m.particle("particle", P, mass)
    m.gravity(-g * N.z)
    return m


def scene() -> Scene:
    """Start at radius 1, at rest radially, turning slower than the circular orbit."""
    return Scene(
        name="paraboloid",
        model=build_model(),
        outputs=(Output.RHS, Output.DOPRI5),
        parameters={"k": 0.5, "m": 1.0},
        fixed={"g": 9.81},
        initial_state={"q1": 1.0, "q2": 0.0, "u1": 0.0, "u2": 2.5},
        t_span=(0.0, 10.0),
        description="particle sliding on a paraboloid under gravity (lecture 1, example 1)",
        conserves_energy=True,
    )
