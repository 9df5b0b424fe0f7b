"""``linearize``: ``A`` and ``B`` equal finite differences of the right-hand side, column by
column and row by row; a tolerance that is not a finite number >= 0 is refused.

* two inputs (a cart pushed by ``F`` with a pendulum driven by ``T``): every column of ``B``
  is ``d rhs / d r_j`` (a ``B`` that kept only the first column failed here, and nowhere else:
  no other model has two inputs);
* a constrained model (the slider-crank, input ``T``): ``B`` has a row for every independent
  state, the speed's included, equal to the finite difference on the loop;
* ``tol=nan`` once accepted any residual (``res > nan`` is false): refused with ``inf`` and
  negative values.
"""

import math
from functools import cache

import numpy as np
import pytest

import mbgen
from mbgen.errors import ArgumentError
from mbgen.model.scene import load_scene
from models import two_input_cart

OUTPUTS = ("rhs", "jacobian", "input_jacobian", "holonomic", "holonomic_jacobian")


@cache
def cart_pendulum():
    return mbgen.compile(two_input_cart(), OUTPUTS[:3])


@cache
def slider_crank():
    scene = load_scene("slider_crank")
    model = mbgen.compile(scene, OUTPUTS)
    return model, model.consistent(scene.x0(model.layout) + np.array([0.3, 0, 0, 0.5]))


def input_differences(model, x, r, h=1e-6):
    """``d rhs / d r`` by central differences, one column per input."""
    cols = []
    for j in range(model.n_r):
        e = np.zeros(model.n_r)
        e[j] = h
        cols.append((model.rhs(0.0, x, None, r + e) - model.rhs(0.0, x, None, r - e)) / (2 * h))
    return np.stack(cols, axis=1)


def test_every_input_has_its_column_of_b():
    model = cart_pendulum()
    x, r = np.array([0.2, 0.4, -0.3, 0.1]), np.array([0.5, -0.2])
    lin = mbgen.linearize(model, x, r=r)
    assert lin.B.shape == (4, 2) and lin.inputs == ("F", "T")
    want = input_differences(model, x, r)
    for j in range(2):
        np.testing.assert_allclose(lin.B[:, j], want[:, j], rtol=1e-7, atol=1e-9)
    assert np.all(np.abs(want[2:, 1]) > 0.1)      # the second column is not trivially zero
    h = 1e-6
    for i in range(4):                              # and A, column by column
        e = np.zeros(4)
        e[i] = h
        col = (model.rhs(0.0, x + e, None, r) - model.rhs(0.0, x - e, None, r)) / (2 * h)
        np.testing.assert_allclose(lin.A[:, i], col, rtol=1e-6, atol=1e-8)


def test_constrained_b_has_the_speed_rows():
    model, x = slider_crank()
    r = np.array([0.4])
    lin = mbgen.linearize(model, x, r=r)
    keep = [model.state_names.index(s) for s in lin.states]
    assert lin.states == ("q1", "u1") and lin.B.shape == (2, 1)
    np.testing.assert_allclose(lin.B, input_differences(model, x, r)[keep], rtol=1e-7,
                               atol=1e-9)
    assert abs(lin.B[1, 0]) > 0.1


@pytest.mark.parametrize("tol", [math.nan, math.inf, -1.0])
def test_a_tolerance_must_be_a_finite_number(tol):
    model, x = slider_crank()
    with pytest.raises(ArgumentError, match="tol"):
        mbgen.linearize(model, x, tol=tol)
    with pytest.raises(ArgumentError, match="tol"):   # unconstrained: checked too
        mbgen.linearize(cart_pendulum(), np.zeros(4), tol=tol)


def test_nan_tolerance_does_not_pass_a_state_off_the_loop():
    model, x = slider_crank()
    with pytest.raises(mbgen.ConstraintError):
        mbgen.linearize(model, x + np.array([0.0, 0.1, 0.0, 0.0]))
    with pytest.raises(ArgumentError):
        mbgen.linearize(model, x + np.array([0.0, 0.1, 0.0, 0.0]), tol=math.nan)
