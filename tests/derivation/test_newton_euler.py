"""Newton–Euler: Kane's equations again, joint reactions against hand derivations, the recursion.

Seams checked here:

* Kane and Newton–Euler give the same ``M``, ``F`` and right-hand side on every
  built-in scene (numerically), and identical equations symbolically on the small ones;
* the articulated-body recursion gives the accelerations of ``M u' = F``, also with a force
  and a torque on a massless link (the generalized forces ``tau`` of such loads);
* joint reactions: a chain hanging at rest carries the weight below each joint; the
  pendulum on the rotating disc has the pivot force of a derivation by hand; a
  prescribed joint's motor torque equals sympy's KanesMethod with an auxiliary
  speed; every joint of a swinging 3-D chain carries what Newton's law asks of the
  subtree below it (Newton's third law at every joint);
* the recursion's operation count grows linearly with the number of bodies.
"""

from dataclasses import FrozenInstanceError
from functools import cache

import numpy as np
import pytest
import sympy as sm
from sympy.physics import mechanics as me

import mbgen
from checks import close, random_states
from mbgen import Model
from mbgen.codegen.optimize import Form
from mbgen.derivation import Method, derive
from mbgen.derivation.prepare import prepare
from mbgen.derivation.recursion import BodyInertia, BodyKinematics, NewtonEuler
from mbgen.errors import ModelError
from mbgen.model.scene import builtin_names
from mbgen.scenes import disc_pendulum
from models import ambiguous_slider, massless_link_scene

HEAVY = {"bicycle", "spatial_arm"}   # their own tests cover them; slow with every output
#: Kane == Newton-Euler on these in the slow run only (the default run's time): whipple's two
#: derivations compile in about 8 s; its equations meet the benchmark's published
#: eigenvalues in the default run (tests/scenes/test_constrained_scenes.py)
SLOW_PAIRS = {"whipple"}


@cache
def scene(name):
    return mbgen.load_scene(name)


def states(model, k=6, seed=1, scale=1.0):
    return random_states(model.n_x, k, seed, scale)


# ------------------------------------------------------------------ Kane == Newton-Euler
@pytest.mark.parametrize("name", [
    pytest.param(n, marks=pytest.mark.slow) if n in SLOW_PAIRS else n
    for n in builtin_names() if n not in HEAVY])
def test_newton_euler_and_kane_give_the_same_equations(name):
    scn = scene(name)
    outs = ("rhs", "mass_matrix", "forcing")
    kane = mbgen.compile(scn, outs, method="kane", name=f"{scn.name}_kane")
    ne = mbgen.compile(scn, outs, method="newton_euler", name=f"{scn.name}_ne")
    p = scn.p(kane.layout)
    assert kane.layout == ne.layout
    for x in states(kane):
        for out in outs:
            a, b = getattr(kane, out)(0.3, x, p), getattr(ne, out)(0.3, x, p)
            assert close(a, b), (out, x, a, b)


@pytest.mark.parametrize("name", ["disc_pendulum", "bead_wire", "paraboloid", "spherical_rod",
                                  "bent_pipe", "torque_free"])
def test_newton_euler_and_kane_are_identical_symbolically(name):
    model = scene(name).model
    k, n = derive(model, Method.KANE), derive(model, Method.NEWTON_EULER)
    M, F = n.program.inline([sm.Matrix(n.mass_matrix), sm.Matrix(n.forcing)])
    assert (sm.Matrix(k.mass_matrix) - M).applyfunc(sm.simplify).is_zero_matrix
    assert (sm.Matrix(k.forcing) - F).applyfunc(sm.simplify).is_zero_matrix


@pytest.mark.parametrize("name", ["spatial_arm", "disc_pendulum", "bead_wire", "torque_free",
                                  "spherical_rod", "n_link_cart", "car_trailer", "rolling_disc",
                                  "four_bar"])
