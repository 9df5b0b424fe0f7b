"""Physics of the built-in scenes: closed forms, the lecture notes' equations,
conservation laws, sympy's KanesMethod, and agreement of the three backends."""

from functools import cache

import numpy as np
import pytest
import sympy as sm
from scipy.integrate import solve_ivp
from sympy.physics import mechanics as me
from sympy.physics.mechanics.models import n_link_pendulum_on_cart

import mbgen
from heavy import scene_params
from mbgen.model.scene import builtin_names
from mbgen.scenes import bent_pipe, n_link_cart, torque_free
from mbgen.symbolic.availability import applicable

TIGHT = dict(method="DOP853", rtol=1e-11, atol=1e-11)


@cache
def scene(name):
    return mbgen.load_scene(name)


@cache
def pipeline(name):
    """Equations, rendered code and compiled C of scene ``name`` with every output."""
    equations = mbgen.equations_of(scene(name))
    return mbgen.run(scene(name), outputs=applicable(equations))


def symbols_of(equations):
    """Every symbol of ``equations`` by name."""
    return {str(s): s for s in equations.layout.symbols()}


def simulate(model, scn, t_eval=None, **tolerances):
    """Integrate ``model`` from the scene's initial state over its time span."""
    layout = model.layout
    sol = solve_ivp(model.bind(scn.p(layout)), scn.t_span, scn.x0(layout), t_eval=t_eval,
                    **(tolerances or TIGHT))
    assert sol.success, sol.message
    return sol


# ------------------------------------------------------------------ bead on a spinning wire
def test_bead_wire_matches_closed_form():
    scn = scene("bead_wire")
    model = mbgen.compile(scn)
    t = np.linspace(*scn.t_span, 61)
    sol = simulate(model, scn, t_eval=t, method="DOP853", rtol=1e-10, atol=1e-12)
    exact = scn.closed_form(t, scn.x0(model.layout), scn.p(model.layout))
    assert exact.shape == (len(t), 2)
    error = np.abs(sol.y.T - exact) / np.maximum(np.abs(exact), 1.0)
    assert error.max() < 1e-7


def test_bead_wire_jacobi_integral_but_not_energy_is_conserved():
    """The motor does work: T changes, but T2 - T0 = m (rho'^2 - omega^2 rho^2) / 2 does not."""
    scn = scene("bead_wire")
    model = mbgen.compile(scn, outputs={"rhs", "energy"})
    omega, = scn.p(model.layout)   # the bead's mass is baked into the code
    mass = scn.fixed["m"]
    sol = simulate(model, scn)
    T = np.array([model.energy(0.0, x)[0] for x in sol.y.T])
    rho, u = sol.y
    np.testing.assert_allclose(T, mass * (u**2 + (omega * rho)**2) / 2, rtol=1e-12)
    jacobi = mass * (u**2 - (omega * rho)**2) / 2
    assert np.ptp(jacobi) < 1e-8 * np.abs(T).max()
    assert np.ptp(T) > 0.5 * np.abs(T).max()


# -------------------------------------------------------- pendulum on a rotating disc (notes)
def notes_disc_pendulum(t, x):
    """The notes' state equations with s = 1, l = 4, g = 10."""
    q1, q2, u1, u2 = x
    return np.array([u1, u2, -8 * np.cos(q2) * u2 * u1 / (1 + 4 * np.sin(q2)),
                     np.cos(q2) * u1**2 / 4 + u1**2 * np.sin(2 * q2) / 2 - 5 * np.sin(q2) / 2])


def test_disc_pendulum_equations_equal_the_notes_symbolically():
    eq = mbgen.equations_of(scene("disc_pendulum"))
    S = symbols_of(eq)
    s, l, g, q2, u1, u2 = (S[n] for n in ("s", "l", "g", "q2", "u1", "u2"))
    notes = sm.Matrix([-2 * l * sm.cos(q2) * u1 * u2 / (s + l * sm.sin(q2)),
                       sm.cos(q2) * u1**2 * (s + l * sm.sin(q2)) / l - g * sm.sin(q2) / l])
    udot = sm.simplify(eq.mass_matrix.LUsolve(eq.forcing))
    assert sm.simplify(udot - notes) == sm.zeros(2, 1)
    assert eq.kinematics == sm.Matrix([u1, u2])


