r"""A planar four-bar linkage under gravity: a closed loop with one degree of freedom.

Three links hang from two ground pivots ``O`` and ``D = ld n1`` in the vertical
plane (gravity ``-g n2``, rotations about n3): the crank ``A`` (length ``la``,
absolute angle ``q1``), the coupler ``B`` (length ``lb``, angle ``q2`` relative to
the crank) and the rocker ``C`` (length ``lc``, absolute angle ``q3`` about ``D``).
Each link is a uniform bar: mass centre at its middle, central moment of inertia
``m l^2 / 12`` about n3.  The loop is closed where the coupler's end ``PB = la a1 +
lb b1`` meets the rocker's end ``PC = ld n1 + lc c1``::

    la cos q1 + lb cos(q1 + q2) - ld - lc cos q3 = 0
    la sin q1 + lb sin(q1 + q2)      - lc sin q3 = 0

stated with :meth:`~mbgen.Model.coincident` (axes n1, n2), with ``q2, q3`` (and
``u2, u3``) dependent: ``q1, u1`` are the states that move freely, ``q2, q3`` stay in
the state and the integrators project them back onto the loop after each step.
The two multipliers (``constraint_forces``) are the force that the rocker exerts
on the coupler at the closing pin, along n1 and n2.

Nothing dissipates: ``T + V`` is conserved.

Dead point (``dead_point=True``): with the coordinates chosen here the loop
equations fix ``q2, q3`` from ``q1`` unless the coupler and the rocker are in one
line; there the dependent block of the constraint Jacobian,
``[[-lb sin(q1+q2), lc sin q3], [lb cos(q1+q2), -lc cos q3]]``, has the
determinant ``lb lc sin(q1 + q2 - q3) = 0`` and the crank reaches its extreme
angle.  The default linkage (``la = 1, lb = lc = ld = 2``, a Grashof crank-rocker)
never gets there: the distance ``|PA D|`` stays within ``[1, 3]``, below ``lb + lc =
4``.  The dead-point variant is a triple rocker (``la = ld = 2, lb = 1.2, lc =
1.5``): its crank's extreme angle is ``q1* = 2 asin((lb + lc) / (2 la)) ~ 1.4828``
(where ``|PA D| = 4 sin(q1/2) = lb + lc``), and it starts at rest at ``q1* -
offset``, the two links nearly in line, so ``cond(A_r) ~ 1/sqrt(offset)`` is large.
"""

from __future__ import annotations

import math

from .. import Model, Output, Scene

#: The default Grashof crank-rocker and the triple rocker of the dead-point variant.
LENGTHS = {"la": 1.0, "lb": 2.0, "lc": 2.0, "ld": 2.0}
DEAD_POINT_LENGTHS = {"la": 2.0, "lb": 1.2, "lc": 1.5, "ld": 2.0}


def build_model() -> Model:
    """The four-bar; constants ``la, lb, lc, ld, ma, mb, mc, g``."""
    m = Model("four_bar")
    q1, q2, q3 = m.coordinates("q1 q2 q3")
    m.speeds("u1 u2 u3")
    la, lb, lc, ld, ma, mb, mc, g = m.constants("la lb lc ld ma mb mc g")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)
    B = m.rotate(A, "B", 3, q2)
    C = m.rotate(N, "C", 3, q3)
    PA = m.point("PA", m.origin, la * A.x)
    PB = m.point("PB", PA, lb * B.x)
    D = m.point("D", m.origin, ld * N.x)
    PC = m.point("PC", D, lc * C.x)
    m.body("crank", A, ma, (0, 0, ma * la**2 / 12), m.point("GA", m.origin, la / 2 * A.x))
    m.body("coupler", B, mb, (0, 0, mb * lb**2 / 12), m.point("GB", PA, lb / 2 * B.x))
    m.body("rocker", C, mc, (0, 0, mc * lc**2 / 12), m.point("GC", D, lc / 2 * C.x))
    m.gravity(-g * N.y)
    m.coincident(PB, PC, [q2, q3], axes=(1, 2), name="pin")
    return m


