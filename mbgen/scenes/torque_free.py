"""Torque-free rigid body with a general inertia dyad, turning about its fixed mass centre.

Orientation: body-fixed 1-2-3 angles, ``A`` is ``N`` turned by ``q1`` about n1,
``C`` is ``A`` turned by ``q2`` about a2, and the body frame ``B`` is ``C``
turned by ``q3`` about c3.  The speeds are the body-fixed components of the
angular velocity, ``N&aV B = u1 b1 + u2 b2 + u3 b3``, so the kinematic
equations come from equating this to the chain's rate::

    q1' = (u1 cos q3 - u2 sin q3) / cos q2
    q2' =  u1 sin q3 + u2 cos q3
    q3' = -(u1 cos q3 - u2 sin q3) tan q2 + u3

singular at the gimbal lock ``cos q2 = 0``.  The central inertia dyad has
products of inertia (``I12, I23, I31``) as well as moments, so the body axes
are not principal.  With no loads, Euler's equations ``I w' = -w x (I w)``
are the whole dynamics; ``T = w.I.w / 2`` (``V = 0``) and the angular
momentum ``H = I.w`` (fixed in ``N``) are conserved.  The mass centre is
fixed at the origin, so the mass never enters and the body is given none.

The default body spins mainly about b3, near its axis of largest inertia, so
the motion is a stable wobble and ``q2`` stays far from the gimbal lock.
"""

from .. import Model, Output, Scene


def build_model() -> Model:
    """The free body; constants ``I11, I22, I33, I12, I23, I31`` (inertia in ``B``)."""
    m = Model("torque_free")
    q1, q2, q3 = m.coordinates("q1 q2 q3")
    u1, u2, u3 = m.speeds("u1 u2 u3")
    inertia = m.constants("I11 I22 I33 I12 I23 I31")
    N = m.newtonian("N")
    *_, B = m.chain_rotations([[N, "A", 1, q1], ["A", "C", 2, q2], ["C", "B", 3, q3]])
    m.angular_velocity(B, u1 * B.x + u2 * B.y + u3 * B.z)
    m.body("body", B, 0, inertia, m.origin)
    return m


def scene() -> Scene:
    """A wobbling spin about the axis of largest inertia, tilted from the vertical."""
    return Scene(
        name="torque_free",
        model=build_model(),
        outputs=(Output.RHS, Output.DOPRI5),
        parameters={"I11": 2.0, "I22": 3.0, "I33": 4.0, "I12": 0.3, "I23": -0.2, "I31": 0.25},
        initial_state={"q1": 0.3, "q2": -0.4, "q3": 0.5, "u1": 0.3, "u2": -0.2, "u3": 2.0},
        t_span=(0.0, 20.0),
        description="torque-free rigid body with products of inertia (Euler's equations)",
        conserves_energy=True,
    )
