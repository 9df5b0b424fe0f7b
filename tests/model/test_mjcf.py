"""MuJoCo models (mbgen.from_mjcf, from_mujoco) against MuJoCo's own mj_forward.

By default a small hand-written MJCF: a hinge with armature, damping and ``ref``, a tilted
hinge with a spring off its anchor, a slide with armature, damping and a spring, a hinge
off its anchor with armature and damping, a welded tool, inertia from geoms and a gravity
off the z axis.  ``slow``: the same with that last hinge a ball joint and a floating body
(free joint) with a hinge below it; and real robots (Solo-12 floating, Panda) compiled by MuJoCo from their URDF.
Contacts, limits, equality constraints, friction loss and actuators are switched off in
MuJoCo: mbgen does not model them.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

import mbgen
from mbgen.abi import Output
from mbgen.errors import MissingExtraError, MjcfError
from mbgen.model.mjcf import scene_values
from mbgen.model.scene import Scene, load_scene

mujoco = pytest.importorskip("mujoco")

RTOL = 1e-9

CHAIN = """
<mujoco model="chain">
  <option gravity="0.3 -0.2 -9.81"/>
  <default><joint damping="0.05"/><geom density="900"/></default>
  <worldbody>
    <body name="base" pos="0 0 1" quat="0.9 0.1 0.2 0.3">
      <joint name="shoulder" type="hinge" axis="0 0 1" armature="0.02" damping="0.3" ref="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
      <body name="upper" pos="0.3 0 0" euler="10 20 30">
        <joint name="elbow" type="hinge" axis="0.3 -0.5 0.8" pos="0.02 0.01 0" stiffness="2"
               springref="0.3" ref="0.2"/>
        <geom type="box" size="0.1 0.04 0.03" pos="0.1 0.01 0"/>
        <body name="slider" pos="0.2 0 0">
          <joint name="slide" type="slide" axis="0 1 1" armature="0.5" damping="1.5" stiffness="3"/>
          <geom type="sphere" size="0.05" pos="0.01 0.02 0.03"/>
          <body name="wrist" pos="0.05 0.1 0" quat="0.7 0 0.7 0.1">
            <joint name="wrist" type="{wrist}" pos="0.01 0 0.02" armature="0.01" damping="0.2"/>
            <geom type="ellipsoid" size="0.06 0.03 0.02" pos="0.05 0 0.01" euler="5 0 40"/>
            <body name="tool" pos="0.1 0 0" euler="0 30 0">
              <geom type="cylinder" size="0.02 0.05" pos="0 0 0.02"/>
            </body>
          </body>
        </body>
      </body>
    </body>
    {extra}
  </worldbody>
</mujoco>
"""

FLOATER = """
    <body name="floater" pos="1 0 2" euler="10 0 20">
      <freejoint name="float"/>
      <geom type="box" size="0.1 0.2 0.3"/>
      <body name="limb" pos="0.1 0 0">
        <joint name="flap" type="hinge" axis="1 0 0" pos="0 0.1 0" damping="0.1" armature="0.03"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/>
      </body>
    </body>
