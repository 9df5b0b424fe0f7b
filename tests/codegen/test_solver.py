"""The dense-loop L D L^T solver (used past ``UNROLL_MAX`` = 12 speeds) in the default suite.

Two ways in: the threshold lowered (and the tree's column solve off) so that a 4-speed cart
takes the loop path (fast),
and a real 13-speed cart (the 12-link pendulum on a cart), both checked in C and in the
generated Python against the lambdified equations solved by NumPy.
"""

from __future__ import annotations

import numpy as np
import pytest

import mbgen
import mbgen.codegen.targets.model
from mbgen.codegen import tree_solve
from mbgen.codegen.solver import UNROLL_MAX
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.verify.check import check


@pytest.fixture
def dense_loops(monkeypatch):
    """The unrolling threshold at 1 and no tree factor: small models take the dense loops."""
    monkeypatch.setattr(mbgen.codegen.targets.model, "UNROLL_MAX", 1)
    monkeypatch.setattr(tree_solve, "TREE_FILL", 0.0)
    monkeypatch.setattr(tree_solve, "TREE_DENSE_MAX", 0)


def _loops(rendered) -> bool:
    return "for (j = 0; j < " in rendered.files[f"{rendered.prefix}.c"]


def test_threshold_as_a_parameter(dense_loops):
    result = run(load_scene("n_link_cart", n=3), ("rhs", "jacobian", "mass_matrix"))
    assert _loops(result.rendered) and "for j in range(n):" in result.rendered.python
    report = check(None, result=result, samples=6)
    assert report.ok, report.format()


def test_thirteen_speeds_take_the_loop_path():
    result = run(load_scene("n_link_cart", n=12), ("rhs",))
    assert result.layout.n_u == 13 > UNROLL_MAX
    assert _loops(result.rendered)
    report = check(None, result=result, samples=3)
    assert report.ok, report.format()
    assert all(r.compared == 3 for r in report.rows)


def test_the_row_wise_column_solve_gives_the_per_column_solves_bits(dense_loops):
    """Past UNROLL_MAX the Jacobian's columns are solved together, row by row (the inner
    loops along a row vectorise): per column the operations of ``ldl_solve`` in its order,
    so the C Jacobian is the generated Python's (one column at a time) bit for bit."""
    result = run(load_scene("n_link_cart", n=3), ("rhs", "jacobian", "parameter_jacobian"))
    assert "double acc[8];" in result.rendered.source
    py = mbgen.python_model(result.rendered)
    rng = np.random.default_rng(2)
    for _ in range(4):
        x = rng.uniform(-1, 1, result.compiled.n_x)
        r = rng.uniform(-1, 1, result.compiled.n_r)
        for name in ("jacobian", "parameter_jacobian"):
            np.testing.assert_array_equal(getattr(result.compiled, name)(0.0, x, None, r),
                                          getattr(py, name)(0.0, x, None, r))


def test_the_column_solve_is_the_generated_pythons_bit_for_bit(dense_loops):
    """``ldl_solve_columns`` takes four rows of ``L`` per pass over a row of ``B``; each
    column still sees ``ldl_solve``'s subtractions in its order, so the C Jacobian is the
    generated Python's (one column at a time) bit for bit.  Six speeds: the four-row passes
    run forward (rows 4, 5) and backward (rows 0, 1), the one-row rest too."""
    result = run(load_scene("n_link_cart", n=5), ("rhs", "jacobian"))
    assert "k + 4 <=" in result.rendered.files[f"{result.rendered.prefix}.c"]
    namespace: dict = {}
    exec(compile(result.rendered.python, "generated", "exec"), namespace)
    model = result.compiled
    p = np.array([result.rendered.defaults[k] for k in result.layout.parameter_names])
    rng = np.random.default_rng(5)
    for _ in range(3):
        x = rng.uniform(-1, 1, model.n_x)
        r = rng.uniform(-1, 1, model.n_r)
        ours = model.jacobian(0.0, x, p, r)
        python = np.asarray(namespace["jacobian"](0.0, x, p, r)).reshape(ours.shape)
        np.testing.assert_array_equal(ours, python)
