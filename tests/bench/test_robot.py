"""``mbgen bench robot FILE`` on a tiny URDF: the command runs, its table is filled where the
peers are installed; nothing timed is asserted.  Pinocchio's C++ loop (a minute to compile)
is left out here."""

from __future__ import annotations

import pytest

from mbgen.bench import robot
from mbgen.cli import main
from urdf_models import ARM_PARTS, FLOATING_PARTS, urdf

URDF = """<robot name="tiny">
  <link name="base"/>
  <link name="upper"><inertial><origin xyz="0 0 0.25" rpy="0 0 0"/><mass value="1.2"/>
    <inertia ixx="0.03" iyy="0.03" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="lower"><inertial><origin xyz="0 0 0.2" rpy="0.1 0 0"/><mass value="0.8"/>
    <inertia ixx="0.012" iyy="0.012" izz="0.001" ixy="0.0005" ixz="0" iyz="0"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="50" velocity="5"/></joint>
  <joint name="elbow" type="continuous"><parent link="upper"/><child link="lower"/>
    <origin xyz="0 0 0.5" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/></joint>
</robot>
"""


def test_bench_robot_on_a_tiny_urdf(tmp_path, capsys):
    path = tmp_path / "tiny.urdf"
    path.write_text(URDF, encoding="utf-8")
    assert main(["bench", "robot", str(path), "--repeats", "1", "--no-cxx"]) == 0
    out = capsys.readouterr().out
    assert "robot " in out and "mbgen RHS" in out and "generation, cold (rhs)" in out
    assert "mbgen ok" in out


def test_peers_fill_their_columns(tmp_path):
    pytest.importorskip("pinocchio")
    pytest.importorskip("mujoco")
    path = tmp_path / "tiny.urdf"
    path.write_text(URDF, encoding="utf-8")
    rep = robot.robot_bench(str(path), repeats=1, cxx=False)
    assert rep.rhs_c_ns and rep.rhs_py_ns and rep.pin_py_ns and rep.mj_py_ns
    assert rep.diff_pin < 1e-9 and rep.diff_mj < 1e-9
    assert set(rep.stages) >= {"derive_s", "bake_s", "cse_s", "render_s", "compile_s"}


def test_bench_robot_without_a_file_is_a_usage_error(capsys):
    assert main(["bench", "robot"]) == 2


ACTUATED = """<mujoco model="actuated"><worldbody><body name="arm" pos="0 0 1">
<joint name="shoulder" axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
<body name="fore" pos="0.3 0 0"><joint name="elbow" axis="0 1 0"/>
<geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02"/></body></body></worldbody>
<actuator><motor joint="shoulder" gear="3"/><position joint="elbow" kp="5"/></actuator></mujoco>"""


def test_an_mjcf_robot_with_actuators_agrees_with_mujoco(tmp_path):
    """The inputs of an MJCF model are qfrc_applied, then the actuators' ctrl: MuJoCo's side
    of the benchmark gets both, with its actuation on."""
    pytest.importorskip("mujoco")
    path = tmp_path / "actuated.xml"
    path.write_text(ACTUATED, encoding="utf-8")
    rep = robot.robot_bench(str(path), repeats=1, cxx=False, pinocchio=False)
    assert rep.diff_mj < 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("parts, floating", [(FLOATING_PARTS, True), (ARM_PARTS, False)])
def test_the_jacobian_is_timed_and_agrees_with_compute_aba_derivatives(tmp_path, parts,
                                                                       floating):
    """``jacobian=True``: mbgen's Jacobian timed in C (the driver's and the module's flags) and
    from Python; in the speeds' tangent space it is Pinocchio's ``[ddq_dq, ddq_dv]`` (a
    floating base's quaternion columns mapped, a continuous joint's cosine and sine too)."""
    pytest.importorskip("pinocchio")
    path = tmp_path / "robot.urdf"
    path.write_text(urdf(parts), encoding="utf-8")
    rep = robot.robot_bench(str(path), floating=floating, jacobian=True, repeats=1, cxx=False,
                            mujoco=False)
    assert rep.status == "ok", rep.notes
    assert rep.jac_c_ns > 0 and rep.jac_own_ns > 0 and rep.jac_py_ns > 0
    assert rep.pin_daba_py_ns > 0 and rep.pin_daba_cxx_ns is None      # cxx=False
    assert rep.diff_pin_jac < 1e-9
    text = robot.format_robot(rep)
    assert "Pinocchio dABA" in text and "module's flags" in text and "tangent space" in text


def test_the_derivatives_table_divides_by_the_modules_jacobian():
    rep = robot.RobotReport(robot="r", floating=True, jac_c_ns=400.0, jac_own_ns=500.0,
                            jac_py_ns=2000.0, pin_daba_cxx_ns=1000.0, pin_daba_py_ns=3000.0,
                            diff_pin_jac=3e-13, tan_own_ns=450.0, tan_py_ns=900.0)
    lines = robot.format_robot(rep).splitlines()
    row = next(x for x in lines if x.startswith("Pinocchio dABA")).split()
    assert row == ["Pinocchio", "dABA", "1000", "3000", "2.00", "1.00"]
    assert next(x for x in lines if x.startswith("mbgen jacobian")).split()[-2:] == [
        "0.80", "0.40"]
    assert next(x for x in lines if x.startswith("mbgen tangent")).split()[2:] == [
        "450", "900", "0.90", "0.45"]
    assert any("3.0e-13" in x for x in lines)
    assert "derivatives" not in robot.format_robot(robot.RobotReport(robot="r", floating=False))
