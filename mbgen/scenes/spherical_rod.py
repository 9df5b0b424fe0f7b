"""Thin rigid rod on a spherical joint at the origin, under gravity (problem P2.1).

Frames (notes, P2.1): ``B`` is ``N`` turned by ``q1`` about n3, ``S`` is ``B``
turned by ``q2`` about b2; the rod of length ``L`` lies along s3 from the joint
at the origin.  The notes find the velocity of the rod's far end ``L s3`` and
the angular velocity of ``S``::

    v = L q1' sin(q2) s2 + L q2' s1,    N&aV S = -sin(q2) q1' s1 + q2' s2 + cos(q2) q1' s3

The rod (mass ``m``) has its mass centre at ``L/2 s3`` and, being thin, the
central inertia ``m L^2/12`` about s1 and s2 and none about s3, so the spin
about its own axis is not a degree of freedom.  Gravity is ``-g n3``:
``q2 = pi`` is the rod hanging straight down and ``q2 = 0`` pointing up.
With ``u1 = q1'``, ``u2 = q2'`` and ``J = m L^2 / 3`` (inertia about the joint)::

    M = diag(J sin(q2)^2, J),   V = m g L cos(q2) / 2
    J sin(q2)^2 u1' = -2 J sin(q2) cos(q2) u1 u2
    J u2' = J sin(q2) cos(q2) u1^2 + m g L sin(q2) / 2

``M`` is singular where the rod is vertical (``sin q2 = 0``).  The default
start is a hanging rod swinging around the vertical (``q2 = 2.5``,
``q1' = 2``): the conserved ``J sin(q2)^2 q1'`` keeps it away from vertical.
"""

from .. import Model, Output, Scene


def build_model() -> Model:
    """The rod on the spherical joint; constants ``L, m, g``."""
    m = Model("spherical_rod")
    q1, q2 = m.coordinates("q1 q2")
    m.speeds("u1 u2")
    L, mass, g = m.constants("L m g")
    N = m.newtonian("N")
    _, S = m.chain_rotations([[N, "B", 3, q1], ["B", "S", 2, q2]])
    G = m.point("G", m.origin, L / 2 * S.z)
    m.body("rod", S, mass, (mass * L**2 / 12, mass * L**2 / 12, 0), G)
    m.gravity(-g * N.z)
    return m


def scene() -> Scene:
    """A hanging rod, 37 degrees out of the vertical, swinging round it."""
    return Scene(
        name="spherical_rod",
        model=build_model(),
        outputs=(Output.RHS, Output.DOPRI5),
        parameters={"L": 1.0, "m": 1.0},
        fixed={"g": 9.81},
        initial_state={"q1": 0.0, "q2": 2.5, "u1": 2.0, "u2": 0.0},
        t_span=(0.0, 10.0),
        description="thin rod on a spherical joint under gravity (problem P2.1)",
        conserves_energy=True,
    )
