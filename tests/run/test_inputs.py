"""Inputs that vary in time: InputTable in C, functions of (t, x) for solve_ivp; B of linearize."""

from functools import cache

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbgen
from mbgen import InputTable, Output
from mbgen.scenes import n_link_cart
from mbgen.run.simulate import simulate

OUTPUTS = (Output.RHS, Output.JACOBIAN, Output.INPUT_JACOBIAN, Output.DOPRI5, Output.RK4,
           Output.ROSENBROCK)


@cache
def cart():
    scene = n_link_cart.scene(n=2)
    return scene, mbgen.compile(scene, OUTPUTS)


def push(t_end=2.0, k=41):
    """A smooth push F(t) sampled finely, so that both sides integrate one function."""
    times = np.linspace(0.0, t_end, k)
    return InputTable(times, {"F": 2.0 * np.sin(3.0 * times)})


@pytest.mark.parametrize("method", ["dopri5", "rosenbrock", "rk4"])
def test_c_input_table_agrees_with_solve_ivp_on_the_same_function(method):
    scene, model = cart()
    x0, table = scene.x0(model.layout), push()
    t = np.linspace(0.0, 2.0, 21)
    got = model.integrate(method, t, x0, r=table, rtol=1e-10, atol=1e-12, h=2e-4)
    ref = solve_ivp(model.bind(None, table), (0.0, 2.0), x0, method="DOP853", t_eval=t,
                    rtol=1e-12, atol=1e-12, first_step=1e-4, max_step=0.05)
    assert got.success and got.y.shape == ref.y.shape
    np.testing.assert_allclose(got.y, ref.y, rtol=0, atol=2e-6)
    # the push matters: held at its first value the answer is far away
    held = model.integrate(method, t, x0, r={"F": 0.0}, rtol=1e-10, atol=1e-12, h=2e-4)
    assert np.max(np.abs(held.y - ref.y)) > 1e-2


@pytest.mark.parametrize("method", ["dopri5", "rosenbrock", "rk4"])
def test_a_constant_table_reproduces_constant_inputs_bit_for_bit(method):
    scene, model = cart()
    x0, t = scene.x0(model.layout), np.linspace(0.0, 1.0, 11)
    const = model.integrate(method, t, x0, r=np.array([0.8]), h=1e-3)
    table = model.integrate(method, t, x0, r=InputTable([0.0, 0.5, 3.0], [[0.8]] * 3), h=1e-3)
    assert np.array_equal(const.x, table.x)


def test_simulate_takes_a_function_of_time_and_state():
    scene, model = cart()
    x0 = scene.x0(model.layout)

    def feedback(t, x):  # a damping push on the cart: only Python can do this
        return np.array([-3.0 * x[model.state_names.index("u0")] + np.sin(t)])

    traj = simulate(model, x0, (0.0, 1.0), r=feedback, rtol=1e-10, atol=1e-12, progress=False)
    assert traj.method == "DOP853" and "Python function" in traj.message
    ref = solve_ivp(lambda t, x: model.rhs(t, x, None, feedback(t, x)), (0.0, 1.0), x0,
                    method="DOP853", rtol=1e-10, atol=1e-12, t_eval=traj.t)
    np.testing.assert_allclose(traj.x, ref.y.T, rtol=0, atol=1e-8)
    in_c = simulate(model, x0, (0.0, 2.0), r=push(), rtol=1e-10, atol=1e-12)
    assert in_c.method == "C dopri5"  # a table stays in C


def test_bad_tables_are_refused():
    scene, model = cart()
    with pytest.raises(ValueError, match="strictly increasing"):
        InputTable([0.0, 0.0, 1.0], [[1.0]] * 3)
    with pytest.raises(ValueError, match="one row per time"):
        InputTable([0.0, 1.0], [[1.0]] * 3)
    with pytest.raises(ValueError, match="finite"):
        InputTable([0.0, 1.0], [[1.0], [np.nan]])
    with pytest.raises(mbgen.UnknownNameError, match="did you mean 'F'"):
        model.integrate("dopri5", [0.0, 1.0], scene.x0(model.layout),
                        r=InputTable([0.0, 1.0], {"f": [0.0, 1.0]}))
    with pytest.raises(ValueError, match="one trajectory"):
        model.integrate("dopri5", [0.0, 1.0], np.zeros((2, model.n_x)), r=push())


def test_linearize_gives_b_for_an_unconstrained_scene_with_inputs():
    scene, model = cart()
    x = scene.x0(model.layout)
    lin = mbgen.linearize(model, x, r={"F": 0.3})
    assert lin.B.shape == (model.n_x, 1) and lin.inputs == ("F",)
    eps = 1e-6
    fd = (model.rhs(0.0, x, None, {"F": 0.3 + eps}) - model.rhs(0.0, x, None, {"F": 0.3 - eps}))
    np.testing.assert_allclose(lin.B[:, 0], fd / (2 * eps), rtol=1e-6, atol=1e-8)
    assert np.any(lin.B[model.n_x // 2:, 0] != 0)  # the push accelerates
