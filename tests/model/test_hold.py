"""Holding a posture (:mod:`mbgen.model.hold`): the hold is the joint input it stands for.

On a URDF arm with revolute, continuous and prismatic joints (a torque with its reaction,
a force along a slide), the held model's right-hand side with no input equals the same
model's with the gains at zero and each input set to ``-kp (q - q_ref) - kd u`` by hand,
at seeded states, in the compiled C and the generated Python.
"""

import numpy as np
import pytest

import mbgen
from checks import assert_close, random_states
from mbgen import Output
from mbgen.errors import ModelError
from mbgen.model.hold import hold_gains, hold_posture, reference_name
from urdf_models import ARM_PARTS, urdf, write


def test_the_hold_is_a_pd_torque_at_each_joint(tmp_path):
    m = mbgen.from_urdf(write(tmp_path, urdf(ARM_PARTS)))
    record = hold_posture(m, 7.0, 0.3, reference={"q_elbow": 0.4})
    held = [q for _, q, _, _ in record.joints]
    assert held == ["q_shoulder", "q_elbow", "q_slide", "q_wrist"]
    assert m.defaults_[reference_name("q_elbow")] == 0.4 and m.defaults_["kp_hold"] == 7.0
    result = mbgen.run(m, (Output.RHS,))
    c = result.compiled
    py = mbgen.python_model(result.rendered)
    p = dict(c.parameter_defaults)
    off = {**p, "kp_hold": 0.0, "kd_hold": 0.0}
    n = len(held)
    for x in random_states(2 * n, 6, seed=2, scale=2.0):
        q, u = x[:n], x[n:]
        ref = np.array([p[reference_name(name)] for name in held])
        tau = -7.0 * (q - ref) - 0.3 * u
        expected = c.rhs(0.0, x, off, tau)
        for back in (c, py):
            assert_close(back.rhs(0.0, x, p, np.zeros(n)), expected, 1e-12)


def test_bad_holds_are_named(tmp_path):
    m = mbgen.from_urdf(write(tmp_path, urdf(ARM_PARTS)))
    with pytest.raises(ModelError, match="kp_hold must be a finite number >= 0"):
        hold_posture(m, -1.0, 0.1)
    with pytest.raises(ModelError, match="reference names \\['q_knee'\\]"):
        hold_posture(m, 1.0, 0.1, reference={"q_knee": 0.2})
    with pytest.raises(ModelError, match="must name an input, a coordinate and a speed"):
        hold_posture(m, 1.0, 0.1, joints={"tau_shoulder": ("q_shoulder", "nope")})
    with pytest.raises(ModelError, match="give the gains as KP,KD"):
        hold_gains("50")
    assert hold_gains("50, 0.5") == (50.0, 0.5)
    bare = mbgen.Model("bare")
    bare.coordinates("q")
    with pytest.raises(ModelError, match="no input tau_X with coordinate q_X"):
        hold_posture(bare, 1.0, 0.1)