def test_kinetic_energy_of_the_recursion_is_kanes(name):
    """Newton-Euler's T (spatial velocities of the outward pass against the spatial
    inertias, named per body) equals Kane's (atom velocities) at random numbers for every
    symbol: rheonomic joints (the spun wire, the driven disc), constraints, a free body."""
    model = scene(name).model
    k = derive(model, Method.KANE, energy=True)
    n = derive(model, Method.NEWTON_EULER, energy=True)
    T_ne, V_ne = n.program.inline([n.kinetic_energy, n.potential_energy])
    syms = sorted(sm.Matrix([k.kinetic_energy, T_ne]).free_symbols, key=str)
    rng = np.random.default_rng(3)
    for _ in range(4):
        values = dict(zip(syms, rng.uniform(-1.5, 1.5, len(syms))))
        a, b = (float(e.xreplace(values).evalf()) for e in (k.kinetic_energy, T_ne))
        assert abs(a - b) <= 1e-11 * max(1.0, abs(a)), (a, b)
    assert sm.simplify(k.potential_energy - V_ne) == 0


@pytest.mark.parametrize("name", ["spatial_arm", "disc_pendulum", "torque_free", "stiff_chain",
                                  "spherical_rod", "n_link_cart"])
def test_inverse_dynamics_residual_is_forcing_minus_mass_matrix_times_accelerations(name):
    """Equations.residual (what the Jacobians differentiate) is F - M a for any a: numbers
    for every symbol and for a, the program inlined."""
    from mbgen.symbolic.equations import acceleration_symbols

    eq = derive(scene(name).model, Method.NEWTON_EULER)
    n = eq.layout.n_u
    a = acceleration_symbols(n)
    M, F, R = (sm.Matrix(m) for m in eq.program.inline(
        [sm.Matrix(eq.mass_matrix), sm.Matrix(eq.forcing), sm.Matrix(eq.residual)]))
    rng = np.random.default_rng(7)
    symbols = sorted(eq.layout.symbols() | set(a), key=str)
    values = {s: rng.uniform(0.5, 1.5) for s in symbols}
    expect = np.array((F - M * sm.Matrix(a)).xreplace(values).evalf(), dtype=float)
    got = np.array(R.xreplace(values).evalf(), dtype=float)
    np.testing.assert_allclose(got, expect, rtol=1e-12, atol=1e-12 * np.abs(expect).max())


@pytest.mark.parametrize("name", ["disc_pendulum", "torque_free", "stiff_chain", "spherical_rod",
                                  "paraboloid", "bead_wire"])
def test_recursion_equals_mass_matrix_solve(name):
    """Both forms of every acceleration-dependent output, compiled, against each other."""
    scn = scene(name)
    outs = ("rhs", "jacobian", "reactions")
    rec = mbgen.run(scn, outs, method="newton_euler", form=Form.RECURSIVE,
                    name=f"{scn.name}_rec")
    sol = mbgen.run(scn, outs, method="newton_euler", form=Form.SOLVE, name=f"{scn.name}_sol")
    assert rec.kernel.form is Form.RECURSIVE and sol.kernel.form is Form.SOLVE
    rhs = rec.rendered.source.split(f"int {scn.name}_rec_rhs(")[1].split("\n}\n")[0]
    assert "_ldl" not in rhs and "_ldl" in sol.rendered.source   # the recursion solves nothing
    a, b = rec.compiled, sol.compiled
    py = mbgen.python_model(rec.rendered)
    p = scn.p(a.layout)
    for x in states(a):
        for out in outs:
            assert close(getattr(a, out)(0.2, x, p), getattr(b, out)(0.2, x, p), 1e-11), out
            assert close(getattr(py, out)(0.2, x, p), getattr(a, out)(0.2, x, p), 1e-13), out


def test_recursion_keeps_the_loads_on_massless_parts():
    """Kane, the mass-matrix solve and the recursion give the same accelerations when a force
    and a torque act on a massless link (once the recursion dropped them: 17.04 vs -0.11)."""
    scn = massless_link_scene()
    kane = mbgen.compile(scn, ("rhs",), method="kane", name="massless_link_kane")
    rec = mbgen.run(scn, ("rhs",), method="newton_euler", form=Form.RECURSIVE,
                    name="massless_link_rec")
    assert rec.kernel.form is Form.RECURSIVE
    py = mbgen.python_model(rec.rendered)
    without = np.array(kane.default_parameters)
    without[[kane.parameter_names.index("f"), kane.parameter_names.index("T")]] = 0.0
    for x in states(kane):
        want = kane.rhs(0.0, x)
        assert not close(want, kane.rhs(0.0, x, without), 1e-3)   # the loads matter
        assert close(rec.compiled.rhs(0.0, x), want, 1e-11), (x, want)
        assert close(py.rhs(0.0, x), want, 1e-11)


