"""URDF robots written in a few lines and compared with Pinocchio: the helpers of
tests/model/test_urdf*.py (text of links, joints and inertias, Pinocchio's model, state and
accelerations, and the comparison of a back end's RHS with ``pin.aba``)."""

import glob
import os
import sysconfig

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio", reason="Pinocchio (pin) is in the test extra")

RTOL = 1e-9


def inertial(mass, xyz="0 0 0", rpy="0 0 0", i=(0.02, 0.03, 0.025, 0.001, -0.002, 0.0015)):
    ixx, iyy, izz, ixy, ixz, iyz = i
    return (f'<inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="{ixy}" ixz="{ixz}" '
            f'iyz="{iyz}"/></inertial>')


def link(name, body=""):
    return f'<link name="{name}">{body}</link>'


def joint(name, kind, parent, child, xyz="0 0 0", rpy="0 0 0", axis=None, extra=""):
    ax = f'<axis xyz="{axis}"/>' if axis else ""
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/>{ax}{extra}</joint>')


#: Pinocchio reads a revolute or prismatic joint only with its limits
LIMIT = '<limit lower="-3" upper="3" effort="10" velocity="5"/>'

#: a branch (fore has two children, listed against name order), rpy origins everywhere,
#: a tilted revolute axis, a prismatic axis off the coordinate axes, a continuous joint,
#: a fixed tool whose inertial is turned, names to sanitise ("tool-mount")
ARM_PARTS = [
    link("base_link", inertial(5.0)),
    link("upper", inertial(2.0, "0.05 0.01 0.2", "0.1 0.2 0.3")),
    link("fore", inertial(1.5, "0.02 -0.03 0.15", "-0.4 0.1 0.0",
                          (0.015, 0.012, 0.009, 0.0005, 0.001, -0.0007))),
    link("hand", inertial(0.5, "0.01 0.02 0.03", "0 0 0", (0.002, 0.003, 0.0025, 0, 0, 0.0001))),
    link("slider", inertial(0.3, "0 0.01 0.02")),
    link("tool", inertial(0.2, "0.01 0 0.05", "0.3 -0.2 0.1", (0.001, 0.0012, 0.0009, 0, 0, 0))),
    joint("shoulder", "revolute", "base_link", "upper", "0 0 0.3", "0.3 -0.2 0.5", "0 0 1",
          '<limit lower="-3" upper="3" effort="10" velocity="5"/>'),
    joint("elbow", "revolute", "upper", "fore", "0.1 0 0.4", "1.5707963267948966 0 0.2",
          "0.3 -0.5 0.8", '<limit lower="-3" upper="3" effort="10" velocity="5"/>'),
    joint("wrist", "continuous", "fore", "hand", "0 0 0.3", "0 1.5707963267948966 0", "1 0 0"),
    joint("slide", "prismatic", "fore", "slider", "0 0.05 0.3", "0 0.4 0", "0 1 1",
          '<limit lower="-1" upper="1" effort="10" velocity="5"/>'),
    joint("tool-mount", "fixed", "slider", "tool", "0.02 0 0.1", "0.2 0.1 -0.3"),
]

FLOATING_PARTS = [
    link("trunk", inertial(3.0, "0.01 -0.02 0.03", "0.2 0 0.1", (0.05, 0.07, 0.06, 0.002, 0, 0))),
    link("leg", inertial(0.4, "0 0 -0.1")),
    link("foot", inertial(0.1, "0 0 -0.05")),
    joint("hip", "revolute", "trunk", "leg", "0.1 0.05 0", "0 0.3 0", "0 1 0",
          '<limit lower="-3" upper="3" effort="10" velocity="5"/>'),
    joint("knee", "prismatic", "leg", "foot", "0 0 -0.2", "0 0 0", "0 0 1",
          '<limit lower="-1" upper="1" effort="10" velocity="5"/>'),
]


def urdf(parts, name="arm"):
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n' + "\n".join(parts) + "\n</robot>\n"


def write(tmp_path, text, name="robot.urdf") -> str:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return str(path)


def pinocchio_model(path, floating=False, mimic=False):
    """Pinocchio's model of the file (``mimic``: mimic joints follow, ``nq``/``nv`` shrink)."""
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer(), mimic=mimic) \
        if floating else pin.buildModelFromUrdf(str(path), mimic=mimic)
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    return model


