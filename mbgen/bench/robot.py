"""``mbgen bench robot FILE``: one robot's RHS against Pinocchio's ``aba`` and MuJoCo's
``mj_forward``.

FILE is a ``.urdf`` file, an MJCF ``.xml`` file, or a robot of ``example-robot-data`` by
name (:data:`mbgen.bench.robot_peers.ROBOTS`: ``panda``, ``ur5``, ``solo12`` and ``g1``
on a floating base).  In one run, side by side:

mbgen (a child process, cold: a compile cache that holds only what it holds once per install)
    the generation stages of :func:`mbgen.pipeline.run` as ``mbgen.compile`` runs them
    (derive, bake, CSE, render, compile; the Jacobian too with ``jacobian=True``), the
    RHS in a C loop (:func:`mbgen.bench.timing.c_rhs_ns`) and ``model.rhs`` from Python.
    With ``jacobian=True`` also ``<prefix>_jacobian`` in a C loop twice: the model's source
    compiled with the driver's flags and with the flags of the user's module
    (:func:`mbgen.build.extension.model_flags`: -O2, or -O1 for a too long function), and
    ``model.jacobian`` from Python; its accelerations' rows mapped to the speeds' tangent
    space (:func:`mbgen.tangent_jacobian`: ``[du'/d delta, du'/du]``, ``n_u x 2 n_u``, a
    floating base's quaternion columns mapped) go to the parent.
Pinocchio (``pin``; URDF only)
    ``aba`` in a C++ loop over the model Pinocchio builds from the same file, and
    ``pin.aba`` from Python; with ``jacobian=True`` also ``computeABADerivatives`` (the same
    C++ loop, and from Python), its ``[ddq_dq, ddq_dv]`` compared with mbgen's tangent
    block.  An MJCF file is left out with a note: MuJoCo's ball and free
    joints are not Pinocchio's.
MuJoCo (``mujoco``)
    ``mj_forward`` (the whole forward pipeline, with contacts, limits, equality constraints,
    friction loss and actuation switched off, :data:`~mbgen.bench.robot_peers.SWITCHED_OFF`)
    in a C loop against the wheel's library, and ``mujoco.mj_forward`` from Python.  A URDF
    file is compiled by MuJoCo (a free joint on the root for a floating base).

The state is seeded and the same for every tool (mapped between their conventions:
Pinocchio's continuous joints as cosine and sine, MuJoCo's quaternion as w, x, y, z and
its free joint's linear velocity in world components).  The accelerations' largest
relative difference from mbgen's is reported per peer.  A peer that is not installed is
skipped with a note.
"""

from __future__ import annotations

import json
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from ..abi import Output
from ..build.extension import model_flags
from ..model.mjcf import compile_mjcf, from_mujoco, scene_values
from ..model.scene import Scene, urdf_scene
from ..pipeline import run
from ..runtime.linearize import tangent_jacobian
from . import children
from . import robot_peers as peers
from .timing import (
    DRIVER_FLAGS,
    c_function_ns,
    c_rhs_ns,
    median_ns,
    per_call_ns,
    pipeline_timer,
    run_driver,
    staged,
)

STAGES = ("derive_s", "bake_s", "cse_s", "render_s", "compile_s")
#: What the child measures of the Jacobian (``jacobian=True``).
JAC_KEYS = ("jac_c_ns", "jac_own_ns", "jac_py_ns", "tan_own_ns", "tan_py_ns", "jac_tangent")
#: The derivative outputs a ``jacobian=True`` run compiles: ``df/dx`` and the tangent-space block.
JAC_OUTPUTS = (Output.RHS, Output.JACOBIAN, Output.TANGENT_JACOBIAN)


@dataclass
class RobotReport:
    """Everything one run measured; None where not measured, ``notes`` says why."""

    robot: str
    floating: bool
    n_q: int = 0
    n_u: int = 0
    outputs: str = "rhs"
    stages: dict = field(default_factory=dict)
    ops_after: int | None = None
    rhs_c_ns: float | None = None
    rhs_py_ns: float | None = None
    pin_cxx_ns: float | None = None
    pin_py_ns: float | None = None
    mj_c_ns: float | None = None
    mj_py_ns: float | None = None
    diff_pin: float | None = None
    diff_mj: float | None = None
    jac_c_ns: float | None = None
    jac_own_ns: float | None = None
    jac_py_ns: float | None = None
    tan_own_ns: float | None = None
    tan_py_ns: float | None = None
    pin_daba_cxx_ns: float | None = None
    pin_daba_py_ns: float | None = None
    diff_pin_jac: float | None = None
    status: str = "not run"
    notes: list = field(default_factory=list)


