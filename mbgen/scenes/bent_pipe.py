"""Ball sliding in a spinning bent pipe (problem P2.2), with the pipe free to spin.

The pipe rises along the vertical a3 from the origin of ``A`` to a bend at
height ``h`` and continues along the slanted segment b1.  Frames (notes,
P2.2): ``F1`` is ``A`` turned by the spin angle ``q1`` about a3, ``B`` is
``F1`` turned by ``pi/2 - phi`` about f2 (``phi`` constant), so b1 makes the
angle ``phi`` with -a3: ``phi < pi/2`` slants down, ``phi > pi/2`` up.  The ball
(a particle of mass ``m``) is at ``q2`` along the segment::

    r = h a3 + q2 b1 = sin(phi) q2 (cos(q1) a1 + sin(q1) a2) + (h - cos(phi) q2) a3
    v = q2' b1 + q1' sin(phi) q2 b2,     A&aV B = q1' (-cos(phi) b1 + sin(phi) b3)

Unlike the notes, the spin ``q1`` is free: the pipe is a rotor of moment of
inertia ``J`` about a3 (its mass centre on the axis, so its mass does not
enter), which keeps ``M`` positive definite when the ball is at the bend.
With ``u1 = q1'``, ``u2 = q2'``, gravity ``-g a3`` and ``s = sin(phi)``::

    T = (J + m s^2 q2^2) q1'^2 / 2 + m q2'^2 / 2,   V = m g (h - cos(phi) q2)
    (J + m s^2 q2^2) u1' = -2 m s^2 q2 u1 u2
    u2' = s^2 q2 u1^2 + g cos(phi)

The default pipe rises at 30 degrees (``phi = 2 pi/3``): gravity pulls the
ball towards the bend, the spin throws it out, and it oscillates along the
pipe while the total angular momentum ``(J + m s^2 q2^2) q1'`` is conserved.
"""

import math

import sympy as sm

from .. import Model, Output, Scene


def build_model() -> Model:
    """The spinning pipe and the ball; constants ``phi, h, m, J, g``."""
    m = Model("bent_pipe")
    q1, q2 = m.coordinates("q1 q2")
    m.speeds("u1 u2")
    phi, h, mass, J, g = m.constants("phi h m J g")
    A = m.newtonian("A")
    F1, B = m.chain_rotations([[A, "F1", 3, q1], ["F1", "B", 2, sm.pi / 2 - phi]])
    E = m.point("E", m.origin, h * A.z)     # the bend
    P = m.point("P", E, q2 * B.x)
    m.particle("ball", P, mass)
    m.body("pipe", F1, 0, (0, 0, J), m.origin)
    m.gravity(-g * A.z)
    return m


def scene() -> Scene:
    """Ball half a unit up a 30-degree segment, pipe spinning a little above steady rate."""
    return Scene(
        name="bent_pipe",
        model=build_model(),
        outputs=(Output.RHS, Output.DOPRI5),
        parameters={"phi": 2 * math.pi / 3, "h": 0.5, "m": 0.2, "J": 0.05},
        fixed={"g": 9.81},
        initial_state={"q1": 0.0, "q2": 0.5, "u1": 4.0, "u2": 0.0},
        t_span=(0.0, 10.0),
        description="ball sliding in a spinning bent pipe (problem P2.2)",
        conserves_energy=True,
    )