def pinocchio_accelerations(model, data, q, v, tau):
    """``aba``; with mimic joints (which Pinocchio's ``aba`` refuses) ``M^-1 (tau - h)`` by
    its RNEA, ``M``'s columns ``rnea(q, 0, e_k) - rnea(q, 0, 0)``: Pinocchio 4.1's ``crba``
    with ``mimic=True`` is wrong where a joint moves below a mimic joint (its RNEA is not)."""
    if not len(model.mimicking_joints):
        return pin.aba(model, data, q, v, tau)
    zero = np.zeros(model.nv)
    rest = pin.rnea(model, data, q, zero, zero).copy()
    M = np.column_stack([pin.rnea(model, data, q, zero, e) - rest for e in np.eye(model.nv)])
    return np.linalg.solve(M, tau - pin.nonLinearEffects(model, data, q, v))


def pinocchio_q(model, q):
    """Our coordinates as Pinocchio's (a continuous joint is stored as cos, sin)."""
    out, k = [], 0
    for j in list(model.joints)[1:]:
        if j.nq == 2 and j.nv == 1:
            out += [np.cos(q[k]), np.sin(q[k])]
            k += 1
        else:
            out += list(q[k:k + j.nq])
            k += j.nq
    return np.array(out)


def random_state(rng, model, floating):
    n_joint = model.nv - (6 if floating else 0)
    q = rng.uniform(-np.pi, np.pi, n_joint)
    if floating:
        quat = rng.normal(size=4)
        q = np.concatenate([rng.uniform(-1, 1, 3), quat / np.linalg.norm(quat), q])
    return q, rng.uniform(-2, 2, model.nv), rng.uniform(-3, 3, n_joint)


def qdot_reference(model, q, v):
    """q' from Pinocchio's integrate, differentiated by a fourth-order stencil."""
    h = 1e-3
    f = [pin.integrate(model, q, v * s * h) for s in (2, 1, -1, -2)]
    return (-f[0] + 8 * f[1] - 8 * f[2] + f[3]) / (12 * h)


def compare(path, floating, backends, samples=5, seed=1, mimic=False):
    model = pinocchio_model(path, floating, mimic)
    data = model.createData()
    rng = np.random.default_rng(seed)
    nq = backends[0].layout.n_q
    for _ in range(samples):
        q, v, tau = random_state(rng, model, floating)
        qp = pinocchio_q(model, q) if not floating else q
        expected = pinocchio_accelerations(model, data, qp, v, np.concatenate(
            [np.zeros(6), tau]) if floating else tau)
        x = np.concatenate([q, v])
        for backend in backends:
            dxdt = backend.rhs(0.0, x, None, tau)
            scale = np.abs(expected).max()
            assert np.abs(dxdt[nq:] - expected).max() <= RTOL * scale, type(backend).__name__
            if floating:
                qd = qdot_reference(model, q, v)
                assert np.abs(dxdt[:nq] - qd).max() <= RTOL * max(1.0, np.abs(qd).max())
            else:
                np.testing.assert_array_equal(dxdt[:nq], v)


def robot_file(relative: str) -> str:
    """A URDF of example-robot-data (its wheel installs them under cmeel.prefix/share)."""
    roots = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    for root in roots:
        hits = glob.glob(os.path.join(root, "cmeel.prefix", "share", "example-robot-data",
                                      "robots", relative))
        if hits:
            return hits[0]
    pytest.skip(f"example-robot-data is not installed ({relative})")


def lower_symmetric(M):
    """The symmetric matrix whose upper triangle is ``M``'s (Pinocchio fills only that)."""
    return np.triu(M) + np.triu(M, 1).T


def coupling(model, follows):
    """``G``, ``o`` with ``q_full = G q + o`` for the independent ``model``'s joints."""
    names = list(model.names)[1:]
    own = [n for n in names if n not in follows]
    G, o = np.zeros((len(names), len(own))), np.zeros(len(names))
    for i, n in enumerate(names):
        leader, a, b = follows.get(n, (n, 1.0, 0.0))
        G[i, own.index(leader)], o[i] = a, b
    return G, o


def coupled_reference(model, data, G, o, damping, q, v, tau):
    """``u'``, ``du'/dq``, ``du'/du`` of the reduced model by hand: ``G^T (M a_f + h + D v_f)
    = tau`` with ``a_f = G a``; derivatives by the implicit function theorem on Pinocchio's
    RNEA derivatives."""
    qf, vf = G @ q + o, G @ v
    M = lower_symmetric(pin.crba(model, data, qf))
    Mr = G.T @ M @ G
    D = np.diag(damping)
    a = np.linalg.solve(Mr, tau - G.T @ (pin.nonLinearEffects(model, data, qf, vf) + D @ vf))
    dq, dv, _ = pin.computeRNEADerivatives(model, data, qf, vf, G @ a)
    return (a, -np.linalg.solve(Mr, G.T @ dq @ G),
            -np.linalg.solve(Mr, G.T @ (dv + D) @ G))