def _scene(file: Path, floating: bool, jacobian: bool) -> Scene:
    outputs = JAC_OUTPUTS if jacobian else (Output.RHS,)
    if file.suffix.lower() == ".urdf":
        scene = urdf_scene(file, floating=floating)
    else:
        mj = compile_mjcf(file)
        model = from_mujoco(mj)
        parameters, initial = scene_values(mj)
        scene = Scene(name=model.name, model=model, parameters=parameters,
                      initial_state=initial, t_span=(0.0, 1.0), outputs=outputs)
    return replace(scene, outputs=outputs)


def random_state(layout, floating: bool, mjcf_mj=None, seed: int = 7):
    """A seeded ``(x, r)`` in mbgen's layout (unit quaternions, joints in [-1, 1])."""
    rng = np.random.default_rng(seed)
    names = list(layout.state_names)
    x = np.concatenate([rng.uniform(-1, 1, layout.n_q), rng.uniform(-1, 1, layout.n_u)])
    if mjcf_mj is not None:
        mujoco = peers.import_mujoco()
        for j in range(mjcf_mj.njnt):
            kind, a = int(mjcf_mj.jnt_type[j]), int(mjcf_mj.jnt_qposadr[j])
            if kind in (int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)):
                s = a if kind == int(mujoco.mjtJoint.mjJNT_BALL) else a + 3
                x[s:s + 4] /= np.linalg.norm(x[s:s + 4])
    elif floating:
        i = names.index("root_qx")
        x[i:i + 4] /= np.linalg.norm(x[i:i + 4])
    return x, rng.uniform(-1, 1, layout.n_r)


# ----------------------------------------------------------------------------- mbgen (child)
def _mbgen_child(file: str, floating: bool, jacobian: bool, repeats: int, emit) -> None:
    stage = staged(emit)

    path = Path(file)
    scene = stage("read_s", _scene, path, floating, jacobian)
    result = run(scene, timer=pipeline_timer(emit, counts={"ops_after": "ops_after"}))
    emit("ops_after", result.kernel.ops_after)   # the kept one's, where both were compared
    rendered, model = result.rendered, result.compiled
    layout = rendered.layout
    mj = compile_mjcf(path) if path.suffix.lower() != ".urdf" else None
    x, r = random_state(layout, floating, mj)
    p = np.array([rendered.defaults[k] for k in layout.parameter_names])
    emit("layout", [list(layout.state_names), layout.n_q, layout.n_u, list(layout.input_names)])
    emit("x", x.tolist())
    emit("r", r.tolist())
    emit("dxdt", model.rhs(0.0, x, p, r).tolist())
    with tempfile.TemporaryDirectory(prefix="mbgen-robot-driver-") as tmp:
        emit("rhs_c_ns", c_rhs_ns(rendered, x, p, r, repeats, Path(tmp)))
    emit("rhs_py_ns", per_call_ns(lambda: model.rhs(0.0, x, p, r), repeats))
    if jacobian:
        _jacobian_child(rendered, model, x, p, r, repeats, emit)


def _jacobian_child(rendered, model, x, p, r, repeats: int, emit) -> None:
    """The Jacobian's C loops (driver flags, the module's flags), its Python call, and the
    generated tangent-space block ``[du'/d delta, du'/du]`` (``tangent_jacobian``: its C loop
    with the module's flags, its Python call, its value)."""
    L = rendered.layout
    own = model_flags(rendered)
    for key, name, size, flags in (("jac_c_ns", "jacobian", L.n_x ** 2, None),
                                   ("jac_own_ns", "jacobian", L.n_x ** 2, own),
                                   ("tan_own_ns", "tangent_jacobian", 2 * L.n_u ** 2, own)):
        with tempfile.TemporaryDirectory(prefix="mbgen-robot-jac-") as tmp:
            emit(key, c_function_ns(rendered, name, size, x, p, r, repeats, Path(tmp),
                                    model_flags=flags))
    emit("jac_py_ns", per_call_ns(lambda: model.jacobian(0.0, x, p, r), repeats))
    emit("tan_py_ns", per_call_ns(lambda: model.tangent_jacobian(0.0, x, p, r), repeats))
    emit("jac_tangent", np.hstack(tangent_jacobian(model, x, p, r)).tolist())


