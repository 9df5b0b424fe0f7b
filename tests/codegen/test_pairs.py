"""A chain's ancestor–descendant products in loops (mbgen.symbolic.pairs, mbgen.codegen.pairs).

* the derivation's vectors give exactly the entries of ``residual_jacobian`` and of the
  Jacobian's own mass matrix (symbolically, every pair of a 6-link arm), and only a chain
  carries them: a branch, a load between two bodies of a pair and a floating base do not;
* the 3-link arm (``LOOPS_MIN`` and the analytic partials' ``MIN_SPEEDS`` lowered; its
  columns take the tree's solve in the output's rows): the C's ``jacobian`` and
  ``tangent_jacobian`` (where each ``q'`` is its ``u``) have the loops and no written-out
  pair; they equal the generated Python's bit for bit, and the copying and the split
  builds'; the written-out build's and the lambdified reference's to 1e-12 and the checker's
  tolerance; strict C99 and C++ within its stack bounds; its JAX function and CasADi's
  Jacobian block (the pattern counts the loops' entries) agree;
* a long chain takes the loops without any threshold lowered, a short one does not.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import sympy as sm

import mbgen
import mbgen.codegen.targets.model
from checks import assert_close, random_states
from cstack import assert_within_stack_bounds
from mbgen import Output
from mbgen.codegen import pairs, split
from mbgen.derivation import Method, rnea_partials
from mbgen.pipeline import equations_of, run
from mbgen.scenes import spatial_arm
from mbgen.symbolic.pairs import PRODUCTS
from mbgen.verify.check import check
from urdf_models import FLOATING_PARTS, urdf, write

OUTS = ("rhs", "jacobian", "tangent_jacobian")
#: Links of the arm whose loops are checked (``LOOPS_MIN`` lowered): three pairs, every loop
#: nest, and a jit of its JAX Jacobian in seconds (the 5-link arm's took 12 s).
LINKS = 3


def pendulums(kind: str) -> mbgen.Model:
    """Five revolute links about alternating axes: a chain; ``branch``: the last hangs from
    the first; ``spring``: a spring from the tip to the second link (a load on a pair)."""
    m = mbgen.Model(f"pend_{kind}")
    q = m.coordinates("q0:5")
    m.speeds("u0:5")
    g, = m.constants("g", defaults=[9.81])
    N = m.newtonian()
    frames, joints = [N], [m.origin]
    for k in range(5):
        parent = 0 if kind == "branch" and k == 4 else k
        F = m.rotate(frames[parent], f"B{k}", 1 + k % 3, q[k])
        J = m.point(f"J{k}", joints[parent], 0.4 * frames[parent].x + 0.05 * k * frames[parent].y)
        m.body(f"b{k}", F, 1.0 + 0.1 * k, (0.02, 0.03, 0.025, 0.001, 0.0, 0.002),
               m.point(f"C{k}", J, 0.2 * F.x + 0.02 * F.z))
        frames.append(F)
        joints.append(J)
    if kind == "spring":
        k_s, = m.constants("k_s", defaults=[3.0])
        m.spring("s", m.point("tip", joints[5], 0.4 * frames[5].x), joints[2], k_s,
                 natural_length=0.1)
    m.gravity(-g * N.z)
    return m


@pytest.fixture
def short(monkeypatch):
    """The loops from two speeds on, and the analytic partials that carry them."""
    monkeypatch.setattr(pairs, "LOOPS_MIN", 2)
    monkeypatch.setattr(rnea_partials, "MIN_SPEEDS", 2)
    return monkeypatch


def test_the_products_are_the_entries_they_stand_for():
    eq = equations_of(spatial_arm.scene(6), Method.NEWTON_EULER, jacobian=True)
    P, (M, _) = eq.pairs, eq.partials_solve
    assert (P.n, P.q0, P.u0) == (6, 0, 0)
    products = P.products(eq.layout.n_q)
    assert len(products) == len(PRODUCTS) * 15
    nonzero = 0
    for (target, i, j), e in products.items():
        entry = M[i, j] if target == "M" else eq.residual_jacobian[i, j]
        assert sm.expand(entry - e) == 0, (target, i, j)
        nonzero += entry != 0
    assert nonzero >= len(products) - 6   # the first joint's axis is vertical: dtau/dq_0 = 0
    # tangent_jacobian: the same loops where each q' is its u (G's columns unit ones)
    assert pairs._in_columns(eq, Output.TANGENT_JACOBIAN) == replace(P, q0=P.u0)
    doubled = replace(eq, kinematics=2 * eq.kinematics)
    assert pairs._in_columns(doubled, Output.TANGENT_JACOBIAN) is None
    assert pairs._in_columns(doubled, Output.JACOBIAN) is P


@pytest.mark.parametrize("kind", ["branch", "spring", "floating"])
def test_only_a_chain_without_loads_across_its_pairs(kind, monkeypatch, tmp_path):
    monkeypatch.setattr(rnea_partials, "MIN_SPEEDS", 1)   # the branch's longest chain: 4
    chain = equations_of(pendulums("chain"), Method.NEWTON_EULER, jacobian=True)
    assert chain.pairs is not None and chain.pairs.n == 5
    model = (mbgen.from_urdf(write(tmp_path, urdf(FLOATING_PARTS, "hopper")), floating=True)
             if kind == "floating" else pendulums(kind))
    other = equations_of(model, Method.NEWTON_EULER, jacobian=True)
    assert other.residual_jacobian is not None and other.pairs is None


def _jacobians(results, seed=4):
    """Each result's compiled ``jacobian`` and ``tangent_jacobian`` (and the first's
    generated Python's) at the same random arguments."""
    py = mbgen.python_model(results[0].rendered)
    model = results[0].compiled
    rng = np.random.default_rng(seed)
    for x in random_states(model.n_x, 3, seed):
        p = model.default_parameters * rng.uniform(0.5, 1.5, model.n_p)
        for o in ("jacobian", "tangent_jacobian"):
            yield [getattr(r.compiled, o)(0.0, x, p) for r in results] + \
                [getattr(py, o)(0.0, x, p)]


