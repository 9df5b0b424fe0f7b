"""Singular is singular: the pivot tests are relative to the matrix's scale, in every back end.

* a particle on a circle at the angle ``q1 + 3 q2`` has the rank-one mass matrix
  ``m l^2 [[1, 3], [3, 9]]``: its ``L D L^T`` pivot is rounding noise (``+-1e-16``, or
  exactly 0), and the compiled C, the generated Python and the lambdified reference all
  raise :class:`~mbgen.errors.SingularMassMatrixError` at every state (before, the C
  returned an answer wherever the noise was positive and the reference raised a bare
  ``LinAlgError``);
* the four-bar with a zero-length crank: the independent speed ``u1`` moves no mass, so
  the reduced mass matrix ``T^T M T`` cancels to rounding noise; every back end raises
  :class:`~mbgen.errors.SingularMassMatrixError` instead of accelerations of 1e16, on the
  unrolled and on the dense-loop path;
* the triple rocker at its dead point: the constraint block ``A_r`` is singular, and every
  back end raises :class:`~mbgen.errors.SingularConstraintError` (the reference by the C's
  LU rule, no longer by a rank of its own);
* Rosenbrock's iteration matrix ``I / (h gamma) - J``, singular to rounding, is recognised
  (not factorised with a 1e-16 pivot): the attempt is rejected before any stage runs and a
  shorter step goes on;
* a nearly singular but well-posed mass matrix (a crank of 1e-6) still gives its answer, and
  the test is per column (invariant under a change of units): a diagonal mass matrix with
  entries 1e-20 and 1 is solved exactly.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
import sympy as sm

import mbgen
import mbgen.codegen.targets.model
from mbgen.abi import INTEGRATOR_STATUS_CODES
from mbgen.codegen.solver import PIVOT_ULPS
from mbgen.errors import SingularConstraintError, SingularMassMatrixError
from mbgen.runtime import lambdified
from mbgen.scenes import four_bar

STATUS = {name: code for name, code, _ in INTEGRATOR_STATUS_CODES}


def lever_scene() -> mbgen.Scene:
    """A particle at ``l (cos a, sin a)``, ``a = q1 + 3 q2``: two speeds, one direction of
    motion."""
    m = mbgen.Model("lever")
    q1, q2 = m.coordinates("q1 q2")
    m.speeds("u1 u2")
    l, mass, g = m.constants("l m g")
    N = m.newtonian()
    a = q1 + 3 * q2
    P = m.point("P", m.origin, l * sm.cos(a) * N.x + l * sm.sin(a) * N.y)
    m.particle("bob", P, mass)
    m.gravity(-g * N.y)
    return mbgen.Scene("lever", m, parameters={"l": 0.7, "m": 1.3, "g": 9.81})


def back_ends(result):
    c = result.compiled
    return (c, mbgen.python_model(result.rendered),
            mbgen.LambdifiedModel(result.baked, c.outputs, layout=c.layout))


@cache
def lever():
    return back_ends(mbgen.run(lever_scene(), ("rhs", "jacobian", "mass_matrix")))


@cache
def four_bar_models():
    return back_ends(mbgen.run(four_bar.scene()))


def zero_crank(model, la=0.0):
    """The four-bar's parameters with crank length ``la`` and a state on its loop."""
    scn = four_bar.scene()
    p = {**scn.parameters, "la": la}
    return model.consistent(scn.x0(model.layout), p=p), p


@pytest.mark.parametrize("seed", range(4))
def test_a_rank_one_mass_matrix_is_singular_in_every_back_end(seed):
    x = np.random.default_rng(seed).uniform(-1.0, 1.0, 4)
    for model in lever():
        for output in ("rhs", "jacobian"):
            with pytest.raises(SingularMassMatrixError):
                getattr(model, output)(0.0, x)


def test_a_zero_length_crank_is_singular_in_every_back_end():
    models = four_bar_models()
    x, p = zero_crank(models[0])
    for model in models:
        for output in ("rhs", "constraint_forces"):
            with pytest.raises(SingularMassMatrixError, match="not positive definite"):
                getattr(model, output)(0.0, x, p)


