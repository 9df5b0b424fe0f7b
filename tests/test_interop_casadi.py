"""``mbgen.casadi_function``: the generated C behind CasADi's external-function interface.

Its values are the compiled C's at seeded random states; its Jacobian ``jac_<name>`` is
mbgen's analytic one (block for block, with the true sparsity) and agrees with CasADi's own
finite differences; it embeds in MX graphs, an ``integrator`` and ``nlpsol`` (the cart-pole
swing-up of ``docs/examples/cartpole_swingup.py``).  The arm's CasADi and JAX functions
agree with ``pin.aba`` and ``computeABADerivatives``, UR5's too (slow).
"""

from __future__ import annotations

import runpy
import subprocess
from pathlib import Path

import numpy as np
import pytest

import mbgen
from checks import assert_close, random_states
from mbgen.errors import MissingExtraError, UsageError
from mbgen.scenes import four_bar, n_link_cart
from models import pendulum

ca = pytest.importorskip("casadi")

ROOT = Path(__file__).resolve().parents[1]
DERIVATIVES = ("rhs", "jacobian", "parameter_jacobian", "input_jacobian")


@pytest.fixture(scope="module")
def cartpole():
    """The cart-pole's CasADi function and its compiled model, of one generation."""
    result = mbgen.run(n_link_cart.scene(1), DERIVATIVES + ("time_derivative", "dopri5"))
    return mbgen.casadi_function(result), result.compiled


def _arguments(model, k=5, seed=3):
    rng = np.random.default_rng(seed)
    for x in random_states(model.n_x, k, seed):
        yield rng.uniform(-1, 1), x, model.default_parameters * rng.uniform(0.5, 1.5, model.n_p), \
            rng.uniform(-2, 2, model.n_r)


def test_values_and_jacobian_blocks_are_the_compiled_c(cartpole):
    f, model = cartpole
    assert f.name_in() == ["t", "x", "p", "r"] and f.name_out() == ["dxdt"]
    jac = f.jacobian()
    assert jac.name() == f"jac_{f.name()}" and jac.class_name() == "External"
    blocks = dict(zip(jac.name_out(), range(jac.n_out())))
    x_pattern = np.array(ca.DM(jac.sparsity_out(blocks["jac_dxdt_x"]), 1))
    assert x_pattern.sum() == 6        # q' = u, and u' of (q1, u1) only: the true sparsity
    assert jac.sparsity_out(blocks["jac_dxdt_t"]).nnz() == 0
    for t, x, p, r in _arguments(model):
        assert_close(np.array(f(t, x, p, r)).ravel(), model.rhs(t, x, p, r), 1e-12)
        out = [np.array(b) for b in jac(t, x, p, r, 0)]
        assert_close(out[blocks["jac_dxdt_x"]], model.jacobian(t, x, p, r), 1e-12)
        assert_close(out[blocks["jac_dxdt_p"]], model.parameter_jacobian(t, x, p, r), 1e-12)
        assert_close(out[blocks["jac_dxdt_r"]], model.input_jacobian(t, x, p, r), 1e-12)
        assert not out[blocks["jac_dxdt_t"]].any()
        assert not model.jacobian(t, x, p, r)[x_pattern == 0].any()


def test_jacobian_agrees_with_casadis_finite_differences(cartpole):
    """CasADi's own central differences of the value-only external, within their error."""
    f, model = cartpole
    fd = mbgen.casadi_function(n_link_cart.scene(1), derivatives=False,
                               options={"enable_fd": True, "fd_method": "central"})
    assert not fd.has_jacobian() if hasattr(fd, "has_jacobian") else True
    t, x, p, r = next(_arguments(model))
    X = ca.MX.sym("x", model.n_x)
    exact = ca.Function("exact", [X], [ca.jacobian(f(t, X, p, r), X)])
    numeric = ca.Function("numeric", [X], [ca.jacobian(fd(t, X, p, r), X)])
    a, b = np.array(exact(x)), np.array(numeric(x))
    assert np.abs(a - b).max() <= 1e-6 * max(1.0, np.abs(a).max())
    assert np.abs(a - b).max() > 0          # the differences are differences


