"""Kinematics against the lecture notes' solved problems (P1.3, P2.1, P2.2), through the
SOPHIA-style helpers of :mod:`mbgen.model.kinematics` and through the derivation engine's tree."""

import pytest
import sympy as sm
from sympy.physics import mechanics as me

import mbgen
from mbgen import Model
from mbgen.derivation.prepare import prepare
from mbgen.derivation.tree import simple_rotation
from mbgen.model import kinematics as kin
from mbgen.scenes import bent_pipe, spherical_rod, torque_free


def is_zero(matrix) -> bool:
    return sm.simplify(sm.Matrix(matrix)) == sm.zeros(*sm.Matrix(matrix).shape)


def names(model: Model) -> dict:
    """Coordinates, speeds and constants of ``model`` by name (coordinates as q(t))."""
    out = {str(f.func): f for f in model.coordinates_ + model.speeds_}
    out.update({str(c): c for c in model.constants_})
    return out


def to_plain(expr, model: Model):
    """Replace q(t), q'(t), q''(t), u(t) by plain symbols, with u = q' (and ``ud`` = q'')."""
    sub = {}
    for q, u in zip(model.coordinates_, model.speeds_):
        sub[q.diff(mbgen.t, 2)] = sm.Symbol(f"{u.func}d")
        sub[q.diff(mbgen.t)] = sm.Symbol(str(u.func))
    sub.update({f: sm.Symbol(str(f.func)) for f in model.coordinates_ + model.speeds_})
    return sm.Matrix(expr).xreplace(sub)


def point(model: Model, name: str):
    return next(p for p in model.points if p.name == name)


# ------------------------------------------------------------------- P1.3 spherical frame
def test_p13_chain_of_simple_rotations():
    m = Model("p13")
    phi, theta = m.constants("phi theta")
    N = m.newtonian("N")
    B, S = m.chain_rotations([[N, "B", 3, phi], ["B", "S", 2, theta]])
    c, s = sm.cos, sm.sin
    assert kin.dcm(N, B) == sm.Matrix([[c(phi), -s(phi), 0], [s(phi), c(phi), 0], [0, 0, 1]])
    assert kin.dcm(B, S) == sm.Matrix([[c(theta), 0, s(theta)], [0, 1, 0],
                                       [-s(theta), 0, c(theta)]])
    notes = sm.Matrix([[c(phi) * c(theta), -s(phi), c(phi) * s(theta)],
                       [s(phi) * c(theta), c(phi), s(phi) * s(theta)],
                       [-s(theta), 0, c(theta)]])
    assert is_zero(kin.dcm(N, S) - notes)
    # a position r s3 has the Cartesian components of spherical coordinates
    r, = m.constants("r")
    assert is_zero(kin.components(kin.express(kin.vec(S, [0, 0, r]), N), N)
                   - r * sm.Matrix([s(theta) * c(phi), s(theta) * s(phi), c(theta)]))


@pytest.mark.parametrize("axis", [1, 2, 3])
def test_tree_simple_rotation_is_sympys_dcm(axis):
    m = Model("axes")
    a, = m.constants("a")
    N = m.newtonian("N")
    F = m.rotate(N, "F", axis, a)
    assert sm.Matrix(simple_rotation(axis, a)) == N.dcm(F)


# ------------------------------------------------------------------- P2.1 rod on a spherical joint
def test_p21_rod_end_velocity_and_angular_velocity():
    m = spherical_rod.build_model()
    s = names(m)
    q1, q2, L = s["q1"], s["q2"], s["L"]
    S = m.frame("S")
    end = m.point("end", m.origin, L * S.z)
    v = kin.velocity(end, m.origin, m.N)
    qd1, qd2 = q1.diff(mbgen.t), q2.diff(mbgen.t)
    assert is_zero(kin.components(v, S) - sm.Matrix([L * qd2, L * qd1 * sm.sin(q2), 0]))
    w = kin.angular_velocity(S, m.N)
    assert is_zero(kin.components(w, S) - sm.Matrix([-sm.sin(q2) * qd1, qd2, sm.cos(q2) * qd1]))
    # the notes' second way: v = (N&aV S) x r
    assert is_zero(kin.components((w ^ kin.vec(S, [0, 0, L])) - v, S))


