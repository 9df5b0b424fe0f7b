"""Numbers by name: p, r and x as mappings in every runtime call, bit-identical to arrays."""

from fractions import Fraction
from functools import cache

import numpy as np
import pytest
from sympy.physics.mechanics.models import n_link_pendulum_on_cart

import mbgen
from mbgen import InputTable, Output, UnknownNameError
from mbgen.errors import ArgumentError, ArgumentTypeError
from mbgen.runtime.named import did_you_mean, vector
from mbgen.scenes import n_link_cart

OUTPUTS = (Output.RHS, Output.JACOBIAN, Output.INPUT_JACOBIAN, Output.DOPRI5)


@cache
def builtin():
    return mbgen.compile(n_link_cart.scene(n=2), OUTPUTS)


@cache
def imported():
    eq = mbgen.from_sympy(n_link_pendulum_on_cart(2, cart_force=True), name="sympy_cart")
    return mbgen.compile(eq, OUTPUTS, parameters=dict.fromkeys(("g", "l0", "l1", "m0", "m1",
                                                                "m2"), 1.0))


def by_name(model, values: dict) -> np.ndarray:
    return np.array([values[n] for n in model.parameter_names])


def test_parameter_orders_differ_between_builtin_and_from_sympy():
    """The reason for names: the same model has p in another order through from_sympy."""
    a, b = builtin(), imported()
    assert sorted(a.parameter_names) == sorted(b.parameter_names)
    assert a.parameter_names != b.parameter_names
    assert a.state_names == b.state_names and a.input_names == b.input_names


@pytest.mark.parametrize("which", [builtin, imported])
def test_by_name_is_bit_identical_to_positional(which):
    model = which()
    rng = np.random.default_rng(1)
    values = dict(zip(model.parameter_names, rng.uniform(0.5, 2.0, model.n_p)))
    x = rng.uniform(-1, 1, model.n_x)
    p, r = by_name(model, values), np.array([0.7])
    xs = dict(zip(model.state_names, x))
    for fn in (model.rhs, model.jacobian, model.input_jacobian):
        want = fn(0.3, x, p, r)
        assert np.array_equal(fn(0.3, xs, values, {"F": 0.7}), want)
        assert np.array_equal(fn(0.3, x, values, {"F": 0.7}), want)
    assert np.array_equal(model.bind(values, {"F": 0.7})(0.3, x), model.rhs(0.3, x, p, r))
    t = np.linspace(0, 1, 5)
    a = model.integrate("dopri5", t, xs, values, {"F": 0.7})
    b = model.integrate("dopri5", t, x, p, r)
    assert np.array_equal(a.x, b.x) and a.n_rhs == b.n_rhs


def test_same_numbers_by_name_give_the_same_physics_in_both_orders():
    a, b = builtin(), imported()
    values = {"g": 9.81, "l0": 1.1, "l1": 0.9, "m0": 2.0, "m1": 0.5, "m2": 0.7}
    x = {"q1": 0.3, "q2": -0.2, "u0": 0.1}
    fa, fb = a.rhs(0.0, x, values, {"F": 0.4}), b.rhs(0.0, x, values, {"F": 0.4})
    np.testing.assert_allclose(fa, fb, rtol=1e-12, atol=1e-12)
    # positional with one model's order in the other is wrong physics: names matter
    wrong = b.rhs(0.0, x, by_name(a, values), {"F": 0.4})
    assert not np.allclose(wrong, fa)


def test_missing_names_take_defaults_and_zeros():
    model = builtin()
    x0 = np.zeros(model.n_x)
    assert np.array_equal(model.rhs(0.0, {}, {}, {}), model.rhs(0.0, x0))
    g = dict(zip(model.parameter_names, model.default_parameters))["g"]
    changed = model.rhs(0.0, {"q1": 0.4}, {"g": 2 * g})
    p = model.default_parameters.copy()
    p[model.parameter_names.index("g")] = 2 * g
    x = x0.copy()
    x[model.state_names.index("q1")] = 0.4
    assert np.array_equal(changed, model.rhs(0.0, x, p))


