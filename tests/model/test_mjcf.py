"""MuJoCo models (mbgen.from_mjcf, from_mujoco) against MuJoCo's own mj_forward.

By default a small hand-written MJCF: a hinge with armature, damping and ``ref``, a tilted
hinge with a spring off its anchor, a slide with armature, damping and a spring, a hinge off
its anchor with armature and damping, a welded tool, inertia from geoms and a gravity off
the z axis.  ``slow``: the same with that last hinge a ball joint and a floating body (free
joint) with a hinge below it; and real robots (Solo-12 floating, Panda) compiled by MuJoCo
from their URDF.  Contacts, limits, equality constraints and friction loss are switched off
in MuJoCo: mbgen does not model them (it names them in one warning at load).  Actuation
stays on: a motor, a position and a velocity servo, an affine general actuator and one
through ``jointinparent``, all geared, are inputs after ``qfrc_applied`` (issue 30).  Also
by default: a ball joint in a turned body under a turned parent and a turned free body
(through lambdify, no C compiler); MuJoCo's flags honoured (gravity, spring, damper,
actuation) and what is dropped named once; what is refused before MuJoCo reads a file (pipes
and devices, numbers that are not finite or whose square overflows, files that multiply into
huge models) or once it has compiled one; a model named after its file.  dm_control's
models: test_mjcf_suite.py.
"""

from __future__ import annotations

import os
import sys
import threading
import warnings

import numpy as np
import pytest

import mbgen
from mbgen.abi import Output
from mbgen.derivation import Method
from mbgen.errors import MissingExtraError, MjcfError, ModelSizeError, ModelWarning
from mbgen.model.mjcf import scene_values
from mbgen.model.scene import Scene, load_scene
from mujoco_models import (
    RTOL,
    compare,
    switch_off,
)

mujoco = pytest.importorskip("mujoco")
#: What mbgen drops (contacts, mostly) is named by one ModelWarning per load; the tests that
#: look at it catch it themselves.
pytestmark = pytest.mark.filterwarnings("ignore::mbgen.errors.ModelWarning")

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


# ------------------------------------------- turned ball and free joints, through lambdify
TURNS = """
<mujoco model="turns">
  <option gravity="0.5 -0.3 -9.81"/>
  <worldbody>
    <body name="arm" pos="0.1 0.2 0.3" euler="20 -30 50">
      <geom type="box" size="0.2 0.05 0.03" pos="0.1 0 0"/>
      <body name="hand" pos="0.3 0.05 0" euler="-40 15 70">
        <joint name="ball" type="ball" pos="0.02 0 0.01" damping="0.05"/>
        <geom type="ellipsoid" size="0.08 0.04 0.02" pos="0.05 0.01 0" euler="10 0 20"/>
      </body>
    </body>
    <body name="drone" pos="1 0 2" euler="35 -20 60">
      <freejoint name="float"/>
      <geom type="box" size="0.1 0.2 0.3" pos="0.03 -0.02 0.05" euler="0 15 5"/>
    </body>
  </worldbody>
</mujoco>
"""


class _Lambdified:
    """The right-hand side through sympy.lambdify: no C compiler, a second for a small model."""

    def __init__(self, mj, equations=None):
        equations = equations or mbgen.equations_of(mbgen.from_mujoco(mj))
        self.model = mbgen.LambdifiedModel(equations, outputs=(Output.RHS,))
        self.p = np.array([scene_values(mj)[0]["g"]])

    def rhs(self, t, x, p, r):
        return self.model.rhs(t, x, self.p, r)


def test_ball_under_a_turned_parent_and_a_turned_free_body_match_mj_forward():
    """A ball joint's rotation composes after its body's reference orientation (``A R``, not
    ``R A``: the body and its parent are turned) and a free joint's ``v`` is in world
    components (the body is turned): at random states every speed's derivative and every
    coordinate's matches MuJoCo's."""
    mj = mujoco.MjModel.from_xml_string(TURNS)
    backend = _Lambdified(mj)
    assert list(backend.model.layout.state_names)[:4] == ["q_ball_qw", "q_ball_qx",
                                                          "q_ball_qy", "q_ball_qz"]
    compare(mj, [backend], samples=4, seed=11)