def test_the_loops_agree_with_every_other_way_of_computing_them(short, tmp_path):
    scene = spatial_arm.scene(LINKS)
    result = run(scene, OUTS, warm=False)
    source = result.rendered.files[f"{result.rendered.prefix}.c"]
    assert "the chain's pair products" in source and f"double PM[{12 * LINKS}]" in source
    assert "double DT[" not in source    # in the output's rows
    assert all(fn.spec.pairs is not None for fn in result.kernel.functions[1:])
    with short.context() as patch:
        patch.setattr(mbgen.codegen.targets.model, "_columns_in_place",
                      lambda view, slots=(): False)
        copied = run(scene, OUTS, warm=False)
    assert "double DT[" in copied.rendered.files[f"{copied.rendered.prefix}.c"]
    with short.context() as patch:
        patch.setattr(split, "SPLIT_CHARS", 2000)
        patch.setattr(split, "PART_CHARS", 2000)
        parts = run(scene, OUTS, warm=False)
    assert "_jacobian_part1(" in parts.rendered.files[f"{parts.rendered.prefix}.c"]
    with short.context() as patch:
        patch.setattr(pairs, "LOOPS_MIN", 99)
        written = run(scene, OUTS, warm=False)
    assert "pair products" not in written.rendered.files[f"{written.rendered.prefix}.c"]
    for J, J_copied, J_parts, J_written, J_py in _jacobians([result, copied, parts, written]):
        assert np.array_equal(J, J_py)
        assert np.array_equal(J, J_copied) and np.array_equal(J, J_parts)
        assert_close(J, J_written, 1e-12)
    report = check(None, result=result, samples=4)
    assert report.ok, report.format()
    assert_within_stack_bounds(result.rendered, tmp_path)


def test_jax_and_casadi_compute_the_loops_too(short):
    jax = pytest.importorskip("jax")
    ca = pytest.importorskip("casadi")
    jax.config.update("jax_enable_x64", True)
    result = run(spatial_arm.scene(LINKS), OUTS + ("parameter_jacobian",), warm=False)
    model = result.compiled
    g = jax.jit(mbgen.jax_function(result, "jacobian"))
    tangent = jax.jit(mbgen.jax_function(result, "tangent_jacobian"))
    jac = mbgen.casadi_function(result).jacobian()
    blocks = dict(zip(jac.name_out(), range(jac.n_out())))
    pattern = np.array(ca.DM(jac.sparsity_out(blocks["jac_dxdt_x"]), 1))
    assert pattern[LINKS:].all()     # u' depends on every state of a chain
    p = model.default_parameters
    for x in random_states(model.n_x, 2, seed=6):
        J = model.jacobian(0.0, x, p)
        assert_close(g(0.0, x, p), J, 1e-12)
        assert_close(tangent(0.0, x, p), model.tangent_jacobian(0.0, x, p), 1e-12)
        assert_close(np.array(jac(0.0, x, p, [], 0)[blocks["jac_dxdt_x"]]), J, 1e-12)


def test_a_long_chain_takes_the_loops_a_short_one_does_not():
    long = run(spatial_arm.scene(pairs.LOOPS_MIN), OUTS[:2], build=False)
    assert long.kernel.functions[1].spec.pairs is not None
    short = run(spatial_arm.scene(pairs.LOOPS_MIN - 1), OUTS[:2], build=False)
    assert short.equations.pairs is not None
    assert short.kernel.functions[1].spec.pairs is None