def _child_main(argv) -> int:
    """``python -m mbgen.bench.robot FILE FLOATING JACOBIAN REPEATS``: JSON lines."""
    def emit(key, value):
        print(json.dumps({key: value}), flush=True)

    with threadpool_limits(limits=1):
        _mbgen_child(argv[0], argv[1] == "1", argv[2] == "1", int(argv[3]), emit)
    return 0


# ----------------------------------------------------------------------------- the peers
def _quat_matrix(qx, qy, qz, qw) -> np.ndarray:
    n = qx * qx + qy * qy + qz * qz + qw * qw
    return np.array([
        [qw * qw + qx * qx - qy * qy - qz * qz, 2 * (qx * qy - qw * qz), 2 * (qx * qz + qw * qy)],
        [2 * (qx * qy + qw * qz), qw * qw - qx * qx + qy * qy - qz * qz, 2 * (qy * qz - qw * qx)],
        [2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx), qw * qw - qx * qx - qy * qy + qz * qz],
    ]) / n


def _pinocchio(report, clean, floating, x, r, accel, repeats, cxx, say, tangent=None) -> None:
    try:
        pin = peers.import_pinocchio()
    except Exception as exc:       # noqa: BLE001 -- a missing peer is a note
        report.notes.append(f"Pinocchio skipped: {exc}")
        return
    model = pin.buildModelFromUrdf(str(clean), pin.JointModelFreeFlyer()) if floating else \
        pin.buildModelFromUrdf(str(clean))
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    n_q = report.n_q
    q, v, out, k = x[:n_q], x[n_q:], [], 0
    for j in list(model.joints)[1:]:
        if j.nq == 2 and j.nv == 1:
            out += [np.cos(q[k]), np.sin(q[k])]
            k += 1
        else:
            out += list(q[k:k + j.nq])
            k += j.nq
    qp = np.array(out)
    tau = np.concatenate([np.zeros(6), r]) if floating else r
    data = model.createData()
    ddq = np.array(pin.aba(model, data, qp, v, tau))
    report.diff_pin = float(np.abs(ddq - accel).max() / np.abs(ddq).max())
    report.pin_py_ns = per_call_ns(lambda: pin.aba(model, data, qp, v, tau), repeats)
    theirs = None
    if tangent is not None:
        def derivatives():
            pin.computeABADerivatives(model, data, qp, v, tau)
        derivatives()
        theirs = np.hstack([np.array(data.ddq_dq), np.array(data.ddq_dv)])
        report.diff_pin_jac = float(np.abs(tangent - theirs).max() / np.abs(theirs).max())
        report.pin_daba_py_ns = per_call_ns(derivatives, repeats)
    if cxx:
        try:
            with tempfile.TemporaryDirectory(prefix="mbgen-robot-aba-") as tmp:
                say("compiling Pinocchio's C++ loop")
                exe = peers.build_aba_driver(Path(tmp), repeats)
                report.pin_cxx_ns, ddq_cxx = peers.run_aba_driver(exe, model, Path(tmp), qp, v,
                                                                   tau)
                if theirs is not None:
                    report.pin_daba_cxx_ns, cxx_block = run_aba_derivatives_driver(
                        exe, model, Path(tmp), qp, v, tau)
                    if not np.allclose(cxx_block, theirs, rtol=1e-9, atol=1e-9):
                        report.notes.append("Pinocchio's C++ computeABADerivatives and "
                                            "pin.computeABADerivatives disagree")
            if not np.allclose(ddq_cxx, ddq, rtol=1e-9, atol=1e-9):
                report.notes.append("Pinocchio's C++ loop and pin.aba disagree")
        except Exception as exc:   # noqa: BLE001
            report.notes.append(f"Pinocchio's C++ loop skipped: {exc}"[:300])