def test_armature_sits_on_the_joint_diagonal_for_newton_euler():
    """MuJoCo's armature is ``Model.armature`` on the joint's speed, no rotor body: the
    joint tree stays the file's, so Newton–Euler derives it (the recursion with the armature
    in its pivots) and agrees with mj_forward."""
    mj = mujoco.MjModel.from_xml_string(CHAIN.format(extra="", wrist="hinge"))
    model = mbgen.from_mujoco(mj)
    assert {str(a.speed.func): float(a.value) for a in model.armatures_} == {
        "u_shoulder": 0.02, "u_slide": 0.5, "u_wrist": 0.01}
    assert [b.name for b in model.bodies] == ["base", "upper", "slider", "wrist"]
    equations = mbgen.equations_of(model, Method.NEWTON_EULER)
    assert equations.accelerations is not None      # the articulated-body recursion
    compare(mj, [_Lambdified(mj, equations)], samples=3, seed=7)


# ------------------------------------------------------------- files MuJoCo must not read
ONE_BODY = """<mujoco model="one"><worldbody><body name="b" pos="0 0 1"><joint name="j"/>
<geom type="sphere" size="0.1"/></body></worldbody></mujoco>"""


def _refused_without_hanging(pipe, read, match):
    """``read()`` must refuse the named pipe ``pipe`` by its kind.  A writer feeds the pipe a
    valid model meanwhile, so code that opens the pipe reads a model and fails the test
    instead of waiting forever; the writer is let go afterwards by opening the read end."""
    def feed():
        try:
            with open(pipe, "w", encoding="utf-8") as f:
                f.write(ONE_BODY)
        except OSError:
            pass
    writer = threading.Thread(target=feed, daemon=True)
    writer.start()
    try:
        with pytest.raises(MjcfError, match=match):
            read()
    finally:
        fd = os.open(pipe, os.O_RDONLY | os.O_NONBLOCK)
        writer.join()
        os.close(fd)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_a_named_pipe_is_refused_by_its_kind_before_mujoco_opens_it(tmp_path):
    pipe = tmp_path / "robot.xml"
    os.mkfifo(pipe)
    _refused_without_hanging(pipe, lambda: mbgen.from_mjcf(pipe), r"robot\.xml.*named pipe")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_an_included_named_pipe_is_refused_before_mujoco_opens_it(tmp_path):
    os.mkfifo(tmp_path / "part.xml")
    main = tmp_path / "main.xml"
    main.write_text('<mujoco><worldbody><include file="part.xml"/></worldbody></mujoco>')
    _refused_without_hanging(tmp_path / "part.xml", lambda: mbgen.from_mjcf(main),
                             r"included by .*main\.xml', line 1.*part\.xml' is a named pipe")


@pytest.mark.parametrize("kind, match", [("folder", "a folder"),
                                         ("device", "a character device"),
                                         ("missing", "does not exist")])
def test_a_path_that_is_no_file_is_named_for_what_it_is(tmp_path, kind, match):
    path = {"folder": tmp_path, "device": os.devnull, "missing": tmp_path / "no.xml"}[kind]
    with pytest.raises(MjcfError, match=match):
        mbgen.from_mjcf(path)


def test_a_mesh_file_that_is_a_device_is_refused(tmp_path):
    main = tmp_path / "main.xml"
    main.write_text(f'<mujoco><asset><mesh name="m" file="{os.devnull}"/></asset></mujoco>')
    with pytest.raises(MjcfError, match="mesh.*character device"):
        mbgen.from_mjcf(main)


