"""The analytic state Jacobian of inverse dynamics (mbgen.derivation.rnea_partials).

``residual_jacobian`` against forward-mode derivatives through the Newton–Euler program
(the path it replaces, itself checked against finite differences and lambdified sympy in
tests/runtime/test_jacobian.py), compiled, at seeded random states, parameters and inputs;
on revolute chains (angles ``q`` and ``-q``), a branching tree, prismatic joints at the
root, in the middle and at a leaf, loads (input torques, a spring, a damper), a coordinate
that moves two bodies (mimic joints), a floating base, and with parameters at run time.
Where it does not apply, the equations say so by carrying none.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
import sympy as sm

import mbgen
from mbgen import Output
from mbgen.derivation import Method, rnea_partials
from mbgen.derivation.prepare import prepare
from mbgen.derivation.recursion import NewtonEuler
from mbgen.model import urdf as urdf_module
from mbgen.pipeline import equations_of, run
from mbgen.scenes import n_link_cart, spatial_arm, torque_free
from mbgen.symbolic.equations import acceleration_symbols
from mbgen.verify.check import check
from urdf_models import FLOATING_PARTS, inertial, joint, link, urdf, write

OUTS = (Output.RHS, Output.JACOBIAN)
INERTIA = ((0.1, 0.2, 0.3, 0.01, 0.02, 0.03), (0.1, 0.25, 0.3, 0.0, 0.02, 0.0),
           (0.2, 0.1, 0.3, 0.0, 0.0, 0.01))


def tree(kind: str) -> mbgen.Model:
    """Three joints: revolute about z, y, x in a chain; variants named by ``kind``."""
    m = mbgen.Model(f"tree_{kind}")
    q = m.coordinates("q1:4")
    m.speeds("u1:4")
    g, = m.constants("g")
    N = m.newtonian("N")
    if kind == "cart":    # a prismatic root carrying a double pendulum
        J1 = m.point("J1", m.origin, q[0] * N.x)
        m.body("a", N, 2.0, INERTIA[0], J1)
        A = m.rotate(N, "A", 2, q[1])
        P2 = m.point("P2", J1, 0.5 * A.x)
        m.body("b", A, 1.0, INERTIA[1], P2)
        B = m.rotate(A, "B", 1, -q[2])
        J3 = m.point("J3", J1, 1.0 * A.x)
        m.body("c", B, 1.5, INERTIA[2], m.point("P3", J3, 0.3 * B.y))
        m.gravity(-g * N.z)
        return m
    A = m.rotate(N, "A", 3, -q[0] if kind == "neg" else q[0])
    m.body("a", A, 1.0, INERTIA[0], m.point("P1", m.origin, 0.5 * A.x))
    J2 = m.point("J2", m.origin, 1.0 * A.x)
    B = m.rotate(A, "B", 2, q[1])
    P2 = m.point("P2", J2, 0.4 * B.x)
    m.body("b", B, 2.0, INERTIA[1], P2)
    if kind == "branch":      # c hangs from a, beside b
        C = m.rotate(A, "C", 1, q[2])
        J3 = m.point("J3", m.origin, 1.0 * A.x + 0.2 * A.y)
        m.body("c", C, 1.5, INERTIA[2], m.point("P3", J3, 0.3 * C.y))
    elif kind == "slider":    # c slides along b's y axis
        J3 = m.point("J3", P2, q[2] * B.y)
        m.body("c", B, 1.5, INERTIA[2], m.point("P3", J3, 0.1 * B.x))
    else:
        C = m.rotate(B, "C", 1, q[2])
        J3 = m.point("J3", J2, 0.8 * B.x)
        P3 = m.point("P3", J3, 0.3 * C.y)
        m.body("c", C, 1.5, INERTIA[2], P3)
        if kind == "loads":   # input torques at two joints, a spring to the ground, a damper
            T1, T2 = m.inputs("T1 T2")
            k, c = m.constants("k_s c_d")
            m.torque(A, T1 * N.z, reaction=N)
            m.torque(B, T2 * A.y, reaction=A)
            m.spring("s", P3, m.point("anchor", m.origin, 0.3 * N.x + 0.5 * N.z), k,
                     natural_length=0.2, damping=c)
            m.damper("d", P2, P3, c)
    m.gravity(-g * N.z)
    return m


def mimic(kind: str) -> mbgen.Model:
    """Two coordinates, three bodies: one coordinate moves two of them, as a URDF mimic joint
    does.  ``chain``: c turns with ``-0.5 q2 + 0.3`` below b, which turns with ``q2``;
    ``fingers``: two bodies slide on a apart, by ``q2`` and ``-q2`` (Panda's fingers)."""
    m = mbgen.Model(f"mimic_{kind}")
    q = m.coordinates("q1:3")
    m.speeds("u1:3")
    g, = m.constants("g")
    N = m.newtonian("N")
    A = m.rotate(N, "A", 3, q[0])
    m.body("a", A, 1.0, INERTIA[0], m.point("P1", m.origin, 0.5 * A.x))
    J2 = m.point("J2", m.origin, 1.0 * A.x)
    if kind == "chain":
        B = m.rotate(A, "B", 2, q[1])
        m.body("b", B, 2.0, INERTIA[1], m.point("P2", J2, 0.4 * B.x))
        C = m.rotate(B, "C", 1, -0.5 * q[1] + 0.3)
        J3 = m.point("J3", J2, 0.8 * B.x)
        m.body("c", C, 1.5, INERTIA[2], m.point("P3", J3, 0.3 * C.y))
    else:
        F1 = m.point("F1", J2, q[1] * A.y)
        m.body("b", A, 2.0, INERTIA[1], m.point("P2", F1, 0.1 * A.x))
        F2 = m.point("F2", J2, -q[1] * A.y)
        m.body("c", A, 1.5, INERTIA[2], m.point("P3", F2, 0.1 * A.x))
    m.gravity(-g * N.y)
    return m


def jacobians(source, rng, fixed=None, samples=3):
    """``(analytic, forward-mode)`` compiled Jacobians at ``samples`` random points."""
    analytic = equations_of(source, Method.NEWTON_EULER, jacobian=True)
    forward = equations_of(source, Method.NEWTON_EULER, jacobian=False)
    assert analytic.residual_jacobian is not None and forward.residual_jacobian is None
    a = run(analytic, OUTS, fixed=fixed).compiled
    b = run(forward, OUTS, fixed=fixed).compiled
    out = []
    for _ in range(samples):
        x = rng.uniform(-1, 1, a.n_x)
        p = rng.uniform(0.5, 1.5, a.n_p)
        r = rng.uniform(-1, 1, a.n_r)
        out.append((a.jacobian(0.0, x, p, r), b.jacobian(0.0, x, p, r)))
    return out


def assert_pairs_close(pairs, rtol=1e-11):
    for ours, ref in pairs:
        assert np.abs(ref).max() > 0.1
        assert np.abs(ours - ref).max() <= rtol * np.abs(ref).max()


@pytest.fixture
def small(monkeypatch):
    """The analytic partials for models under ``MIN_SPEEDS`` too."""
    monkeypatch.setattr(rnea_partials, "MIN_SPEEDS", 1)


@pytest.mark.parametrize("kind", ["chain", "neg", "branch", "slider", "cart", "loads"])
def test_analytic_equals_forward_mode(kind, small):
    assert_pairs_close(jacobians(tree(kind), np.random.default_rng(3)))


@pytest.mark.parametrize("kind", ["chain", "fingers"])
def test_a_coordinate_that_moves_two_bodies(kind, small):
    """A mimic joint: the coordinate's rows and columns sum its bodies' terms (Panda as
    shipped, whose second finger mimics the first, fell back to forward mode)."""
    assert_pairs_close(jacobians(mimic(kind), np.random.default_rng(4)))


def floating_pairs(model, samples=3):
    """``(analytic, forward-mode)`` ``jacobian`` and ``tangent_jacobian`` of a floating
    model at random states (quaternions off the unit sphere)."""
    analytic = equations_of(model, Method.NEWTON_EULER, jacobian=True)
    forward = equations_of(model, Method.NEWTON_EULER, jacobian=False)
    assert analytic.residual_jacobian is not None
    assert analytic.residual_tangent is not None    # tangent_jacobian: no sum over G
    outs = (Output.RHS, Output.JACOBIAN, Output.TANGENT_JACOBIAN)
    a, b = run(analytic, outs).compiled, run(forward, outs).compiled
    rng = np.random.default_rng(6)
    pairs = []
    for _ in range(samples):
        x, r = rng.uniform(-1, 1, a.n_x), rng.uniform(-1, 1, a.n_r)
        pairs += [(getattr(a, o)(0.0, x, None, r), getattr(b, o)(0.0, x, None, r))
                  for o in ("jacobian", "tangent_jacobian")]
    return pairs


def root_passes(model) -> set:
    """The tags of the forward-mode passes ``residual_jacobian`` added (``nea``: the applied
    loads; ``nert``: a free root's rotation and position)."""
    ne = NewtonEuler(prepare(model))
    udot = acceleration_symbols(ne.nu)
    extra = rnea_partials.residual_jacobian(ne, udot).extra
    return {re.match(r"mbgen:([a-z]+)", str(s)).group(1) for s, _ in extra.assignments}


def test_a_floating_base(small, tmp_path):
    """A free root (six speeds, a quaternion) carrying a revolute and a prismatic joint: the
    root's rows against the joints and its own columns are analytic, its coordinates'
    through the body twist of each (only its rotation and position differentiated); the
    ``jacobian`` and the ``tangent_jacobian`` equal those of forward mode throughout."""
    model = mbgen.from_urdf(write(tmp_path, urdf(FLOATING_PARTS, "hopper")), floating=True)
    ne = NewtonEuler(prepare(model))
    assert rnea_partials.free_root(ne) is ne.bodies[0]
    assert len(rnea_partials.screw_joints(ne)) == len(ne.bodies) - 1
    assert root_passes(model) == {"nea", "nert"}
    assert_pairs_close(floating_pairs(model))


def test_a_root_rotation_that_is_not_one_everywhere(small, tmp_path, monkeypatch):
    """A quaternion's matrix not normalised where it is read is a rotation on the unit sphere
    only: the chain through ``R^T dR`` would miss its radial part and the world columns
    would not move rigidly, so the model keeps forward mode."""
    normalised = urdf_module.quaternion_matrix

    def unnormalised(x, y, z, w):
        return normalised(x, y, z, w) * (x * x + y * y + z * z + w * w)

    with monkeypatch.context() as patch:
        patch.setattr(urdf_module, "quaternion_matrix", unnormalised)
        model = mbgen.from_urdf(write(tmp_path, urdf(FLOATING_PARTS, "hopper")), floating=True)
    assert rnea_partials.free_root(NewtonEuler(prepare(model))) is None
    assert equations_of(model, Method.NEWTON_EULER, jacobian=True).residual_jacobian is None


def values(eq, exprs, rng):
    """``exprs`` (matrices of ``eq``) at a random state (inputs, parameters and the held
    ``u'`` too), ``g = 9.81``, the program evaluated assignment by assignment."""
    L = eq.layout
    at = {s: sm.Float(rng.uniform(-1, 1))
          for s in (*L.states, *L.inputs, *acceleration_symbols(L.n_u))}
    at.update({s: sm.Float(rng.uniform(0.5, 1.5)) for s in L.parameters})
    at.update({sm.Symbol("g"): sm.Float(9.81), L.time: 0})
    for symbol, expr in eq.program.assignments:
        at[symbol] = sm.Float(float(expr.xreplace(at)))
    return [np.array(sm.Matrix(e).xreplace(at).evalf(), dtype=float) for e in exprs]


@pytest.mark.parametrize("kind", ["branch", "slider", "loads", "fingers", "hopper"])
def test_the_jacobians_own_mass_matrix_and_forcing(kind, small, tmp_path):
    """``M`` and ``F`` from the partials' world-frame quantities (``partials_solve``, what the
    Jacobians solve with) are the derivation's ``M`` and ``F``."""
    model = (mimic(kind) if kind == "fingers" else tree(kind) if kind != "hopper" else
             mbgen.from_urdf(write(tmp_path, urdf(FLOATING_PARTS, kind)), floating=True))
    eq = equations_of(model, Method.NEWTON_EULER, jacobian=True)
    own_M, own_F, M, F = values(eq, [*eq.partials_solve, eq.mass_matrix, eq.forcing],
                                np.random.default_rng(8))
    assert np.abs(M).max() > 0.1 and np.abs(F).max() > 0.1
    assert np.allclose(own_M, M, rtol=1e-12, atol=1e-12)
    assert np.allclose(own_F, F, rtol=1e-12, atol=1e-12)


def test_few_joints_on_a_floating_base_keep_forward_mode(tmp_path):
    """A free root with fewer than MIN_SPEEDS joints keeps forward mode (the hopper's 2: 5,195
    operations forward against 7,768 analytic with the RHS and tangent_jacobian), with as
    many it takes the analytic partials, whatever its chains' length (legs of 3 joints: 6
    joints 25,744 against 31,178; Solo-12 36,260 against 39,828)."""
    model = mbgen.from_urdf(write(tmp_path, urdf(FLOATING_PARTS, "hopper")), floating=True)
    ne = NewtonEuler(prepare(model))
    assert rnea_partials.longest_chain(ne, rnea_partials.screw_joints(ne)) == 2
    assert ne.nu >= rnea_partials.MIN_SPEEDS
    assert equations_of(model, Method.NEWTON_EULER, jacobian=True).residual_jacobian is None
    legs = FLOATING_PARTS[:1]
    for leg in range(2):
        parent = "trunk"
        for k in range(3):
            child = f"leg{leg}_{k}"
            legs += [link(child, inertial(0.4, "0 0 -0.1")),
                     joint(child, "revolute", parent, child, f"0.1 {0.1 * leg} -0.2", "0 0.3 0",
                           "0 1 0", '<limit lower="-3" upper="3" effort="10" velocity="5"/>')]
            parent = child
    model = mbgen.from_urdf(write(tmp_path, urdf(legs, "legs"), "legs.urdf"), floating=True)
    ne = NewtonEuler(prepare(model))
    assert rnea_partials.longest_chain(ne, rnea_partials.screw_joints(ne)) == 3
    assert equations_of(model, Method.NEWTON_EULER, jacobian=True).residual_jacobian is not None


def test_spatial_arm_with_parameters_at_run_time():
    """``MIN_SPEEDS`` links, no monkeypatching: every link constant a run-time parameter."""
    scene = spatial_arm.scene(rnea_partials.MIN_SPEEDS)
    assert len(scene.model.speeds_) == rnea_partials.MIN_SPEEDS
    assert_pairs_close(jacobians(scene.model, np.random.default_rng(5), samples=2), rtol=1e-10)


def test_not_where_it_does_not_apply(small):
    """Absolute angles (two motion columns per body), a free body, constraints: none."""
    for scene in (n_link_cart.scene(), torque_free.scene()):
        ne = NewtonEuler(prepare(scene.model))
        assert rnea_partials.screw_joints(ne) is None
        eq = equations_of(scene, Method.NEWTON_EULER, jacobian=True)
        assert eq.residual_jacobian is None
    assert equations_of(tree("chain"), Method.NEWTON_EULER).residual_jacobian is None


def test_below_min_speeds_forward_mode():
    eq = equations_of(spatial_arm.scene(rnea_partials.MIN_SPEEDS - 1), Method.NEWTON_EULER,
                      jacobian=True)
    assert eq.residual_jacobian is None


def test_pipeline_asks_for_it_with_the_jacobian():
    """With ``jacobian`` or ``tangent_jacobian`` (alone, G1's RHS and tangent_jacobian took
    forward mode: 131,087 operations against 69,652), not with the RHS alone."""
    scene = spatial_arm.scene(rnea_partials.MIN_SPEEDS)
    with_jacobian = mbgen.run(scene, OUTS, build=False)
    assert with_jacobian.equations.residual_jacobian is not None
    tangent = mbgen.run(scene, (Output.RHS, Output.TANGENT_JACOBIAN), build=False)
    assert tangent.equations.residual_jacobian is not None
    assert mbgen.run(scene, (Output.RHS,), build=False).equations.residual_jacobian is None


def test_the_checker_takes_equations_with_analytic_partials():
    """The lambdified reference inlines the program and drops what reads it: the analytic
    Jacobian, its tangent and its own ``M``, ``F`` (the checker refused the 5-link arm's
    ``jacobian``: "partials_solve ... with a residual Jacobian")."""
    result = run(spatial_arm.scene(rnea_partials.MIN_SPEEDS), OUTS)
    assert result.equations.partials_solve is not None
    report = check(None, result=result, samples=3)
    assert report.ok, report.format()
