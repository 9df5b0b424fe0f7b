"""from_sympy: sympy.physics.mechanics equations into mbgen Equations."""

from functools import cache

import numpy as np
import pytest
import sympy as sm
from sympy.physics import mechanics as me
from sympy.physics.mechanics.models import n_link_pendulum_on_cart

import mbgen
from checks import assert_close
from mbgen import LambdifiedModel, ModelError, Output
from mbgen.derivation.from_sympy import from_sympy
from mbgen.scenes import n_link_cart

OUTPUTS = (Output.RHS, Output.MASS_MATRIX, Output.FORCING)


@cache
def n_link(n):
    return n_link_pendulum_on_cart(n, cart_force=True)


def cart_pendulum(lagrange=False):
    """Cart on a rail (PrismaticJoint) with a rigid pendulum (PinJoint), pushed by F(t)."""
    g, l = sm.symbols("g l")
    F = me.dynamicsymbols("F")
    q = me.dynamicsymbols("q1:3")
    speeds = [qi.diff() if lagrange else None for qi in q]
    rail, cart, link = me.RigidBody("rail"), me.RigidBody("cart"), me.RigidBody("link")
    system = me.System.from_newtonian(rail)
    system.add_joints(
        me.PrismaticJoint("slider", rail, cart, coordinates=q[0], speeds=speeds[0],
                          joint_axis=rail.x),
        me.PinJoint("pin", cart, link, coordinates=q[1], speeds=speeds[1], joint_axis=cart.z,
                    child_point=-l * link.y))
    system.apply_uniform_gravity(-g * system.y)
    system.add_loads((cart.masscenter, F * rail.x))
    system.validate_system(me.LagrangesMethod if lagrange else me.KanesMethod)
    system.form_eoms(me.LagrangesMethod if lagrange else me.KanesMethod)
    return system


def samples(layout, count=5, seed=0):
    """Seeded random (t, x, p, r): parameters in [0.5, 2] so M stays positive definite."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        yield (rng.uniform(0, 1), rng.uniform(-1, 1, layout.n_x),
               rng.uniform(0.5, 2.0, layout.n_p), rng.uniform(-1, 1, layout.n_r))


def sympy_values(obj, eq):
    """sympy's own M and F lambdified in its own (time-dependent) symbols, in ``eq``'s order."""
    inputs = [me.dynamicsymbols(n) for n in eq.layout.input_names]
    args = [eq.layout.time, obj.q[:] + obj.u[:], list(eq.layout.parameters), inputs]
    return (sm.lambdify(args, obj.mass_matrix, modules="numpy"),
            sm.lambdify(args, obj.forcing, modules="numpy"))


def check_against_sympy(obj, eq):
    """Compiled C, lambdified reference and sympy's own M, F agree at random points."""
    compiled = mbgen.compile(eq, OUTPUTS)
    reference = LambdifiedModel(eq)
    M_sympy, F_sympy = sympy_values(obj, eq)
    for t, x, p, r in samples(eq.layout):
        assert_close(compiled.rhs(t, x, p, r), reference.rhs(t, x, p, r))
        M = reference.mass_matrix(t, x, p, r)
        assert_close(M, M_sympy(t, x, p, r))
        assert_close(reference.forcing(t, x, p, r), np.ravel(F_sympy(t, x, p, r)))
        assert_close(compiled.mass_matrix(t, x, p, r), M)
        assert_close(compiled.forcing(t, x, p, r), reference.forcing(t, x, p, r))


@pytest.mark.parametrize("n", [1, 2, 3])
def test_n_link_pendulum_on_cart(n):
    km = n_link(n)
    eq = from_sympy(km)
    L = eq.layout
    assert L.input_names == ("F",)
    assert L.state_names == tuple(str(s.func) for s in km.q[:] + km.u[:])
    masses, lengths = [f"m{i}" for i in range(n + 1)], [f"l{i}" for i in range(n)]
    assert L.parameter_names == tuple(sorted(["g", *masses, *lengths]))
    assert (eq.name, eq.source, eq.method) == ("sympy_model", "sympy KanesMethod",
                                               "sympy.KanesMethod")
    check_against_sympy(km, eq)


