"""``mbgen.jax_function``: the kernel printed into ``jax.numpy``.

Its values are the compiled C's at seeded random states (1e-12, float64); ``jax.jacfwd`` of
it is the analytic Jacobians (1e-10); ``jit``, ``vmap``, broadcasting and ``grad`` work; the
arm's and UR5's agree with Pinocchio (``tests/test_interop_casadi.py``, with CasADi's); the batched
rollout of ``docs/examples/batched_rollout.py`` has the derivative its finite differences
give; a singular mass matrix is NaN; constraints are refused by name.
"""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest
import sympy as sm

import mbgen
from checks import assert_close, random_states
from mbgen.codegen.targets.jax import JaxPrinter
from mbgen.errors import MissingExtraError, UsageError
from mbgen.scenes import four_bar, n_link_cart

jax = pytest.importorskip("jax")
jax.config.update("jax_enable_x64", True)
jnp = jax.numpy

ROOT = Path(__file__).resolve().parents[1]
OUTPUTS = ("rhs", "jacobian", "parameter_jacobian", "input_jacobian", "mass_matrix",
           "tangent_jacobian")
QUICK = ("rhs", "jacobian", "tangent_jacobian")


@pytest.fixture(scope="module")
def cartpole():
    """Its JAX functions and the compiled model, of one generation."""
    result = mbgen.run(n_link_cart.scene(1), OUTPUTS)
    return {o: mbgen.jax_function(result, o) for o in OUTPUTS}, result.compiled


@pytest.mark.parametrize("outputs", [QUICK, pytest.param(OUTPUTS, marks=pytest.mark.slow)])
def test_values_and_forward_derivatives_equal_the_compiled_c(cartpole, outputs):
    fns, model = cartpole
    f = fns["rhs"]
    jitted = {o: jax.jit(fns[o]) for o in outputs}
    dx, dp, dr = (jax.jit(jax.jacfwd(f, 1)), jax.jit(jax.jacfwd(f, 2)),
                  jax.jit(jax.jacrev(f, 3)))
    rng = np.random.default_rng(4)
    for x in random_states(model.n_x, 3, seed=4):
        p = model.default_parameters * rng.uniform(0.5, 1.5, model.n_p)
        r = rng.uniform(-2, 2, model.n_r)
        for o in outputs:
            assert_close(jitted[o](0.0, x, p, r), getattr(model, o)(0.0, x, p, r), 1e-12)
        assert_close(dx(0.0, x, p, r), model.jacobian(0.0, x, p, r), 1e-10)
        if outputs == OUTPUTS:
            assert_close(dp(0.0, x, p, r), model.parameter_jacobian(0.0, x, p, r), 1e-10)
            assert_close(dr(0.0, x, p, r), model.input_jacobian(0.0, x, p, r), 1e-10)
    assert f(0.0, x).dtype == jnp.float64
    assert f.parameter_names == ("m0", "m1", "l0", "g") and f.input_names == ("F",)


def test_jit_vmap_broadcast_and_grad(cartpole):
    fns, model = cartpole
    f = fns["rhs"]
    X = random_states(model.n_x, 16, seed=9)
    looped = np.array([model.rhs(0.0, x, None, [0.3]) for x in X])
    batched = jax.jit(jax.vmap(f, in_axes=(None, 0, None, None)))(0.0, X, None, jnp.array([0.3]))
    assert_close(batched, looped, 1e-12)
    assert_close(f(0.0, X, None, [0.3]), looped, 1e-12)        # (16, n_x) broadcasts
    assert fns["jacobian"](0.0, X).shape == (16, 4, 4)
    energy = jax.jit(jax.grad(lambda x: jnp.sum(f(0.0, x) ** 2)))(X[0])
    assert_close(energy, 2 * model.jacobian(0.0, X[0]).T @ model.rhs(0.0, X[0]), 1e-10)


def test_a_singular_mass_matrix_is_nan(cartpole):
    fns, _ = cartpole
    assert np.isnan(fns["rhs"](0.0, np.zeros(4), [0.0, 0.0, 1.0, 9.81])).all()
    assert np.isfinite(fns["mass_matrix"](0.0, np.zeros(4), [0.0, 0.0, 1.0, 9.81])).all()


def test_the_printer_writes_no_python_branch():
    x, y = sm.symbols("x y")
    exprs = [sm.Piecewise((x, x > 0), (y * y, y < 1), (2 * y, True)), sm.Min(x, y, 1),
             sm.Max(x, -y), sm.sign(x), sm.Piecewise((x, sm.And(x > 0, y > 0)), (0, True))]
    printer = JaxPrinter({x: "x", y: "y"})
    for e in exprs:
        code = printer.doprint(e)
        assert " if " not in code and "min(" not in code and " and " not in code, code
        fn = jax.jit(eval(f"lambda x, y: {code}", {"jnp": jnp}))
        for a, b in ((0.5, 2.0), (-0.5, 0.5), (-1.0, 3.0)):
            assert float(fn(a, b)) == float(e.subs({x: a, y: b})), (e, a, b)


def test_batched_rollout_derivative_equals_finite_differences():
    """Example (b): 1,024 states, a derivative through the rollout, checked by differences."""
    ns = runpy.run_path(str(ROOT / "docs" / "examples" / "batched_rollout.py"))
    cost, derivative, fd = ns["rollout_derivative"](batch=1024, steps=30)
    assert cost > 0 and abs(derivative - fd) <= 1e-6 * abs(derivative)


def test_a_compiled_model_is_refused(cartpole):
    with pytest.raises(UsageError, match="Scene or Model"):
        mbgen.jax_function(cartpole[1])


@pytest.mark.slow
def test_a_constrained_model_is_refused():
    with pytest.raises(UsageError, match="constraints"):
        mbgen.jax_function(mbgen.run(four_bar.scene(), ("rhs",), build=False))


def test_without_jax_the_extra_is_named(monkeypatch):
    import builtins
    real = builtins.__import__
    monkeypatch.setattr(builtins, "__import__", lambda name, *a, **k: (
        (_ for _ in ()).throw(ImportError(name)) if name == "jax" else real(name, *a, **k)))
    with pytest.raises(MissingExtraError, match=r"mbgen\[jax\]"):
        mbgen.jax_function(n_link_cart.scene(1))