def run_aba_derivatives_driver(exe: Path, model, folder: Path, q, v, tau
                               ) -> tuple[float, np.ndarray]:
    """``(median ns per computeABADerivatives call, [ddq_dq, ddq_dv])`` (``n_v x 2 n_v``)
    from the C++ loop of :func:`mbgen.bench.robot_peers.build_aba_driver`, run with the
    argument ``derivatives`` on the model :func:`~mbgen.bench.robot_peers.run_aba_driver`
    saved in ``folder``."""
    text = "\n".join(" ".join(repr(float(x)) for x in row)
                     for row in (model.gravity.linear, q, v, tau)) + "\n"
    out = run_driver([str(exe), str(Path(folder) / "model.bin"), "derivatives"],
                     "Pinocchio's C++ computeABADerivatives loop", text)
    n = len(v)

    def values(key):
        line = next(s for s in out.splitlines() if s.startswith(key + " "))
        return np.array([float(x) for x in line.split()[1:]]).reshape(n, n)
    return median_ns(out), np.hstack([values("ddq_dq"), values("ddq_dv")])


def _mujoco_state(mj, names, x, r, floating, urdf: bool):
    """MuJoCo's ``(qpos, qvel, qfrc_applied)`` of mbgen's state, and the map back of qacc.
    An MJCF model's inputs are ``qfrc_applied`` then the actuators' ``ctrl``
    (:mod:`mbgen.model.mjcf`); the ``ctrl`` part is set by the caller."""
    if not urdf:
        n_q = mj.nq
        return x[:n_q], x[n_q:], r[:mj.nv], lambda qacc, x=x: qacc
    mujoco = peers.import_mujoco()
    from ..model.urdf import identifier
    index = {n: i for i, n in enumerate(names)}
    n_q = len(names) // 2 + (1 if floating else 0)
    qpos, qvel, qfrc = np.zeros(mj.nq), np.zeros(mj.nv), np.zeros(mj.nv)
    joint_rows = []
    inputs = {n: i for i, n in enumerate(names[n_q:])}
    for j in range(mj.njnt):
        a, dof = int(mj.jnt_qposadr[j]), int(mj.jnt_dofadr[j])
        if int(mj.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE):
            px, py, pz, qx, qy, qz, qw = x[:7]
            R = _quat_matrix(qx, qy, qz, qw)
            qpos[a:a + 7] = [px, py, pz, qw, qx, qy, qz]
            qvel[dof:dof + 3] = R @ x[n_q:n_q + 3]
            qvel[dof + 3:dof + 6] = x[n_q + 3:n_q + 6]
            continue
        name = identifier(mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_JOINT, j))
        i = index[f"q_{name}"]
        qpos[a], qvel[dof] = x[i], x[n_q + inputs[f"u_{name}"]]
        qfrc[dof] = r[inputs[f"u_{name}"] - (6 if floating else 0)]
        joint_rows.append((dof, inputs[f"u_{name}"]))

    def back(qacc):
        """qacc in mbgen's speed order (a free joint's linear part in root components)."""
        out = np.zeros(len(names) - n_q)
        for dof, k in joint_rows:
            out[k] = qacc[dof]
        if floating:
            qx, qy, qz, qw = x[3:7]
            R = _quat_matrix(qx, qy, qz, qw)
            v, w = x[n_q:n_q + 3], x[n_q + 3:n_q + 6]
            out[:3] = R.T @ qacc[:3] - np.cross(w, v)
            out[3:6] = qacc[3:6]
        return out
    return qpos, qvel, qfrc, back