def test_a_scene_names_imported_equations_after_itself(tmp_path):
    """Every imported model generated ``sympy_model.h`` with ``sympy_model_rhs``: two of them
    could not link into one program, and the files did not say which model they held."""
    cart = mbgen.Scene("cart", from_sympy(n_link(1)), parameters=dict.fromkeys(
        ["g", "l0", "m0", "m1"], 1.0))
    assert cart.prefix == "cart"
    files = mbgen.pipeline.run(cart, build=False).rendered.files
    assert sorted(files) == ["cart.c", "cart.h", "cart.py"] and "int cart_rhs(" in files["cart.h"]
    named = mbgen.Scene("cart", from_sympy(n_link(1), name="my_cart"),
                        parameters=cart.parameters)
    assert named.prefix is None                 # a name given to from_sympy is kept
    assert mbgen.pipeline.run(named, build=False).rendered.prefix == "my_cart"
    chosen = mbgen.Scene("cart", from_sympy(n_link(1)), parameters=cart.parameters,
                         prefix="cart_fast")
    assert mbgen.pipeline.run(chosen, build=False).rendered.prefix == "cart_fast"


def test_natural_and_explicit_parameter_order():
    natural = ("g", *(f"l{i}" for i in range(10)), *(f"m{i}" for i in range(11)))
    assert from_sympy(n_link(10)).layout.parameter_names == natural  # m2 < m10
    order = ["g", *(f"m{i}" for i in range(11)), *(f"l{i}" for i in range(10))]
    assert from_sympy(n_link(10), parameters=order).layout.parameter_names == tuple(order)
    with pytest.raises(ModelError, match=r"not parameters of the equations: \['k'\]"):
        from_sympy(n_link(10), parameters=[*order, "k"])
    with pytest.raises(ModelError, match=r"missing: \['g'\]"):
        from_sympy(n_link(10), parameters=order[1:])


def test_system_kane():
    system = cart_pendulum()
    eq = from_sympy(system, name="cart_pendulum")
    L = eq.layout
    assert L.state_names == ("q1", "q2", "u_slider", "u_pin")
    assert L.input_names == ("F",)
    assert L.parameter_names == ("cart_mass", "g", "l", "link_izz", "link_mass")
    assert (eq.source, eq.method) == ("sympy System (KanesMethod)", "sympy.KanesMethod")
    check_against_sympy(system, eq)


def test_system_lagrange_matches_kane():
    system = cart_pendulum(lagrange=True)
    eq = from_sympy(system)
    assert eq.layout.state_names == ("q1", "q2", "q1_dot", "q2_dot")
    assert eq.method == "sympy.LagrangesMethod"
    check_against_sympy(system, eq)
    kane, lagrange = LambdifiedModel(from_sympy(cart_pendulum())), LambdifiedModel(eq)
    for t, x, p, r in samples(eq.layout):  # same parameter order; u = q' in both
        assert_close(lagrange.rhs(t, x, p, r), kane.rhs(t, x, p, r))


@pytest.mark.parametrize("n", [1, 2, 3])
def test_matches_mbgen_derivation(n):
    ours = mbgen.derive(n_link_cart.build_model(n))
    theirs = from_sympy(n_link(n))
    assert set(ours.layout.parameter_names) == set(theirs.layout.parameter_names)
    assert ours.layout.state_names == theirs.layout.state_names
    a, b = LambdifiedModel(ours), LambdifiedModel(theirs)
    for t, x, p, r in samples(theirs.layout):
        p_ours = dict(zip(theirs.layout.parameter_names, p))
        p_ours = [p_ours[name] for name in ours.layout.parameter_names]
        assert_close(a.mass_matrix(t, x, p_ours, r), b.mass_matrix(t, x, p, r))
        assert_close(a.forcing(t, x, p_ours, r), b.forcing(t, x, p, r))
        assert_close(a.rhs(t, x, p_ours, r), b.rhs(t, x, p, r))