def test_recursion_checks_its_pivots():
    """A negative mass is a named error from the recursion, in C and in Python."""
    scn = scene("disc_pendulum")
    res = mbgen.run(scn, ("rhs",), method="newton_euler", form=Form.RECURSIVE,
                    name="disc_pendulum_pivot")
    x = np.array([0.1, 0.5, 0.3, 0.2])
    bad = np.array([1.0, 4.0, 10.0, -1.0])     # m < 0
    for model in (res.compiled, mbgen.python_model(res.rendered)):
        with pytest.raises(mbgen.SingularMassMatrixError):
            model.rhs(0.0, x, bad)


def test_a_zero_pivot_no_output_reads_is_still_checked():
    """A massless particle fixed at mass 0 with no force on it: u' = 0/0, not 0.  Baking the
    mass leaves a pivot of 0 whose reciprocal multiplies a zero right-hand side, so nothing
    reads it; the recursion's pivots are checked all the same (rhs, reactions, Jacobian)."""
    m = Model("massless_zero")
    q, = m.coordinates("q")
    m.speeds("u")
    mass, = m.constants("mass")
    N = m.newtonian()
    m.particle("b", m.point("P", m.origin, q * N.x), mass)
    res = mbgen.run(m, ("rhs", "reactions", "jacobian"), method="newton_euler",
                    form=Form.RECURSIVE, fixed={"mass": 0.0})
    x = np.array([0.1, 0.2])
    for model in (res.compiled, mbgen.python_model(res.rendered)):
        for output in (model.rhs, model.reactions, model.jacobian):
            with pytest.raises(mbgen.SingularMassMatrixError):
                output(0.0, x)


# ------------------------------------------------------------------ joints
def test_joints_are_inferred_from_the_frame_and_point_tree():
    eq = derive(scene("n_link_cart").model, Method.NEWTON_EULER, reactions=True)
    J = eq.reactions
    n = len(J.names) - 1
    assert J.parents[0] is None and J.points[0] == "P0"            # the cart slides on ground
    assert J.parents[1:] == J.children[:-1]                        # each link hangs from the last
    assert J.points[1:] == tuple(f"P{i}" for i in range(n))         # at the previous bob
    dp = derive(scene("disc_pendulum").model, Method.NEWTON_EULER, reactions=True).reactions
    assert dp.parents == (None,) and dp.points == ("E",) and dp.frames == ("B",)


def test_per_body_quantities_are_frozen_records_by_name():
    """Pinocchio's shape: each pass's per-body quantities are named fields, not dict keys."""
    ne = NewtonEuler(prepare(scene("spatial_arm").model))
    for b in ne.bodies:
        kin, inertia = ne.kin[b], ne.inertia[b]
        assert isinstance(kin, BodyKinematics) and isinstance(inertia, BodyInertia)
        assert list(kin.S) == [b.index] and len(inertia.spatial) == 6
        with pytest.raises(FrozenInstanceError):
            kin.S = {}


def test_stated_joint_names_frame_and_errors():
    m = disc_pendulum.build_model()
    m.joint("bob", frame=m.N, name="pivot")
    J = derive(m, Method.NEWTON_EULER, reactions=True).reactions
    assert J.names == ("pivot",) and J.frames == ("N",)
    with pytest.raises(ModelError, match="not a particle or rigid body"):
        m.joint("nobody")
    with pytest.raises(ModelError, match="already stated"):
        m.joint("bob")
    with pytest.raises(ModelError, match="itself"):
        disc_pendulum.build_model().joint("bob", parent="bob")
    m2 = disc_pendulum.build_model()
    m2.joint("bob", point=m2.origin)      # O is not fixed in the pendulum
    with pytest.raises(ModelError, match="not fixed in"):
        derive(m2, Method.NEWTON_EULER)


