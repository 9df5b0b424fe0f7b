"""``from_mjcf(..., contacts=...)``: sites and bodies as rigid point contacts, against MuJoCo.

The reference is built from MuJoCo's own quantities at the same state: the mass matrix
(``mj_fullM``), ``qfrc_bias``, the contact points' Jacobians (``mj_jacSite``, ``mj_jacBody``:
translation, world components) and their drift :math:`\\dot J v` (the Jacobian times ``qvel``
differentiated along ``mj_integratePos``), solved as ``[M -J^T; J 0] [qacc; lambda] =
[qfrc_applied - qfrc_bias; -Jdot v]``.
"""

from __future__ import annotations

import numpy as np
import pytest

import mbgen
from mbgen.errors import MjcfError

mujoco = pytest.importorskip("mujoco")

WALKER = """
<mujoco model="walker">
  <option gravity="0 0 -9.81"><flag contact="disable"/></option>
  <worldbody>
    <body name="trunk" pos="0 0 1" euler="10 -20 30">
      <freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.05" mass="4"/>
      <body name="thigh" pos="0.1 0.05 -0.05">
        <joint name="hip" type="hinge" axis="0 1 0.2"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03" mass="1"/>
        <body name="shank" pos="0 0 -0.3" euler="0 10 0">
          <joint name="knee" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.02 0 -0.3" size="0.02" mass="0.5"/>
          <site name="toe" pos="0.02 0.01 -0.31"/>
        </body>
      </body>
      <body name="arm" pos="-0.1 -0.05 -0.05">
        <joint name="swing" type="hinge" axis="1 0 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03" mass="0.8"/>
        <body name="paw" pos="0.01 0 -0.42" euler="30 0 0">
          <geom type="sphere" size="0.02" mass="0.1"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def mujoco_contact_dynamics(mj, data, qpos, qvel, tau, sites, bodies):
    """``(qacc, lambda)`` from MuJoCo's quantities (module docstring)."""
    def jacobian(q):
        data.qpos[:] = q
        mujoco.mj_forward(mj, data)
        rows = []
        for kind, i in [("site", s) for s in sites] + [("body", b) for b in bodies]:
            jp = np.zeros((3, mj.nv))
            (mujoco.mj_jacSite if kind == "site" else mujoco.mj_jacBody)(mj, data, jp, None, i)
            rows.append(jp)
        return np.vstack(rows)

    h = 1e-6
    moved = []
    for s in (1, -1):
        q = qpos.copy()
        mujoco.mj_integratePos(mj, q, qvel, s * h)
        moved.append(jacobian(q) @ qvel)
    drift = (moved[0] - moved[1]) / (2 * h)
    data.qvel[:], data.qfrc_applied[:] = qvel, tau
    J = jacobian(qpos)
    M = np.zeros((mj.nv, mj.nv))
    mujoco.mj_fullM(mj, data, M)
    m = J.shape[0]
    K = np.block([[M, -J.T], [J, np.zeros((m, m))]])
    y = np.linalg.solve(K, np.concatenate([tau - data.qfrc_bias, -drift]))
    return y[:mj.nv], y[mj.nv:]


def test_a_site_and_a_body_held_match_mujocos_saddle_point():
    mj = mujoco.MjModel.from_xml_string(WALKER)
    model = mbgen.from_mujoco(mj, contacts=["toe", "paw"])
    assert [c.name for c in model.contacts_] == ["toe", "paw"]
    res = mbgen.run(model, ("rhs", "constraint_forces"), build=False)
    py = mbgen.python_model(res.rendered)
    data = mujoco.MjData(mj)
    site, body = mj.site("toe").id, mj.body("paw").id
    rng = np.random.default_rng(2)
    for _ in range(3):
        qpos = np.array(mj.qpos0)
        qpos[:3] = rng.uniform(-1, 1, 3)
        quat = rng.normal(size=4)
        qpos[3:7] = quat / np.linalg.norm(quat)
        qpos[7:] = rng.uniform(-1.5, 1.5, mj.nq - 7)
        qvel, tau = rng.uniform(-2, 2, mj.nv), rng.uniform(-3, 3, mj.nv)
        qacc, lam = mujoco_contact_dynamics(mj, data, qpos, qvel, tau, [site], [body])
        x = np.concatenate([qpos, qvel])
        p = np.array([9.81] + [0.0] * (py.n_p - 1))
        for ours, theirs in ((py.rhs(0, x, p, tau)[mj.nq:], qacc),
                             (py.constraint_forces(0, x, p, tau), lam)):
            assert np.abs(ours - theirs).max() <= 1e-7 * np.abs(theirs).max()


def test_a_contact_that_is_neither_site_nor_body_is_refused_by_name():
    mj = mujoco.MjModel.from_xml_string(WALKER)
    with pytest.raises(MjcfError, match="no site or body 'tow'.*'toe'"):
        mbgen.from_mujoco(mj, contacts=["tow"])
