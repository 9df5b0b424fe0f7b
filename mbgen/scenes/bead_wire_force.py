r"""The bead on the spinning wire with the wire stated as a guide: the wire's force on the bead.

The scene ``bead_wire`` puts the bead on the wire by its coordinates, so the
wire's push never appears.  Here the bead may leave the wire sideways: in the
wire's frame ``W`` (turned about N3 by the prescribed ``theta = omega t``) it is at
``r = rho w1 + s w2``, and the wire is a guide, :meth:`~mbgen.Model.coincident`
along ``w2`` between the bead ``P`` and the wire's point ``Q = rho w1`` next to it::

    (r_P - r_Q) . w2 = s = 0      (dependent coordinate s, dependent speed v = s')

The multiplier (``constraint_forces``, row ``wire_y``) is the force of the wire on
the bead along ``w2 = e_theta``.  The notes (lecture 1, example 2) find ``a =
(rho'' - rho omega^2) e_rho + 2 rho' omega e_theta``, so ``rho'' = omega^2 rho``
(:func:`mbgen.scenes.bead_wire.closed_form` holds unchanged) and the wire pushes with::

    lambda(t) = 2 m omega rho'(t)

(:func:`wire_force`).  Same numbers and start as ``bead_wire``; the motor that
spins the wire does work, so ``T + V`` is not conserved.
"""

from __future__ import annotations

import numpy as np

from .. import Model, Output, Scene, t
from .bead_wire import closed_form as _rho_closed_form


def build_model() -> Model:
    """The bead with the wire as a guide; constants ``omega, m`` (in this order)."""
    m = Model("bead_wire_force")
    rho, s = m.coordinates("rho s")
    m.speeds("u v")
    omega, mass = m.constants("omega m")
    N = m.newtonian("N")
    W = m.rotate(N, "W", 3, m.prescribed("theta", omega * t))
    P = m.point("P", m.origin, rho * W.x + s * W.y)
    Q = m.point("Q", m.origin, rho * W.x)
    m.particle("bead", P, mass)
    m.coincident(P, Q, [s], frame=W, axes=(2,), name="wire")
    return m


def closed_form(t, x0, p) -> np.ndarray:
    """Exact ``[rho, s, rho']`` at times ``t`` (``s = 0``; see ``bead_wire``).

    Parameters
    ----------
    t : array_like, shape (k,)
    x0 : array_like, shape (3,)
        ``[rho, s, u]`` at ``t = 0``.
    p : array_like, shape (2,)
        ``[omega, m]``.

    Returns
    -------
    ndarray, shape (k, 3)
    """
    rho = _rho_closed_form(t, [x0[0], x0[2]], p)
    return np.column_stack([rho[:, 0], np.zeros(len(rho)), rho[:, 1]])


def wire_force(x, omega: float, m: float) -> float:
    """``lambda = 2 m omega rho'`` at the state ``x = [rho, s, u]``."""
    return 2.0 * m * omega * float(x[2])


def scene() -> Scene:
    """The ``bead_wire`` start: near the axis, moving inwards; the bead turns back."""
    return Scene(
        name="bead_wire_force",
        model=build_model(),
        outputs=(Output.RHS, Output.CONSTRAINT_FORCES, Output.DOPRI5),
        parameters={"omega": 2.0, "m": 0.1},
        initial_state={"rho": 0.5, "s": 0.0, "u": -0.8},
        t_span=(0.0, 3.0),
        description="bead on a spinning wire, wire stated as a guide: its force "
                    "(lecture 1, ex. 2)",
        closed_form=closed_form,
        conserves_energy=False,
    )
