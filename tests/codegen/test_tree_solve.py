"""The mass matrix factored and solved over a kinematic tree's structural nonzeros
(mbgen.codegen.tree_solve), and the Jacobian's column solve that uses it.

* the factor of a tree pattern, leaves first, fills nothing in, and its statements run as
  Python solve ``M x = b`` to 1e-12 for a random positive definite ``M`` of that pattern;
* which models take it: from two speeds on (below ``UNROLL_MAX`` too), sparse (a branched
  tree) or small enough (a chain of up to 33 speeds); a longer chain keeps the loops and a
  single speed its unrolled solve;
* a branched model (a hub with three pendulums; the unrolling threshold lowered so that four
  speeds take the path) compiles to ``<prefix>_tree_factor`` and the tree's column solve: C
  and generated Python agree bit for bit, with the dense path (its generated Python) to
  1e-12, and with the lambdified reference; it compiles without a warning as strict C and
  C++ and within its stack bounds; the 3-link cart (a chain) past ``TREE_DENSE_MAX`` keeps
  ``ldl_solve_columns``.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import mbgen
import mbgen.codegen.targets.model
from cstack import assert_within_stack_bounds
from mbgen.codegen import split, tree_solve
from mbgen.codegen.solver import UNROLL_MAX, py_lines
from mbgen.codegen.tree_solve import TreeFactor, tree_factor
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.verify.check import check

#: Parents of the speeds of a tree listed parents first: a root and two chains of three.
PARENTS = (-1, 0, 1, 2, 0, 4, 5)


def _ancestors(parents, i):
    out = []
    while i >= 0:
        out.append(i)
        i = parents[i]
    return out


def tree_pattern(parents) -> frozenset:
    """``(i, j)``, ``i > j``: ``j`` an ancestor of ``i``."""
    return frozenset((i, j) for i in range(len(parents)) for j in _ancestors(parents, i)[1:])


def tree_matrix(parents, rng) -> np.ndarray:
    """A positive definite ``M`` with exactly the tree's pattern: a body's ``G G^T`` on the
    speeds from it to the root, summed."""
    n = len(parents)
    M = np.zeros((n, n))
    for b in range(n):
        path = _ancestors(parents, b)
        G = rng.uniform(-1, 1, (len(path), 6))
        M[np.ix_(path, path)] += G @ G.T
    return M + np.diag(rng.uniform(0.5, 1.0, n))


def test_a_tree_factor_fills_nothing_in_and_solves():
    n, pattern = len(PARENTS), tree_pattern(PARENTS)
    tree = TreeFactor(n, pattern)
    assert tree.order == tuple(reversed(range(n)))
    assert tree.nonzeros == len(pattern) == 12 < n * (n - 1) // 2
    rng = np.random.default_rng(4)
    M = tree_matrix(PARENTS, rng)
    b = rng.uniform(-1, 1, n)
    scope = {"M": list(M.ravel()), "ID": [0.0] * n, "b": list(b), "DBL_EPSILON": 2.0 ** -52}
    exec("\n".join(py_lines(tree.factor(), "ArithmeticError()")
                   + py_lines(tree.solve(), "")), scope)
    x = np.linalg.solve(M, b)
    assert np.abs(np.array(scope["b"]) - x).max() <= 1e-12 * np.abs(x).max()


def test_a_sparse_or_bounded_factor_takes_the_tree():
    star = (-1, 0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8)   # a hub and four chains of three
    assert len(star) == 13 > UNROLL_MAX
    assert tree_factor(13, tree_pattern(star)) is not None
    chain = tuple(range(-1, 32))                      # dense M, 528 nonzeros in L
    assert tree_factor(33, tree_pattern(chain)).nonzeros == tree_solve.TREE_DENSE_MAX
    longer = tuple(range(-1, 33))
    assert tree_factor(34, tree_pattern(longer)) is None          # dense and long: the loops
    assert tree_factor(9, tree_pattern(star[:9])) is not None     # below UNROLL_MAX too
    assert tree_factor(1, frozenset()) is None                     # one speed: the unrolled


def hub(name="hub") -> mbgen.Model:
    """A hub turning about z carrying three pendulums (pitch, roll, pitch): four speeds, ``M``
    nonzero between the hub and each pendulum only."""
    m = mbgen.Model(name)
    q = m.coordinates("q0:4")
    m.speeds("u0:4")
    g, = m.constants("g", defaults=[9.81])
    T = m.inputs("T0:4")
    N = m.newtonian()
    H = m.rotate(N, "H", 3, q[0])
    m.body("hub", H, 2.0, (0.1, 0.12, 0.2, 0.01, 0.0, 0.002), m.origin)
    m.torque(H, T[0] * H.z, reaction=N)
    for k, (axis, at) in enumerate(((2, H.x), (1, H.y), (2, -H.x - H.y)), start=1):
        F = m.rotate(H, f"B{k}", axis, q[k])
        P = m.point(f"P{k}", m.origin, 0.3 * at)
        m.body(f"b{k}", F, 0.5 + 0.1 * k, (0.01, 0.02, 0.015, 0.001, 0.0, 0.0005),
               m.point(f"C{k}", P, 0.2 * F.x + 0.03 * F.z))
        m.torque(F, T[k] * (F.y if axis == 2 else F.x), reaction=H)
    m.gravity(-g * N.z)
    return m


@pytest.fixture
def small_trees(monkeypatch):
    """The unrolling threshold at 1: four speeds take the loops, and a sparse tree the tree."""
    monkeypatch.setattr(mbgen.codegen.targets.model, "UNROLL_MAX", 1)
    return monkeypatch


def test_a_branched_model_solves_its_columns_over_the_tree(small_trees, tmp_path):
    outputs = ("rhs", "jacobian")
    result = run(hub(), outputs)
    source = result.rendered.files[f"{result.rendered.prefix}.c"]
    assert "hub_tree_factor(M, CD)" in source and "ldl_solve_columns" not in source
    assert "double DT[" not in source   # the columns' right-hand sides go into J's rows
    assert "_tree_solve(M, CD, DT, j * 4)" in result.rendered.python
    small_trees.setattr(tree_solve, "TREE_FILL", 0.0)
    small_trees.setattr(tree_solve, "TREE_DENSE_MAX", 0)
    dense = run(hub("hub_dense"), outputs, build=False)
    assert "ldl_solve_columns" in dense.rendered.files["hub_dense.c"]
    py, py_dense = mbgen.python_model(result.rendered), mbgen.python_model(dense.rendered)
    rng = np.random.default_rng(2)
    for _ in range(3):
        x, r = rng.uniform(-1, 1, 8), rng.uniform(-1, 1, 4)
        p = result.compiled.default_parameters
        J = result.compiled.jacobian(0.0, x, p, r)
        assert np.array_equal(J, py.jacobian(0.0, x, p, r))
        J_dense = py_dense.jacobian(0.0, x, p, r)
        assert np.abs(J - J_dense).max() <= 1e-12 * np.abs(J_dense).max()
    report = check(None, result=result, samples=4)
    assert report.ok, report.format()
    assert_within_stack_bounds(result.rendered, tmp_path)


def test_in_parts_the_columns_are_stored_in_the_output_rows(small_trees, tmp_path):
    """Cut into parts, the parts store DT's entries straight into J's rows: the same bits as
    the parts that store into a local DT copied there, and as the generated Python (with
    gcc's basic-block vectoriser, one entry differed by a rounding: extension.NO_SLP);
    strict C and C++."""
    small_trees.setattr(split, "SPLIT_CHARS", 400)
    small_trees.setattr(split, "PART_CHARS", 400)
    result = run(hub("hub_parts"), ("rhs", "jacobian"))
    source = result.rendered.files["hub_parts.c"]
    assert "hub_parts_jacobian_part1(" in source and "double DT[" not in source
    assert re.search(r"static void hub_parts_jacobian_part\d+\([^)]*double \*J, double \*W\)",
                     source)
    small_trees.setattr(mbgen.codegen.targets.model, "_columns_in_place",
                        lambda view, slots=(): False)
    copied = run(hub("hub_copied"), ("rhs", "jacobian"))
    assert "double DT[" in copied.rendered.files["hub_copied.c"]
    py = mbgen.python_model(result.rendered)
    rng = np.random.default_rng(3)
    p = result.compiled.default_parameters
    for _ in range(3):
        x, r = rng.uniform(-1, 1, 8), rng.uniform(-1, 1, 4)
        J = result.compiled.jacobian(0.0, x, p, r)
        assert np.array_equal(J, copied.compiled.jacobian(0.0, x, p, r))
        assert np.array_equal(J, py.jacobian(0.0, x, p, r))
    assert_within_stack_bounds(result.rendered, tmp_path)


def test_a_chain_keeps_the_dense_column_solve(small_trees):
    """Dense and past TREE_DENSE_MAX (lowered to 2 here): the loops."""
    small_trees.setattr(tree_solve, "TREE_DENSE_MAX", 2)
    result = run(load_scene("n_link_cart", n=3), ("rhs", "jacobian"), build=False)
    source = result.rendered.files[f"{result.rendered.prefix}.c"]
    assert "ldl_solve_columns" in source and "_tree_factor" not in source
