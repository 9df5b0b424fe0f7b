"""URDF robots (mbgen.from_urdf) against Pinocchio's ABA, and every refusal of a bad file.

Small hand-written robots run by default: a 4-joint arm with rpy origins, a tilted axis,
a prismatic, a continuous and a fixed joint, and a floating base; both through the
generated C and the generated Python.  Real robots from example-robot-data, as shipped, are
``slow`` (tests/model/test_urdf_robots.py, with mimic joints, joint dynamics and options).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import sympy as sm

import mbgen
from mbgen.cli import main
from mbgen.derivation import Method, choose_method
from mbgen.derivation.articulated import speed_owners
from mbgen.derivation.prepare import prepare
from mbgen.derivation.recursion import NewtonEuler
from mbgen.errors import (
    ModelSizeError,
    UrdfError,
    UrdfInertiaError,
    UrdfStructureError,
    UrdfSyntaxError,
    UrdfUnsupportedError,
)
from mbgen.model import limits, urdf_xml
from mbgen.model.scene import load_scene, urdf_scene
from mbgen.pipeline import run
from models import count_joint_parent_reads, read_in_thread
from urdf_models import (
    ARM_PARTS,
    FLOATING_PARTS,
    LIMIT,
    RTOL,
    compare,
    inertial,
    joint,
    link,
    pinocchio_model,
    pinocchio_q,
    random_state,
    urdf,
    write,
)

pin = pytest.importorskip("pinocchio")

@pytest.fixture(scope="module")
def arm_path(tmp_path_factory):
    return write(tmp_path_factory.mktemp("urdf"), urdf(ARM_PARTS))


@pytest.fixture(scope="module")
def arm_compiled(arm_path):
    # Kane's method: 1.3 s to the C here against 3.7 s for Newton-Euler, which the pipeline
    # picks (and which the real robots, slow, and the floating base go through)
    return mbgen.compile(urdf_scene(arm_path), method=mbgen.Method.KANE)


def test_arm_names_and_order_follow_pinocchio(arm_path):
    m = mbgen.from_urdf(arm_path)
    names = [n for n in pinocchio_model(arm_path).names][1:]
    assert names == ["shoulder", "elbow", "slide", "wrist"]   # depth first, children by name
    assert [str(s.func) for s in m.coordinates_] == [f"q_{n}" for n in names]
    assert [str(s.func) for s in m.speeds_] == [f"u_{n}" for n in names]
    assert [str(s.func) for s in m.inputs_] == [f"tau_{n}" for n in names]
    assert [str(c) for c in m.constants_] == ["g"]
    # the fixed tool is merged into the slider; the ground's inertia is not a body
    assert [b.name for b in m.bodies] == ["upper", "fore", "slider", "hand"]


def test_arm_matches_pinocchio_aba_in_c_and_python(arm_compiled, arm_path):
    python = mbgen.python_model(arm_compiled.rendered)
    compare(arm_path, False, [arm_compiled, python])


def test_the_comparison_has_teeth(arm_compiled, tmp_path):
    """Pinocchio given the fixed tool's product of inertia with its sign flipped disagrees."""
    parts = list(ARM_PARTS)
    parts[5] = link("tool", inertial(0.2, "0.01 0 0.05", "0.3 -0.2 0.1",
                                     (0.001, 0.0012, 0.0009, 0.0002, 0, 0)))
    flipped = write(tmp_path, urdf(parts))
    with pytest.raises(AssertionError):
        compare(flipped, False, [arm_compiled], samples=2)


