"""A compliant ground (``Model.ground``, :mod:`mbgen.model.ground`).

A ball (a sphere of radius R on the ground: x, y, z and a turn about y) against the law
written out by hand (numpy, from the module docstring) at seeded states in every branch
(above the ground, pushed, let go while penetrating), in the compiled C, the generated
Python and lambdified sympy; the Jacobian against finite differences of the hand formula;
the ball dropped from 0.4 m bounces with its energy (kinetic, gravity and the ground's
spring) falling at every output time, comes to rest sunk by ``m g / k`` and rolls at 5/7
of its sliding speed (a solid sphere's rolling without slip); a URDF robot's ground points
(a link merged by a fixed joint among them) at Pinocchio's frame heights, and (slow) its
accelerations on the ground Pinocchio's with the forces by hand; an MJCF model's sphere
geoms and sites at MuJoCo's; bad input.
"""

import numpy as np
import pytest

import mbgen
from checks import assert_close
from mbgen import Model, Output
from mbgen.errors import ArgumentTypeError, ModelError, UrdfStructureError
from mbgen.model.ground import (
    DROP,
    PENETRATION,
    STANDARD_GRAVITY,
    default_stiffness,
    drop_state,
    heights,
)

M, R, I, K, C, MU, VS, G = 1.0, 0.1, 0.004, 1e4, 20.0, 0.8, 0.01, 9.81


def ball(**ground) -> Model:
    m = Model("ball")
    x, y, z, th = m.coordinates("x y z th")
    m.speeds("ux uy uz w")
    g, mass, radius = m.constants("g m R", defaults=[G, M, R])
    N = m.newtonian()
    B = m.rotate(N, "B", 2, th)
    P = m.point("P", m.origin, x * N.x + y * N.y + z * N.z)
    m.body("ball", B, mass, (I, I, I), P)
    m.gravity(-g * N.z)
    m.ground([P], **{"k": K, "c": C, "mu": MU, "slip": VS, "radius": radius, **ground})
    return m


def by_hand(x) -> np.ndarray:
    """The ball's ``u'``: normal force ``-K h - C h'`` where ``h = z - R < 0`` and it pushes,
    friction ``-MU f_n v / sqrt(|v|^2 + VS^2)`` at the sphere's bottom, whose velocity is
    ``(ux - R w, uy)``; its moment about y is ``-R F_x``."""
    z, ux, uy, uz, w = x[2], x[4], x[5], x[6], x[7]
    h, push = z - R, -K * (z - R) - C * uz
    fn = push if h < 0 and push > 0 else 0.0
    vx, vy = ux - R * w, uy
    scale = -MU * fn / np.sqrt(vx ** 2 + vy ** 2 + VS ** 2)
    return np.array([scale * vx / M, scale * vy / M, fn / M - G, -R * scale * vx / I])


@pytest.fixture(scope="module")
def models():
    model = ball()
    result = mbgen.run(model, (Output.RHS, Output.JACOBIAN, Output.ROSENBROCK, Output.ENERGY))
    c = result.compiled
    lam = mbgen.LambdifiedModel(result.baked, (Output.RHS,), layout=c.layout)
    return c, mbgen.python_model(result.rendered), lam


