"""The spatial arm against Pinocchio, and the arm benchmark's machinery (nothing timed is asserted).

Pinocchio (PyPI ``pin``) is in the ``test`` extra, so these tests always run;
the C++ loop against the wheel's headers takes about a minute to compile and is
marked ``slow``.
"""

import math

import numpy as np
import pytest

import mbgen
from mbgen.bench import arm as armbench
from mbgen.bench import arm_pinocchio
from mbgen.scenes import spatial_arm


@pytest.mark.parametrize("n", [1, 2, 5])
def test_arm_rhs_equals_pinocchio_aba(n):
    model = mbgen.compile(spatial_arm.scene(n))
    rng = np.random.default_rng(100 + n)
    for _ in range(5):
        q, v = rng.uniform(-np.pi, np.pi, n), rng.uniform(-2.0, 2.0, n)
        ours = model.rhs(0.0, np.concatenate([q, v]))
        np.testing.assert_array_equal(ours[:n], v)                  # q' = u
        theirs = arm_pinocchio.pinocchio_aba(n, q, v)
        assert np.abs(ours[n:] - theirs).max() <= 1e-10 * max(1.0, np.abs(theirs).max())


def test_arm_rhs_differs_from_pinocchio_when_a_parameter_differs():
    """The comparison has teeth: a 1% heavier payload changes the accelerations."""
    n = 3
    model = mbgen.compile(spatial_arm.scene(n))
    q, v = armbench.state(n)
    p = model.default_parameters.copy()
    p[list(model.layout.parameter_names).index(f"m{n}")] *= 1.01
    ours = model.rhs(0.0, np.concatenate([q, v]), p)
    assert np.abs(ours[n:] - arm_pinocchio.pinocchio_aba(n, q, v)).max() > 1e-6


@pytest.fixture(scope="module")
def small_run():
    messages = []
    rows = armbench.arm_scaling((2, 3), repeats=2, cxx=False, budget_s=math.inf,
                                sympy_budget_s=math.inf, casadi=False,   # its own tests
                                progress=messages.append)
    return rows, messages


def test_small_run_fills_every_column(small_run):
    rows, messages = small_run
    assert [r.n for r in rows] == [2, 3]
    assert messages[:3] == ["n=2: mbgen", "n=2: sympy KanesMethod", "n=2: Pinocchio"]
    for r in rows:
        assert r.status == "ok" and r.sympy_status == "ok"
        for value in (r.derive_s, r.bake_s, r.cse_s, r.render_s, r.compile_s, r.rhs_c_ns,
                      r.rhs_py_ns, r.pin_py_ns, r.sympy_derive_s, r.sympy_cse_s,
                      r.sympy_lambdify_s, r.sympy_rhs_py_ns):
            assert value is not None and value > 0
        assert r.ops_after > 0 and r.sympy_ops_after > 0
        assert r.pin_cxx_ns is None                     # cxx=False
        assert r.max_abs_diff_pin < 1e-10 and r.max_abs_diff_sympy < 1e-10
    assert rows[1].ops_after > rows[0].ops_after


def test_table_csv_and_plot(small_run, tmp_path):
    rows, _ = small_run
    text = armbench.format_arm(rows)
    lines = text.splitlines()
    assert lines[0].split()[:3] == ["n", "derive", "bake"]
    assert lines[2].split()[0] == "2" and lines[4].split()[0] == "slope"
    assert "n=3: mbgen ok; sympy ok" in text
    slopes = armbench.growth_exponents(rows)
    expected = np.log(rows[1].ops_after / rows[0].ops_after) / np.log(3 / 2)
    assert slopes["ops_after"] == pytest.approx(expected)
    path = armbench.write_csv(rows, tmp_path / "arm.csv")
    content = path.read_text().splitlines()
    assert content[0].startswith("n,derive_s,") and content[-1].startswith("slope,")
    assert len(content) == 4
    png = armbench.plot(rows, tmp_path / "arm.png")
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_budget_stops_a_side_and_skips_larger_n():
    rows = armbench.arm_scaling((2, 3), repeats=1, budget_s=0.05, sympy_budget_s=0,
                                pinocchio=False)
    assert rows[0].status.startswith("stopped in derive at the 0.05 s budget")
    assert rows[1].status == "not run (stopped at a smaller n)"
    assert rows[0].sympy_status == rows[1].sympy_status == "not run"
    assert rows[0].derive_s is None and rows[0].rhs_c_ns is None


@pytest.mark.slow
def test_cxx_aba_loop_matches_pin_aba(tmp_path):
    exe = arm_pinocchio.build_aba_driver(tmp_path, repeats=2)
    for n in (2, 7):
        q, v = armbench.state(n)
        ns, ddq = arm_pinocchio.run_aba_driver(exe, n, q, v)
        assert ns > 0
        np.testing.assert_allclose(ddq, arm_pinocchio.pinocchio_aba(n, q, v),
                                   rtol=1e-12, atol=1e-12)