def test_floating_base_matches_pinocchio_free_flyer(tmp_path):
    path = write(tmp_path, urdf(FLOATING_PARTS, "hopper"))
    scn = urdf_scene(path, floating=True)
    assert scn.model.coordinates_[:7] and [str(s.func) for s in scn.model.coordinates_][:7] == [
        "root_x", "root_y", "root_z", "root_qx", "root_qy", "root_qz", "root_qw"]
    assert scn.initial_state == {"root_qw": 1.0}
    compiled = mbgen.compile(scn)
    compare(path, True, [compiled, mbgen.python_model(compiled.rendered)])
    # the quaternion is normalised where it is read: a scaled one gives the same accelerations
    x = np.concatenate([[0.1, 0.2, 0.3, 0.2, -0.4, 0.5, 0.7, 0.3, 0.1], np.linspace(-1, 1, 8)])
    scaled = x.copy()
    scaled[3:7] *= 3.0
    np.testing.assert_allclose(compiled.rhs(0.0, scaled)[9:], compiled.rhs(0.0, x)[9:],
                               rtol=1e-12, atol=1e-12)


def test_floating_base_jacobian_in_the_tangent_space_matches_aba_derivatives(tmp_path):
    """``mbgen.tangent_jacobian`` = Pinocchio's ``computeABADerivatives`` on a free-flyer
    (``ddq_dq`` in the tangent space: ``du'/dq`` times ``G = dq'/du``); ``du'/dq``
    alone, in the quaternion's four components, is not it."""
    path = write(tmp_path, urdf(FLOATING_PARTS, "hopper"))
    scn = urdf_scene(path, floating=True)
    out = mbgen.Output
    compiled = mbgen.compile(scn.__class__(**{**scn.__dict__, "outputs": (
        out.RHS, out.JACOBIAN)}))
    # the same in C: the generated tangent_jacobian (the sum over G before the solve)
    result = run(scn.__class__(**{**scn.__dict__, "outputs": (out.RHS, out.TANGENT_JACOBIAN)}))
    direct = result.compiled
    reference = mbgen.LambdifiedModel(result.baked, direct.outputs, layout=result.layout)
    model = pinocchio_model(path, True)
    data = model.createData()
    rng = np.random.default_rng(4)
    for _ in range(3):
        q, v, tau = random_state(rng, model, True)
        pin.computeABADerivatives(model, data, q, v, np.concatenate([np.zeros(6), tau]))
        x = np.concatenate([q, v])
        T = direct.tangent_jacobian(0.0, x, None, tau)
        assert T.shape == (model.nv, 2 * model.nv)
        for source in (compiled, direct):
            dq, dv = mbgen.tangent_jacobian(source, x, None, tau)
            for ours, theirs in ((dq, data.ddq_dq), (dv, data.ddq_dv)):
                assert np.abs(ours - theirs).max() <= RTOL * np.abs(theirs).max()
        np.testing.assert_allclose(reference.tangent_jacobian(0.0, x, None, tau), T,
                                   rtol=1e-9, atol=1e-9 * np.abs(T).max())
        J = compiled.jacobian(0.0, x, None, tau)
        assert J[model.nq:, :model.nq].shape != data.ddq_dq.shape


def test_tangent_jacobian_names_the_missing_output(arm_compiled):
    assert mbgen.Output.JACOBIAN not in arm_compiled.outputs
    with pytest.raises(mbgen.MbgenError, match="compile with outputs including 'jacobian'"):
        mbgen.tangent_jacobian(arm_compiled, np.zeros(arm_compiled.n_x))


