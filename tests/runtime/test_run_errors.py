"""Errors on the execution side are named, and name the right cause.

* generated Python raises the named error the C reports (or returns the C's finite
  value) where plain Python floats raise ``ZeroDivisionError``, ``ValueError: math
  domain error`` or ``OverflowError``;
* runtime arguments: a complex ``t``, ``t=10**400``, ``max_steps=2**63``, ``rtol=None``
  and bad output times are named errors, never a dropped imaginary part or a raw
  builtin or cffi error;
* C integrator statuses name the cause: rk4 over ``[0, 1e300]`` stops at its step
  limit with steps of the requested size (no stretched step reported as NONFINITE),
  rosenbrock over ``[0, 5e-324]`` reports a step too small, not a singular matrix.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm

import mbgen
from mbgen.abi import INTEGRATOR_STATUS_CODES
from mbgen.errors import (
    ArgumentError,
    ArgumentTypeError,
    IntegrationError,
    MbgenError,
)
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.runtime.python import python_model

STATUS = {name: code for name, code, _ in INTEGRATOR_STATUS_CODES}


def _domain_scene() -> mbgen.Scene:
    """One particle pushed by ``sqrt(q) + 1/(1 + exp(q)) + 1/(q - 2) + log(q + 3)``.

    Python's floats raise where C's do not: sqrt(-1) and log(0) (domain), exp(1000)
    (overflow, yet 1/(1 + inf) = 0 is finite in C), 1/0 at q = 2.
    """
    m = mbgen.Model("domain")
    q, = m.coordinates("q")
    m.speeds("u")
    mass, = m.constants("mass")
    N = m.newtonian()
    P = m.point("P", m.origin, q * N.x)
    m.particle("b", P, mass)
    m.force(P, (sm.sqrt(q) + 1 / (1 + sm.exp(q)) + 1 / (q - 2) + sm.log(q + 3)) * N.x)
    return mbgen.Scene("domain", m, parameters={"mass": 1.0})


@pytest.fixture(scope="module")
def domain():
    result = run(_domain_scene(), ("rhs", "forcing"))
    return result.compiled, python_model(result.rendered)


def _outcome(f):
    try:
        return "ok", f()
    except MbgenError as exc:
        return type(exc).__name__, None


@pytest.mark.parametrize("q, expected", [
    (-1.0, "NonFiniteResultError"),   # sqrt(-1): math domain error in Python
    (-3.0, "NonFiniteResultError"),   # log(0): math domain error in Python, -inf in C
    (2.0, "NonFiniteResultError"),    # 1/0: ZeroDivisionError in Python
    (1000.0, "ok"),                   # exp(1000): OverflowError in Python, 1/(1+inf) = 0 in C
])
def test_python_backend_raises_what_c_raises(domain, q, expected):
    c, py = domain
    x = np.array([q, 0.3])
    for output in ("rhs", "forcing"):
        oc, vc = _outcome(lambda output=output: getattr(c, output)(0.0, x))
        op, vp = _outcome(lambda output=output: getattr(py, output)(0.0, x))
        assert (oc, op) == (expected, expected), output
        if expected == "ok":
            np.testing.assert_array_equal(vc, vp)


def test_generated_module_itself_raises_its_named_errors(domain):
    """Users importing the generated .py directly get NonFinite, not ZeroDivisionError."""
    _, py = domain
    mod = py.module
    with pytest.raises(mod.NonFinite):
        mod.rhs(0.0, np.array([2.0, 0.0]), np.array([1.0]))
    with pytest.raises(mod.NotPositiveDefinite):
        mod.rhs(0.0, np.array([0.5, 0.0]), np.array([0.0]))
    with np.errstate(all="raise"):  # the IEEE retry does not leak warnings or errors
        with pytest.raises(mod.NonFinite):
            mod.rhs(0.0, np.array([-1.0, 0.0]), np.array([1.0]))


def test_spring_pendulum_division_by_zero_is_named_in_both():
    """s = -l makes the spring length 0: a 1/0 in the generated code."""
    result = run(load_scene("spring_pendulum"), ("rhs", "jacobian"))
    c, py = result.compiled, python_model(result.rendered)
    x = np.array([0.1, -1.0, 0.0, 0.0])
    for output in ("rhs", "jacobian"):
        assert _outcome(lambda output=output: getattr(c, output)(0.0, x))[0] == \
            _outcome(lambda output=output: getattr(py, output)(0.0, x))[0] != "ok"


# ------------------------------------------------------------------ runtime arguments
@pytest.fixture(scope="module")
def pendulum():
    result = run(load_scene("spring_pendulum"), ("rhs", "rk4", "rosenbrock", "dopri5"))
    return result.compiled, python_model(result.rendered)


@pytest.mark.parametrize("t, error", [
    (np.complex128(1 + 5j), ArgumentTypeError),
    (np.complex128(1 + 0j), ArgumentTypeError),
    (1j, ArgumentTypeError),
    ("0.5", ArgumentTypeError),
    (None, ArgumentTypeError),
    (10**400, ArgumentError),
    (-(10**400), ArgumentError),
])
def test_bad_time_is_named(pendulum, t, error):
    x = np.array([0.1, 0.0, 0.0, 0.0])
    for model in pendulum:
        with pytest.raises(error) as info:
            model.rhs(t, x)
        assert "time t" in str(info.value)


def test_real_times_of_every_kind_still_work(pendulum):
    c, py = pendulum
    x = np.array([0.1, 0.0, 0.0, 0.0])
    want = c.rhs(0.5, x)
    for t in (np.float32(0.5), np.float64(0.5), np.array(0.5), 1, np.int64(1), True):
        for model in pendulum:
            assert model.rhs(t, x).shape == want.shape


@pytest.mark.parametrize("kw, error", [
    ({"max_steps": 2**63}, ArgumentError),
    ({"max_steps": -1}, ArgumentError),
    ({"max_steps": 1.5}, ArgumentError),
    ({"max_steps": None}, ArgumentTypeError),
    ({"max_steps": "10"}, ArgumentTypeError),
    ({"rtol": None}, ArgumentTypeError),
    ({"atol": "1e-9"}, ArgumentTypeError),
    ({"rtol": 10**400}, ArgumentError),
    ({"rtol": 1j}, ArgumentTypeError),
    ({"h_max": None}, ArgumentTypeError),
    ({"h": 10**400}, ArgumentError),
])
def test_bad_integrator_settings_are_named(pendulum, kw, error):
    c, _ = pendulum
    with pytest.raises(error):
        c.integrate("dopri5", [0.0, 1.0], np.array([0.1, 0.0, 0.0, 0.0]), **kw)


@pytest.mark.parametrize("t_eval", [[0.0, 10**400], [0.0, 1j], "0 1", [[0.0, 1.0]], [1.0, 0.0],
                                    [0.0, np.inf], None])
def test_bad_output_times_are_named(pendulum, t_eval):
    c, _ = pendulum
    with pytest.raises(ArgumentError):
        c.integrate("dopri5", t_eval, np.array([0.1, 0.0, 0.0, 0.0]))


def test_integral_float_step_limit_accepted(pendulum):
    c, _ = pendulum
    run_ = c.integrate("dopri5", [0.0, 0.1], np.array([0.1, 0.0, 0.0, 0.0]), max_steps=1000.0)
    assert run_.n_steps > 0


def test_rk4_over_a_huge_span_reports_the_step_limit(pendulum):
    c, _ = pendulum
    with pytest.raises(IntegrationError) as info:
        c.integrate("rk4", [0.0, 1e300], np.array([0.1, 0.0, 0.0, 0.0]), h=1e-3, max_steps=50)
    assert info.value.status == STATUS["MAX_STEPS"]
    # it took exactly the allowed steps of the requested size h, no stretched step
    assert info.value.t == pytest.approx(50 * 1e-3, rel=1e-12)


def test_rk4_step_limit_across_output_times(pendulum):
    c, _ = pendulum
    x0 = np.array([0.1, 0.0, 0.0, 0.0])
    ok = c.integrate("rk4", [0.0, 0.01, 0.02], x0, h=1e-3, max_steps=20)
    assert ok.n_steps == 20
    with pytest.raises(IntegrationError) as info:
        c.integrate("rk4", [0.0, 0.01, 0.02], x0, h=1e-3, max_steps=19)
    assert info.value.status == STATUS["MAX_STEPS"]
    assert info.value.t == pytest.approx(0.01 + 9e-3)


def test_rosenbrock_over_a_subnormal_span_is_not_a_singular_matrix(pendulum):
    c, _ = pendulum
    with pytest.raises(IntegrationError) as info:
        c.integrate("rosenbrock", [0.0, 5e-324], np.array([0.1, 0.0, 0.0, 0.0]))
    assert info.value.status == STATUS["STEP_TOO_SMALL"]
    assert info.value.status != STATUS["SINGULAR_ITERATION_MATRIX"]


def test_rhs_fast_path_unchanged(pendulum):
    """The lean call path still returns a fresh array and needs no validation."""
    c, _ = pendulum
    x = np.array([0.1, 0.0, 0.0, 0.0])
    a, b = c.rhs(0.0, x), c.rhs(0.0, x)
    assert a is not b and np.array_equal(a, b)


def test_rosenbrock_step_over_a_subnormal_span_is_not_a_singular_matrix():
    from mbgen.codegen.targets import Targets
    from mbgen.runtime.stepper import Stepper

    scene = load_scene("stiff_chain")
    model = mbgen.compile(scene, targets=Targets(step=True))
    s = Stepper(model, "rosenbrock", 0.0, scene.x0(model.layout))
    with pytest.raises(IntegrationError) as info:
        s.step(5e-324)
    assert info.value.status == STATUS["STEP_TOO_SMALL"]


def test_generated_module_accepts_lists(domain):
    _, py = domain
    mod = py.module
    want = mod.rhs(0.0, np.array([0.5, 0.1]), np.array([2.0]))
    np.testing.assert_array_equal(mod.rhs(0.0, [0.5, 0.1], (2.0,)), want)
    with pytest.raises(mod.NonFinite):
        mod.rhs(0.0, [2.0, 0.0], [1.0])