def simple_kane(force=None, kd_scale=1, **options):
    """A point mass on a line: q' = kd_scale u, pushed by ``force`` (default input f(t))."""
    q, u, f = me.dynamicsymbols("q u f")
    m = sm.symbols("m")
    N = me.ReferenceFrame("N")
    P = me.Point("P")
    P.set_vel(N, u * N.x)
    km = me.KanesMethod(N, [q], [u], kd_eqs=[q.diff() - kd_scale * u], **options)
    bodies, loads = [me.Particle("Pa", P, m)], [(P, (f if force is None else force) * N.x)]
    return km, bodies, loads


def test_kinematics_and_plain_symbols():
    k = sm.Symbol("k")
    km, bodies, loads = simple_kane(kd_scale=k)
    km.kanes_equations(bodies, loads)
    eq = from_sympy(km)
    q, u, f, m = sm.symbols("q u f m")
    assert eq.kinematics == sm.ImmutableMatrix([k * u])
    assert (eq.mass_matrix, eq.forcing) == (sm.ImmutableMatrix([[m]]), sm.ImmutableMatrix([f]))
    assert eq.layout.parameters == (k, m) and eq.layout.inputs == (f,)


def test_refuses_unformed_and_unsupported():
    km, _, _ = simple_kane()
    with pytest.raises(ModelError, match=r"kanes_equations"):
        from_sympy(km)
    q = me.dynamicsymbols("q")
    with pytest.raises(ModelError, match=r"form_lagranges_equations"):
        from_sympy(me.LagrangesMethod(q.diff() ** 2 / 2, [q]))
    with pytest.raises(ModelError, match=r"form_eoms"):
        from_sympy(me.System(me.ReferenceFrame("N")))
    for obj in (object(), sm.Matrix([1]), mbgen.derive(n_link_cart.build_model(1))):
        with pytest.raises(ModelError, match=r"cannot convert .*KanesMethod"):
            from_sympy(obj)
    with pytest.raises(ModelError, match=r"keyword"):
        from_sympy(n_link(1), name="int")


def test_refuses_input_derivatives():
    f = me.dynamicsymbols("f")
    km, bodies, loads = simple_kane(force=f + f.diff())
    km.kanes_equations(bodies, loads)
    with pytest.raises(ModelError, match=r"Derivative\(f\(t\), t\)"):
        from_sympy(km)


def test_refuses_lagrange_with_joint_speeds():
    system = cart_pendulum()
    system.form_eoms(me.LagrangesMethod)
    with pytest.raises(ModelError, match=r"System speeds \['u_pin', 'u_slider'\]"):
        from_sympy(system)


def test_refuses_symbol_named_like_a_coordinate():
    km, bodies, loads = simple_kane(force=-sm.Symbol("q") * me.dynamicsymbols("q"))
    km.kanes_equations(bodies, loads)
    with pytest.raises(ModelError, match=r"\['q'\] belong to two different symbols"):
        from_sympy(km)


@pytest.mark.parametrize("output, option", [("energy", "Output.ENERGY"),
                                            ("positions", "Output.POSITIONS"),
                                            ("reactions", "Output.REACTIONS")])
def test_from_sympy_messages_name_its_own_arguments(output, option):
    eq = mbgen.from_sympy(n_link_pendulum_on_cart(1, cart_force=True))
    with pytest.raises(mbgen.ModelError) as info:
        mbgen.compile(eq, ["rhs", output])
    text = str(info.value)
    assert "from_sympy(obj, name=, parameters=, dependent=)" in text and option in text
    assert "energy=True" not in text and "points=..." not in text