def test_the_floating_root_is_one_joint_owning_six_unit_speeds(tmp_path):
    """Newton-Euler sees the free-flyer as one joint that owns its six speeds, with the
    identity for motion subspace and w x v (and gravity) for its velocity-product term:
    R^T R of the quaternion's rotation cancels instead of multiplying through the tree
    (before, each linear column was R^T R e_k, 49 to 66 operations an entry, and each
    component of the root's acceleration some 1,200)."""
    path = write(tmp_path, urdf(FLOATING_PARTS, "hopper"))
    model = mbgen.from_urdf(path, floating=True)
    ne = NewtonEuler(prepare(model))
    assert speed_owners(ne) is not None
    root = ne.bodies[0]
    assert root.parent is None and sorted(ne.kin[root].S) == list(range(6))
    for k, col in ne.kin[root].S.items():   # speeds (v, w); spatial vectors (w, v)
        assert list(col) == [1 if i == (k + 3) % 6 else 0 for i in range(6)], k
    defs = dict(ne.P.assignments)
    wx, wy, wz = (sm.Symbol(f"root_w{c}") for c in "xyz")
    vx, vy, vz = (sm.Symbol(f"root_v{c}") for c in "xyz")
    acc = [defs.get(a, a) for a in ne.kin[root].acc]
    assert all(sm.count_ops(a) <= 20 for a in acc), acc
    w_x_v = (wy * vz - wz * vy, wz * vx - wx * vz, wx * vy - wy * vx)
    g = sm.Symbol("g")
    assert [sm.expand(a - b).coeff(g, 0) for a, b in zip(acc, w_x_v)] == [0, 0, 0]
    # a floating base makes every chain on it six speeds longer: Newton-Euler, not compared
    choice = choose_method(model)
    assert choice.method is Method.NEWTON_EULER, choice.reason
    assert "a chain of 3 bodies and 8 speeds; Kane's method not derived" in choice.reason


def test_a_free_flying_body_costs_few_operations(tmp_path):
    """One floating body: 147 operations after CSE (before: 414, the quaternion's
    normalisation carried through R^T R; Kane's method 490)."""
    path = write(tmp_path, urdf([FLOATING_PARTS[0]], "flyer"))
    result = mbgen.pipeline.run(urdf_scene(path, floating=True), build=False)
    assert result.equations.method == "newton_euler"
    assert result.kernel.ops_after <= 180, result.kernel.ops_after


def test_the_rounding_of_constant_rotations_is_dropped(tmp_path):
    """A tilted axis turns the frame by constant rotations whose rounding left products of
    inertia of 6e-19 here (offsets of 6e-18 m on Unitree G1's arms), each an operation in
    every recursion through them: components below 1e-12 of their largest are zero."""
    path = write(tmp_path, urdf([
        link("base_link", inertial(5.0)),
        link("upper", inertial(2.0, "0.05 0.01 0.2")),
        link("fore", inertial(1.5, "0.02 -0.03 0.15")),
        joint("shoulder", "continuous", "base_link", "upper", "0 0 0.3", axis="0.3 0.4 0.866"),
        joint("elbow", "continuous", "upper", "fore", "0 0 0.4", axis="0 0 1")]))
    m = mbgen.from_urdf(path)
    numbers = [float(c) for b in m.bodies for c in b.inertia]
    numbers += [float(c) for pd in m.points.values() if pd.offset != 0
                for matrix, _ in pd.offset.args for c in matrix]
    assert numbers and all(x == 0 or abs(x) > 1e-12 for x in numbers), numbers
    compare(path, False, [mbgen.compile(urdf_scene(path), method=mbgen.Method.KANE)], samples=2)


def test_a_urdf_file_is_a_scene(arm_path):
    scn = load_scene(arm_path)
    assert scn.name == "arm" and scn.parameters == {"g": 9.81} and scn.initial_state == {}
    assert scn.source == str(Path(arm_path).resolve())
    assert load_scene(arm_path, floating="true").initial_state == {"root_qw": 1.0}


