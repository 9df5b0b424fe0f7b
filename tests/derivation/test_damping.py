"""Dampers remove energy, at the rate a hand derivation gives.

Two masses on a line: a damped spring between them (stiffness k, damping c, natural
length 1) and a plain damper c0 from the first to the origin.  With E = T + V,

    dE/dt = -c (x2' - x1')^2 - c0 x1'^2  <= 0

at every state (the dampers' power); along a trajectory E never increases.
"""

from __future__ import annotations

import numpy as np
import pytest

import mbgen
from mbgen.derivation import Method
from mbgen.pipeline import run
from mbgen.runtime.python import python_model

K, C, C0, M1, M2 = 40.0, 0.8, 0.3, 1.0, 2.0


def damped_pair() -> mbgen.Scene:
    m = mbgen.Model("damped_pair")
    x1, x2 = m.coordinates("x1 x2")
    m.speeds("v1 v2")
    k, c, c0, m1, m2 = m.constants("k c c0 m1 m2")
    N = m.newtonian()
    P1 = m.point("P1", m.origin, x1 * N.x)
    P2 = m.point("P2", m.origin, x2 * N.x)
    m.particle("b1", P1, m1)
    m.particle("b2", P2, m2)
    m.spring("s12", P2, P1, k, natural_length=1.0, damping=c)
    m.damper("d1", P1, m.origin, c0)
    return mbgen.Scene("damped_pair", m, parameters={"k": K, "c": C, "c0": C0, "m1": M1, "m2": M2},
                       initial_state={"x1": 0.5, "x2": 2.3, "v1": 1.0, "v2": -0.5})


@pytest.fixture(scope="module", params=[Method.KANE, Method.NEWTON_EULER], ids=["kane", "ne"])
def models(request):
    result = run(damped_pair(), ("rhs", "energy", "dopri5"), method=request.param)
    return result.compiled, python_model(result.rendered)


def test_dissipation_rate_matches_the_hand_derivation(models):
    rng = np.random.default_rng(11)
    for model in models:
        for _ in range(6):
            x = rng.uniform(-1, 1, 4)
            x[1] = x[0] + 1.0 + rng.uniform(0.2, 1.0)  # keep the masses apart (L > 0)
            f = model.rhs(0.0, x)
            h = 1e-6
            E = lambda y, model=model: float(np.sum(model.energy(0.0, y)))  # noqa: E731
            rate = (E(x + h * f) - E(x - h * f)) / (2 * h)
            want = -C * (x[3] - x[2]) ** 2 - C0 * x[2] ** 2
            assert want < 0
            assert rate == pytest.approx(want, rel=1e-6, abs=1e-9)


def test_energy_never_increases_along_a_trajectory(models):
    c, _ = models
    t = np.linspace(0.0, 5.0, 201)
    run_ = c.integrate("dopri5", t, np.array([0.5, 2.3, 1.0, -0.5]), rtol=1e-11, atol=1e-12)
    E = np.array([np.sum(c.energy(0.0, x)) for x in run_.x])
    assert np.all(np.diff(E) <= 1e-9 * abs(E[0]))
    assert E[-1] < 0.5 * E[0]  # and it really dissipates
