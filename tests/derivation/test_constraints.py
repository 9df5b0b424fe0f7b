"""Constraints and reduced speeds: the core, checked against sympy and against physics.

* the rolling disc stated with ``no_slip`` reproduces the published equations of the disc
  whose contact is built in (sympy's test_kane.py), in C, generated Python and the reference;
* its constraint forces are the ground's force at the contact (Newton's law for the disc);
* Jacobians by implicit differentiation equal finite differences and the reference;
* linearisation equals sympy's ``KanesMethod.linearize`` of the same nonholonomic disc, and
  the upright disc at the critical speed 1/sqrt(3) has only zero eigenvalues;
* a four-bar closed with ``coincident``: consistent initial states, projection keeps the
  loop closed (and not projecting lets it drift), joint reactions including the loop-closing
  force satisfy Newton's law for the whole mechanism;
* a particle held on a paraboloid by a stated holonomic constraint feels the normal force
  the embedded model's joint reaction gives.
"""

from functools import cache

import numpy as np
import pytest
import sympy as sm
from sympy.physics import mechanics as me

import mbgen
from checks import random_states
from mbgen import Model
from mbgen.derivation import Method
from mbgen.scenes.rolling_disc import build_model as build_rolling_disc
from models import four_bar_model

DISC = dict(r=1.0, m=1.0, g=1.0)


def rolling_disc_model():
    """sympy's rolling disc (yaw, lean, spin; body rates in the lean frame) on a plane, with the
    contact point's position q4, q5 and its no-slip constraint stated (the built-in scene
    ``rolling_disc``'s model)."""
    return build_rolling_disc("disc_ns")


@cache
def rolling_disc():
    scn = mbgen.Scene("disc_ns", rolling_disc_model(), parameters=DISC, points=("D",))
    return mbgen.run(scn, ("rhs", "jacobian", "constraint_forces", "velocities", "energy"))


def published(x, r=1.0, g=1.0):
    q1, q2, q3, q4, q5, u1, u2, u3 = x
    return np.array([(6 * u2 * u3 * r - u3**2 * r * np.tan(q2) + 4 * g * np.sin(q2)) / (5 * r),
                     -2 * u1 * u3 / 3, u1 * (-2 * u2 + u3 * np.tan(q2))])


def test_rolling_disc_reproduces_the_published_equations():
    res = rolling_disc()
    c, py = res.compiled, mbgen.python_model(res.rendered)
    ref = mbgen.LambdifiedModel(res.baked, c.outputs, layout=c.layout)
    assert c.state_names == ("q1", "q2", "q3", "q4", "q5", "u1", "u2", "u3")
    assert c.constraint_names == ("C_contact_x", "C_contact_y")
    for x in random_states(c.n_x):
        np.testing.assert_allclose(c.rhs(0, x)[5:], published(x), rtol=1e-12, atol=1e-12)
        for out in ("rhs", "jacobian", "constraint_forces", "velocities", "energy"):
            want = getattr(ref, out)(0, x)
            np.testing.assert_allclose(getattr(c, out)(0, x), want, rtol=1e-11, atol=1e-12)
            np.testing.assert_allclose(getattr(py, out)(0, x), getattr(c, out)(0, x),
                                       rtol=1e-13, atol=1e-13)
        h = 1e-6
        fd = np.column_stack([(c.rhs(0, x + h * e) - c.rhs(0, x - h * e)) / (2 * h)
                              for e in np.eye(c.n_x)])
        np.testing.assert_allclose(c.jacobian(0, x), fd, rtol=1e-6, atol=1e-7)


def test_rolling_disc_contact_force_is_newtons_law():
    """The ground's horizontal force on the disc is m a_D (the disc's only other force, gravity,
    is vertical): the multipliers are that force along N.x and N.y."""
    res = rolling_disc()
    c = res.compiled
    for x in random_states(c.n_x, seed=3):
        f = c.rhs(0, x)
        h = 1e-6
        a = (c.velocities(0, x + h * f) - c.velocities(0, x - h * f))[0] / (2 * h)
        np.testing.assert_allclose(c.constraint_forces(0, x), a[:2] * DISC["m"], rtol=1e-6,
                                   atol=1e-7)
        # the contact point of the disc does not move: its centre's velocity is w x r_CD
        assert np.all(np.isfinite(c.velocities(0, x)))


