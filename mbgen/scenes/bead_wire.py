"""Bead sliding on a straight wire spun at a constant rate in a horizontal plane
(lecture 1, example 2).

The wire lies along ``w1`` of the frame ``W``, which turns about the vertical
N3 by the prescribed angle ``theta = omega t``.  The bead of mass ``m`` is at
``r = rho w1``; its speed is ``u = rho'``.  Gravity is balanced by the wire
and does no work, so it is left out.  The notes find::

    a = (rho'' - rho omega^2) e_rho + 2 rho' omega e_theta,
    m (rho'' - rho omega^2) = 0  =>  rho(t) = c1 e^(omega t) + c2 e^(-omega t)

with ``c1 = (rho0 + rho0'/omega) / 2`` and ``c2 = (rho0 - rho0'/omega) / 2``
from the state at ``t = 0``; the wire pushes with ``lambda = 2 m omega rho'``
along ``e_theta``.  The motor that keeps ``omega`` constant does work, so the
energy ``m (rho'^2 + omega^2 rho^2) / 2`` is not conserved.
"""

import numpy as np

from .. import Model, Output, Scene, t


def build_model() -> Model:
    """The bead on the spinning wire; constants ``omega, m`` (in this order)."""
    m = Model("bead_wire")
    rho, = m.coordinates("rho")
    m.speeds("u")
    omega, mass = m.constants("omega m")
    N = m.newtonian("N")
    W = m.rotate(N, "W", 3, m.prescribed("theta", omega * t))
    P = m.point("P", m.origin, rho * W.x)
    m.particle("bead", P, mass)
    return m


def closed_form(t, x0, p) -> np.ndarray:
    """Exact ``[rho, rho']`` at times ``t``.

    Parameters
    ----------
    t : array_like, shape (k,)
        Times (the solution starts from ``x0`` at ``t = 0``).
    x0 : array_like, shape (2,)
        ``[rho, u]`` at ``t = 0``.
    p : array_like, shape (2,)
        Parameters in layout order, ``[omega, m]``.

    Returns
    -------
    ndarray, shape (k, 2)
    """
    t = np.asarray(t, dtype=float)
    rho0, u0 = x0
    omega = p[0]
    c1 = (rho0 + u0 / omega) / 2
    c2 = (rho0 - u0 / omega) / 2
    grow, decay = c1 * np.exp(omega * t), c2 * np.exp(-omega * t)
    return np.column_stack([grow + decay, omega * (grow - decay)])


def scene() -> Scene:
    """Start near the axis, moving inwards slowly: the bead turns back and flies out."""
    return Scene(
        name="bead_wire",
        model=build_model(),
        outputs=(Output.RHS, Output.DOPRI5),
        parameters={"omega": 2.0},
        fixed={"m": 0.1},
        initial_state={"rho": 0.5, "u": -0.8},
        t_span=(0.0, 3.0),
        description="bead on a straight wire spun at constant rate (lecture 1, example 2)",
        closed_form=closed_form,
        conserves_energy=False,
    )