def test_embeds_in_an_integrator(cartpole):
    """CVODES (BDF, Newton with the external's Jacobian) against mbgen's own dopri5; a
    compiled model as the source: dense blocks, and the derivative outputs required."""
    f, model = cartpole
    dense = mbgen.casadi_function(model, name="cartpole_dense")
    assert dense.sparsity_out(0).is_dense() and dense.jacobian().sparsity_out(1).is_dense()
    t, x, p, r = next(_arguments(model))
    assert_close(np.array(dense.jacobian()(t, x, p, r, 0)[1]), model.jacobian(t, x, p, r),
                 1e-12)
    x = ca.MX.sym("x", model.n_x)
    p, r = model.default_parameters, np.array([0.5])
    ode = {"x": x, "ode": f(0, x, p, r)}
    step = ca.integrator("step", "cvodes", ode, 0.0, 1.0,
                         {"abstol": 1e-12, "reltol": 1e-12, "newton_scheme": "direct"})
    x0 = np.array([0.0, 0.4, 0.0, 0.0])
    ours = model.integrate("dopri5", [0.0, 1.0], x0, p, r, rtol=1e-12, atol=1e-12).x[-1]
    assert_close(np.array(step(x0=x0)["xf"]).ravel(), ours, 1e-8)


def test_swing_up_is_solved_by_ipopt_and_holds_in_mbgens_dynamics():
    """Example (a): the NLP solves, and the forces replayed through the compiled right-hand
    side (the same RK4 steps) bring the pole upright."""
    ns = runpy.run_path(str(ROOT / "docs" / "examples" / "cartpole_swingup.py"))
    xs, F, stats = ns["swing_up"](N=30)
    assert stats["success"], stats["return_status"]
    scene = n_link_cart.scene(1)
    model = mbgen.compile(mbgen.Scene("cartpole", scene.model, fixed=scene.parameters))
    x, h = np.array([0.0, np.pi, 0.0, 0.0]), 2.5 / 30
    for force in F:
        k1 = model.rhs(0, x, None, [force])
        k2 = model.rhs(0, x + h / 2 * k1, None, [force])
        k3 = model.rhs(0, x + h / 2 * k2, None, [force])
        k4 = model.rhs(0, x + h * k3, None, [force])
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert np.abs(x).max() < 1e-6 and np.abs(F).max() <= 20 + 1e-6


def test_a_time_dependent_model_fills_the_t_block():
    """A pendulum driven by ``tau + t^2``: ``d u'/dt = 2 t / (m l^2)``."""
    m = pendulum("forced")
    tau, = m.inputs("tau")
    m.torque(m.frame("B"), (tau + mbgen.t ** 2) * m.frame("N").z)
    scene = mbgen.Scene("forced", m, parameters={"l": 1.5, "g": 9.81, "m": 2.0})
    jac = mbgen.casadi_function(scene).jacobian()
    assert jac.sparsity_out(0).nnz() == 1
    dfdt = np.array(jac(0.7, [0.3, -0.2], [1.5, 9.81, 2.0], 0.1, 0)[0]).ravel()
    assert_close(dfdt, [0.0, 2 * 0.7 / (2.0 * 1.5 ** 2)], 1e-12)


@pytest.mark.slow
def test_a_constrained_model_and_a_compiled_source():
    """The four-bar (constraints): the external is its C, the Jacobian its analytic one;
    a compiled model gives dense blocks and must carry the derivative outputs."""
    scene = four_bar.scene()
    model = mbgen.compile(scene, outputs=("rhs", "jacobian", "parameter_jacobian"))
    f = mbgen.casadi_function(model)
    assert f.sparsity_out(0).is_dense()
    x, p = scene.x0(model.layout), model.default_parameters
    assert_close(np.array(f(0, x, p, [])).ravel(), model.rhs(0, x, p), 1e-12)
    assert_close(np.array(f.jacobian()(0, x, p, [], 0)[1]), model.jacobian(0, x, p), 1e-12)
    with pytest.raises(UsageError, match="parameter_jacobian"):
        mbgen.casadi_function(mbgen.compile(scene, outputs=("rhs", "jacobian")))
    with pytest.raises(UsageError, match="parameter_jacobian"):
        mbgen.casadi_function(mbgen.run(scene, ("rhs", "jacobian"), build=False))
    values = mbgen.casadi_function(mbgen.compile(scene, outputs=("rhs",)), derivatives=False)
    assert_close(np.array(values(0, x, p, [])).ravel(), model.rhs(0, x, p), 1e-12)