def _mujoco(report, file, clean, floating, names, x, r, accel, repeats, say) -> None:
    mujoco = peers.import_mujoco()
    if mujoco is None:
        report.notes.append("MuJoCo skipped: not installed (pip install 'mbgen[mujoco]')")
        return
    urdf = file.suffix.lower() == ".urdf"
    mj = peers.mujoco_of_urdf(clean, floating) if urdf else compile_mjcf(file)
    peers.switch_off(mj, actuation=not urdf)      # an MJCF file's actuators are read
    qpos, qvel, qfrc, back = _mujoco_state(mj, names, x, r, floating, urdf)
    data = mujoco.MjData(mj)
    data.qpos[:], data.qvel[:], data.qfrc_applied[:] = qpos, qvel, qfrc
    if not urdf:
        data.ctrl[:] = r[mj.nv:mj.nv + mj.nu]

    def forward():
        mujoco.mj_forward(mj, data)
    forward()
    theirs = back(np.array(data.qacc))
    report.diff_mj = float(np.abs(theirs - accel).max() / np.abs(accel).max())
    report.mj_py_ns = per_call_ns(forward, repeats)
    try:
        with tempfile.TemporaryDirectory(prefix="mbgen-robot-mj-") as tmp:
            say("compiling MuJoCo's C loop")
            exe = peers.build_mj_driver(Path(tmp), repeats)
            mjb = Path(tmp) / "robot.mjb"
            mujoco.mj_saveModel(mj, str(mjb), None)
            report.mj_c_ns, qacc = peers.run_mj_driver(exe, mjb, qpos, qvel, qfrc)
    except Exception as exc:       # noqa: BLE001
        report.notes.append(f"MuJoCo's C loop skipped (timed from Python only): {exc}"[:300])


# ----------------------------------------------------------------------------- the benchmark
def robot_bench(what: str, *, floating: bool | None = None, jacobian: bool = False,
                repeats: int = 7, budget_s: float = 600.0, memory_gb: float = 12.0,
                pinocchio: bool = True, cxx: bool = True, mujoco: bool = True,
                progress: Callable[[str], None] | None = None) -> RobotReport:
    """Run the benchmark on one robot (module docstring); ``floating`` None: the named
    robot's own, else fixed."""
    say = progress or (lambda message: None)
    file, default = peers.robot_file(what)
    floating = bool(default) if floating is None else floating
    report = RobotReport(robot=what, floating=floating,
                         outputs=", ".join(o.value for o in JAC_OUTPUTS) if jacobian else "rhs")
    with tempfile.TemporaryDirectory(prefix="mbgen-robot-") as tmp:
        urdf = file.suffix.lower() == ".urdf"
        clean = peers.clean_urdf(file, Path(tmp)) if urdf else file
        say(f"{what}: mbgen (cold, in a child process)")
        res, rc, error = children.run_json_child(
            ["-m", "mbgen.bench.robot", str(clean), "1" if floating else "0",
             "1" if jacobian else "0", str(repeats)], budget_s=budget_s, memory_gb=memory_gb,
            prefix="mbgen-robot-child-", seeded=True)
        report.status = children.status(
            res, ["read_s", *STAGES, "rhs_c_ns", "rhs_py_ns", *(JAC_KEYS if jacobian else ())],
            rc, error, budget_s)
        report.stages = {k: res[k] for k in ("read_s", *STAGES) if k in res}
        report.ops_after = res.get("ops_after")
        report.rhs_c_ns, report.rhs_py_ns = res.get("rhs_c_ns"), res.get("rhs_py_ns")
        report.jac_c_ns, report.jac_own_ns = res.get("jac_c_ns"), res.get("jac_own_ns")
        report.jac_py_ns = res.get("jac_py_ns")
        report.tan_own_ns, report.tan_py_ns = res.get("tan_own_ns"), res.get("tan_py_ns")
        tangent = np.array(res["jac_tangent"]) if "jac_tangent" in res else None
        if "dxdt" not in res:
            return report
        names, report.n_q, report.n_u, _ = res["layout"]
        x, r = np.array(res["x"]), np.array(res["r"])
        accel = np.array(res["dxdt"])[report.n_q:]
        if pinocchio and urdf:
            say(f"{what}: Pinocchio")
            _pinocchio(report, clean, floating, x, r, accel, repeats, cxx, say, tangent)
        elif pinocchio:
            report.notes.append("Pinocchio skipped: an MJCF file's ball and free joints are not "
                                "Pinocchio's; compare a URDF file")
        if mujoco:
            say(f"{what}: MuJoCo")
            _mujoco(report, file, clean, floating, names, x, r, accel, repeats, say)
    return report


