r"""Joint armature (``Model.armature``): a generalized inertia on one speed's diagonal.

A geared arm: a slider ``x`` along ``N.x``, a hinge ``q1`` about the vertical, a hinge
``q2`` tilted against it (each through its joint point, so that its motion subspace is a
unit vector and the articulated-body recursion would take its shortcut, which armature
rules out: the tilt makes the parent feel it), and a wrist of two speeds ``q3, q4`` (a
2 x 2 pivot), each with armature ``a_k`` (a constant symbol on ``q1``, numbers elsewhere),
under gravity.  With :math:`a = \operatorname{diag}(a_k)`:

* every method's ``M`` is the arm's without armature plus ``a`` on the diagonal, ``F`` is
  unchanged and the kinetic energy gains :math:`\tfrac12 u^T a u`;
* Newton–Euler's articulated-body recursion gives :math:`u' = M^{-1}F` and its inverse
  dynamics :math:`F - M u'`, with the armature inside the recursion (the pivots ``D``);
* on a hinge chain the analytic partials of the inverse dynamics (``u'`` held) equal
  sympy's derivative of Kane's ``F - M u'``;
* with no damping the energy ``T + V`` is conserved: :math:`dE/dt = 0` along ``rhs`` (it
  would not be if ``M`` and ``T`` disagreed on the armature);
* compiled C, generated Python and lambdify agree (``slow``).

MuJoCo's armature against ``mj_forward``: tests/model/test_mjcf.py and test_mjcf_suite.py.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm

import mbgen
from mbgen.abi import Output
from mbgen.derivation import Method, derive, rnea_partials
from mbgen.errors import ModelError
from mbgen.symbolic.equations import acceleration_symbols
from mbgen.verify.check import check

ARMATURE = {"v": 0.4, "u1": "J", "u2": 0.05, "u3": 0.02, "u4": 0.03}
J = 0.07


def geared_arm(armature: bool = True) -> mbgen.Model:
    m = mbgen.Model("geared_arm")
    x, q1, q2, q3, q4 = m.coordinates("x q1 q2 q3 q4")
    m.speeds("v u1 u2 u3 u4")
    g, _ = m.constants("g J")
    N = m.newtonian()
    P = m.point("P", m.origin, x * N.x)
    A = m.rotate(N, "A", 3, q1)
    B = m.rotate(m.rotate(A, "A2", 1, 0.4), "B", 2, q2)   # a tilted hinge
    C, D = m.chain_rotations([[B, "C", 1, q3], ["C", "D", 3, q4]])
    Ac = m.point("Ac", P, 0.2 * A.x)
    Bo = m.point("Bo", P, 0.4 * A.x + 0.1 * A.z)
    Bc = m.point("Bc", Bo, 0.25 * B.x)
    Do = m.point("Do", Bo, 0.5 * B.x)
    Dc = m.point("Dc", Do, 0.1 * D.y + 0.05 * D.z)
    m.particle("slider", P, 3.0)
    m.body("link", A, 2.0, (0.02, 0.03, 0.04), Ac)
    m.body("upper", B, 1.0, (0.01, 0.05, 0.06, 0.002, 0.0, 0.001), Bc)
    m.body("hand", D, 0.5, (0.004, 0.005, 0.006), Dc)
    m.gravity(-g * N.z)
    if armature:
        for speed, value in ARMATURE.items():
            m.armature(speed, value)
    return m


def numbers(eq, exprs, seed: int = 3):
    """``exprs`` (sympy matrices of ``eq``) as arrays at one random point: states and the
    acceleration placeholders uniform in [-1, 1], g = 9.81, J = 0.07;
    the program evaluated step by step (inlined, the recursion's ``u'`` would be a huge
    tree)."""
    rng = np.random.default_rng(seed)
    L = eq.layout
    held = acceleration_symbols(L.n_u)
    at = {s: sm.Float(rng.uniform(-1, 1)) for s in list(L.states) + list(held)}
    at.update({sm.Symbol("g"): sm.Float(9.81), sm.Symbol("J"): sm.Float(J), L.time: 0})
    for symbol, expr in eq.program.assignments:
        at[symbol] = sm.Float(float(expr.xreplace(at)))
    return [np.array(sm.Matrix(e).xreplace(at).evalf(), dtype=float) for e in exprs]


def diagonal() -> np.ndarray:
    values = [J if v == "J" else v for v in ARMATURE.values()]
    return np.diag(values)


@pytest.fixture(scope="module")
def derived():
    return {(method, armature): derive(geared_arm(armature), method)
            for method in (Method.KANE, Method.NEWTON_EULER) for armature in (True, False)}


@pytest.mark.parametrize("method", [Method.KANE, Method.NEWTON_EULER])
def test_every_method_adds_the_armature_to_the_diagonal_alone(derived, method):
    with_, without = derived[method, True], derived[method, False]
    M1, F1, T1 = numbers(with_, [with_.mass_matrix, with_.forcing, [with_.kinetic_energy]])
    M0, F0, T0 = numbers(without, [without.mass_matrix, without.forcing,
                                   [without.kinetic_energy]])
    a = diagonal()
    assert np.allclose(M1 - M0, a, rtol=0, atol=1e-13)
    assert np.allclose(F1, F0, rtol=0, atol=1e-12)
    u = numbers(with_, [sm.Matrix(with_.layout.speeds)])[0].ravel()
    assert T1 - T0 == pytest.approx(0.5 * u @ a @ u, abs=1e-13)


def test_newton_euler_agrees_with_kane(derived):
    kane, ne = derived[Method.KANE, True], derived[Method.NEWTON_EULER, True]
    for x, y in zip(numbers(ne, [ne.mass_matrix, ne.forcing, [ne.kinetic_energy]]),
                    numbers(kane, [kane.mass_matrix, kane.forcing, [kane.kinetic_energy]])):
        assert np.allclose(x, y, rtol=1e-12, atol=1e-12)


def test_the_recursion_carries_the_armature(derived):
    """The articulated-body recursion (the armature in every pivot ``D_i``, the unit-vector
    shortcut skipped where it would drop it) and the inverse dynamics ``F - M u'``."""
    ne = derived[Method.NEWTON_EULER, True]
    assert ne.accelerations is not None and ne.residual is not None
    udot = acceleration_symbols(ne.layout.n_u)
    M, F, A, R, held = numbers(ne, [ne.mass_matrix, ne.forcing, ne.accelerations, ne.residual,
                                    sm.Matrix(udot)])
    assert np.allclose(A.ravel(), np.linalg.solve(M, F).ravel(), rtol=1e-12, atol=1e-12)
    assert np.allclose(R.ravel(), (F - M @ held).ravel(), rtol=1e-12, atol=1e-12)


