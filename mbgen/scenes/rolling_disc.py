r"""The rolling disc of sympy's mechanics documentation, its rolling stated as a constraint.

A thin uniform disc (radius ``r``, mass ``m``) rolls without slipping on the
horizontal plane.  Its orientation is the documentation's body-fixed chain::

    Y = N turned by q1 about n3      yaw
    L = Y turned by q2 about y1      lean
    R = L turned by q3 about l2      spin (the disc)

with the body rates taken in the lean frame, ``w_R = u1 l1 + u2 l2 + u3 l3``
(:meth:`~mbgen.Model.angular_velocity` adds the kinematic equations).  Unlike the
documentation, the contact is not built into the coordinates: the contact point
``C = q4 n1 + q5 n2`` has its own coordinates, the centre is ``D = C + r l3``, and
:meth:`~mbgen.Model.no_slip` states that the disc's material point at ``C`` does
not move along n1 and n2 (dependent speeds ``u4 = q4'``, ``u5 = q5'``).  Inertia
about ``D``: ``m r^2 / 4`` about the diameters ``l1, l3``, ``m r^2 / 2`` about the
axle ``l2``.

The published equations (sympy's ``test_kane.py`` and the documentation's
rolling-disc example) are reproduced exactly::

    u1' = (6 u2 u3 r - u3^2 r tan(q2) + 4 g sin(q2)) / (5 r)
    u2' = -2 u1 u3 / 3
    u3' = u1 (-2 u2 + u3 tan(q2))

The multipliers (``constraint_forces``, rows ``C_contact_x``, ``C_contact_y``) are
the ground's horizontal force on the disc.  Nothing dissipates: ``T + V`` is
conserved.  Upright (``q2 = 0``) rolling at spin rate ``u2`` is steady; its
linearisation has only zero eigenvalues at the critical rate ``u2 = 1/sqrt(3)`` (for
``r = g = 1``) and is oscillatory above it.  The default run rolls at ``u2 = 2``,
leaning ``q2 = 0.1`` (it wobbles, it does not fall).
"""

from __future__ import annotations

import sympy as sm

from .. import Model, Output, Scene


def build_model(name: str = "rolling_disc") -> Model:
    """The disc; constants ``r, m, g``."""
    m = Model(name)
    q1, q2, q3, q4, q5 = m.coordinates("q1 q2 q3 q4 q5")
    u1, u2, u3, u4, u5 = m.speeds("u1 u2 u3 u4 u5")
    r, mass, g = m.constants("r m g")
    N = m.newtonian()
    Y = m.rotate(N, "Y", 3, q1)
    L = m.rotate(Y, "L", 1, q2)
    R = m.rotate(L, "R", 2, q3)
    m.angular_velocity(R, u1 * L.x + u2 * L.y + u3 * L.z)
    C = m.point("C", m.origin, q4 * N.x + q5 * N.y)
    D = m.point("D", C, r * L.z)
    inertia = sm.Matrix([[mass * r**2 / 4, 0, 0], [0, mass * r**2 / 2, 0],
                         [0, 0, mass * r**2 / 4]])
    disc = m.body("disc", R, mass, inertia, D)
    m.gravity(-g * N.z)
    m.no_slip(C, disc, [u4, u5], axes=(1, 2))
    return m


def scene() -> Scene:
    """Leaning 0.1 rad, spinning at u2 = 2 rad/s (r = m = g = 1, as in sympy's tests)."""
    return Scene(
        name="rolling_disc",
        model=build_model(),
        outputs=(Output.RHS, Output.ENERGY, Output.CONSTRAINT_FORCES, Output.DOPRI5),
        parameters={"r": 1.0, "m": 1.0, "g": 1.0},
        initial_state={"q2": 0.1, "u2": 2.0},
        t_span=(0.0, 10.0),
        description="rolling disc of sympy's documentation, contact stated with no_slip",
        points=("D",),
        conserves_energy=True,
    )