@pytest.mark.slow
def test_check_and_generate_take_a_urdf_file(arm_path, tmp_path):
    assert main(["check", arm_path, "--samples", "3"]) == 0
    assert main(["generate", arm_path, "-o", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "arm.c").is_file()


# ----------------------------------------------------------------------------- refusals
def replaced(old, new):
    return urdf(ARM_PARTS).replace(old, new, 1)


ELBOW_AXIS = '<axis xyz="0.3 -0.5 0.8"/>'


BAD = {
    "malformed": (UrdfSyntaxError, "not well-formed", urdf(ARM_PARTS)[:-10]),
    "not a robot": (UrdfSyntaxError, "not <robot>", "<model name='x'/>"),
    "doctype": (UrdfSyntaxError, "DOCTYPE",
                '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaaaaaaaa">'
                '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]><robot name="x">&b;</robot>'),
    "external entity": (UrdfSyntaxError, "DOCTYPE",
                        '<!DOCTYPE r [<!ENTITY e SYSTEM "file:///etc/passwd">]>'
                        '<robot name="x"><link name="&e;"/></robot>'),
    "not a number": (UrdfSyntaxError, "finite number", replaced('xyz="0 0 0.3"', 'xyz="0 0 nan"')),
    "missing mass": (UrdfInertiaError, "link 'upper'.*no <mass", replaced(
        '<mass value="2.0"/>', "")),
    "massless moving link": (UrdfInertiaError, "joint 'e'.*link 'empty'", urdf(
        ARM_PARTS + [link("empty"), joint("e", "revolute", "tool", "empty", axis="1 0 0")])),
    "negative mass": (UrdfInertiaError, "link 'upper'.*negative", replaced(
        '<mass value="2.0"/>', '<mass value="-2.0"/>')),
    "indefinite inertia": (UrdfInertiaError, "link 'upper'.*positive semidefinite", replaced(
        '<mass value="2.0"/><inertia ixx="0.02" iyy="0.03" izz="0.025" ixy="0.001"',
        '<mass value="2.0"/><inertia ixx="0.02" iyy="0.03" izz="0.025" ixy="0.5"')),
    "unknown joint type": (UrdfUnsupportedError, "joint 'elbow'.*'hinge'", replaced(
        'name="elbow" type="revolute"', 'name="elbow" type="hinge"')),
    "floating joint": (UrdfUnsupportedError, "floating=True", replaced(
        'name="elbow" type="revolute"', 'name="elbow" type="floating"')),
    "mimic of nothing": (UrdfStructureError, "joint 'elbow'.*mimics joint 'none', which is "
                         "not a <joint>", replaced(ELBOW_AXIS,
                                                   ELBOW_AXIS + '<mimic joint="none"/>')),
    "mimic of a fixed joint": (UrdfStructureError, "mimics joint 'tool-mount', which is fixed",
                               replaced(ELBOW_AXIS, ELBOW_AXIS + '<mimic joint="tool-mount"/>')),
    "mimics in a cycle": (UrdfStructureError, "closes a cycle of mimics \\(shoulder -> elbow "
                          "-> shoulder\\)", replaced(ELBOW_AXIS, ELBOW_AXIS + '<mimic joint='
                                                     '"shoulder"/>').replace(
        '<axis xyz="0 0 1"/>', '<axis xyz="0 0 1"/><mimic joint="elbow"/>', 1)),
    "mimic without a leader": (UrdfSyntaxError, "joint 'elbow'.*<mimic> has no joint", replaced(
        ELBOW_AXIS, ELBOW_AXIS + '<mimic multiplier="2"/>')),
    "limit not a number": (UrdfSyntaxError, "joint 'shoulder'.*<limit> upper=\"nan\"", replaced(
        'upper="3" effort="10"', 'upper="nan" effort="10"')),
    "two parents": (UrdfStructureError, "link 'hand' has two parents", urdf(
        ARM_PARTS + [joint("extra", "fixed", "upper", "hand")])),
    "cycle": (UrdfStructureError, "cycle.*c1, c2", urdf(
        ARM_PARTS + [link("c1"), link("c2"), joint("a", "fixed", "c1", "c2"),
                     joint("b", "fixed", "c2", "c1")])),
    "no root": (UrdfStructureError, "no root", urdf(
        ARM_PARTS + [joint("back", "fixed", "tool", "base_link")])),
    "two roots": (UrdfStructureError, "2 root links", urdf(ARM_PARTS + [link("stray")])),
    "missing link": (UrdfStructureError, "'nowhere' is not a <link>", urdf(
        ARM_PARTS + [joint("x", "fixed", "tool", "nowhere")])),
    "names collide": (UrdfStructureError, "both become the name 'q_a_b'", urdf(
        ARM_PARTS + [link("p", inertial(1)), link("r", inertial(1)),
                     joint("a-b", "revolute", "tool", "p", axis="1 0 0"),
                     joint("a.b", "revolute", "tool", "r", axis="1 0 0")])),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_file_is_refused_by_name(case, tmp_path):
    error, match, text = BAD[case]
    path = write(tmp_path, text)
    with pytest.raises(error, match=match) as info:
        mbgen.from_urdf(path)
    assert isinstance(info.value, UrdfError) and "robot.urdf" in str(info.value)


def test_a_file_over_the_size_limit_is_refused_before_it_is_read(tmp_path, monkeypatch):
    path = write(tmp_path, urdf(ARM_PARTS))
    monkeypatch.setattr(urdf_xml, "MAX_URDF_BYTES", 100)
    monkeypatch.setattr(Path, "read_bytes", lambda self: pytest.fail("the file was read"))
    with pytest.raises(UrdfSyntaxError, match="limit"):
        mbgen.from_urdf(path)


def test_a_missing_file_is_a_scene_error_and_a_urdf_error(tmp_path):
    with pytest.raises(mbgen.SceneError, match="does not exist"):
        load_scene(str(tmp_path / "none.urdf"))
    with pytest.raises(UrdfSyntaxError, match="cannot be read"):
        mbgen.from_urdf(tmp_path / "none.urdf")


def test_a_path_that_is_no_file_is_named_for_what_it_is(tmp_path):
    """A folder and a device are refused by what they are, before anything is read."""
    folder = tmp_path / "robot.urdf"
    folder.mkdir()
    with pytest.raises(UrdfSyntaxError, match="is a folder, not a file"):
        mbgen.from_urdf(folder)
    with pytest.raises(UrdfSyntaxError, match="is a character device, not a file"):
        mbgen.from_urdf(os.devnull)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_a_named_pipe_is_refused_without_blocking(tmp_path):
    """Was: the size stat'ed as 0, then a read that waited for a writer for ever."""
    fifo = tmp_path / "robot.urdf"
    os.mkfifo(fifo)
    error = read_in_thread(mbgen.from_urdf, fifo)
    assert isinstance(error, UrdfSyntaxError) and "is a named pipe (FIFO), not a file" in \
        str(error), error


# ----------------------------------------------------------------------------- sizes
def chain(n: int) -> str:
    """A chain of ``n`` links joined by ``n - 1`` revolute joints."""
    links = [link(f"l{i}", inertial(1.0, "0 0 0.05")) for i in range(n)]
    joints = [joint(f"j{i}", "revolute", f"l{i - 1}", f"l{i}", "0 0 0.1", axis="0 1 0")
              for i in range(1, n)]
    return urdf(links + joints, "chain")


def test_reading_is_linear_in_the_links(monkeypatch):
    """Reading looks at each joint's parent a few times, not once per link (quadratic: a
    50 MB file of 170,000 links took hours to read); counted, not timed."""
    Counted = count_joint_parent_reads(monkeypatch)
    n = 1000
    with limits.allow_large_models():     # past the size guard, to be read
        robot = urdf_xml.parse_urdf(chain(n))
    assert [j.child for j in robot.ordered_joints()] == [f"l{i}" for i in range(1, n)]
    assert Counted.reads <= 4 * n, Counted.reads


def test_a_robot_past_the_size_guard_is_refused_as_soon_as_it_is_parsed(tmp_path, monkeypatch):
    """A 20,000-link chain is refused by the size guard (ModelSizeError, with the fix) before
    its elements are checked; the links are counted too, and a floating base's six speeds."""
    path = write(tmp_path, chain(20_000), "chain.urdf")
    monkeypatch.setattr(urdf_xml._Reader, "link", lambda *a: pytest.fail("a link was read"))
    with pytest.raises(ModelSizeError, match="chain.urdf' with 19999 moving joints.*--force"):
        mbgen.from_urdf(path)
    monkeypatch.undo()
    monkeypatch.setattr(urdf_xml, "MAX_URDF_LINKS", 5)
    with pytest.raises(ModelSizeError, match="has 6 links, more than 5.*force=True"):
        mbgen.from_urdf(arm_file(tmp_path))
    assert mbgen.from_urdf(arm_file(tmp_path), force=True).bodies
    monkeypatch.undo()
    monkeypatch.setattr(limits, "MAX_SPEEDS", 4)
    assert mbgen.from_urdf(arm_file(tmp_path)).speeds_
    with pytest.raises(ModelSizeError, match="4 moving joints on a floating base has 10 speeds"):
        mbgen.from_urdf(arm_file(tmp_path), floating=True, force=False)


def arm_file(tmp_path):
    return write(tmp_path, urdf(ARM_PARTS), "arm.urdf")


# ----------------------------------------------------------------------------- numbers
def centres(model, values: dict) -> list[np.ndarray]:
    """Each body's mass centre in the world at the coordinates ``values`` (by name)."""
    at = {q: values[str(q.func)] for q in model.coordinates_}
    return [np.array(b.center.pos_from(model.origin).to_matrix(model.N).subs(at),
                     dtype=float).ravel() for b in model.bodies]


def pinocchio_centres(path, q) -> list[np.ndarray]:
    """The same from Pinocchio's forward kinematics (its joints' bodies, in the same order)."""
    model = pinocchio_model(path)
    data = model.createData()
    pin.forwardKinematics(model, data, pinocchio_q(model, q))
    return [data.oMi[i].act(model.inertias[i].lever) for i in range(1, model.njoints)]


@pytest.mark.parametrize("kind", ["revolute", "continuous", "prismatic"])
@pytest.mark.parametrize("axis", ["0 0 -1", "-1 0 0", "0 -1 0", "0 0 1", "0 -0.6 -0.8"])
def test_a_joint_turns_the_way_its_axis_points(kind, axis, tmp_path):
    """The child's mass centre at q = 0.7 where Pinocchio puts it, for axes along the
    negative coordinate axes too (an axis -e_k is e_k with the angle's sign flipped)."""
    path = write(tmp_path, urdf([
        link("base_link", inertial(2.0)), link("arm", inertial(1.0, "0.3 0.1 0.2")),
        joint("j", kind, "base_link", "arm", "0.1 0 0.2", "0 0 0", axis, LIMIT)]))
    ours = centres(mbgen.from_urdf(path), {"q_j": 0.7})
    theirs = pinocchio_centres(path, np.array([0.7]))
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-12)


@pytest.mark.parametrize("axis, unit", [("1e200 0 0", (1.0, 0.0, 0.0)),
                                        ("1e-200 0 0", (1.0, 0.0, 0.0)),
                                        ("3e307 -4e307 0", (0.6, -0.8, 0.0)),
                                        ("0 0 -5e-324", (0.0, 0.0, -1.0))])
def test_an_axis_of_any_scale_is_its_direction(axis, unit):
    """|axis|^2 of 1e200 overflowed to inf and the axis became (0, 0, 0): the joint
    turned about y (u' 28.78 for 16.93); one of 1e-200 was refused as zero."""
    robot = urdf_xml.parse_urdf(replaced('<axis xyz="1 0 0"/>', f'<axis xyz="{axis}"/>'))
    assert robot.joints["hand"].axis == pytest.approx(unit, abs=1e-15)


OUT_OF_RANGE = {
    "joint origin": ('xyz="0 0 0.3"', 'xyz="0 0 1e300"', "joint 'shoulder'.*<origin> xyz"),
    "joint rpy": ('rpy="0.3 -0.2 0.5"', 'rpy="0.3 -2e20 0.5"', "joint 'shoulder'.*<origin> rpy"),
    "axis": ('<axis xyz="1 0 0"/>', '<axis xyz="1 inf 0"/>', "joint 'wrist'.*<axis> xyz"),
    "mass": ('<mass value="2.0"/>', '<mass value="1e300"/>', "link 'upper'.*<mass> value"),
    "inertia": ('ixx="0.002" iyy="0.003" izz="0.0025"', 'ixx="2e290" iyy="3e290" izz="2e290"',
                "link 'hand'.*<inertia> ixx"),
    "centre": ('xyz="0.05 0.01 0.2"', 'xyz="0.05 1e200 0.2"', "link 'upper'.*<origin> xyz"),
}


@pytest.mark.parametrize("case", sorted(OUT_OF_RANGE))
def test_a_number_that_would_overflow_is_refused_by_name(case, tmp_path):
    old, new, match = OUT_OF_RANGE[case]
    path = write(tmp_path, replaced(old, new))
    with pytest.raises(UrdfSyntaxError, match=match):
        mbgen.from_urdf(path)


# ----------------------------------------------------------------------------- floating base
def hip(name, child, xyz, axis):
    return joint(name, "revolute", "trunk", child, xyz, "0 0 0", axis, LIMIT)


#: (parts, singular): a floating root's mass matrix is singular when some motion of the root
#: moves no mass: the root's articulated inertia (what it carries, each joint free) is singular
FLOATING_CASES = {
    "massless trunk, one leg": ([link("trunk")] + FLOATING_PARTS[1:], True),
    "massless trunk, hips on one line": ([
        link("trunk"), link("left", inertial(0.4, "0 0 -0.1")),
        link("right", inertial(0.4, "0 0 -0.1")),
        hip("hl", "left", "0 0.1 0", "0 1 0"), hip("hr", "right", "0 -0.1 0", "0 1 0")], True),
    "point-mass trunk": ([link("trunk", inertial(3.0, i=(0, 0, 0, 0, 0, 0)))], True),
    "massless trunk, two hips across": ([
        link("trunk"), link("left", inertial(0.4, "0 0 -0.1")),
        link("right", inertial(0.4, "0 0 -0.1")),
        hip("hl", "left", "0 0.1 0", "0 1 0"), hip("hr", "right", "0 -0.1 0", "1 0 0")], False),
    "massless trunk, a fixed body": ([
        link("trunk"), link("box", inertial(1.0, "0 0 0.1")), link("leg", inertial(0.4)),
        joint("weld", "fixed", "trunk", "box", "0.1 0 0"),
        hip("hip", "leg", "0 0 -0.1", "0 1 0")], False),
    "hopper": (FLOATING_PARTS, False),
}


@pytest.mark.parametrize("case", sorted(FLOATING_CASES))
def test_a_floating_root_that_moves_no_mass_is_refused(case, tmp_path):
    """Refused exactly where Pinocchio's free-flyer mass matrix is singular (at any state):
    a massless trunk with one leg is, though the leg's composite inertia is full rank (the
    trunk turns about the hip while the hip turns back); it gave finite garbage at half the
    states and SingularMassMatrixError at the rest."""
    parts, singular = FLOATING_CASES[case]
    path = write(tmp_path, urdf(parts, "flyer"))
    model = pinocchio_model(path, floating=True)
    data = model.createData()
    rng = np.random.default_rng(2)
    for _ in range(2):
        q, _, _ = random_state(rng, model, True)
        moments = np.linalg.eigvalsh(pin.crba(model, data, q))
        assert (moments[0] < 1e-12 * moments[-1]) == singular, moments
    if singular:
        with pytest.raises(UrdfInertiaError, match="floating root link 'trunk'"):
            mbgen.from_urdf(path, floating=True)
    else:
        assert mbgen.from_urdf(path, floating=True).coordinates_
    mbgen.from_urdf(path)   # a fixed root holds the trunk: fine
