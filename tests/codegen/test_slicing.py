"""Slicing: the scene's code leaves out what it does not need and still gives the same numbers."""

from dataclasses import replace

import numpy as np
import pytest
import sympy as sm

import mbgen
from heavy import scene_params
from mbgen import Model, Output
from mbgen.codegen.slicing import bake
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.symbolic.graph import xreplace_dag
from mbgen.verify.audit import audit


def values(scene, layout):
    merged = {**scene.parameters, **scene.fixed}
    return np.array([merged[n] for n in layout.parameter_names])


@pytest.mark.parametrize("name", scene_params(heavy=True))
def test_sliced_code_gives_the_numbers_of_the_full_code(name):
    scene = load_scene(name)
    outputs = [o for o in scene.outputs if not Output(o).is_integrator]
    full = run(scene, outputs, sliced=False)
    sliced = run(scene, outputs)
    assert set(sliced.layout.parameter_names).isdisjoint(scene.fixed)
    rng = np.random.default_rng(3)
    p_full, p_sliced = values(scene, full.layout), values(scene, sliced.layout)
    for k in range(5):
        x = scene.x0(full.layout) + rng.uniform(-0.1, 0.1, full.layout.n_x)
        given = {n: rng.uniform(-1, 1) for n in sliced.layout.input_names}
        r_full = np.array([given.get(n, 0.0) for n in full.layout.input_names])
        r_sliced = np.array([given[n] for n in sliced.layout.input_names])
        for output in outputs:
            a = getattr(full.compiled, Output(output).value)(0.1 * k, x, p_full, r_full)
            b = getattr(sliced.compiled, Output(output).value)(0.1 * k, x, p_sliced, r_sliced)
            # entries that vanish by cancellation (a ball hitch's yaw moment) carry rounding
            # noise of the size of the summed terms (up to ~10 eps times the output's largest)
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-13 * max(1.0, np.abs(a).max()))


def free_fall():
    """A particle under gravity with a spring whose offset is a parameter."""
    m = Model("fall")
    z, = m.coordinates("z")
    m.speeds("w")
    g, mass, k, z0, F = (*m.constants("g mass k z0"), *m.inputs("F"))
    N = m.newtonian()
    P = m.point("P", m.origin, z * N.z)
    anchor = m.point("A", m.origin, z0 * N.z)
    m.particle("ball", P, mass)
    m.gravity(-g * N.z)
    m.spring("s", P, anchor, k)
    m.force(P, F * N.z)
    return m


def test_baked_parameter_equals_passing_its_value():
    full = mbgen.compile(free_fall())
    sliced = mbgen.compile(free_fall(), fixed={"g": 9.81, "z0": 0.0}, inputs=())
    assert full.parameter_names == ("g", "mass", "k", "z0") and full.input_names == ("F",)
    assert sliced.parameter_names == ("mass", "k") and sliced.input_names == ()
    x = np.array([0.3, -0.2])
    np.testing.assert_allclose(sliced.rhs(0, x, [2.0, 5.0]),
                               full.rhs(0, x, [9.81, 2.0, 5.0, 0.0], [0.0]), rtol=1e-15)


def test_zero_offset_removes_terms_and_unused_parameters_leave_the_abi():
    result = run(free_fall(), fixed={"z0": 0.0}, inputs=(), build=False)
    assert "z0" not in result.rendered.source
    # mass cancels nowhere, but with g and k free every remaining parameter is read
    assert result.layout.parameter_names == ("g", "mass", "k")
    only_g = run(free_fall(), fixed={"k": 0.0, "z0": 1.0, "mass": 1.0}, inputs=(), build=False)
    assert only_g.layout.parameter_names == ("g",)   # the anchor offset vanished with k = 0
    assert "const double *r" not in only_g.rendered.header


