"""Bad constrained input gets a named error that says what to do."""

import numpy as np
import pytest

import mbgen
from mbgen import Model


def space(name):
    """A free particle in space under gravity: coordinates x y z, speeds ux uy uz."""
    m = Model(name)
    x, y, z = m.coordinates("x y z")
    ux, uy, uz = m.speeds("ux uy uz")
    N = m.newtonian()
    m.particle("p", m.point("P", m.origin, x * N.x + y * N.y + z * N.z), 1.0)
    m.gravity(-9.81 * N.z)
    return m, (x, y, z), (ux, uy, uz)


def derive_error(m):
    with pytest.raises(mbgen.ModelError) as exc:
        mbgen.compile(mbgen.Scene(m.name, m), ("rhs",))
    return str(exc.value)


def test_more_constraints_than_speeds():
    m, (x, y, z), (ux, uy, uz) = space("too_many")
    m.nonholonomic([ux, uy, uz], [ux, uy, uz])
    assert "at least one speed must stay independent" in derive_error(m)


def test_more_configuration_constraints_than_coordinates_is_refused_where_stated():
    m, (x, y, z), _ = space("too_many_q")
    with pytest.raises(mbgen.ModelError, match="dependent"):
        m.holonomic([x - 1, y - 1, z - 1, x + y], [x, y, z])


def test_dependent_coordinate_no_constraint_contains():
    m, (x, y, z), _ = space("dep_q")
    m.holonomic([x - 1], [y])
    assert "does not contain its dependent coordinate y" in derive_error(m)


def test_dependent_speed_no_constraint_contains():
    m, _, (ux, uy, uz) = space("dep_u")
    m.nonholonomic([ux - 1], [uy])
    assert "dependent speed uy appears in no constraint" in derive_error(m)


def test_motion_constraint_not_linear_in_the_speeds():
    m, _, (ux, uy, uz) = space("nonlin")
    m.nonholonomic([ux**2 - uy], [uy])
    assert "not linear in the speeds" in derive_error(m)


def test_redundant_constraints():
    m, _, (ux, uy, uz) = space("redundant")
    m.nonholonomic([ux - uy, 2 * ux - 2 * uy], [ux, uy])
    text = derive_error(m)
    assert "redundant" in text or "rank" in text, text


def test_configuration_constraint_with_speeds():
    m, (x, y, z), (ux, uy, uz) = space("hol_u")
    m.holonomic([x - ux], [x])
    assert "contains speeds" in derive_error(m)


@pytest.fixture(scope="module")
def sphere():
    """The particle hanging on a sphere of radius 1 (z dependent, z < 0 near the bottom)."""
    m, (x, y, z), _ = space("sphere")
    m.holonomic([x**2 + y**2 + z**2 - 1], [z])
    return mbgen.compile(mbgen.Scene("sphere", m), ("rhs", "jacobian", "holonomic",
                                                      "holonomic_jacobian", "dopri5"))


def test_initial_state_off_the_constraint_is_refused_with_the_fix(sphere):
    bad = np.array([0.3, 0.2, -0.5, 0.1, 0.0])     # z = -0.5 is not on the sphere
    assert abs(sphere.holonomic(0, bad)[0]) > 0.1
    t = np.linspace(0, 1, 5)
    with pytest.raises(mbgen.ConstraintError, match=r"model.consistent\(x0\)"):
        sphere.integrate("dopri5", t, bad)
    with pytest.raises(mbgen.ConstraintError, match="consistent"):
        mbgen.linearize(sphere, bad)
    good = sphere.consistent(bad)
    assert abs(sphere.holonomic(0, good)[0]) < 1e-12 and good[2] < 0
    run = sphere.integrate("dopri5", t, good)
    # dense output between projected steps
    assert np.max(np.abs([sphere.holonomic(0, xi)[0] for xi in run.x])) < 1e-6
    drift = sphere.integrate("dopri5", t, bad, project=False)   # asked for: taken as given
    assert np.allclose(drift.x[0], bad)


def test_no_solution_is_named_with_its_residual(sphere):
    with pytest.raises(mbgen.ConstraintError, match="residual"):
        sphere.consistent(np.array([3.0, 3.0, -0.5, 0.0, 0.0]))   # x^2 + y^2 > 1: no z


def test_constraint_force_of_a_model_without_constraints():
    scene = mbgen.load_scene("disc_pendulum")
    with pytest.raises(mbgen.MbgenError, match="constraint"):
        mbgen.compile(scene, ("rhs", "constraint_forces"))
