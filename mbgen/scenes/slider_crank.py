r"""A slider-crank driven by a torque: a closed loop with one degree of freedom and an input.

In the horizontal plane (no gravity), the crank ``A`` (length ``la``, uniform bar of
mass ``ma``) turns about the fixed pivot ``O`` by ``q1``; the connecting rod ``B``
(length ``lb``, uniform bar of mass ``mb``, absolute angle ``q2``) joins the crank pin
``PA = la a1`` to the piston, a slider of mass ``ms`` at ``S = q3 n1`` on the line
through ``O`` along n1.  The loop closes where the rod's end meets the piston::

    la cos q1 + lb cos q2 - q3 = 0,      la sin q1 + lb sin q2 = 0

(:meth:`~mbgen.Model.coincident` along n1 and n2, dependent ``q3`` and ``q2``).  With
``lb > la`` the rod never stands across the guide, so the dependent block of the
constraint Jacobian, ``[[-1, -lb sin q2], [0, lb cos q2]]`` (rows n1, n2; columns
``u3``, ``u2``), stays invertible: ``det = -lb cos q2 != 0``.  The crank is driven by
the input torque ``T`` (about n3); the piston compresses a gas spring (stiffness
``k``, natural length ``l0``) against the cylinder head ``H = lh n1``; a viscous
damper ``c`` on the crank dissipates.

Power balance: ``d(T + V)/dt = T q1' - c q1'^2`` (``V = k (lh - q3 - l0)^2 / 2``).  The
multipliers (``constraint_forces``, rows ``pin_x``, ``pin_y``) are the force the
piston exerts on the rod at the pin, along n1 and n2.
"""

from __future__ import annotations

import math

from .. import Model, Output, Scene


def build_model() -> Model:
    """The slider-crank; constants ``la lb ma mb ms k lh l0 c``, input ``T``."""
    m = Model("slider_crank")
    q1, q2, q3 = m.coordinates("q1 q2 q3")
    u1, u2, u3 = m.speeds("u1 u2 u3")
    la, lb, ma, mb, ms, k, lh, l0, c = m.constants("la lb ma mb ms k lh l0 c")
    T, = m.inputs("T")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)
    B = m.rotate(N, "B", 3, q2)
    PA = m.point("PA", m.origin, la * A.x)
    PB = m.point("PB", PA, lb * B.x)
    S = m.point("S", m.origin, q3 * N.x)
    m.body("crank", A, ma, (0, 0, ma * la**2 / 12), m.point("GA", m.origin, la / 2 * A.x))
    m.body("rod", B, mb, (0, 0, mb * lb**2 / 12), m.point("GB", PA, lb / 2 * B.x))
    m.particle("piston", S, ms)
    m.torque(A, (T - c * u1) * N.z)
    m.spring("gas", m.point("H", m.origin, lh * N.x), S, k, l0)
    m.coincident(PB, S, [q3, q2], axes=(1, 2), name="pin")
    return m


def closed_loop(q1: float, la: float, lb: float) -> tuple[float, float]:
    """``(q2, q3)`` that close the loop at crank angle ``q1`` (the piston on the +n1 side)."""
    q2 = -math.asin(la * math.sin(q1) / lb)
    return q2, la * math.cos(q1) + lb * math.cos(q2)


def scene() -> Scene:
    """Start at rest at ``q1 = 0.3``; the torque input ``T`` is given at run time."""
    la, lb = 0.1, 0.35
    q2, q3 = closed_loop(0.3, la, lb)
    return Scene(
        name="slider_crank",
        model=build_model(),
        outputs=(Output.RHS, Output.ENERGY, Output.CONSTRAINT_FORCES, Output.DOPRI5),
        parameters={"la": la, "lb": lb, "ma": 1.0, "mb": 0.8, "ms": 0.5, "k": 200.0,
                    "lh": 0.6, "l0": 0.2, "c": 0.05},
        initial_state={"q1": 0.3, "q2": q2, "q3": q3, "u1": 0.0},
        t_span=(0.0, 2.0),
        description="slider-crank driven by the input torque T, closed loop with 1 dof",
        conserves_energy=False,
    )
