r"""Planar pendulum whose rod is a stiff spring: a stiff, oscillatory test problem.

A particle of mass ``m`` hangs from the origin on a linear spring of
stiffness ``k`` and natural length ``l`` (with an optional parallel damper
``c``), under gravity ``-g N.y``.  Coordinates: the angle ``theta`` of the
spring from the downward vertical (frame ``A`` is ``N`` turned by ``theta``
about n3) and the stretch ``s`` of the spring, so the particle is at
``-(l + s) a2`` and the length is ``r = l + s``; speeds ``u1 = theta'``,
``u2 = s'``::

    T = m (u2^2 + (l + s)^2 u1^2) / 2,      V = -m g (l + s) cos(theta) + k s^2 / 2
    m (l + s)^2 u1' = -2 m (l + s) u1 u2 - m g (l + s) sin(theta)
    m u2'          =  m (l + s) u1^2 + m g cos(theta) - k s - c u2

``M = diag(m (l + s)^2, m)`` is singular where the spring has collapsed to
zero length (``s = -l``; the spring's direction is undefined there too).

Time scales: the slow swing has ``omega_p ~ sqrt(g / l)`` (period ~ 2 s for
the defaults), the fast spring mode ``omega_s = sqrt(k / m)`` (1e3 rad/s at
the default ``k = 1e6``).  Undamped, the fast mode is a pair of imaginary
eigenvalues ``+-i omega_s``: an explicit method needs a step below ``~3 /
omega_s`` however small the fast oscillation is, while an L-stable implicit
method with the Jacobian can step over it when the state starts (and stays)
near the slow manifold ``k s ~ m g cos(theta) + m (l + s) theta'^2``.

Options: ``stiffness`` (``k``, default 1e6), ``damping`` (``c``, default 0).
The start is ``theta = 1`` at rest with the static stretch ``s = m g cos(1) /
k`` (on the slow manifold, so the fast mode is barely excited).  Without
damping ``T + V`` is conserved; ``conserves_energy`` is ``damping == 0``.
"""

import math

from .. import Model, Output, Scene


def build_model() -> Model:
    """The spring pendulum; constants ``m, l, k, c, g`` (in this order)."""
    m = Model("spring_pendulum")
    theta, s = m.coordinates("theta s")
    m.speeds("u1 u2")
    mass, l, k, c, g = m.constants("m l k c g")
    N = m.newtonian("N")
    A = m.rotate(N, "A", 3, theta)
    P = m.point("P", m.origin, -(l + s) * A.y)
    m.particle("bob", P, mass)
    m.spring("rod", P, m.origin, k, natural_length=l, damping=c)
    m.gravity(-g * N.y)
    return m


def parameters(stiffness: float = 1e6, damping: float = 0.0) -> dict[str, float]:
    """Parameter values for the given options."""
    return {"m": 1.0, "l": 1.0, "k": float(stiffness), "c": float(damping), "g": 9.81}


def initial_state(stiffness: float = 1e6, theta0: float = 1.0) -> dict[str, float]:
    """At rest at ``theta0`` with the static stretch ``m g cos(theta0) / k``."""
    p = parameters(stiffness)
    return {"theta": theta0, "s": p["m"] * p["g"] * math.cos(theta0) / p["k"]}


def scene(stiffness: float = 1e6, damping: float = 0.0) -> Scene:
    """The spring pendulum with spring stiffness ``stiffness`` (see the module docstring)."""
    if stiffness <= 0:
        raise ValueError("stiffness must be positive")
    if damping < 0:
        raise ValueError("damping must not be negative")
    return Scene(
        name="spring_pendulum",
        model=build_model(),
        outputs=(Output.RHS, Output.ROSENBROCK),
        parameters=parameters(stiffness, damping),
        fixed={"c": float(damping)},  # baked: with the default c = 0 the damper vanishes
        initial_state=initial_state(stiffness),
        t_span=(0.0, 10.0),
        description=f"planar pendulum on a stiff spring (k = {stiffness:g}, c = {damping:g})",
        conserves_energy=damping == 0,
    )
