"""Batch evaluation in C: (k, n_x) states and (k, n_p) parameter sets in one C loop, the same
bits as k single calls; batches of trajectories; solve_ivp(vectorized=True)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbgen
from checks import random_states
from mbgen.model.scene import load_scene
from mbgen.scenes import four_bar


@pytest.fixture(scope="module")
def pendulum():
    scene = load_scene("disc_pendulum")
    return scene, mbgen.compile(scene, ("rhs", "jacobian", "energy", "mass_matrix", "dopri5"))


def states(k, n, seed=0):
    return random_states(n, k, seed)


def test_rhs_of_a_batch_is_k_single_calls(pendulum):
    _, model = pendulum
    x = states(50, model.n_x)
    out = model.rhs(0.3, x)
    assert out.shape == (50, model.n_x)
    assert np.array_equal(out, np.array([model.rhs(0.3, xi) for xi in x]))


def test_parameter_sets_times_and_matrix_outputs(pendulum):
    _, model = pendulum
    k = 20
    x = states(k, model.n_x, 1)
    p = model.default_parameters * np.random.default_rng(2).uniform(0.5, 2.0, (k, model.n_p))
    t = np.linspace(0.0, 1.0, k)
    jac = model.jacobian(t, x, p)
    assert jac.shape == (k, model.n_x, model.n_x)
    assert np.array_equal(jac, np.array([model.jacobian(ti, xi, pi)
                                         for ti, xi, pi in zip(t, x, p)]))
    # one state, many parameter sets
    e = model.energy(0.0, x[0], p)
    assert np.array_equal(e, np.array([model.energy(0.0, x[0], pi) for pi in p]))
    assert model.mass_matrix(0.0, x).shape == (k, 2, 2)


def test_bad_batches_raise_named_errors(pendulum):
    _, model = pendulum
    with pytest.raises(ValueError, match=r"shape \(4,\) or \(3, 4\)"):
        model.rhs(0.0, states(3, model.n_x), np.ones((3, model.n_p + 1)))
    with pytest.raises(ValueError, match="batch sizes differ"):
        model.rhs(0.0, states(3, model.n_x), np.ones((4, model.n_p)))
    with pytest.raises(ValueError, match=r"t must be a number or have shape \(3,\)"):
        model.rhs(np.zeros(2), states(3, model.n_x))
    p = np.tile(model.default_parameters, (3, 1))
    p[1, 3] = 0.0                                              # zero mass: M singular
    with pytest.raises(mbgen.SingularMassMatrixError, match="batch item 1 of 3"):
        model.rhs(0.0, states(3, model.n_x), p)


def test_solve_ivp_vectorized_matches_the_column_calls(pendulum):
    scene, model = pendulum
    x0 = scene.x0(model.layout)
    plain = solve_ivp(model.bind(), (0, 5), x0, method="BDF", rtol=1e-8, atol=1e-10)
    vec = solve_ivp(model.bind(vectorized=True), (0, 5), x0, method="BDF", rtol=1e-8,
                    atol=1e-10, vectorized=True)
    assert vec.success and vec.nfev == plain.nfev
    assert np.array_equal(vec.y, plain.y)           # the finite-difference Jacobian too


def test_integrate_a_batch_in_c(pendulum):
    scene, model = pendulum
    k = 12
    x0 = scene.x0(model.layout) + 0.1 * states(k, model.n_x, 3)
    p = model.default_parameters * np.random.default_rng(4).uniform(0.8, 1.2, (k, model.n_p))
    t = np.linspace(0.0, 5.0, 11)
    out = model.integrate("dopri5", t, x0, p, rtol=1e-8, atol=1e-10)
    assert out.x.shape == (k, t.size, model.n_x) and not out.status.any()
    for i in range(k):
        single = model.integrate("dopri5", t, x0[i], p[i], rtol=1e-8, atol=1e-10)
        assert np.array_equal(out.x[i], single.x)
        assert out.stats["n_rhs"][i] == single.n_rhs


def test_failed_members_are_recorded_or_raised(pendulum):
    scene, model = pendulum
    p = np.tile(model.default_parameters, (3, 1))
    p[2, 3] = -1.0                                             # negative mass
    t = [0.0, 1.0]
    x0 = scene.x0(model.layout)
    out = model.integrate("dopri5", t, x0, p, on_failure="record")
    assert out.status.tolist() == [0, 0, 1]
    assert "NOT_POSITIVE_DEFINITE" in out.messages[2] and out.messages[0] == ""
    assert np.array_equal(out.x[0], out.x[1])
    with pytest.raises(mbgen.IntegrationError, match="member 2 of 3"):
        model.integrate("dopri5", t, x0, p)


@pytest.fixture(scope="module")
def triple_rocker():
    scene = load_scene("four_bar", dead_point=True)
    return scene, mbgen.compile(scene, ("rhs", "holonomic", "holonomic_jacobian", "dopri5"))


def test_constrained_batch_checks_each_start_like_the_single_call(triple_rocker):
    """A start off the loop is refused (naming the member), as the single call refuses it;
    ``project=False`` integrates it as given, unprojected, as the single call does."""
    scene, model = triple_rocker
    x0 = scene.x0(model.layout)
    off = x0 + np.array([0.0, 0.3, 0.0, 0.0])
    t = np.linspace(0.0, 0.5, 6)
    with pytest.raises(mbgen.ConstraintError):
        model.integrate("dopri5", t, off)
    with pytest.raises(mbgen.ConstraintError, match="member 1 of 2"):
        model.integrate("dopri5", t, np.array([x0, off]), on_failure="record")
    p = np.tile(model.default_parameters, (2, 1))
    p[1, 0] = 2.1                                         # x0 is off the loop of crank 2.1
    with pytest.raises(mbgen.ConstraintError, match="member 1 of 2"):
        model.integrate("dopri5", t, x0, p)
    drift = model.integrate("dopri5", t, np.array([x0, off]), project=False)
    single = model.integrate("dopri5", t, off, project=False)
    assert np.array_equal(drift.x[1], single.x)
    assert drift.stats["max_residual"][1] == single.max_residual > 0.1
    projected = model.integrate("dopri5", t, np.array([x0, x0]))
    assert np.array_equal(projected.x[0], model.integrate("dopri5", t, x0).x)


def test_constrained_batch_names_constraint_failures(triple_rocker):
    """A member started at the dead point fails as the single call does: CONSTRAINT_SINGULAR."""
    scene, model = triple_rocker
    x0 = scene.x0(model.layout)
    lock = four_bar.dead_point_state(four_bar.DEAD_POINT_LENGTHS, 0.0)   # the crank's limit
    dead = model.consistent(lock)
    t = [0.0, 0.5]
    with pytest.raises(mbgen.IntegrationError) as single:
        model.integrate("dopri5", t, dead)
    out = model.integrate("dopri5", t, np.array([x0, dead]), on_failure="record")
    assert out.status.tolist() == [0, single.value.status]
    assert out.messages[1].startswith("FOUR_BAR_CONSTRAINT_SINGULAR: ")
    assert out.messages[1] in str(single.value)