# ------------------------------------------------------------------------ numbers in the file
@pytest.mark.parametrize("tag, attribute, value", [
    ("body", "pos", "nan 0 1"), ("joint", "damping", "nan"), ("joint", "stiffness", "inf"),
    ("joint", "axis", "0 NaN 1"), ("option", "gravity", "0 0 -inf")])
def test_a_number_that_is_not_finite_is_named_by_element_and_attribute(tmp_path, tag,
                                                                         attribute, value):
    attrs = {"option": {"gravity": "0 0 -9.81"}, "body": {"name": "b", "pos": "0 0 1"},
             "joint": {"name": "j", "axis": "0 1 0", "damping": "0.1", "stiffness": "0"}}
    attrs[tag][attribute] = value
    text = " ".join(f'{a}="{v}"' for a, v in attrs["option"].items()), \
        " ".join(f'{a}="{v}"' for a, v in attrs["body"].items()), \
        " ".join(f'{a}="{v}"' for a, v in attrs["joint"].items())
    path = tmp_path / "m.xml"
    path.write_text(f'<mujoco model="m"><option {text[0]}/><worldbody>\n<body {text[1]}>\n'
                    f'<joint {text[2]}/><geom type="sphere" size="0.1"/></body>'
                    f'</worldbody></mujoco>')
    with pytest.raises(MjcfError, match=rf"m\.xml.*<{tag}\b.*{attribute}=.*not a finite"):
        mbgen.from_mjcf(path)


@pytest.mark.parametrize("where", ['axis="1e200 0 0"', 'pos="1e200 0 0"'])
def test_a_vector_whose_square_overflows_is_refused_not_turned(tmp_path, where):
    """MuJoCo turns ``axis="1e200 0 0"`` into (0, 0, 0): the joint would turn about another
    axis.  The file is refused, naming the joint and the attribute."""
    path = tmp_path / "big.xml"
    path.write_text(ONE_BODY.replace('<joint name="j"', f'<joint name="j" {where}'))
    with pytest.raises(MjcfError, match=rf"<joint name='j'>.*{where.split('=')[0]}=.*1e\+?200"):
        mbgen.from_mjcf(path)


def test_a_compiled_model_with_a_zero_axis_or_a_nan_is_refused_by_name(tmp_path, monkeypatch):
    """``from_mujoco`` reads a compiled model with no file to point at: the joint, the body
    and MuJoCo's field are named instead."""
    monkeypatch.chdir(tmp_path)                   # MuJoCo's warning log goes there
    mj = mujoco.MjModel.from_xml_string(ONE_BODY.replace('<joint name="j"',
                                                         '<joint name="j" axis="1e200 0 0"'))
    assert not mj.jnt_axis[0].any()               # what MuJoCo made of it
    with pytest.raises(MjcfError, match=r"joint 'j'.*jnt_axis.*zero"):
        mbgen.from_mujoco(mj)
    mj = mujoco.MjModel.from_xml_string(ONE_BODY)
    mj.dof_damping[0] = np.nan
    with pytest.raises(MjcfError, match=r"joint 'j'.*dof_damping.*nan"):
        mbgen.from_mujoco(mj)
    mj = mujoco.MjModel.from_xml_string(ONE_BODY)
    mj.body_quat[1] = [1e-200, 0, 0, 1e-200]       # scaled before it is squared: 90 deg about z
    assert mbgen.from_mujoco(mj).frames is not None


# -------------------------------------------------------------------- sizes before compiling
@pytest.mark.parametrize("nest", [
    '<replicate count="1000" offset="0 0 1"><replicate count="1000000" offset="1 0 0">{b}'
    '</replicate></replicate>',
    '<frame><replicate count="100000" offset="1 0 0"><frame>{b}</frame></replicate></frame>',
    '<body name="c"><composite type="cable" count="1000000 1 1" size="1"/></body>',
    '<body name="h"><replicate count="100000000" offset="1 0 0"><geom size="0.1"/>'
    '</replicate></body>'])