def dead_angle(la: float, lb: float, lc: float, ld: float) -> float | None:
    """Extreme crank angle ``q1* > 0`` where coupler and rocker lie in line (``|PA D| = lb +
    lc``, law of cosines in the triangle ``O PA D``), or None when the crank never gets
    there (``la = ld``: ``q1* = 2 asin((lb + lc) / (2 la))``)."""
    c = (la**2 + ld**2 - (lb + lc)**2) / (2.0 * la * ld)
    return math.acos(c) if -1.0 <= c <= 1.0 else None


def closed_loop(q1: float, lengths, branch: int = 1) -> tuple[float, float]:
    """``(q2, q3)`` that close the loop at crank angle ``q1`` (position analysis).

    The pin is where the circle of radius ``lb`` about ``PA`` meets the circle
    of radius ``lc`` about ``D``: with ``d = D - PA``, ``L = |d|``, ``a = (lb^2 -
    lc^2 + L^2) / (2 L)`` and ``h = sqrt(lb^2 - a^2)``, the pin is ``PA + (a d +
    branch h d_perp) / L`` (``d_perp`` is ``d`` turned by +90 degrees; ``branch``
    is +1 or -1, the two assembly modes).  Raises ValueError where the loop
    cannot close (``L > lb + lc`` or ``L < |lb - lc|``).
    """
    la, lb, lc, ld = (lengths[k] for k in ("la", "lb", "lc", "ld"))
    ax, ay = la * math.cos(q1), la * math.sin(q1)
    dx, dy = ld - ax, -ay
    L = math.hypot(dx, dy)
    a = (lb**2 - lc**2 + L**2) / (2.0 * L)
    if lb**2 - a**2 < -1e-12 * lb**2:
        raise ValueError(f"the loop cannot close at q1 = {q1}")
    h = math.sqrt(max(lb**2 - a**2, 0.0))      # 0 at a dead point (round-off clipped)
    px = ax + (a * dx - branch * h * dy) / L
    py = ay + (a * dy + branch * h * dx) / L
    q2 = math.atan2(py - ay, px - ax) - q1
    q3 = math.atan2(py, px - ld)
    return q2, q3


def dead_point_state(lengths, offset: float) -> dict:
    """At rest, ``offset`` rad below the crank's extreme angle, loop closed (``branch = 1``)."""
    q1 = dead_angle(*(lengths[k] for k in ("la", "lb", "lc", "ld"))) - offset
    q2, q3 = closed_loop(q1, lengths)
    return {"q1": q1, "q2": q2, "q3": q3, "u1": 0.0}


def scene(dead_point: bool = False, offset: float = 1e-3) -> Scene:
    """The crank-rocker released from ``q1 = 0.5`` (default), or the triple rocker released
    ``offset`` rad below its dead point (``dead_point=True``)."""
    if dead_point:
        lengths, x0 = DEAD_POINT_LENGTHS, dead_point_state(DEAD_POINT_LENGTHS, offset)
        t_end, what = 1.0, f"released {offset:g} rad below its dead point"
    else:
        q2, q3 = closed_loop(0.5, LENGTHS)
        lengths, x0 = LENGTHS, {"q1": 0.5, "q2": q2, "q3": q3, "u1": 0.0}
        t_end, what = 5.0, "crank-rocker released from rest"
    return Scene(
        name="four_bar",
        model=build_model(),
        outputs=(Output.RHS, Output.ENERGY, Output.CONSTRAINT_FORCES, Output.DOPRI5),
        parameters={**lengths, "ma": 1.0, "mb": 1.5, "mc": 1.2},
        fixed={"g": 9.81},
        initial_state=x0,
        t_span=(0.0, t_end),
        description=f"four-bar linkage, closed loop with 1 dof ({what})",
        conserves_energy=True,
    )