def test_generate_target_casadi_writes_warning_free_c_and_a_loader(tmp_path):
    done = mbgen.generate(n_link_cart.scene(1), ["casadi"], tmp_path,
                          outputs=DERIVATIVES + ("time_derivative",))
    names = {p.name for p in done.files}
    assert {"n_link_cart_casadi.c", "n_link_cart_casadi.py", "n_link_cart.c"} <= names
    for lang in (["-x", "c", "-std=c99", "-pedantic"], ["-x", "c++"]):
        subprocess.run(["cc" if lang[1] == "c" else "c++", *lang, "-Wall", "-Wextra", "-Werror",
                        "-c", str(tmp_path / "n_link_cart_casadi.c"), "-o", "/dev/null"],
                       check=True)
    loaded = runpy.run_path(str(tmp_path / "n_link_cart_casadi.py"))["load"]()
    x = np.array([0.1, 0.2, 0.3, 0.4])
    ours = mbgen.casadi_function(n_link_cart.scene(1))
    assert_close(np.array(loaded(0, x, [1, 1, 1, 9.81], 0.5)),
                 np.array(ours(0, x, [1, 1, 1, 9.81], 0.5)), 1e-12)
    with pytest.raises(UsageError, match="jacobian, parameter_jacobian, input_jacobian"):
        mbgen.generate(n_link_cart.scene(1), ["casadi"], tmp_path / "b")


def test_without_casadi_the_extra_is_named(monkeypatch):
    import builtins
    real = builtins.__import__
    monkeypatch.setattr(builtins, "__import__", lambda name, *a, **k: (
        (_ for _ in ()).throw(ImportError(name)) if name == "casadi" else real(name, *a, **k)))
    with pytest.raises(MissingExtraError, match=r"mbgen\[casadi\]"):
        mbgen.casadi_function(n_link_cart.scene(1))


def test_the_arm_agrees_with_pinocchio_in_casadi_and_jax():
    """The spatial arm (n = 2, unactuated), one generation for both: values against
    ``pin.aba``, Jacobians (CasADi's ``jac_``, ``jax.jacfwd``) against
    ``computeABADerivatives``."""
    pytest.importorskip("pinocchio")
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    from mbgen.bench.arm_pinocchio import pinocchio_aba, pinocchio_aba_derivatives
    from mbgen.scenes import spatial_arm
    result = mbgen.run(spatial_arm.scene(2), ("rhs", "jacobian", "parameter_jacobian"),
                       build=False)
    f = mbgen.casadi_function(result)
    jac = f.jacobian()
    g = mbgen.jax_function(result)
    value, jacfwd = jax.jit(g), jax.jit(jax.jacfwd(g, 1))
    p = [spatial_arm.link_parameters(2)[k] for k in ("m2", "g")]
    for x in random_states(4, 3, seed=5):
        aba, derivatives = pinocchio_aba(2, x[:2], x[2:]), pinocchio_aba_derivatives(2, x[:2],
                                                                                     x[2:])
        assert_close(np.array(f(0, x, p, [])).ravel()[2:], aba, 1e-10)
        assert_close(np.array(jac(0, x, p, [], 0)[1])[2:], derivatives, 1e-9)
        assert_close(value(0.0, x, p)[2:], aba, 1e-10)
        assert_close(jacfwd(0.0, x, p)[2:], derivatives, 1e-9)


@pytest.mark.slow
def test_ur5_agrees_with_pinocchio_in_casadi_and_jax(tmp_path):
    pin = pytest.importorskip("pinocchio")
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    from mbgen.bench.robot_peers import clean_urdf, robot_file
    from mbgen.model.scene import urdf_scene
    path = clean_urdf(robot_file("ur5")[0], tmp_path)
    result = mbgen.run(urdf_scene(path), ("rhs", "jacobian", "parameter_jacobian",
                                          "input_jacobian"), build=False)
    f = mbgen.casadi_function(result)
    jac = f.jacobian()
    g = mbgen.jax_function(result)
    value, jacfwd = jax.jit(g), jax.jit(jax.jacfwd(g, 1))
    model = pin.buildModelFromUrdf(str(path))
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    data = model.createData()
    n = model.nv
    rng = np.random.default_rng(8)
    for _ in range(3):
        q, v, tau = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-5, 5, n)
        x = np.concatenate([q, v])
        aba = np.array(pin.aba(model, data, q, v, tau))
        pin.computeABADerivatives(model, data, q, v, tau)
        derivatives = np.hstack([data.ddq_dq, data.ddq_dv])
        assert_close(np.array(f(0, x, [9.81], tau)).ravel()[n:], aba, 1e-10)
        blocks = jac(0, x, [9.81], tau, 0)
        assert_close(np.array(blocks[1])[n:], derivatives, 1e-9)
        assert_close(np.array(blocks[3])[n:], data.Minv, 1e-9)
        assert_close(value(0.0, x, None, tau)[n:], aba, 1e-10)
        assert_close(jacfwd(0.0, x, None, tau)[n:], derivatives, 1e-9)