def test_ambiguous_joint_asks_to_state_it():
    """Two bodies hold the same point with unrelated frames: the third cannot choose."""
    m = Model("ambiguous")
    q1, q2, q3 = m.coordinates("q1 q2 q3")
    m.speeds("u1 u2 u3")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)
    B = m.rotate(N, "B", 3, q2)
    C = m.rotate(N, "C", 3, q3)
    P = m.point("P", m.origin, N.x)
    m.body("a", A, 1, (1, 1, 1), m.point("Ga", P, A.x))
    m.body("b", B, 1, (1, 1, 1), m.point("Gb", P, B.x))
    # a and b hang from the ground at P; c's centre sits at P itself
    m.body("c", C, 1, (1, 1, 1), m.point("Gc", P, C.x))
    eq = derive(m, Method.NEWTON_EULER, reactions=True)
    assert eq.reactions.parents == (None, None, None)
    # a slider whose rail starts at P, which both a and b (and the ground) hold
    m2 = ambiguous_slider("ambiguous2")
    with pytest.raises(ModelError, match="state it with"):
        derive(m2, Method.NEWTON_EULER, reactions=True)
    m2.joint("c", parent=m2.N)
    assert derive(m2, Method.NEWTON_EULER, reactions=True).reactions.parents[-1] is None


# ------------------------------------------------------------------ reactions
def hanging_chain(n=3, method=Method.NEWTON_EULER):
    """``n`` rigid links on relative revolute joints (about x then y), a tip mass, gravity -z."""
    m = Model(f"chain{n}")
    q = m.coordinates(" ".join(f"q{i}" for i in range(1, n + 1)))
    m.speeds(" ".join(f"u{i}" for i in range(1, n + 1)))
    g, = m.constants("g")
    N = m.newtonian()
    frame, joint = N, m.origin
    for i in range(1, n + 1):
        frame = m.rotate(frame, f"L{i}", 1 if i % 2 else 2, q[i - 1])
        centre = m.point(f"G{i}", joint, -0.25 * i * frame.z)
        m.body(f"link{i}", frame, 1.0 + i, (0.1, 0.2, 0.05, 0.01, 0.0, 0.02), centre)
        m.joint(f"link{i}", frame=N)
        joint = m.point(f"J{i}", joint, -0.5 * i * frame.z)
    m.particle("tip", joint, 0.7)
    m.gravity(-g * N.z)
    return mbgen.Scene(f"chain{n}", m, parameters={"g": 9.81}, method=method)


@pytest.mark.parametrize("method,form", [(Method.NEWTON_EULER, Form.RECURSIVE),
                                         (Method.NEWTON_EULER, Form.SOLVE),
                                         (Method.KANE, None)])
def test_hanging_chain_at_rest_carries_the_weight_below_each_joint(method, form):
    scn = hanging_chain(3, method)
    model = mbgen.compile(scn, ("rhs", "reactions"), form=form,
                          name=f"chain3_{method.value}_{form.value if form else 'kane'}")
    x = np.zeros(model.n_x)
    assert np.allclose(model.rhs(0.0, x), 0.0, atol=1e-14)
    R = model.reactions(0.0, x)
    masses = [2.0, 3.0, 4.0]
    below = [sum(masses[i:]) + 0.7 for i in range(3)]
    expected = np.array([[0, 0, 9.81 * w, 0, 0, 0] for w in below])
    np.testing.assert_allclose(R, expected, atol=1e-12)
    assert model.reaction_names == ("link1", "link2", "link3")
    assert model.reaction_frames == ("N", "N", "N")


