r"""The particle on the paraboloid with the surface stated as a constraint: its normal force.

The scene ``paraboloid`` embeds the surface ``x3 = k (x1^2 + x2^2)`` in its
coordinates, so Kane's method never sees the normal reaction.  Here the height is
a coordinate of its own: with ``B`` turned by ``q2`` about N3 the particle is at
``r = q1 b1 + q3 b3``, and the surface is the configuration constraint (lecture 1,
example 1, stated)::

    f = q3 - k q1^2 = 0          (dependent coordinate q3, dependent speed u3 = q3')

Its multiplier ``lambda`` (``constraint_forces``, row ``surface``) is the
generalized force conjugate to ``f``: the surface pushes the particle with
``lambda grad f``, which in ``B`` axes is ``lambda (-2 k q1 b1 + b3)`` (so
``lambda`` is the normal force's vertical component, and ``|N| = lambda sqrt(1 +
4 k^2 q1^2)``).  Newton's law along n3, ``m q3'' = -m g + lambda``, with ``q3'' =
2 k (q1'^2 + q1 q1'')`` and ``q1''`` from the notes' equation of motion::

    (1 + 4 k^2 q1^2) q1'' = q1 q2'^2 - 4 k^2 q1 q1'^2 - 2 g k q1
    lambda = m (g + 2 k (q1'^2 + q1 q1''))

(:func:`normal_force`).  On the circular orbit (``q1' = 0``, ``q2'^2 = 2 g k``) it is
``m g``.  Same numbers and start as ``paraboloid``; ``T + V`` is conserved.
"""

from __future__ import annotations

from .. import Model, Output, Scene


def build_model() -> Model:
    """The particle with the surface stated; constants ``k, g, m``."""
    m = Model("paraboloid_normal")
    q1, q2, q3 = m.coordinates("q1 q2 q3")
    m.speeds("u1 u2 u3")
    k, g, mass = m.constants("k g m")
    N = m.newtonian("N")
    B = m.rotate(N, "B", 3, q2)
    P = m.point("P", m.origin, q1 * B.x + q3 * B.z)
    m.particle("particle", P, mass)
    m.gravity(-g * N.z)
    m.holonomic(q3 - k * q1**2, q3, names=["surface"])
    return m


def normal_force(x, k: float, g: float, m: float) -> float:
    """Closed-form ``lambda`` at the state ``x = [q1, q2, q3, u1, u2]`` (see the docstring)."""
    q1, _, _, u1, u2 = x
    q1dd = (q1 * u2**2 - 4 * k**2 * q1 * u1**2 - 2 * g * k * q1) / (1 + 4 * k**2 * q1**2)
    return float(m * (g + 2 * k * (u1**2 + q1 * q1dd)))


def scene() -> Scene:
    """The ``paraboloid`` start: radius 1 on the surface, turning slower than the orbit."""
    k = 0.5
    return Scene(
        name="paraboloid_normal",
        model=build_model(),
        outputs=(Output.RHS, Output.ENERGY, Output.CONSTRAINT_FORCES, Output.DOPRI5),
        parameters={"k": k, "m": 1.0},
        fixed={"g": 9.81},
        initial_state={"q1": 1.0, "q2": 0.0, "q3": k * 1.0**2, "u1": 0.0, "u2": 2.5},
        t_span=(0.0, 10.0),
        description="particle on a paraboloid, surface stated: normal force (lecture 1, ex. 1)",
        conserves_energy=True,
    )
