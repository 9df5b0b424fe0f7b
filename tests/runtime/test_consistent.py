"""``consistent(x)``: Newton on the configuration constraints ends on the loop or raises.

Near the triple rocker's dead point the Jacobian of the dependent coordinates is nearly
singular and Newton's steps are huge: from these starts it once wandered to ``q2 ~ -7900``
and stopped there with a residual of 2.5e-9, 2500 times its tolerance, because the
tolerance grew with the iterate (``tol (1 + max|q_r|)``).  Now the tolerance is fixed by
the state it was given, the result is the state whose residual was checked, and a tolerance
that is not a finite number >= 0 is refused.
"""

import math

import numpy as np
import pytest

import mbgen
import mbgen.abi
from mbgen.errors import ArgumentError
from mbgen.model.scene import load_scene
from mbgen.scenes import four_bar


@pytest.fixture(scope="module")
def triple_rocker():
    scene = load_scene("four_bar", dead_point=True)
    model = mbgen.compile(scene, ("rhs", "holonomic", "holonomic_jacobian"))
    return scene, model


#: Crank angles just below the dead point and far guesses of q2, q3 (seen to go wrong).
DEAD = four_bar.dead_angle(**four_bar.DEAD_POINT_LENGTHS)
STARTS = [(DEAD - 1e-6, -4.0, -0.8), (DEAD - 1e-10, -3.4, -1.9), (DEAD - 1e-10, -3.1, 1.3),
          (DEAD - 1e-10, -3.8, 0.8), (DEAD - 1e-10, -2.8, -1.0)]


@pytest.mark.parametrize("q", STARTS)
def test_near_a_dead_point_the_result_is_on_the_loop_or_an_error(triple_rocker, q):
    _, model = triple_rocker
    x = np.array([*q, 0.0])
    try:
        y = model.consistent(x)
    except mbgen.ConstraintError as exc:
        assert "did not converge" in str(exc) or "singular" in str(exc)
        return
    assert y[0] == x[0]
    assert np.max(np.abs(model.holonomic(0.0, y))) <= 1e-12 * (1.0 + np.max(np.abs(x[:3])))


@pytest.mark.parametrize("tol", [math.nan, math.inf, -1e-12])
def test_a_tolerance_must_be_a_finite_number(triple_rocker, tol):
    scene, model = triple_rocker
    with pytest.raises(ArgumentError, match="tol"):
        model.consistent(scene.x0(model.layout), tol=tol)


def test_the_default_start_is_unchanged(triple_rocker):
    scene, model = triple_rocker
    x0 = scene.x0(model.layout)
    y = model.consistent(x0 + np.array([0.0, 1e-3, -1e-3, 0.0]))
    np.testing.assert_allclose(y, x0, atol=1e-10)


@pytest.mark.parametrize("q", STARTS)
def test_the_integrators_projection_ends_on_the_loop_or_fails(q):
    """The C projection after a step had the same weakness: its tolerance grew with the
    iterate, so Newton wandering off near the dead point was taken for convergence.  From a
    start off the loop (the C function called directly: ``integrate`` refuses such a start)
    every returned row lies on the loop, or the integrator names the failure."""
    scene = load_scene("four_bar", dead_point=True)
    model = mbgen.compile(scene, ("rhs", "dopri5"))
    ffi, lib, prefix = model.ffi, model.lib, model.rendered.prefix
    x0 = np.array([*q, 0.0])
    t = np.array([0.0, 1e-6, 2e-6])
    x_out = np.empty((t.size, model.n_x))
    opt = ffi.new(f"{prefix}_options *", {"rtol": 1e-9, "atol": 1e-12, "h0": 1e-7})
    stats = ffi.new(f"{prefix}_stats *")
    args = [ffi.from_buffer("double[]", x0)]
    if model.n_p:
        args.append(ffi.from_buffer("double[]", model.default_parameters))
    status = getattr(lib, f"{prefix}_dopri5")(*args, t.size, ffi.from_buffer("double[]", t),
                                             ffi.from_buffer("double[]", x_out), opt, stats)
    if status:
        assert mbgen.abi.status_name(status) in ("PROJECTION_FAILED", "CONSTRAINT_SINGULAR")
        return
    for row in x_out[1:]:
        scale = 1.0 + np.max(np.abs(x0[:3]))
        assert np.max(np.abs(model.holonomic(0.0, row))) <= 1e-11 * scale, row


# ------------------------------------------------------------------ issue 28: residual units
@pytest.fixture(scope="module")
def crank_rocker():
    scene = load_scene("four_bar")
    return scene, mbgen.compile(scene, ("rhs", "holonomic", "holonomic_jacobian", "dopri5"))


def _huge_angles(x0):
    """The crank-rocker's start with dependent angles ~1e13 rad: the loop is open by 2.9."""
    x = x0.copy()
    x[1:3] = 1e13, -7e12
    return x


def test_a_start_with_huge_angles_off_the_loop_is_refused(crank_rocker):
    """Issue 28: the start tolerance was 1e-8 (1 + max|q|) = 1e5 here, so a loop open by
    2.9 length units was integrated (and ended open by 3.3).  A residual is a length: it
    is compared with the links' scale plus the rounding floor at 1e13 rad (~0.04)."""
    scene, model = crank_rocker
    x = _huge_angles(scene.x0(model.layout))
    assert np.max(np.abs(model.holonomic(0.0, x))) > 2.5
    t = [0.0, 0.5]
    with pytest.raises(mbgen.ConstraintError, match=r"residual 2\.88, at most 0\.0\d+ allowed"):
        model.integrate("dopri5", t, x)
    with pytest.raises(mbgen.ConstraintError, match="member 1 of 2"):
        model.integrate("dopri5", t, np.array([scene.x0(model.layout), x]))
    # consistent() projects it instead (it took it as given: bound 1e-12 (1 + 1e13) = 10),
    # to the loop as closely as angles of 1e13 rad can be rounded (|q| eps lever arms)
    y = model.consistent(x)
    floor = 8 * np.finfo(float).eps * np.abs(model.holonomic_jacobian(0.0, y)) @ np.abs(y[:3])
    assert np.all(np.abs(model.holonomic(0.0, y)) <= floor) and np.max(floor) < 0.1
    model.integrate("dopri5", t, y)                     # on the loop: accepted


def test_the_start_tolerance_is_the_mechanisms_not_the_angles(crank_rocker):
    """The same loop, scaled: lengths x 1000 allow a 1000 times larger residual (3e-6 is
    closed for links of 2000, open for links of 2), and whole turns of the angles change
    nothing but the rounding floor."""
    scene, model = crank_rocker
    x0 = scene.x0(model.layout)
    p = model.default_parameters.copy()
    big = p.copy()
    big[:4] *= 1000.0                                     # la, lb, lc, ld
    off = x0 + np.array([0.0, 3e-6 / 2000.0, 0.0, 0.0])   # coupler turned: ~3e-6 at 2000
    model.integrate("dopri5", [0.0, 0.1], off, big)
    with pytest.raises(mbgen.ConstraintError):
        model.integrate("dopri5", [0.0, 0.1], x0 + np.array([0.0, 3e-6, 0.0, 0.0]), p)
    turned = x0 + np.array([0.0, 2 * np.pi * 1000, -2 * np.pi * 1000, 0.0])
    model.integrate("dopri5", [0.0, 0.1], model.consistent(turned))