def test_a_file_that_multiplies_into_a_huge_model_is_refused_before_compiling(
        tmp_path, nest, monkeypatch):
    """300 bytes that make 10^9 bodies (or a million cable segments, or 10^8 geoms) are
    refused before MuJoCo's compiler sees them: handing them over fails the test at once
    (MuJoCo would grow its memory without an answer)."""
    def compiled(*_args, **_kwargs):
        raise AssertionError("the file went to MuJoCo's compiler")
    monkeypatch.setattr(mujoco.MjModel, "from_xml_path", staticmethod(compiled))
    body = '<body><joint/><geom size="0.1"/></body>'
    path = tmp_path / "bomb.xml"
    path.write_text(f'<mujoco><worldbody>{nest.format(b=body)}</worldbody></mujoco>')
    with pytest.raises(MjcfError, match=r"bomb\.xml.*would make at least [0-9]{6,} elem"):
        mbgen.from_mjcf(path)


def test_more_bodies_than_mbgen_derives_are_refused_before_compiling(tmp_path, monkeypatch):
    """2,500 replicated bodies: few enough for MuJoCo, too many for mbgen; the size guard's
    own error (which ``--force`` lifts) comes before MuJoCo's compiler runs."""
    def compiled(*_args, **_kwargs):
        raise AssertionError("the file went to MuJoCo's compiler")
    monkeypatch.setattr(mujoco.MjModel, "from_xml_path", staticmethod(compiled))
    path = tmp_path / "crowd.xml"
    path.write_text('<mujoco><worldbody><replicate count="50" offset="1 0 0">'
                    '<replicate count="50" offset="0 1 0"><body><joint/><geom size="0.1"/>'
                    '</body></replicate></replicate></worldbody></mujoco>')
    with pytest.raises(ModelSizeError, match=r"crowd\.xml' would have 2500 bodies"):
        mbgen.from_mjcf(path)


def test_replicated_bodies_are_counted_as_mujoco_makes_them(tmp_path):
    """Below the bound a replicated model compiles: 2 x 3 bodies, each a hinge."""
    path = tmp_path / "rows.xml"
    path.write_text('<mujoco><worldbody><replicate count="2" offset="0 1 0">'
                    '<replicate count="3" offset="1 0 0"><body><joint axis="1 0 0"/>'
                    '<geom size="0.1"/></body></replicate></replicate></worldbody></mujoco>')
    assert len(mbgen.from_mjcf(path).coordinates_) == 6


# --- a free body whose subtree some motion leaves still (issue 28, item 10)
FREE_TRUNK = """<mujoco><worldbody><body name="trunk"><freejoint name="root"/>
<inertial pos="0 0 0" mass="2" diaginertia="0.1 0.2 0.3"/>
<body name="leg" pos="0 0 -0.3"><joint name="hip" type="hinge" axis="0 1 0"{armature}/>
<inertial pos="0 0 -0.2" mass="1" diaginertia="0.01 0.01 0.001"/></body></body></worldbody>
</mujoco>"""