def _f(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def format_robot(rep: RobotReport) -> str:
    """The side-by-side table, the generation stages, the agreement and the notes."""
    def ratio(a, b):
        return "-" if a is None or b is None else f"{a / b:.2f}"

    rows = [("mbgen RHS", rep.rhs_c_ns, rep.rhs_py_ns),
            ("Pinocchio aba", rep.pin_cxx_ns, rep.pin_py_ns),
            ("MuJoCo mj_forward", rep.mj_c_ns, rep.mj_py_ns)]
    lines = [f"robot {rep.robot}: {rep.n_q} coordinates, {rep.n_u} speeds"
             f"{', floating base' if rep.floating else ''}; mbgen {rep.status}",
             "", f"{'ns per call':20s} {'in C/C++':>10s} {'from Python':>12s} "
                 f"{'C: /mbgen':>10s} {'py: /mbgen':>11s}"]
    for name, c, py in rows:
        lines.append(f"{name:20s} {_f(c, '.0f'):>10s} {_f(py, '.0f'):>12s} "
                     f"{ratio(c, rep.rhs_c_ns):>10s} {ratio(py, rep.rhs_py_ns):>11s}")
    total = sum(rep.stages.get(k, 0.0) for k in ("read_s", *STAGES))
    lines += ["", f"generation, cold ({rep.outputs}): " + ", ".join(
        f"{k.removesuffix('_s')} {v:.2f} s" for k, v in rep.stages.items())
        + f"; total {total:.2f} s; {_f(rep.ops_after, 'd')} operations after CSE",
        f"accelerations, largest relative difference from mbgen's: Pinocchio "
        f"{_f(rep.diff_pin, '.1e')}, MuJoCo {_f(rep.diff_mj, '.1e')}",
        "", "MuJoCo: mj_forward, the whole forward pipeline, with contacts, limits, equality "
            "constraints, friction loss and actuation off.",
        f"Driver flags: {' '.join(DRIVER_FLAGS)}; medians of {MIN_REPEATS_TEXT}."]
    if rep.jac_c_ns is not None or rep.pin_daba_py_ns is not None:
        lines += _jacobian_lines(rep)
    lines += [f"note: {n}" for n in rep.notes]
    return "\n".join(lines)


def _jacobian_lines(rep: RobotReport) -> list[str]:
    """The derivatives' table: mbgen's Jacobian (driver flags, the module's flags) against
    ``computeABADerivatives``; the ratio column is each row's C time over mbgen's with the
    module's flags."""
    def ratio(a, b):
        return "-" if a is None or b is None else f"{a / b:.2f}"

    rows = [("mbgen jacobian", rep.jac_c_ns, rep.jac_py_ns),
            ("  module's flags", rep.jac_own_ns, None),
            ("mbgen tangent", rep.tan_own_ns, rep.tan_py_ns),
            ("Pinocchio dABA", rep.pin_daba_cxx_ns, rep.pin_daba_py_ns)]
    lines = ["", f"{'derivatives, ns':20s} {'in C/C++':>10s} {'from Python':>12s} "
                 f"{'C: /module':>10s} {'C: /dABA':>9s}"]
    for name, c, py in rows:
        lines.append(f"{name:20s} {_f(c, '.0f'):>10s} {_f(py, '.0f'):>12s} "
                     f"{ratio(c, rep.jac_own_ns):>10s} {ratio(c, rep.pin_daba_cxx_ns):>9s}")
    return lines + [
        f"Jacobian [du'/d delta, du'/du] in the speeds' tangent space (the tangent_jacobian "
        f"output),"
        f" largest relative difference from Pinocchio's computeABADerivatives: "
        f"{_f(rep.diff_pin_jac, '.1e')}",
        "mbgen jacobian: df/dx (n_x x n_x, quaternion columns included) timed in a C loop, "
        "its source compiled with the driver flags; module's flags: as the user's module "
        "is built (mbgen.build.extension.model_flags); mbgen tangent: the tangent_jacobian "
        "output (n_u x 2 n_u, Pinocchio's [ddq_dq, ddq_dv]) with the module's flags; dABA: "
        "computeABADerivatives."]


MIN_REPEATS_TEXT = "loops of at least 20 ms each"


if __name__ == "__main__":  # the child process
    sys.exit(_child_main(sys.argv[1:]))