def test_no_parameter_slot_when_everything_is_baked():
    result = run(free_fall(), fixed={"g": 9.81, "mass": 1.0, "k": 2.0, "z0": 0.5}, inputs=())
    assert "const double *p" not in result.rendered.header
    assert "(double t, const double *x, double *dxdt)" in result.rendered.header
    np.testing.assert_allclose(result.compiled.rhs(0.0, [0.5, 0.0]), [0.0, -9.81])


def test_only_requested_functions_and_includes():
    result = run(load_scene("bead_wire"), outputs=("rhs",), build=False)
    header, source = result.rendered.header, result.rendered.source
    assert "bead_wire_rhs(" in header
    for absent in ("_mass_matrix(", "_forcing(", "_energy(", "_jacobian(", "_dopri5(",
                   "_options", "BEAD_WIRE_MAX_STEPS"):
        assert absent not in header and absent not in source
    assert "#include <math.h>" not in source  # no trigonometry survives for the bead


def test_diagonal_mass_matrix_needs_no_factorisation_loops():
    source = run(load_scene("disc_pendulum"), build=False).rendered.source
    assert "for (j" not in source.split("disc_pendulum_ldl_solve")[0]
    assert "M[3] = M[3]/M[3]" not in source


def test_bake_rejects_unknown_names():
    eq = mbgen.derive(free_fall())
    with pytest.raises(mbgen.ModelError, match="not parameters"):
        bake(eq, {"gravity": 9.81})
    with pytest.raises(mbgen.ModelError, match="not inputs"):
        bake(eq, {}, inputs=("G",))


def test_same_scene_sliced_two_ways_in_one_process():
    scene = load_scene("paraboloid")
    a = mbgen.compile(scene)                                   # g baked, k and m free
    b = mbgen.compile(scene, fixed={}, name="paraboloid_full")  # nothing baked
    x = scene.x0(a.layout)
    np.testing.assert_allclose(a.rhs(0, x), b.rhs(0, x, values(scene, b.layout)), rtol=1e-14)
    assert a.parameter_names != b.parameter_names


@pytest.mark.parametrize("name", ["disc_pendulum", "n_link_cart", "paraboloid"])
def test_audit_reports_every_cut(name):
    report = audit(load_scene(name))
    text = report.format()
    for step in ("1 outputs", "2 fixed parameters", "3 inputs", "4 unused symbols",
                 "5 exact zeros", "6 accelerations", "7 CSE", "8 includes"):
        assert step in text
    assert report.sliced_ops < report.full_ops and report.sliced_lines < report.full_lines
    assert "jacobian" in text  # a left-out output is named with its cost


def test_baking_constants_costs_no_operations():
    """Fixed link constants become numbers; sympy would distribute each over the sum it
    multiplies (0.4*(x + y) -> 0.4*x + 0.4*y), so the 8-link arm's baked RHS had 1,960
    operations against 1,864 with every constant at run time.  Baked, it has fewer."""
    scene = replace(load_scene("spatial_arm", n=8), outputs=(Output.RHS,))
    baked = run(scene, build=False).kernel.ops_after
    at_run_time = run(scene, build=False, sliced=False).kernel.ops_after
    assert len(scene.fixed) == 70 and baked < at_run_time, (baked, at_run_time)


def test_a_number_times_a_sum_stays_one_product():
    x, y, a, b = sm.symbols("x y a b")
    baked, = xreplace_dag([a * (x + y) + b], {a: sm.Float(0.4), b: sm.Integer(2)},
                          keep_sums=True)
    assert baked == sm.Add(sm.Mul._from_args((sm.Float(0.4), x + y)), 2)
    assert float(baked.subs({x: 1.5, y: -0.25})) == 0.4 * (1.5 - 0.25) + 2
    plain, = xreplace_dag([a * (x + y)], {a: sm.Float(0.4)})     # sympy's own evaluation
    assert plain == 0.4 * x + 0.4 * y
    for c in (0, 1, -1):   # sympy's simplifications still apply
        assert xreplace_dag([a * (x + y)], {a: sm.Integer(c)}, keep_sums=True)[0] == c * (x + y)
