"""Physics of the vehicle scenes: the rolling bicycle and the car towing a trailer.

Bicycle: no contact point slips and both wheels touch the ground (checked on
the model's own sympy vectors with an independent formula for the contact
point, ``q'`` replaced by the derived ``G(q, u)``); ``T + V`` is conserved; the
upright straight run follows its closed form.  Car and trailer: the kinetic
energy changes at the rate of the tyre forces' power, computed by hand.
"""

from functools import cache

import numpy as np
import pytest
import sympy as sm

import mbgen
from mbgen.scenes import bicycle, car_trailer


@cache
def bicycle_scene():
    return mbgen.load_scene("bicycle")


@cache
def bicycle_compiled():
    """rhs + energy + dopri5 of the bicycle (the scene's Jacobian is not needed here)."""
    return mbgen.compile(bicycle_scene(), outputs=("rhs", "energy", "dopri5"))


def test_bicycle_contact_points_do_not_slip_and_touch_the_ground():
    scene = bicycle_scene()
    model = scene.model
    equations = mbgen.equations_of(scene)
    layout = equations.layout
    N, R, RW, FW = (model.frame(n) for n in ("N", "R", "RW", "FW"))
    points = {p.name: p for p in model.points}
    origin = model.origin
    values = {**scene.parameters, **scene.fixed}
    rr, rf = sm.Symbol("rr"), sm.Symbol("rf")   # the model's constants of these names

    def rim_point_nearest_ground(frame, radius):
        """Centre-to-contact vector: the in-plane direction closest to -n3 (independent formula)."""
        axle = frame.y
        down = -N.z + N.z.dot(axle) * axle          # -n3 minus its component along the axle
        return radius * down / sm.sqrt(down.dot(down))

    t = mbgen.t
    contacts = {}
    for hub, wheel, radius in ((points["CR"], RW, rr), (points["CF"], FW, rf)):
        to_contact = rim_point_nearest_ground(wheel, radius)
        velocity = hub.pos_from(origin).dt(N) + wheel.ang_vel_in(N).cross(to_contact)
        height = (hub.pos_from(origin) + to_contact).dot(N.z)
        contacts[hub.name] = [velocity.dot(N.x), velocity.dot(N.y), velocity.dot(N.z), height]

    q_funcs, u_funcs = model.coordinates_, model.speeds_
    rng = np.random.default_rng(11)
    for _ in range(4):
        q = rng.uniform(-0.6, 0.6, layout.n_q)
        u = rng.uniform(-3.0, 3.0, layout.n_u)
        numbers = {s: v for s, v in zip(layout.states, np.concatenate([q, u]))}
        numbers.update({s: values[str(s)] for s in layout.parameters})
        qdot = [float(g.xreplace(numbers)) for g in equations.kinematics]
        sub = {f.diff(t): v for f, v in zip(q_funcs, qdot)}
        sub.update({f: v for f, v in zip(q_funcs, q)})
        sub.update({f: v for f, v in zip(u_funcs, u)})
        sub.update({c: values[str(c)] for c in model.constants_})
        for name, exprs in contacts.items():
            vx, vy, vz, height = (float(e.subs(sub)) for e in exprs)
            assert max(abs(vx), abs(vy), abs(vz)) < 1e-12, (name, vx, vy, vz)
            assert abs(height) < 1e-12, (name, height)


def test_bicycle_conserves_energy():
    scene = bicycle_scene()
    model = bicycle_compiled()
    t_eval = np.linspace(*scene.t_span, 25)
    x = model.integrate("dopri5", t_eval, scene.x0(model.layout), rtol=1e-11, atol=1e-12).x
    assert abs(x[-1, 3]) > 0.2                         # it really falls over: a hard test
    TV = np.array([model.energy(0.0, xi) for xi in x])
    E = TV.sum(axis=1)
    assert np.abs(E - E[0]).max() < 1e-8 * np.abs(TV).max()


def test_bicycle_straight_run_matches_closed_form():
    model = bicycle_compiled()
    layout = model.layout
    x0 = np.zeros(layout.n_x)
    x0[list(layout.state_names).index("psi")] = 0.7
    x0[list(layout.state_names).index("u_r")] = 5.0 / bicycle.PARAMETERS["rr"]
    t_eval = np.linspace(0.0, 1.0, 11)
    x = model.integrate("dopri5", t_eval, x0, rtol=1e-11, atol=1e-12).x
    exact = bicycle.straight_run(t_eval, x0, bicycle.PARAMETERS)
    np.testing.assert_allclose(x, exact, rtol=1e-9, atol=1e-9)
    assert exact[-1, 0] == pytest.approx(5.0 * np.cos(0.7))   # 5 m/s for 1 s along psi


def test_bicycle_straight_run_rejects_a_leaning_start():
    with pytest.raises(ValueError, match="straight run"):
        bicycle.straight_run([0.0], [0, 0, 0, 0.1, 0, 0, 0, 0, 0, 1.0], bicycle.PARAMETERS)


