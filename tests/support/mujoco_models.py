"""MuJoCo models compared with ``mj_forward``: the helpers of tests/model/test_mjcf*.py
(MuJoCo's switches for what mbgen does not model, random ``qpos`` and ``ctrl``, and the
comparison of a back end's RHS with ``qacc``)."""

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco", reason="MuJoCo is in the test extra")

RTOL = 1e-9


OFF = ("mjDSBL_CONTACT", "mjDSBL_LIMIT", "mjDSBL_EQUALITY", "mjDSBL_FRICTIONLOSS")


def switch_off(mj) -> None:
    """What mbgen does not model, off in MuJoCo (springs, dampers and actuators stay on;
    mbgen never clamps an actuator's force, so neither does MuJoCo here)."""
    for flag in OFF:
        mj.opt.disableflags |= int(getattr(mujoco.mjtDisableBit, flag))
    mj.actuator_forcelimited[:] = 0


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


def random_ctrl(rng, mj) -> np.ndarray:
    """MuJoCo's ``ctrl``: inside ``ctrlrange`` where MuJoCo clamps it (mbgen does not)."""
    lo, hi = np.asarray(mj.actuator_ctrlrange, dtype=float).reshape(-1, 2).T
    return np.where(mj.actuator_ctrllimited, lo + (hi - lo) * rng.uniform(0, 1, mj.nu),
                    rng.uniform(-2, 2, mj.nu))


def compare(mj, backends, samples=5, seed=3) -> float:
    """Largest relative difference of u' from mj_forward's qacc (and q' from integratePos),
    with random ``qfrc_applied`` and ``ctrl`` (every actuator read: inputs ``(tau, ctrl)``)."""
    switch_off(mj)
    data = mujoco.MjData(mj)
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(samples):
        qpos = random_qpos(rng, mj)
        qvel, tau = rng.uniform(-2, 2, mj.nv), rng.uniform(-3, 3, mj.nv)
        ctrl = random_ctrl(rng, mj)
        data.qpos[:], data.qvel[:], data.qfrc_applied[:] = qpos, qvel, tau
        data.ctrl[:] = ctrl
        mujoco.mj_forward(mj, data)
        h = 1e-4
        steps = []
        for s in (2, 1, -1, -2):
            q = qpos.copy()
            mujoco.mj_integratePos(mj, q, qvel, s * h)
            steps.append(q)
        qdot = (-steps[0] + 8 * steps[1] - 8 * steps[2] + steps[3]) / (12 * h)
        for backend in backends:
            dxdt = backend.rhs(0.0, np.concatenate([qpos, qvel]), None,
                               np.concatenate([tau, ctrl]))
            err = np.abs(dxdt[mj.nq:] - data.qacc).max() / np.abs(data.qacc).max()
            assert err <= RTOL, (type(backend).__name__, err)
            assert np.abs(dxdt[:mj.nq] - qdot).max() <= 1e-9 * max(1, np.abs(qdot).max())
            worst = max(worst, err)
    return worst
