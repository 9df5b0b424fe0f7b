"""``mbgen bench interop``: the SX articulated-body algorithm is Pinocchio's, the NLP solves
with both kinds of dynamics, and a small run fills every column (slow); nothing timed is
asserted."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("casadi")
pin = pytest.importorskip("pinocchio")


def test_sx_aba_is_pinocchios():
    from mbgen.bench.arm_pinocchio import pinocchio_arm
    from mbgen.bench.interop import sx_dynamics

    f, traced = sx_dynamics(pinocchio_arm(4))       # raises unless it agrees with pin.aba
    assert f.n_in() == 2 and traced > 0


@pytest.mark.slow
def test_the_nlp_solves_both_ways():
    import casadi as ca

    import mbgen
    from mbgen.bench.arm_pinocchio import pinocchio_arm
    from mbgen.bench.interop import actuated_arm, solve_shooting, sx_dynamics

    f, _ = sx_dynamics(pinocchio_arm(2))
    ours = mbgen.compile(actuated_arm(2))
    rng = np.random.default_rng(0)
    q, v, tau = rng.uniform(-1, 1, (3, 2))
    np.testing.assert_allclose(ours.rhs(0, np.r_[q, v], None, tau),
                               np.array(f(np.r_[q, v], tau)).ravel(), rtol=1e-10, atol=1e-12)
    external = mbgen.casadi_function(actuated_arm(2))
    empty = ca.DM(0, 1)
    a = solve_shooting(lambda x, u: external(0, x, empty, u), 2, N=8)
    b = solve_shooting(lambda x, u: f(x, u), 2, N=8)
    assert a[2] == b[2] == "Solve_Succeeded" and abs(a[0] - b[0]) <= 3


@pytest.mark.slow
def test_a_small_run_fills_every_column(tmp_path):
    pytest.importorskip("jax")
    from mbgen.bench.interop import format_interop, interop_bench

    report = interop_bench(tmp_path, arm_n=3, N=6, batches=(50,), repeats=1)
    assert len(report.nlp) == 4 and all(r.iterations > 0 and r.total_s > 0 for r in report.nlp)
    ways = {r.way for r in report.throughput}
    assert len(ways) == 3
    for r in report.throughput:
        assert not math.isnan(r.ns_per_state) or r.note
    assert set(report.jax_compile) == {"trace", "lower", "compile"}
    assert "ms/iter" in format_interop(report)