@pytest.mark.parametrize("armature, refused", [("", True), (' armature="0.05"', False)])
def test_a_massless_free_body_on_one_hinge_is_refused_unless_its_rotor_holds_it(
        armature, refused, tmp_path, monkeypatch):
    """MuJoCo's compiler refuses a massless moving body in a file, but a compiled model's
    fields can be set: with the trunk's mass and inertia zeroed, the trunk can turn about
    the hip while the hip turns back, and M is singular at every state; armature on the
    hip (a rotor) makes that motion cost energy again."""
    mj = mujoco.MjModel.from_xml_string(FREE_TRUNK.format(armature=armature))
    mj.body_mass[1], mj.body_inertia[1] = 0.0, 0.0
    if refused:
        with pytest.raises(MjcfError, match=r"free body 'trunk' \(joint 'root'\).*no inertia "
                                            r"against a rotation.*singular at every state"):
            mbgen.from_mujoco(mj)
    else:
        mbgen.from_mujoco(mj)
    monkeypatch.chdir(tmp_path)          # MuJoCo logs its warning to ./MUJOCO_LOG.TXT
    data = mujoco.MjData(mj)             # MuJoCo's own mass matrix agrees on the rank
    data.qpos[3:7] = [0.8, 0.2, -0.3, 0.4]
    data.qpos[3:7] /= np.linalg.norm(data.qpos[3:7])
    data.qpos[7] = 0.7
    mujoco.mj_forward(mj, data)
    M = np.zeros((mj.nv, mj.nv))
    try:                                 # MuJoCo 3.3+: (model, data, dst); before: qM
        mujoco.mj_fullM(mj, data, M)
    except TypeError:
        mujoco.mj_fullM(mj, M, data.qM)
    eig = np.linalg.eigvalsh(M)
    assert (eig[0] < 1e-12 * eig[-1]) == refused


def test_a_free_body_that_carries_mass_is_accepted():
    mbgen.from_mujoco(mujoco.MjModel.from_xml_string(FREE_TRUNK.format(armature="")))


# ---------------------------------------- actuators, flags, what is dropped (issue 30, 2/3/6)
SERVO = """
<mujoco model="servo">
  <option gravity="0.2 0 -9.81"><flag {flags}/></option>
  <worldbody>
    <body name="arm" pos="0 0 1" euler="0 10 20">
      <joint name="shoulder" axis="0 1 0" damping="0.1" ref="0.2" stiffness="1.5"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/>
      <body name="carriage" pos="0.4 0 0">
        <joint name="rail" type="slide" axis="1 0 0.2" damping="0.05"/>
        <geom type="box" size="0.05 0.03 0.03"/>
        <body name="hand" pos="0.1 0 0">
          <joint name="wrist" axis="0 0 1" pos="0.02 0 0"/>
          <geom type="sphere" size="0.04" pos="0.05 0 0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="torque" joint="shoulder" gear="3" ctrllimited="true" ctrlrange="-1 1"/>
    <position name="servo" joint="rail" kp="40" kv="2" gear="1.5" damping="0.3"
              armature="0.02"/>
    <velocity name="spin" joint="wrist" kv="0.8" gear="2"/>
    <general name="affine" joint="shoulder" gaintype="affine" gainprm="1.5 0.3 -0.2"
             biastype="affine" biasprm="0.1 -0.4 -0.05" forcelimited="true"
             forcerange="-5 5"/>
    <motor name="in_parent" jointinparent="wrist" gear="0.5"/>
  </actuator>
</mujoco>
"""
SERVO_INPUTS = ["ctrl_torque", "ctrl_servo", "ctrl_spin", "ctrl_affine", "ctrl_in_parent"]


@pytest.fixture(scope="module")
def servo():
    mj = mujoco.MjModel.from_xml_string(SERVO.format(flags=""))
    with pytest.warns(ModelWarning):
        return mj, _Lambdified(mj)


def test_actuators_are_inputs_that_match_mj_forward_with_actuation_on(servo):
    """A motor, a position servo (with actuator damping and armature), a velocity servo, an
    affine general actuator and one through ``jointinparent``, all with gears: their
    ``ctrl`` comes after ``qfrc_applied``, and ``u'`` matches ``mj_forward`` within the
    ranges, force clamping off (mbgen never clamps)."""
    mj, backend = servo
    inputs = list(backend.model.layout.input_names)
    assert inputs == ["tau_shoulder", "tau_rail", "tau_wrist"] + SERVO_INPUTS
    assert compare(mj, [backend], samples=6) <= RTOL


