r"""A car towing a single-axle trailer on flat ground: planar vehicle dynamics with linear tyres.

The car (frame ``C``, mass centre ``G`` at ``X n1 + Y n2``, yaw ``psi`` about
n3) moves with the body-fixed velocity ``u c1 + v c2`` (longitudinal and
lateral speed) and the yaw rate ``r``.  The trailer (frame ``T``, turned from
the car's frame by the articulation angle ``theta`` about c3) hangs on the ball
of the point ``hitch`` at ``lh`` behind the car's mass centre; its mass centre
is ``e`` and its axle ``lt`` behind the hitch.  Speeds ``u, v, r`` and the
articulation rate ``w = theta'``; kinematics::

    X' = u cos(psi) - v sin(psi),   Y' = u sin(psi) + v cos(psi),   psi' = r,   theta' = w

Tyres: each axle (front at ``lf`` ahead of ``G``, rear at ``lr`` behind, trailer
axle) carries a linear side force ``-C_i alpha_i`` along its wheels' lateral
axis, with the slip angle taken as ``alpha_i = v_lat / v_long`` (the wheel
point's velocity across and along the wheel heading, the usual small-angle
linear tyre of single-track models; it needs ``v_long > 0``, a car driving
forwards).  The front wheels are steered by the input ``delta`` (their heading
is ``cos(delta) c1 + sin(delta) c2``); the input ``F_drive`` pushes the rear
axle along ``c1``.  Tyre side slip dissipates energy, so ``T + V`` is not
conserved (there is no potential energy: the motion is horizontal).

The hitch is the joint whose load matters: the trailer's inertia and tyre
force all pass through it.  The scene derives by Newton-Euler and reports the
``reactions``: row ``car`` (the ground's load on the car: zero, the car is a
free body) and row ``hitch`` (the force and moment the car exerts on the
trailer at the hitch, in car axes ``C``; a ball hitch carries no yaw moment).

Parameters are a mid-size car with a small luggage trailer; the masses stay
free at run time (a loaded trailer), the rest is baked in.  The default start
drives straight at 25 m/s with the trailer swung out by 0.1 rad; the trailer
sway dies out at this speed.
"""

from __future__ import annotations

import sympy as sm

from .. import Method, Model, Output, Scene

#: Parameter values (SI units).
PARAMETERS = {
    "m_car": 1500.0, "Izz_car": 2500.0,           # car mass and yaw inertia
    "lf": 1.2, "lr": 1.5, "lh": 2.5,              # front axle, rear axle, hitch from G
    "C_f": 80000.0, "C_r": 90000.0,               # cornering stiffness per axle, N/rad
    "m_tr": 600.0, "Izz_tr": 700.0,               # trailer mass and yaw inertia
    "e": 1.6, "lt": 1.9,                          # trailer mass centre and axle behind the hitch
    "C_t": 50000.0,                               # trailer axle cornering stiffness
}


def build_model() -> Model:
    """The car and trailer; constants in the order of :data:`PARAMETERS`, inputs
    ``F_drive, delta``."""
    m = Model("car_trailer")
    X, Y, psi, theta = m.coordinates("X Y psi theta")
    u, v, r, w = m.speeds("u v r w")
    (m_car, Izz_car, lf, lr, lh, C_f, C_r, m_tr, Izz_tr, e, lt, C_t) = \
        m.constants(" ".join(PARAMETERS))
    F_drive, delta = m.inputs("F_drive delta")
    m.kinematics({X: u * sm.cos(psi) - v * sm.sin(psi), Y: u * sm.sin(psi) + v * sm.cos(psi),
                  psi: r, theta: w})

    N = m.newtonian("N")
    C = m.rotate(N, "C", 3, psi)
    T = m.rotate(C, "T", 3, theta)
    G = m.point("G", m.origin, X * N.x + Y * N.y)
    front = m.point("front_axle", G, lf * C.x)
    rear = m.point("rear_axle", G, -lr * C.x)
    hitch = m.point("hitch", G, -lh * C.x)
    G_tr = m.point("G_tr", hitch, -e * T.x)
    axle_tr = m.point("trailer_axle", hitch, -lt * T.x)
    m.body("car", C, m_car, (0, 0, Izz_car), G)
    m.body("trailer", T, m_tr, (0, 0, Izz_tr), G_tr)
    m.joint("trailer", name="hitch", frame=C)   # the ball hitch; its load in car axes

    # velocities of the tyre points from the speeds (rigid-body formula in each body)
    v_G = u * C.x + v * C.y
    v_hitch = v_G + (r * C.z).cross(-lh * C.x)
    velocity = {front: v_G + (r * C.z).cross(lf * C.x), rear: v_G + (r * C.z).cross(-lr * C.x),
                axle_tr: v_hitch + ((r + w) * C.z).cross(-lt * T.x)}
    heading = {front: sm.cos(delta) * C.x + sm.sin(delta) * C.y, rear: C.x, axle_tr: T.x}
    stiffness = {front: C_f, rear: C_r, axle_tr: C_t}
    for point in (front, rear, axle_tr):
        along = heading[point]
        across = C.z.cross(along)
        slip = velocity[point].dot(across) / velocity[point].dot(along)
        m.force(point, -stiffness[point] * slip * across)
    m.force(rear, F_drive * C.x)
    return m


def scene() -> Scene:
    """Straight at 25 m/s, trailer swung out by 0.1 rad (see the module docstring)."""
    free = ("m_car", "m_tr")
    return Scene(
        name="car_trailer",
        model=build_model(),
        outputs=(Output.RHS, Output.REACTIONS, Output.DOPRI5),
        method=Method.NEWTON_EULER,
        parameters={k: PARAMETERS[k] for k in free},
        fixed={k: v for k, v in PARAMETERS.items() if k not in free},
        initial_state={"u": 25.0, "theta": 0.1},
        t_span=(0.0, 10.0),
        description="car towing a single-axle trailer: planar, linear tyre side forces, "
                    "steer and drive inputs, hitch point for the joint load",
        conserves_energy=False,
    )