def test_without_damping_the_energy_is_conserved():
    model = mbgen.LambdifiedModel(mbgen.equations_of(geared_arm(), Method.NEWTON_EULER),
                                  outputs=(Output.RHS, Output.ENERGY))
    p = [9.81, J]
    rng = np.random.default_rng(5)
    for _ in range(3):
        x = rng.uniform(-1, 1, 10)
        f = model.rhs(0.0, x, p)
        h = 1e-6
        E = [float(np.sum(model.energy(0.0, x + s * h * f, p))) for s in (1, -1)]
        scale = float(np.sum(np.abs(model.energy(0.0, x, p))))
        assert abs(E[0] - E[1]) / (2 * h) <= 1e-6 * scale


def test_the_analytic_partials_of_the_inverse_dynamics_are_unchanged(monkeypatch):
    r"""A hinge chain (tilted axes, armature on each speed): Newton–Euler's analytic
    :math:`\partial R/\partial x` of :math:`R = F - M u'` (:mod:`~mbgen.derivation.rnea_partials`,
    ``u'`` held) equals sympy's derivative of Kane's ``F - M u'``; the armature's
    :math:`-a_k u'_k` is constant in the state."""
    monkeypatch.setattr(rnea_partials, "MIN_SPEEDS", 1)
    m = mbgen.Model("geared_chain")
    q = m.coordinates("q1:4")
    u = m.speeds("u1:4")
    g, _ = m.constants("g J")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q[0])
    B = m.rotate(m.rotate(A, "A2", 1, 0.3), "B", 2, q[1])
    C = m.rotate(B, "C", 1, q[2])
    J2 = m.point("J2", m.origin, 0.5 * A.x)
    J3 = m.point("J3", J2, 0.4 * B.x)
    m.body("a", A, 1.0, (0.01, 0.02, 0.03), m.point("P1", m.origin, 0.2 * A.x))
    m.body("b", B, 2.0, (0.02, 0.01, 0.03, 0.001, 0.0, 0.002), m.point("P2", J2, 0.2 * B.x))
    m.body("c", C, 0.5, (0.004, 0.005, 0.006), m.point("P3", J3, 0.1 * C.y))
    m.gravity(-g * N.z)
    for speed, value in zip(u, ("J", 0.2, 0.05)):
        m.armature(speed, value)
    ne = derive(m, Method.NEWTON_EULER, jacobian=True)
    assert ne.residual_jacobian is not None
    kane = derive(m, Method.KANE)
    udot = sm.Matrix(acceleration_symbols(3))
    R = kane.forcing - kane.mass_matrix * udot
    dR = R.jacobian(list(kane.layout.states))
    ours, = numbers(ne, [ne.residual_jacobian])
    theirs, = numbers(kane, [dR])
    assert np.abs(theirs).max() > 0.1
    assert np.allclose(ours, theirs, rtol=1e-12, atol=1e-12)
    own_M, own_F, M, F = numbers(ne, [*ne.partials_solve, ne.mass_matrix, ne.forcing])
    assert np.allclose(own_M, M, rtol=1e-12, atol=1e-12)   # the armature on its diagonal
    assert np.allclose(own_F, F, rtol=1e-12, atol=1e-12)


@pytest.mark.slow
def test_compiled_python_and_lambdify_agree():
    scene = mbgen.Scene("geared_arm", geared_arm(), parameters={"g": 9.81, "J": J},
                        outputs=(Output.RHS, Output.ENERGY), method=Method.NEWTON_EULER)
    check(scene, samples=5).raise_if_failed()


@pytest.mark.parametrize("speed, value, message", [
    ("w", 0.1, "armature on 'w': not a speed of model 'geared_arm'; speeds: v, u1"),
    ("u2", 0.1, "speed 'u2' already has armature"),
    ("u3", -0.5, "must be a finite number >= 0, got -0.5"),
    ("u3", float("nan"), "armature on 'u3' is not finite"),
    ("u3", float("inf"), "armature on 'u3' is not finite"),
    ("u3", "q1", "must be a number or constants, not q1"),
    ("u3", "K", "'K' names 'K', which is not a symbol of the model"),
])
def test_bad_armature_is_refused_by_name(speed, value, message):
    m = geared_arm(armature=False)
    m.armature("u2", 0.1)
    with pytest.raises(ModelError, match=message.replace("(", r"\(").replace(")", r"\)")):
        m.armature(speed, value)
