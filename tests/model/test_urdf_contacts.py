"""``from_urdf(..., contacts=...)`` against Pinocchio's contact dynamics.

Each named link's origin is a rigid 3D point contact; the reference is
``pin.constraintDynamics`` with ``RigidConstraintModel(CONTACT_3D, model, joint, placement,
LOCAL_WORLD_ALIGNED)`` at the link's frame (a frame merged away by a fixed joint included):
the accelerations u' and the contact forces lambda at 1e-9, and
``computeConstraintDynamicsDerivatives`` (``ddq_dq``, ``ddq_dv``, ``dlambda_dq``,
``dlambda_dv`` in Pinocchio's tangent space, from the ``contact_jacobian`` output as
:func:`mbgen.tangent_jacobian` maps a quaternion).  A hopper runs by default, with the
Baumgarte gains and anchors set; Solo-12 on four feet and on two, and the biped Bolt, are
``slow``.
"""

from __future__ import annotations

import numpy as np
import pytest

import mbgen
from mbgen.errors import ArgumentTypeError, UrdfStructureError
from urdf_models import (
    FLOATING_PARTS,
    RTOL,
    joint,
    link,
    pinocchio_model,
    random_state,
    robot_file,
    urdf,
    write,
)

pin = pytest.importorskip("pinocchio")

#: the hopper with a toe fixed to its foot, off its origin and turned
TOE_PARTS = FLOATING_PARTS + [link("toe"), joint("toe_mount", "fixed", "foot", "toe",
                                                  "0.03 -0.02 -0.06", "0.3 0.2 -0.1")]


def pinocchio_contacts(model, frames, gains=(0.0, 0.0), anchors=None):
    """Pinocchio's contact models (and datas) at ``frames``, initialised."""
    data = model.createData()
    models, datas = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for i, name in enumerate(frames):
        frame = model.frames[model.getFrameId(name)]
        cm = pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, model, frame.parentJoint,
                                      frame.placement, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        cm.m_baumgarte_parameters.Kp, cm.m_baumgarte_parameters.Kd = gains
        if anchors is not None:
            cm.joint2_placement = pin.SE3(np.eye(3), np.asarray(anchors[i], dtype=float))
        models.append(cm)
        datas.append(cm.createData())
    pin.initConstraintDynamics(model, data, models, datas)
    return data, models, datas


def compare(path, frames, compiled, samples=3, gains=(0.0, 0.0), anchors=None, seed=0):
    """u', lambda and their derivatives (when compiled) against Pinocchio at random states."""
    model = pinocchio_model(path, True)
    data, models, datas = pinocchio_contacts(model, frames, gains, anchors)
    p = np.array([9.81, *gains, *np.ravel(anchors if anchors is not None
                                            else np.zeros((len(frames), 3)))])
    nq, nx = model.nq, model.nq + model.nv
    rng = np.random.default_rng(seed)
    for _ in range(samples):
        q, v, tau = random_state(rng, model, True)
        ddq = pin.constraintDynamics(model, data, q, v, np.concatenate([np.zeros(6), tau]),
                                     models, datas)
        lam = data.lambda_c.copy()
        x = np.concatenate([q, v])
        for ours, theirs in ((compiled.rhs(0, x, p, tau)[nq:], ddq),
                             (compiled.constraint_forces(0, x, p, tau), lam)):
            assert np.abs(ours - theirs).max() <= RTOL * np.abs(theirs).max()
        if mbgen.Output.CONTACT_JACOBIAN not in compiled.outputs:
            continue
        theirs = pin.computeConstraintDynamicsDerivatives(model, data, models, datas)
        Jc = compiled.contact_jacobian(0, x, p, tau)
        G = Jc[:nq, nq:nx]
        ours = (Jc[nq:nx, :nq] @ G, Jc[nq:nx, nq:nx], Jc[nx:, :nq] @ G, Jc[nx:, nq:nx])
        for a, b in zip(ours, (theirs[0], theirs[1], theirs[3], theirs[4])):
            assert np.abs(a - b).max() <= RTOL * np.abs(b).max()


@pytest.fixture(scope="module")
def hopper(tmp_path_factory):
    path = write(tmp_path_factory.mktemp("urdf"), urdf(TOE_PARTS, "hopper"))
    model = mbgen.from_urdf(path, floating=True, contacts=["toe"])
    res = mbgen.run(model, ("rhs", "constraint_forces", "contact_jacobian"), build=False)
    return path, mbgen.python_model(res.rendered)   # the C: the robots below (slow)


def test_a_toe_merged_by_a_fixed_joint_matches_pinocchios_contact_dynamics(hopper):
    path, compiled = hopper
    assert compiled.parameter_names == ("g", "contact_kp", "contact_kd", "toe_x0", "toe_y0",
                                        "toe_z0")
    assert compiled.constraint_names == ("toe.x", "toe.y", "toe.z")
    compare(path, ["toe"], compiled)


def test_baumgarte_gains_and_anchor_are_pinocchios_corrector(hopper):
    path, compiled = hopper
    compare(path, ["toe"], compiled, samples=2, gains=(7.0, 3.0), anchors=[[0.1, -0.2, 0.3]],
            seed=1)


def test_the_comparison_has_teeth(hopper):
    """Pinocchio holding the foot's origin rather than the toe disagrees."""
    path, compiled = hopper
    with pytest.raises(AssertionError):
        compare(path, ["foot"], compiled, samples=1)


def test_a_contact_that_is_no_link_is_refused_by_name(tmp_path):
    path = write(tmp_path, urdf(TOE_PARTS, "hopper"))
    with pytest.raises(UrdfStructureError, match="no link 'tow'.*'toe'"):
        mbgen.from_urdf(path, floating=True, contacts=["tow"])
    with pytest.raises(ArgumentTypeError, match="contacts must be link or frame names"):
        mbgen.from_urdf(path, floating=True, contacts=[3])
    with pytest.raises(ArgumentTypeError, match="twice"):
        mbgen.from_urdf(path, floating=True, contacts=("toe", "toe"))


FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")


@pytest.mark.slow
@pytest.mark.parametrize("robot, frames", [
    ("solo_description/robots/solo12.urdf", FEET),
    ("solo_description/robots/solo12.urdf", ("FL_FOOT", "HR_FOOT")),
    ("bolt_description/robots/bolt.urdf", ("FL_FOOT", "FR_FOOT")),
], ids=["solo12-four-feet", "solo12-two-feet", "bolt-biped"])
def test_legged_robots_match_pinocchios_contact_dynamics_and_derivatives(robot, frames):
    path = robot_file(robot)
    model = mbgen.from_urdf(path, floating=True, contacts=frames)
    compiled = mbgen.compile(model, outputs=("rhs", "constraint_forces", "contact_jacobian"))
    compare(path, frames, compiled, samples=4)
