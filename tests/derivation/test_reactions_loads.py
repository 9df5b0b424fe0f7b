"""``reaction=`` on forces and torques: Newton's third law and a hand derivation.

Two particles on a line pushed apart by an internal force ``f`` (applied at P1,
its reaction at P2), and two discs on one axis twisted by an internal torque ``T``
(on A, its reaction on B).  By hand, with no other load::

    m1 x1'' =  f,   m2 x2'' = -f          (so m1 x1'' + m2 x2'' = 0)
    I1 q1'' =  T,   I2 q2'' = -T          (so I1 q1'' + I2 q2'' = 0)

Both derivations (Kane, Newton-Euler) and both back ends must give exactly that.
"""

from __future__ import annotations

import numpy as np
import pytest

import mbgen
from mbgen.derivation import Method
from mbgen.pipeline import run
from mbgen.runtime.python import python_model


def two_particles() -> mbgen.Scene:
    m = mbgen.Model("pushed_pair")
    x1, x2 = m.coordinates("x1 x2")
    m.speeds("v1 v2")
    m1, m2, k, f0 = m.constants("m1 m2 k f0")
    N = m.newtonian()
    P1 = m.point("P1", m.origin, x1 * N.x)
    P2 = m.point("P2", m.origin, x2 * N.x + N.y)
    m.particle("b1", P1, m1)
    m.particle("b2", P2, m2)
    # an internal force that depends on the state, along x and y
    m.force(P1, (f0 + k * (x2 - x1)) * N.x + k * x1 * N.y, reaction=P2)
    return mbgen.Scene("pushed_pair", m,
                       parameters={"m1": 1.5, "m2": 0.7, "k": 3.0, "f0": 0.4})


def two_discs() -> mbgen.Scene:
    m = mbgen.Model("twisted_pair")
    q1, q2 = m.coordinates("q1 q2")
    m.speeds("w1 w2")
    I1, I2, k, t0 = m.constants("I1 I2 k t0")
    N = m.newtonian()
    A = m.rotate(N, "A", 3, q1)
    B = m.rotate(N, "B", 3, q2)
    m.body("a", A, 1.0, (0.1, 0.1, I1), m.origin)
    m.body("b", B, 1.0, (0.1, 0.1, I2), m.origin)
    m.torque(A, (t0 + k * (q2 - q1)) * N.z, reaction=B)
    return mbgen.Scene("twisted_pair", m, parameters={"I1": 0.3, "I2": 1.1, "k": 2.0, "t0": 0.5})


STATES = np.random.default_rng(3).uniform(-1, 1, (5, 4))


@pytest.mark.parametrize("method", [Method.KANE, Method.NEWTON_EULER])
def test_internal_force_obeys_the_third_law(method):
    result = run(two_particles(), ("rhs",), method=method)
    m1, m2, k, f0 = 1.5, 0.7, 3.0, 0.4
    for model in (result.compiled, python_model(result.rendered)):
        for x in STATES:
            x1, x2 = x[0], x[1]
            f = f0 + k * (x2 - x1)
            # P2 moves along x only (its y offset is constant): the y part acts on nothing
            want = np.array([x[2], x[3], f / m1, -f / m2])
            got = model.rhs(0.0, x)
            np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-14)
            assert m1 * got[2] + m2 * got[3] == pytest.approx(0.0, abs=1e-13)


@pytest.mark.parametrize("method", [Method.KANE, Method.NEWTON_EULER])
def test_internal_torque_obeys_the_third_law(method):
    result = run(two_discs(), ("rhs",), method=method)
    I1, I2, k, t0 = 0.3, 1.1, 2.0, 0.5
    for model in (result.compiled, python_model(result.rendered)):
        for x in STATES:
            T = t0 + k * (x[1] - x[0])
            want = np.array([x[2], x[3], T / I1, -T / I2])
            got = model.rhs(0.0, x)
            np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-14)
            assert I1 * got[2] + I2 * got[3] == pytest.approx(0.0, abs=1e-13)