def states(n=60, seed=3) -> np.ndarray:
    """Seeded states: heights within 1 cm of touching, speeds up to 3 (every branch)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, (n, 8)) * [1, 1, 0, 3, 3, 3, 3, 30]
    x[:, 2] = R + rng.uniform(-0.01, 0.01, n)
    return x


def test_the_law_is_the_hand_formula_in_c_python_and_sympy(models):
    c, py, lam = models
    assert c.parameter_names == ("g", "m", "R", "k_ground", "c_ground", "mu", "v_slip")
    x = states()
    h, push = x[:, 2] - R, -K * (x[:, 2] - R) - C * x[:, 6]
    branches = {(bool(a), bool(b)) for a, b in zip(h < 0, push > 0)}
    assert {(False, True), (False, False), (True, True), (True, False)} <= branches
    for xi in x:
        expected = np.concatenate([xi[4:], by_hand(xi)])
        for back in (c, py, lam):
            assert_close(back.rhs(0.0, xi), expected, 1e-12)


def test_the_jacobian_is_the_hand_formulas(models):
    c = models[0]
    for xi in states(20, seed=5):
        h, push = xi[2] - R, -K * (xi[2] - R) - C * xi[6]
        if abs(h) < 1e-4 or abs(push) < 1.0:   # next to a kink: no difference quotient
            continue
        eps = 1e-7 * np.maximum(1.0, np.abs(xi))
        columns = [(by_hand(xi + e) - by_hand(xi - e)) / (2 * e[k])
                   for k, e in enumerate(np.diag(eps))]
        assert_close(c.jacobian(0.0, xi)[4:], np.column_stack(columns), 1e-6)


def test_a_dropped_ball_bounces_loses_energy_and_rests_sunk_by_its_weight(models):
    """Stiff: auto takes the C rosenbrock; every output time has less energy than the one
    before (to the integration's tolerance), it leaves the ground more than once, rests
    ``m g / k`` deep and rolls at 5/7 of its first speed, turning at ``v / R``."""
    c = models[0]
    x0 = np.array([0, 0, 0.5, 0, 1.0, 0, 0, 0])
    traj = mbgen.simulate(c, x0, (0, 5), n_out=2001, stiff=True, rtol=1e-8, atol=1e-10)
    assert traj.method == "C rosenbrock"
    T, V = np.array([c.energy(0.0, xi) for xi in traj.x]).T
    h = traj.x[:, 2] - R
    E = T + V + 0.5 * K * np.minimum(h, 0.0) ** 2
    assert np.diff(E).max() <= 1e-6 * E[0]
    assert E[-1] < 0.3 * E[0]
    contacts = np.diff((h < 0).astype(int))
    assert (contacts == 1).sum() >= 3 and (contacts == -1).sum() >= 2   # bounces
    assert abs(h[-1] + M * G / K) < 1e-6
    assert abs(traj.x[-1, 6]) < 1e-4
    assert_close(traj.x[-1, [4, 7]], [5 / 7, 5 / 7 / R], 1e-4)


def test_defaults_follow_the_mass_and_the_constants_are_named():
    m = ball(k=None, c=None, mu=1.0, slip=0.01)
    k, c = default_stiffness(m, 1)
    assert k == pytest.approx(M * STANDARD_GRAVITY / PENETRATION)
    assert c == pytest.approx(2 * np.sqrt(k * M))
    assert m.defaults_["k_ground"] == k and m.defaults_["c_ground"] == c
    record = m.ground_
    assert [p.name for p in record.points] == ["P"] and record.frames[0].name == "B"
    assert heights(m, {"z": 0.25}) == pytest.approx([0.15])
    assert drop_state(m, {"z": 0.0}, 0.2, height="z") == {"z": pytest.approx(0.3)}
    with pytest.raises(ModelError, match="has no floating base \\(root_z"):
        drop_state(m, {}, 0.2)
    assert DROP == 0.3


def test_expressions_are_used_as_given():
    m = Model("slab")
    z, = m.coordinates("z")
    m.speeds("w")
    k0, = m.constants("k0", defaults=[5.0])
    N = m.newtonian()
    P = m.point("P", m.origin, z * N.z)
    m.particle("p", P, 2.0)
    record = m.ground("P", k="3*k0", c=0, mu=0)
    assert record.stiffness == 3 * k0 and str(record.damping) == "c_ground"
    assert [str(s) for s in m.constants_] == ["k0", "c_ground", "mu", "v_slip"]
    assert m.defaults_ == {"k0": 5.0, "c_ground": 0.0, "mu": 0.0, "v_slip": 0.01}


@pytest.mark.parametrize("call, match", [
    (lambda m: m.ground([]), "at least one contact point"),
    (lambda m: m.ground(["Q"]), "no point 'Q' \\(points: P\\)"),
    (lambda m: m.ground(["P", "P"]), "named twice"),
    (lambda m: m.ground(["O"]), "origin is fixed"),
    (lambda m: m.ground(["P"], k=-1.0), "k=-1.0; give a finite number >= 0"),
    (lambda m: m.ground(["P"], slip=0.0), "slip=0.0; give a finite number > 0"),
    (lambda m: m.ground(["P"], radius=[0.1, 0.2]), "2 radii for 1 points"),
    (lambda m: m.ground(["P"], radius=-0.1), "radius must be a finite number >= 0"),
    (lambda m: (m.ground(["P"]), m.ground(["P"])), "already has a ground"),
])
def test_bad_input_is_named(call, match):
    m = Model("slab")
    z, = m.coordinates("z")
    m.speeds("w")
    N = m.newtonian()
    m.particle("p", m.point("P", m.origin, z * N.z), 2.0)
    with pytest.raises(ModelError, match=match):
        call(m)


def test_symbolic_masses_need_k_and_c():
    m = Model("slab")
    z, = m.coordinates("z")
    m.speeds("w")
    mass, = m.constants("mass")
    N = m.newtonian()
    m.particle("p", m.point("P", m.origin, z * N.z), mass)
    with pytest.raises(ModelError, match="give k= and c="):
        m.ground(["P"])
    mu, = m.constants("mu")
    with pytest.raises(ModelError, match="already has a constant 'mu'; pass mu=mu"):
        m.ground(["P"], k=1.0, c=1.0)
    assert m.ground(["P"], k=1.0, c=1.0, mu=mu).friction is mu   # nothing was left declared


# ----------------------------------------------------------------------------- URDF
def test_urdf_ground_points_sit_at_pinocchios_frames(tmp_path):
    """Points on a moving link and on a link fixed below one, against Pinocchio's
    ``framesForwardKinematics`` at seeded configurations."""
    pin = pytest.importorskip("pinocchio")
    from urdf_models import FLOATING_PARTS, inertial, joint, link, urdf, write

    parts = FLOATING_PARTS + [link("toe", inertial(0.05)),
                              joint("ankle", "fixed", "foot", "toe", "0.03 -0.02 -0.08",
                                    "0.3 0.2 0.1")]
    path = write(tmp_path, urdf(parts, "walker"))
    m = mbgen.from_urdf(path, floating=True, ground=("toe", "leg"))
    assert [p.name for p in m.ground_.points] == ["toe", "leg_origin"]
    model = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
    data = model.createData()
    names = [str(q.func) for q in m.coordinates_]
    rng = np.random.default_rng(4)
    for _ in range(5):
        quat = rng.normal(size=4)
        q = np.concatenate([rng.uniform(-1, 1, 3), quat / np.linalg.norm(quat),
                            rng.uniform(-1, 1, model.nq - 7)])
        pin.framesForwardKinematics(model, data, q)
        expected = [data.oMf[model.getFrameId(f)].translation[2] for f in ("toe", "leg")]
        assert_close(heights(m, dict(zip(names, q))), expected, 1e-12)
    spheres = mbgen.from_urdf(path, floating=True, ground={"toe": 0.02})
    assert spheres.ground_.radii == (0.02,)
    with pytest.raises(UrdfStructureError, match="no link 'tow' for the ground.*'toe'"):
        mbgen.from_urdf(path, floating=True, ground="tow")
    with pytest.raises(ArgumentTypeError, match="ground must be link names"):
        mbgen.from_urdf(path, floating=True, ground=3)


def by_hand_force(h, v, k, c, mu, slip) -> np.ndarray:
    """The law of the module docstring at a contact of height ``h`` and velocity ``v``."""
    push = -k * h - c * v[2]
    fn = push if h < 0 and push > 0 else 0.0
    return np.array([*(-mu * fn * v[:2] / np.sqrt(v[0] ** 2 + v[1] ** 2 + slip ** 2)), fn])


@pytest.mark.slow
def test_a_floating_robot_on_the_ground_is_pinocchios_with_the_forces_by_hand(tmp_path):
    """The walker's accelerations with two contacts (a link fixed below the last one among
    them) equal Pinocchio's ``aba`` with the law's forces, computed by hand from its frame
    placements and velocities, as external forces on the joints that carry them, at
    seeded states with the contacts near the ground (both branches)."""
    pin = pytest.importorskip("pinocchio")
    from urdf_models import FLOATING_PARTS, inertial, joint, link, urdf, write

    parts = FLOATING_PARTS + [link("toe", inertial(0.05)),
                              joint("ankle", "fixed", "foot", "toe", "0.03 -0.02 -0.08",
                                    "0.3 0.2 0.1")]
    path = write(tmp_path, urdf(parts, "walker"))
    m = mbgen.from_urdf(path, floating=True, ground=("toe", "leg"))
    c = mbgen.compile(m)
    law = [c.parameter_defaults[n] for n in ("k_ground", "c_ground", "mu", "v_slip")]
    model = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    data = model.createData()
    frames = [model.getFrameId(f) for f in ("toe", "leg")]
    rng = np.random.default_rng(9)
    pressed = 0
    for _ in range(8):
        quat = rng.normal(size=4)
        q = np.concatenate([[0, 0, 0], quat / np.linalg.norm(quat),
                            rng.uniform(-1, 1, model.nq - 7)])
        pin.framesForwardKinematics(model, data, q)
        q[2] = -min(data.oMf[f].translation[2] for f in frames) + rng.uniform(-0.01, 0.005)
        v = rng.uniform(-1, 1, model.nv)
        pin.forwardKinematics(model, data, q, v)
        pin.updateFramePlacements(model, data)
        fext = [pin.Force.Zero() for _ in range(model.njoints)]
        for f in frames:
            at = data.oMf[f].translation
            vel = pin.getFrameVelocity(model, data, f, pin.LOCAL_WORLD_ALIGNED).linear
            force = by_hand_force(at[2], vel, *law)
            pressed += force[2] > 0
            joint_id = model.frames[f].parentJoint
            R, o = data.oMi[joint_id].rotation, data.oMi[joint_id].translation
            fext[joint_id] += pin.Force(R.T @ force, R.T @ np.cross(at - o, force))
        expected = pin.aba(model, data, q, v, np.zeros(model.nv), fext)
        assert_close(c.rhs(0.0, np.concatenate([q, v]))[model.nq:], expected, 1e-9)
    assert 0 < pressed < 16


MJCF = """<mujoco model="dropper">
  <worldbody>
    <body name="torso" pos="0 0 1">
      <freejoint name="root"/>
      <geom name="core" type="box" size="0.1 0.1 0.1" mass="2"/>
      <body name="arm" pos="0.1 0.05 0" euler="10 20 30">
        <joint name="swing" type="hinge" axis="0.3 1 0.2"/>
        <geom name="hand" type="sphere" pos="0.02 -0.03 -0.3" size="0.04" mass="0.5"/>
        <site name="elbow" pos="0.01 0.02 -0.1"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""


