r"""A bicycle rolling on flat ground: four bodies, two nonholonomic rolling constraints.

The model is written the way a vehicle engineer writes it: a rear frame
(with the rider), a front frame (fork and handlebar) steering about a head
axis, and two knife-edge wheels that roll without slipping.  mbgen has no
constraint API yet, so the rolling constraints go into the kinematic
differential equations: the three speeds are the independent ones, and
``q' = G(q, u)`` is chosen so that neither contact point slips.

Frames (z up, gravity ``-g n3``)::

    Y  = N turned by psi about n3        heading (yaw) frame
    R  = Y turned by phi about y1        rear frame, leaned by phi (roll)
    RW = R turned by theta_r about r2    rear wheel
    F  = R turned by delta about r3      front frame, steered about the head axis r3
    FW = F turned by theta_f about f2    front wheel

Points: the rear contact ``P`` at ``x n1 + y n2``; the rear hub
``CR = P + rr r3``; the rear frame's mass centre ``GR = CR + xR r1 + zR r3``;
the head point ``S = CR + ws r1`` (the steer axis is the line through ``S``
along ``r3``); the front frame's mass centre ``GF = S + xF f1 + zF f3``; the
front hub ``CF = S + d f1 + s r3`` (``d``: fork offset, negative = the hub
behind the steer axis, so the trail is ``-d``); the front contact is the
point of the front rim nearest the ground,
``CF - rf (sin(delta) sin(phi) f1 + cos(phi) f3) / k`` with
``k = sqrt(sin(delta)^2 sin(phi)^2 + cos(phi)^2)``.

Simplification, stated plainly: the head axis is perpendicular to the rear
frame's ground line (no head-angle tilt), and the rear frame does not pitch.
A Whipple bicycle closes the loop through the ground with the rear frame's
pitch angle (a holonomic constraint with no closed form); here the front hub
slides instead along the steer axis by ``s(phi, delta) = (rf k - rr cos(phi)
- d sin(delta) sin(phi)) / cos(phi)`` (an ideal telescopic fork whose length
follows the ground; ``s = rf - rr`` upright), so both wheels touch the ground
exactly for every lean and steer angle.

Coordinates ``x, y, psi, phi, delta, theta_r, theta_f``; speeds
``u_phi = phi'``, ``u_delta = delta'``, ``u_r = theta_r'`` (3 degrees of
freedom).  Kinematic equations: those three; the rear wheel's rolling,
``x' = rr u_r cos(psi)``, ``y' = rr u_r sin(psi)``; and ``psi'``, ``theta_f'``
from the horizontal components (along ``y1``, ``y2``) of the velocity of the
front contact *material* point, ``v_CF + w_FW x (contact - CF) = 0``, two
equations linear in ``psi'`` and ``theta_f'`` (solved by Cramer's rule, with
the expressions as sympy.physics.vector produces them, unsimplified).  The
vertical components vanish by themselves (the wheels stay on the ground).  The
constraint forces do no work and nothing dissipates: ``T + V`` is conserved.

Closed form (:func:`straight_run`): upright and straight (``phi = delta = 0``,
``u_phi = u_delta = 0``) the bicycle rolls on at constant speed ``v = rr u_r``,
``x = x0 + v cos(psi) t``, ``y = y0 + v sin(psi) t``, ``theta_r = theta_r0 +
u_r t``, ``theta_f = theta_f0 + v t / rf`` (the machine is left-right symmetric,
so this is a solution, though an unstable one at most speeds).

Parameters are loosely those of the Meijaard et al. (2007) benchmark bicycle,
with the head axis made vertical; all are baked in as ``fixed`` constants
except ``g``.  Without head-angle tilt this machine is not self-stable: at
every forward speed its linearisation about the upright straight run has a
real eigenvalue near +5 /s (it falls over), so the default run, a lean of
0.05 rad at 4 m/s, is 0.6 s long (the lean grows to about 0.4 rad).
"""

from __future__ import annotations

import math

import numpy as np
import sympy as sm

from .. import Model, Output, Scene, t

#: Parameter values (SI units); inertias about the mass centres in body-frame components.
PARAMETERS = {
    "rr": 0.3, "rf": 0.35,                     # wheel radii
    "ws": 1.1, "d": -0.08,                     # hub-to-head distance, fork offset (trail 0.08)
    "mR": 85.0, "xR": 0.3, "zR": 0.6,          # rear frame + rider: mass, centre from the rear hub
    "IRxx": 9.2, "IRyy": 11.0, "IRzz": 2.8, "IRzx": -2.4,
    "mF": 4.0, "xF": -0.2, "zF": 0.4,          # front frame: mass, centre from the head point
    "IFxx": 0.05892, "IFyy": 0.06, "IFzz": 0.00708, "IFzx": 0.00756,
    "mRW": 2.0, "IRWd": 0.0603, "IRWa": 0.12,  # rear wheel: mass, diametral and axial inertia
    "mFW": 3.0, "IFWd": 0.1405, "IFWa": 0.28,  # front wheel
    "g": 9.81,
}


