"""Pendulum hanging from a rotating disc (lecture 1, example 3).

The disc turns about the vertical N3 by ``q1``; a pendulum of length ``l`` hangs
from a point at radius ``s`` on the disc and swings out by ``q2`` in the
disc's radial plane.  The bob has mass ``m``; the disc is massless.  Position
of the bob (notes, section 1.4.2)::

    r = [(s + l sin q2) cos q1, (s + l sin q2) sin q1, -l cos q2]

The notes' state equations (with u1 = q1', u2 = q2')::

    u1' = -2 l cos(q2) u1 u2 / (s + l sin q2)
    u2' = cos(q2) u1^2 (s + l sin q2) / l - g sin(q2) / l

With s = 1, l = 4, g = 10: u1' = -8 cos(q2) u2 u1 / (1 + 4 sin q2),
u2' = cos(q2) u1^2 / 4 + u1^2 sin(2 q2) / 2 - 5 sin(q2) / 2.
"""

from .. import Model, Output, Scene


def build_model() -> Model:
    m = Model("disc_pendulum")
    q1, q2 = m.coordinates("q1 q2")
    m.speeds("u1 u2")
    s, l, g, mass = m.constants("s l g m")
    N = m.newtonian("N")
    A = m.rotate(N, "A", 3, q1)        # disc
    B = m.rotate(A, "B", 2, -q2)       # pendulum; the rod hangs along -B3
    E = m.point("E", m.origin, s * A.x)
    P = m.point("P", E, -l * B.z)
    m.particle("bob", P, mass)
    m.gravity(-g * N.z)
    return m


def scene() -> Scene:
    return Scene(
        name="disc_pendulum",
        model=build_model(),
        outputs=(Output.RHS, Output.DOPRI5),
        parameters={"s": 1.0, "l": 4.0, "g": 10.0, "m": 1.0},
        initial_state={"q1": 0.0, "q2": 1.0, "u1": 0.5, "u2": 0.0},
        t_span=(0.0, 20.0),
        description="pendulum hanging from a rotating disc (lecture 1, example 3)",
        conserves_energy=True,
    )