def test_disc_pendulum_pivot_force_by_hand():
    r"""The bob: ``m a_P = R + m g``, so ``R = m (a_P - g)`` and, about the pivot ``E``,
    ``M_E = r_EP x R`` (the bob is a point); ``a_P`` from the notes' closed-form
    position, differentiated by hand (sympy), with the notes' state equations."""
    m = disc_pendulum.build_model()
    m.joint("bob", frame=m.N)
    scn = mbgen.Scene("dp_pivot", m, parameters={"s": 1.0, "l": 4.0, "g": 10.0, "m": 1.5},
                      method=Method.NEWTON_EULER)
    model = mbgen.compile(scn, ("rhs", "reactions"))
    t = sm.Symbol("t")
    q1, q2 = sm.Function("q1")(t), sm.Function("q2")(t)
    s, l, g, mass = 1.0, 4.0, 10.0, 1.5
    r = sm.Matrix([(s + l * sm.sin(q2)) * sm.cos(q1), (s + l * sm.sin(q2)) * sm.sin(q1),
                   -l * sm.cos(q2)])
    r_EP = sm.Matrix([l * sm.sin(q2) * sm.cos(q1), l * sm.sin(q2) * sm.sin(q1), -l * sm.cos(q2)])
    a = r.diff(t, 2)
    Q1, Q2, U1, U2, A1, A2 = sm.symbols("Q1 Q2 U1 U2 A1 A2")
    sub = {q1.diff(t, 2): A1, q2.diff(t, 2): A2, q1.diff(t): U1, q2.diff(t): U2}
    sub2 = {q1: Q1, q2: Q2}
    R = mass * (a.subs(sub).subs(sub2) + sm.Matrix([0, 0, g]))
    M = r_EP.subs(sub2).cross(R)
    f = sm.lambdify([Q1, Q2, U1, U2, A1, A2], list(R) + list(M))
    for x in states(model, seed=3):
        q1v, q2v, u1v, u2v = x
        a1 = -2 * l * np.cos(q2v) * u1v * u2v / (s + l * np.sin(q2v))
        a2 = np.cos(q2v) * u1v ** 2 * (s + l * np.sin(q2v)) / l - g * np.sin(q2v) / l
        np.testing.assert_allclose(model.rhs(0.0, x)[2:], [a1, a2], rtol=1e-12, atol=1e-12)
        expected = np.array(f(q1v, q2v, u1v, u2v, a1, a2), dtype=float)
        np.testing.assert_allclose(model.reactions(0.0, x)[0], expected, rtol=1e-11, atol=1e-11)


def prescribed_arm():
    """Two links in a vertical plane: q1 free, the elbow driven as theta2 = a sin(w t)."""
    m = Model("driven_arm")
    q1, = m.coordinates("q1")
    m.speeds("u1")
    l1, l2, m1, m2, I1, I2, g, amp, w = m.constants("l1 l2 m1 m2 I1 I2 g amp w")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)
    B = m.rotate(A, "B", 3, m.prescribed("theta2", amp * sm.sin(w * mbgen.t)))
    P1 = m.point("P1", m.origin, l1 * A.x)
    m.body("upper", A, m1, (0, 0, I1), m.point("G1", m.origin, l1 / 2 * A.x))
    m.body("lower", B, m2, (0, 0, I2), m.point("G2", P1, l2 / 2 * B.x))
    m.gravity(-g * N.y)
    values = dict(l1=1.0, l2=0.8, m1=2.0, m2=1.5, I1=0.3, I2=0.2, g=9.81, amp=0.7, w=2.0)
    return mbgen.Scene("driven_arm", m, parameters=values, method=Method.NEWTON_EULER)


