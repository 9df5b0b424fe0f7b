"""``mbgen bench arm``'s Jacobian and CasADi columns (nothing timed is asserted).

Pinocchio is in the ``test`` extra, so the Jacobian's agreement with
``computeABADerivatives`` is always checked; CasADi is optional: its tests are skipped,
with the reason, where ``casadi`` does not import.  The C++ loop takes minutes to compile
and is marked ``slow``.
"""

import math

import numpy as np
import pytest

from mbgen.bench import arm as armbench
from mbgen.bench import arm_casadi, arm_jacobian, arm_pinocchio
from mbgen.scenes.spatial_arm import link_parameters

needs_casadi = pytest.mark.skipif(not arm_casadi.have_casadi(),
                                  reason="casadi is not installed (pip install casadi)")


@pytest.fixture(scope="module")
def jacobian_run():
    messages = []
    rows = armbench.arm_scaling((2,), repeats=1, cxx=False, budget_s=math.inf,
                                sympy_budget_s=0, jacobian=True,
                                casadi=arm_casadi.have_casadi(), progress=messages.append)
    return rows, messages


def test_jacobian_columns_filled_and_agree_with_compute_aba_derivatives(jacobian_run):
    rows, messages = jacobian_run
    assert "n=2: mbgen Jacobian" in messages
    for r in rows:
        assert r.jac_status == "ok"
        for value in (r.jac_derive_s, r.jac_bake_s, r.jac_cse_s, r.jac_render_s,
                      r.jac_compile_s, r.jac_c_ns, r.jac_own_ns):
            assert value is not None and value > 0
        assert r.jac_ops > r.ops_after > 0
        assert r.pin_daba_ns is None                      # cxx=False: no C++ loop
        assert r.jac_rel_diff_pin < 1e-9                  # pin.computeABADerivatives
    text = armbench.format_arm(rows)
    assert "Jacobian: mbgen vs Pinocchio's computeABADerivatives" in text
    assert "n=2: jacobian ok" in text
    assert "module ns" in text and "mod/pin" in text


def test_mbgen_jacobian_block_is_pinocchios():
    """The comparison itself, at a state other than the timed one, n = 3."""
    n = 3
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.uniform(-2, 2, n), rng.uniform(-1, 1, n)])
    row = armbench.ArmRow(n=n)
    block = arm_jacobian.run_jacobian(row, x, 1, "kane", math.inf, 12.0)
    assert row.jac_status == "ok" and block.shape == (n, 2 * n)
    theirs = arm_pinocchio.pinocchio_aba_derivatives(n, x[:n], x[n:])
    assert arm_jacobian.relative_difference(block, theirs) < 1e-9
    assert arm_jacobian.relative_difference(block + 1e-6, theirs) > 1e-8   # it has teeth


def test_jacobian_is_off_by_default_and_stops_with_the_budget():
    rows = armbench.arm_scaling((2,), repeats=1, sympy_budget_s=0, pinocchio=False,
                                casadi=False)
    assert rows[0].jac_status == "not run" and rows[0].jac_c_ns is None
    rows = armbench.arm_scaling((2, 3), repeats=1, budget_s=0.05, sympy_budget_s=0,
                                pinocchio=False, casadi=False, jacobian=True)
    assert rows[0].jac_status.startswith("stopped in jac_derive at the 0.05 s budget")
    assert rows[1].jac_status == "not run (stopped at a smaller n)"


@needs_casadi
def test_casadi_columns_filled_and_agree(jacobian_run):
    rows, messages = jacobian_run
    assert "n=2: CasADi" in messages
    for r in rows:
        assert r.cas_status == "ok"
        for value in (r.cas_trace_s, r.cas_generate_s, r.cas_compile_s, r.cas_compile_o1_s,
                      r.cas_c_ns, r.casjac_trace_s, r.casjac_generate_s, r.casjac_compile_s,
                      r.casjac_c_ns):
            assert value is not None and value > 0
        assert r.cas_ops > 0 and r.casjac_ops > r.cas_ops
        assert r.max_abs_diff_cas < 1e-10 and r.casjac_rel_diff < 1e-9
    text = armbench.format_arm(rows)
    assert "Generation vs CasADi: RHS" in text and "Generation vs CasADi: Jacobian" in text


@needs_casadi
@pytest.mark.parametrize("n", [1, 4])
def test_casadi_aba_is_pinocchios(n):
    import casadi as ca

    x, p = ca.SX.sym("x", 2 * n), ca.SX.sym("p", 2)
    udot = arm_casadi.aba_sx(n, x, p)
    f = ca.Function("f", [x, p], [udot, ca.jacobian(udot, x)])
    values = link_parameters(n)
    q, v = armbench.state(n)
    ddq, jac = f(np.concatenate([q, v]), [values[f"m{n}"], values["g"]])
    np.testing.assert_allclose(np.array(ddq).ravel(), arm_pinocchio.pinocchio_aba(n, q, v),
                               rtol=1e-12, atol=1e-12)
    theirs = arm_pinocchio.pinocchio_aba_derivatives(n, q, v)
    assert arm_jacobian.relative_difference(np.array(jac), theirs) < 1e-12


def test_without_casadi_the_rows_say_so(monkeypatch):
    monkeypatch.setattr(armbench, "have_casadi", lambda: False)
    monkeypatch.setattr(arm_jacobian, "have_casadi", lambda: False)
    messages = []
    rows = armbench.arm_scaling((2,), repeats=1, budget_s=0, sympy_budget_s=0,
                                pinocchio=False, progress=messages.append)
    assert rows[0].cas_status == "not run: casadi is not installed"
    assert any("casadi is not installed" in m for m in messages)
    assert "casadi not run: casadi is not installed" in armbench.format_arm(rows)


@pytest.mark.slow
def test_cxx_aba_derivatives_loop_matches_python(tmp_path):
    exe = arm_pinocchio.build_aba_driver(tmp_path, repeats=2)
    for n in (2, 7):
        q, v = armbench.state(n)
        ns, block = arm_pinocchio.run_aba_derivatives_driver(exe, n, q, v)
        assert ns > 0 and block.shape == (n, 2 * n)
        np.testing.assert_allclose(block, arm_pinocchio.pinocchio_aba_derivatives(n, q, v),
                                   rtol=1e-10, atol=1e-10)