def sympy_nonholonomic_disc():
    """The same disc in sympy's KanesMethod with u4, u5 dependent (test_kane2.py style)."""
    t = me.dynamicsymbols._t
    q1, q2, q3, q4, q5 = q = me.dynamicsymbols("q1:6")
    u1, u2, u3, u4, u5 = u = me.dynamicsymbols("u1:6")
    r, m, g = sm.symbols("r m g")
    N = me.ReferenceFrame("N")
    Y = N.orientnew("Y", "Axis", [q1, N.z])
    L = Y.orientnew("L", "Axis", [q2, Y.x])
    R = L.orientnew("R", "Axis", [q3, L.y])
    w_qd = R.ang_vel_in(N)
    R.set_ang_vel(N, u1 * L.x + u2 * L.y + u3 * L.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", q4 * N.x + q5 * N.y)
    C.set_vel(N, u4 * N.x + u5 * N.y)
    D = C.locatenew("D", r * L.z)
    D.set_vel(N, C.vel(N) + me.cross(L.ang_vel_in(N), r * L.z))
    kd = [me.dot(R.ang_vel_in(N) - w_qd, v) for v in L] + [q4.diff(t) - u4, q5.diff(t) - u5]
    contact = D.vel(N) + me.cross(R.ang_vel_in(N), -r * L.z)
    vc = [me.dot(contact, N.x), me.dot(contact, N.y)]
    I = me.inertia(L, m / 4 * r**2, m / 2 * r**2, m / 4 * r**2)
    body = me.RigidBody("disc", D, R, m, (I, D))
    kane = me.KanesMethod(N, q_ind=list(q), u_ind=[u1, u2, u3], u_dependent=[u4, u5],
                          kd_eqs=kd, velocity_constraints=vc)
    kane.kanes_equations([body], [(D, -m * g * N.z)])
    return kane, q, u, (r, m, g)


def test_linearisation_equals_sympys_nonholonomic_kane():
    """At steady upright rolling (a motion, not a rest point: q3, q4 and q5 change), sympy's
    Linearizer needs every derivative's operating value; they come from the compiled RHS."""
    t = me.dynamicsymbols._t
    kane, q, u, (r, m, g) = sympy_nonholonomic_disc()
    res = rolling_disc()
    c = res.compiled
    x = np.array([0.3, 0.0, -0.4, 0.5, -0.1, 0.0, 0.9, 0.0])
    xdot = c.rhs(0, x)
    assert np.allclose(xdot[5:], 0.0)                     # steady
    op = dict(zip(q, x[:5])) | dict(zip(u[:3], x[5:]))
    op |= {qi.diff(t): v for qi, v in zip(q, xdot[:5])}
    op |= {ui.diff(t): 0.0 for ui in u}
    vc = kane._f_nh + kane._k_nh * kane.u   # private in sympy 1.14: the velocity constraints
    op |= sm.solve([e.subs(op) for e in vc], list(u[3:]), dict=True)[0]
    A = kane.linearize(A_and_B=True, op_point=op, simplify=False)[0]
    A = np.array(A.subs({r: 1, m: 1, g: 1}).evalf(), dtype=float)
    lin = mbgen.linearize(c, x)
    assert lin.states == c.state_names and lin.A.shape == (8, 8)
    np.testing.assert_allclose(lin.A, A, rtol=1e-9, atol=1e-10)
    assert np.abs(lin.A).max() > 0.1


def test_upright_disc_at_the_critical_speed_has_only_zero_eigenvalues():
    """sympy's benchmark (test_kane.py): r = g = m = 1, upright, spinning at u2 = 1/sqrt(3)."""
    c = rolling_disc().compiled
    x = np.zeros(8)
    x[6] = 1 / np.sqrt(3)
    lin = mbgen.linearize(c, x)
    assert np.max(np.abs(lin.eigenvalues)) < 1e-6
    x[6] = 1.0               # faster: the upright disc is stable, purely oscillatory
    ev = mbgen.linearize(c, x).eigenvalues
    assert np.max(np.abs(ev.real)) < 1e-9 and np.max(np.abs(ev.imag)) > 0.1


# ------------------------------------------------------------------ four-bar (holonomic)
FOUR_BAR = dict(la=1.0, lb=2.0, lc=2.0, ld=2.0, g=9.81)


@cache
def four_bar(method=Method.KANE):
    scn = mbgen.Scene("fourbar_t", four_bar_model("fourbar_t"), parameters=FOUR_BAR,
                      points=("GA", "GB", "GC"), method=method)
    return mbgen.run(scn, ("rhs", "jacobian", "energy", "reactions", "constraint_forces",
                           "velocities", "dopri5"), name=f"fourbar_{method.value}")


def test_four_bar_consistent_state_projection_and_energy():
    c = four_bar().compiled
    assert c.dependent_coordinates == ("q2", "q3")
    x0 = c.consistent([0.5, 1.5, 1.2, 0.0])
    assert np.max(np.abs(c.holonomic(0, x0))) < 1e-12 and x0[0] == 0.5
    with pytest.raises(mbgen.ConstraintError, match="did not converge"):
        c.consistent([0.5, 1.5, 1.2, 0.0], max_iterations=1)
    t = np.linspace(0, 5, 11)
    on = c.integrate("dopri5", t, x0, rtol=1e-8, atol=1e-10)
    off = c.integrate("dopri5", t, x0, rtol=1e-8, atol=1e-10, project=False)
    assert np.max(np.abs(c.holonomic(0, on.x[-1]))) < 1e-12
    drift = np.max(np.abs(c.holonomic(0, off.x[-1])))
    assert drift > 100 * np.max(np.abs(c.holonomic(0, on.x[-1])))
    assert off.max_residual == pytest.approx(drift, rel=0.5)
    energy = [sum(c.energy(0, x)) for x in on.x]
    assert max(energy) - min(energy) < 1e-5


@pytest.mark.parametrize("method", [Method.KANE, Method.NEWTON_EULER])
def test_four_bar_reactions_include_the_loop_closing_force(method):
    """The two ground joints carry what Newton's law asks of the whole mechanism."""
    res = four_bar(method)
    c = res.compiled
    ref = mbgen.LambdifiedModel(res.baked, c.outputs, layout=c.layout)
    masses, g = np.array([1.0, 1.5, 1.2]), np.array([0.0, -9.81, 0.0])
    for x in random_states(4, seed=9):
        x = c.consistent(x)
        np.testing.assert_allclose(c.reactions(0, x), ref.reactions(0, x), rtol=1e-10,
                                   atol=1e-10)
        f = c.rhs(0, x)
        h = 1e-6
        a = (c.velocities(0, x + h * f) - c.velocities(0, x - h * f)) / (2 * h)
        R = c.reactions(0, x)
        assert c.reaction_names == ("crank", "coupler", "rocker")

        def rot(angle):
            return np.array([[np.cos(angle), -np.sin(angle), 0],
                             [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])

        ground = rot(x[0]) @ R[0, :3] + rot(x[2]) @ R[2, :3]
        np.testing.assert_allclose(ground, (masses[:, None] * (a - g)).sum(axis=0), rtol=1e-6,
                                   atol=1e-6)


def test_four_bar_linearisation_in_the_independent_state():
    """At a rest point (an equilibrium), one degree of freedom: A is 2 x 2 in (q1, u1), and
    its dq1 column matches a finite difference of u1' along the constraint manifold."""
    c = mbgen.compile(four_bar().equations, ("rhs", "jacobian", "holonomic", "holonomic_jacobian"),
                      parameters=FOUR_BAR, name="fourbar_lin")
    # follow the branch of the loop by continuation; a stable rest point has u1' = 0 and
    # u1' decreasing in q1
    x = c.consistent([0.5, 1.5, 1.2, 0.0])
    branch = []
    for q1 in np.linspace(0.5, 0.5 - 2 * np.pi, 253):
        x = c.consistent([q1, x[1], x[2], 0.0])
        branch.append((q1, x.copy(), c.rhs(0, x)[3]))
    k = next(i for i in range(len(branch) - 1)
             if branch[i][2] > 0 >= branch[i + 1][2] or branch[i][2] < 0 <= branch[i + 1][2])
    (qa, xa, _), (qb, _, _) = branch[k], branch[k + 1]

    def accel(q1, guess=xa):
        return c.rhs(0, c.consistent([q1, guess[1], guess[2], 0.0]))[3]

    from scipy.optimize import brentq

    q_eq = brentq(accel, qa, qb, xtol=1e-14)
    x = c.consistent([q_eq, xa[1], xa[2], 0.0])
    lin = mbgen.linearize(c, x)
    assert lin.states == ("q1", "u1") and lin.A.shape == (2, 2)
    h = 1e-6
    slope = (accel(q_eq + h, x) - accel(q_eq - h, x)) / (2 * h)
    assert lin.A[1, 0] == pytest.approx(slope, rel=1e-5)
    assert lin.A[0, 1] == pytest.approx(1.0) and lin.A[0, 0] == 0 and abs(lin.A[1, 1]) < 1e-9
    ev = lin.eigenvalues      # a rest point: +-sqrt(slope), real or imaginary
    np.testing.assert_allclose(np.sort_complex(ev), np.sort_complex(
        np.array([1, -1]) * np.sqrt(complex(slope))), atol=1e-6)
    with pytest.raises(mbgen.ConstraintError, match="consistent"):
        mbgen.linearize(c, x + np.array([0.0, 0.01, 0.0, 0.0]))


# ------------------------------------------------------------------ stated vs embedded
def test_paraboloid_normal_force_stated_equals_embedded():
    """A particle on z = k (x^2 + y^2): in Cartesian coordinates with the surface stated as a
    holonomic constraint, the multiplier times the gradient is the force the embedded model's
    joint reaction gives (the scene ``paraboloid``)."""
    k, mass, g = 0.5, 1.0, 9.81
    m = Model("para_stated")
    x, y, z = m.coordinates("x y z")
    m.speeds("vx vy vz")
    N = m.newtonian()
    m.particle("p", m.point("P", m.origin, x * N.x + y * N.y + z * N.z), mass)
    m.gravity(-g * N.z)
    m.holonomic(z - k * (x**2 + y**2), z)
    stated = mbgen.compile(mbgen.Scene("para_stated", m),
                           ("rhs", "constraint_forces", "holonomic", "holonomic_jacobian"))
    embedded_scene = mbgen.load_scene("paraboloid")
    emb = mbgen.compile(embedded_scene, ("rhs", "reactions"), method=Method.NEWTON_EULER,
                        fixed={}, parameters={"k": k, "m": mass, "g": g}, name="para_emb")
    assert set(emb.parameter_names) <= {"k", "m", "g"}
    p_emb = np.array([{"k": k, "m": mass, "g": g}[n] for n in emb.parameter_names])
    for q1, q2, u1, u2 in random_states(4, seed=4):
        # embedded: x = q1 cos q2, y = q1 sin q2, z = k q1^2
        pos = [q1 * np.cos(q2), q1 * np.sin(q2)]
        vel = [u1 * np.cos(q2) - q1 * u2 * np.sin(q2), u1 * np.sin(q2) + q1 * u2 * np.cos(q2)]
        xs = stated.consistent(np.array(pos + [0.0] + vel))
        lam = stated.constraint_forces(0, xs)[0]
        grad = np.array([-2 * k * pos[0], -2 * k * pos[1], 1.0])
        force = lam * grad
        R = emb.reactions(0, np.array([q1, q2, u1, u2]), p_emb)[0]
        frame = emb.reaction_frames[0]
        assert frame in ("N", "A", "B")
        np.testing.assert_allclose(np.linalg.norm(R[:3]), np.linalg.norm(force), rtol=1e-9)
        np.testing.assert_allclose(stated.rhs(0, xs)[:2], vel, atol=1e-12)
