"""mbgen's Jacobian of a URDF robot's RHS against Pinocchio's ``computeABADerivatives`` (slow).

The lower block of ``df/dx`` (``x = (q, u)``) is ``du'/d(q, u)``: for a fixed base with
revolute and prismatic joints ``q`` is Pinocchio's configuration and ``u = q'``, so it is
``(ddq_dq, ddq_dv)`` one to one.  A floating base's ``q`` holds the quaternion: its
``ddq_dq`` is in the tangent space, ``du'/dq G`` with ``G = dq'/du``
(:func:`mbgen.tangent_jacobian`).  Panda as shipped has a mimic finger, which
``computeABADerivatives`` refuses: the reference is the hand-coupled model
(``tests/model/test_urdf_robots.py``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbgen
from mbgen.abi import Output
from mbgen.model.scene import urdf_scene
from urdf_models import coupled_reference, coupling

pin = pytest.importorskip("pinocchio")


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["panda", "ur5"])
def test_jacobian_matches_aba_derivatives(robot, tmp_path):
    from mbgen.bench.robot_peers import clean_urdf, robot_file
    path = clean_urdf(robot_file(robot)[0], tmp_path)
    scene = urdf_scene(path)
    compiled = mbgen.compile(scene.__class__(**{**scene.__dict__,
                                                "outputs": (Output.RHS, Output.JACOBIAN)}))
    model = pin.buildModelFromUrdf(str(path))
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    assert all(j.nq == j.nv == 1 for j in list(model.joints)[1:])
    data = model.createData()
    rng = np.random.default_rng(11)
    n = model.nv
    for _ in range(5):
        q, v, tau = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-5, 5, n)
        pin.computeABADerivatives(model, data, q, v, tau)
        J = compiled.jacobian(0.0, np.concatenate([q, v]), None, tau)
        for ours, theirs in ((J[n:, :n], data.ddq_dq), (J[n:, n:], data.ddq_dv)):
            scale = np.abs(theirs).max()
            assert np.abs(ours - theirs).max() <= 1e-9 * scale
        np.testing.assert_array_equal(J[:n, n:], np.eye(n))
        assert not J[:n, :n].any()
    assert Path(path).is_file()


@pytest.mark.slow
def test_floating_base_jacobian_matches_aba_derivatives(tmp_path):
    """Solo-12 on Pinocchio's free-flyer: ``tangent_jacobian`` against ``computeABADerivatives``."""
    from mbgen.bench.robot_peers import clean_urdf, robot_file
    path = clean_urdf(robot_file("solo12")[0], tmp_path)
    scene = urdf_scene(path, floating=True)
    compiled = mbgen.compile(scene.__class__(**{**scene.__dict__,
                                                "outputs": (Output.RHS, Output.JACOBIAN)}))
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    data = model.createData()
    rng = np.random.default_rng(12)
    nq, nv = model.nq, model.nv
    for _ in range(5):
        quat = rng.normal(size=4)
        q = np.concatenate([rng.uniform(-1, 1, 3), quat / np.linalg.norm(quat),
                            rng.uniform(-2, 2, nq - 7)])
        v, tau = rng.uniform(-2, 2, nv), rng.uniform(-5, 5, nv - 6)
        pin.computeABADerivatives(model, data, q, v, np.concatenate([np.zeros(6), tau]))
        x = np.concatenate([q, v])
        dq, dv = mbgen.tangent_jacobian(compiled, x, None, tau)
        for ours, theirs in ((dq, data.ddq_dq), (dv, data.ddq_dv)):
            assert ours.shape == theirs.shape == (nv, nv)
            assert np.abs(ours - theirs).max() <= 1e-9 * np.abs(theirs).max()


@pytest.mark.slow
def test_panda_as_shipped_jacobian_matches_the_hand_coupled_model():
    """Panda as shipped: its second finger follows the first (``<mimic>``, coupled), so
    ``q`` has 8 entries, Pinocchio's ``mimic=True`` ``nq``; its ``computeABADerivatives``
    refuses mimic joints, so the reference is the independent model's RNEA derivatives
    projected through the coupling (``q_full = G q``)."""
    from mbgen.bench.robot_peers import robot_file
    path = robot_file("panda")[0]
    compiled = mbgen.compile(mbgen.from_urdf(path), (Output.RHS, Output.JACOBIAN))
    full = pin.buildModelFromUrdf(str(path))
    full.gravity.linear = np.array([0.0, 0.0, -9.81])
    data = full.createData()
    G, o = coupling(full, {"panda_finger_joint2": ("panda_finger_joint1", 1.0, 0.0)})
    n = G.shape[1]
    assert n == compiled.layout.n_q == pin.buildModelFromUrdf(str(path), mimic=True).nq == 8
    rng = np.random.default_rng(13)
    for _ in range(5):
        q, v, tau = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-5, 5, n)
        a, da_dq, da_dv = coupled_reference(full, data, G, o, np.zeros(full.nv), q, v, tau)
        x = np.concatenate([q, v])
        assert np.abs(compiled.rhs(0.0, x, None, tau)[n:] - a).max() <= 1e-9 * np.abs(a).max()
        J = compiled.jacobian(0.0, x, None, tau)
        for ours, theirs in ((J[n:, :n], da_dq), (J[n:, n:], da_dv)):
            assert np.abs(ours - theirs).max() <= 1e-9 * np.abs(theirs).max()
