"""Rigid point contacts (Model.contact): the constrained dynamics (u', lambda) and its
derivatives, checked against physics and across the seams.

* a particle on three sliders, held at a point: it does not accelerate and the ground's force
  is its weight less the applied forces (closed form);
* a four-joint leg with its foot held: compiled C, generated Python and the lambdified
  reference (numpy's dense saddle-point solve) agree on rhs, constraint_forces, jacobian and
  contact_jacobian at seeded random states, with Newton-Euler's rows (from the recursion) and
  Kane's (from the kinematic tree): two derivations of J and gamma;
* the Jacobians equal central differences of the right-hand side and of the forces;
* Baumgarte: J u' + gamma = -kd v - kp (r - r0), checked by differentiating the foot's
  velocity along the motion; the leg started off its anchor returns to it;
* two contacts at one place are CONTACT_SINGULAR, in C, Python and the reference; the
  refusals name the problem.
"""

from functools import cache

import numpy as np
import pytest

import mbgen
from checks import assert_close, random_states
from mbgen.derivation import Method
from mbgen.errors import ModelError, SingularConstraintError

OUTPUTS = ("rhs", "constraint_forces", "jacobian", "contact_jacobian", "positions",
           "velocities")


def leg(name="leg", extra_contact=False) -> mbgen.Model:
    """A four-joint leg (yaw, two pitches, a roll) on a fixed hip; its foot S is held."""
    m = mbgen.Model(name)
    q = m.coordinates("q1:5")
    m.speeds("u1:5")
    g, = m.constants("g", defaults=[9.81])
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q[0])
    B = m.rotate(A, "B", 2, q[1])
    C = m.rotate(B, "C", 2, q[2])
    D = m.rotate(C, "D", 1, q[3])
    P = m.point("P", m.origin, 0.1 * A.z)
    Q = m.point("Q", P, 0.5 * B.x)
    R = m.point("R", Q, 0.4 * C.x + 0.05 * C.z)
    S = m.point("S", R, 0.2 * D.y)
    m.body("thigh", B, 1.0, (0.01, 0.02, 0.03, 0.001, 0.0, 0.002), Q)
    m.body("shank", C, 0.7, (0.01, 0.02, 0.015), R)
    m.body("foot", D, 0.3, (0.002, 0.003, 0.004), S)
    m.gravity(-g * N.z)
    T = m.inputs("T1:5")
    for Ti, (F, parent, axis) in zip(T, [(A, N, A.z), (B, A, B.y), (C, B, C.y), (D, C, D.x)]):
        m.torque(F, Ti * axis, reaction=parent)
    m.contact(S, name="toe", anchor=(0.1, 0.2, 0.3))
    if extra_contact:
        m.contact(m.point("S2", S, 0), name="toe2")
    return m


@cache
def compiled_leg():
    return mbgen.run(leg(), OUTPUTS, method=Method.NEWTON_EULER)


@cache
def rendered_leg(method):
    return mbgen.run(leg(f"leg_{method.value}"), OUTPUTS, method=method, build=False)


def states(n, k=3, seed=0):
    rng = np.random.default_rng(seed)
    for x in random_states(n, k, seed):
        yield x, rng.uniform(-1, 1, 4), np.array([9.81, *rng.uniform(0.5, 2.0, 2),
                                                  *rng.uniform(-0.5, 0.5, 3)])


