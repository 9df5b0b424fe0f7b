"""Compiled Jacobians: against the lambdified symbolic Jacobian, finite differences, and in
solve_ivp."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbgen
from heavy import scene_params
from mbgen import Output
from mbgen.model.scene import load_scene
from mbgen.verify.check import check
from models import stiff_pair

SENSITIVITIES = (Output.RHS, Output.JACOBIAN, Output.PARAMETER_JACOBIAN, Output.TIME_DERIVATIVE)


def central_difference(f, x, h=1e-6):
    """``df/dx`` by central differences with a relative step."""
    cols = []
    for i in range(x.size):
        step = h * max(1.0, abs(x[i]))
        e = np.zeros_like(x)
        e[i] = step
        cols.append((f(x + e) - f(x - e)) / (2 * step))
    return np.column_stack(cols)


@pytest.fixture(scope="module", params=scene_params(heavy=True))
def result(request):
    return mbgen.run(load_scene(request.param), outputs=SENSITIVITIES)


def test_against_lambdified_symbolic_jacobians(result):
    report = check(None, result=result, samples=8, rtol=1e-9)
    assert {r.output for r in report.rows} >= {"jacobian", "parameter_jacobian", "time_derivative"}
    assert report.ok, report.format()


def test_against_finite_differences_of_compiled_rhs(result):
    model = result.compiled
    rng = np.random.default_rng(7)
    p = model.default_parameters
    for _ in range(4):
        x = rng.uniform(-1, 1, model.n_x)
        r = rng.uniform(-1, 1, model.n_r)
        t = float(rng.uniform(0, 1))
        J = model.jacobian(t, x, p, r)
        J_fd = central_difference(lambda y, t=t, r=r: model.rhs(t, y, p, r), x)
        scale = max(1.0, np.abs(J_fd).max())
        assert np.abs(J - J_fd).max() <= 1e-6 * scale
        Jp = model.parameter_jacobian(t, x, p, r)
        Jp_fd = central_difference(lambda q, t=t, x=x, r=r: model.rhs(t, x, q, r), p)
        assert np.abs(Jp - Jp_fd).max() <= 1e-6 * max(1.0, np.abs(Jp_fd).max())
        dt = model.time_derivative(t, x, p, r)
        h = 1e-6
        dt_fd = (model.rhs(t + h, x, p, r) - model.rhs(t - h, x, p, r)) / (2 * h)
        assert np.abs(dt - dt_fd).max() <= 1e-6 * max(1.0, np.abs(dt_fd).max())


def test_shapes_and_fresh_arrays(result):
    model = result.compiled
    x = np.linspace(0.1, 0.9, model.n_x)  # distinct values: no coinciding points
    J1, J2 = model.jacobian(0.0, x), model.jacobian(0.0, x)
    assert J1.shape == (model.n_x, model.n_x) and J1 is not J2
    assert model.parameter_jacobian(0.0, x).shape == (model.n_x, model.n_p)
    assert model.time_derivative(0.0, x).shape == (model.n_x,)


class Counted:
    """Wrap a callable and count its calls."""

    def __init__(self, f):
        self.f, self.calls = f, 0

    def __call__(self, *args):
        self.calls += 1
        return self.f(*args)


@pytest.mark.parametrize("method", ["Radau", "BDF", "LSODA"])
def test_jacobian_in_solve_ivp(method):
    scene = stiff_pair()
    model = mbgen.compile(scene, outputs={"rhs", "jacobian"})
    x0, span = scene.x0(model.layout), (0.0, 2.0)
    rhs, jac = Counted(model.rhs), Counted(model.jacobian)
    with_jac = solve_ivp(rhs, span, x0, method=method, jac=jac, rtol=1e-8, atol=1e-10)
    reference = solve_ivp(model.rhs, span, x0, method="Radau", jac=model.jacobian, rtol=1e-11,
                          atol=1e-13)
    assert with_jac.success and jac.calls > 0
    np.testing.assert_allclose(with_jac.y[:, -1], reference.y[:, -1], rtol=1e-5, atol=1e-6)
    plain = Counted(model.rhs)
    solve_ivp(plain, span, x0, method=method, rtol=1e-8, atol=1e-10)
    # a finite-difference Jacobian costs n_x extra RHS calls each time it is formed
    assert rhs.calls < plain.calls


def test_time_derivative_is_zero_without_explicit_time():
    model = mbgen.compile(load_scene("disc_pendulum"), outputs={"time_derivative"})
    np.testing.assert_array_equal(model.time_derivative(0.0, [0.1, 0.2, 0.3, 0.4]), 0.0)
    assert "cholesky" not in model.rendered.source  # no solve when u' has no explicit t