def test_a_parameter_without_default_must_be_named():
    eq = mbgen.from_sympy(n_link_pendulum_on_cart(1, cart_force=True), name="nodefault")
    model = mbgen.compile(eq, [Output.RHS], parameters={"g": 9.81})
    with pytest.raises(UnknownNameError, match=r"no value for parameters \['l0', 'm0', 'm1'\]"):
        model.rhs(0.0, np.zeros(model.n_x), {"g": 1.0})
    full = {"g": 1.0, "l0": 1.0, "m0": 1.0, "m1": 1.0}
    assert model.rhs(0.0, np.zeros(model.n_x), full).shape == (model.n_x,)


def test_unknown_names_say_did_you_mean():
    model = builtin()
    x = np.zeros(model.n_x)
    with pytest.raises(UnknownNameError, match=r"'gg' is not one of the parameters .*did you "
                                               r"mean 'g'\?"):
        model.rhs(0.0, x, {"gg": 1.0})
    with pytest.raises(UnknownNameError, match=r"'q7' is not one of the states.*did you mean"):
        model.rhs(0.0, {"q7": 1.0})
    with pytest.raises(UnknownNameError, match=r"'Force' is not one of the inputs"):
        model.integrate("dopri5", [0, 1], x, r={"Force": 1.0})
    with pytest.raises(ValueError):  # UnknownNameError is a ValueError too
        model.bind({"mass": 1.0})
    assert did_you_mean("zzz", ["g", "l0"]) == ""


def test_sequences_by_name_make_a_batch():
    model = builtin()
    x = np.full(model.n_x, 0.1)
    g = [1.0, 5.0, 9.81]
    batch = model.rhs(0.0, x, {"g": g})
    assert batch.shape == (3, model.n_x)
    for k, gk in enumerate(g):
        assert np.array_equal(batch[k], model.rhs(0.0, x, {"g": gk}))
    res = model.integrate("dopri5", [0.0, 0.5], x, {"g": g})
    one = model.integrate("dopri5", [0.0, 0.5], x, {"g": 5.0})
    assert np.array_equal(res.x[1], one.x)
    with pytest.raises(ValueError, match="differ in length"):
        vector({"a": [1, 2], "b": [1, 2, 3]}, ["a", "b"], "parameters")


def test_wrong_values_by_name_are_named_errors():
    model = builtin()
    with pytest.raises(TypeError, match="parameters 'g' must be a real number"):
        model.rhs(0.0, np.zeros(model.n_x), {"g": "heavy"})


@pytest.mark.parametrize("value", [None, 1 + 2j, np.complex128(0.5), "9.81", b"9.81", True,
                                   [1.0, None], [1.0, 2j], ["1", "2"], {"g": 1.0}, object()])
def test_non_real_values_by_name_are_refused_naming_the_entry(value):
    """``None`` became NaN, a complex its real part, ``"9.81"`` the number: each is a
    TypeError (ArgumentTypeError) that names the entry, in p, x and r alike."""
    model = builtin()
    x = np.zeros(model.n_x)
    for call in (lambda: model.rhs(0.0, x, {"g": value}),
                 lambda: model.integrate("dopri5", [0.0, 0.1], x, {"g": value})):
        with pytest.raises(ArgumentTypeError, match="parameters 'g' must be a real number"):
            call()
    state = model.state_names[0]
    with pytest.raises(ArgumentTypeError, match=f"states '{state}'"):
        model.rhs(0.0, {state: value})
    with pytest.raises(ArgumentTypeError, match="inputs 'F'"):
        model.rhs(0.0, x, None, {"F": value})
    with pytest.raises(ArgumentTypeError, match="InputTable"):
        InputTable([0.0, 1.0], {"F": [0.0, value]})


def test_real_values_of_every_kind_by_name_still_work():
    model = builtin()
    x = np.zeros(model.n_x)
    want = model.rhs(0.0, x, {"g": 4.0})
    for value in (4, 4.0, np.float32(4.0), np.int64(4), Fraction(8, 2), np.array(4.0)):
        assert np.array_equal(model.rhs(0.0, x, {"g": value}), want)
    assert model.rhs(0.0, x, {"g": [4, Fraction(8, 2), np.float32(4.0)]}).shape == (3, model.n_x)
    with pytest.raises(ArgumentError, match="too large"):
        model.rhs(0.0, x, {"g": 10**400})