def test_the_ground_holds_a_particle_with_its_weight_less_the_applied_force():
    m = mbgen.Model("slider3")
    x = m.coordinates("x y z")
    m.speeds("vx vy vz")
    mass, g = m.constants("mass g", defaults=[2.0, 9.81])
    fx, fz = m.inputs("fx fz")
    N = m.newtonian()
    P = m.point("P", m.origin, x[0] * N.x + x[1] * N.y + x[2] * N.z)
    m.particle("p", P, mass)
    m.gravity(-g * N.z)
    m.force(P, fx * N.x + fz * N.z)
    m.contact(P)
    assert [str(c) for c in m.constants_][2:] == ["contact_kp", "contact_kd", "P_x0", "P_y0",
                                                  "P_z0"]
    res = mbgen.run(m, ("rhs", "constraint_forces"), build=False)
    py = mbgen.python_model(res.rendered)
    s = np.array([0.3, -0.2, 0.1, 0.0, 0.0, 0.0])
    p = np.array([2.0, 9.81, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert_close(py.rhs(0.0, s, p, [1.5, -4.0])[3:], np.zeros(3), 1e-14)
    assert_close(py.constraint_forces(0.0, s, p, [1.5, -4.0]), [-1.5, 0.0, 2.0 * 9.81 + 4.0],
                 1e-14)
    assert py.constraint_names == ("P.x", "P.y", "P.z")


def test_c_python_and_the_reference_agree_on_a_held_leg():
    res = compiled_leg()
    c, py = res.compiled, mbgen.python_model(res.rendered)
    ref = mbgen.LambdifiedModel(res.baked, c.outputs, layout=c.layout)
    assert res.equations.method == "newton_euler" and res.baked.accelerations is None
    assert c.contact_jacobian(0, np.zeros(8), None, np.zeros(4)).shape == (11, 8)
    for x, r, p in states(c.n_x):
        for out in OUTPUTS:
            want = getattr(ref, out)(0, x, p, r)
            assert_close(getattr(c, out)(0, x, p, r), want, 1e-10)
            np.testing.assert_array_equal(getattr(py, out)(0, x, p, r), getattr(c, out)(0, x, p, r))
        assert_close(c.contact_jacobian(0, x, p, r)[:8], c.jacobian(0, x, p, r), 1e-14)


def test_kane_and_newton_euler_contact_rows_agree():
    """Kane's J and gamma come from the kinematic tree's atoms, Newton-Euler's (the compiled
    leg's) from the recursion's body kinematics: the two give the same motion and forces."""
    py = mbgen.python_model(rendered_leg(Method.KANE).rendered)
    c = compiled_leg().compiled
    for x, r, p in states(c.n_x, seed=1):
        for out in ("rhs", "constraint_forces", "contact_jacobian"):
            assert_close(getattr(py, out)(0, x, p, r), getattr(c, out)(0, x, p, r), 1e-10)


def test_the_jacobians_are_central_differences():
    c = compiled_leg().compiled
    h = 1e-6

    def both(y, p, r):
        return np.concatenate([c.rhs(0, y, p, r), c.constraint_forces(0, y, p, r)])

    for x, r, p in states(c.n_x, k=2, seed=2):
        fd = np.column_stack([(both(x + h * e, p, r) - both(x - h * e, p, r)) / (2 * h)
                              for e in np.eye(c.n_x)])
        assert_close(c.contact_jacobian(0, x, p, r), fd, 1e-6)


def test_baumgarte_holds_the_foot_to_its_anchor():
    """J u' + gamma = -kd v - kp (r - r0): the foot's acceleration along the motion (velocity
    differentiated numerically) is -kd v - kp (r - r0)."""
    c = compiled_leg().compiled
    kp, kd, r0 = 7.0, 3.0, np.array([0.1, 0.2, 0.3])
    p = np.array([9.81, kp, kd, *r0])
    for x, r, _ in states(c.n_x, seed=4):
        f = c.rhs(0, x, p, r)
        h = 1e-6
        acc = (c.velocities(0, x + h * f, p, r) - c.velocities(0, x - h * f, p, r))[-1] / (2 * h)
        want = -kd * c.velocities(0, x, p, r)[-1] - kp * (c.positions(0, x, p, r)[-1] - r0)
        assert_close(acc, want, 1e-6)


def test_a_leg_started_off_its_anchor_returns_to_it():
    """kp = 100, kd = 20 (critically damped at 10 rad/s): after 2 s the foot's distance from
    its anchor is (1 + 10 t) exp(-10 t) = 4e-8 of the start's."""
    from scipy.integrate import solve_ivp
    c = compiled_leg().compiled
    r0 = np.array([0.3, 0.1, -0.2])
    p = np.array([9.81, 100.0, 20.0, *r0])
    x0 = np.array([0.1, -0.4, 0.9, 0.2, 0.0, 0.0, 0.0, 0.0])
    sol = solve_ivp(lambda t, y: c.rhs(t, y, p, np.zeros(4)), (0, 2.0), x0, rtol=1e-10,
                    atol=1e-12)
    start = np.linalg.norm(c.positions(0, x0, p)[-1] - r0)
    assert start > 0.3 and np.linalg.norm(c.positions(0, sol.y[:, -1], p)[-1] - r0) < 1e-6 * start


def test_two_contacts_at_one_place_leave_the_forces_undetermined():
    res = mbgen.run(leg("leg2", extra_contact=True), ("rhs", "constraint_forces"), build=False)
    py = mbgen.python_model(res.rendered)
    ref = mbgen.LambdifiedModel(res.baked, py.outputs, layout=py.layout)
    x = random_states(8, 1, seed=5)[0]
    for model in (py, ref):
        with pytest.raises(SingularConstraintError, match="Delassus"):
            model.rhs(0, x, None, np.zeros(4))
    assert "CONTACT_SINGULAR 9" in res.rendered.header


def point(model, name):
    return next(p for p in model.points if p.name == name)


def test_what_is_refused_is_named():
    m = leg("leg_refused")
    with pytest.raises(ModelError, match="already has a contact"):
        m.contact(point(m, "S"), name="again")
    with pytest.raises(ModelError, match="already exists"):
        m.contact(point(m, "R"), name="toe")
    with pytest.raises(ModelError, match="anchor of contact"):
        m.contact(point(m, "R"), anchor=(1, 2))
    fixed = leg("leg_fixed")
    fixed.contact(fixed.origin, name="origin")
    with pytest.raises(ModelError, match="does not move"):
        mbgen.derive(fixed)
    both = leg("leg_both")
    q1 = both.coordinates_[0]
    both.holonomic([q1 - 0.1], [q1])
    with pytest.raises(ModelError, match="contacts .* and constraints"):
        mbgen.derive(both)
    with pytest.raises(ModelError, match="joint reactions"):
        mbgen.run(leg("leg_reactions"), ("rhs", "reactions"), build=False)
    pendulum = mbgen.Model("pend_nc")
    q, = pendulum.coordinates("q")
    pendulum.speeds("u")
    A = pendulum.rotate(pendulum.newtonian(), "A", 3, q)
    pendulum.particle("bob", pendulum.point("P", pendulum.origin, A.x), 1.0)
    with pytest.raises(ModelError, match="no contacts"):
        mbgen.run(pendulum, ("contact_jacobian",), build=False)


@pytest.mark.slow
def test_the_contact_code_compiles_strictly_as_c_and_as_cpp(tmp_path):
    """The contact routine and the functions that call it, with the integrators (Rosenbrock
    calls the Jacobian) and the step API: no warning under -pedantic -Wall -Wextra -Wshadow
    -Wconversion, in C99 and in C++."""
    import shutil
    import subprocess
    scene = mbgen.Scene("leg_strict", leg("leg_strict"), outputs=OUTPUTS + (
        "input_jacobian", "parameter_jacobian", "dopri5", "rosenbrock"))
    res = mbgen.run(scene, build=False, targets=mbgen.Targets(step=True),
                    method=Method.NEWTON_EULER)
    for name, text in res.rendered.files.items():
        (tmp_path / name).write_text(text)
    strict = ["-pedantic", "-Wall", "-Wextra", "-Werror", "-Wshadow", "-Wconversion",
              "-Wno-sign-conversion", "-c", f"{res.rendered.prefix}.c", "-o", "out.o"]
    for tool, flags in ((shutil.which("gcc"), ["-std=c99"]),
                        (shutil.which("g++"), ["-x", "c++", "-std=c++11"])):
        proc = subprocess.run([tool, *flags, *strict], cwd=tmp_path, capture_output=True,
                              text=True)
        assert proc.returncode == 0 and not proc.stderr, proc.stderr[-3000:]