@pytest.mark.parametrize("break_it", ["gear", "kp", "actuator armature"])
def test_the_actuator_comparison_has_teeth(servo, break_it):
    mj = mujoco.MjModel.from_xml_string(SERVO.format(flags=""))
    if break_it == "gear":
        mj.actuator_gear[0, 0] = 1.0     # the motor without its gear
    elif break_it == "kp":
        mj.actuator_biasprm[1, 1] = 0.0  # the servo without its position feedback
    else:
        mj.actuator_armature[1] = 0.0
    with pytest.raises(AssertionError):
        compare(mj, [servo[1]], samples=2)


def test_ranges_are_kept_as_data_and_their_clamping_named_once():
    from mbgen.model.mjcf_physics import read_physics
    mj = mujoco.MjModel.from_xml_string(SERVO.format(flags=""))
    with pytest.warns(ModelWarning) as caught:
        mbgen.from_mujoco(mj)
    assert len(caught) == 1
    message = str(caught[0].message)
    assert "ctrl to ctrlrange ('torque')" in message and "forcerange" in message
    assert "'affine'" in message
    physics = read_physics(mj, ["shoulder", "rail", "wrist"], set())
    ranges = {a.name: (a.ctrlrange, a.forcerange) for a in physics.actuators}
    assert ranges["torque"] == ((-1.0, 1.0), None) and ranges["affine"] == (None, (-5.0, 5.0))
    assert ranges["spin"] == (None, None)
    mj.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CLAMPCTRL)
    assert read_physics(mj, ["shoulder", "rail", "wrist"], set()).actuators[0].ctrlrange is None


def test_disabled_gravity_springs_dampers_and_actuation_are_honoured():
    """``<flag gravity="disable" spring="disable" damper="disable" actuation="disable"/>``:
    no gravity (``g`` = 0), no spring, no damping (the actuator's neither), no actuator
    inputs; the actuator's armature stays (MuJoCo adds it whatever the flags); no warning
    (nothing is dropped that MuJoCo would apply)."""
    flags = 'gravity="disable" spring="disable" damper="disable" actuation="disable" ' \
        'contact="disable"'
    mj = mujoco.MjModel.from_xml_string(SERVO.format(flags=flags))
    mj.actuator_ctrllimited[:] = 0
    mj.actuator_forcelimited[:] = 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        backend = _Lambdified(mj)
    assert scene_values(mj)[0] == {"g": 0.0}
    assert list(backend.model.layout.input_names) == ["tau_shoulder", "tau_rail", "tau_wrist"]
    backend.p = np.array([9.81])        # the model holds no gravity term for g to scale
    compare(mj, [_TauOnly(backend, mj.nv)], samples=3)


class _TauOnly:
    """A back end without actuator inputs, called as :func:`compare` calls (tau, ctrl)."""

    def __init__(self, backend, nv):
        self.backend, self.nv = backend, nv

    def rhs(self, t, x, p, r):
        return self.backend.rhs(t, x, p, r[:self.nv])


DROPS = """
<mujoco model="drops">
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="a" pos="0 0 0.5">
      <joint name="hinge_a" axis="0 1 0" limited="true" range="-1 1" frictionloss="0.1"/>
      <geom name="ball_a" size="0.1"/>
      <body name="b" pos="0.3 0 0">
        <joint name="hinge_b" axis="0 1 0"/>
        <geom name="ball_b" size="0.1"/>
      </body>
    </body>
  </worldbody>
  <tendon><fixed name="link"><joint joint="hinge_a" coef="1"/><joint joint="hinge_b" coef="-1"/>
  </fixed></tendon>
  <equality><joint name="couple" joint1="hinge_a" joint2="hinge_b"/></equality>
  <actuator>
    <motor name="pull" tendon="link"/>
    <general name="slow" joint="hinge_b" dyntype="filter" dynprm="0.1"/>
    <motor name="direct" joint="hinge_b" gear="2"/>
  </actuator>
</mujoco>
"""