def build_model() -> Model:
    """The bicycle; constants in the order of :data:`PARAMETERS`."""
    m = Model("bicycle")
    x, y, psi, phi, delta, theta_r, theta_f = m.coordinates("x y psi phi delta theta_r theta_f")
    u_phi, u_delta, u_r = m.speeds("u_phi u_delta u_r")
    (rr, rf, ws, d, mR, xR, zR, IRxx, IRyy, IRzz, IRzx, mF, xF, zF, IFxx, IFyy, IFzz, IFzx,
     mRW, IRWd, IRWa, mFW, IFWd, IFWa, g) = m.constants(" ".join(PARAMETERS))

    N = m.newtonian("N")
    Y = m.rotate(N, "Y", 3, psi)
    R = m.rotate(Y, "R", 1, phi)
    RW = m.rotate(R, "RW", 2, theta_r)
    F = m.rotate(R, "F", 3, delta)
    FW = m.rotate(F, "FW", 2, theta_f)

    # geometry of the front contact: the rim point nearest the ground
    down_fx, down_fz = N.z.dot(F.x), N.z.dot(F.z)        # sin(delta) sin(phi), cos(phi)
    k = sm.sqrt(down_fx ** 2 + down_fz ** 2)
    s = (rf * k - rr * N.z.dot(R.z) - d * down_fx) / N.z.dot(R.z)   # telescopic fork

    P = m.point("P", m.origin, x * N.x + y * N.y)
    CR = m.point("CR", P, rr * R.z)
    GR = m.point("GR", CR, xR * R.x + zR * R.z)
    S = m.point("S", CR, ws * R.x)
    GF = m.point("GF", S, xF * F.x + zF * F.z)
    CF = m.point("CF", S, d * F.x + s * R.z)
    to_front_contact = -rf * (down_fx * F.x + down_fz * F.z) / k

    m.body("rear_frame", R, mR, (IRxx, IRyy, IRzz, 0, 0, IRzx), GR)
    m.body("front_frame", F, mF, (IFxx, IFyy, IFzz, 0, 0, IFzx), GF)
    m.body("rear_wheel", RW, mRW, (IRWd, IRWa, IRWd), CR)
    m.body("front_wheel", FW, mFW, (IFWd, IFWa, IFWd), CF)
    m.gravity(-g * N.z)

    # rolling without slip: the contact material points have no horizontal velocity.
    # Rear wheel: its contact moves along r1 at rr theta_r', so P moves with rr u_r y1.
    rear = {x.diff(t): rr * u_r * sm.cos(psi), y.diff(t): rr * u_r * sm.sin(psi),
            phi.diff(t): u_phi, delta.diff(t): u_delta, theta_r.diff(t): u_r}
    # Front wheel: two equations, linear in psi' and theta_f', solved by Cramer's rule
    # (its determinant is far from 0 near the upright straight run).
    v_front = CF.pos_from(m.origin).dt(N) + FW.ang_vel_in(N).cross(to_front_contact)
    psi_d, theta_f_d = psi.diff(t), theta_f.diff(t)
    (a1, b1, c1), (a2, b2, c2) = (
        [e.diff(psi_d), e.diff(theta_f_d), e.subs({psi_d: 0, theta_f_d: 0})]
        for e in (v_front.dot(Y.x).xreplace(rear), v_front.dot(Y.y).xreplace(rear)))
    det = a1 * b2 - a2 * b1
    m.kinematics({x: rear[x.diff(t)], y: rear[y.diff(t)], phi: u_phi, delta: u_delta,
                  theta_r: u_r, psi: (b1 * c2 - b2 * c1) / det, theta_f: (a2 * c1 - a1 * c2) / det})
    return m


def straight_run(t_eval, x0, p) -> np.ndarray:
    """Exact state of the upright straight run, ``x(t)`` for ``x0`` with ``phi = delta = 0``.

    Parameters
    ----------
    t_eval : array_like, shape (k,)
        Times from the start of the run.
    x0 : array_like, shape (10,)
        Initial state in layout order ``[x, y, psi, phi, delta, theta_r, theta_f,
        u_phi, u_delta, u_r]``; ``phi, delta, u_phi, u_delta`` must be 0.
    p : mapping
        Parameter values by name (``rr`` and ``rf`` are read).

    Returns
    -------
    ndarray, shape (k, 10)
    """
    t_eval = np.asarray(t_eval, dtype=float)
    x0 = np.asarray(x0, dtype=float)
    if np.any(x0[[3, 4, 7, 8]] != 0):
        raise ValueError("the straight run needs phi = delta = u_phi = u_delta = 0")
    speed = p["rr"] * x0[9]
    out = np.tile(x0, (t_eval.size, 1))
    out[:, 0] += speed * math.cos(x0[2]) * t_eval
    out[:, 1] += speed * math.sin(x0[2]) * t_eval
    out[:, 5] += x0[9] * t_eval
    out[:, 6] += speed / p["rf"] * t_eval
    return out


def scene(speed: float = 4.0, lean: float = 0.05) -> Scene:
    """Start at ``speed`` m/s leaned by ``lean`` rad, steering straight (see the module
    docstring)."""
    fixed = {k: v for k, v in PARAMETERS.items() if k != "g"}
    return Scene(
        name="bicycle",
        model=build_model(),
        outputs=(Output.RHS, Output.JACOBIAN, Output.ROSENBROCK),
        parameters={"g": PARAMETERS["g"]},
        fixed=fixed,
        initial_state={"phi": lean, "u_r": speed / PARAMETERS["rr"]},
        t_span=(0.0, 0.6),
        description="bicycle: rear frame, steered front frame, two wheels rolling without slip "
                    "(vertical head axis, telescopic fork closes the loop)",
        conserves_energy=True,
    )