def test_p21_tree_angular_velocity_and_partials():
    m = spherical_rod.build_model()
    prep = prepare(m)
    q2, u1, u2 = sm.symbols("q2 u1 u2")
    node = prep.frame_nodes[m.frame("S")]
    assert is_zero(sm.Matrix(prep.tree.omega(node))
                   - sm.Matrix([-sm.sin(q2) * u1, u2, sm.cos(q2) * u1]))
    partials = prep.tree.omega_partials(node)
    assert is_zero(sm.Matrix(partials[0]) - sm.Matrix([-sm.sin(q2), 0, sm.cos(q2)]))
    assert sm.Matrix(partials[1]) == sm.Matrix([0, 1, 0])


# ------------------------------------------------------------------- P2.2 ball in a bent pipe
def test_p22_ball_position_velocity_and_angular_velocity():
    m = bent_pipe.build_model()
    s = names(m)
    q1, q2, phi, h = s["q1"], s["q2"], s["phi"], s["h"]
    qd1, qd2 = q1.diff(mbgen.t), q2.diff(mbgen.t)
    A, B, ball = m.N, m.frame("B"), point(m, "P")
    r = kin.position(ball, m.origin)
    assert is_zero(kin.components(r, A) - sm.Matrix([
        sm.cos(q1) * sm.sin(phi) * q2, sm.sin(q1) * sm.sin(phi) * q2, h - sm.cos(phi) * q2]))
    assert is_zero(kin.components(kin.velocity(ball, m.origin, A), B)
                   - sm.Matrix([qd2, qd1 * sm.sin(phi) * q2, 0]))
    w = kin.angular_velocity(B, A)
    assert is_zero(kin.components(w, A) - sm.Matrix([0, 0, qd1]))
    assert is_zero(kin.components(w, B) - sm.Matrix([-sm.cos(phi) * qd1, 0, sm.sin(phi) * qd1]))


def tree_point_kinematics(m: Model, name: str):
    """Velocity and acceleration of point ``name`` from the derivation engine, in N components.

    The acceleration is ``a^t + sum_r v_r u_r'``, with ``u_r'`` as the symbol ``u<r>d``.
    """
    prep = prepare(m)
    tree, root = prep.tree, prep.frame_nodes[m.N]
    udot = [sm.Symbol(f"{u}d") for u in prep.layout.speeds]
    v, a = sm.zeros(3, 1), sm.zeros(3, 1)
    for atom in prep.point_atoms[point(m, name)]:
        v += sm.Matrix(tree.express(tree.atom_velocity(atom), atom.frame, root))
        a += sm.Matrix(tree.express(tree.atom_acceleration_rest(atom), atom.frame, root))
        for r, vr in tree.atom_partials(atom).items():
            a += udot[r] * sm.Matrix(tree.express(vr, atom.frame, root))
    return v, a


@pytest.mark.parametrize("build, name", [(bent_pipe.build_model, "P"),
                                         (spherical_rod.build_model, "G")],
                         ids=["bent_pipe-ball", "spherical_rod-centre"])
def test_tree_point_kinematics_equal_sympys(build, name):
    m = build()
    v, a = tree_point_kinematics(m, name)
    r = point(m, name).pos_from(m.origin)
    assert is_zero(v - to_plain(r.dt(m.N).to_matrix(m.N), m))
    assert is_zero(a - to_plain(r.dt(m.N).dt(m.N).to_matrix(m.N), m))


# ------------------------------------------------------------------- body rates as speeds
def test_torque_free_kinematic_equations_invert_the_body_rates():
    """The chain's angular velocity with q' = G(q, u) gives back u1 b1 + u2 b2 + u3 b3."""
    m = torque_free.build_model()
    G = mbgen.equations_of(m).kinematics
    q = me.dynamicsymbols("q1:4")
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Body", q, "123")
    w = to_plain(B.ang_vel_in(N).to_matrix(B), m)
    qdot = dict(zip(sm.symbols("u1:4"), G))  # to_plain wrote q_i' as u_i
    assert is_zero(w.xreplace(qdot) - sm.Matrix(sm.symbols("u1:4")))