def test_mjcf_sphere_geoms_and_sites_sit_at_mujocos(tmp_path):
    """A sphere geom's height is its centre's in MuJoCo minus its radius, a site's its own,
    at seeded ``qpos`` (a free joint and a tilted hinge above them); the file's scene
    drops it (its free joint's ``_z`` lifted) with its hinge held."""
    from mujoco_models import mujoco, random_qpos

    mj = mujoco.MjModel.from_xml_string(MJCF)
    m = mbgen.from_mujoco(mj, ground="hand,elbow")
    assert [p.name for p in m.ground_.points] == ["hand", "elbow"]
    assert m.ground_.radii == (pytest.approx(0.04), 0)
    data = mujoco.MjData(mj)
    names = [str(q.func) for q in m.coordinates_]
    rng = np.random.default_rng(6)
    for _ in range(5):
        data.qpos[:] = random_qpos(rng, mj)
        mujoco.mj_kinematics(mj, data)
        expected = [data.geom_xpos[1][2] - 0.04, data.site_xpos[0][2]]
        assert_close(heights(m, dict(zip(names, data.qpos))), expected, 1e-12)
    path = tmp_path / "dropper.xml"
    path.write_text(MJCF, encoding="utf-8")
    scene = mbgen.load_scene(str(path), ground="hand,elbow", hold="5,0.1", drop="0.2")
    assert min(heights(scene.model, scene.initial_state)) == pytest.approx(0.2)
    assert scene.outputs == (Output.RHS, Output.JACOBIAN, Output.ROSENBROCK)
    assert scene.points == ("hand", "elbow") and scene.t_span == (0.0, 3.0)
    assert scene.parameters["kp_hold"] == 5.0 and "k_ground" in scene.parameters
    with pytest.raises(mbgen.errors.MjcfError, match="geom 'core' is no sphere"):
        mbgen.from_mujoco(mj, ground=["core"])
    with pytest.raises(mbgen.errors.MjcfError, match="no geom or site 'hnd'.*'hand'"):
        mbgen.from_mujoco(mj, ground=["hnd"])
