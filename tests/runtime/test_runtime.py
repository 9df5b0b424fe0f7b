"""The compiled model's Python interface: arrays in, new arrays out, clear errors."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbgen
from mbgen import Output
from mbgen.model.scene import load_scene


@pytest.fixture(scope="module")
def disc():
    return mbgen.compile(load_scene("disc_pendulum"),
                         outputs={"rhs", "mass_matrix", "forcing", "energy"})


X = np.array([0.0, 1.0, 0.5, 0.0])


def test_names_and_defaults(disc):
    assert disc.state_names == ("q1", "q2", "u1", "u2")
    assert disc.parameter_names == ("s", "l", "g", "m")
    assert disc.input_names == ()
    np.testing.assert_array_equal(disc.default_parameters, [1.0, 4.0, 10.0, 1.0])
    assert set(disc.outputs) == {Output.RHS, Output.MASS_MATRIX, Output.FORCING, Output.ENERGY}


def test_notes_equations_at_initial_state(disc):
    # notes: u1' = -8 cos(q2) u2 u1 / (1 + 4 sin q2);
    #        u2' = cos(q2) u1^2/4 + u1^2 sin(2 q2)/2 - 5 sin(q2)/2
    q2, u1, u2 = 1.0, 0.5, 0.0
    expected = [u1, u2, -8 * np.cos(q2) * u2 * u1 / (1 + 4 * np.sin(q2)),
                np.cos(q2) * u1**2 / 4 + u1**2 * np.sin(2 * q2) / 2 - 2.5 * np.sin(q2)]
    np.testing.assert_allclose(disc.rhs(0.0, X), expected, rtol=1e-14, atol=1e-15)


def test_new_array_every_call(disc):
    a = disc.rhs(0.0, X)
    b = disc.rhs(0.0, X)
    assert a is not b and not np.shares_memory(a, b)
    a[:] = 123.0
    np.testing.assert_array_equal(b, disc.rhs(0.0, X))


def test_non_contiguous_and_other_numeric_inputs(disc):
    wide = np.zeros((4, 3))
    wide[:, 1] = X
    np.testing.assert_array_equal(disc.rhs(0.0, wide[:, 1]), disc.rhs(0.0, X))
    np.testing.assert_array_equal(disc.rhs(0, [0, 1, 0.5, 0]), disc.rhs(0.0, X))
    np.testing.assert_array_equal(disc.rhs(np.float32(0), X.astype(np.float32)),
                                  disc.rhs(0.0, X.astype(np.float32).astype(float)))
    np.testing.assert_array_equal(disc.rhs(0.0, X[::-1][::-1]), disc.rhs(0.0, X))


def test_input_arrays_are_not_modified(disc):
    x = X.copy()
    p = disc.default_parameters.copy()
    disc.rhs(0.0, x, p)
    np.testing.assert_array_equal(x, X)
    np.testing.assert_array_equal(p, disc.default_parameters)


@pytest.mark.parametrize("bad", [np.zeros(3), np.zeros(5), np.zeros((4, 1)), 1.0, []])
def test_wrong_length_is_value_error(disc, bad):
    with pytest.raises(ValueError, match=r"shape \(4,\)"):
        disc.rhs(0.0, bad)


def test_wrong_parameter_length(disc):
    with pytest.raises(ValueError, match="parameters p"):
        disc.rhs(0.0, X, np.ones(3))


@pytest.mark.parametrize("bad", [np.array(["a", "b", "c", "d"]), X.astype(complex),
                                 np.array([None] * 4), np.array([True] * 4)])
def test_wrong_dtype_is_type_error(disc, bad):
    with pytest.raises(TypeError, match="real numbers"):
        disc.rhs(0.0, bad)


def test_bad_time(disc):
    with pytest.raises(TypeError, match="time t"):
        disc.rhs("zero", X)


def test_matrix_outputs(disc):
    M = disc.mass_matrix(0.0, X)
    assert M.shape == (2, 2)
    np.testing.assert_allclose(M, M.T)
    F = disc.forcing(0.0, X)
    np.testing.assert_allclose(np.linalg.solve(M, F), disc.rhs(0.0, X)[2:], rtol=1e-13)
    T, V = disc.energy(0.0, X)
    assert T > 0


def test_output_not_generated_is_clear():
    model = mbgen.compile(load_scene("disc_pendulum"))
    with pytest.raises(mbgen.MbgenError, match="not generated"):
        model.energy(0.0, X)


def test_solve_ivp_directly_and_with_args(disc):
    sol = solve_ivp(disc.rhs, (0, 1), X, rtol=1e-10, atol=1e-12)
    sol2 = solve_ivp(disc.rhs, (0, 1), X, rtol=1e-10, atol=1e-12, args=(disc.default_parameters,))
    sol3 = solve_ivp(disc.bind(), (0, 1), X, rtol=1e-10, atol=1e-12)
    assert sol.success
    np.testing.assert_array_equal(sol.y[:, -1], sol2.y[:, -1])
    np.testing.assert_array_equal(sol.y[:, -1], sol3.y[:, -1])


def test_parameters_change_result(disc):
    p = disc.default_parameters.copy()
    p[2] = 20.0  # double gravity: the gravity term of u2' doubles
    base = disc.rhs(0.0, [0, 1, 0, 0])
    heavy = disc.rhs(0.0, [0, 1, 0, 0], p)
    np.testing.assert_allclose(heavy[3], 2 * base[3])


def test_inputs_of_n_link_cart():
    model = mbgen.compile(load_scene("n_link_cart", n=2))
    assert model.input_names == ("F",)
    x = np.zeros(model.n_x)
    pushed = model.rhs(0.0, x, None, [1.0])
    np.testing.assert_array_equal(model.rhs(0.0, x), model.rhs(0.0, x, None, [0.0]))
    assert pushed[3] > 0  # the cart accelerates along the force
    with pytest.raises(ValueError, match="inputs r"):
        model.rhs(0.0, x, None, [1.0, 2.0])


def test_fast_path_sees_a_parameter_array_changed_in_place():
    """Values changed in place and alternating arrays are honoured by the fast path."""
    import mbgen
    from mbgen.model.scene import load_scene

    m = mbgen.compile(load_scene("disc_pendulum"), ("rhs",))
    x = np.full(m.n_x, 0.3)
    p = np.array(m.default_parameters, dtype=float)
    first = m.rhs(0.0, x, p)
    p[:] = p * 1.5 + 0.1
    changed = m.rhs(0.0, x, p)
    assert not np.array_equal(first, changed)
    assert np.array_equal(changed, m.rhs(0.0, x, p.copy()))       # a new array, same values
    other = p.copy()                                                # back and forth
    other[m.parameter_names.index("g")] += 1.0
    assert np.array_equal(m.rhs(0.0, x, p), changed)
    assert not np.array_equal(m.rhs(0.0, x, other), changed)
    assert np.array_equal(m.rhs(0.0, x, p), changed)


def test_fast_path_reads_a_reallocated_array_not_its_freed_memory():
    """``p.resize`` (and ``r``'s) reallocates in place: the next call reads the array's new
    memory.  Grown (the new tail filled) and shrunk back, then refilled: each call equals the
    call with a fresh array of the same values (once it read the freed first buffer)."""
    scene = mbgen.load_scene("n_link_cart", n=2)
    m = mbgen.compile(scene, ("rhs",))
    x = np.full(m.n_x, 0.3)
    p, r = m.default_parameters.copy(), np.array([0.5])
    m.rhs(0.0, x, p, r)                                     # the arrays' first buffers
    for scale in (1.5, 0.7, 2.0):
        for a in (p, r):
            n = a.size
            a.resize(1 << 16, refcheck=False)               # moves: the old block is freed
            a[n:] = -7.0
            a.resize(n, refcheck=False)
        p[:] = m.default_parameters * scale
        r[:] = [scale]
        np.testing.assert_array_equal(m.rhs(0.0, x, p, r), m.rhs(0.0, x, p.copy(), r.copy()))