"""

OFF = ("mjDSBL_CONTACT", "mjDSBL_LIMIT", "mjDSBL_EQUALITY", "mjDSBL_FRICTIONLOSS",
       "mjDSBL_ACTUATION")


def switch_off(mj) -> None:
    """What mbgen does not model, off in MuJoCo (springs and dampers stay on)."""
    for flag in OFF:
        mj.opt.disableflags |= int(getattr(mujoco.mjtDisableBit, flag))


def random_qpos(rng, mj) -> np.ndarray:
    qpos = np.array(mj.qpos0)
    for j in range(mj.njnt):
        a, kind = mj.jnt_qposadr[j], int(mj.jnt_type[j])
        if kind in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            qpos[a] = rng.uniform(-1.5, 1.5)
        else:
            free = kind == int(mujoco.mjtJoint.mjJNT_FREE)
            start = a + 3 if free else a
            if free:
                qpos[a:a + 3] = rng.uniform(-1, 1, 3)
            quat = rng.normal(size=4)
            qpos[start:start + 4] = quat / np.linalg.norm(quat)
    return qpos


def compare(mj, backends, samples=5, seed=3) -> float:
    """Largest relative difference of u' from mj_forward's qacc (and q' from integratePos)."""
    switch_off(mj)
    data = mujoco.MjData(mj)
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(samples):
        qpos = random_qpos(rng, mj)
        qvel, tau = rng.uniform(-2, 2, mj.nv), rng.uniform(-3, 3, mj.nv)
        data.qpos[:], data.qvel[:], data.qfrc_applied[:] = qpos, qvel, tau
        mujoco.mj_forward(mj, data)
        h = 1e-4
        steps = []
        for s in (2, 1, -1, -2):
            q = qpos.copy()
            mujoco.mj_integratePos(mj, q, qvel, s * h)
            steps.append(q)
        qdot = (-steps[0] + 8 * steps[1] - 8 * steps[2] + steps[3]) / (12 * h)
        for backend in backends:
            dxdt = backend.rhs(0.0, np.concatenate([qpos, qvel]), None, tau)
            err = np.abs(dxdt[mj.nq:] - data.qacc).max() / np.abs(data.qacc).max()
            assert err <= RTOL, (type(backend).__name__, err)
            assert np.abs(dxdt[:mj.nq] - qdot).max() <= 1e-9 * max(1, np.abs(qdot).max())
            worst = max(worst, err)
    return worst


def compiled_of(mj):
    model = mbgen.from_mujoco(mj)
    parameters, initial = scene_values(mj)
    return mbgen.compile(Scene(name=model.name, model=model, parameters=parameters,
                               initial_state=initial, t_span=(0.0, 1.0),
                               outputs=(Output.RHS,)))


@pytest.fixture(scope="module")
def chain():
    mj = mujoco.MjModel.from_xml_string(CHAIN.format(extra="", wrist="hinge"))
    return mj, compiled_of(mj)


def test_chain_matches_mj_forward(chain):
    mj, compiled = chain
    names = list(compiled.layout.state_names)
    assert names == ["q_shoulder", "q_elbow", "q_slide", "q_wrist", "u_shoulder", "u_elbow",
                     "u_slide", "u_wrist"]
    compare(mj, [compiled])


@pytest.mark.slow
def test_chain_matches_mj_forward_in_generated_python(chain):
    mj, compiled = chain
    compare(mj, [mbgen.python_model(compiled.rendered)])


def test_the_comparison_has_teeth(chain):
    mj = mujoco.MjModel.from_xml_string(CHAIN.format(extra="", wrist="hinge"))
    compiled = chain[1]
    mj.dof_armature[0] += 0.01          # MuJoCo's model no longer the one compiled
    with pytest.raises(AssertionError):
        compare(mj, [compiled], samples=1)


@pytest.mark.slow
def test_floating_body_matches_mj_forward(tmp_path):
    path = tmp_path / "floating.xml"
    path.write_text(CHAIN.format(extra=FLOATER, wrist="ball"), encoding="utf-8")
    scene = load_scene(str(path))
    assert scene.initial_state["q_float_z"] == 2.0
    compiled = mbgen.compile(scene)
    names = list(compiled.layout.state_names)
    assert names[3:7] == ["q_wrist_qw", "q_wrist_qx", "q_wrist_qy", "q_wrist_qz"]
    assert names[15 + 3:15 + 6] == ["u_wrist_wx", "u_wrist_wy", "u_wrist_wz"]
    assert names[7:14] == [
        "q_float_x", "q_float_y", "q_float_z", "q_float_qw", "q_float_qx", "q_float_qy",
        "q_float_qz"]
    compare(mujoco.MjModel.from_xml_path(str(path)), [compiled])


def test_unmodelled_forces_are_refused_by_name():
    mj = mujoco.MjModel.from_xml_string(CHAIN.format(extra="", wrist="hinge"))
    mj.body_gravcomp[2] = 1.0
    mj.opt.viscosity = 0.1
    with pytest.raises(MjcfError, match="gravity compensation.*fluid"):
        mbgen.from_mujoco(mj)


def test_a_file_mujoco_cannot_compile_is_an_mjcf_error(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text("<mujoco><worldbody><body><joint type='nope'/></body></worldbody></mujoco>")
    with pytest.raises(MjcfError, match="could not compile"):
        mbgen.from_mjcf(path)


def test_without_mujoco_the_error_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'mbgen\[mujoco\]'"):
        mbgen.from_mjcf("robot.xml")


@pytest.mark.slow
@pytest.mark.parametrize("robot, floating", [("solo12", True), ("panda", False)])
def test_real_robot_compiled_by_mujoco_matches_mj_forward(robot, floating, tmp_path):
    from mbgen.bench.robot_peers import mujoco_spec_of_urdf, robot_file
    path = tmp_path / f"{robot}.xml"           # MuJoCo's MJCF of the robot, then from_mjcf
    path.write_text(mujoco_spec_of_urdf(robot_file(robot)[0], floating).to_xml(),
                    encoding="utf-8")
    mj = mujoco.MjModel.from_xml_path(str(path))
    model = mbgen.from_mjcf(path)
    parameters, initial = scene_values(mj)
    compiled = mbgen.compile(Scene(name=model.name, model=model, parameters=parameters,
                                   initial_state=initial, t_span=(0.0, 1.0),
                                   outputs=(Output.RHS,)))
    compare(mj, [compiled], samples=10)