def test_disc_pendulum_rhs_matches_the_notes_numerically():
    scn = scene("disc_pendulum")
    model = mbgen.compile(scn)
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = np.concatenate([rng.uniform(-3, 3, 1), rng.uniform(0.0, 1.3, 1), rng.uniform(-2, 2, 2)])
        np.testing.assert_allclose(model.rhs(0.0, x), notes_disc_pendulum(0.0, x),
                                   rtol=1e-12, atol=1e-12)


def test_disc_pendulum_trajectory_matches_the_notes():
    scn = scene("disc_pendulum")
    model = mbgen.compile(scn)
    x0 = scn.x0(model.layout)
    assert x0.tolist() == [0.0, 1.0, 0.5, 0.0]
    ours = simulate(model, scn, method="DOP853", rtol=1e-10, atol=1e-10)
    notes = solve_ivp(notes_disc_pendulum, scn.t_span, x0, method="DOP853", rtol=1e-10,
                      atol=1e-10)
    assert ours.t[-1] == notes.t[-1] == 20.0
    np.testing.assert_allclose(ours.y[:, -1], notes.y[:, -1], rtol=1e-7, atol=1e-7)


# ------------------------------------------------------------------------ conservation laws
CONSERVATIVE = [n for n in builtin_names() if scene(n).conserves_energy]


def test_conservative_scenes_include_the_required_ones():
    assert {"paraboloid", "torque_free", "spherical_rod", "bent_pipe"} <= set(CONSERVATIVE)
    assert "bead_wire" not in CONSERVATIVE


@pytest.mark.parametrize("name", scene_params(CONSERVATIVE))
def test_energy_is_conserved(name):
    scn = scene(name)
    model = mbgen.compile(scn, outputs={"rhs", "energy"})
    sol = simulate(model, scn)
    TV = np.array([model.energy(t, x) for t, x in zip(sol.t, sol.y.T)])
    E = TV.sum(axis=1)
    assert np.abs(E - E[0]).max() < 1e-8 * np.abs(TV).sum(axis=1).max()


def test_torque_free_angular_momentum_is_conserved():
    scn = scene("torque_free")
    mdl = scn.model
    model = mbgen.compile(scn)
    body, = mdl.bodies
    plain = {f: sm.Symbol(str(f.func)) for f in mdl.coordinates_ + mdl.speeds_}
    u = sm.Matrix([plain[s] for s in mdl.speeds_])
    H = (mdl.N.dcm(body.frame) * body.inertia * u).xreplace(plain)
    layout = model.layout
    H_of = sm.lambdify([layout.states, layout.parameters], H, modules="numpy")
    p = scn.p(layout)
    sol = simulate(model, scn)
    Hs = np.array([np.ravel(H_of(x, p)) for x in sol.y.T])
    assert np.abs(Hs - Hs[0]).max() < 1e-8 * np.linalg.norm(Hs[0])
    assert np.ptp(sol.y[3:], axis=1).max() > 0.1  # the body rates do change: it wobbles


# -------------------------------------------------------------- sympy.physics.mechanics.KanesMethod
def kanes_numeric(kane, equations):
    """``(M, F)`` of a sympy ``KanesMethod`` as functions of mbgen's ``(x, p, r)``, by symbol
    name."""
    exprs = [kane.mass_matrix, kane.forcing]
    funcs = me.find_dynamicsymbols(sm.Matrix.hstack(*exprs))
    plain = {f: sm.Symbol(str(f.func)) for f in funcs}
    L = equations.layout
    args = [L.states, L.parameters, L.inputs]
    return [sm.lambdify(args, e.xreplace(plain), modules="numpy") for e in exprs]