def test_a_zero_length_crank_is_singular_on_the_dense_loop_path(monkeypatch):
    monkeypatch.setattr(mbgen.codegen.targets.model, "UNROLL_MAX", 0)
    result = mbgen.run(four_bar.scene(), ("rhs", "holonomic", "holonomic_jacobian"))
    assert "for (j = 0; j < 1; ++j)" in result.rendered.source
    c, py = result.compiled, mbgen.python_model(result.rendered)
    x, p = zero_crank(c)
    for model in (c, py):
        with pytest.raises(SingularMassMatrixError):
            model.rhs(0.0, x, p)
    x, p = zero_crank(c, la=1.0)
    np.testing.assert_allclose(py.rhs(0.0, x, p), c.rhs(0.0, x, p), rtol=1e-12)


def test_the_dead_point_is_a_singular_constraint_in_every_back_end():
    models = back_ends(mbgen.run(four_bar.scene(dead_point=True)))
    lock = four_bar.dead_point_state(four_bar.DEAD_POINT_LENGTHS, 0.0)
    x = models[0].consistent(lock)
    for model in models:
        for output in ("rhs", "constraint_forces"):
            with pytest.raises(SingularConstraintError):
                getattr(model, output)(0.0, x)


def test_a_short_crank_is_not_singular():
    """A crank of 1e-6: the reduced mass ~1e-12 is far above rounding (~1e-15), so every back
    end answers; they agree to the conditioning (~1e-3 of the terms cancel)."""
    c, py, ref = four_bar_models()
    x, p = zero_crank(c, la=1e-6)
    want = ref.rhs(0.0, x, p)
    assert np.all(np.isfinite(want))
    for model in (c, py):
        np.testing.assert_allclose(model.rhs(0.0, x, p), want, rtol=1e-2, atol=1e-9)


def test_the_test_is_per_column():
    """Two particles of masses 1e-20 and 1: ``M = diag(1e-20, 1)`` is far from singular."""
    m = mbgen.Model("pair")
    x1, x2 = m.coordinates("x1 x2")
    m.speeds("v1 v2")
    m1, m2 = m.constants("m1 m2")
    N = m.newtonian()
    for name, q, mass in (("a", x1, m1), ("b", x2, m2)):
        P = m.point(f"P{name}", m.origin, q * N.x)
        m.particle(name, P, mass)
        m.force(P, -q * N.x)
    result = mbgen.run(mbgen.Scene("pair", m, parameters={"m1": 1e-20, "m2": 1.0}), ("rhs",))
    x = np.array([2.0, 3.0, 0.0, 0.0])
    for model in back_ends(result):
        np.testing.assert_allclose(model.rhs(0.0, x), [0.0, 0.0, -2e20, -3.0], rtol=1e-15)


def test_the_reference_has_the_generated_rule():
    assert lambdified.PIVOT_ULPS == PIVOT_ULPS


def test_rosenbrock_meets_its_singular_iteration_matrix():
    """``x'' = k x`` with ``h = 1 / (gamma sqrt(k))``: ``I / (h gamma) - J`` is singular but
    for rounding whenever the step is ``h``.  Such an attempt is recognised by the LU's
    pivot rule and rejected before its stages run (an attempt factorised with a 1e-16 pivot
    would have called the right-hand side for every stage), and the run reaches
    ``cosh(sqrt(k) t)``."""
    m = mbgen.Model("unstable")
    q, = m.coordinates("q")
    m.speeds("u")
    k, = m.constants("k")
    N = m.newtonian()
    P = m.point("P", m.origin, q * N.x)
    m.particle("b", P, 1.0)
    m.force(P, k * q * N.x)
    c = mbgen.compile(mbgen.Scene("unstable", m, parameters={"k": 10.0}),
                      outputs=("rhs", "jacobian", "rosenbrock"))
    gamma = 0.25   # Rodas4
    h = 1.0 / (gamma * np.sqrt(10.0))

    def stage_calls(run):       # right-hand sides inside attempts: not the first, not the FSAL
        return run.n_rhs - 1 - run.n_steps

    regular = c.integrate("rosenbrock", [0.0, 2.0], np.array([1.0, 0.0]), h=0.9 * h,
                          h_max=0.9 * h)
    per_attempt = stage_calls(regular) / regular.n_lu
    assert per_attempt == int(per_attempt) > 0
    run = c.integrate("rosenbrock", [0.0, 2.0], np.array([1.0, 0.0]), h=h, h_max=h)
    assert run.n_rejected >= 1
    assert stage_calls(run) < per_attempt * run.n_lu        # some attempt ran no stage
    assert run.x[-1, 0] == pytest.approx(np.cosh(np.sqrt(10.0) * 2.0), rel=1e-4)