def test_car_trailer_kinetic_energy_changes_at_the_power_of_the_tyre_forces():
    """dT/dt along the RHS equals the sum of tyre force . point velocity, by hand."""
    scene = mbgen.load_scene("car_trailer")
    model = mbgen.compile(scene, outputs=("rhs", "energy"))
    P = {**car_trailer.PARAMETERS, **scene.parameters}
    layout = model.layout
    names = list(layout.state_names)
    rng = np.random.default_rng(5)

    def kinetic(x):
        X, Y, psi, th, u, v, r, w = x
        car = P["m_car"] * (u * u + v * v) + P["Izz_car"] * r * r
        # trailer mass centre: hitch velocity plus (r + w) n3 x (-e t1), in car components
        c, s = np.cos(th), np.sin(th)
        vh = np.array([u, v - r * P["lh"]])
        vg = vh + (r + w) * P["e"] * np.array([s, -c])
        trailer = P["m_tr"] * vg @ vg + P["Izz_tr"] * (r + w) ** 2
        return 0.5 * (car + trailer)

    def tyre_power(x, delta):
        X, Y, psi, th, u, v, r, w = x
        c, s = np.cos(th), np.sin(th)
        vf = np.array([u, v + r * P["lf"]])
        vr = np.array([u, v - r * P["lr"]])
        vt = np.array([u, v - r * P["lh"]]) + (r + w) * P["lt"] * np.array([s, -c])
        power = 0.0
        for vel, heading, C in ((vf, np.array([np.cos(delta), np.sin(delta)]), P["C_f"]),
                                (vr, np.array([1.0, 0.0]), P["C_r"]),
                                (vt, np.array([c, s]), P["C_t"])):
            across = np.array([-heading[1], heading[0]])
            power += -C * (vel @ across) ** 2 / (vel @ heading)
        return power

    for _ in range(5):
        x = rng.uniform(-0.3, 0.3, layout.n_x)
        x[names.index("u")] = rng.uniform(10.0, 30.0)
        drive, delta = rng.uniform(-500.0, 500.0), rng.uniform(-0.05, 0.05)
        r_in = np.array([{"F_drive": drive, "delta": delta}[n] for n in layout.input_names])
        f = model.rhs(0.0, x, None, r_in)
        h = 1e-6
        dT = (kinetic(x + h * f) - kinetic(x - h * f)) / (2 * h)
        u = x[names.index("u")]
        expected = tyre_power(x, delta) + drive * u
        assert dT == pytest.approx(expected, rel=1e-6, abs=1e-6)
        T_model = model.energy(0.0, x, None, r_in)[0]
        assert T_model == pytest.approx(kinetic(x), rel=1e-12)


def test_car_trailer_sway_dies_out_at_the_default_speed():
    scene = mbgen.load_scene("car_trailer")
    model = mbgen.compile(scene)
    layout = model.layout
    t_eval = np.linspace(*scene.t_span, 11)
    x = model.integrate("dopri5", t_eval, scene.x0(layout), rtol=1e-9, atol=1e-12).x
    theta = x[:, list(layout.state_names).index("theta")]
    assert abs(theta[0]) == 0.1 and abs(theta[-1]) < 1e-3


def test_car_trailer_hitch_force_is_newtons_law_for_the_trailer():
    """The hitch row of ``reactions`` (car on trailer, car axes) by hand: Newton's law for the
    trailer, ``F_hitch + F_tyre = m_tr a_G``, with ``a_G`` from its velocity differentiated along
    the motion; a ball hitch carries no yaw moment; the car (a free body) gets nothing from the
    ground."""
    scene = mbgen.load_scene("car_trailer")
    model = mbgen.compile(scene, outputs=("rhs", "reactions"))
    assert model.reaction_names == ("car", "hitch") and model.reaction_frames == ("C", "C")
    P = {**car_trailer.PARAMETERS, **scene.parameters}
    names = list(model.layout.state_names)
    rng = np.random.default_rng(8)

    def trailer_velocity(x):     # mass centre, car axes
        X, Y, psi, th, u, v, r, w = x
        return np.array([u, v - r * P["lh"]]) + (r + w) * P["e"] * np.array(
            [np.sin(th), -np.cos(th)])

    for _ in range(4):
        x = rng.uniform(-0.3, 0.3, model.n_x)
        x[names.index("u")] = rng.uniform(10.0, 30.0)
        delta = rng.uniform(-0.05, 0.05)
        r_in = np.array([{"F_drive": 300.0, "delta": delta}[n] for n in model.layout.input_names])
        f = model.rhs(0.0, x, None, r_in)
        h = 1e-6
        vg = trailer_velocity(x)
        dvg = (trailer_velocity(x + h * f) - trailer_velocity(x - h * f)) / (2 * h)
        r_yaw = x[names.index("r")]
        a = dvg + r_yaw * np.array([-vg[1], vg[0]])          # acceleration, car axes
        X, Y, psi, th, u, v, r, w = x
        c, s = np.cos(th), np.sin(th)
        vt = np.array([u, v - r * P["lh"]]) + (r + w) * P["lt"] * np.array([s, -c])
        heading = np.array([c, s])
        across = np.array([-s, c])
        tyre = -P["C_t"] * (vt @ across) / (vt @ heading) * across
        R = model.reactions(0.0, x, None, r_in)
        np.testing.assert_allclose(R[1, :2], P["m_tr"] * a - tyre, rtol=1e-6, atol=1e-3)
        assert abs(R[1, 5]) < 1e-9 * max(1.0, np.abs(R[1, :2]).max())
        np.testing.assert_allclose(R[0], 0.0, atol=1e-9)
