"""The derivation registry: every method has a row, and every row agrees with Kane.

A new derivation method is one module and one row of ``mbgen.derivation.METHODS``
(the package docstring says how); these tests fail when the row is forgotten,
or when the new method's equations differ from Kane's.
"""

import numpy as np
import pytest
import sympy as sm

import mbgen
from mbgen.derivation import METHODS, Method, derive
from mbgen.errors import ModelError

#: small built-in scenes: body rates, a prescribed motion, constraints
SMALL = ["disc_pendulum", "spring_pendulum", "torque_free", "bead_wire", "four_bar"]


def loaded() -> mbgen.Model:
    """Two rigid bodies and every kind of load (a new kind of load belongs here too)."""
    m = mbgen.Model("loaded")
    q1, q2, x = m.coordinates("q1 q2 x")
    m.speeds("u1 u2 v")
    k, c, length, g = m.constants("k c length g")
    f, tau = m.inputs("f tau")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)
    B = m.rotate(A, "B", 1, q2)
    Ao = m.point("Ao", m.origin, x * N.x)
    Bo = m.point("Bo", Ao, 0.5 * A.y)
    Bc = m.point("Bc", Bo, 0.3 * B.z)
    m.body("a", A, 2.0, (0.1, 0.2, 0.3), Ao)
    m.body("b", B, 1.0, (0.05, 0.06, 0.07, 0.01, 0.0, 0.02), Bc)
    m.gravity(-g * N.z)
    m.spring("spring", Bc, m.origin, k, natural_length=length, damping=c)
    m.damper("damper", Ao, m.origin, c)
    m.force(Bc, f * N.y, reaction=Ao)
    m.torque(B, tau * A.x, reaction=A)
    m.armature("u2", 0.04)              # a generalized inertia on one speed
    return m


MODELS = {**{name: (lambda name=name: mbgen.load_scene(name).model) for name in SMALL},
          "loaded": loaded}


def test_every_method_has_a_derivation():
    assert set(METHODS) == set(Method)


def test_an_unknown_method_names_the_choices():
    model = mbgen.load_scene("disc_pendulum").model
    with pytest.raises(ModelError, match="unknown derivation method 'lagrange'; choose from "
                                         "kane, newton_euler"):
        derive(model, "lagrange")


def _values(eq, seed=3):
    """``eq``'s matrices as numbers at a random point (program symbols inlined)."""
    parts = [eq.mass_matrix, eq.forcing, eq.kinematics,
             sm.Matrix([eq.kinetic_energy, eq.potential_energy])]
    if eq.reactions is not None:
        parts.append(eq.reactions.matrix)
    inlined = eq.program.inline([sm.Matrix(p) for p in parts])
    symbols = sorted(set().union(*(m.free_symbols for m in inlined)), key=str)
    rng = np.random.default_rng(seed)
    at = {s: sm.Float(rng.uniform(0.5, 1.5)) for s in symbols}
    return [np.array(m.xreplace(at).evalf(), dtype=float) for m in inlined]


@pytest.mark.parametrize("method", [m for m in METHODS if m is not Method.KANE])
@pytest.mark.parametrize("name", MODELS)
def test_every_method_agrees_with_kane(method, name):
    model = MODELS[name]()
    kane = derive(model, Method.KANE, reactions=True)
    other = derive(model, method, reactions=True)
    assert other.method == method.value
    assert other.layout == kane.layout
    for a, b in zip(_values(other), _values(kane)):
        assert a.shape == b.shape
        assert np.allclose(a, b, rtol=1e-10, atol=1e-10)