def motor_torque_by_kanes_method(values):
    """The elbow torque from sympy's KanesMethod with an auxiliary speed for the elbow."""
    t = me.dynamicsymbols._t
    q1, u1, ua = me.dynamicsymbols("q1 u1 ua")
    T = sm.Symbol("T")
    v = {k: sm.Float(x) for k, x in values.items()}
    theta = v["amp"] * sm.sin(v["w"] * t)
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [q1, N.z])
    B = A.orientnew("B", "Axis", [theta, A.z])
    A.set_ang_vel(N, u1 * N.z)
    B.set_ang_vel(A, (theta.diff(t) + ua) * A.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P1 = O.locatenew("P1", v["l1"] * A.x)
    P1.v2pt_theory(O, N, A)
    G1 = O.locatenew("G1", v["l1"] / 2 * A.x)
    G1.v2pt_theory(O, N, A)
    G2 = P1.locatenew("G2", v["l2"] / 2 * B.x)
    G2.v2pt_theory(P1, N, B)
    upper = me.RigidBody("upper", G1, A, v["m1"], (me.inertia(A, 0, 0, v["I1"]), G1))
    lower = me.RigidBody("lower", G2, B, v["m2"], (me.inertia(B, 0, 0, v["I2"]), G2))
    loads = [(G1, -v["m1"] * v["g"] * N.y), (G2, -v["m2"] * v["g"] * N.y),
             (B, T * A.z), (A, -T * A.z)]
    kane = me.KanesMethod(N, [q1], [u1], kd_eqs=[q1.diff(t) - u1], u_auxiliary=[ua])
    fr, frstar = kane.kanes_equations([upper, lower], loads)
    eqs = (fr + frstar).subs(ua, 0)
    acc = sm.solve(eqs[0], u1.diff(t))[0]
    torque = sm.solve(eqs[1].subs(u1.diff(t), acc), T)[0]
    Q, U, tt = sm.symbols("Q U tt")
    return sm.lambdify([tt, Q, U], torque.subs({q1: Q, u1: U}).subs(t, tt)), \
        sm.lambdify([tt, Q, U], acc.subs({q1: Q, u1: U}).subs(t, tt))


def test_prescribed_joint_reaction_is_the_motor_torque():
    scn = prescribed_arm()
    model = mbgen.compile(scn, ("rhs", "reactions"))
    torque, acc = motor_torque_by_kanes_method(dict(scn.parameters))
    assert model.reaction_names == ("upper", "lower")
    for k, x in enumerate(states(model, seed=5)):
        tv = 0.3 * k
        np.testing.assert_allclose(model.rhs(tv, x)[1], acc(tv, *x), rtol=1e-11, atol=1e-12)
        R = model.reactions(tv, x)
        assert R[1, 5] == pytest.approx(float(torque(tv, *x)), rel=1e-10, abs=1e-12)
        np.testing.assert_allclose(R[1, [2, 3, 4]], 0.0, atol=1e-12)   # planar: no z force,
        # no moment about in-plane axes


def spatial_particle_chain():
    """Three bobs on massless rods, each joint turning about two axes (a 3-D swing)."""
    m = Model("swing3")
    q = m.coordinates("a1 b1 a2 b2 a3 b3")
    m.speeds("ua1 ub1 ua2 ub2 ua3 ub3")
    g, = m.constants("g")
    N = m.newtonian()
    frame, joint = N, m.origin
    for i in range(3):
        inner = m.rotate(frame, f"I{i}", 1, q[2 * i])
        frame = m.rotate(inner, f"L{i}", 2, q[2 * i + 1])
        bob = m.point(f"P{i}", joint, -(1.0 + 0.3 * i) * frame.z)
        m.particle(f"bob{i}", bob, 1.0 + 0.5 * i)
        m.joint(f"bob{i}", frame=N)
        joint = bob
    m.gravity(-g * N.z)
    return mbgen.Scene("swing3", m, parameters={"g": 9.81}, points=("P0", "P1", "P2"),
                       method=Method.NEWTON_EULER)


def test_every_joint_obeys_newtons_law_for_the_subtree_below():
    """Third law at every joint: the force on the subtree below joint j is its
    ``sum m (a - g)``, the moment about the joint its ``sum r x m (a - g)``; the bobs'
    accelerations come from their velocities, differentiated along the motion."""
    scn = spatial_particle_chain()
    model = mbgen.compile(scn, ("rhs", "reactions", "positions", "velocities"))
    masses, g = np.array([1.0, 1.5, 2.0]), np.array([0.0, 0.0, -9.81])
    for x in states(model, k=4, seed=7, scale=0.8):
        f = model.rhs(0.0, x)
        h = 1e-6
        acc = (model.velocities(0.0, x + h * f) - model.velocities(0.0, x - h * f)) / (2 * h)
        pos = model.positions(0.0, x)
        R = model.reactions(0.0, x)
        joints = np.vstack([np.zeros(3), pos[:-1]])
        for j in range(3):
            net = masses[j:, None] * (acc[j:] - g)
            np.testing.assert_allclose(R[j, :3], net.sum(axis=0), rtol=1e-7, atol=1e-7)
            moment = np.cross(pos[j:] - joints[j], net).sum(axis=0)
            np.testing.assert_allclose(R[j, 3:], moment, rtol=1e-7, atol=1e-7)


# ------------------------------------------------------------------ scaling
def relative_chain(n):
    """A spatial chain of rigid links on relative revolute joints (z and y alternating)."""
    m = Model(f"rel{n}")
    q = m.coordinates(" ".join(f"q{i}" for i in range(n)))
    m.speeds(" ".join(f"u{i}" for i in range(n)))
    g, = m.constants("g")
    N = m.newtonian()
    frame, joint = N, m.origin
    for i in range(n):
        frame = m.rotate(frame, f"L{i}", 3 if i % 2 == 0 else 2, q[i])
        m.body(f"l{i}", frame, 1.0 + 0.1 * i, (0.01, 0.05, 0.06, 0.001, 0.002, 0.003),
               m.point(f"G{i}", joint, 0.25 * frame.x))
        joint = m.point(f"J{i}", joint, 0.5 * frame.x)
    m.gravity(-g * N.z)
    return mbgen.Scene(f"rel{n}", m, parameters={"g": 9.81}, method=Method.NEWTON_EULER)


def test_recursion_grows_linearly_and_wins_on_long_chains():
    ops = {}
    for n in (4, 8, 12):
        res = mbgen.run(relative_chain(n), ("rhs",), build=False, form=Form.RECURSIVE)
        ops[n] = res.kernel.ops_after
    first, second = ops[8] - ops[4], ops[12] - ops[8]
    assert abs(second - first) <= 0.05 * first, ops          # the same cost per added body
    assert second / 4 <= 400                                 # operations per body
    res = mbgen.run(relative_chain(12), ("rhs",), build=False)
    costs = dict(res.kernel.form_costs)
    assert res.kernel.form is Form.RECURSIVE and costs[Form.RECURSIVE] < costs[Form.SOLVE]


def slider_on_a_turning_tube():
    """A massive tube turning freely about the vertical, a ball sliding inside it on a spring:
    the joint of the ball slides along a moving body (Coriolis and centripetal terms)."""
    m = Model("tube_slider")
    q1, q2 = m.coordinates("q1 q2")
    m.speeds("u1 u2")
    k, = m.constants("k")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)
    m.body("tube", A, 2.0, (0.4, 0.5, 0.6, 0.05, 0.0, 0.0), m.point("G", m.origin, 0.3 * A.x))
    ball = m.point("B", m.origin, q2 * A.x)
    m.particle("ball", ball, 0.5)
    m.spring("s", ball, m.origin, k, natural_length=0.5)
    m.joint("ball", frame=A)
    return mbgen.Scene("tube_slider", m, parameters={"k": 20.0}, method=Method.NEWTON_EULER)


@pytest.mark.parametrize("form", [Form.RECURSIVE, Form.SOLVE])
def test_slider_on_a_turning_tube(form):
    scn = slider_on_a_turning_tube()
    ne = mbgen.compile(scn, ("rhs", "reactions"), form=form, name=f"tube_{form.value}")
    kane = mbgen.compile(scn, ("rhs",), method="kane", name="tube_kane")
    for x in states(ne, seed=11):
        assert close(ne.rhs(0.0, x), kane.rhs(0.0, x))
        R = ne.reactions(0.0, x)
        # the tube pushes the ball across the tube only (no force along it, the spring is
        # applied separately) and exerts no moment on a point mass about its own centre
        assert abs(R[1, 0]) <= 1e-12 and np.allclose(R[1, 3:], 0.0, atol=1e-12)
        # across the tube: m (2 w v + w' r) with v = q2', w = u1 (Coriolis and Euler terms)
        q2, u1, u2 = x[1], x[2], x[3]
        u1dot = ne.rhs(0.0, x)[2]
        assert R[1, 1] == pytest.approx(0.5 * (2 * u1 * u2 + u1dot * q2), rel=1e-10, abs=1e-12)