def assert_same_equations(kane, equations, seed, n_states=4):
    M_ref, F_ref = kanes_numeric(kane, equations)
    ours = mbgen.LambdifiedModel(equations)
    L = equations.layout
    rng = np.random.default_rng(seed)
    for _ in range(n_states):
        x, p, r = rng.uniform(-1, 1, L.n_x), rng.uniform(0.5, 2, L.n_p), rng.uniform(-1, 1, L.n_r)
        np.testing.assert_allclose(ours.mass_matrix(0.0, x, p, r), M_ref(x, p, r),
                                   rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(ours.forcing(0.0, x, p, r), np.ravel(F_ref(x, p, r)),
                                   rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_n_link_cart_matches_sympy_kanes_method(n):
    equations = mbgen.equations_of(n_link_cart.build_model(n))
    assert equations.layout.input_names == ("F",)
    assert_same_equations(n_link_pendulum_on_cart(n, cart_force=True), equations, seed=n)


def test_torque_free_matches_sympy_kanes_method():
    """Body-fixed 1-2-3 angles, speeds = body rates, a general inertia dyad."""
    q = me.dynamicsymbols("q1:4")
    u = me.dynamicsymbols("u1:4")
    inertia = sm.symbols("I11 I22 I33 I12 I23 I31")
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Body", q, "123")
    rates = u[0] * B.x + u[1] * B.y + u[2] * B.z
    kd = [(B.ang_vel_in(N) - rates).dot(b) for b in (B.x, B.y, B.z)]
    B.set_ang_vel(N, rates)
    O = me.Point("O")
    O.set_vel(N, 0)
    body = me.RigidBody("body", O, B, 1, (me.inertia(B, *inertia), O))
    kane = me.KanesMethod(N, q, u, kd_eqs=kd)
    kane.kanes_equations([body], [])
    assert_same_equations(kane, mbgen.equations_of(torque_free.build_model()), seed=11)


def test_bent_pipe_matches_sympy_kanes_method():
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    phi, h, m, J, g = sm.symbols("phi h m J g")
    A = me.ReferenceFrame("A")
    F1 = A.orientnew("F1", "Axis", [q1, A.z])
    B = F1.orientnew("B", "Axis", [sm.pi / 2 - phi, F1.y])
    O = me.Point("O")
    O.set_vel(A, 0)
    P = O.locatenew("P", h * A.z + q2 * B.x)
    P.set_vel(A, P.pos_from(O).dt(A))
    ball = me.Particle("ball", P, m)
    pipe = me.RigidBody("pipe", O, F1, 0, (me.inertia(F1, 0, 0, J), O))
    kane = me.KanesMethod(A, [q1, q2], [u1, u2], kd_eqs=[q1.diff() - u1, q2.diff() - u2])
    kane.kanes_equations([ball, pipe], [(P, -m * g * A.z)])
    assert_same_equations(kane, mbgen.equations_of(bent_pipe.build_model()), seed=7)


# -------------------------------------------------------------- C, generated Python, lambdify
def random_point(scn, layout, rng):
    """A state near the scene's start (away from singular configurations), and p, r near
    defaults."""
    x = scn.x0(layout) + rng.uniform(-0.2, 0.2, layout.n_x)
    p = scn.p(layout) * rng.uniform(0.9, 1.1, layout.n_p)
    return rng.uniform(0, 1), x, p, rng.uniform(-1, 1, layout.n_r)


@pytest.mark.parametrize("name", scene_params(heavy=True))
def test_backends_agree(name):
    res = pipeline(name)
    outputs = applicable(res.baked)
    backends = [res.compiled, mbgen.python_model(res.rendered)]
    reference = mbgen.LambdifiedModel(res.baked, outputs, layout=res.layout)
    rng = np.random.default_rng(2024)
    for _ in range(5):
        t, x, p, r = random_point(scene(name), reference.layout, rng)
        for output in outputs:
            want = getattr(reference, output.value)(t, x, p, r)
            for model in backends:
                got = getattr(model, output.value)(t, x, p, r)
                assert got.shape == want.shape
                scale = max(np.abs(want).max(), 1e-300)
                assert np.abs(got - want).max() <= 1e-9 * scale, (model.backend, output, x)