def test_what_is_dropped_is_named_in_one_warning_at_load():
    """Contacts, limits, friction loss, equality constraints and the actuators mbgen does not
    read (a tendon transmission, activation dynamics): one ModelWarning names each; the
    actuator it reads is an input; with MuJoCo's flags switching them off, nothing is
    named but the unread actuators."""
    mj = mujoco.MjModel.from_xml_string(DROPS)
    with pytest.warns(ModelWarning) as caught:
        model = mbgen.from_mujoco(mj)
    assert len(caught) == 1
    message = str(caught[0].message)
    for part in ["'drops'", "contacts (", "'floor' and 'ball_a'", "limits of 'hinge_a'",
                 "equality constraints ('couple')", "friction loss of 'hinge_a'",
                 "'pull' (tendon transmission)", "'slow' (activation dynamics (filter))"]:
        assert part in message, (part, message)
    assert [str(s) for s in model.inputs_][-1] == "ctrl_direct(t)"
    switch_off(mj)
    with pytest.warns(ModelWarning) as caught:
        mbgen.from_mujoco(mj)
    assert "contacts" not in str(caught[0].message) and "'pull'" in str(caught[0].message)


@pytest.mark.parametrize("change, match", [
    (lambda mj: mj.tendon_armature.__setitem__(0, 0.1), "tendon armature"),
    (lambda mj: mj.dof_dampingpoly.__setitem__(0, [0.3, 0.0]), r"nonlinear damping"),
    (lambda mj: mj.actuator_armature.__setitem__(0, 0.1),
     r"armature or damping of the actuator 'pull' \(not on a hinge or slide joint\)")])
def test_forces_mbgen_has_no_term_for_are_refused_by_name(change, match):
    mj = mujoco.MjModel.from_xml_string(DROPS)
    change(mj)
    with pytest.raises(MjcfError, match=match):
        mbgen.from_mujoco(mj)


def test_a_model_is_named_after_its_file(tmp_path):
    """``cartpole.xml`` with ``<mujoco model="cart-pole">`` writes ``cartpole.*``, not
    ``cart_pole.*``; a compiled model keeps MuJoCo's name unless given one."""
    path = tmp_path / "my-arm.xml"
    path.write_text(ONE_BODY.replace('model="one"', 'model="cart-pole"'), encoding="utf-8")
    assert mbgen.from_mjcf(path).name == "my_arm"
    assert load_scene(str(path)).name == "my_arm"
    mj = mujoco.MjModel.from_xml_path(str(path))
    assert mbgen.from_mujoco(mj).name == "cart_pole"
    assert mbgen.from_mujoco(mj, name="arm").name == "arm"


TRIANGLE = """<mujoco model="tri"><compiler {balance}/><worldbody><body name="b" pos="0 0 1">
<joint name="j" axis="1 0.2 0.3"/><inertial pos="0.1 0 0" mass="1" diaginertia="0.1 0.1 0.3"/>
</body></worldbody></mujoco>"""


def test_an_inertia_against_the_triangle_inequality_is_mujocos_to_refuse(tmp_path, monkeypatch):
    """MuJoCo's compiler refuses such an inertia (or mends it with ``balanceinertia``):
    mbgen accepts whatever it compiles.  A compiled model whose inertia is set by hand to
    break the inequality (positive semidefinite still) is read as mj_forward reads it,
    without a warning, and agrees with it."""
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "tri.xml"
    path.write_text(TRIANGLE.format(balance=""), encoding="utf-8")
    with pytest.raises(MjcfError, match=r"could not compile.*A \+ B >= C"):
        mbgen.from_mjcf(path)
    mj = mujoco.MjModel.from_xml_string(TRIANGLE.format(balance='balanceinertia="true"'))
    mj.body_inertia[1] = [0.1, 0.1, 0.3]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        backend = _Lambdified(mj)
    compare(mj, [backend], samples=3)
